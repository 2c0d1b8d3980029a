"""What FLAVORS paper §2 and §4 prove about the nonintrusive FLAVOR's one-step map, checked on the FPU test chain
(6 unit masses on the x axis, conftest): Theorem 2.2 (symplectic for a symplectic legacy integrator), Theorem 2.4
(the Verlet FLAVOR (2.7) is time-reversible, symplectic Euler's (2.5) is not), Theorem 2.1 (symmetric under the
legacy integrator's group actions: translations and rotations give conserved momenta) and Theorem 4.1 (with isotropic
friction the Langevin FLAVOR is conformally symplectic: J^T Omega J = exp(-gamma delta) Omega).  Reference platform."""
import math

import numpy as np
import openmm
import openmm.unit as unit
import pytest

from conftest import INITIAL_VX, INITIAL_X, build_fpu_system, make_integrator

SCHEMES = {"Verlet": 1, "SymplecticEuler": 0}


def one_step(integrator_args, x, v, steps=1, system=None):
    """The FLAVOR's map over `steps` mesosteps from positions x and velocities v (arrays of shape (n, 3))."""
    integrator = make_integrator(**integrator_args)
    context = openmm.Context(system or build_fpu_system(), integrator, openmm.Platform.getPlatformByName("Reference"))
    context.setPositions(x * unit.nanometer)
    context.setVelocities(v * unit.nanometer / unit.picosecond)
    integrator.step(steps)
    state = context.getState(getPositions=True, getVelocities=True)
    return (np.array(state.getPositions(asNumpy=True)._value), np.array(state.getVelocities(asNumpy=True)._value))


def start():
    x, v = np.zeros((6, 3)), np.zeros((6, 3))
    x[:, 0], v[:, 0] = INITIAL_X, INITIAL_VX
    return x, v


def jacobian(integrator_args, h=1e-5):
    """The Jacobian of the x-axis map (x_1..x_6, v_1..v_6) -> same, by central differences."""
    x, v = start()
    z0 = np.concatenate([x[:, 0], v[:, 0]])
    columns = []
    for i in range(12):
        images = []
        for sign in (1, -1):
            z = z0.copy()
            z[i] += sign * h
            xi, vi = np.zeros((6, 3)), np.zeros((6, 3))
            xi[:, 0], vi[:, 0] = z[:6], z[6:]
            xo, vo = one_step(integrator_args, xi, vi)
            images.append(np.concatenate([xo[:, 0], vo[:, 0]]))
        columns.append((images[0] - images[1]) / (2 * h))
    return np.array(columns).T


OMEGA = np.block([[np.zeros((6, 6)), np.eye(6)], [-np.eye(6), np.zeros((6, 6))]])


@pytest.mark.parametrize("scheme", SCHEMES)
def test_one_step_map_is_symplectic(scheme):
    # Theorem 2.2 (and 2.4 for Verlet): J^T Omega J = Omega.  Central differences with h = 1e-5 give it to about
    # 1e-11 here; a map that is not symplectic (the friction case below) is off by O(gamma delta) = 0.06.
    J = jacobian(dict(scheme=SCHEMES[scheme]))
    assert np.max(np.abs(J.T @ OMEGA @ J - OMEGA)) < 1e-9
    assert np.max(np.abs(J - np.eye(12))) > 0.01  # the step does something


@pytest.mark.parametrize("scheme", SCHEMES)
def test_langevin_step_is_conformally_symplectic(scheme):
    # Theorem 4.1: friction gamma on every particle over the whole mesostep (zero temperature: no noise, which would
    # not change the Jacobian anyway) scales the symplectic form by exp(-gamma delta) per step.
    gamma, delta = 3.0, 0.02
    J = jacobian(dict(scheme=SCHEMES[scheme], temperature=0.0, friction=gamma))
    form = J.T @ OMEGA @ J
    assert np.max(np.abs(form - math.exp(-gamma * delta) * OMEGA)) < 1e-9
    assert np.max(np.abs(form - OMEGA)) > 0.05


def test_verlet_flavor_is_reversible_and_symplectic_euler_is_not():
    # Theorem 2.4: (2.7) is its own adjoint, so stepping back with negated velocities returns to the start; the
    # symplectic Euler FLAVOR (2.5) is not symmetric and misses the start at O(delta^2).
    x, v = start()
    misses = {}
    for scheme, value in SCHEMES.items():
        args = dict(scheme=value)
        x1, v1 = one_step(args, x, v, steps=25)
        x2, v2 = one_step(args, x1, -v1, steps=25)
        misses[scheme] = max(np.max(np.abs(x2 - x)), np.max(np.abs(-v2 - v)))
    assert misses["Verlet"] < 1e-12
    assert misses["SymplecticEuler"] > 1e-4


def test_translations_and_rotations_give_conserved_momenta():
    # Theorem 2.1: a chain of stiff harmonic and soft quartic bonds between particles in 3-D (no walls) is invariant
    # under translations and rotations, and so are symplectic Euler and Verlet; so is the FLAVOR, and by the discrete
    # Noether theorem it conserves linear and angular momentum.
    system = openmm.System()
    for _ in range(4):
        system.addParticle(1.0)
    stiff = openmm.HarmonicBondForce()
    stiff.addBond(0, 1, 0.1, 1600.0)
    stiff.addBond(2, 3, 0.1, 1600.0)
    stiff.setForceGroup(1)
    soft = openmm.CustomBondForce("r^4")
    soft.addBond(1, 2, [])
    system.addForce(stiff)
    system.addForce(soft)
    rng = np.random.default_rng(3)
    x = np.array([[0, 0, 0], [0.1, 0.02, 0], [0.5, -0.1, 0.2], [0.55, -0.05, 0.28]]) + 0.01 * rng.standard_normal((4, 3))
    v = rng.standard_normal((4, 3))
    for scheme in SCHEMES.values():
        x1, v1 = one_step(dict(scheme=scheme), x, v, steps=200, system=system)
        assert np.max(np.abs(v1 - v)) > 0.1  # the motion is not trivial
        np.testing.assert_allclose(v1.sum(axis=0), v.sum(axis=0), rtol=0, atol=1e-11)
        np.testing.assert_allclose(np.cross(x1, v1).sum(axis=0), np.cross(x, v).sum(axis=0), rtol=0, atol=1e-11)
