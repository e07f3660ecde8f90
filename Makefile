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

.PHONY: demo test deps deps-4.3 deps-5.2 build-3.4 build-4.3 build-5.2 test-native test-python test-fuzz \
        test-blender test-blender-3.4 test-blender-4.3 test-blender-5.2 test-demo bench clean

demo: deps build-3.4
	tools/with_blender.sh 3.4 $(BLENDER_ARGS) --python demo/demo.py -- --zip $(ZIP_3.4) --out out
	@echo "Demo output: out/demo.blend and out/demo.png"

test: deps deps-4.3 deps-5.2 build-3.4 build-4.3 build-5.2 test-native test-python test-blender test-demo test-fuzz
	@echo "make test: everything passed on Blender 3.4, 4.3 and 5.2"

# The README's other command, the demo, run whole into a scratch folder: a script or API change that breaks it
# fails the tests (out/ is left to `make demo`).
test-demo:
	scratch=$$(mktemp -d) && trap 'rm -rf "$$scratch"' EXIT && \
	tools/with_blender.sh 3.4 $(BLENDER_ARGS) --python demo/demo.py -- --zip $(ZIP_3.4) --out "$$scratch" && \
	test -s "$$scratch/demo.png" && test -s "$$scratch/demo.blend" && test -s "$$scratch/contacts.png" && \
	test -s "$$scratch/filters.png" && \
	test -s "$$scratch/ik_reach.png" && test -s "$$scratch/feet_fingers.png" && \
	test -s "$$scratch/reduction.png" && test -s "$$scratch/mirror.png"

deps:
	tools/install_deps.sh

deps-4.3: deps
	tools/chroot.sh trixie setup
deps-5.2: deps
	tools/chroot.sh sid setup

# Each build also compiles the native tests and benchmarks with that Blender's toolchain
# (g++ 12 on the host, g++ 14 in trixie, g++ 16 in sid).
$(addprefix build-,$(BLENDERS)): build-%:
	$(IN_$*) python3 build_addon.py --blender /usr/bin/blender --all

test-native:
	$(foreach v,$(BLENDERS),$(IN_$(v)) ctest --test-dir $(BUILD_$(v)) --output-on-failure --no-tests=error && ) true

test-python:
	python3 -m pytest -p no:cacheprovider -q -rs tests/python

# A bounded libFuzzer run of the BVH reader under ASan and UBSan (clang).
test-fuzz:
	tools/fuzz_bvh.sh 30

test-blender: $(addprefix test-blender-,$(BLENDERS))
$(addprefix test-blender-,$(BLENDERS)): test-blender-%:
	tools/with_blender.sh $* $(BLENDER_ARGS) --python tests/blender/run_in_blender.py -- $(ZIP_$*)

# Benchmarks are not tests: run them by hand and record the figures in docs/benchmarks.md.
# The native ones on each toolchain, then each end-to-end script on each Blender.
bench: $(addprefix build-,$(BLENDERS))
	$(foreach v,$(BLENDERS),$(IN_$(v)) $(BUILD_$(v))/motionkit_bench && ) true
	$(foreach b,$(BENCHES),$(foreach v,$(BLENDERS),\
	  tools/with_blender.sh $(v) $(BLENDER_ARGS) --python bench/$(b).py -- --zip $(ZIP_$(v)) && )) true

clean:
	rm -rf build dist out
