"""Rewinding a Context with loadCheckpoint repeats its steps bit for bit (Reference platform, PME water).

On the CPU platform OpenMM's nonbonded kernels sum forces in an order that depends on how threads share the work, so
no integrator repeats a PME trajectory there, OpenMM's own included; the C++ test
StoredTrajectories.EverySchemeRewoundByLoadCheckpointRepeatsItsStepsBitForBit covers both platforms on Systems whose
forces every platform computes deterministically.
"""
import numpy as np
import openmm
import openmm.app as app
import openmm.unit as unit
import pytest

from conftest import protein_recipe_flavor
from openmmflavors import FlavorIntegrator


@pytest.fixture(scope="module")
def water():
    forcefield = app.ForceField("tip3p.xml")
    modeller = app.Modeller(app.Topology(), [])
    modeller.addSolvent(forcefield, model="tip3p", numAdded=60)
    system = forcefield.createSystem(modeller.topology, nonbondedMethod=app.PME, nonbondedCutoff=0.6 * unit.nanometer,
                                     rigidWater=False, constraints=None)
    for force in system.getForces():
        force.setForceGroup(1 if isinstance(force, (openmm.HarmonicBondForce, openmm.HarmonicAngleForce)) else 0)
    return system, modeller.positions


def artificial_flavor():
    return protein_recipe_flavor(seed=5)


def nonintrusive_flavor():
    integrator = FlavorIntegrator(1 * unit.femtoseconds, 0.25 * unit.femtoseconds, {1})
    integrator.setTemperature(300 * unit.kelvin)
    integrator.setFriction(1 / unit.picosecond)
    integrator.setRandomNumberSeed(5)
    return integrator


@pytest.mark.parametrize("make", [artificial_flavor, nonintrusive_flavor])
def test_rewinding_with_load_checkpoint_repeats_the_steps_bit_for_bit(water, make):
    system, positions = water
    integrator = make()
    context = openmm.Context(system, integrator, openmm.Platform.getPlatformByName("Reference"))
    context.setPositions(positions)
    openmm.LocalEnergyMinimizer.minimize(context, 10, 50)
    context.setVelocitiesToTemperature(300 * unit.kelvin, 3)
    integrator.step(5)
    checkpoint = context.createCheckpoint()
    integrator.step(20)
    first = context.getState(getPositions=True, getVelocities=True)
    context.loadCheckpoint(checkpoint)
    integrator.step(20)
    again = context.getState(getPositions=True, getVelocities=True)
    assert np.array_equal(first.getPositions(asNumpy=True)._value, again.getPositions(asNumpy=True)._value)
    assert np.array_equal(first.getVelocities(asNumpy=True)._value, again.getVelocities(asNumpy=True)._value)
