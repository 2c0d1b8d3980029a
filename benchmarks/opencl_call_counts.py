#!/usr/bin/env python3
"""What one step asks of an OpenCL device, counted: kernel launches, buffer reads and writes (the blocking ones, each a
round trip that stalls the host until the device has caught up, apart) and host waits, per step and per ps of simulated
time, for every peer of gpu_benchmark.py's scenes (the plugin's integrators beside OpenMM's own, the same systems and
start states).  Counts do not depend on the machine's load, so PoCL (a CPU OpenCL driver) counts what a GPU would be
asked; benchmarks/README.md's GPU time model turns them into predicted times.

The counts come from the OpenCL test layer the build makes (build/tests/libOpenCLTestLayer.so: tests/OpenCLCallCounts.cpp),
which the script preloads into itself when it is not yet loaded.  Mixed precision; each peer takes 3 steps first
(kernel compilation, the first step's set-up), then --steps counted steps in one integrator.step() call.

    PYTHONPATH=build/python .venv/bin/python benchmarks/opencl_call_counts.py [--quick] [--out DIR]
        [--scenes flexible_water drude_water] [--steps N] [--flexible-sizes N ...] [--drude-sizes N ...]

Writes DIR/opencl_call_counts.json and prints the table.
"""
import ctypes
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
LAYER = os.path.join(HERE, "..", "build", "tests", "libOpenCLTestLayer.so")
VENDORS = os.path.join(HERE, "..", "build", "opencl-vendors")
FIELDS = ("launches", "reads", "blockingReads", "writes", "blockingWrites", "waits")


class Counts(ctypes.Structure):
    _fields_ = [(name, ctypes.c_longlong) for name in FIELDS]


def counter():
    """The layer's counting function, or None where it is not loaded."""
    try:
        return ctypes.CDLL(None).flavorsOpenCLCallCounts
    except AttributeError:
        return None


def ensure_layer():
    """Re-executes this script with the layer preloaded (and the build's OpenCL drivers) where it is not loaded."""
    if counter() is not None:
        return
    if not os.path.exists(LAYER) or os.environ.get("FLAVORS_COUNTS_REEXEC"):
        sys.exit(f"opencl_call_counts: needs the OpenCL test layer {os.path.normpath(LAYER)} (make build makes it)")
    environment = dict(os.environ, FLAVORS_COUNTS_REEXEC="1",
                       LD_PRELOAD=" ".join(filter(None, [os.path.abspath(LAYER), os.environ.get("LD_PRELOAD")])))
    if os.path.isdir(VENDORS) and "OCL_ICD_VENDORS" not in environment:
        environment["OCL_ICD_VENDORS"] = os.path.abspath(VENDORS)
    os.execve(sys.executable, [sys.executable] + sys.argv, environment)


ensure_layer()

import openmm as mm  # noqa: E402

import gpu_benchmark  # noqa: E402
from flavorbench import reporting  # noqa: E402


def read_counts():
    counts = Counts()
    counter()(ctypes.byref(counts))
    return {name: getattr(counts, name) for name in FIELDS}


def count_peer(platform, system, factory, start, steps):
    integrator = factory()
    context = mm.Context(system, integrator, platform, {"Precision": "mixed"})
    start(context)
    integrator.step(3)
    before = read_counts()
    integrator.step(steps)
    after = read_counts()
    del context
    return {name: (after[name] - before[name]) / steps for name in FIELDS}


def main():
    p = reporting.parser(__doc__, "gpu", quick_help="the scenes' small systems")
    p.add_argument("--scenes", nargs="+", default=["flexible_water", "drude_water"],
                   choices=["flexible_water", "drude_water"])
    p.add_argument("--steps", type=int, default=20, help="counted steps per peer (default 20)")
    p.add_argument("--flexible-sizes", nargs="+", type=int, default=None, metavar="N",
                   help="flexible_water at these numbers of molecules (as gpu_benchmark.py)")
    p.add_argument("--drude-sizes", nargs="+", type=int, default=None, metavar="N",
                   help="drude_water at these numbers of molecules (as gpu_benchmark.py)")
    args = p.parse_args()
    platform = mm.Platform.getPlatformByName("OpenCL")
    builders = {"flexible_water": gpu_benchmark.flexible_scene, "drude_water": gpu_benchmark.drude_scene}
    data = {"command": " ".join(sys.argv), "openmm_version": mm.Platform.getOpenMMVersion(), "steps": args.steps,
            "precision": "mixed", "scenes": {}}
    sizes = {"flexible_water": args.flexible_sizes, "drude_water": args.drude_sizes}
    runs = [(f"{name}_{n}" if sizes[name] else name, name, n) for name in args.scenes for n in (sizes[name] or [None])]
    for key, name, molecules in runs:
        description, start, peers = builders[name](args.quick, None, molecules)
        records = {}
        for peer, step_fs, system, factory, _ in peers:
            gpu_benchmark.log(f"  {name}: counting {peer}")
            try:
                per_step = count_peer(platform, system, factory, start, args.steps)
            except mm.OpenMMException as error:
                records[peer] = {"available": False, "error": str(error)}
                continue
            records[peer] = {"available": True, "step_fs": step_fs, "per_step": per_step,
                             "per_ps": {key: value * 1000.0 / step_fs for key, value in per_step.items()}}
        data["scenes"][key] = {"system": description, "peers": records}
        rows = [[peer, r["step_fs"], r["per_step"]["launches"], r["per_step"]["blockingReads"],
                 r["per_step"]["blockingWrites"], r["per_step"]["reads"], r["per_step"]["writes"],
                 r["per_step"]["waits"], r["per_ps"]["launches"],
                 r["per_ps"]["blockingReads"] + r["per_ps"]["blockingWrites"]]
                for peer, r in records.items() if r["available"]]
        reporting.table(f"{key}: {description}, OpenCL mixed, per step after warm-up ({args.steps} steps)",
                        [("peer", max(len(peer) for peer in records), "s"), ("step fs", 8, ".3g"),
                         ("launches", 9, ".4g"), ("blk reads", 9, ".3g"), ("blk writes", 10, ".3g"),
                         ("reads", 6, ".3g"), ("writes", 6, ".3g"), ("waits", 6, ".3g"),
                         ("launches/ps", 11, ".4g"), ("blocking/ps", 11, ".4g")], rows)
    path = os.path.join(args.out, "opencl_call_counts.json")
    reporting.write_json(path, data, strict=False)
    print(f"\nwrote {path}")


if __name__ == "__main__":
    main()
