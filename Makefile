# The two entry points of the README. Both install missing Debian packages first (idempotent),
# configure a Release build in build/ and build with all cores.
BUILD_DIR ?= build
JOBS ?= $(shell nproc)

.PHONY: all deps build demo test format clean

all: build

deps:
	bash scripts/install_deps.sh

build: deps
	cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=Release -DCTCAL_WERROR=ON
	cmake --build $(BUILD_DIR) -j $(JOBS)

demo: build
	bash scripts/demo.sh $(BUILD_DIR)

test: build
	cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS)

format:
	bash scripts/format.sh

clean:
	rm -rf $(BUILD_DIR)
