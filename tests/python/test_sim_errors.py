"""Bad input to StochasticImpulseIntegrator: the message names the parameter; a rejected setter leaves the
integrator as it was; stiff forces that are not quadratic, a negative stiff curvature and constraints on stiff
particles are refused with messages that say what to do."""
import numpy as np
import openmm
import openmm.unit as unit
import pytest

from conftest import build_fpu_system, make_context, state_arrays
from openmmflavors import StochasticImpulseIntegrator

NAN = float("nan")
INF = float("inf")


def parameters(integrator):
    return (integrator.getTemperature(), integrator.getFriction(), integrator.getStepSize(),
            integrator.getStiffGroups(), integrator.getSplitting(), integrator.getRandomNumberSeed())


BAD_CONSTRUCTOR_ARGUMENTS = [
    # (temperature, friction, step, groups, parameter named, value text)
    (-1.0, 1.0, 0.01, 2, "temperature", "-1"),
    (-300 * unit.kelvin, 1.0, 0.01, 2, "temperature", "-300"),
    (NAN, 1.0, 0.01, 2, "temperature", "nan"),
    (300.0, -0.5, 0.01, 2, "friction", "-0.5"),
    (300.0, -0.5 / unit.picosecond, 0.01, 2, "friction", "-0.5"),
    (300.0, INF, 0.01, 2, "friction", "inf"),
    (300.0, 1.0, -0.01, 2, "stepSize", "-0.01"),
    (300.0, 1.0, -2 * unit.femtosecond, 2, "stepSize", "-0.002"),
    (300.0, 1.0, 0.0, 2, "stepSize", "0"),
    (300.0, 1.0, NAN, 2, "stepSize", "nan"),
    (300.0, 1.0, 0.01, 0, "stiffGroups", "0"),
    (300.0, 1.0, 0.01, set(), "stiffGroups", "0"),
]


@pytest.mark.parametrize("temperature, friction, step, groups, parameter, value_text", BAD_CONSTRUCTOR_ARGUMENTS,
                         ids=[f"{c[4]}={c[5]}" for c in BAD_CONSTRUCTOR_ARGUMENTS])
def test_constructor_rejects_bad_values(temperature, friction, step, groups, parameter, value_text):
    with pytest.raises(openmm.OpenMMException) as info:
        StochasticImpulseIntegrator(temperature, friction, step, groups)
    message = str(info.value)
    assert parameter in message, message
    assert f"= {value_text} " in message.lower(), message


@pytest.mark.parametrize("groups, exception", [({32}, ValueError), ({-1}, ValueError), (1 << 40, ValueError),
                                               ("1", TypeError), (True, TypeError), (1.5, TypeError)])
def test_bad_group_arguments_rejected_in_python(groups, exception):
    with pytest.raises(exception, match="stiffGroups"):
        StochasticImpulseIntegrator(300.0, 1.0, 0.01, groups)


BAD_SETTER_CALLS = [
    ("setTemperature", -1.0, "temperature"),
    ("setTemperature", INF, "temperature"),
    ("setFriction", -2.0, "friction"),
    ("setFriction", NAN, "friction"),
    ("setStepSize", -0.01, "stepSize"),
    ("setStepSize", 0.0, "stepSize"),
    ("setStepSize", -1 * unit.femtosecond, "stepSize"),
    ("setStiffGroups", 0, "stiffGroups"),
    ("setSplitting", 5, "splitting"),
    ("setSplitting", -1, "splitting"),
]


@pytest.mark.parametrize("setter, value, parameter", BAD_SETTER_CALLS,
                         ids=[f"{c[0]}({c[1]})" for c in BAD_SETTER_CALLS])
def test_rejected_setter_keeps_old_value(setter, value, parameter):
    integrator = StochasticImpulseIntegrator(250.0, 2.0, 0.02, {1, 2})
    integrator.setRandomNumberSeed(5)
    before = parameters(integrator)
    with pytest.raises(openmm.OpenMMException) as info:
        getattr(integrator, setter)(value)
    assert parameter in str(info.value)
    assert parameters(integrator) == before


def test_yoshida4_refused_with_friction():
    integrator = StochasticImpulseIntegrator(300.0, 1.0, 0.01, {1})
    with pytest.raises(openmm.OpenMMException) as info:
        integrator.setSplitting(StochasticImpulseIntegrator.Yoshida4)
    assert "Yoshida4" in str(info.value) and "friction" in str(info.value)
    assert integrator.getSplitting() == StochasticImpulseIntegrator.Strang


def test_friction_refused_with_yoshida4():
    integrator = StochasticImpulseIntegrator(300.0, 0.0, 0.01, {1})
    integrator.setSplitting(StochasticImpulseIntegrator.Yoshida4)
    with pytest.raises(openmm.OpenMMException) as info:
        integrator.setFriction(0.5 / unit.picosecond)
    assert "friction" in str(info.value) and "Yoshida4" in str(info.value)
    assert integrator.getFriction().value_in_unit(unit.picosecond**-1) == 0.0
    integrator.setFriction(0.0)


# ---------------------------------------------------------------------------------------------------------------
# Systems the integrator cannot run


def spring_system(length, extra_particles=0, group=1):
    system = openmm.System()
    for mass in [1.0, 2.0] + [1.0] * extra_particles:
        system.addParticle(mass)
    spring = openmm.HarmonicBondForce()
    spring.addBond(0, 1, length, 1000.0)
    spring.setForceGroup(group)
    system.addForce(spring)
    soft = openmm.CustomExternalForce("x^4")
    soft.addParticle(0, [])
    system.addForce(soft)
    return system


def positions(n):
    rng = np.random.default_rng(3)
    return [openmm.Vec3(*p) for p in rng.uniform(-0.2, 0.2, (n, 3))] * unit.nanometer


def zero_velocities(n):
    return [openmm.Vec3(0, 0, 0)] * n


def test_nonlinear_stiff_force_raises_at_first_step(platform_name):
    integrator = StochasticImpulseIntegrator(300.0, 1.0, 0.01, {1})
    context = make_context(spring_system(0.1), integrator, platform_name, positions=positions(2),
                           velocities=[openmm.Vec3(0.5, 0, 0), openmm.Vec3(0, 0, 0)])
    before = state_arrays(context)
    for _ in range(2):
        with pytest.raises(openmm.OpenMMException) as info:
            integrator.step(1)
        message = str(info.value)
        assert "quadratic" in message and "FlavorIntegrator" in message, message
        # The measured deviation is reported.
        assert "differ" in message and "relative" in message, message
    # Nothing moved and no time passed.
    for a, b in zip(state_arrays(context), before):
        np.testing.assert_array_equal(a, b)
    assert context.getState().getStepCount() == 0


def test_nonlinear_stiff_force_raises_for_frequencies(platform_name):
    integrator = StochasticImpulseIntegrator(300.0, 1.0, 0.01, {1})
    context = make_context(spring_system(0.1), integrator, platform_name, positions=positions(2),
                           velocities=zero_velocities(2))
    with pytest.raises(openmm.OpenMMException, match="quadratic"):
        integrator.getStiffModeFrequencies()
    assert context.getState().getStepCount() == 0


def test_fixing_the_stiff_force_recovers(platform_name):
    system = spring_system(0.1)
    integrator = StochasticImpulseIntegrator(300.0, 1.0, 0.01, {1})
    context = make_context(system, integrator, platform_name, positions=positions(2), velocities=zero_velocities(2))
    with pytest.raises(openmm.OpenMMException):
        integrator.step(1)
    system.getForce(0).setBondParameters(0, 0, 1, 0.0, 1000.0)
    system.getForce(0).updateParametersInContext(context)
    integrator.step(3)
    assert context.getState().getStepCount() == 3


def test_negative_stiff_curvature_is_refused(platform_name):
    system = openmm.System()
    system.addParticle(1.0)
    force = openmm.CustomExternalForce("-5*x^2")
    force.addParticle(0, [])
    force.setForceGroup(1)
    system.addForce(force)
    integrator = StochasticImpulseIntegrator(300.0, 1.0, 0.01, {1})
    context = make_context(system, integrator, platform_name, positions=positions(1),
                           velocities=zero_velocities(1))
    with pytest.raises(openmm.OpenMMException) as info:
        integrator.step(1)
    assert "negative" in str(info.value) and "-10" in str(info.value)
    assert context.getState().getStepCount() == 0


def test_constraint_inside_a_stiff_component_refused_at_context_creation(platform_name):
    system = spring_system(0.0)
    system.addConstraint(1, 0, 0.1)
    integrator = StochasticImpulseIntegrator(300.0, 1.0, 0.01, {1})
    with pytest.raises(openmm.OpenMMException) as info:
        make_context(system, integrator, platform_name, positions=positions(2), velocities=zero_velocities(2))
    message = str(info.value)
    assert "constraint 0 between particles 1 and 0" in message, message
    assert "joins two particles of one stiff component" in message, message


def test_two_constrained_particles_of_one_stiff_component_refused(platform_name):
    system = spring_system(0.0, extra_particles=2)
    system.addConstraint(0, 2, 0.1)
    system.addConstraint(3, 1, 0.1)
    integrator = StochasticImpulseIntegrator(300.0, 1.0, 0.01, {1})
    with pytest.raises(openmm.OpenMMException) as info:
        make_context(system, integrator, platform_name, positions=positions(4), velocities=zero_velocities(4))
    message = str(info.value)
    assert "constraint 1 between particles 3 and 1" in message and "particle 0" in message, message
    assert "at most one particle of each stiff component" in message, message


@pytest.mark.parametrize("pair", [(1, 2), (2, 0)])
def test_constraint_from_a_stiff_particle_to_another_is_held(platform_name, pair):
    system = spring_system(0.0, extra_particles=1)
    system.addConstraint(pair[0], pair[1], 0.1)
    integrator = StochasticImpulseIntegrator(300.0, 1.0, 0.002, {1})
    integrator.setConstraintTolerance(1e-8)
    context = make_context(system, integrator, platform_name,
                           positions=[openmm.Vec3(0, 0, 0), openmm.Vec3(0.01, 0, 0), openmm.Vec3(0.1, 0, 0)] *
                           unit.nanometer, velocities=zero_velocities(3))
    context.applyConstraints(1e-8)
    for _ in range(20):
        integrator.step(1)
        pos, _ = state_arrays(context)
        assert np.linalg.norm(pos[pair[0]] - pos[pair[1]]) == pytest.approx(0.1, rel=1e-7)


def test_constraint_away_from_stiff_particles_is_allowed(platform_name):
    system = spring_system(0.0, extra_particles=2)
    system.addConstraint(2, 3, 0.1)
    integrator = StochasticImpulseIntegrator(300.0, 1.0, 0.01, {1})
    context = make_context(system, integrator, platform_name,
                           positions=[openmm.Vec3(0, 0, 0), openmm.Vec3(0.1, 0, 0), openmm.Vec3(1, 0, 0),
                                      openmm.Vec3(1.1, 0, 0)] * unit.nanometer,
                           velocities=zero_velocities(4))
    integrator.step(20)
    pos, _ = state_arrays(context)
    assert np.linalg.norm(pos[3] - pos[2]) == pytest.approx(0.1, abs=1e-4)


def test_no_force_in_stiff_groups_is_refused(platform_name):
    integrator = StochasticImpulseIntegrator(300.0, 1.0, 0.01, {5})
    with pytest.raises(openmm.OpenMMException, match="stiffGroups"):
        make_context(build_fpu_system(), integrator, platform_name)


def test_stiff_groups_change_on_bound_integrator_needs_a_force(platform_name):
    integrator = StochasticImpulseIntegrator(300.0, 1.0, 0.01, {1})
    context = make_context(build_fpu_system(), integrator, platform_name)
    integrator.step(1)
    with pytest.raises(openmm.OpenMMException, match="stiffGroups"):
        integrator.setStiffGroups({5})
    assert integrator.getStiffGroups() == 2
    integrator.step(1)
    assert context.getState().getStepCount() == 2
