"""How often the SIM (Warped, Middle) blows up on NaCl in SWM4-NDP with Drude-2019 ions, with and without the hard
wall (StochasticImpulseIntegrator.setMaxDrudeDistance): independent starts, each equilibrated with DrudeLangevin at
0.5 fs, then a few ps of SIM per step size and wall setting; a run fails on a NaN energy, an exception, or a Drude
temperature above 10 K in any frame.

    PYTHONPATH=build/python .venv/bin/python examples/drude_ions/stability_probe.py [--seeds 1 2 3 4] \
        [--steps 2 2.5] [--walls 0 0.02] [--ps 3] [--max-warped-phase RAD] [--quick] [--out DIR]

Writes stability_probe.json to --out: per run its seed, step, wall, the step it failed at (or none), its hottest
Drude frame and how many steps the wall acted in (pairs found past it, counted from the frames)."""
import argparse
import json
import math
import os
import sys
import time

import numpy as np
import openmm
import openmm.unit as unit

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from drude_ions import SPRING_GROUP, Analysis, build, equilibrated, make_integrator  # noqa: E402
from openmmflavors import StochasticImpulseIntegrator  # noqa: E402


def probe(separated, state, analysis, step_fs, wall_nm, seed, ps, frames, max_warped_phase=0.0):
    integrator = make_integrator("WarpedMiddle", step_fs, seed, max_warped_phase)
    integrator.setMaxDrudeDistance(wall_nm)
    context = openmm.Context(separated, integrator, openmm.Platform.getPlatformByName("CPU"), {"Threads": "2"})
    context.setState(state)
    steps = int(round(ps * 1000 / step_fs))
    every = max(1, steps // frames)
    hottest, beyond, done = 0.0, 0, 0
    failure = None
    while done < steps:
        try:
            integrator.step(every)
        except openmm.OpenMMException as e:
            failure = f"step {done + every}: {str(e)[:120]}"
            break
        done += every
        st = context.getState(getPositions=True, getVelocities=True, getEnergy=True)
        energy = st.getPotentialEnergy().value_in_unit(unit.kilojoule_per_mole)
        _, t_drude = analysis.temperatures(st.getVelocities(asNumpy=True).value_in_unit(unit.nanometer / unit.picosecond))
        x = st.getPositions(asNumpy=True).value_in_unit(unit.nanometer)
        d = np.linalg.norm(analysis.displacements(x), axis=1)
        beyond += int(np.sum(d > 0.02))
        hottest = max(hottest, t_drude)
        if not math.isfinite(energy) or t_drude > 10.0:
            failure = f"step {done}: " + ("NaN energy" if not math.isfinite(energy) else f"Drude frame {t_drude:.1f} K")
            break
    return {"seed": seed, "step_fs": step_fs, "wall_nm": wall_nm, "failed": failure, "hottest_drude_K": hottest,
            "frames_pairs_beyond_0.02nm": beyond, "ps": done * step_fs / 1000}


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4])
    parser.add_argument("--steps", type=float, nargs="+", default=[2.0, 2.5])
    parser.add_argument("--walls", type=float, nargs="+", default=[0.0, 0.02], help="nm; 0 = no wall")
    parser.add_argument("--ps", type=float, default=3.0, help="ps of SIM per run")
    parser.add_argument("--max-warped-phase", type=float, default=0.0,
                        help="setMaxWarpedPhase of the SIM in radians (default 0: no limit)")
    parser.add_argument("--quick", action="store_true", help="a small, short run (smoke test)")
    parser.add_argument("--out", default=os.path.join("results", "drude_ions"))
    args = parser.parse_args()
    waters, pairs, cutoff, equilibrate_ps = (64, 2, 0.55, 0.05) if args.quick else (248, 4, 0.8, 1.0)
    if args.quick:
        args.seeds, args.steps, args.ps = args.seeds[:1], args.steps[:1], 0.05
    begin = time.time()
    runs = []
    for seed in args.seeds:
        system, topology, positions = build(waters, pairs, cutoff, seed)
        analysis = Analysis(system, topology)
        separated = openmm.XmlSerializer.deserialize(openmm.XmlSerializer.serialize(system))
        StochasticImpulseIntegrator.separateDrudeSprings(separated, SPRING_GROUP)
        state = equilibrated(system, positions, seed, equilibrate_ps, minimize=False)
        for step_fs in args.steps:
            for wall in args.walls:
                run = probe(separated, state, analysis, step_fs, wall, seed + 3, args.ps, 30, args.max_warped_phase)
                runs.append(run)
                print(f"seed {seed} H = {step_fs:g} fs wall {wall:g} nm: "
                      f"{run['failed'] or 'held'}; hottest Drude frame {run['hottest_drude_K']:.2f} K; "
                      f"pairs past 0.02 nm in frames: {run['frames_pairs_beyond_0.02nm']} "
                      f"({time.time() - begin:.0f} s)", file=sys.stderr, flush=True)
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "stability_probe.json"), "w") as f:
        json.dump({"args": vars(args), "runs": runs, "wall_s": time.time() - begin}, f, indent=1)
    print_summary(runs, args.steps, args.walls)


def print_summary(runs, steps, walls):
    """A Markdown table: per step and wall, how many runs held and how the others failed."""
    print("\n| step | wall | runs held | failures |")
    print("|---|---|---|---|")
    for step_fs in steps:
        for wall in walls:
            these = [r for r in runs if r["step_fs"] == step_fs and r["wall_nm"] == wall]
            held = sum(r["failed"] is None for r in these)
            fails = "; ".join(f"seed {r['seed'] - 3}: {r['failed']}" for r in these if r["failed"])
            print(f"| {step_fs:g} fs | {wall:g} nm | {held} of {len(these)} | {fails or '–'} |")


if __name__ == "__main__":
    main()
