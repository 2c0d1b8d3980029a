"""Quickstart: a box of flexible TIP3P water, its O-H bonds stiff, integrated by a Langevin artificial FLAVOR.

The O-H bond vibration (period ~9 fs) holds an ordinary integrator at ~0.5 fs.  Here the bonds (force group 1) are
integrated at full strength for a microstep tau = 0.5 fs in every mesostep delta = 2 fs and frozen (their lengths held,
their rates stored and restored) for the rest of it, while everything else (angles, PME electrostatics,
Lennard-Jones; group 0) acts over the whole mesostep.  The mean O-H length stays at flexible TIP3P's 0.0973 nm.

    PYTHONPATH=build/python /usr/bin/python3 examples/quickstart/quickstart.py [--steps N] [--waters N]
"""
import argparse

import numpy as np
import openmm
from openmm import app, unit

from openmmflavors import FlavorIntegrator

parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
parser.add_argument("--steps", type=int, default=2000, help="mesosteps to run (default 2000 = 4 ps)")
parser.add_argument("--waters", type=int, default=216)
parser.add_argument("--platform", default="CPU", choices=["CPU", "Reference"])
args = parser.parse_args()

# A small real System: flexible TIP3P water with PME, built by OpenMM's Modeller.
forcefield = app.ForceField("tip3p.xml")
modeller = app.Modeller(app.Topology(), [])
modeller.addSolvent(forcefield, model="tip3p", numAdded=args.waters)
system = forcefield.createSystem(modeller.topology, nonbondedMethod=app.PME, nonbondedCutoff=0.7 * unit.nanometer,
                                 rigidWater=False, constraints=None)

# Stiff and soft are chosen by force group: the O-H bonds in group 1, every other force in group 0.
for force in system.getForces():
    force.setForceGroup(1 if isinstance(force, openmm.HarmonicBondForce) else 0)

integrator = FlavorIntegrator(2 * unit.femtoseconds, 0.5 * unit.femtoseconds, {1})  # mesostep, microstep, stiff
integrator.setAveraging(FlavorIntegrator.ArtificialProjected)  # the stiff bonds frozen, not weakened, between microsteps
integrator.setTemperature(300 * unit.kelvin)  # a Langevin FLAVOR
integrator.setFriction(1 / unit.picosecond)
integrator.setRandomNumberSeed(2024)
context = openmm.Context(system, integrator, openmm.Platform.getPlatformByName(args.platform))
context.setPositions(modeller.positions)
openmm.LocalEnergyMinimizer.minimize(context, 10.0, 200)
context.setVelocitiesToTemperature(300 * unit.kelvin, 2024)

oxygens = [atom.index for atom in modeller.topology.atoms() if atom.element.symbol == "O"]
dof = 3 * system.getNumParticles() - 3  # flexible water, no constraints; the barycentre moves too, minus 3 is usual


def report():
    state = context.getState(getPositions=True, getEnergy=True)
    q = state.getPositions(asNumpy=True).value_in_unit(unit.nanometer)
    oh = np.concatenate([np.linalg.norm(q[[o + 1, o + 2]] - q[o], axis=1) for o in oxygens])
    kelvin = (2 * state.getKineticEnergy() / (dof * unit.MOLAR_GAS_CONSTANT_R)).value_in_unit(unit.kelvin)
    print(f"{state.getTime().value_in_unit(unit.picosecond):8.3f} {kelvin:10.1f} "
          f"{state.getPotentialEnergy().value_in_unit(unit.kilojoule_per_mole) / len(oxygens):14.2f} "
          f"{oh.mean():12.5f}")
    return kelvin, oh.mean()


print(f"{len(oxygens)} waters, {system.getNumParticles()} atoms, {args.platform} platform")
print(f"{'t (ps)':>8s} {'T (K)':>10s} {'PE/water (kJ/mol)':>14s} {'<r_OH> (nm)':>12s}")
report()
chunk = max(1, args.steps // 10)
for done in range(0, args.steps, chunk):
    integrator.step(min(chunk, args.steps - done))
    temperature, bond = report()
