"""Context checkpoints restore a StochasticImpulseIntegrator simulation so that it continues bit for bit, with and
without friction (the checkpoint must carry the random state)."""
import numpy as np
import openmm
import openmm.unit as unit
import pytest

from conftest import (assert_continuation_depends_on_random_state, assert_set_state_reproduces, build_fpu_system,
                      make_context, run_trajectory, state_arrays)
from openmmflavors import StochasticImpulseIntegrator

N_BEFORE = 7
M_AFTER = 12
STEP = 0.05  # omega*H = 2: a large step, as SIM is meant to take

CASES = {
    "strang-friction0": dict(splitting=StochasticImpulseIntegrator.Strang, friction=0.0),
    "lietrotter-friction0": dict(splitting=StochasticImpulseIntegrator.LieTrotter, friction=0.0),
    "yoshida4-friction0": dict(splitting=StochasticImpulseIntegrator.Yoshida4, friction=0.0),
    "strang-langevin": dict(splitting=StochasticImpulseIntegrator.Strang, friction=3.0, seed=2024),
    "lietrotter-langevin": dict(splitting=StochasticImpulseIntegrator.LieTrotter, friction=3.0, seed=77),
    "strang-langevin-cold-stiff-modes": dict(splitting=StochasticImpulseIntegrator.Strang, friction=3.0, seed=5,
                                             stiff_mode_bath=(1.0, 20.0)),
    "filtered-langevin-cold-stiff-modes": dict(splitting=StochasticImpulseIntegrator.Filtered, friction=3.0, seed=8,
                                               stiff_mode_bath=(1.0, 20.0)),
    "filtered-friction0": dict(splitting=StochasticImpulseIntegrator.Filtered, friction=0.0),
    "warped-langevin-cold-stiff-modes": dict(splitting=StochasticImpulseIntegrator.Warped, friction=3.0, seed=9,
                                             stiff_mode_bath=(1.0, 20.0)),
    "warped-middle-langevin": dict(splitting=StochasticImpulseIntegrator.Warped, friction=3.0, seed=10,
                                   placement=StochasticImpulseIntegrator.Middle),
}
LANGEVIN = [case for case in CASES if "langevin" in case]


def case_integrator(case, seed=None):
    options = CASES[case]
    integrator = StochasticImpulseIntegrator(300.0, options["friction"], STEP, {1})
    integrator.setSplitting(options["splitting"])
    if "placement" in options:
        integrator.setThermostatPlacement(options["placement"])
    if "stiff_mode_bath" in options:
        integrator.setStiffModeTemperature(options["stiff_mode_bath"][0])
        integrator.setStiffModeFriction(options["stiff_mode_bath"][1])
    chosen = seed if seed is not None else options.get("seed")
    if chosen is not None:
        integrator.setRandomNumberSeed(chosen)
    return integrator


def time_and_steps(context):
    state = context.getState()
    return state.getTime().value_in_unit(unit.picosecond), state.getStepCount()


@pytest.mark.parametrize("case", list(CASES))
def test_checkpoint_restores_and_continues_identically(platform_name, case):
    context = make_context(build_fpu_system(), case_integrator(case), platform_name)
    context.getIntegrator().step(N_BEFORE)
    pos_at_checkpoint, vel_at_checkpoint = state_arrays(context)
    time_at_checkpoint, steps_at_checkpoint = time_and_steps(context)
    assert steps_at_checkpoint == N_BEFORE
    assert time_at_checkpoint == pytest.approx(N_BEFORE * STEP, rel=1e-12)

    checkpoint = context.createCheckpoint()
    positions, velocities = run_trajectory(context, M_AFTER)
    assert np.max(np.abs(positions[-1] - pos_at_checkpoint)) > 1e-3

    context.loadCheckpoint(checkpoint)
    pos_loaded, vel_loaded = state_arrays(context)
    np.testing.assert_array_equal(pos_loaded, pos_at_checkpoint)
    np.testing.assert_array_equal(vel_loaded, vel_at_checkpoint)
    assert time_and_steps(context) == (time_at_checkpoint, steps_at_checkpoint)

    positions_again, velocities_again = run_trajectory(context, M_AFTER)
    np.testing.assert_array_equal(positions_again, positions)
    np.testing.assert_array_equal(velocities_again, velocities)
    assert time_and_steps(context)[1] == N_BEFORE + M_AFTER


@pytest.mark.parametrize("case", list(CASES))
def test_checkpoint_loaded_into_new_context(platform_name, case):
    context = make_context(build_fpu_system(), case_integrator(case), platform_name)
    context.getIntegrator().step(N_BEFORE)
    checkpoint = context.createCheckpoint()
    positions, velocities = run_trajectory(context, M_AFTER)

    # A different seed in the new context: the checkpoint's random state must win.
    other = make_context(build_fpu_system(), case_integrator(case, seed=99), platform_name)
    other.getIntegrator().step(2)
    other.loadCheckpoint(checkpoint)
    assert time_and_steps(other)[1] == N_BEFORE
    positions_other, velocities_other = run_trajectory(other, M_AFTER)
    np.testing.assert_array_equal(positions_other, positions)
    np.testing.assert_array_equal(velocities_other, velocities)


@pytest.mark.parametrize("case", LANGEVIN)
def test_checkpoint_loaded_twice(platform_name, case):
    # Loading must not consume or shift the random stream it restores.
    context = make_context(build_fpu_system(), case_integrator(case), platform_name)
    context.getIntegrator().step(N_BEFORE)
    checkpoint = context.createCheckpoint()
    first, _ = run_trajectory(context, M_AFTER)
    context.loadCheckpoint(checkpoint)
    context.getIntegrator().step(3)
    context.loadCheckpoint(checkpoint)
    second, _ = run_trajectory(context, M_AFTER)
    np.testing.assert_array_equal(second, first)


@pytest.mark.parametrize("case", LANGEVIN)
def test_same_seed_same_trajectory_and_other_seed_differs(platform_name, case):
    runs = []
    for seed in (None, None, 12345):
        context = make_context(build_fpu_system(), case_integrator(case, seed=seed), platform_name)
        runs.append(run_trajectory(context, M_AFTER)[0])
    np.testing.assert_array_equal(runs[0], runs[1])
    assert np.max(np.abs(runs[2][-1] - runs[0][-1])) > 1e-4


@pytest.mark.parametrize("case", LANGEVIN)
def test_langevin_continuation_depends_on_the_random_state(platform_name, case):
    context = make_context(build_fpu_system(), case_integrator(case), platform_name)
    assert_continuation_depends_on_random_state(context, N_BEFORE, M_AFTER)


@pytest.mark.parametrize("case", ["strang-friction0", "lietrotter-friction0"])
def test_set_positions_invalidates_cached_forces(platform_name, case):
    assert_set_state_reproduces(make_context(build_fpu_system(), case_integrator(case), platform_name), N_BEFORE,
                                M_AFTER)


def test_step_size_change_after_checkpoint_is_used(platform_name):
    # The checkpoint holds the dynamical state, not the integrator's parameters; the propagators must be rebuilt.
    context = make_context(build_fpu_system(), case_integrator("strang-friction0"), platform_name)
    integrator = context.getIntegrator()
    integrator.step(N_BEFORE)
    checkpoint = context.createCheckpoint()
    positions, _ = run_trajectory(context, M_AFTER)
    context.loadCheckpoint(checkpoint)
    integrator.setStepSize(STEP / 2)
    half, _ = run_trajectory(context, 2 * M_AFTER)
    assert np.all(np.isfinite(half))
    # Same end time, different discretization: close but not identical.
    difference = np.max(np.abs(half[-1] - positions[-1]))
    assert 1e-9 < difference < 0.1


def rigid_drude_water(molecules=8):
    """Rigid waters (O, H, H, D) whose oxygens are Drude cores held by SETTLE; tethers on every particle and
    a field on the Drude particles are the soft forces, the Drude springs (group 1) the stiff ones."""
    system = openmm.System()
    springs = openmm.HarmonicBondForce()
    springs.setForceGroup(1)
    tether = openmm.CustomExternalForce("0.5*2000*((x-x0)^2+(y-y0)^2+(z-z0)^2)-300*(x+0.5*y)*isdrude")
    for name in ("x0", "y0", "z0", "isdrude"):
        tether.addPerParticleParameter(name)
    positions = []
    oh, angle = 0.09572, np.radians(104.52)
    for m in range(molecules):
        first = system.getNumParticles()
        for mass in (15.2, 1.008, 1.008, 0.4):
            system.addParticle(mass)
        system.addConstraint(first, first + 1, oh)
        system.addConstraint(first, first + 2, oh)
        system.addConstraint(first + 1, first + 2, 2 * oh * np.sin(angle / 2))
        springs.addBond(first, first + 3, 0.0, 418400.0)
        origin = np.array([0.4 * (m % 2), 0.4 * ((m // 2) % 2), 0.4 * (m // 4)])
        molecule = [origin, origin + [oh, 0, 0], origin + [oh * np.cos(angle), oh * np.sin(angle), 0],
                    origin + [0.002, -0.001, 0.0015]]
        for i, x in enumerate(molecule):
            rest = x + [0.01 * ((m + i) % 3), -0.01, 0.005 * i]
            tether.addParticle(first + i, [*rest, 1.0 if i == 3 else 0.0])
            positions.append(openmm.Vec3(*x))
    system.addForce(springs)
    system.addForce(tether)
    return system, positions


@pytest.mark.parametrize("splitting, placement", [
    (StochasticImpulseIntegrator.Strang, StochasticImpulseIntegrator.Throughout),
    (StochasticImpulseIntegrator.Filtered, StochasticImpulseIntegrator.Throughout),
    (StochasticImpulseIntegrator.Warped, StochasticImpulseIntegrator.Middle)])
def test_checkpoint_carries_the_step_history_of_constrained_drude_cores(platform_name, splitting, placement):
    # With the Middle placement a step returns velocities processed for the closing half of its constraint impulses,
    # which the next step takes off (and Filtered's the processing of its soft forces): a checkpoint must hold them,
    # also when it is loaded into a Context that has not taken a step (its constrained pairs are not known until then).
    def integrator(seed):
        sim = StochasticImpulseIntegrator(300.0, 5.0, 0.002, {1})
        sim.setSplitting(splitting)
        sim.setThermostatPlacement(placement)
        sim.setStiffModeTemperature(1.0)
        sim.setStiffModeFriction(20.0)
        sim.setRandomNumberSeed(seed)
        return sim

    system, positions = rigid_drude_water()
    velocities = [openmm.Vec3(0, 0, 0)] * len(positions)
    context = make_context(system, integrator(3), platform_name, positions, velocities)
    context.getIntegrator().step(N_BEFORE)
    checkpoint = context.createCheckpoint()
    expected, expected_velocities = run_trajectory(context, M_AFTER)
    context.loadCheckpoint(checkpoint)
    again, _ = run_trajectory(context, M_AFTER)
    np.testing.assert_array_equal(again, expected)

    stepped = make_context(system, integrator(99), platform_name, positions, velocities)
    stepped.getIntegrator().step(2)
    stepped.loadCheckpoint(checkpoint)
    from_stepped, _ = run_trajectory(stepped, M_AFTER)
    np.testing.assert_array_equal(from_stepped, expected)

    # A Context that has not stepped measures its stiff modes at the checkpoint's positions instead of the first ones,
    # which changes the propagator in its last bits: the trajectories agree to rounding.
    fresh = make_context(system, integrator(99), platform_name, positions, velocities)
    fresh.loadCheckpoint(checkpoint)
    from_fresh, from_fresh_velocities = run_trajectory(fresh, M_AFTER)
    np.testing.assert_allclose(from_fresh, expected, rtol=0, atol=1e-13)
    np.testing.assert_allclose(from_fresh_velocities, expected_velocities, rtol=0, atol=1e-10)
