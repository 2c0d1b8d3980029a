"""The Fermi-Pasta-Ulam chain (FLAVORS paper eq. 6.7, SIM paper eq. 9) shared by examples/fpu, examples/sim_fpu and
the benchmarks.

    H = 1/2 sum p^2 + omega^2/4 sum_{i=1..m} (q_2i - q_2i-1)^2 + sum_{i=0..m} (q_2i+1 - q_2i)^4,  q_0 = q_2m+1 = 0

Unit masses on the x axis.  Stiff springs: HarmonicBondForce (length 0, k = omega^2/2) in force group 1; soft quartic
springs (CustomBondForce "r^4") and the walls (CustomExternalForce "x^4") in group 0.  Slow and fast coordinates:
x0,i = (q_2i + q_2i-1)/sqrt2, x1,i = (q_2i - q_2i-1)/sqrt2; y0, y1 the same for the velocities.

Named fpu_chain, not fpu: examples/fpu/fpu.py would otherwise import itself.
"""
import math

import numpy as np
import openmm as mm

import scene
from scene import leapfrog_start, masses_of, synchronized  # noqa: F401  (re-exported for the benchmarks)

SQRT2 = math.sqrt(2.0)
SOFT_GROUP, STIFF_GROUP = 0, 1


def fpu_system(m, omega, chains=1):
    """`chains` copies of the chain; particle 2m*c + k is q_{k+1} of chain c."""
    system = mm.System()
    stiff = mm.HarmonicBondForce()
    soft = mm.CustomBondForce("r^4")
    walls = mm.CustomExternalForce("x^4")
    stiff.setForceGroup(STIFF_GROUP)
    soft.setForceGroup(SOFT_GROUP)
    walls.setForceGroup(SOFT_GROUP)
    for c in range(chains):
        first = system.getNumParticles()
        for _ in range(2 * m):
            system.addParticle(1.0)
        for i in range(m):
            # k/2 r^2 with k = omega^2/2 is omega^2/4 (q_2i - q_2i-1)^2.
            stiff.addBond(first + 2 * i, first + 2 * i + 1, 0.0, omega * omega / 2)
        for i in range(m - 1):
            soft.addBond(first + 2 * i + 1, first + 2 * i + 2)
        walls.addParticle(first)
        walls.addParticle(first + 2 * m - 1)
    for force in (stiff, soft, walls):
        system.addForce(force)
    return system


def from_slow_fast(x0, x1):
    """Particle coordinates (last axis: 2m particles) from slow x0 and fast x1 (last axis: m), the inverse of
    eq. (10): q_2i-1 = (x0_i - x1_i)/sqrt2, q_2i = (x0_i + x1_i)/sqrt2.  Works for velocities alike."""
    x0, x1 = np.asarray(x0, dtype=float), np.asarray(x1, dtype=float)
    q = np.empty(x0.shape[:-1] + (2 * x0.shape[-1],))
    q[..., 0::2] = (x0 - x1) / SQRT2
    q[..., 1::2] = (x0 + x1) / SQRT2
    return q


def fpu_positions(x0, x1):
    """One chain's positions on the x axis, as a list of 3-tuples."""
    return [(float(a), 0.0, 0.0) for a in from_slow_fast(x0, x1)]


def chain_positions(m, omega, chains, seed=1234):
    """Chain 0 at the Fig. 6.5 start x0 = (1, 0, ..), x1 = (1/omega, 0, ..); the others at random slow/fast
    coordinates of the same size.  Chain c lies at y = c.  Returns an array (2m chains, 3)."""
    rng = np.random.default_rng(seed)
    x0 = 0.5 * rng.uniform(-1, 1, (chains, m))
    x1 = rng.uniform(-1, 1, (chains, m)) / omega
    x0[0], x1[0] = [1.0] + [0.0] * (m - 1), [1.0 / omega] + [0.0] * (m - 1)
    q = np.zeros((chains, 2 * m, 3))
    q[:, :, 0] = from_slow_fast(x0, x1)
    q[:, :, 1] = np.arange(chains)[:, None]
    return q.reshape(-1, 3)


def observables(q, v, omega):
    """Slow x0, fast x1, fast velocities y1, stiff energies I_j = (y1_j^2 + omega^2 x1_j^2)/2 and omega^2 x1_j^2 (the
    last axis of q and v: particles)."""
    x0 = (q[..., 1::2] + q[..., 0::2]) / SQRT2
    x1 = (q[..., 1::2] - q[..., 0::2]) / SQRT2
    y1 = (v[..., 1::2] - v[..., 0::2]) / SQRT2
    return {"x0": x0, "x1": x1, "y1": y1, "I": 0.5 * (y1 * y1 + omega * omega * x1 * x1),
            "Ix": omega * omega * x1 * x1}


def start_context(system, integrator, dt, leapfrog, positions):
    """A Reference Context at `positions` with v = 0 (for a leapfrog run, v(-dt/2): see scene.leapfrog_start)."""
    return scene.start_context(system, integrator, dt, positions, np.zeros((system.getNumParticles(), 3)), leapfrog)


def read_x(context, dt, leapfrog, masses):
    """The x coordinates of the positions and of the velocities (synchronized for a leapfrog run)."""
    q, v, _ = scene.read_state(context, dt, leapfrog, masses)
    return q[:, 0], v[:, 0]


def simulate(system, integrator, dt, leapfrog, positions, times, label, progress, hint):
    """Run on the Reference platform from (positions, v = 0) and sample the x coordinates at `times`.

    progress: a Progress for `label`; hint: the message (with {dt}) when dt does not divide the times.
    Returns q, v (samples x particles), potential energies, the step count and the wall time of the step() calls."""
    run = scene.simulate(system, integrator, dt, positions, np.zeros((system.getNumParticles(), 3)), times, label,
                         leapfrog=leapfrog, energy=True, progress=progress, hint=hint)
    return {"q": run["q"][:, :, 0], "v": run["v"][:, :, 0], "pe": run["pe"], "masses": run["masses"],
            "steps": run["steps"], "wall_s": run["wall_s"]}


def simulate_observed(system, integrator, dt, leapfrog, positions, times, omega, label, progress, hint):
    """simulate(), returned as the chain's observables (x0, x1, y1, I, Ix) and total energy E at `times`."""
    run = simulate(system, integrator, dt, leapfrog, positions, times, label, progress, hint)
    o = observables(run["q"], run["v"], omega)
    energy = 0.5 * np.sum(run["masses"] * run["v"] * run["v"], axis=1) + run["pe"]
    return {"steps": run["steps"], "wall_s": run["wall_s"], "E": energy, **o}
