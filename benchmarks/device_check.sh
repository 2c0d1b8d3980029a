#!/usr/bin/env bash
# The GPU check, for a borrowed GPU machine that reaches no network.  Prepare here first
# (benchmarks/device_prepare.sh fills the git-ignored device/), carry device/ with the working tree, then run there from
# the repository root:
#
#     benchmarks/device_check.sh [OUT]          (OUT: default results/device_check; on the device machine, $OUT)
#
# 1. installs the carried wheels (openmm, its CUDA add-on, numpy, SWIG) into the machine's Python, whose site-packages
#    hold NVIDIA's CUDA runtime wheels (the add-on finds them there), and reports the platforms OpenMM loads and their
#    devices -> OUT/devices.json;
# 2. builds the project against that OpenMM (Ninja, every core; Eigen, GoogleTest and the CUDA headers from device/);
# 3. runs the C++ tests of every GPU platform OpenMM has (TestFlavorsPlatforms --gtest_filter='*CUDA*:*OpenCL*'), which
#    print each comparison's measured deviation from Reference -> OUT/gpu_tests.log, OUT/gpu_tests.xml;
# 4. runs benchmarks/gpu_benchmark.py on CUDA (and OpenCL where OpenMM has it) from device/states, JSON only (the chart
#    is drawn here afterwards with --replot) -> OUT/gpu_benchmark_<platform>.json, .log.
# OUT/device_check.json sums it up, with the time of each part.  Environment: DEVICE_CHECK_SCENES (default
# "flexible_water drude_water"), DEVICE_CHECK_FLEXIBLE_SIZES and DEVICE_CHECK_DRUDE_SIZES (the scenes' numbers of
# molecules; default "501 16000" and "256 8192"), DEVICE_CHECK_PRECISION (default "mixed"), DEVICE_CHECK_TARGET and
# DEVICE_CHECK_REPEATS (the benchmark's seconds per batch and rounds; default 1 and 3), DEVICE_CHECK_TEST_FILTER (the
# tests' GoogleTest filter), DEVICE_CHECK_PYTHON (python3).
set -u -o pipefail

OUT=${1:-${OUT:-results/device_check}}
PYTHON=${DEVICE_CHECK_PYTHON:-python3}
SCENES=${DEVICE_CHECK_SCENES:-flexible_water drude_water}
FLEXIBLE_SIZES=${DEVICE_CHECK_FLEXIBLE_SIZES:-501 16000}
DRUDE_SIZES=${DEVICE_CHECK_DRUDE_SIZES:-256 8192}
PRECISION=${DEVICE_CHECK_PRECISION:-mixed}
TARGET=${DEVICE_CHECK_TARGET:-1}
REPEATS=${DEVICE_CHECK_REPEATS:-3}
TEST_FILTER=${DEVICE_CHECK_TEST_FILTER:-*CUDA*:*OpenCL*}
BUILD=build-device
UNPACKED=$BUILD/carried

fail() {
    echo "device_check: FAILED: $*" >&2
    exit 1
}
seconds_since() { echo $(($(date +%s) - $1)); }

[ -f benchmarks/device_check.sh ] || fail "run it from the repository root"
[ -d device/wheels ] || fail "device/wheels is missing: run benchmarks/device_prepare.sh where PyPI is reachable"
mkdir -p "$OUT" "$UNPACKED" || fail "cannot create $OUT"
started=$(date +%s)

echo "== 1. OpenMM from the carried wheels"
part=$(date +%s)
command -v nvidia-smi >/dev/null 2>&1 && nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader
# The machine's own Python: a virtual environment would separate OpenMM's CUDA add-on from the NVIDIA wheels that its
# run path expects beside it (site-packages/nvidia/cu13/lib).
"$PYTHON" -m pip install -q --no-index --no-deps --disable-pip-version-check --find-links device/wheels \
    openmm openmm-cuda-13 numpy swig 2>&1 | tail -3 ||
    "$PYTHON" -m pip install -q --no-index --no-deps --disable-pip-version-check --break-system-packages \
        --find-links device/wheels openmm openmm-cuda-13 numpy swig || fail "could not install the carried wheels"
OPENMM_DIR=$("$PYTHON" -c 'import os, openmm.version as v; print(os.path.dirname(v.openmm_library_path))') ||
    fail "openmm does not import"
# The swig wheel's binary, told where its library is (its console script would do that, were it on PATH).
SWIG=$("$PYTHON" -c 'import os, swig; print(os.path.join(swig.BIN_DIR, "swig"))') || fail "swig does not import"
SWIG_LIB=$("$PYTHON" -c 'import glob, os, swig; print(glob.glob(os.path.join(swig.SWIG_SHARE_DIR, "*"))[0])')
export SWIG_LIB
"$PYTHON" - "$OUT/devices.json" <<'EOF'
import json
import sys

import openmm as mm

report = {"openmm_version": mm.Platform.getOpenMMVersion(),
          "platforms": [mm.Platform.getPlatform(i).getName() for i in range(mm.Platform.getNumPlatforms())],
          "plugin_load_failures": list(mm.Platform.getPluginLoadFailures()), "devices": {}}
system = mm.System()
system.addParticle(1.0)
for name in ("CUDA", "OpenCL"):
    if name in report["platforms"]:
        platform = mm.Platform.getPlatformByName(name)
        context = mm.Context(system, mm.VerletIntegrator(0.001), platform)
        report["devices"][name] = {key: platform.getPropertyValue(context, key)
                                   for key in platform.getPropertyNames() if "Name" in key or key == "Precision"}
print(json.dumps(report, indent=1))
json.dump(report, open(sys.argv[1], "w"), indent=1)
EOF
install_seconds=$(seconds_since $part)

echo "== 2. build against OpenMM in $OPENMM_DIR"
part=$(date +%s)
for archive in eigen3 googletest cuda-headers; do
    mkdir -p "$UNPACKED/$archive" && tar xzf "device/$archive.tar.gz" -C "$UNPACKED/$archive" ||
        fail "device/$archive.tar.gz is missing"
done
generator=()
command -v ninja >/dev/null 2>&1 && generator=(-G Ninja)
cmake "${generator[@]}" -S . -B "$BUILD" -DCMAKE_BUILD_TYPE=Release -DOPENMM_DIR="$OPENMM_DIR" \
    -DPython3_EXECUTABLE="$(command -v "$PYTHON")" -DSWIG_EXECUTABLE="$SWIG" \
    -DEIGEN3_INCLUDE_DIR="$PWD/$UNPACKED/eigen3" -DFLAVORS_GTEST_SOURCE_DIR="$PWD/$UNPACKED/googletest/googletest" \
    -DFLAVORS_CUDA_INCLUDE_DIR="$PWD/$UNPACKED/cuda-headers" >"$OUT/build.log" 2>&1 &&
    cmake --build "$BUILD" -j "$(nproc)" >>"$OUT/build.log" 2>&1 || {
    tail -30 "$OUT/build.log"
    fail "the build failed: see $OUT/build.log"
}
grep -E 'Building the|Not building' "$OUT/build.log"
build_seconds=$(seconds_since $part)

echo "== 3. GPU tests ($TEST_FILTER) -> $OUT/gpu_tests.log"
part=$(date +%s)
"$BUILD/tests/TestFlavorsPlatforms" --gtest_filter="$TEST_FILTER" --gtest_output="xml:$OUT/gpu_tests.xml" \
    >"$OUT/gpu_tests.log" 2>&1
tests_status=$?
grep -E '^\[  (PASSED|FAILED|SKIPPED) |^\[==========\] [0-9]+ tests' "$OUT/gpu_tests.log"
grep -E '^\[  FAILED  \]' "$OUT/gpu_tests.log" | sort -u | head -40
tests_seconds=$(seconds_since $part)

echo "== 4. GPU benchmark (scenes: $SCENES; precision: $PRECISION) -> $OUT"
part=$(date +%s)
export PYTHONPATH="$PWD/$BUILD/python" PYTHONDONTWRITEBYTECODE=1
bench_status=0
platforms=$("$PYTHON" -c 'import json, sys; print(" ".join(p for p in ("CUDA", "OpenCL") if p in json.load(open(sys.argv[1]))["platforms"]))' "$OUT/devices.json")
for platform in $platforms; do
    echo "-- $platform"
    "$PYTHON" benchmarks/gpu_benchmark.py --platform "$platform" --out "$OUT" --states device/states --no-chart \
        --scenes $SCENES --flexible-sizes $FLEXIBLE_SIZES --drude-sizes $DRUDE_SIZES --precision $PRECISION \
        --target "$TARGET" --repeats "$REPEATS" \
        2>"$OUT/gpu_benchmark_${platform,,}.stderr.log" | tee "$OUT/gpu_benchmark_${platform,,}.log" ||
        bench_status=1
done
bench_seconds=$(seconds_since $part)

"$PYTHON" - "$OUT" "$tests_status" "$bench_status" "$install_seconds" "$build_seconds" "$tests_seconds" \
    "$bench_seconds" "$(seconds_since $started)" <<'EOF'
import json
import os
import sys

out, tests_status, bench_status, *seconds = sys.argv[1:]
summary = {"devices": json.load(open(os.path.join(out, "devices.json"))),
           "tests": {"exit_status": int(tests_status), "log": "gpu_tests.log", "report": "gpu_tests.xml"},
           "benchmark": {"exit_status": int(bench_status)},
           "seconds": dict(zip(("install", "build", "tests", "benchmark", "total"), map(int, seconds)))}
for name in sorted(os.listdir(out)):
    if name.startswith("gpu_benchmark_") and name.endswith(".json"):
        data = json.load(open(os.path.join(out, name)))
        ratios = {}
        for scene, run in data["scenes"].items():
            for precision, result in run["precisions"].items():
                timed = {peer: p["ns_per_day"] for peer, p in result["peers"].items() if p.get("available")}
                first = next(iter(timed.values()), None)
                ratios[f"{scene} {precision}"] = {peer: v / first for peer, v in timed.items()} if first else {}
        summary["benchmark"][data["platform"]] = {"json": name, "ns_per_day_ratio_to_first_peer": ratios}
json.dump(summary, open(os.path.join(out, "device_check.json"), "w"), indent=1)
print(json.dumps(summary["seconds"]))
EOF
[ $tests_status -eq 0 ] || fail "GPU tests failed: see $OUT/gpu_tests.log"
[ $bench_status -eq 0 ] || fail "the GPU benchmark failed: see $OUT/gpu_benchmark_*.stderr.log"
echo "device_check: OK"
