"""The systems the benchmarks share: the Fermi-Pasta-Ulam chain and the two-mass linear system.

The FPU chain (FLAVORS paper eq. 6.7, SIM paper eq. 9; Hairer-Lubich-Wanner, Geometric Numerical Integration,
section I.5):

    H = 1/2 sum p^2 + omega^2/4 sum_{i=1..m} (q_2i - q_2i-1)^2 + sum_{i=0..m} (q_2i+1 - q_2i)^4,  q_0 = q_2m+1 = 0

Unit masses on the x axis.  Stiff springs: HarmonicBondForce (length 0, k = omega^2/2) in force group 1; soft quartic
springs (CustomBondForce "r^4") and the walls (CustomExternalForce "x^4") in group 0.  Slow and fast coordinates:
x0,i = (q_2i + q_2i-1)/sqrt2, x1,i = (q_2i - q_2i-1)/sqrt2; y0, y1 the same for the velocities.

Units are OpenMM's, read as the papers' dimensionless ones (mass 1 amu, length 1 nm, time 1 ps, energy 1 kJ/mol).
"""
import math

import numpy as np
import openmm as mm
import openmm.unit as unit

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


def fpu_initial(m, omega, setup="paper"):
    """(q, v) on the x axis, each of length 2m.

    'paper': FLAVORS Fig. 6.5 and SIM Fig. 4: x0 = (1, 0, ..), x1 = (1/omega, 0, ..), y = 0.
    'hlw':   Hairer-Lubich-Wanner (GNI section I.5.1): x0,1 = 1, y0,1 = 1, x1,1 = 1/omega, y1,1 = 1, others 0.
    """
    x0, x1, y0, y1 = (np.zeros(m) for _ in range(4))
    x0[0], x1[0] = 1.0, 1.0 / omega
    if setup == "hlw":
        y0[0], y1[0] = 1.0, 1.0
    elif setup != "paper":
        raise ValueError(f"unknown FPU setup {setup!r}")
    return from_slow_fast(x0, x1), from_slow_fast(y0, y1)


def chain_positions(m, omega, chains, seed=1234):
    """Chain 0 at the Fig. 6.5 start; the others at random slow/fast coordinates of the same size.  Chain c lies at
    y = c.  Returns an array (2m chains, 3)."""
    rng = np.random.default_rng(seed)
    x0 = 0.5 * rng.uniform(-1, 1, (chains, m))
    x1 = rng.uniform(-1, 1, (chains, m)) / omega
    x0[0], x1[0] = [1.0] + [0.0] * (m - 1), [1.0 / omega] + [0.0] * (m - 1)
    q = np.zeros((chains, 2 * m, 3))
    q[:, :, 0] = from_slow_fast(x0, x1)
    q[:, :, 1] = np.arange(chains)[:, None]
    return q.reshape(-1, 3)


def as_vec3(x, y=0.0):
    """Positions or velocities (particles, 3) from their x (and y) components."""
    out = np.zeros((len(x), 3))
    out[:, 0] = x
    out[:, 1] = y
    return out


def observables(q, v, omega):
    """Slow x0, fast x1, fast velocities y1, stiff energies I_j = (y1_j^2 + omega^2 x1_j^2)/2 and omega^2 x1_j^2 (the
    last axis of q and v: the particles' x coordinates)."""
    x0 = (q[..., 1::2] + q[..., 0::2]) / SQRT2
    x1 = (q[..., 1::2] - q[..., 0::2]) / SQRT2
    y1 = (v[..., 1::2] - v[..., 0::2]) / SQRT2
    return {"x0": x0, "x1": x1, "y1": y1, "I": 0.5 * (y1 * y1 + omega * omega * x1 * x1),
            "Ix": omega * omega * x1 * x1}


def fpu_energy(q, v, omega):
    """Total energy of one chain from its x coordinates and velocities."""
    d = np.diff(np.concatenate(([0.0], q, [0.0])))
    return 0.5 * np.sum(v * v) + 0.25 * omega * omega * np.sum(d[1::2] ** 2) + np.sum(d[0::2] ** 4)


def two_mass_system(omega):
    """The FLAVORS paper's system (5.1): H = px^2/2 + py^2/2 + x^2/2 + omega^2/2 (y - x)^2.  Particle 0 is x,
    particle 1 is y."""
    system = mm.System()
    system.addParticle(1.0)
    system.addParticle(1.0)
    soft = mm.CustomExternalForce("0.5*x^2")
    soft.addParticle(0)
    soft.setForceGroup(SOFT_GROUP)
    stiff = mm.HarmonicBondForce()
    stiff.addBond(0, 1, 0.0, omega * omega)
    stiff.setForceGroup(STIFF_GROUP)
    system.addForce(soft)
    system.addForce(stiff)
    return system


def assign_force_groups(system, groups_by_type):
    """Puts every force of `system` in the group that `groups_by_type` gives for its class, and every other force in
    group 0 (soft): e.g. {openmm.HarmonicBondForce: 1, openmm.HarmonicAngleForce: 2}."""
    for force in system.getForces():
        force.setForceGroup(groups_by_type.get(type(force), 0))
    return system


def harmonic_angles(system):
    """(parameters, force group) of every angle of the System's HarmonicAngleForces with a nonzero force constant:
    each angle once, as FlavorIntegrator.separatePlanarAngles leaves the angles it moves behind with force constant 0."""
    return [(x, force.getForceGroup()) for force in system.getForces() if isinstance(force, mm.HarmonicAngleForce)
            for x in (force.getAngleParameters(i) for i in range(force.getNumAngles()))
            if x[4].value_in_unit(unit.kilojoule_per_mole / unit.radian**2) != 0]
