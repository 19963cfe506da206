# The two entry points of the README. Both install missing Debian packages first (idempotent)
# and configure a Release build in build/. `make demo` builds only the ctcal program the demo runs
# (not the tests and benchmarks, most of a fresh build's time); `make test` and `make build` build
# everything, with all cores.
BUILD_DIR ?= build
JOBS ?= $(shell nproc)

.PHONY: all deps configure build demo test format clean

all: build

deps:
	bash scripts/install_deps.sh

configure: deps
	cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=Release -DCTCAL_WERROR=ON

build: configure
	cmake --build $(BUILD_DIR) -j $(JOBS)

demo: configure
	cmake --build $(BUILD_DIR) -j $(JOBS) --target ctcal
	bash scripts/demo.sh $(BUILD_DIR)

test: build
	cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS)

format:
	bash scripts/format.sh

clean:
	rm -rf $(BUILD_DIR)
