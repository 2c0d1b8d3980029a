"""Context checkpoints restore a FlavorIntegrator simulation so that it continues bit for bit."""
import numpy as np
import openmm.unit as unit
import pytest

from conftest import (assert_continuation_depends_on_random_state, assert_set_state_reproduces, build_fpu_system,
                      make_context, make_integrator, run_trajectory, state_arrays)
from openmmflavors import FlavorIntegrator

N_BEFORE = 7
M_AFTER = 12

CASES = {
    "hamiltonian-verlet": dict(scheme=FlavorIntegrator.Verlet),
    "hamiltonian-euler": dict(scheme=FlavorIntegrator.SymplecticEuler),
    "langevin-verlet": dict(scheme=FlavorIntegrator.Verlet, temperature=300.0, friction=5.0, seed=2024),
    "langevin-euler": dict(scheme=FlavorIntegrator.SymplecticEuler, temperature=300.0, friction=5.0, seed=2024),
    "langevin-stiff-friction": dict(scheme=FlavorIntegrator.Verlet, temperature=300.0, friction=5.0, seed=31337,
                                    stiff_friction=True),
}


def case_integrator(case, **overrides):
    options = dict(CASES[case])
    options.update(overrides)
    return make_integrator(meso=0.02, micro=0.002, groups={1}, **options)


def time_and_steps(context):
    state = context.getState()
    return state.getTime().value_in_unit(unit.picosecond), state.getStepCount()


@pytest.mark.parametrize("case", list(CASES))
def test_checkpoint_restores_and_continues_identically(platform_name, case):
    context = make_context(build_fpu_system(), case_integrator(case), platform_name)
    integrator = context.getIntegrator()
    integrator.step(N_BEFORE)
    pos_at_checkpoint, vel_at_checkpoint = state_arrays(context)
    time_at_checkpoint, steps_at_checkpoint = time_and_steps(context)
    assert steps_at_checkpoint == N_BEFORE
    assert time_at_checkpoint == pytest.approx(N_BEFORE * 0.02, rel=1e-12)

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
    time_end, steps_end = time_and_steps(context)
    assert steps_end == N_BEFORE + M_AFTER
    assert time_end == pytest.approx((N_BEFORE + M_AFTER) * 0.02, rel=1e-12)


@pytest.mark.parametrize("case", ["hamiltonian-verlet", "langevin-verlet", "langevin-stiff-friction"])
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


@pytest.mark.parametrize("case", list(CASES))
def test_checkpoint_loaded_into_new_context(platform_name, case):
    context = make_context(build_fpu_system(), case_integrator(case), platform_name)
    context.getIntegrator().step(N_BEFORE)
    checkpoint = context.createCheckpoint()
    positions, velocities = run_trajectory(context, M_AFTER)

    other = make_context(build_fpu_system(), case_integrator(case), platform_name)
    other.loadCheckpoint(checkpoint)
    assert time_and_steps(other)[1] == N_BEFORE
    positions_other, velocities_other = run_trajectory(other, M_AFTER)
    np.testing.assert_array_equal(positions_other, positions)
    np.testing.assert_array_equal(velocities_other, velocities)


@pytest.mark.parametrize("case", ["langevin-verlet", "langevin-stiff-friction"])
def test_checkpoint_restores_random_state_over_a_different_seed(platform_name, case):
    # The checkpoint carries the random state, as OpenMM's own Langevin integrators' checkpoints do.
    context = make_context(build_fpu_system(), case_integrator(case), platform_name)
    context.getIntegrator().step(N_BEFORE)
    checkpoint = context.createCheckpoint()
    positions, velocities = run_trajectory(context, M_AFTER)

    other = make_context(build_fpu_system(), case_integrator(case, seed=99), platform_name)
    other.getIntegrator().step(2)
    other.loadCheckpoint(checkpoint)
    positions_other, velocities_other = run_trajectory(other, M_AFTER)
    np.testing.assert_array_equal(positions_other, positions)
    np.testing.assert_array_equal(velocities_other, velocities)


def test_langevin_continuation_depends_on_the_random_state(platform_name):
    context = make_context(build_fpu_system(), case_integrator("langevin-verlet"), platform_name)
    assert_continuation_depends_on_random_state(context, N_BEFORE, M_AFTER)


@pytest.mark.parametrize("case", ["hamiltonian-verlet", "hamiltonian-euler"])
def test_set_positions_invalidates_cached_forces(platform_name, case):
    # The integrator caches forces between steps; resetting the state must not reuse forces of the old positions.
    assert_set_state_reproduces(make_context(build_fpu_system(), case_integrator(case), platform_name), N_BEFORE,
                                M_AFTER)


def test_parameter_change_after_checkpoint_is_used(platform_name):
    # The checkpoint holds the dynamical state, not the integrator's parameters.
    context = make_context(build_fpu_system(), case_integrator("hamiltonian-verlet"), platform_name)
    integrator = context.getIntegrator()
    integrator.step(N_BEFORE)
    checkpoint = context.createCheckpoint()
    positions, _ = run_trajectory(context, M_AFTER)
    context.loadCheckpoint(checkpoint)
    integrator.setMicroStep(0.001)
    positions_changed, _ = run_trajectory(context, M_AFTER)
    assert np.all(np.isfinite(positions_changed))
    assert np.max(np.abs(positions_changed[-1] - positions[-1])) > 1e-5
