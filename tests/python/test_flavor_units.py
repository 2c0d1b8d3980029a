"""Quantities in and out, force-group masks and the scheme enum of FlavorIntegrator."""
import numpy as np
import openmm
import openmm.unit as unit
import pytest

from conftest import STIFF_GROUP, build_fpu_system, make_context, run_trajectory
from openmmflavors import FlavorIntegrator

PER_PS = unit.picosecond**-1


def assert_quantity(value, expected, target_unit):
    assert unit.is_quantity(value), f"{value!r} is not a Quantity"
    assert value.unit == target_unit, f"{value!r} is not in {target_unit}"
    assert value.value_in_unit(target_unit) == pytest.approx(expected, rel=1e-14, abs=0.0)


# ---------------------------------------------------------------------------------------------------------------
# Steps


def test_constructor_with_femtoseconds_converts_to_picoseconds():
    integrator = FlavorIntegrator(4 * unit.femtosecond, 0.5 * unit.femtosecond, 2)
    assert_quantity(integrator.getMesoStep(), 0.004, unit.picosecond)
    assert_quantity(integrator.getMicroStep(), 0.0005, unit.picosecond)


def test_constructor_with_picosecond_quantities():
    integrator = FlavorIntegrator(0.02 * unit.picosecond, 0.002 * unit.picosecond, 2)
    assert_quantity(integrator.getMesoStep(), 0.02, unit.picosecond)
    assert_quantity(integrator.getMicroStep(), 0.002, unit.picosecond)


def test_constructor_with_plain_floats_means_picoseconds():
    integrator = FlavorIntegrator(0.02, 0.002, 2)
    assert_quantity(integrator.getMesoStep(), 0.02, unit.picosecond)
    assert_quantity(integrator.getMicroStep(), 0.002, unit.picosecond)


def test_constructor_mixes_quantity_and_float():
    integrator = FlavorIntegrator(20 * unit.femtosecond, 0.002, 2)
    assert_quantity(integrator.getMesoStep(), 0.02, unit.picosecond)
    assert_quantity(integrator.getMicroStep(), 0.002, unit.picosecond)


def test_step_size_is_the_mesostep():
    integrator = FlavorIntegrator(3 * unit.femtosecond, 1 * unit.femtosecond, 2)
    assert integrator.getStepSize() == integrator.getMesoStep()
    assert_quantity(integrator.getStepSize(), 0.003, unit.picosecond)
    integrator.setMesoStep(7 * unit.femtosecond)
    assert integrator.getStepSize() == integrator.getMesoStep()
    assert_quantity(integrator.getStepSize(), 0.007, unit.picosecond)


@pytest.mark.parametrize("value, expected", [(5 * unit.femtosecond, 0.005), (0.005 * unit.picosecond, 0.005),
                                             (0.03, 0.03)])
def test_set_meso_step(value, expected):
    integrator = FlavorIntegrator(0.01, 0.001, 2)
    integrator.setMesoStep(value)
    assert_quantity(integrator.getMesoStep(), expected, unit.picosecond)
    assert_quantity(integrator.getMicroStep(), 0.001, unit.picosecond)


@pytest.mark.parametrize("value, expected", [(4 * unit.femtosecond, 0.004), (0.004 * unit.picosecond, 0.004),
                                             (0.006, 0.006)])
def test_set_step_size_sets_the_meso_step(value, expected):
    integrator = FlavorIntegrator(0.01, 0.001, 2)
    integrator.setStepSize(value)
    assert_quantity(integrator.getMesoStep(), expected, unit.picosecond)
    assert integrator.getStepSize() == integrator.getMesoStep()


@pytest.mark.parametrize("value, expected", [(2 * unit.femtosecond, 0.002), (0.003 * unit.picosecond, 0.003),
                                             (0.0025, 0.0025)])
def test_set_micro_step(value, expected):
    integrator = FlavorIntegrator(0.01, 0.001, 2)
    integrator.setMicroStep(value)
    assert_quantity(integrator.getMicroStep(), expected, unit.picosecond)
    assert_quantity(integrator.getMesoStep(), 0.01, unit.picosecond)


def test_micro_step_equal_to_meso_step_is_allowed():
    integrator = FlavorIntegrator(2 * unit.femtosecond, 2 * unit.femtosecond, 2)
    assert integrator.getMicroStep() == integrator.getMesoStep()
    integrator.setMesoStep(0.002)
    integrator.setMicroStep(0.002)
    assert integrator.getMicroStep() == integrator.getMesoStep()


def test_context_time_advances_by_meso_step(platform_name):
    integrator = FlavorIntegrator(20 * unit.femtosecond, 2 * unit.femtosecond, {STIFF_GROUP})
    context = make_context(build_fpu_system(), integrator, platform_name)
    integrator.step(5)
    state = context.getState()
    assert state.getTime().value_in_unit(unit.picosecond) == pytest.approx(0.1, rel=1e-12)
    assert state.getStepCount() == 5


# ---------------------------------------------------------------------------------------------------------------
# Temperature, friction, flags


def test_defaults():
    integrator = FlavorIntegrator(0.01, 0.001, 2)
    assert_quantity(integrator.getTemperature(), 0.0, unit.kelvin)
    assert_quantity(integrator.getFriction(), 0.0, PER_PS)
    assert integrator.getStiffFriction() is False
    assert integrator.getRandomNumberSeed() == 0
    assert integrator.getScheme() == FlavorIntegrator.Verlet


@pytest.mark.parametrize("value", [300 * unit.kelvin, 300.0, 300])
def test_set_temperature(value):
    integrator = FlavorIntegrator(0.01, 0.001, 2)
    integrator.setTemperature(value)
    assert_quantity(integrator.getTemperature(), 300.0, unit.kelvin)


@pytest.mark.parametrize("value", [5 / unit.picosecond, 5.0 * PER_PS, 0.005 / unit.femtosecond, 5.0])
def test_set_friction(value):
    integrator = FlavorIntegrator(0.01, 0.001, 2)
    integrator.setFriction(value)
    assert_quantity(integrator.getFriction(), 5.0, PER_PS)


def test_friction_getter_converts_to_other_units():
    integrator = FlavorIntegrator(0.01, 0.001, 2)
    integrator.setFriction(2.5 / unit.picosecond)
    assert integrator.getFriction().value_in_unit(unit.femtosecond**-1) == pytest.approx(0.0025, rel=1e-14)


def test_stiff_friction_flag_round_trip():
    integrator = FlavorIntegrator(0.01, 0.001, 2)
    integrator.setStiffFriction(True)
    assert integrator.getStiffFriction() is True
    integrator.setStiffFriction(False)
    assert integrator.getStiffFriction() is False


@pytest.mark.parametrize("seed", [1, 12345, 2**31 - 1, -7])
def test_random_seed_round_trip(seed):
    integrator = FlavorIntegrator(0.01, 0.001, 2)
    integrator.setRandomNumberSeed(seed)
    assert integrator.getRandomNumberSeed() == seed


@pytest.mark.parametrize("call, value, name", [
    ("mesoStep", 1 * unit.nanometer, "mesoStep"),
    ("microStep", 1 * unit.kelvin, "microStep"),
    ("setMesoStep", 1 * unit.nanometer, "mesoStep"),
    ("setStepSize", 1 * unit.kilojoule_per_mole, "stepSize"),
    ("setMicroStep", 1 * unit.nanometer, "microStep"),
    ("setTemperature", 300 * unit.picosecond, "temperature"),
    ("setFriction", 5 * unit.picosecond, "friction"),
    ("setFriction", 5 * unit.kelvin, "friction"),
])
def test_incompatible_units_raise(call, value, name):
    if call == "mesoStep":
        with pytest.raises(TypeError, match=name) as info:
            FlavorIntegrator(value, 0.001, 2)
        assert str(value) in str(info.value)
        return
    if call == "microStep":
        with pytest.raises(TypeError, match=name) as info:
            FlavorIntegrator(0.01, value, 2)
        assert str(value) in str(info.value)
        return
    integrator = FlavorIntegrator(0.01, 0.001, 2)
    integrator.setTemperature(10.0)
    integrator.setFriction(1.0)
    before = (integrator.getMesoStep(), integrator.getMicroStep(), integrator.getTemperature(),
              integrator.getFriction())
    with pytest.raises(TypeError, match=name) as info:
        getattr(integrator, call)(value)
    assert str(value) in str(info.value)
    after = (integrator.getMesoStep(), integrator.getMicroStep(), integrator.getTemperature(),
             integrator.getFriction())
    assert after == before


# ---------------------------------------------------------------------------------------------------------------
# stiffGroups


@pytest.mark.parametrize("groups, mask", [
    (2, 2),
    (0b1010, 0b1010),
    ({1}, 2),
    ([1, 3], 0b1010),
    ((0, 2), 0b101),
    (frozenset({4}), 16),
    ({1, 1}, 2),
    ({31}, -2**31),
    ([0, 31], 1 - 2**31),
    (1 << 31, -2**31),
    (0xFFFFFFFF, -1),
    (-1, -1),
    (-2**31, -2**31),
    (set(range(32)), -1),
])
def test_stiff_groups_accepted_forms(groups, mask):
    integrator = FlavorIntegrator(0.01, 0.001, groups)
    assert integrator.getStiffGroups() == mask
    other = FlavorIntegrator(0.01, 0.001, 1)
    other.setStiffGroups(groups)
    assert other.getStiffGroups() == mask


def test_stiff_group_31_is_a_negative_32_bit_int():
    mask = FlavorIntegrator(0.01, 0.001, {31}).getStiffGroups()
    assert isinstance(mask, int)
    assert mask < 0
    assert mask == -2147483648
    assert mask & 0xFFFFFFFF == 1 << 31


@pytest.mark.parametrize("groups, exception, value_text", [
    ({32}, ValueError, "32"),
    ({-1}, ValueError, "-1"),
    ([1, 40], ValueError, "40"),
    (1 << 40, ValueError, str(1 << 40)),
    (1 << 32, ValueError, str(1 << 32)),
    (-(1 << 31) - 1, ValueError, str(-(1 << 31) - 1)),
    ({1.0}, ValueError, "1.0"),
    ({True}, ValueError, "True"),
    (True, TypeError, "True"),
    (2.0, TypeError, "2.0"),
    ("1", TypeError, "'1'"),
    (None, TypeError, "None"),
])
def test_stiff_groups_rejected_forms(groups, exception, value_text):
    with pytest.raises(exception) as info:
        FlavorIntegrator(0.01, 0.001, groups)
    message = str(info.value)
    assert "stiffGroups" in message
    assert value_text in message
    assert "31" in message  # says what is allowed

    integrator = FlavorIntegrator(0.01, 0.001, {2})
    with pytest.raises(exception, match="stiffGroups"):
        integrator.setStiffGroups(groups)
    assert integrator.getStiffGroups() == 4


@pytest.mark.parametrize("groups", [0, set(), []])
def test_empty_stiff_groups_raise(groups):
    with pytest.raises(openmm.OpenMMException, match="stiffGroups") as info:
        FlavorIntegrator(0.01, 0.001, groups)
    assert "0" in str(info.value)
    integrator = FlavorIntegrator(0.01, 0.001, {1})
    with pytest.raises(openmm.OpenMMException, match="stiffGroups"):
        integrator.setStiffGroups(groups)
    assert integrator.getStiffGroups() == 2


def test_stiff_group_31_selects_force_group_31(platform_name):
    # The same chain with its stiff springs in group 31 must move exactly as with them in group 1.
    reference = make_context(build_fpu_system(stiff_group=1), FlavorIntegrator(0.02, 0.002, {1}), platform_name)
    high = make_context(build_fpu_system(stiff_group=31), FlavorIntegrator(0.02, 0.002, {31}), platform_name)
    pos_ref, vel_ref = run_trajectory(reference, 15)
    pos_high, vel_high = run_trajectory(high, 15)
    assert np.all(np.isfinite(pos_high))
    np.testing.assert_array_equal(pos_high, pos_ref)
    np.testing.assert_array_equal(vel_high, vel_ref)


def test_stiff_groups_choose_which_forces_are_stiff(platform_name):
    # Calling the soft group stiff is a different integrator: the trajectory must change.
    stiff_ok = make_context(build_fpu_system(), FlavorIntegrator(0.02, 0.002, {1}), platform_name)
    swapped = make_context(build_fpu_system(), FlavorIntegrator(0.02, 0.002, {0}), platform_name)
    pos_ok, _ = run_trajectory(stiff_ok, 5)
    pos_swapped, _ = run_trajectory(swapped, 5)
    assert np.max(np.abs(pos_ok[-1] - pos_swapped[-1])) > 1e-4


# ---------------------------------------------------------------------------------------------------------------
# Scheme enum


def test_scheme_enum_values():
    assert FlavorIntegrator.SymplecticEuler == 0
    assert FlavorIntegrator.Verlet == 1
    assert FlavorIntegrator.SymplecticEuler != FlavorIntegrator.Verlet


def test_scheme_round_trip():
    integrator = FlavorIntegrator(0.01, 0.001, 2)
    assert integrator.getScheme() == FlavorIntegrator.Verlet
    integrator.setScheme(FlavorIntegrator.SymplecticEuler)
    assert integrator.getScheme() == FlavorIntegrator.SymplecticEuler
    integrator.setScheme(FlavorIntegrator.Verlet)
    assert integrator.getScheme() == FlavorIntegrator.Verlet


@pytest.mark.parametrize("bad", [2, -1, 7])
def test_invalid_scheme_raises(bad):
    integrator = FlavorIntegrator(0.01, 0.001, 2)
    integrator.setScheme(FlavorIntegrator.SymplecticEuler)
    with pytest.raises(openmm.OpenMMException, match="scheme") as info:
        integrator.setScheme(bad)
    assert str(bad) in str(info.value)
    assert integrator.getScheme() == FlavorIntegrator.SymplecticEuler


def test_scheme_changes_the_trajectory(platform_name):
    verlet = make_context(build_fpu_system(), FlavorIntegrator(0.02, 0.002, {1}), platform_name)
    euler_integrator = FlavorIntegrator(0.02, 0.002, {1})
    euler_integrator.setScheme(FlavorIntegrator.SymplecticEuler)
    euler = make_context(build_fpu_system(), euler_integrator, platform_name)
    pos_verlet, _ = run_trajectory(verlet, 5)
    pos_euler, _ = run_trajectory(euler, 5)
    assert np.all(np.isfinite(pos_euler))
    assert np.max(np.abs(pos_verlet[-1] - pos_euler[-1])) > 1e-6
