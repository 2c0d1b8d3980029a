"""numpy scalars and arrays wherever the integrators take numbers, and numpy arrays from getStiffModeFrequencies."""
import numpy as np
import openmm
import pytest
from openmm import unit

from openmmflavors import FlavorIntegrator, StochasticImpulseIntegrator

INTEGER_TYPES = [np.int64, np.int32, np.int16, np.uint8]
FLOAT_TYPES = [np.float64, np.float32]


def spring_system():
    """Two particles on a zero-length stiff spring (group 1) and a soft tether (group 0)."""
    system = openmm.System()
    system.addParticle(1.0)
    system.addParticle(2.0)
    bond = openmm.HarmonicBondForce()
    bond.addBond(0, 1, 0.0, 1000.0)
    bond.setForceGroup(1)
    system.addForce(bond)
    tether = openmm.CustomExternalForce("x^2+y^2+z^2")
    tether.addParticle(0, [])
    tether.addParticle(1, [])
    system.addForce(tether)
    return system


@pytest.mark.parametrize("integer", INTEGER_TYPES)
def test_numpy_integers_as_stiff_groups(integer):
    assert FlavorIntegrator(0.01, 0.001, integer(2)).getStiffGroups() == 2
    assert FlavorIntegrator(0.01, 0.001, {integer(1)}).getStiffGroups() == 2
    assert FlavorIntegrator(0.01, 0.001, np.array([1, 3], dtype=integer)).getStiffGroups() == 10
    assert StochasticImpulseIntegrator(300, 1, 0.01, integer(2)).getStiffGroups() == 2
    sim = StochasticImpulseIntegrator(300, 1, 0.01, {integer(1)})
    assert sim.getStiffGroups() == 2
    sim.setStiffGroups({integer(0), integer(1)})
    assert sim.getStiffGroups() == 3
    flavor = FlavorIntegrator(0.01, 0.001, 2)
    flavor.setStiffGroups(integer(1))
    assert flavor.getStiffGroups() == 1


def test_numpy_booleans_are_not_group_numbers():
    with pytest.raises(ValueError, match="stiffGroups"):
        FlavorIntegrator(0.01, 0.001, {np.bool_(True)})


@pytest.mark.parametrize("real", FLOAT_TYPES)
def test_numpy_floats_wherever_floats_go(real):
    flavor = FlavorIntegrator(real(0.01), real(0.001), 2)
    assert flavor.getMesoStep() == float(real(0.01)) * unit.picosecond
    assert flavor.getMicroStep() == float(real(0.001)) * unit.picosecond
    flavor.setMesoStep(real(0.02))
    flavor.setStepSize(real(0.02))
    flavor.setMicroStep(real(0.002))
    flavor.setTemperature(real(310))
    flavor.setFriction(real(2))
    assert flavor.getMicroStep() == float(real(0.002)) * unit.picosecond
    assert flavor.getTemperature() == 310 * unit.kelvin
    assert flavor.getFriction() == 2 / unit.picosecond
    # Quantities whose values are numpy scalars.
    flavor.setMesoStep(real(20) * unit.femtosecond)
    assert flavor.getMesoStep().value_in_unit(unit.picosecond) == pytest.approx(0.02, rel=1e-6)

    sim = StochasticImpulseIntegrator(real(300), real(1), real(0.01), 2)
    assert sim.getTemperature() == 300 * unit.kelvin
    assert sim.getStepSize() == float(real(0.01)) * unit.picosecond
    sim.setStepSize(real(0.005))
    sim.setTemperature(real(250) * unit.kelvin)
    sim.setFriction(real(3))
    assert sim.getStepSize() == float(real(0.005)) * unit.picosecond
    assert sim.getTemperature() == 250 * unit.kelvin
    assert sim.getFriction() == 3 / unit.picosecond


@pytest.mark.parametrize("integer", INTEGER_TYPES)
def test_numpy_integers_wherever_integers_go(integer):
    flavor = FlavorIntegrator(0.01, 0.001, 2)
    flavor.setScheme(integer(FlavorIntegrator.SymplecticEuler))
    flavor.setRandomNumberSeed(integer(7))
    flavor.setFrictionParticles(np.array([0, 1], dtype=integer))
    flavor.setStiffFriction(np.bool_(True))
    assert flavor.getScheme() == FlavorIntegrator.SymplecticEuler
    assert flavor.getRandomNumberSeed() == 7
    assert flavor.getFrictionParticles() == [0, 1]
    assert flavor.getStiffFriction()
    flavor.setFrictionParticles([integer(1)])
    assert flavor.getFrictionParticles() == [1]
    sim = StochasticImpulseIntegrator(0, 0, 0.01, 2)
    sim.setSplitting(integer(StochasticImpulseIntegrator.LieTrotter))
    sim.setRandomNumberSeed(integer(9))
    assert sim.getSplitting() == StochasticImpulseIntegrator.LieTrotter
    assert sim.getRandomNumberSeed() == 9

    for integrator in (flavor, sim):
        integrator.setIntegrationForceGroups({integer(0), integer(1)})
        assert integrator.getIntegrationForceGroups() == 3
        context = openmm.Context(spring_system(), integrator, openmm.Platform.getPlatformByName("Reference"))
        context.setPositions([(0.1, 0, 0), (0.2, 0, 0)])
        integrator.step(integer(3))
        assert context.getState().getStepCount() == 3


def test_floats_are_not_integers():
    flavor = FlavorIntegrator(0.01, 0.001, 2)
    with pytest.raises(TypeError, match="randomNumberSeed"):
        flavor.setRandomNumberSeed(np.float64(3))
    with pytest.raises(TypeError, match="frictionParticles"):
        flavor.setFrictionParticles([0.5])


def test_stiff_mode_frequencies_are_a_quantity_wrapping_a_numpy_array():
    sim = StochasticImpulseIntegrator(0, 0, 0.01, {1})
    context = openmm.Context(spring_system(), sim, openmm.Platform.getPlatformByName("Reference"))
    context.setPositions([(0.1, 0, 0), (0.2, 0, 0)])
    w = sim.getStiffModeFrequencies()
    assert unit.is_quantity(w)
    values = w.value_in_unit(unit.picosecond**-1)
    assert isinstance(values, np.ndarray) and values.dtype == np.float64
    # Masses 1 and 2 on a spring of 1000 kJ/mol/nm^2: the centre of mass (w = 0) and the relative motion,
    # w^2 = k (1/m1 + 1/m2), three times each.
    expected = np.sqrt(1000.0 * (1 / 1.0 + 1 / 2.0))
    np.testing.assert_allclose(np.sort(values), [0.0] * 3 + [expected] * 3, rtol=1e-9, atol=1e-6)
    assert np.array(values).min() == pytest.approx(0.0, abs=1e-6)
    assert w.max() == pytest.approx(expected, rel=1e-9) / unit.picosecond
