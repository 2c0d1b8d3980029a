# openmm-flavors: the commands a user needs.  Every target first installs what it needs: Debian packages (apt) and, for
# the default OpenMM, a project virtual environment .venv filled from PyPI (requirements.txt).
#   make demo                 build, then the molecular wins in short runs, each beside its OpenMM peer, then the FPU
#                             scene and a reduced work-precision comparison of every integrator; results in results/
#   make test                 check the C++ formatting, build (any compiler warning fails), then run every C++ test
#                             (ctest) and the Python tests (pytest) but the long scene runs
#   make test-long            the long scene runs that `make test` leaves out (pytest -m long)
#   make install PREFIX=dir   install libraries, headers, kernel plugins and the Python package under dir
#   make bench                run the benchmarks (not part of the tests)
#
# Which OpenMM (each builds in its own folder):
#   (default)                 OpenMM 8.6.1 from PyPI in .venv, with the CUDA add-on (build/)
#   OPENMM=debian             Debian 12's OpenMM 7.7 and /usr/bin/python3 (build-debian/)
#   OPENMM_DIR=<prefix> PYTHON=<python>   any other install, e.g. conda's: OPENMM_DIR=$$CONDA_PREFIX (build-custom/)

PREFIX ?= /usr/local
JOBS ?= $(shell nproc)
SYSTEM_PYTHON := /usr/bin/python3
VENV ?= .venv
# The OpenMM CUDA add-on matching requirements.txt's openmm.
OPENMM_CUDA := openmm-cuda-13==8.6.1

# PoCL's library without its ICD (pocl-opencl-icd): the build registers it for the tests alone (OPENCL_VENDORS).
COMMON_APT := cmake make gcc g++ python3-dev libeigen3-dev libgtest-dev clang-format git \
              libpocl2 opencl-c-headers ocl-icd-opencl-dev
ifeq ($(OPENMM),debian)
BUILD ?= build-debian
PYTHON := $(SYSTEM_PYTHON)
SWIG := swig
OPENMM_PREFIX := /usr
APT_PACKAGES := $(COMMON_APT) swig libopenmm-dev libopenmm-plugins python3-simtk python3-numpy python3-pytest \
                python3-matplotlib python3-scipy opencl-clhpp-headers
PYTHON_ENV_READY :=
else ifneq ($(OPENMM_DIR),)
BUILD ?= build-custom
PYTHON ?= python3
SWIG ?= swig
OPENMM_PREFIX := $(OPENMM_DIR)
APT_PACKAGES := $(COMMON_APT)
PYTHON_ENV_READY :=
else
BUILD ?= build
PYTHON := $(CURDIR)/$(VENV)/bin/python
SWIG := $(CURDIR)/$(VENV)/bin/swig
# OpenMM.libs beside the wheel's Python package: the wheel's include/ and lib/.
OPENMM_PREFIX = $$($(PYTHON) -c 'import os, openmm.version as v; print(os.path.dirname(v.openmm_library_path))')
APT_PACKAGES := $(COMMON_APT) python3-venv
PYTHON_ENV_READY := $(VENV)/.installed
endif

# The build's OpenCL drivers (PoCL, a CPU one, among them) for the tests and scripts run here, without registering PoCL
# for the rest of the machine (/etc/OpenCL/vendors), where it would become the platform OpenMM picks for every script.
OPENCL_VENDORS = $(if $(wildcard $(BUILD)/opencl-vendors),OCL_ICD_VENDORS=$(CURDIR)/$(BUILD)/opencl-vendors)
PYTHON_ENV = PYTHONPATH=$(CURDIR)/$(BUILD)/python PYTHONDONTWRITEBYTECODE=1 $(OPENCL_VENDORS)
# The layer that refuses OpenCL kernel arguments of the wrong size as NVIDIA's driver does and counts launches and
# transfers (tests/OpenCLArgumentCheck.cpp, tests/OpenCLCallCounts.cpp),
# where the OpenCL backend was built.
OPENCL_CHECK = $(if $(wildcard $(BUILD)/tests/libOpenCLTestLayer.so),LD_PRELOAD=$(CURDIR)/$(BUILD)/tests/libOpenCLTestLayer.so)
PYTEST = $(PYTHON_ENV) $(OPENCL_CHECK) $(PYTHON) -m pytest -q -p no:cacheprovider

.PHONY: deps venv build format-check test test-cpp test-python test-long smoke demo install bench clean

deps:
	@missing=$$(for p in $(APT_PACKAGES); do \
	    dpkg-query -W -f='$${Status}\n' $$p 2>/dev/null | grep -q '^install ok installed' || echo $$p; done); \
	if [ -n "$$missing" ]; then \
	    echo "Installing Debian packages:" $$missing; \
	    apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends $$missing; \
	fi

# The project's Python environment: requirements.txt, then OpenMM's CUDA add-on.  Where no NVIDIA driver is installed
# the add-on comes without NVIDIA's runtime wheels: its library and headers are what the CUDA kernel plugin compiles and
# links against, and OpenMM skips a CUDA platform it cannot load.
$(VENV)/.installed: requirements.txt | deps
	$(SYSTEM_PYTHON) -m venv $(VENV)
	$(VENV)/bin/pip install -q --disable-pip-version-check -r requirements.txt
	if command -v nvidia-smi >/dev/null 2>&1; then \
	    $(VENV)/bin/pip install -q --disable-pip-version-check $(OPENMM_CUDA); \
	else \
	    $(VENV)/bin/pip install -q --disable-pip-version-check --no-deps $(OPENMM_CUDA); \
	fi
	touch $@

venv: $(PYTHON_ENV_READY)

build: deps $(PYTHON_ENV_READY)
	cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release -DOPENMM_DIR="$(OPENMM_PREFIX)" \
	    -DPython3_EXECUTABLE=$$(command -v $(PYTHON)) -DSWIG_EXECUTABLE=$$(command -v $(SWIG)) \
	    -DFLAVORS_WARNINGS_AS_ERRORS=ON
	cmake --build $(BUILD) -j $(JOBS)

# Every C++ file of the project as .clang-format lays it out.
format-check: deps
	clang-format --dry-run --Werror $$(git ls-files '*.cpp' '*.h' '*.cc' '*.cu')

test-cpp: build
	cd $(BUILD) && ctest --output-on-failure -j $(JOBS)

test-python: build
	$(PYTEST) tests/python

test: format-check test-cpp test-python

test-long: build
	$(PYTEST) -m long tests/python

# Imports the package, runs both integrators on every platform and a script of the README (CI runs it against
# Debian's 7.7 after that build's C++ tests).
smoke: build
	$(PYTEST) tests/python/test_smoke.py

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
