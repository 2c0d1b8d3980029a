"""Bad input to FlavorIntegrator: the message names the parameter, the value and what is allowed, and a rejected
setter leaves the integrator (and a Context using it) exactly as it was."""
import math

import numpy as np
import openmm
import openmm.unit as unit
import pytest

from conftest import build_fpu_system, make_context, make_integrator, run_trajectory, state_arrays
from openmmflavors import FlavorIntegrator

NAN = float("nan")
INF = float("inf")


def check_message(info, parameter, value_text, allowed_text):
    message = str(info.value)
    assert parameter in message, message
    assert value_text in message.lower(), message
    assert allowed_text in message, message


# ---------------------------------------------------------------------------------------------------------------
# Constructor


@pytest.mark.parametrize("meso, value_text", [(0.0, "0"), (-0.01, "-0.01"), (NAN, "nan"), (INF, "inf"),
                                              (-INF, "-inf"), (-2 * unit.femtosecond, "-0.002")])
def test_constructor_rejects_bad_meso_step(meso, value_text):
    with pytest.raises(openmm.OpenMMException) as info:
        FlavorIntegrator(meso, 0.001, 2)
    check_message(info, "mesoStep", value_text, "> 0")


@pytest.mark.parametrize("micro, value_text", [(0.0, "0"), (-0.001, "-0.001"), (NAN, "nan"), (INF, "inf"),
                                               (-1 * unit.femtosecond, "-0.001")])
def test_constructor_rejects_bad_micro_step(micro, value_text):
    with pytest.raises(openmm.OpenMMException) as info:
        FlavorIntegrator(0.01, micro, 2)
    check_message(info, "microStep", value_text, "> 0")


@pytest.mark.parametrize("meso, micro, value_text", [(0.01, 0.02, "0.02"), (0.01, 0.0100001, "0.0100001"),
                                                     (1 * unit.femtosecond, 2 * unit.femtosecond, "0.002")])
def test_constructor_rejects_micro_step_above_meso_step(meso, micro, value_text):
    with pytest.raises(openmm.OpenMMException) as info:
        FlavorIntegrator(meso, micro, 2)
    check_message(info, "microStep", value_text, "<= mesoStep")


# ---------------------------------------------------------------------------------------------------------------
# Setters on a free integrator


def configured_integrator():
    integrator = make_integrator(meso=0.02, micro=0.002, groups={1}, temperature=100.0, friction=2.0)
    return integrator


def parameters(integrator):
    return (integrator.getMesoStep(), integrator.getStepSize(), integrator.getMicroStep(),
            integrator.getStiffGroups(), integrator.getScheme(), integrator.getTemperature(),
            integrator.getFriction(), integrator.getStiffFriction(), integrator.getRandomNumberSeed(),
            integrator.getAveraging(), integrator.getExactFastFlow(), integrator.getNumFrozenDistances(),
            integrator.getThermostatPlacement())


BAD_SETTER_CALLS = [
    # (setter, value, exception, parameter named, value text, allowed text)
    ("setMesoStep", 0.0, openmm.OpenMMException, "mesoStep", "0", "> 0"),
    ("setMesoStep", -0.02, openmm.OpenMMException, "mesoStep", "-0.02", "> 0"),
    ("setMesoStep", NAN, openmm.OpenMMException, "mesoStep", "nan", "finite"),
    ("setMesoStep", INF, openmm.OpenMMException, "mesoStep", "inf", "finite"),
    ("setMesoStep", 0.001, openmm.OpenMMException, "mesoStep", "0.001", ">= microStep"),
    ("setMesoStep", 1 * unit.femtosecond, openmm.OpenMMException, "mesoStep", "0.001", ">= microStep"),
    ("setStepSize", 0.001, openmm.OpenMMException, "mesoStep", "0.001", ">= microStep"),
    ("setStepSize", -1.0, openmm.OpenMMException, "mesoStep", "-1", "> 0"),
    ("setMicroStep", 0.0, openmm.OpenMMException, "microStep", "0", "> 0"),
    ("setMicroStep", -0.001, openmm.OpenMMException, "microStep", "-0.001", "> 0"),
    ("setMicroStep", NAN, openmm.OpenMMException, "microStep", "nan", "finite"),
    ("setMicroStep", INF, openmm.OpenMMException, "microStep", "inf", "finite"),
    ("setMicroStep", 0.03, openmm.OpenMMException, "microStep", "0.03", "<= mesoStep"),
    ("setMicroStep", 30 * unit.femtosecond, openmm.OpenMMException, "microStep", "0.03", "<= mesoStep"),
    ("setTemperature", -1.0, openmm.OpenMMException, "temperature", "-1", ">= 0"),
    ("setTemperature", -300 * unit.kelvin, openmm.OpenMMException, "temperature", "-300", ">= 0"),
    ("setTemperature", NAN, openmm.OpenMMException, "temperature", "nan", "finite"),
    ("setTemperature", INF, openmm.OpenMMException, "temperature", "inf", "finite"),
    ("setFriction", -5.0, openmm.OpenMMException, "friction", "-5", ">= 0"),
    ("setFriction", -5 / unit.picosecond, openmm.OpenMMException, "friction", "-5", ">= 0"),
    ("setFriction", NAN, openmm.OpenMMException, "friction", "nan", "finite"),
    ("setFriction", INF, openmm.OpenMMException, "friction", "inf", "finite"),
    ("setStiffGroups", 0, openmm.OpenMMException, "stiffGroups", "0", "nonzero"),
    ("setStiffGroups", set(), openmm.OpenMMException, "stiffGroups", "0", "nonzero"),
    ("setStiffGroups", {32}, ValueError, "stiffGroups", "32", "0..31"),
    ("setStiffGroups", {-1}, ValueError, "stiffGroups", "-1", "0..31"),
    ("setStiffGroups", 1 << 40, ValueError, "stiffGroups", str(1 << 40), "0..31"),
    ("setScheme", 5, openmm.OpenMMException, "scheme", "5", "Verlet"),
    ("setAveraging", 3, openmm.OpenMMException, "averaging", "3", "ArtificialProjected (2)"),
    ("setThermostatPlacement", 2, openmm.OpenMMException, "thermostatPlacement", "2", "Middle (1)"),
    ("setThermostatPlacement", 1.5, TypeError, "thermostatPlacement", "1.5", "integer"),
    ("addFrozenDistance", (2, 2), openmm.OpenMMException, "frozen distance particles", "2, 2", "must differ"),
    ("addFrozenDistance", (-1, 2), openmm.OpenMMException, "frozen distance particle", "-1", ">= 0"),
]


def call_id(call):
    return f"{call[0]}({call[1]})"


@pytest.mark.parametrize("setter, value, exception, parameter, value_text, allowed", BAD_SETTER_CALLS,
                         ids=[call_id(c) for c in BAD_SETTER_CALLS])
def test_rejected_setter_keeps_old_value(setter, value, exception, parameter, value_text, allowed):
    integrator = configured_integrator()
    before = parameters(integrator)
    with pytest.raises(exception) as info:
        getattr(integrator, setter)(*(value if isinstance(value, tuple) else (value,)))
    check_message(info, parameter, value_text, allowed)
    assert parameters(integrator) == before


def test_zero_temperature_and_friction_are_allowed():
    integrator = configured_integrator()
    integrator.setTemperature(0.0)
    integrator.setFriction(0 / unit.picosecond)
    assert integrator.getTemperature() == 0 * unit.kelvin
    assert integrator.getFriction() == 0 / unit.picosecond


# ---------------------------------------------------------------------------------------------------------------
# Context binding


@pytest.mark.parametrize("groups", [{5}, {2, 31}, 1 << 7])
def test_context_without_stiff_force_raises(platform_name, groups):
    system = build_fpu_system()
    integrator = FlavorIntegrator(0.02, 0.002, groups)
    platform = openmm.Platform.getPlatformByName(platform_name)
    with pytest.raises(openmm.OpenMMException, match="stiffGroups") as info:
        openmm.Context(system, integrator, platform)
    assert str(integrator.getStiffGroups()) in str(info.value)


def test_context_with_all_forces_in_soft_groups_raises(platform_name):
    system = build_fpu_system(stiff_group=0, soft_group=0)
    integrator = FlavorIntegrator(0.02, 0.002, {1})
    with pytest.raises(openmm.OpenMMException, match="stiffGroups"):
        openmm.Context(system, integrator, openmm.Platform.getPlatformByName(platform_name))


def test_system_with_only_stiff_forces_is_rejected(platform_name):
    # No soft force at all is almost always a bitmask mistaken for a group number: an error naming the cause.
    system = build_fpu_system(stiff_group=1, soft_group=1)
    integrator = FlavorIntegrator(0.02, 0.002, {1})
    with pytest.raises(openmm.OpenMMException, match=r"no force of the System is soft.*\{1\} means group 1"):
        openmm.Context(system, integrator, openmm.Platform.getPlatformByName(platform_name))


BOUND_BAD_CALLS = [
    ("setMesoStep", 0.001, openmm.OpenMMException, "mesoStep"),
    ("setMesoStep", NAN, openmm.OpenMMException, "mesoStep"),
    ("setStepSize", -0.02, openmm.OpenMMException, "mesoStep"),
    ("setMicroStep", 0.05, openmm.OpenMMException, "microStep"),
    ("setMicroStep", INF, openmm.OpenMMException, "microStep"),
    ("setTemperature", -10.0, openmm.OpenMMException, "temperature"),
    ("setFriction", NAN, openmm.OpenMMException, "friction"),
    ("setFriction", -1.0, openmm.OpenMMException, "friction"),
    ("setStiffGroups", 0, openmm.OpenMMException, "stiffGroups"),
    ("setStiffGroups", {5}, openmm.OpenMMException, "stiffGroups"),
    ("setStiffGroups", {32}, ValueError, "stiffGroups"),
    ("setScheme", 3, openmm.OpenMMException, "scheme"),
]


@pytest.mark.parametrize("setter, value, exception, parameter", BOUND_BAD_CALLS,
                         ids=[call_id(c) for c in BOUND_BAD_CALLS])
def test_rejected_setter_on_bound_integrator_context_still_steps(platform_name, setter, value, exception,
                                                                 parameter):
    system = build_fpu_system()
    integrator = make_integrator(meso=0.02, micro=0.002, groups={1})
    context = make_context(system, integrator, platform_name)
    integrator.step(3)
    before = parameters(integrator)
    pos_before, _ = state_arrays(context)
    with pytest.raises(exception, match=parameter):
        getattr(integrator, setter)(value)
    assert parameters(integrator) == before
    positions, velocities = run_trajectory(context, 10)
    assert np.all(np.isfinite(positions)) and np.all(np.isfinite(velocities))
    assert np.max(np.abs(positions[-1] - pos_before)) > 1e-3

    # The rejected call must not have changed the dynamics either.
    control = make_context(system, make_integrator(meso=0.02, micro=0.002, groups={1}), platform_name)
    control.getIntegrator().step(3)
    control_positions, control_velocities = run_trajectory(control, 10)
    np.testing.assert_array_equal(positions, control_positions)
    np.testing.assert_array_equal(velocities, control_velocities)


def test_set_stiff_groups_on_bound_integrator_leaving_no_soft_force_is_rejected(platform_name):
    integrator = FlavorIntegrator(0.02, 0.002, {1})
    context = make_context(build_fpu_system(), integrator, platform_name)
    with pytest.raises(openmm.OpenMMException, match=r"stiffGroups = 3 .*no force of the System is soft"):
        integrator.setStiffGroups({0, 1})
    assert integrator.getStiffGroups() == 2
    integrator.step(5)
    pos, vel = state_arrays(context)
    assert np.all(np.isfinite(pos)) and np.all(np.isfinite(vel))


def test_step_without_context_raises():
    integrator = FlavorIntegrator(0.02, 0.002, {1})
    with pytest.raises(openmm.OpenMMException):
        integrator.step(1)


def test_integrator_cannot_be_bound_twice(platform_name):
    integrator = FlavorIntegrator(0.02, 0.002, {1})
    context = make_context(build_fpu_system(), integrator, platform_name)
    with pytest.raises(openmm.OpenMMException):
        openmm.Context(build_fpu_system(), integrator, openmm.Platform.getPlatformByName(platform_name))
    integrator.step(2)
    assert np.all(np.isfinite(state_arrays(context)[0]))
    assert math.isclose(context.getState().getTime().value_in_unit(unit.picosecond), 0.04, rel_tol=1e-12)


# ---------------------------------------------------------------------------------------------------------------
# Stiff forces the artificial averaging cannot freeze


def stiff_torsion_system():
    system = openmm.System()
    for _ in range(4):
        system.addParticle(12.0)
    torsion = openmm.PeriodicTorsionForce()
    torsion.addTorsion(0, 1, 2, 3, 3, 0.0, 5.0)
    torsion.setForceGroup(1)
    system.addForce(torsion)
    soft = openmm.CustomExternalForce("x^2+y^2+z^2")
    for i in range(4):
        soft.addParticle(i)
    system.addForce(soft)
    return system


def test_a_stiff_torsion_is_rejected_at_context_creation_under_the_artificial_averaging():
    integrator = FlavorIntegrator(2 * unit.femtosecond, 0.5 * unit.femtosecond, {1})
    integrator.setAveraging(FlavorIntegrator.ArtificialProjected)
    with pytest.raises(openmm.OpenMMException) as info:
        openmm.Context(stiff_torsion_system(), integrator, openmm.Platform.getPlatformByName("Reference"))
    message = str(info.value)
    for part in ("force 0 (PeriodicTorsionForce", "addFrozenDistance", "Nonintrusive"):
        assert part in message, message


def test_middle_placement_with_the_nonintrusive_averaging_is_rejected_when_stepping(platform_name):
    system = build_fpu_system()
    integrator = make_integrator(meso=0.02, micro=0.002, groups={1}, temperature=100.0, friction=2.0)
    context = make_context(system, integrator, platform_name)
    integrator.setThermostatPlacement(FlavorIntegrator.Middle)
    pos_before, _ = state_arrays(context)
    with pytest.raises(openmm.OpenMMException, match="thermostatPlacement = Middle .* Nonintrusive"):
        integrator.step(1)
    np.testing.assert_array_equal(state_arrays(context)[0], pos_before)
    integrator.setThermostatPlacement(FlavorIntegrator.Edges)
    positions, velocities = run_trajectory(context, 5)
    assert np.all(np.isfinite(positions)) and np.all(np.isfinite(velocities))
