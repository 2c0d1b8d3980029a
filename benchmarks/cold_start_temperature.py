#!/usr/bin/env python3
"""The temperature of the Drude pairs' relative motion right after Context.setVelocitiesToTemperature(300 K), for the
SIM with and without a stiff-mode temperature (1 K) and for DrudeLangevinIntegrator (Drudes at 1 K): SWM4-NDP water
(--molecules, default 2,000; rigid, PME), its isotropic springs separated into the stiff group, CPU platform.  OpenMM
applies the rigid-water velocity constraints after the draw, which warms the relative motion a little for both.

    PYTHONPATH=build/python .venv/bin/python benchmarks/cold_start_temperature.py [--molecules N] [--seed S]
"""
import argparse

import numpy as np
import openmm
import openmm.app as app
import openmm.unit as unit

from openmmflavors import StochasticImpulseIntegrator

KB = unit.MOLAR_GAS_CONSTANT_R.value_in_unit(unit.kilojoule_per_mole / unit.kelvin)


def relative_temperature(system, positions, integrator, pairs, mass, seed):
    context = openmm.Context(system, integrator, openmm.Platform.getPlatformByName("CPU"))
    context.setPositions(positions)
    context.setVelocitiesToTemperature(300 * unit.kelvin, seed)
    v = context.getState(getVelocities=True).getVelocities(asNumpy=True).value_in_unit(unit.nanometer / unit.picosecond)
    drudes, cores = pairs[:, 0], pairs[:, 1]
    mu = (mass[drudes] * mass[cores] / (mass[drudes] + mass[cores]))[:, None]
    return float((mu * (v[drudes] - v[cores]) ** 2).sum() / (3 * len(drudes) * KB))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--molecules", type=int, default=2000)
    parser.add_argument("--seed", type=int, default=3)
    args = parser.parse_args()
    forcefield = app.ForceField("charmm_polar_2019.xml")
    modeller = app.Modeller(app.Topology(), [])
    modeller.addSolvent(app.ForceField("amber14/tip3p.xml"), model="tip3p", numAdded=args.molecules)
    modeller.addExtraParticles(forcefield)
    system = forcefield.createSystem(modeller.topology, nonbondedMethod=app.PME,
                                     nonbondedCutoff=0.8 * unit.nanometer, constraints=app.HBonds)
    for force in system.getForces():
        force.setForceGroup(0)
    StochasticImpulseIntegrator.separateDrudeSprings(system, 1)
    drude = next(f for f in system.getForces() if isinstance(f, openmm.DrudeForce))
    pairs = np.array([drude.getParticleParameters(i)[:2] for i in range(drude.getNumParticles())])
    mass = np.array([system.getParticleMass(i).value_in_unit(unit.dalton) for i in range(system.getNumParticles())])

    def sim(stiff_kelvin):
        integrator = StochasticImpulseIntegrator(300 * unit.kelvin, 5 / unit.picosecond, 2.5 * unit.femtoseconds, {1})
        if stiff_kelvin is not None:
            integrator.setStiffModeTemperature(stiff_kelvin * unit.kelvin)
        return integrator

    peers = [("SIM, stiff-mode temperature 1 K", sim(1.0)), ("SIM, no stiff-mode temperature", sim(None)),
             ("DrudeLangevin, Drudes at 1 K", openmm.DrudeLangevinIntegrator(
                 300 * unit.kelvin, 5 / unit.picosecond, 1 * unit.kelvin, 20 / unit.picosecond, 1 * unit.femtosecond))]
    for label, integrator in peers:
        t = relative_temperature(system, modeller.positions, integrator, pairs, mass, args.seed)
        print(f"{label}: {len(pairs)} Drude pairs, relative motion at {t:.2f} K")


if __name__ == "__main__":
    main()
