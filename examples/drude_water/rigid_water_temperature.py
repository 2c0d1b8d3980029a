"""Does the Middle treatment of rigid molecules by itself cool them?  Rigid TIP3P water (256 molecules in the
drude_water scene's 2.17-nm box, PME with a 0.8-nm cutoff, 300 K at 5/ps, CPU platform, 1 thread) under OpenMM's
LangevinMiddleIntegrator and, with --integrators SIM, under StochasticImpulseIntegrator (Warped, Middle placement)
whose stiff group holds an empty HarmonicBondForce: no stiff component, every particle a zero mode, so its step is its
Middle free flow with SETTLE, the treatment the SWM4-NDP molecules get.  Three runs per step and integrator from one
equilibrated state, the kinetic temperature of the molecules (6 N - 3 degrees of freedom) every 0.1 ps after 1 ps;
mean over the runs ± its standard error.

    PYTHONPATH=build/python .venv/bin/python examples/drude_water/rigid_water_temperature.py [--steps 1 2 3 4] \\
        [--ps 4] [--integrators LangevinMiddle SIM] [--water tip4pew]

--water tip4pew takes TIP4P-Ew instead, whose massless M site is a virtual site as SWM4-NDP's is.
"""
import argparse
import math

import numpy as np
import openmm
import openmm.app as app
import openmm.unit as unit
from openmmflavors import StochasticImpulseIntegrator

R = 8.314462618e-3  # kJ/mol/K


def make_integrator(kind, step_fs, seed):
    if kind == "LangevinMiddle":
        integrator = openmm.LangevinMiddleIntegrator(300, 5, step_fs / 1000)
    else:
        integrator = StochasticImpulseIntegrator(300, 5, step_fs / 1000, {1})
        integrator.setSplitting(StochasticImpulseIntegrator.Warped)
        integrator.setThermostatPlacement(StochasticImpulseIntegrator.Middle)
        integrator.setMaxWarpedPhase(math.pi)  # Warped's own step, as measured here
    integrator.setRandomNumberSeed(seed)
    return integrator


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=float, nargs="+", default=[1.0, 2.0, 3.0, 4.0], help="steps in fs")
    parser.add_argument("--ps", type=float, default=4.0, help="ps sampled per run (default 4)")
    parser.add_argument("--integrators", nargs="+", choices=["LangevinMiddle", "SIM"], default=["LangevinMiddle"])
    parser.add_argument("--water", choices=["tip3p", "tip4pew"], default="tip3p",
                        help="tip4pew: with its massless M site, a virtual site as SWM4-NDP's (default tip3p)")
    args = parser.parse_args()
    forcefield = app.ForceField(f"amber14/{args.water}.xml")
    modeller = app.Modeller(app.Topology(), [])
    modeller.addSolvent(forcefield, model=args.water, boxSize=openmm.Vec3(2.17, 2.17, 2.17) * unit.nanometer)
    system = forcefield.createSystem(modeller.topology, nonbondedMethod=app.PME, nonbondedCutoff=0.8 * unit.nanometer,
                                     rigidWater=True)
    empty = openmm.HarmonicBondForce()
    empty.setForceGroup(1)
    system.addForce(empty)
    masses = np.array([system.getParticleMass(i).value_in_unit(unit.dalton) for i in range(system.getNumParticles())])
    dof = 6 * modeller.topology.getNumResidues() - 3
    platform = openmm.Platform.getPlatformByName("CPU")
    integrator = openmm.LangevinMiddleIntegrator(300, 5, 0.001)
    context = openmm.Context(system, integrator, platform, {"Threads": "1"})
    context.setPositions(modeller.positions)
    openmm.LocalEnergyMinimizer.minimize(context, 10, 300)
    context.setVelocitiesToTemperature(300, 1)
    integrator.step(2000)
    start = context.getState(getPositions=True, getVelocities=True)
    print("| integrator | step (fs) | T molecules (K) |\n|---|---|---|")
    for step_fs in args.steps:
        for kind in args.integrators:
            means = []
            for seed in (1, 2, 3):
                integrator = make_integrator(kind, step_fs, seed)
                context = openmm.Context(system, integrator, platform, {"Threads": "1"})
                context.setState(start)
                integrator.step(int(round(1000 / step_fs)))
                temperatures = []
                for _ in range(int(round(args.ps * 10))):
                    integrator.step(int(round(100 / step_fs)))
                    v = context.getState(getVelocities=True).getVelocities(asNumpy=True)
                    v = v.value_in_unit(unit.nanometer / unit.picosecond)
                    temperatures.append((masses[:, None] * v**2).sum() / (dof * R))
                means.append(np.mean(temperatures))
            error = np.std(means, ddof=1) / np.sqrt(len(means))
            print(f"| {kind} | {step_fs:g} | {np.mean(means):.1f} ± {error:.1f} |", flush=True)


if __name__ == "__main__":
    main()
