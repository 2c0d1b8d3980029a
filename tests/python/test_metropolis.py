"""setMetropolis / getAcceptanceRate from Python: the setting survives XmlSerializer, copy and pickle, the acceptance
rate is NaN before the first proposal and a fraction after, a scheme without a reversible proposal raises an
OpenMMException naming it when stepping, and the Context then steps once the setting is undone."""
import copy
import math
import pickle

import numpy as np
import openmm
import pytest

import openmmflavors  # noqa: F401
from conftest import PLATFORMS, build_fpu_system, fpu_positions, fpu_velocities
from openmmflavors import FlavorIntegrator, StochasticImpulseIntegrator


def adjusted_flavor():
    integrator = FlavorIntegrator(0.02, 0.002, 1 << 1)
    integrator.setScheme(FlavorIntegrator.Verlet)
    integrator.setTemperature(300)
    integrator.setFriction(1.0)
    integrator.setMetropolis(True)
    return integrator


def adjusted_sim():
    integrator = StochasticImpulseIntegrator(300, 1.0, 0.02, 1 << 1)
    integrator.setMetropolis(True)
    return integrator


def make_context(integrator, platform_name):
    context = openmm.Context(build_fpu_system(), integrator, openmm.Platform.getPlatformByName(platform_name))
    context.setPositions(fpu_positions())
    context.setVelocities(fpu_velocities())
    return context


@pytest.mark.parametrize("make", [adjusted_flavor, adjusted_sim])
def test_setting_survives_serialization_copy_and_pickle(make):
    integrator = make()
    for copied in (openmm.XmlSerializer.deserialize(openmm.XmlSerializer.serialize(integrator)),
                   copy.deepcopy(integrator), pickle.loads(pickle.dumps(integrator))):
        assert copied.getMetropolis()
    integrator.setMetropolis(False)
    assert not openmm.XmlSerializer.deserialize(openmm.XmlSerializer.serialize(integrator)).getMetropolis()


@pytest.mark.parametrize("platform_name", PLATFORMS)
@pytest.mark.parametrize("make", [adjusted_flavor, adjusted_sim])
def test_acceptance_rate_counts_proposals(make, platform_name):
    integrator = make()
    context = make_context(integrator, platform_name)
    assert math.isnan(integrator.getAcceptanceRate())
    integrator.step(200)
    rate = integrator.getAcceptanceRate()
    # A fraction of 200 proposals, some accepted.
    assert 0.0 < rate <= 1.0
    assert rate * 200 == pytest.approx(round(rate * 200), abs=1e-9)
    assert np.isfinite(context.getState(getEnergy=True).getPotentialEnergy()._value)


def test_acceptance_rate_needs_a_context():
    with pytest.raises(openmm.OpenMMException, match="not bound to a Context"):
        adjusted_sim().getAcceptanceRate()


@pytest.mark.parametrize("platform_name", PLATFORMS)
def test_irreversible_scheme_raises_and_context_stays_usable(platform_name):
    integrator = adjusted_flavor()
    context = make_context(integrator, platform_name)
    integrator.setScheme(FlavorIntegrator.SymplecticEuler)
    before = context.getState(getPositions=True).getPositions(asNumpy=True)
    with pytest.raises(openmm.OpenMMException, match="scheme = SymplecticEuler.*setMetropolis\\(false\\)"):
        integrator.step(1)
    after = context.getState(getPositions=True).getPositions(asNumpy=True)
    assert np.array_equal(before, after)
    integrator.setScheme(FlavorIntegrator.Verlet)
    integrator.step(3)
    assert integrator.getAcceptanceRate() >= 0.0


def test_describe_step_shows_the_proposal():
    assert adjusted_sim().describeStep().startswith("O(H/2) [K_S(H/2) E(H) K_S(H/2)]_MH O(H/2)")
