"""The stiff modes' own bath, the Filtered and Warped splittings, the Warped phase limit, the hard wall and the
thermostat placement from Python: Quantities in and out, defaults that follow the integrator, rejected values that
leave the old ones, and XmlSerializer round trips."""
import math

import conftest
import openmm
import openmm.unit as unit
import pytest

from openmmflavors import StochasticImpulseIntegrator

PER_PS = unit.picosecond**-1


def test_defaults_follow_the_integrator():
    integrator = StochasticImpulseIntegrator(300.0, 5.0, 0.002, {1})
    assert integrator.getStiffModeTemperature() == 300.0 * unit.kelvin
    assert integrator.getStiffModeFriction() == 5.0 * PER_PS
    assert not integrator.hasStiffModeTemperature() and not integrator.hasStiffModeFriction()
    integrator.setTemperature(280.0)
    integrator.setFriction(2.0)
    assert integrator.getStiffModeTemperature() == 280.0 * unit.kelvin
    assert integrator.getStiffModeFriction() == 2.0 * PER_PS


def test_setters_take_quantities_and_getters_return_them():
    integrator = StochasticImpulseIntegrator(300.0, 5.0, 0.002, {1})
    integrator.setStiffModeTemperature(1.0 * unit.kelvin)
    integrator.setStiffModeFriction(0.02 / unit.femtosecond)
    temperature, friction = integrator.getStiffModeTemperature(), integrator.getStiffModeFriction()
    assert unit.is_quantity(temperature) and temperature.value_in_unit(unit.kelvin) == 1.0
    assert unit.is_quantity(friction) and friction.value_in_unit(PER_PS) == pytest.approx(20.0, rel=1e-15)
    integrator.setStiffModeFriction(7.0)
    assert integrator.getStiffModeFriction().value_in_unit(PER_PS) == 7.0
    with pytest.raises(TypeError, match="stiffModeTemperature"):
        integrator.setStiffModeTemperature(1.0 * unit.picosecond)


@pytest.mark.parametrize("setter, value, parameter, text", [
    ("setStiffModeTemperature", -2.0, "stiffModeTemperature", "-2"),
    ("setStiffModeTemperature", math.nan, "stiffModeTemperature", "nan"),
    ("setStiffModeFriction", -1.0, "stiffModeFriction", "-1"),
    ("setStiffModeFriction", math.inf, "stiffModeFriction", "inf"),
])
def test_bad_values_are_rejected_and_the_old_ones_kept(setter, value, parameter, text):
    integrator = StochasticImpulseIntegrator(300.0, 5.0, 0.002, {1})
    integrator.setStiffModeTemperature(1.0)
    integrator.setStiffModeFriction(20.0)
    with pytest.raises(openmm.OpenMMException, match=f"{parameter} = {text}"):
        getattr(integrator, setter)(value)
    assert integrator.getStiffModeTemperature() == 1.0 * unit.kelvin
    assert integrator.getStiffModeFriction() == 20.0 * PER_PS


def test_xml_round_trip_keeps_the_bath():
    integrator = StochasticImpulseIntegrator(300.0, 5.0, 0.002, {1})
    integrator.setStiffModeTemperature(1.0)
    integrator.setStiffModeFriction(20.0)
    copy = openmm.XmlSerializer.deserialize(openmm.XmlSerializer.serialize(integrator))
    assert isinstance(copy, StochasticImpulseIntegrator)
    assert copy.getStiffModeTemperature() == 1.0 * unit.kelvin
    assert copy.getStiffModeFriction() == 20.0 * PER_PS
    plain = openmm.XmlSerializer.deserialize(
        openmm.XmlSerializer.serialize(StochasticImpulseIntegrator(300.0, 5.0, 0.002, {1})))
    assert not plain.hasStiffModeTemperature() and not plain.hasStiffModeFriction()


@pytest.mark.parametrize("name, value", [("Filtered", 3), ("Warped", 4)])
def test_bias_free_splittings_are_exposed_and_serialized(name, value):
    splitting = getattr(StochasticImpulseIntegrator, name)
    assert splitting == value
    integrator = StochasticImpulseIntegrator(300.0, 5.0, 0.002, {1})
    integrator.setSplitting(splitting)
    copy = openmm.XmlSerializer.deserialize(openmm.XmlSerializer.serialize(integrator))
    assert copy.getSplitting() == splitting


def test_an_unknown_splitting_names_every_allowed_one():
    integrator = StochasticImpulseIntegrator(300.0, 5.0, 0.002, {1})
    integrator.setSplitting(StochasticImpulseIntegrator.Warped)
    with pytest.raises(openmm.OpenMMException, match="splitting = 5.*Filtered \\(3\\) or Warped \\(4\\)"):
        integrator.setSplitting(5)
    assert integrator.getSplitting() == StochasticImpulseIntegrator.Warped


def test_thermostat_placement_is_exposed_checked_and_serialized():
    integrator = StochasticImpulseIntegrator(300.0, 5.0, 0.002, {1})
    assert (StochasticImpulseIntegrator.Throughout, StochasticImpulseIntegrator.Middle) == (0, 1)
    assert integrator.getThermostatPlacement() == StochasticImpulseIntegrator.Throughout
    integrator.setSplitting(StochasticImpulseIntegrator.Warped)
    integrator.setThermostatPlacement(StochasticImpulseIntegrator.Middle)
    copy = openmm.XmlSerializer.deserialize(openmm.XmlSerializer.serialize(integrator))
    assert copy.getThermostatPlacement() == StochasticImpulseIntegrator.Middle
    assert copy.getSplitting() == StochasticImpulseIntegrator.Warped
    with pytest.raises(openmm.OpenMMException, match="thermostatPlacement = 2"):
        integrator.setThermostatPlacement(2)
    assert integrator.getThermostatPlacement() == StochasticImpulseIntegrator.Middle


def test_version_2_xml_loads_with_the_thermostat_throughout():
    integrator = StochasticImpulseIntegrator(300.0, 5.0, 0.002, {1})
    integrator.setSplitting(StochasticImpulseIntegrator.Warped)
    xml = openmm.XmlSerializer.serialize(integrator)
    old = xml.replace('version="3"', 'version="2"').replace(' thermostatPlacement="0"', '')
    assert 'version="2"' in old and "thermostatPlacement" not in old
    copy = openmm.XmlSerializer.deserialize(old)
    assert copy.getThermostatPlacement() == StochasticImpulseIntegrator.Throughout


@pytest.mark.parametrize("configure, message", [
    (lambda i: i.setThermostatPlacement(StochasticImpulseIntegrator.Middle), r"thermostatPlacement = Middle \(1\)"),
    (lambda i: i.setMaxWarpedPhase(2.05), r"maxWarpedPhase = 2.05 is not allowed with splitting = 1"),
    (lambda i: i.setWarpedFrictionScaling(True), r"warpedFrictionScaling = true is not allowed with splitting = 1"),
])
def test_settings_strang_lacks_are_rejected_when_stepping_and_the_context_stays_usable(configure, message):
    integrator = StochasticImpulseIntegrator(300.0, 5.0, 0.002, {conftest.STIFF_GROUP})
    configure(integrator)
    context = openmm.Context(conftest.build_fpu_system(), integrator, openmm.Platform.getPlatformByName("Reference"))
    context.setPositions(conftest.fpu_positions())
    with pytest.raises(openmm.OpenMMException, match=message):
        integrator.step(1)
    assert context.getState().getStepCount() == 0
    integrator.setSplitting(StochasticImpulseIntegrator.Warped)
    integrator.step(2)
    assert context.getState().getStepCount() == 2


def test_the_warped_phase_limit_takes_radians_is_checked_and_serialized():
    integrator = StochasticImpulseIntegrator(300.0, 5.0, 0.003, {conftest.STIFF_GROUP})
    assert integrator.getMaxWarpedPhase() == 0.0 * unit.radian
    integrator.setMaxWarpedPhase(2.05)
    assert integrator.getMaxWarpedPhase() == 2.05 * unit.radian
    integrator.setMaxWarpedPhase(90 * unit.degree)
    assert integrator.getMaxWarpedPhase().value_in_unit(unit.radian) == pytest.approx(math.pi / 2, rel=1e-15)
    with pytest.raises(openmm.OpenMMException, match="maxWarpedPhase = 4 is not allowed.*between 0 and pi"):
        integrator.setMaxWarpedPhase(4.0)
    with pytest.raises(TypeError, match="maxWarpedPhase"):
        integrator.setMaxWarpedPhase(1.0 * unit.nanometer)
    assert integrator.getMaxWarpedPhase().value_in_unit(unit.radian) == pytest.approx(math.pi / 2, rel=1e-15)
    integrator.setMaxWarpedPhase(2.05)
    copy = openmm.XmlSerializer.deserialize(openmm.XmlSerializer.serialize(integrator))
    assert copy.getMaxWarpedPhase() == 2.05 * unit.radian
    integrator.setSplitting(StochasticImpulseIntegrator.Warped)
    assert "ω̃H ≤ 2.05" in integrator.describeStep()


def test_the_warped_friction_scaling_is_a_bool_serialized_and_described():
    integrator = StochasticImpulseIntegrator(300.0, 5.0, 0.003, {conftest.STIFF_GROUP})
    assert integrator.getWarpedFrictionScaling() is False
    with pytest.raises(TypeError, match="setWarpedFrictionScaling"):
        integrator.setWarpedFrictionScaling(1.0 / unit.picosecond)
    integrator.setWarpedFrictionScaling(True)
    assert integrator.getWarpedFrictionScaling() is True
    copy = openmm.XmlSerializer.deserialize(openmm.XmlSerializer.serialize(integrator))
    assert copy.getWarpedFrictionScaling() is True
    integrator.setSplitting(StochasticImpulseIntegrator.Warped)
    assert "stiff friction scaled" in integrator.describeStep()


def test_the_hard_wall_takes_lengths():
    integrator = StochasticImpulseIntegrator(300.0, 5.0, 0.002, {1})
    integrator.setMaxDrudeDistance(0.2 * unit.angstrom)
    assert integrator.getMaxDrudeDistance().value_in_unit(unit.nanometer) == pytest.approx(0.02, rel=1e-15)
    integrator.setMaxDrudeDistance(0.03)
    assert integrator.getMaxDrudeDistance() == 0.03 * unit.nanometer
    with pytest.raises(TypeError, match="maxDrudeDistance"):
        integrator.setMaxDrudeDistance(1.0 * unit.picosecond)
