"""StochasticImpulseIntegrator (friction 0) on the FPU chain against an independent NumPy computation of the
splittings (docs/ARCHITECTURE.md) with a nonlinear soft force: the stiff flow is written out per spring (centre of
mass drifts, the bond length rotates at OMEGA), with no probing, no modes and no matrices."""
import math

import numpy as np
import pytest

from conftest import (INITIAL_VX, INITIAL_X, OMEGA, STIFF_PAIRS, TRAJECTORY_RTOL, assert_close_relative,
                      build_fpu_system, make_context, numpy_forces, run_trajectory)
from openmmflavors import StochasticImpulseIntegrator

SPLITTINGS = {"LieTrotter": StochasticImpulseIntegrator.LieTrotter, "Strang": StochasticImpulseIntegrator.Strang,
              "Yoshida4": StochasticImpulseIntegrator.Yoshida4}
YOSHIDA_C = 1.0 / (2.0 - 2.0 ** (1.0 / 3.0))


def numpy_stiff_flow(x, v, h):
    """Exact flow of the stiff springs (k = OMEGA^2/2 between unit masses: the bond length oscillates at OMEGA)."""
    c, s = math.cos(OMEGA * h), math.sin(OMEGA * h)
    for i, j in STIFF_PAIRS:
        centre, centre_v = (x[i] + x[j]) / 2, (v[i] + v[j]) / 2
        d, dv = x[j] - x[i], v[j] - v[i]
        d, dv = c * d + s / OMEGA * dv, -OMEGA * s * d + c * dv
        centre += h * centre_v
        x[i], x[j] = centre - d / 2, centre + d / 2
        v[i], v[j] = centre_v - dv / 2, centre_v + dv / 2


def numpy_impulse_step(x, v, H, splitting):
    def kick(h):
        v[:] += h * numpy_forces(x, "soft")

    if splitting == "LieTrotter":
        numpy_stiff_flow(x, v, H)
        kick(H)
        return
    stages = [1.0] if splitting == "Strang" else [YOSHIDA_C, 1 - 2 * YOSHIDA_C, YOSHIDA_C]
    for a in stages:
        kick(a * H / 2)
        numpy_stiff_flow(x, v, a * H)
        kick(a * H / 2)


def numpy_impulse_trajectory(H, splitting, steps):
    x, v = INITIAL_X.astype(np.float64).copy(), INITIAL_VX.astype(np.float64).copy()
    positions, velocities = [], []
    for _ in range(steps):
        numpy_impulse_step(x, v, H, splitting)
        positions.append(x.copy())
        velocities.append(v.copy())
    return np.array(positions), np.array(velocities)


# Reduced units (H = 0.37 is no molecular step), and Yoshida4's longest substep at H = 0.37 is 8.02 pi: this compares
# compositions, not accuracy, so openmmflavors' warnings about both are expected.
@pytest.mark.filterwarnings("ignore::openmmflavors.FlavorsWarning")
@pytest.mark.parametrize("splitting", list(SPLITTINGS))
@pytest.mark.parametrize("H", [0.013, 0.37])  # OMEGA H = 0.52 and 14.8 (2.36 turns: between resonances)
def test_impulse_matches_numpy_composition(platform_name, splitting, H):
    steps = 40
    integrator = StochasticImpulseIntegrator(0.0, 0.0, H, {1})
    integrator.setSplitting(SPLITTINGS[splitting])
    context = make_context(build_fpu_system(), integrator, platform_name)
    pos, vel = run_trajectory(context, steps)
    ref_x, ref_v = numpy_impulse_trajectory(H, splitting, steps)
    assert np.all(pos[:, :, 1:] == 0.0) and np.all(vel[:, :, 1:] == 0.0)
    assert_close_relative(pos[:, :, 0], ref_x, TRAJECTORY_RTOL.get(platform_name, 1e-10))
    assert_close_relative(vel[:, :, 0], ref_v, TRAJECTORY_RTOL.get(platform_name, 1e-10))


@pytest.mark.parametrize("H", [0.013, 0.37])
def test_numpy_splittings_are_distinguishable(H):
    # The comparison above is only meaningful if the splittings differ by far more than its tolerance (1e-10 of
    # the largest coordinate, about 0.5) at these steps.
    runs = {name: numpy_impulse_trajectory(H, name, 40)[0] for name in SPLITTINGS}
    for a in SPLITTINGS:
        for b in SPLITTINGS:
            if a < b:
                assert np.max(np.abs(runs[a] - runs[b])) > 1e-6, (a, b)
