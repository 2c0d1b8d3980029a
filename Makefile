# openmm-flavors: the commands a user needs.  Every target installs the Debian packages it needs first.
#   make demo                 build, then the molecular wins in short runs, each beside its OpenMM peer (Drude water:
#                             SIM against DrudeLangevin; flexible water: FLAVOR against LangevinMiddle) with the full
#                             runs' numbers, then the FPU scene (FLAVOR vs Verlet) and a reduced work-precision
#                             comparison of every integrator on the FPU chain, with tables; results in results/
#   make test                 check the C++ formatting, build (any compiler warning fails), then run every C++ test
#                             (ctest) and every Python test (pytest)
#   make install PREFIX=dir   install libraries, headers, kernel plugins and the Python package under dir
#   make bench                run the benchmarks (not part of the tests)

PREFIX ?= /usr/local
BUILD ?= build
PYTHON := /usr/bin/python3
JOBS ?= $(shell nproc)
APT_PACKAGES := cmake make gcc g++ swig libopenmm-dev libopenmm-plugins python3-simtk python3-dev libeigen3-dev \
                libgtest-dev python3-numpy python3-pytest python3-matplotlib python3-scipy clang-format git \
                pocl-opencl-icd opencl-c-headers opencl-clhpp-headers ocl-icd-opencl-dev
PYTHON_ENV := PYTHONPATH=$(CURDIR)/$(BUILD)/python PYTHONDONTWRITEBYTECODE=1
# The layer that refuses OpenCL kernel arguments of the wrong size as NVIDIA's driver does (tests/OpenCLArgumentCheck.cpp),
# where the OpenCL backend was built.
OPENCL_CHECK = $(if $(wildcard $(BUILD)/tests/libOpenCLArgumentCheck.so),LD_PRELOAD=$(CURDIR)/$(BUILD)/tests/libOpenCLArgumentCheck.so)

.PHONY: deps build format-check test demo install bench clean

deps:
	@missing=$$(for p in $(APT_PACKAGES); do \
	    dpkg-query -W -f='$${Status}\n' $$p 2>/dev/null | grep -q '^install ok installed' || echo $$p; done); \
	if [ -n "$$missing" ]; then \
	    echo "Installing Debian packages:" $$missing; \
	    apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends $$missing; \
	fi

build: deps
	cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release -DPython3_EXECUTABLE=$(PYTHON) -DFLAVORS_WARNINGS_AS_ERRORS=ON
	cmake --build $(BUILD) -j $(JOBS)

# Every C++ file of the project as .clang-format lays it out.
format-check: deps
	clang-format --dry-run --Werror $$(git ls-files '*.cpp' '*.h' '*.cc')

test: format-check build
	cd $(BUILD) && ctest --output-on-failure -j $(JOBS)
	$(PYTHON_ENV) $(OPENCL_CHECK) $(PYTHON) -m pytest -q -p no:cacheprovider tests/python

demo: build
	$(PYTHON_ENV) $(PYTHON) examples/demo/demo.py
	$(PYTHON_ENV) $(PYTHON) examples/fpu/fpu.py --T 50
	$(PYTHON_ENV) $(PYTHON) benchmarks/work_precision.py --demo

bench: build
	$(PYTHON_ENV) $(PYTHON) benchmarks/step_cost.py
	$(PYTHON_ENV) $(PYTHON) benchmarks/work_precision.py
	$(PYTHON_ENV) $(PYTHON) benchmarks/stability.py
	$(PYTHON_ENV) $(PYTHON) benchmarks/sim_work_precision.py
	$(PYTHON_ENV) $(PYTHON) benchmarks/sim_step_cost.py
	$(PYTHON_ENV) $(PYTHON) benchmarks/frozen_energy_drift.py

install: build
	cmake --install $(BUILD) --prefix $(PREFIX)
	@echo "Python package installed in $(PREFIX)/lib/python3/dist-packages/openmmflavors"
	@echo "Use it with: PYTHONPATH=$(PREFIX)/lib/python3/dist-packages $(PYTHON) -c 'import openmmflavors'"

clean:
	rm -rf $(BUILD)
