"""Friction and noise restricted to a list of particles, from Python."""
import copy
import pickle

import numpy as np
import openmm
import pytest

from openmmflavors import FlavorIntegrator


def free_particles(n):
    system = openmm.System()
    for _ in range(n):
        system.addParticle(1.0)
    zero = openmm.CustomExternalForce("0")
    zero.addParticle(0, [])
    zero.setForceGroup(1)
    system.addForce(zero)
    soft = openmm.CustomExternalForce("0")  # FLAVOR needs a soft force
    soft.addParticle(0, [])
    system.addForce(soft)
    return system


@pytest.mark.parametrize("platform_name", ["Reference", "CPU"])
def test_only_listed_particles_feel_friction(platform_name):
    integrator = FlavorIntegrator(0.01, 0.002, {1})
    integrator.setFriction(5.0)
    integrator.setTemperature(0.0)
    integrator.setFrictionParticles([0, 2])
    assert integrator.getFrictionParticles() == [0, 2]
    context = openmm.Context(free_particles(3), integrator, openmm.Platform.getPlatformByName(platform_name))
    context.setPositions([(0, 0, 0)] * 3)
    context.setVelocities([(1.0, 0, 0)] * 3)
    integrator.step(10)
    v = context.getState(getVelocities=True).getVelocities(asNumpy=True).value_in_unit(
        openmm.unit.nanometer / openmm.unit.picosecond)
    assert v[1, 0] == 1.0
    assert v[0, 0] == pytest.approx(np.exp(-5.0 * 0.1), rel=1e-12)
    assert v[2, 0] == pytest.approx(np.exp(-5.0 * 0.1), rel=1e-12)


def test_friction_particles_survive_copies_and_reject_bad_indices():
    integrator = FlavorIntegrator(0.01, 0.002, {1})
    integrator.setFrictionParticles([3, 1])
    for duplicate in (copy.copy(integrator), copy.deepcopy(integrator), pickle.loads(pickle.dumps(integrator))):
        assert duplicate.getFrictionParticles() == [3, 1]
    with pytest.raises(openmm.OpenMMException, match="frictionParticles.*-4"):
        integrator.setFrictionParticles([-4])
    assert integrator.getFrictionParticles() == [3, 1]
    with pytest.raises(openmm.OpenMMException, match="frictionParticles.*3.*< 2"):
        openmm.Context(free_particles(2), integrator, openmm.Platform.getPlatformByName("Reference"))
