# MotionKit: `make demo` sets up and runs the headless demo; `make test` runs
# every test on the three Blenders (3.4 on the host, 4.3 and 5.2 in chroots).
# See README.md.
SHELL := /bin/bash
.SHELLFLAGS := -euo pipefail -c
# Blender finds its Python's standard library through the first python3.X on
# PATH: keep pyenv or a virtualenv out of it.
export PATH := /usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin
export MOTIONKIT_WERROR ?= ON

VERSION := $(shell sed -n 's/^project.motionkit VERSION \([0-9.]*\).*/\1/p' CMakeLists.txt)
BLENDERS := 3.4 4.3 5.2
ZIP_3.4 := dist/motionkit-$(VERSION)-linux-x64-py311.zip
ZIP_4.3 := dist/motionkit-$(VERSION)-linux-x64-py313.zip
ZIP_5.2 := dist/motionkit-$(VERSION)-linux-x64-py314.zip
# Where each Blender's commands run (3.4: on the host) and its build folder.
IN_3.4 :=
IN_4.3 := tools/chroot.sh trixie run
IN_5.2 := tools/chroot.sh sid run
BUILD_3.4 := build/py311
BUILD_4.3 := build/py313
BUILD_5.2 := build/py314
BLENDER_ARGS := --background --factory-startup --python-exit-code 1
BENCHES := fcurve_write bvh_import resample retarget plant_feet control_rig ik ik_live

.PHONY: demo test test-tiers deps deps-4.3 deps-5.2 build-3.4 build-4.3 build-5.2 test-native test-python \
        test-fuzz test-blender test-demo test-long bench clean \
        $(addprefix test-native-,$(BLENDERS)) $(addprefix test-blender-,$(BLENDERS)) $(addprefix test-long-,$(BLENDERS)) test-long-python

demo: deps build-3.4
	tools/with_blender.sh 3.4 $(BLENDER_ARGS) --python demo/demo.py -- --zip $(ZIP_3.4) --out out
	@echo "Demo output: out/demo.blend and out/demo.png"

# The tiers run two at a time, one per core: the Blender suites are mostly one Python thread each, so two
# of them (or a suite beside a build) keep both cores busy. Each tier's output is printed whole when it ends
# (--output-sync), its time is written to build/tiers.txt (tools/timed.sh), and the table closes the run.
TEST_JOBS ?= 2
test: deps
	@mkdir -p build && rm -f build/tiers.txt
	$(MAKE) --no-print-directory -j$(TEST_JOBS) --output-sync=target test-tiers
	@sort -t$$'\t' -k2 -rn build/tiers.txt | awk -F'\t' '{printf "  %-18s %5d s\n", $$1, $$2}'
	@echo "make test: everything passed on Blender 3.4, 4.3 and 5.2"

# The Blender suites first: they are the longest, so they start as soon as their build is done.
test-tiers: test-blender test-native test-python test-demo test-fuzz

# The README's other command, the demo, run whole into a scratch folder.
test-demo: build-3.4
	tools/timed.sh $@ tools/test_demo.sh $(ZIP_3.4)

deps:
	tools/install_deps.sh

deps-4.3: deps
	tools/chroot.sh trixie setup
deps-5.2: deps
	tools/chroot.sh sid setup
build-3.4: deps
build-4.3: deps-4.3
build-5.2: deps-5.2

# Each build also compiles the native tests and benchmarks with that Blender's toolchain
# (g++ 12 on the host, g++ 14 in trixie, g++ 16 in sid).
$(addprefix build-,$(BLENDERS)): build-%:
	tools/timed.sh $@ $(IN_$*) python3 build_addon.py --blender /usr/bin/blender --all

test-native: $(addprefix test-native-,$(BLENDERS))
$(addprefix test-native-,$(BLENDERS)): test-native-%: build-%
	tools/timed.sh $@ $(IN_$*) ctest --test-dir $(BUILD_$*) --output-on-failure --no-tests=error

# Twice: as numpy runs on this processor, then with its SIMD kernels above SSE and AVX off (AVX2, FMA3,
# AVX-512: tools/simd_baseline.py), so that a bound set on one processor's last digits fails on any machine.
test-python: build-3.4
	tools/timed.sh $@ python3 -m pytest -p no:cacheprovider -q -rs tests/python
	NPY_DISABLE_CPU_FEATURES="$$(python3 tools/simd_baseline.py)" \
	  tools/timed.sh test-python-simd python3 -m pytest -p no:cacheprovider -q -rs tests/python \
	  --ignore=tests/python/test_ik_rates.py  # random IK problems: the native solver, no numpy kernel

# A bounded libFuzzer run of the BVH reader under ASan and UBSan (clang).
test-fuzz: deps
	tools/timed.sh $@ tools/fuzz_bvh.sh 30

test-blender: $(addprefix test-blender-,$(BLENDERS))
# Every build before any Blender suite: each suite checks the other Blenders' zips (test_install).
$(addprefix test-blender-,$(BLENDERS)): test-blender-%: $(addprefix build-,$(BLENDERS))
	tools/timed.sh $@ tools/with_blender.sh $* $(BLENDER_ARGS) --python tests/blender/run_in_blender.py -- $(ZIP_$*)

# What takes minutes and adds no coverage the tiers above lack (every clip of a loop the tests keep one case
# of): not run by `make test` or CI. Same Blenders, tests/long.
test-long: $(addprefix test-long-,$(BLENDERS)) test-long-python
test-long-python: build-3.4
	MOTIONKIT_LONG=1 tools/timed.sh $@ python3 -m pytest -p no:cacheprovider -q -rs tests/python/test_ik_rates.py
$(addprefix test-long-,$(BLENDERS)): test-long-%: build-%
	tools/timed.sh $@ tools/with_blender.sh $* $(BLENDER_ARGS) --python tests/blender/run_in_blender.py -- \
	  $(ZIP_$*) --long

# Benchmarks are not tests: run them by hand and record the figures in docs/benchmarks.md.
# The native ones on each toolchain, then each end-to-end script on each Blender.
bench: $(addprefix build-,$(BLENDERS))
	$(foreach v,$(BLENDERS),$(IN_$(v)) $(BUILD_$(v))/motionkit_bench && ) true
	$(foreach b,$(BENCHES),$(foreach v,$(BLENDERS),\
	  tools/with_blender.sh $(v) $(BLENDER_ARGS) --python bench/$(b).py -- --zip $(ZIP_$(v)) && )) true

clean:
	rm -rf build dist out
