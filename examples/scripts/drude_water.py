"""Polarizable water with StochasticImpulseIntegrator: 256 SWM4-NDP molecules (OpenMM's swm4ndp.xml, rigid, PME),
the Drude springs integrated exactly, cold, in 2.5-fs steps (Warped splitting, Middle placement).

    PYTHONPATH=build/python .venv/bin/python examples/scripts/drude_water.py [--steps N] [--quick]
"""
import argparse

import numpy as np
import openmm
from openmm import app, unit
from openmmflavors import StochasticImpulseIntegrator

parser = argparse.ArgumentParser(description=__doc__)
parser.add_argument("--steps", type=int, default=4000, help="steps of 2.5 fs (default 4000)")
parser.add_argument("--quick", action="store_true", help="a smoke run of a few seconds (make test runs it)")
args = parser.parse_args()
steps, equilibration = (20, 20) if args.quick else (args.steps, 400)

forcefield = app.ForceField("swm4ndp.xml")
modeller = app.Modeller(app.Topology(), [])
modeller.addSolvent(app.ForceField("tip3p.xml"), model="tip3p", numAdded=256, neutralize=False)  # a water box
# addSolvent leaves room at the faces (256 waters in a 2.07-nm box, 0.87 g/cm³): move each molecule with its
# oxygen into the box that holds them at water's density at 300 K, 0.9965 g/cm³.
edge = (256 * 18.0153 / (0.9965 * 602.214)) ** (1 / 3)  # nm
old = modeller.topology.getPeriodicBoxVectors()[0][0].value_in_unit(unit.nanometer)
xyz = np.array(modeller.positions.value_in_unit(unit.nanometer)).reshape(-1, 3, 3)  # O, H, H per molecule
xyz += (xyz[:, :1] % old) * (edge / old) - xyz[:, :1]
modeller.topology.setPeriodicBoxVectors(np.eye(3) * edge * unit.nanometer)
modeller.positions = [openmm.Vec3(*p) for p in xyz.reshape(-1, 3)] * unit.nanometer
modeller.addExtraParticles(forcefield)                          # with SWM4-NDP's M sites and Drude particles
system = forcefield.createSystem(modeller.topology, nonbondedMethod=app.PME, nonbondedCutoff=0.8*unit.nanometer,
                                 constraints=app.HBonds, rigidWater=True)
# Stiff: the Drude springs (DrudeForce, exactly quadratic without Thole pairs) in group 1. Soft: everything else.
for force in system.getForces():
    force.setForceGroup(1 if isinstance(force, openmm.DrudeForce) else 0)

integrator = StochasticImpulseIntegrator(300*unit.kelvin, 5/unit.picosecond, 2.5*unit.femtoseconds, {1})
integrator.setSplitting(StochasticImpulseIntegrator.Warped)
integrator.setThermostatPlacement(StochasticImpulseIntegrator.Middle)
integrator.setStiffModeTemperature(1*unit.kelvin)               # the Drudes' own bath, as DrudeLangevinIntegrator's
integrator.setStiffModeFriction(20/unit.picosecond)
simulation = app.Simulation(modeller.topology, system, integrator, openmm.Platform.getPlatformByName("CPU"))
simulation.context.setPositions(modeller.positions)
simulation.minimizeEnergy(maxIterations=500)                    # the moved molecules' close contacts relaxed
simulation.context.setVelocitiesToTemperature(300*unit.kelvin)
simulation.step(equilibration)                                  # 1 ps to 300 K, the Drudes to 1 K
omega = integrator.getStiffModeFrequencies().value_in_unit(unit.picosecond**-1).max()
print(f"stiffest Drude mode {omega:.0f}/ps, omega*H = {omega * 0.0025:.2f} (keep it away from multiples of pi)")

# Temperatures of the molecules (each core-Drude pair at its centre of mass: 6 degrees of freedom per rigid
# molecule) and of the Drudes' motion relative to their cores.
drude = next(f for f in system.getForces() if isinstance(f, openmm.DrudeForce))
pairs = np.array([drude.getParticleParameters(i)[:2] for i in range(drude.getNumParticles())])  # (Drude, core)
mass = np.array([system.getParticleMass(i).value_in_unit(unit.dalton) for i in range(system.getNumParticles())])
reduced = mass[pairs[:, 0]] * mass[pairs[:, 1]] / (mass[pairs[:, 0]] + mass[pairs[:, 1]])
R = unit.MOLAR_GAS_CONSTANT_R.value_in_unit(unit.kilojoule_per_mole / unit.kelvin)
print("time (ps)  T molecules (K)  T Drudes (K)  PE per molecule (kJ/mol)")
for _ in range(10):
    simulation.step(max(1, steps // 10))
    state = simulation.context.getState(getVelocities=True, getEnergy=True)
    v = state.getVelocities(asNumpy=True).value_in_unit(unit.nanometer / unit.picosecond)
    kinetic = 0.5 * np.sum(mass[:, None] * v**2)
    relative = 0.5 * np.sum(reduced[:, None] * (v[pairs[:, 0]] - v[pairs[:, 1]])**2)
    t_molecules = 2 * (kinetic - relative) / ((6 * len(pairs) - 3) * R)  # less the 3 of the removed momentum
    t_drudes = 2 * relative / (3 * len(pairs) * R)
    pe = state.getPotentialEnergy().value_in_unit(unit.kilojoule_per_mole) / len(pairs)
    print(f"{state.getTime().value_in_unit(unit.picosecond):9.3f} {t_molecules:16.1f} {t_drudes:13.2f} {pe:25.2f}")
