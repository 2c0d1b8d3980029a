#!/usr/bin/env python3
"""The Warped phase limit the StochasticImpulseIntegrator chooses by itself (setMaxWarpedPhase(0), the default), and
how long choosing takes, on the three Drude systems this project runs: SWM4-NDP water (examples/drude_water, 256
molecules), the Drude-2019 dipeptide in 250 SWM4-NDP molecules (this scene) and villin in Drude-2019 water (OpenMM's
villin box, 14,789 particles), each after separateDrudeSprings where it has anisotropic Drudes, at 2 fs, CPU platform,
after a local energy minimization (500 iterations).
The choice is the largest soft stiffness r along the stiff modes in units of their own, by Lanczos iterations of
central differences of the soft forces, and the phase 2 arcsin(1 / sqrt(1 + r)); drude_coupling.py measures r from the
whole Hessian over the protein's Drude coordinates instead (villin 1.21, the dipeptide 0.54 at the built positions).

    PYTHONPATH=build/python .venv/bin/python examples/drude_protein/phase_choice.py [--systems water dipeptide villin]

Writes phase_choice.json to --out.
"""
import argparse
import json
import os
import sys
import time

import openmm
import openmm.unit as unit

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:0] = [HERE, os.path.join(HERE, "..", "drude_ions"), os.path.join(HERE, "..", "drude_water")]
from drude_coupling import villin_box  # noqa: E402
from drude_protein import SPRING_GROUP, build  # noqa: E402
from openmmflavors import StochasticImpulseIntegrator  # noqa: E402


def water():
    import drude_water
    system, _, positions, _ = drude_water.build_water(256)
    return system, positions, 1 << drude_water.DRUDE_GROUP


def protein(name):
    system, _, positions = villin_box() if name == "villin" else build(250, 0.8)
    StochasticImpulseIntegrator.separateDrudeSprings(system, SPRING_GROUP)
    return system, positions, 1 << SPRING_GROUP


def choose(system, positions, stiff_groups):
    integrator = StochasticImpulseIntegrator(300 * unit.kelvin, 5 / unit.picosecond, 2 * unit.femtosecond,
                                             stiff_groups)
    integrator.setSplitting(StochasticImpulseIntegrator.Warped)
    integrator.setThermostatPlacement(StochasticImpulseIntegrator.Middle)
    context = openmm.Context(system, integrator, openmm.Platform.getPlatformByName("CPU"))
    context.setPositions(positions)
    # As a run starts: minimized first (at the built positions, unrelaxed contacts read r ten times too high).
    openmm.LocalEnergyMinimizer.minimize(context, 10, 500)
    started = time.time()
    text = integrator.describeContext()
    return {"describe_seconds": time.time() - started,
            "line": next(line for line in text.splitlines() if line.startswith("Warped phase limit"))}


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--systems", nargs="+", default=["water", "dipeptide", "villin"],
                        choices=["water", "dipeptide", "villin"])
    parser.add_argument("--out", default=os.path.join(HERE, "..", "..", "results", "drude_protein"),
                        help="where phase_choice.json goes (this run's: examples/drude_protein/results)")
    args = parser.parse_args()
    results = {}
    for name in args.systems:
        system, positions, groups = water() if name == "water" else protein(name)
        results[name] = {"particles": system.getNumParticles(), **choose(system, positions, groups)}
        print(f"{name} ({results[name]['particles']} particles): {results[name]['line']}; describeContext() "
              f"{results[name]['describe_seconds']:.1f} s", flush=True)
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "phase_choice.json"), "w") as f:
        json.dump(results, f, indent=1)


if __name__ == "__main__":
    main()
