#!/usr/bin/env python3
"""Instructions per step of StochasticImpulseIntegrator (Filtered at H = 2 fs, Warped at 2.5 fs) against
DrudeLangevinIntegrator (1 fs) and VerletIntegrator (1 fs) on the drude_water system (256 SWM4-NDP molecules, rigid,
PME, CPU platform with one thread), counted by valgrind's callgrind: load-independent, unlike wall times on a shared
machine.

Each integrator is run from one saved state for 10 and for 40 steps in a child process under callgrind; the difference
over 30 steps is the cost of a step, split by function into: the nonbonded and PME forces, the neighbour list, the
integrator's own work (the openmm-flavors engine, or OpenMM's DrudeLangevin kernel and its random numbers), SETTLE,
and the rest.  The neighbour list is rebuilt when a particle has moved far enough, so its cost per simulated time does
not fall with a longer step: it is part of the price of any 2-fs step.

    PYTHONPATH=build/python .venv/bin/python benchmarks/drude_step_instructions.py [--out DIR]   # about 5 min

Needs valgrind (apt-get install valgrind).  Outputs: DIR/drude_step_instructions.json and .png (default
results/bench).
"""
import argparse
import json
import os
import subprocess
import sys

from flavorbench.callgrind import per_step, require_valgrind, scene_module

HERE = os.path.dirname(os.path.abspath(__file__))

# (label, integrator kind of drude_water.make_integrator or "Verlet", step in fs)
RUNS = [("DrudeLangevin 1 fs", "DrudeLangevin", 1.0), ("SIM Filtered 2 fs", "Filtered", 2.0),
        ("SIM Warped 2.5 fs", "Warped", 2.5), ("Verlet 1 fs", "Verlet", 1.0)]
STEPS = (10, 40)
CATEGORIES = ["nonbonded and PME forces", "neighbour list", "integrator", "SETTLE", "rest"]


def category(function):
    """The category of one function of callgrind_annotate's listing."""
    if "NeighborList" in function or "getNeighbors" in function:
        return "neighbour list"
    if "SETTLE" in function:
        return "SETTLE"
    if ("libOpenMMFlavors" in function or "DrudeLangevin" in function or "SFMT" in function
            or "getNormallyDistributedRandomNumber" in function):
        return "integrator"
    if "Nonbonded" in function or "pme" in function or "fftpack" in function or "libOpenMM.so" in function:
        return "nonbonded and PME forces"
    return "rest"


def child(kind, steps, state_dir):
    import openmm
    make_integrator = scene_module("drude_water").make_integrator
    with open(os.path.join(state_dir, "system.xml")) as f:
        system = openmm.XmlSerializer.deserialize(f.read())
    with open(os.path.join(state_dir, "state.xml")) as f:
        state = openmm.XmlSerializer.deserialize(f.read())
    step_fs = dict((k, h) for _, k, h in RUNS)[kind]
    integrator = (openmm.VerletIntegrator(step_fs * 1e-3) if kind == "Verlet" else make_integrator(kind, step_fs, 5))
    context = openmm.Context(system, integrator, openmm.Platform.getPlatformByName("CPU"), {"Threads": "1"})
    context.setState(state)
    integrator.step(2)
    integrator.step(steps)


def save_state(state_dir):
    import openmm
    drude_water = scene_module("drude_water")
    build_water, equilibrated_state = drude_water.build_water, drude_water.equilibrated_state
    system, _, positions, _ = build_water(256)
    state = equilibrated_state(system, positions, 1.0, 300, 1, threads=1)
    with open(os.path.join(state_dir, "system.xml"), "w") as f:
        f.write(openmm.XmlSerializer.serialize(system))
    with open(os.path.join(state_dir, "state.xml"), "w") as f:
        f.write(openmm.XmlSerializer.serialize(state))


def plot(data, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 3, figsize=(15, 5.2))
    labels = [run["label"] for run in data["runs"]]
    panels = ((axes[0], "per_step", CATEGORIES, "instructions per step (millions)", "(a) per step"),
              (axes[1], "per_step", CATEGORIES[1:], "instructions per step (millions)",
               "(b) per step, without the nonbonded and PME forces"),
              (axes[2], "per_fs", CATEGORIES, "instructions per simulated fs (millions)", "(c) per simulated fs"))
    colours = dict(zip(CATEGORIES, plt.rcParams["axes.prop_cycle"].by_key()["color"]))
    for ax, key, shown, ylabel, title in panels:
        bottom = [0.0] * len(labels)
        for name in shown:
            values = [run[key][name] / 1e6 for run in data["runs"]]
            ax.bar(labels, values, bottom=bottom, color=colours[name], label=name if ax is axes[0] else None)
            bottom = [b + v for b, v in zip(bottom, values)]
        for x, total in enumerate(bottom):
            ax.text(x, total, "%.2f" % total, ha="center", va="bottom", fontsize=9)
        ax.set_ylabel(ylabel)
        ax.set_title(title, fontsize=10)
        ax.set_ylim(0, max(bottom) * 1.12)
        ax.tick_params(axis="x", labelsize=8)
    fig.legend(loc="lower center", ncol=len(CATEGORIES), fontsize=9)
    fig.suptitle("SWM4-NDP water (256 molecules, PME), CPU platform with 1 thread: instructions of "
                 "SIM Filtered at H = 2 fs and Warped at 2.5 fs against DrudeLangevin and Verlet at 1 fs (callgrind)")
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    fig.savefig(path, dpi=110)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default=os.path.join(os.path.dirname(HERE), "results", "bench"))
    parser.add_argument("--replot", metavar="JSON", help="only redraw the chart of an earlier run's JSON into --out")
    parser.add_argument("--child", nargs=2, metavar=("KIND", "STEPS"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    state_dir = os.path.join(args.out, "drude_step_instructions")
    if args.replot:
        with open(args.replot) as f:
            plot(json.load(f), os.path.join(args.out, "drude_step_instructions.png"))
        return
    if args.child:
        child(args.child[0], int(args.child[1]), state_dir)
        return
    valgrind = require_valgrind(parser)
    os.makedirs(state_dir, exist_ok=True)
    print("saving an equilibrated state (300 DrudeLangevin steps)", file=sys.stderr, flush=True)
    save_state(state_dir)
    for label, kind, _ in RUNS:
        print("  callgrind: %s, %d and %d steps" % (label, STEPS[0], STEPS[1]), file=sys.stderr, flush=True)
        jobs = []
        for steps in STEPS:  # the two runs of one integrator side by side
            out_file = os.path.join(state_dir, "callgrind.%s.%d" % (kind, steps))
            command = [valgrind, "--tool=callgrind", "--callgrind-out-file=" + out_file, sys.executable,
                       os.path.abspath(__file__), "--out", args.out, "--child", kind, str(steps)]
            jobs.append(subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True))
        for steps, job in zip(STEPS, jobs):
            _, errors = job.communicate()
            if job.returncode != 0:
                sys.exit("callgrind run failed: %s, %d steps\n%s" % (label, steps, errors[-2000:]))
    runs = []
    for label, kind, step_fs in RUNS:
        functions = per_step(*(os.path.join(state_dir, "callgrind.%s.%d" % (kind, n)) for n in STEPS), STEPS)
        step_counts = dict.fromkeys(CATEGORIES, 0.0)
        top = []
        for function, difference in functions.items():
            step_counts[category(function)] += difference
            top.append((difference, function))
        top.sort(reverse=True)
        runs.append({"label": label, "step_fs": step_fs, "per_step": step_counts,
                     "per_fs": {k: v / step_fs for k, v in step_counts.items()},
                     "total_per_step": sum(step_counts.values()),
                     "top_functions": [{"function": f[:200], "per_step": d} for d, f in top[:25]]})
    reference = next(run for run in runs if run["label"].startswith("DrudeLangevin"))
    for run in runs:
        run["speedup_over_DrudeLangevin_1fs"] = (reference["total_per_step"] / reference["step_fs"]) / (
            run["total_per_step"] / run["step_fs"])
        print("%-20s %6.2fM per step  %6.2fM per fs  speedup over DrudeLangevin 1 fs %.3f  " % (
            run["label"], run["total_per_step"] / 1e6, run["total_per_step"] / run["step_fs"] / 1e6,
            run["speedup_over_DrudeLangevin_1fs"]) + "  ".join(
            "%s %.3fM" % (k, v / 1e6) for k, v in run["per_step"].items()))
    data = {"benchmark": "drude_step_instructions", "system": "256 SWM4-NDP molecules, rigid, PME",
            "platform": "CPU, 1 thread", "steps": STEPS, "runs": runs}
    with open(os.path.join(args.out, "drude_step_instructions.json"), "w") as f:
        json.dump(data, f, indent=1)
    plot(data, os.path.join(args.out, "drude_step_instructions.png"))
    print("wrote %s/drude_step_instructions.json and .png" % args.out, file=sys.stderr)


if __name__ == "__main__":
    main()
