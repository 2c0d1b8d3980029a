#!/usr/bin/env bash
# Fills device/ (git-ignored) with what benchmarks/device_check.sh needs on a borrowed GPU machine that reaches no
# network: its Python (3.12 by default) holds NVIDIA's CUDA runtime wheels, CMake, ninja and a compiler, and nothing
# of OpenMM, SWIG, Eigen or GoogleTest.  Run here, from the repository root, after `make build` (it uses .venv's pip):
#
#     benchmarks/device_prepare.sh [PYTHON_VERSION]      (default 3.12)
#
# device/wheels   the wheels of openmm and its CUDA add-on (requirements.txt's version), numpy and SWIG for that Python
# device/eigen3.tar.gz, device/googletest.tar.gz   Eigen's headers and GoogleTest's sources (Debian's packages)
# device/cuda-headers.tar.gz   cuda.h and the headers it includes (the CUDA toolkit's), which OpenMM's CUDA headers need
# device/states   the GPU benchmark's start states (XML), made here on the CPU platform so the GPU spends no time on them
# Everything travels with the working tree (at most 64 MiB in all): `run` with carry=["device"].
set -euo pipefail

PYTHON_VERSION=${1:-3.12}
DEVICE=device
PIP=.venv/bin/pip
[ -f benchmarks/device_prepare.sh ] || { echo "run it from the repository root" >&2; exit 1; }
[ -x "$PIP" ] || { echo "no .venv: run 'make build' first" >&2; exit 1; }

openmm=$(grep -E '^openmm==' requirements.txt)
numpy=$(grep -E '^numpy==' requirements.txt)
swig=$(grep -E '^swig==' requirements.txt)
cuda="openmm-cuda-13==${openmm#openmm==}"

rm -rf "$DEVICE/wheels"
mkdir -p "$DEVICE/wheels"
# pip matches each --platform tag exactly: name every manylinux tag these wheels are built for.
platforms=()
for tag in 2_34 2_28 2_27 2_17 2_12 2_5; do platforms+=(--platform "manylinux_${tag}_x86_64"); done
platforms+=(--platform manylinux2014_x86_64 --platform manylinux2010_x86_64 --platform manylinux1_x86_64)
"$PIP" download -q --disable-pip-version-check --only-binary=:all: --no-deps --python-version "$PYTHON_VERSION" \
    "${platforms[@]}" -d "$DEVICE/wheels" "$openmm" "$cuda" "$numpy" "$swig"
tar czf "$DEVICE/eigen3.tar.gz" -C /usr/include/eigen3 Eigen
tar czf "$DEVICE/googletest.tar.gz" -C /usr/src googletest
# The CUDA headers that OpenMM's CUDA headers include (cuda.h and the types it names), from the toolkit here, in case
# the GPU machine's NVIDIA wheels carry no headers.
cuda_include=$(dirname "$(readlink -f "$(command -v nvcc)")")/../include
(cd "$cuda_include" && tar czf - cuda.h builtin_types.h crt/host_defines.h cuda_device_runtime_api.h cuda_runtime_api.h \
    device_types.h driver_types.h surface_types.h texture_types.h vector_functions.h vector_functions.hpp \
    vector_types.h) >"$DEVICE/cuda-headers.tar.gz"

# The start states of the device check's scenes, made once on the CPU platform (the benchmark reads them back).
PYTHONPATH=build/python .venv/bin/python benchmarks/gpu_benchmark.py --platform OpenCL --states "$DEVICE/states" \
    --make-states-only --scenes ${DEVICE_CHECK_SCENES:-flexible_water drude_water} \
    --flexible-sizes ${DEVICE_CHECK_FLEXIBLE_SIZES:-501 16000} --drude-sizes ${DEVICE_CHECK_DRUDE_SIZES:-256 8192}

du -sh "$DEVICE"/*
total=$(du -sm "$DEVICE" | cut -f1)
echo "device/: ${total} MiB (the working tree may carry 64 MiB in all)"
[ "$total" -lt 60 ] || { echo "device/ is too large to travel" >&2; exit 1; }
