"""Where the SIM's step ends on the polarizable peptide (examples/drude_protein), and why: independent starts, each
equilibrated with DrudeLangevin at 0.5 fs, then a few ps of SIM (Warped, Middle, the 0.02-nm wall) per step size, on the
System as it is and, with --thole-off, on one whose Thole-screened pairs have no dipole-dipole interaction left
(screening parameter a = 0: a diagnostic that changes the force field, not a setting to run).  A run fails on an
exception (the wall's check that no pair ends a step past twice the wall), a NaN energy or a Drude frame above 10 K.

    PYTHONPATH=build/python .venv/bin/python examples/drude_protein/step_limit_probe.py [--seeds 1 2] \
        [--steps 2 2.25 2.5] [--ps 3] [--thole-off] [--max-warped-phase RAD] [--quick] [--out DIR]

Writes step_limit_probe.json to --out and a Markdown table to stdout."""
import argparse
import json
import os
import sys
import time

import openmm

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:0] = [HERE, os.path.join(HERE, "..", "drude_ions")]
from drude_protein import PEPTIDE, SPRING_GROUP, Analysis, build, equilibrated  # noqa: E402
from openmmflavors import StochasticImpulseIntegrator  # noqa: E402
from stability_probe import print_summary, probe  # noqa: E402

WALL_NM = 0.02


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--steps", type=float, nargs="+", default=[2.0, 2.25, 2.5])
    parser.add_argument("--ps", type=float, default=3.0, help="ps of SIM per run")
    parser.add_argument("--thole-off", action="store_true", help="the screened pairs' interaction off (diagnostic)")
    parser.add_argument("--max-warped-phase", type=float, default=0.0,
                        help="setMaxWarpedPhase of the SIM in radians (default 0: no limit)")
    parser.add_argument("--quick", action="store_true", help="a small, short run (smoke test)")
    parser.add_argument("--out", default=os.path.join(HERE, "..", "..", "results", "drude_protein"))
    args = parser.parse_args()
    waters, cutoff, equilibrate_ps = (80, 0.55, 0.05) if args.quick else (250, 0.8, 0.5)
    if args.quick:
        args.seeds, args.steps, args.ps = args.seeds[:1], args.steps[:1], 0.05
    begin = time.time()
    system, topology, positions = build(waters, cutoff)
    analysis = Analysis(system, topology, solute=(PEPTIDE,))
    separated = openmm.XmlSerializer.deserialize(openmm.XmlSerializer.serialize(system))
    if args.thole_off:
        drude = next(f for f in separated.getForces() if isinstance(f, openmm.DrudeForce))
        for k in range(drude.getNumScreenedPairs()):
            first, second, _ = drude.getScreenedPairParameters(k)
            drude.setScreenedPairParameters(k, first, second, 0.0)
    StochasticImpulseIntegrator.separateDrudeSprings(separated, SPRING_GROUP)
    runs = []
    for seed in args.seeds:
        state = equilibrated(system, positions, seed, equilibrate_ps)
        for step_fs in args.steps:
            run = probe(separated, state, analysis, step_fs, WALL_NM, seed + 3, args.ps, 30, args.max_warped_phase)
            runs.append(run)
            print(f"seed {seed} H = {step_fs:g} fs: {run['failed'] or 'held'} ({time.time() - begin:.0f} s)",
                  file=sys.stderr, flush=True)
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "step_limit_probe.json"), "w") as f:
        json.dump({"args": vars(args), "runs": runs, "wall_s": time.time() - begin}, f, indent=1)
    print_summary(runs, args.steps, [WALL_NM])


if __name__ == "__main__":
    main()
