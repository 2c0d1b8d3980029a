"""FlavorIntegrator trajectories against independent computations: OpenMM's VerletIntegrator when the microstep
equals the mesostep, and a NumPy evaluation of the FLAVOR compositions (docs/ARCHITECTURE.md)."""
import numpy as np
import openmm
import openmm.unit as unit
import pytest

from conftest import (INITIAL_VX, INITIAL_X, TRAJECTORY_RTOL, assert_close_relative, build_fpu_system, make_context,
                      make_integrator, numpy_forces, state_arrays)
from openmmflavors import FlavorIntegrator


def verlet_reference(h, steps, start_velocity_shift):
    """OpenMM's leapfrog VerletIntegrator; returns positions, stored velocities and forces after every step."""
    system = build_fpu_system()
    probe = openmm.Context(system, openmm.VerletIntegrator(h), openmm.Platform.getPlatformByName("Reference"))
    probe.setPositions([openmm.Vec3(x, 0, 0) for x in INITIAL_X])
    f0 = probe.getState(getForces=True).getForces(asNumpy=True).value_in_unit(
        unit.kilojoule_per_mole / unit.nanometer)
    v0 = np.array([[v, 0.0, 0.0] for v in INITIAL_VX])
    start = v0 + start_velocity_shift * h * np.array(f0)  # unit masses
    context = make_context(build_fpu_system(), openmm.VerletIntegrator(h), "Reference",
                           velocities=[openmm.Vec3(*v) for v in start] * unit.nanometer / unit.picosecond)
    positions, velocities, forces = [], [], []
    for _ in range(steps):
        context.getIntegrator().step(1)
        pos, vel, frc = state_arrays(context, forces=True)
        positions.append(pos)
        velocities.append(vel)
        forces.append(frc)
    return np.array(positions), np.array(velocities), np.array(forces)


def flavor_trajectory(integrator, steps, platform_name="Reference"):
    context = make_context(build_fpu_system(), integrator, platform_name)
    positions, velocities = [], []
    for _ in range(steps):
        integrator.step(1)
        pos, vel = state_arrays(context)
        positions.append(pos)
        velocities.append(vel)
    return np.array(positions), np.array(velocities)


def test_verlet_with_micro_equal_meso_is_velocity_verlet():
    h, steps = 0.01, 60
    flavor = make_integrator(meso=h, micro=h, groups={1}, scheme=FlavorIntegrator.Verlet)
    pos, vel = flavor_trajectory(flavor, steps)
    # Leapfrog started from v0 - (h/2) F(q0)/m has velocity-Verlet positions.
    ref_pos, ref_vel, ref_force = verlet_reference(h, steps, -0.5)
    assert np.all(np.isfinite(pos))
    assert np.max(np.abs(pos[-1] - pos[0])) > 1e-2
    assert_close_relative(pos, ref_pos)
    # Synchronous velocities: v_n = v_{n-1/2} + (h/2) F(q_n)/m.
    assert_close_relative(vel, ref_vel + 0.5 * h * ref_force)


def test_symplectic_euler_with_micro_equal_meso_is_symplectic_euler():
    h, steps = 0.01, 60
    flavor = make_integrator(meso=h, micro=h, groups={1}, scheme=FlavorIntegrator.SymplecticEuler)
    pos, vel = flavor_trajectory(flavor, steps)
    # Symplectic Euler (kick then drift) is leapfrog started from v0 itself, with the same stored velocities.
    ref_pos, ref_vel, _ = verlet_reference(h, steps, 0.0)
    assert_close_relative(pos, ref_pos)
    assert_close_relative(vel, ref_vel)


def test_verlet_reduction_is_not_symplectic_euler():
    # The two reductions above must be distinguishable, else they would not test the scheme.
    h, steps = 0.01, 20
    verlet_pos, _ = flavor_trajectory(make_integrator(meso=h, micro=h, groups={1}), steps)
    euler_pos, _ = verlet_reference(h, steps, 0.0)[:2]
    assert np.max(np.abs(verlet_pos - euler_pos)) > 1e-6


# ---------------------------------------------------------------------------------------------------------------
# FLAVOR with microStep < mesoStep, against the compositions written out in NumPy on the 1D chain.


def numpy_flavor_step(x, v, meso, micro, scheme):
    def kick(h, which):
        v[:] += h * numpy_forces(x, which)

    def drift(h):
        x[:] += h * v

    rest = meso - micro
    if scheme == FlavorIntegrator.SymplecticEuler:
        kick(micro, "all"); drift(micro); kick(rest, "soft"); drift(rest)
    else:
        kick(micro / 2, "all"); drift(micro / 2); kick(rest / 2, "soft"); drift(rest)
        kick(rest / 2, "soft"); drift(micro / 2); kick(micro / 2, "all")


def numpy_flavor_trajectory(meso, micro, scheme, steps):
    x, v = INITIAL_X.astype(np.float64).copy(), INITIAL_VX.astype(np.float64).copy()
    positions, velocities = [], []
    for _ in range(steps):
        numpy_flavor_step(x, v, meso, micro, scheme)
        positions.append(x.copy())
        velocities.append(v.copy())
    return np.array(positions), np.array(velocities)


@pytest.mark.parametrize("scheme", [FlavorIntegrator.Verlet, FlavorIntegrator.SymplecticEuler],
                         ids=["Verlet", "SymplecticEuler"])
@pytest.mark.parametrize("meso, micro", [(0.02, 0.002), (0.05, 0.001), (0.01, 0.0075)])
def test_flavor_matches_numpy_composition(platform_name, scheme, meso, micro):
    steps = 40
    integrator = make_integrator(meso=meso, micro=micro, groups={1}, scheme=scheme)
    pos, vel = flavor_trajectory(integrator, steps, platform_name)
    ref_x, ref_v = numpy_flavor_trajectory(meso, micro, scheme, steps)
    # Motion stays on the x axis.
    assert np.all(pos[:, :, 1:] == 0.0) and np.all(vel[:, :, 1:] == 0.0)
    assert_close_relative(pos[:, :, 0], ref_x, TRAJECTORY_RTOL.get(platform_name, 1e-10))
    assert_close_relative(vel[:, :, 0], ref_v, TRAJECTORY_RTOL.get(platform_name, 1e-10))


def test_numpy_composition_distinguishes_micro_steps():
    # The comparison above is only meaningful if the microstep visibly matters at this size.
    a, _ = numpy_flavor_trajectory(0.02, 0.002, FlavorIntegrator.Verlet, 40)
    b, _ = numpy_flavor_trajectory(0.02, 0.001, FlavorIntegrator.Verlet, 40)
    assert np.max(np.abs(a - b)) > 1e-4


def test_parameter_change_between_steps_takes_effect(platform_name):
    # Changing the microstep and scheme mid-run must change the composition used from the next step on.
    integrator = make_integrator(meso=0.02, micro=0.002, groups={1})
    context = make_context(build_fpu_system(), integrator, platform_name)
    integrator.step(10)
    integrator.setMicroStep(0.005)
    integrator.setScheme(FlavorIntegrator.SymplecticEuler)
    integrator.step(10)
    pos, vel = state_arrays(context)

    x, v = INITIAL_X.astype(np.float64).copy(), INITIAL_VX.astype(np.float64).copy()
    for _ in range(10):
        numpy_flavor_step(x, v, 0.02, 0.002, FlavorIntegrator.Verlet)
    for _ in range(10):
        numpy_flavor_step(x, v, 0.02, 0.005, FlavorIntegrator.SymplecticEuler)
    assert_close_relative(pos[:, 0], x)
    assert_close_relative(vel[:, 0], v)


def test_unique_seeds_when_seed_is_zero(platform_name):
    # Seed 0 picks a fresh seed per Context, so two Langevin runs differ.
    runs = []
    for _ in range(2):
        integrator = make_integrator(meso=0.02, micro=0.002, groups={1}, temperature=300.0, friction=5.0, seed=0)
        runs.append(flavor_trajectory(integrator, 3, platform_name)[0][-1])
    assert np.max(np.abs(runs[0] - runs[1])) > 1e-6


def test_langevin_with_friction_moves_off_axis(platform_name):
    # Noise acts in all three dimensions; the Hamiltonian runs above stay on the x axis.
    integrator = make_integrator(meso=0.02, micro=0.002, groups={1}, temperature=300.0, friction=5.0, seed=11)
    pos, vel = flavor_trajectory(integrator, 3, platform_name)
    assert np.all(np.isfinite(pos))
    assert np.max(np.abs(pos[-1, :, 1:])) > 1e-4


# ---------------------------------------------------------------------------------------------------------------
# Friction at zero temperature: the Ornstein-Uhlenbeck flows reduce to v *= exp(-gamma h), so the Langevin
# compositions (slow friction over the mesostep, stiff friction only with the stiff forces) are deterministic.


def numpy_langevin_step(x, v, meso, micro, scheme, gamma, stiff_friction):
    def kick(h, which):
        v[:] += h * numpy_forces(x, which)

    def drift(h):
        x[:] += h * v

    def damp(h):
        v[:] *= np.exp(-gamma * h)

    rest = meso - micro
    if scheme == FlavorIntegrator.SymplecticEuler:
        damp(micro); kick(micro, "all"); drift(micro)
        if not stiff_friction:
            damp(rest)
        kick(rest, "soft"); drift(rest)
    else:
        edge = micro / 2 if stiff_friction else meso / 2
        damp(edge)
        kick(micro / 2, "all"); drift(micro / 2); kick(rest / 2, "soft"); drift(rest)
        kick(rest / 2, "soft"); drift(micro / 2); kick(micro / 2, "all")
        damp(edge)


def numpy_langevin_trajectory(meso, micro, scheme, gamma, stiff_friction, steps):
    x, v = INITIAL_X.astype(np.float64).copy(), INITIAL_VX.astype(np.float64).copy()
    positions, velocities = [], []
    for _ in range(steps):
        numpy_langevin_step(x, v, meso, micro, scheme, gamma, stiff_friction)
        positions.append(x.copy())
        velocities.append(v.copy())
    return np.array(positions), np.array(velocities)


@pytest.mark.parametrize("stiff_friction", [False, True], ids=["slow-friction", "stiff-friction"])
@pytest.mark.parametrize("scheme", [FlavorIntegrator.Verlet, FlavorIntegrator.SymplecticEuler],
                         ids=["Verlet", "SymplecticEuler"])
def test_zero_temperature_friction_matches_numpy(platform_name, scheme, stiff_friction):
    meso, micro, gamma, steps = 0.02, 0.002, 3.0, 40
    integrator = make_integrator(meso=meso, micro=micro, groups={1}, scheme=scheme, temperature=0.0,
                                 friction=gamma, seed=5, stiff_friction=stiff_friction)
    pos, vel = flavor_trajectory(integrator, steps, platform_name)
    ref_x, ref_v = numpy_langevin_trajectory(meso, micro, scheme, gamma, stiff_friction, steps)
    assert np.all(pos[:, :, 1:] == 0.0) and np.all(vel[:, :, 1:] == 0.0)
    assert_close_relative(pos[:, :, 0], ref_x)
    assert_close_relative(vel[:, :, 0], ref_v)


def test_numpy_friction_placements_are_distinguishable():
    # Slow and stiff friction, and no friction, must give visibly different reference trajectories.
    slow, _ = numpy_langevin_trajectory(0.02, 0.002, FlavorIntegrator.Verlet, 3.0, False, 40)
    stiff, _ = numpy_langevin_trajectory(0.02, 0.002, FlavorIntegrator.Verlet, 3.0, True, 40)
    free, _ = numpy_flavor_trajectory(0.02, 0.002, FlavorIntegrator.Verlet, 40)
    assert np.max(np.abs(slow - stiff)) > 1e-3
    assert np.max(np.abs(stiff - free)) > 1e-4
