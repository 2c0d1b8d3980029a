"""Python API of StochasticImpulseIntegrator: Quantities in and out, stiff groups, the splitting enum, the stiff
mode spectrum against closed forms, and XmlSerializer/copy/pickle round trips."""
import copy
import math
import pickle

import numpy as np
import openmm
import openmm.unit as unit
import pytest

from conftest import OMEGA, build_fpu_system, make_context, platform_properties, state_arrays
from openmmflavors import StochasticImpulseIntegrator

PER_PS = unit.picosecond**-1


def parameters(integrator):
    return {
        "temperature": integrator.getTemperature().value_in_unit(unit.kelvin),
        "friction": integrator.getFriction().value_in_unit(PER_PS),
        "stepSize": integrator.getStepSize().value_in_unit(unit.picosecond),
        "stiffGroups": integrator.getStiffGroups(),
        "splitting": integrator.getSplitting(),
        "randomSeed": integrator.getRandomNumberSeed(),
        "constraintTolerance": integrator.getConstraintTolerance(),
        "integrationForceGroups": integrator.getIntegrationForceGroups(),
    }


# ---------------------------------------------------------------------------------------------------------------
# Quantities, groups, enum


def test_constructor_takes_quantities_and_getters_return_quantities():
    integrator = StochasticImpulseIntegrator(310.5 * unit.kelvin, 0.002 / unit.femtosecond, 1.5 * unit.femtosecond,
                                             {1})
    temperature, friction, step = integrator.getTemperature(), integrator.getFriction(), integrator.getStepSize()
    assert unit.is_quantity(temperature) and temperature.unit == unit.kelvin
    assert unit.is_quantity(friction) and friction.unit.is_compatible(PER_PS)
    assert unit.is_quantity(step) and step.unit == unit.picosecond
    assert temperature.value_in_unit(unit.kelvin) == 310.5
    assert friction.value_in_unit(PER_PS) == pytest.approx(2.0, rel=1e-15)
    assert step.value_in_unit(unit.picosecond) == pytest.approx(0.0015, rel=1e-15)


def test_constructor_takes_plain_numbers_in_openmm_units():
    integrator = StochasticImpulseIntegrator(300.0, 1.0, 0.004, 2)
    assert parameters(integrator)["temperature"] == 300.0
    assert parameters(integrator)["friction"] == 1.0
    assert parameters(integrator)["stepSize"] == 0.004
    assert integrator.getStiffGroups() == 2


def test_setters_take_quantities():
    integrator = StochasticImpulseIntegrator(300.0, 1.0, 0.004, 2)
    integrator.setTemperature(77.0 * unit.kelvin)
    integrator.setFriction(5.0 / unit.nanosecond)
    integrator.setStepSize(3.0 * unit.femtosecond)
    assert integrator.getTemperature() == 77.0 * unit.kelvin
    assert integrator.getFriction().value_in_unit(PER_PS) == pytest.approx(0.005, rel=1e-15)
    assert integrator.getStepSize().value_in_unit(unit.picosecond) == pytest.approx(0.003, rel=1e-15)


@pytest.mark.parametrize("call", [
    lambda: StochasticImpulseIntegrator(300.0 * unit.nanometer, 1.0, 0.004, 2),
    lambda: StochasticImpulseIntegrator(300.0, 1.0 * unit.picosecond, 0.004, 2),
    lambda: StochasticImpulseIntegrator(300.0, 1.0, 0.004 * unit.kelvin, 2),
    lambda: StochasticImpulseIntegrator(300.0, 1.0, 0.004, 2).setFriction(2.0 * unit.nanometer),
    lambda: StochasticImpulseIntegrator(300.0, 1.0, 0.004, 2).setTemperature(2.0 * unit.picosecond),
    lambda: StochasticImpulseIntegrator(300.0, 1.0, 0.004, 2).setStepSize(2.0 / unit.picosecond),
], ids=["temperature", "frictionCoeff", "stepSize", "setFriction", "setTemperature", "setStepSize"])
def test_incompatible_units_are_rejected(call):
    with pytest.raises(TypeError, match="not compatible"):
        call()


@pytest.mark.parametrize("groups, mask", [
    (2, 2), ({1}, 2), ([1, 4], 0b10010), ((0, 2), 0b101), (frozenset({3}), 8), ({31}, -2**31), ({1, 31}, -2**31 + 2),
])
def test_stiff_groups_as_bitmask_or_set(groups, mask):
    integrator = StochasticImpulseIntegrator(300.0, 1.0, 0.004, groups)
    assert integrator.getStiffGroups() == mask
    integrator.setStiffGroups(1)
    integrator.setStiffGroups(groups)
    assert integrator.getStiffGroups() == mask


def test_splitting_enum():
    assert (StochasticImpulseIntegrator.LieTrotter, StochasticImpulseIntegrator.Strang,
            StochasticImpulseIntegrator.Yoshida4) == (0, 1, 2)
    integrator = StochasticImpulseIntegrator(0.0, 0.0, 0.004, 2)
    assert integrator.getSplitting() == StochasticImpulseIntegrator.Strang
    for splitting in (StochasticImpulseIntegrator.LieTrotter, StochasticImpulseIntegrator.Yoshida4,
                      StochasticImpulseIntegrator.Strang):
        integrator.setSplitting(splitting)
        assert integrator.getSplitting() == splitting


def test_random_number_seed():
    integrator = StochasticImpulseIntegrator(300.0, 1.0, 0.004, 2)
    assert integrator.getRandomNumberSeed() == 0
    integrator.setRandomNumberSeed(-12345)
    assert integrator.getRandomNumberSeed() == -12345


# ---------------------------------------------------------------------------------------------------------------
# Stiff mode spectrum


def one_spring_system(m1, m2, k, length=0.0, group=1):
    system = openmm.System()
    system.addParticle(m1)
    system.addParticle(m2)
    spring = openmm.HarmonicBondForce()
    spring.addBond(0, 1, length, k)
    spring.setForceGroup(group)
    system.addForce(spring)
    return system


def frequencies(context):
    result = context.getIntegrator().getStiffModeFrequencies()
    assert unit.is_quantity(result)
    values = np.array(result.value_in_unit(PER_PS))
    assert np.all(np.diff(values) >= 0), "frequencies must be ascending"
    return values


@pytest.mark.parametrize("m1, m2, k", [(1.0, 1.0, 800.0), (1.008, 15.999, 4.0e5), (3.0, 0.25, 1.0)])
def test_one_spring_has_three_zero_modes_and_three_at_sqrt_k_over_mu(platform_name, m1, m2, k):
    system = one_spring_system(m1, m2, k)
    integrator = StochasticImpulseIntegrator(300.0, 1.0, 0.002, {1})
    positions = [openmm.Vec3(0.1, -0.2, 0.3), openmm.Vec3(0.45, 0.05, -0.1)] * unit.nanometer
    context = make_context(system, integrator, platform_name, positions=positions,
                           velocities=[openmm.Vec3(0, 0, 0)] * 2)
    omega = math.sqrt(k / (m1 * m2 / (m1 + m2)))
    values = frequencies(context)
    assert len(values) == 6
    np.testing.assert_allclose(values[:3], 0.0, atol=1e-6 * omega)
    np.testing.assert_allclose(values[3:], omega, rtol=1e-7)


def test_fpu_spectrum(platform_name):
    # Three springs k = omega^2/2 between unit masses (reduced mass 1/2): nine modes at omega, nine free ones.
    integrator = StochasticImpulseIntegrator(300.0, 1.0, 0.01, {1})
    context = make_context(build_fpu_system(), integrator, platform_name)
    values = frequencies(context)
    assert len(values) == 18
    np.testing.assert_allclose(values[:9], 0.0, atol=1e-6 * OMEGA)
    np.testing.assert_allclose(values[9:], OMEGA, rtol=1e-7)


def test_external_quadratic_and_global_parameter_change(platform_name):
    # k*(x-x0)^2 on a particle of mass m: one mode at sqrt(2k/m); y and z are free.  A new value of the global
    # parameter must be picked up without updateStiffModes().
    system = openmm.System()
    system.addParticle(2.5)
    force = openmm.CustomExternalForce("kx*(x-0.3)^2")
    force.addGlobalParameter("kx", 50.0)
    force.addParticle(0, [])
    force.setForceGroup(2)
    system.addForce(force)
    soft = openmm.CustomExternalForce("0.1*z^4")
    soft.addParticle(0, [])
    system.addForce(soft)
    integrator = StochasticImpulseIntegrator(0.0, 0.0, 0.01, {2})
    context = make_context(system, integrator, platform_name, positions=[openmm.Vec3(0.2, 0.1, 0.4)],
                           velocities=[openmm.Vec3(0, 0, 0)])
    np.testing.assert_allclose(frequencies(context), [0.0, 0.0, math.sqrt(2 * 50.0 / 2.5)], atol=1e-8, rtol=1e-9)
    integrator.step(3)
    context.setParameter("kx", 200.0)
    np.testing.assert_allclose(frequencies(context), [0.0, 0.0, math.sqrt(2 * 200.0 / 2.5)], atol=1e-8, rtol=1e-9)


def test_update_parameters_in_context_changes_spectrum(platform_name):
    system = one_spring_system(1.0, 3.0, 300.0)
    spring = system.getForce(0)
    integrator = StochasticImpulseIntegrator(0.0, 0.0, 0.01, {1})
    positions = [openmm.Vec3(0, 0, 0), openmm.Vec3(0.1, 0.2, 0.0)] * unit.nanometer
    context = make_context(system, integrator, platform_name, positions=positions,
                           velocities=[openmm.Vec3(0, 0, 0)] * 2)
    integrator.step(2)
    spring.setBondParameters(0, 0, 1, 0.0, 1200.0)
    spring.updateParametersInContext(context)
    np.testing.assert_allclose(frequencies(context)[3:], math.sqrt(1200.0 / 0.75), rtol=1e-7)
    integrator.updateStiffModes()
    np.testing.assert_allclose(frequencies(context)[3:], math.sqrt(1200.0 / 0.75), rtol=1e-7)


def test_frequencies_need_positions():
    integrator = StochasticImpulseIntegrator(300.0, 1.0, 0.002, {1})
    with pytest.raises(openmm.OpenMMException, match="bound to a Context"):
        integrator.getStiffModeFrequencies()
    context = openmm.Context(one_spring_system(1.0, 1.0, 100.0), integrator,
                             openmm.Platform.getPlatformByName("Reference"))
    with pytest.raises(openmm.OpenMMException, match="positions"):
        integrator.getStiffModeFrequencies()
    context.setPositions([openmm.Vec3(0, 0, 0), openmm.Vec3(0.1, 0, 0)])
    assert len(integrator.getStiffModeFrequencies()) == 6


@pytest.mark.parametrize("splitting", ["LieTrotter", "Strang", "Yoshida4"])
def test_purely_harmonic_system_is_integrated_exactly(platform_name, splitting):
    # No soft force: every splitting is the exact flow, even at omega*H = 7.3.
    m1, m2, k = 1.0, 3.0, 4000.0
    mu = m1 * m2 / (m1 + m2)
    omega, h, steps = math.sqrt(k / mu), 0.1, 25
    integrator = StochasticImpulseIntegrator(0.0, 0.0, h, {1})
    integrator.setSplitting(getattr(StochasticImpulseIntegrator, splitting))
    r0, u0 = np.array([0.05, -0.02, 0.01]), np.array([0.3, 0.0, -0.4])
    com_v = np.array([0.2, 0.1, 0.0])
    positions = [openmm.Vec3(*(-m2 / (m1 + m2) * r0)), openmm.Vec3(*(m1 / (m1 + m2) * r0))]
    velocities = [openmm.Vec3(*(com_v - m2 / (m1 + m2) * u0)), openmm.Vec3(*(com_v + m1 / (m1 + m2) * u0))]
    context = make_context(one_spring_system(m1, m2, k), integrator, platform_name, positions=positions,
                           velocities=velocities)
    integrator.step(steps)
    pos, vel = state_arrays(context)
    t = steps * h
    r = r0 * math.cos(omega * t) + u0 / omega * math.sin(omega * t)
    u = -r0 * omega * math.sin(omega * t) + u0 * math.cos(omega * t)
    np.testing.assert_allclose(pos[1] - pos[0], r, atol=1e-9)
    np.testing.assert_allclose(vel[1] - vel[0], u, atol=1e-7)
    np.testing.assert_allclose((m1 * pos[0] + m2 * pos[1]) / (m1 + m2), com_v * t, atol=1e-10)


# ---------------------------------------------------------------------------------------------------------------
# Serialization and copies


def xml_round_trip(integrator):
    return openmm.XmlSerializer.deserialize(openmm.XmlSerializer.serialize(integrator))


COPIERS = {
    "xml": xml_round_trip,
    "copy": copy.copy,
    "deepcopy": copy.deepcopy,
    "pickle": lambda integrator: pickle.loads(pickle.dumps(integrator)),
    "clone": openmm.XmlSerializer.clone,
}


def non_default_integrator():
    integrator = StochasticImpulseIntegrator(287.25 * unit.kelvin, 3.75 / unit.picosecond, 1.37 * unit.femtosecond,
                                             {1, 3, 31})
    integrator.setSplitting(StochasticImpulseIntegrator.LieTrotter)
    integrator.setRandomNumberSeed(918273)
    integrator.setConstraintTolerance(3.5e-7)
    integrator.setIntegrationForceGroups({0, 1, 3, 31})
    return integrator


@pytest.mark.parametrize("copier", list(COPIERS))
def test_copy_is_a_stochastic_impulse_integrator_with_every_parameter(copier):
    original = non_default_integrator()
    expected = parameters(original)
    defaults = parameters(StochasticImpulseIntegrator(300.0, 1.0, 0.002, 2))
    assert all(expected[key] != defaults[key] for key in expected)
    duplicate = COPIERS[copier](original)
    assert isinstance(duplicate, StochasticImpulseIntegrator)
    assert duplicate is not original
    assert parameters(duplicate) == expected


@pytest.mark.parametrize("copier", list(COPIERS))
def test_copy_keeps_yoshida4(copier):
    original = StochasticImpulseIntegrator(0.0, 0.0, 0.01, {1})
    original.setSplitting(StochasticImpulseIntegrator.Yoshida4)
    duplicate = COPIERS[copier](original)
    assert isinstance(duplicate, StochasticImpulseIntegrator)
    assert duplicate.getSplitting() == StochasticImpulseIntegrator.Yoshida4


@pytest.mark.parametrize("copier", ["xml", "deepcopy", "pickle"])
def test_copy_integrates_like_the_original(platform_name, copier):
    def trajectory(integrator):
        context = make_context(build_fpu_system(), integrator, platform_name)
        integrator.step(15)
        return state_arrays(context)

    original = StochasticImpulseIntegrator(300.0, 2.0, 0.02, {1})
    original.setRandomNumberSeed(4242)
    duplicate = COPIERS[copier](original)
    for a, b in zip(trajectory(original), trajectory(duplicate)):
        np.testing.assert_array_equal(a, b)


def test_plain_integrator_proxy_from_context_is_the_real_class(platform_name):
    integrator = StochasticImpulseIntegrator(300.0, 1.0, 0.01, {1})
    properties = platform_properties(platform_name)
    context = openmm.Context(build_fpu_system(), integrator, openmm.Platform.getPlatformByName(platform_name),
                             properties)
    assert isinstance(openmm.XmlSerializer.clone(context.getIntegrator()), StochasticImpulseIntegrator)


# ---------------------------------------------------------------------------------------------------------------
# Temperature and noise as seen from Python


def test_harmonic_equipartition_with_temperature_quantity(platform_name):
    # A purely harmonic system is propagated by its exact Ornstein-Uhlenbeck flow, so after gamma*t = 11 the
    # ensemble is Boltzmann at the requested temperature to within sampling error (here 3 * 3000 samples).
    n, k, mass = 3000, 5000.0, 2.0
    system = openmm.System()
    stiff = openmm.CustomExternalForce("0.5*k*(x^2+y^2+z^2)")
    stiff.addGlobalParameter("k", k)
    stiff.setForceGroup(1)
    for i in range(n):
        system.addParticle(mass)
        stiff.addParticle(i, [])
    system.addForce(stiff)
    integrator = StochasticImpulseIntegrator(300 * unit.kelvin, 10 / unit.picosecond, 0.37 * unit.picosecond, {1})
    integrator.setRandomNumberSeed(11)
    context = make_context(system, integrator, platform_name, positions=np.zeros((n, 3)),
                           velocities=np.zeros((n, 3)))
    integrator.step(3)
    pos, vel = state_arrays(context)
    kT = (unit.MOLAR_GAS_CONSTANT_R * 300 * unit.kelvin).value_in_unit(unit.kilojoule_per_mole)
    standard_error = math.sqrt(2.0 / (3 * n))
    assert np.mean(k * pos**2) / kT == pytest.approx(1.0, abs=4 * standard_error)
    assert np.mean(mass * vel**2) / kT == pytest.approx(1.0, abs=4 * standard_error)
    kinetic = context.getState(getEnergy=True).getKineticEnergy().value_in_unit(unit.kilojoule_per_mole)
    assert kinetic == pytest.approx(0.5 * mass * np.sum(vel**2), rel=1e-12)


def test_friction_zero_is_deterministic_at_any_temperature_and_seed(platform_name):
    runs = []
    for temperature, seed in ((300.0, 1), (300.0, 2), (0.0, 3)):
        integrator = StochasticImpulseIntegrator(temperature, 0.0, 0.05, {1})
        integrator.setRandomNumberSeed(seed)
        context = make_context(build_fpu_system(), integrator, platform_name)
        integrator.step(20)
        runs.append(state_arrays(context))
    for other in runs[1:]:
        for a, b in zip(runs[0], other):
            np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("friction", [0.0, 2.0])
def test_cpu_agrees_with_reference(friction):
    states = []
    for platform_name in ("Reference", "CPU"):
        integrator = StochasticImpulseIntegrator(300.0, friction, 0.05, {1})
        integrator.setRandomNumberSeed(7)
        context = make_context(build_fpu_system(), integrator, platform_name)
        integrator.step(40)
        states.append(state_arrays(context))
    for a, b in zip(*states):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-9)
