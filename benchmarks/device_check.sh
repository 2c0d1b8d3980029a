#!/usr/bin/env bash
# The OpenCL device check, run as it is from the repository root after `make build`:
#
#     benchmarks/device_check.sh [OUT]          (OUT: default results/device_check)
#
# 1. reports whether an OpenCL driver is present: the ICDs in /etc/OpenCL/vendors and the devices of OpenMM's OpenCL
#    platform (DeviceName, OpenCLPlatformName, Precision from a Context) -> OUT/opencl_devices.json;
# 2. runs the OpenCL C++ tests (build/tests/TestFlavorsPlatforms --gtest_filter='*OpenCL*')
#    -> OUT/opencl_tests.log and OUT/opencl_tests.xml (GoogleTest's XML report);
# 3. runs benchmarks/opencl_benchmark.py -> OUT/opencl_benchmark.json, .png and OUT/opencl_benchmark.log.
# OUT/device_check.json sums it up.  Exits non-zero, with a message, when OpenMM has no OpenCL platform (and then runs
# nothing else), when the build is missing, or when a test or the benchmark fails.
#
# When a GPU's OpenCL device is found, the benchmark runs on the first one (FLAVORS_OPENCL_PLATFORM_INDEX and
# FLAVORS_OPENCL_DEVICE_INDEX); the C++ tests run on the device OpenMM chooses.
# Environment: DEVICE_CHECK_QUICK=1 runs the benchmark as a smoke run (small systems, short batches: a few minutes on
# a CPU OpenCL such as PoCL); DEVICE_CHECK_PRECISION (default "mixed double") its precisions; DEVICE_CHECK_SCENES
# (default: the benchmark's own, all of them) its scenes, e.g. "drude_protein drude_villin" for the Drude-2019 scenes
# alone; BUILD (default build) the build directory.
set -u -o pipefail

OUT=${1:-results/device_check}
BUILD=${BUILD:-build}
PYTHON=/usr/bin/python3
PRECISION=${DEVICE_CHECK_PRECISION:-mixed double}
SCENES=${DEVICE_CHECK_SCENES:-}
QUICK=${DEVICE_CHECK_QUICK:-0}
export PYTHONPATH="$PWD/$BUILD/python${PYTHONPATH:+:$PYTHONPATH}" PYTHONDONTWRITEBYTECODE=1

fail() {
    echo "device_check: FAILED: $*" >&2
    exit 1
}

[ -f benchmarks/device_check.sh ] || fail "run it from the repository root"
[ -x "$BUILD/tests/TestFlavorsPlatforms" ] ||
    fail "$BUILD/tests/TestFlavorsPlatforms is missing: run 'make build' first"
mkdir -p "$OUT" || fail "cannot create $OUT"
started=$(date +%s)

echo "== 1. OpenCL drivers"
echo "Installable client drivers in /etc/OpenCL/vendors:"
if ls /etc/OpenCL/vendors/*.icd >/dev/null 2>&1; then
    for icd in /etc/OpenCL/vendors/*.icd; do
        echo "  $icd -> $(cat "$icd")"
    done
else
    echo "  none"
fi
[ -n "${OCL_ICD_VENDORS:-}" ] && echo "  (OCL_ICD_VENDORS=$OCL_ICD_VENDORS: the loader reads the ICDs there instead)"
if command -v nvidia-smi >/dev/null 2>&1; then
    echo "nvidia-smi: $(nvidia-smi --query-gpu=name,driver_version --format=csv,noheader 2>&1 | head -4 | tr '\n' ';')"
fi

rm -f "$OUT/opencl_devices.json.env"
"$PYTHON" - "$OUT/opencl_devices.json" <<'EOF'
import glob
import json
import sys

import openmm as mm

platforms = [mm.Platform.getPlatform(i).getName() for i in range(mm.Platform.getNumPlatforms())]
report = {"openmm_version": mm.Platform.getOpenMMVersion(), "platforms": platforms,
          "icds": {path: open(path).read().strip() for path in sorted(glob.glob("/etc/OpenCL/vendors/*.icd"))},
          "opencl": None}
print("OpenMM %s platforms: %s" % (report["openmm_version"], ", ".join(platforms)))
if "OpenCL" in platforms:
    platform = mm.Platform.getPlatformByName("OpenCL")
    system = mm.System()
    system.addParticle(1.0)
    context = mm.Context(system, mm.VerletIntegrator(0.001), platform)
    report["opencl"] = {key: platform.getPropertyValue(context, key)
                        for key in ("DeviceName", "OpenCLPlatformName", "OpenCLPlatformIndex", "DeviceIndex",
                                    "Precision")}
    print("OpenMM's OpenCL platform, default device: " +
          ", ".join("%s = %s" % item for item in report["opencl"].items()))
    # Every device of every OpenCL platform that OpenMM can open, by index (a Context on a missing one throws).
    report["devices"] = []
    for p in range(8):
        found = 0
        for d in range(16):
            try:
                c = mm.Context(system, mm.VerletIntegrator(0.001), platform,
                               {"OpenCLPlatformIndex": str(p), "DeviceIndex": str(d)})
            except Exception:
                break
            entry = {key: platform.getPropertyValue(c, key) for key in ("OpenCLPlatformName", "DeviceName")}
            entry.update(OpenCLPlatformIndex=p, DeviceIndex=d)
            report["devices"].append(entry)
            print("  platform %d device %d: %s (%s)" % (p, d, entry["DeviceName"], entry["OpenCLPlatformName"]))
            found += 1
            del c
        if not found:
            break
    # Judged from the names: PoCL and the CPU runtimes name the processor; a GPU's driver names its vendor's platform.
    def is_gpu(entry):
        device, name = entry["DeviceName"].lower(), entry["OpenCLPlatformName"].lower()
        if any(cpu in device for cpu in ("pthread", "cpu", "xeon", "epyc", "core(tm)", "ryzen")):
            return False
        return any(gpu in name + " " + device for gpu in ("nvidia", "cuda", "amd accelerated", "rocm", "radeon",
                                                           "graphics", "gpu", "tesla", "geforce", "h100", "h200",
                                                           "a100"))
    report["gpu_devices"] = [e for e in report["devices"] if is_gpu(e)]
    report["gpu_driver"] = bool(report["gpu_devices"])
    if report["gpu_driver"]:
        print("A GPU's OpenCL driver: yes (%s)" % "; ".join(e["DeviceName"] for e in report["gpu_devices"]))
    else:
        print("A GPU's OpenCL driver: no, only a CPU OpenCL (%s): its times are a CPU's" %
              "; ".join(e["OpenCLPlatformName"] for e in report["devices"]))
with open(sys.argv[1], "w") as f:
    json.dump(report, f, indent=1)
if report.get("gpu_devices"):
    with open(sys.argv[1] + ".env", "w") as f:
        f.write("export FLAVORS_OPENCL_PLATFORM_INDEX=%d FLAVORS_OPENCL_DEVICE_INDEX=%d\n" %
                (report["gpu_devices"][0]["OpenCLPlatformIndex"], report["gpu_devices"][0]["DeviceIndex"]))
sys.exit(0 if report["opencl"] else 3)
EOF
status=$?
if [ $status -eq 3 ]; then
    fail "OpenMM has no OpenCL platform: no OpenCL driver (ICD) for this machine's GPU, or none at all.  On an NVIDIA" \
        "GPU, install the driver's OpenCL ICD (e.g. Debian's nvidia-opencl-icd; /etc/OpenCL/vendors/nvidia.icd); on" \
        "a CPU, pocl-opencl-icd.  Nothing else was run."
elif [ $status -ne 0 ]; then
    fail "could not query OpenMM's platforms (exit status $status; is the build's Python module in $BUILD/python?)"
fi

if [ -f "$OUT/opencl_devices.json.env" ]; then
    # The benchmark runs on the first GPU found, whatever OpenMM would choose.
    . "$OUT/opencl_devices.json.env"
    echo "The benchmark runs on OpenCL platform $FLAVORS_OPENCL_PLATFORM_INDEX, device $FLAVORS_OPENCL_DEVICE_INDEX"
fi

echo
echo "== 2. OpenCL C++ tests ($BUILD/tests/TestFlavorsPlatforms --gtest_filter='*OpenCL*') -> $OUT/opencl_tests.log"
tests_started=$(date +%s)
"$BUILD/tests/TestFlavorsPlatforms" --gtest_filter='*OpenCL*' --gtest_output="xml:$OUT/opencl_tests.xml" \
    >"$OUT/opencl_tests.log" 2>&1
tests_status=$?
tests_seconds=$(($(date +%s) - tests_started))
grep -E '^\[  (PASSED|FAILED) |^\[==========\] [0-9]+ tests' "$OUT/opencl_tests.log" | sed 's/^/  /'
grep -E '^\[  FAILED  \]' "$OUT/opencl_tests.log" | sed 's/^/  /' | sort -u | head -40

echo
echo "== 3. OpenCL benchmark (benchmarks/opencl_benchmark.py, precision: $PRECISION, quick: $QUICK) -> $OUT"
bench_started=$(date +%s)
bench_args=(--out "$OUT" --precision $PRECISION)
[ "$QUICK" != "0" ] && bench_args+=(--quick)
[ -n "$SCENES" ] && bench_args+=(--scenes $SCENES)
"$PYTHON" benchmarks/opencl_benchmark.py "${bench_args[@]}" 2> >(tee "$OUT/opencl_benchmark.stderr.log" >&2) |
    tee "$OUT/opencl_benchmark.log"
bench_status=$?
bench_seconds=$(($(date +%s) - bench_started))

"$PYTHON" - "$OUT" "$tests_status" "$tests_seconds" "$bench_status" "$bench_seconds" "$(($(date +%s) - started))" \
    "$QUICK" <<'EOF'
import json
import os
import sys

out, tests_status, tests_seconds, bench_status, bench_seconds, total, quick = sys.argv[1:]
summary = {"opencl": json.load(open(os.path.join(out, "opencl_devices.json"))),
           "tests": {"exit_status": int(tests_status), "seconds": int(tests_seconds), "log": "opencl_tests.log",
                     "report": "opencl_tests.xml"},
           "benchmark": {"exit_status": int(bench_status), "seconds": int(bench_seconds), "quick": quick != "0",
                         "json": "opencl_benchmark.json", "chart": "opencl_benchmark.png"},
           "seconds": int(total)}
bench = os.path.join(out, "opencl_benchmark.json")
if int(bench_status) == 0 and os.path.exists(bench):
    ratios = {}
    for scene, data in json.load(open(bench))["scenes"].items():
        for precision, run in data["precisions"].items():
            timed = {name: p["ns_per_day"] for name, p in run["peers"].items() if p.get("available")}
            first = next(iter(timed.values()), None)
            ratios[f"{scene} {precision}"] = {name: v / first for name, v in timed.items()} if first else {}
    summary["benchmark"]["ns_per_day_ratio_to_first_peer"] = ratios
with open(os.path.join(out, "device_check.json"), "w") as f:
    json.dump(summary, f, indent=1)
EOF

echo
echo "== summary ($OUT/device_check.json)"
tests_result=$([ $tests_status -eq 0 ] && echo passed || echo "FAILED (exit $tests_status)")
bench_result=$([ $bench_status -eq 0 ] && echo done || echo "FAILED (exit $bench_status)")
echo "  OpenCL tests: $tests_result in ${tests_seconds} s"
echo "  benchmark:    $bench_result in ${bench_seconds} s"
[ $tests_status -eq 0 ] || fail "the OpenCL tests failed: see $OUT/opencl_tests.log"
[ $bench_status -eq 0 ] || fail "the OpenCL benchmark failed: see $OUT/opencl_benchmark.stderr.log"
echo "device_check: OK"
