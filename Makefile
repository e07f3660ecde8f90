# MotionKit: `make demo` sets up and runs the headless demo; `make test` runs
# every test on both Blenders. See README.md.
SHELL := /bin/bash
.SHELLFLAGS := -euo pipefail -c
# Blender finds its Python's standard library through the first python3.X on
# PATH: keep pyenv or a virtualenv out of it.
export PATH := /usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin
export MOTIONKIT_WERROR ?= ON

VERSION := $(shell sed -n 's/^project.motionkit VERSION \([0-9.]*\).*/\1/p' CMakeLists.txt)
ZIP_3.4 := dist/motionkit-$(VERSION)-linux-x64-py311.zip
ZIP_5.2 := dist/motionkit-$(VERSION)-linux-x64-py314.zip
BLENDER_ARGS := --background --factory-startup --python-exit-code 1
B5 := tools/blender5.sh

.PHONY: demo test deps deps-5.2 build-3.4 build-5.2 test-native test-python test-fuzz \
        test-blender test-blender-3.4 test-blender-5.2 test-demo bench clean

demo: deps build-3.4
	tools/with_blender.sh 3.4 $(BLENDER_ARGS) --python demo/demo.py -- --zip $(ZIP_3.4) --out out
	@echo "Demo output: out/demo.blend and out/demo.png"

test: deps deps-5.2 build-3.4 build-5.2 test-native test-python test-blender test-demo test-fuzz
	@echo "make test: everything passed on Blender 3.4 and 5.2"

# The README's other command, the demo, run whole into a scratch folder: a script or API change that breaks it
# fails the tests (out/ is left to `make demo`).
test-demo:
	scratch=$$(mktemp -d) && trap 'rm -rf "$$scratch"' EXIT && \
	tools/with_blender.sh 3.4 $(BLENDER_ARGS) --python demo/demo.py -- --zip $(ZIP_3.4) --out "$$scratch" && \
	test -s "$$scratch/demo.png" && test -s "$$scratch/demo.blend" && test -s "$$scratch/contacts.png"

deps:
	tools/install_deps.sh

deps-5.2: deps
	$(B5) setup

# Each build also compiles the native tests and benchmarks with that toolchain.
build-3.4:
	python3 build_addon.py --blender /usr/bin/blender --all
build-5.2:
	$(B5) run python3 build_addon.py --blender /usr/bin/blender --all

test-native:
	ctest --test-dir build/py311 --output-on-failure --no-tests=error
	$(B5) run ctest --test-dir build/py314 --output-on-failure --no-tests=error

test-python:
	python3 -m pytest -p no:cacheprovider -q -rs tests/python

# A bounded libFuzzer run of the BVH reader under ASan and UBSan (clang).
test-fuzz:
	tools/fuzz_bvh.sh 30

test-blender: test-blender-3.4 test-blender-5.2
test-blender-3.4:
	tools/with_blender.sh 3.4 $(BLENDER_ARGS) --python tests/blender/run_in_blender.py -- $(ZIP_3.4)
test-blender-5.2:
	tools/with_blender.sh 5.2 $(BLENDER_ARGS) --python tests/blender/run_in_blender.py -- $(ZIP_5.2)

# Benchmarks are not tests: run them by hand and record the figures in docs/benchmarks.md.
bench: build-3.4 build-5.2
	build/py311/motionkit_bench
	$(B5) run build/py314/motionkit_bench
	tools/with_blender.sh 3.4 $(BLENDER_ARGS) --python bench/fcurve_write.py -- --zip $(ZIP_3.4)
	tools/with_blender.sh 5.2 $(BLENDER_ARGS) --python bench/fcurve_write.py -- --zip $(ZIP_5.2)
	tools/with_blender.sh 3.4 $(BLENDER_ARGS) --python bench/bvh_import.py -- --zip $(ZIP_3.4)
	tools/with_blender.sh 5.2 $(BLENDER_ARGS) --python bench/bvh_import.py -- --zip $(ZIP_5.2)
	tools/with_blender.sh 3.4 $(BLENDER_ARGS) --python bench/resample.py -- --zip $(ZIP_3.4)
	tools/with_blender.sh 5.2 $(BLENDER_ARGS) --python bench/resample.py -- --zip $(ZIP_5.2)
	tools/with_blender.sh 3.4 $(BLENDER_ARGS) --python bench/retarget.py -- --zip $(ZIP_3.4)
	tools/with_blender.sh 5.2 $(BLENDER_ARGS) --python bench/retarget.py -- --zip $(ZIP_5.2)
	tools/with_blender.sh 3.4 $(BLENDER_ARGS) --python bench/plant_feet.py -- --zip $(ZIP_3.4)
	tools/with_blender.sh 5.2 $(BLENDER_ARGS) --python bench/plant_feet.py -- --zip $(ZIP_5.2)
	tools/with_blender.sh 3.4 $(BLENDER_ARGS) --python bench/ik.py -- --zip $(ZIP_3.4)
	tools/with_blender.sh 5.2 $(BLENDER_ARGS) --python bench/ik.py -- --zip $(ZIP_5.2)
	tools/with_blender.sh 3.4 $(BLENDER_ARGS) --python bench/ik_live.py -- --zip $(ZIP_3.4)
	tools/with_blender.sh 5.2 $(BLENDER_ARGS) --python bench/ik_live.py -- --zip $(ZIP_5.2)

clean:
	rm -rf build dist out
