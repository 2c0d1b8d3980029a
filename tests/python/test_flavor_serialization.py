"""XmlSerializer, copy and pickle give back a FlavorIntegrator with every parameter, and the copy integrates
exactly like the original."""
import copy
import pickle
import re

import numpy as np
import openmm
import openmm.unit as unit
import pytest

from conftest import build_fpu_system, make_context, run_trajectory
from openmmflavors import FlavorIntegrator


def xml_round_trip(integrator):
    return openmm.XmlSerializer.deserialize(openmm.XmlSerializer.serialize(integrator))


def pickle_round_trip(integrator):
    return pickle.loads(pickle.dumps(integrator))


COPIERS = {
    "xml": xml_round_trip,
    "copy": copy.copy,
    "deepcopy": copy.deepcopy,
    "pickle": pickle_round_trip,
    "clone": openmm.XmlSerializer.clone,
}


def non_default_integrator():
    integrator = FlavorIntegrator(0.0173 * unit.picosecond, 1.37 * unit.femtosecond, {1, 3, 31})
    integrator.setScheme(FlavorIntegrator.SymplecticEuler)
    integrator.setTemperature(287.25 * unit.kelvin)
    integrator.setFriction(3.75 / unit.picosecond)
    integrator.setStiffFriction(True)
    integrator.setRandomNumberSeed(918273)
    integrator.setConstraintTolerance(3.5e-7)
    integrator.setIntegrationForceGroups({0, 1, 3, 31})
    integrator.setAveraging(FlavorIntegrator.ArtificialProjected)
    integrator.setExactFastFlow(True)
    integrator.setThermostatPlacement(FlavorIntegrator.Middle)
    integrator.addFrozenDistance(4, 9)
    integrator.addFrozenDistance(2, 1)
    return integrator


def all_parameters(integrator):
    return {
        "mesoStep": integrator.getMesoStep().value_in_unit(unit.picosecond),
        "stepSize": integrator.getStepSize().value_in_unit(unit.picosecond),
        "microStep": integrator.getMicroStep().value_in_unit(unit.picosecond),
        "stiffGroups": integrator.getStiffGroups(),
        "scheme": integrator.getScheme(),
        "temperature": integrator.getTemperature().value_in_unit(unit.kelvin),
        "friction": integrator.getFriction().value_in_unit(unit.picosecond**-1),
        "stiffFriction": integrator.getStiffFriction(),
        "randomSeed": integrator.getRandomNumberSeed(),
        "constraintTolerance": integrator.getConstraintTolerance(),
        "integrationForceGroups": integrator.getIntegrationForceGroups(),
        "averaging": integrator.getAveraging(),
        "exactFastFlow": integrator.getExactFastFlow(),
        "thermostatPlacement": integrator.getThermostatPlacement(),
        "frozenDistances": [list(integrator.getFrozenDistance(i)) for i in range(integrator.getNumFrozenDistances())],
    }


@pytest.mark.parametrize("copier", list(COPIERS), ids=list(COPIERS))
def test_copy_is_a_flavor_integrator_with_every_parameter(copier):
    original = non_default_integrator()
    expected = all_parameters(original)
    # Guard against a test that would pass on defaults.
    defaults = all_parameters(FlavorIntegrator(0.01, 0.001, 2))
    assert all(expected[key] != defaults[key] for key in expected)

    duplicate = COPIERS[copier](original)
    assert isinstance(duplicate, FlavorIntegrator)
    assert duplicate is not original
    # Exact equality: the XML must carry every double at full precision.
    assert all_parameters(duplicate) == expected
    assert duplicate.getStiffGroups() == -2**31 + 0b1010


@pytest.mark.parametrize("copier", list(COPIERS), ids=list(COPIERS))
def test_copy_of_default_integrator(copier):
    original = FlavorIntegrator(2 * unit.femtosecond, 2 * unit.femtosecond, {1})
    duplicate = COPIERS[copier](original)
    assert isinstance(duplicate, FlavorIntegrator)
    assert all_parameters(duplicate) == all_parameters(original)
    assert duplicate.getScheme() == FlavorIntegrator.Verlet


def test_copy_is_independent_of_original():
    original = non_default_integrator()
    duplicate = copy.deepcopy(original)
    duplicate.setMicroStep(0.002)
    duplicate.setTemperature(10.0)
    duplicate.setScheme(FlavorIntegrator.Verlet)
    assert original.getMicroStep().value_in_unit(unit.picosecond) == pytest.approx(0.00137, rel=1e-15)
    assert original.getTemperature().value_in_unit(unit.kelvin) == 287.25
    assert original.getScheme() == FlavorIntegrator.SymplecticEuler


def test_serialized_xml_names_the_integrator():
    text = openmm.XmlSerializer.serialize(non_default_integrator())
    assert 'type="FlavorIntegrator"' in text


def test_xml_with_unknown_version_is_rejected():
    text = openmm.XmlSerializer.serialize(non_default_integrator())
    assert 'version="3"' in text
    with pytest.raises(openmm.OpenMMException, match="version"):
        openmm.XmlSerializer.deserialize(text.replace('version="3"', 'version="99"'))


def test_version_1_xml_loads_as_the_nonintrusive_flavor():
    # Version 1 had no averaging: written here as that version wrote it, every other parameter kept.
    text = openmm.XmlSerializer.serialize(non_default_integrator())
    old = (text.replace('version="3"', 'version="1"').replace(' averaging="2"', '')
           .replace(' exactFastFlow="1"', '').replace(' thermostatPlacement="1"', ''))
    old = re.sub(r"<FrozenDistances>.*</FrozenDistances>", "", old, flags=re.S)
    assert "averaging" not in old and "exactFastFlow" not in old and "FrozenDistances" not in old
    integrator = openmm.XmlSerializer.deserialize(old)
    assert isinstance(integrator, FlavorIntegrator)
    assert integrator.getAveraging() == FlavorIntegrator.Nonintrusive
    assert not integrator.getExactFastFlow()
    expected = all_parameters(non_default_integrator())
    expected.update(averaging=FlavorIntegrator.Nonintrusive, exactFastFlow=False, frozenDistances=[],
                    thermostatPlacement=FlavorIntegrator.Edges)
    assert all_parameters(integrator) == expected


def test_version_2_xml_loads_with_the_thermostat_at_the_edges():
    # Version 2 had no thermostat placement: its Langevin steps put the thermostat at the edges of the mesostep.
    text = openmm.XmlSerializer.serialize(non_default_integrator())
    old = text.replace('version="3"', 'version="2"').replace(' thermostatPlacement="1"', '')
    assert "thermostatPlacement" not in old
    integrator = openmm.XmlSerializer.deserialize(old)
    expected = all_parameters(non_default_integrator())
    expected.update(thermostatPlacement=FlavorIntegrator.Edges)
    assert all_parameters(integrator) == expected


def test_xml_with_invalid_parameter_is_rejected():
    text = openmm.XmlSerializer.serialize(non_default_integrator())
    with pytest.raises(openmm.OpenMMException, match="stiffGroups"):
        openmm.XmlSerializer.deserialize(text.replace('stiffGroups="-2147483638"', 'stiffGroups="0"'))


def test_deserialized_integrator_can_be_serialized_again():
    original = non_default_integrator()
    text = openmm.XmlSerializer.serialize(original)
    again = openmm.XmlSerializer.serialize(xml_round_trip(original))
    assert again == text


TRAJECTORY_CASES = {
    "hamiltonian-verlet": dict(scheme=FlavorIntegrator.Verlet),
    "hamiltonian-euler": dict(scheme=FlavorIntegrator.SymplecticEuler),
    "langevin": dict(scheme=FlavorIntegrator.Verlet, temperature=300.0, friction=5.0, seed=4242),
    "langevin-stiff-friction": dict(scheme=FlavorIntegrator.SymplecticEuler, temperature=300.0, friction=5.0,
                                    seed=77, stiffFriction=True),
}


def trajectory_integrator(case):
    options = TRAJECTORY_CASES[case]
    integrator = FlavorIntegrator(0.02, 0.002, {1})
    integrator.setScheme(options["scheme"])
    if "temperature" in options:
        integrator.setTemperature(options["temperature"])
        integrator.setFriction(options["friction"])
        integrator.setRandomNumberSeed(options["seed"])
    if options.get("stiffFriction"):
        integrator.setStiffFriction(True)
    return integrator


@pytest.mark.parametrize("case", list(TRAJECTORY_CASES))
@pytest.mark.parametrize("copier", list(COPIERS), ids=list(COPIERS))
def test_copy_reproduces_trajectory(platform_name, copier, case):
    original = trajectory_integrator(case)
    duplicate = COPIERS[copier](original)
    context_original = make_context(build_fpu_system(), original, platform_name)
    context_duplicate = make_context(build_fpu_system(), duplicate, platform_name)
    pos_original, vel_original = run_trajectory(context_original, 20)
    pos_duplicate, vel_duplicate = run_trajectory(context_duplicate, 20)
    assert np.all(np.isfinite(pos_original))
    assert np.max(np.abs(pos_original[-1] - pos_original[0])) > 1e-3
    np.testing.assert_array_equal(pos_duplicate, pos_original)
    np.testing.assert_array_equal(vel_duplicate, vel_original)


def test_copy_of_bound_integrator_is_usable(platform_name):
    # Copying an integrator that already drives a Context gives a fresh, unbound one.
    original = trajectory_integrator("hamiltonian-verlet")
    context_original = make_context(build_fpu_system(), original, platform_name)
    duplicate = copy.deepcopy(original)
    context_duplicate = make_context(build_fpu_system(), duplicate, platform_name)
    pos_original, _ = run_trajectory(context_original, 10)
    pos_duplicate, _ = run_trajectory(context_duplicate, 10)
    np.testing.assert_array_equal(pos_duplicate, pos_original)


def test_different_seeds_give_different_langevin_trajectories(platform_name):
    # Without this, the Langevin copies above could agree for want of any noise.
    first = trajectory_integrator("langevin")
    second = trajectory_integrator("langevin")
    second.setRandomNumberSeed(4243)
    pos_first, _ = run_trajectory(make_context(build_fpu_system(), first, platform_name), 5)
    pos_second, _ = run_trajectory(make_context(build_fpu_system(), second, platform_name), 5)
    assert np.max(np.abs(pos_first[-1] - pos_second[-1])) > 1e-4


@pytest.mark.parametrize("make", [lambda: openmm.VerletIntegrator(0.002),
                                  lambda: openmm.LangevinMiddleIntegrator(300, 1, 0.002)],
                         ids=["Verlet", "LangevinMiddle"])
def test_patched_serializer_keeps_openmm_integrators(make):
    original = make()
    for duplicate in (xml_round_trip(original), copy.deepcopy(original), pickle_round_trip(original)):
        assert type(duplicate) is type(original)
        assert duplicate.getStepSize() == original.getStepSize()
