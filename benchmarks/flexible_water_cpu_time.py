#!/usr/bin/env python3
"""CPU time per simulated picosecond on flexible water (examples/flexible_water: 501 TIP3P molecules, PME, CPU
platform): LangevinMiddleIntegrator at 2 fs against the artificial FLAVOR (ArtificialProjected, Middle placement,
O-H bonds and H-O-H angles frozen, tau = 0.5 fs) at delta = 6, 7 and 8 fs, with 1 and 2 threads.

Every peer starts from the same saved state (the one engine_step_instructions.py saves for its flexible_water scene;
made here if missing), runs --warmup ps, then --rounds interleaved rounds of --ps simulated ps each (the order
reversed every other round), so machine load falls on all peers alike.  The time is time.process_time() around
integrator.step(): the CPU time of the process, all its threads together.  Reported: CPU seconds per simulated ps and
the ratio of each FLAVOR to LangevinMiddle 2 fs at the same thread count.  To compare two builds, run this with each
(PYTHONPATH) in turn, twice alternating, and compare the ratios.

    PYTHONPATH=build/python .venv/bin/python benchmarks/flexible_water_cpu_time.py [--out DIR] [--threads 1 2]
        [--rounds 3] [--ps 0.12] [--warmup 0.03] [--label NAME]       # ~1 min

Output: a table on stdout and DIR/flexible_water_cpu_time[_LABEL].json (default results/bench).
"""
import argparse
import json
import os
import sys
import time
import warnings

from flavorbench import _config
from flavorbench.callgrind import scene_module

DELTAS = (6.0, 7.0, 8.0)


def start_state(path):
    """The flexible-water start state of engine_step_instructions.py, saved there if missing."""
    import openmm
    if not os.path.exists(path):
        sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
        import engine_step_instructions
        _, _, _, start = engine_step_instructions.make_flexible_water()
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, "w") as f:
            f.write(openmm.XmlSerializer.serialize(start()))
    with open(path) as f:
        return openmm.XmlSerializer.deserialize(f.read())


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default=os.path.join(_config.SOURCE_DIR, "results", "bench"))
    parser.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--ps", type=float, default=0.12, help="simulated ps per peer and round")
    parser.add_argument("--warmup", type=float, default=0.03, help="simulated ps per peer before the rounds")
    parser.add_argument("--label", default="", help="appended to the JSON file's name (e.g. the build)")
    args = parser.parse_args()
    import openmm
    # delta = 7 and 8 fs are beyond the mesosteps measured as accurate; here only their cost is measured.
    warnings.filterwarnings("ignore", message=".*longer than any mesostep measured as accurate.*")
    flexible_water = scene_module("flexible_water")
    forcefield, modeller = flexible_water.build_box(501)
    system = flexible_water.make_system(forcefield, modeller.topology, False)
    state = start_state(os.path.join(args.out, "engine_step_instructions", "flexible_water.state.xml"))
    peers = [flexible_water.langevin_peer(2.0)] + [
        flexible_water.flavor_peer("ArtificialProjected", delta, 0.5, True, True) for delta in DELTAS]
    results = {}
    for threads in args.threads:
        runs = []
        for name, _, factory, _ in peers:
            integrator = factory(5)
            context = openmm.Context(system, integrator, openmm.Platform.getPlatformByName("CPU"),
                                     {"Threads": str(threads)})
            context.setState(state)
            step_ps = integrator.getStepSize()._value
            integrator.step(max(1, int(round(args.warmup / step_ps))))
            runs.append({"name": name, "integrator": integrator, "context": context, "step_ps": step_ps,
                         "cpu_s": 0.0, "simulated_ps": 0.0})
        for r in range(args.rounds):
            for run in (runs if r % 2 == 0 else runs[::-1]):
                steps = max(1, int(round(args.ps / run["step_ps"])))
                begin = time.process_time()
                run["integrator"].step(steps)
                run["cpu_s"] += time.process_time() - begin
                run["simulated_ps"] += steps * run["step_ps"]
        reference = runs[0]["cpu_s"] / runs[0]["simulated_ps"]
        results[str(threads)] = []
        for run in runs:
            per_ps = run["cpu_s"] / run["simulated_ps"]
            results[str(threads)].append({"integrator": run["name"], "cpu_s_per_ps": per_ps,
                                          "ratio_to_langevin_2fs": per_ps / reference,
                                          "simulated_ps": run["simulated_ps"]})
            print("threads %d  %-58s %7.3f CPU s/ps  ratio %.3f" % (threads, run["name"], per_ps, per_ps / reference),
                  flush=True)
            del run["context"], run["integrator"]
    os.makedirs(args.out, exist_ok=True)
    path = os.path.join(args.out, "flexible_water_cpu_time%s.json" % ("_" + args.label if args.label else ""))
    with open(path, "w") as f:
        json.dump({"benchmark": "flexible_water_cpu_time", "rounds": args.rounds, "ps_per_round": args.ps,
                   "threads": results}, f, indent=1)
    print("wrote %s" % path, file=sys.stderr)


if __name__ == "__main__":
    main()
