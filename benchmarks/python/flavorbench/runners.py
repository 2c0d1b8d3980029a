"""Running integrators: factories for everything the scripts compare, Contexts at a given state, sampled runs and
timings of integrator.step().

OpenMM's VerletIntegrator is a leapfrog: the velocities it stores lag the positions by dt/2 and the initial velocities
are read as v(-dt/2).  Starting from v0 - dt/2 F(q0)/m and reading v + dt/2 F(q)/m makes a run exactly velocity
Verlet from (q0, v0) (leapfrog=True below).  FlavorIntegrator's and StochasticImpulseIntegrator's velocities are
synchronous.
"""
import math
import statistics
import sys
import time

import numpy as np
import openmm as mm
import openmm.unit as unit
from openmm import mtsintegrator

import openmmflavors

from .progress import Progress
from .systems import SOFT_GROUP, STIFF_GROUP, observables

FORCE_UNIT = unit.kilojoule_per_mole / unit.nanometer
# Boltzmann constant in kJ/mol/K: temperature = kT / KB.
KB = (unit.BOLTZMANN_CONSTANT_kB * unit.AVOGADRO_CONSTANT_NA).value_in_unit(unit.kilojoule_per_mole / unit.kelvin)


# ----------------------------------------------------------------------------------------------------------------------
# Integrators (steps in ps, temperatures in K, friction in 1/ps; the stiff force group is systems.STIFF_GROUP)

def flavor(delta, tau, scheme="Verlet", temperature=None, friction=None, seed=None, stiff_friction=None,
           friction_particles=None):
    """FlavorIntegrator(delta, tau, {stiff group}) with the scheme (a name, "Verlet" or "SymplecticEuler", or the
    enum value) and whatever Langevin settings are given."""
    FI = openmmflavors.FlavorIntegrator
    integrator = FI(delta * unit.picoseconds, tau * unit.picoseconds, {STIFF_GROUP})
    integrator.setScheme(getattr(FI, scheme) if isinstance(scheme, str) else scheme)
    if temperature is not None:
        integrator.setTemperature(temperature * unit.kelvin)
    if friction is not None:
        integrator.setFriction(friction / unit.picosecond)
    if stiff_friction is not None:
        integrator.setStiffFriction(stiff_friction)
    if friction_particles is not None:
        integrator.setFrictionParticles(friction_particles)
    if seed is not None:
        integrator.setRandomNumberSeed(seed)
    return integrator


def sim(step, splitting="Strang", temperature=0.0, friction=0.0, seed=None):
    """StochasticImpulseIntegrator(temperature, friction, step, {stiff group}) with the splitting (name or enum)."""
    SI = openmmflavors.StochasticImpulseIntegrator
    integrator = SI(temperature * unit.kelvin, friction / unit.picosecond, step * unit.picoseconds, {STIFF_GROUP})
    integrator.setSplitting(getattr(SI, splitting) if isinstance(splitting, str) else splitting)
    if seed is not None:
        integrator.setRandomNumberSeed(seed)
    return integrator


def mts(step, inner):
    """r-RESPA: the soft group once per step, the stiff group `inner` times.  Both groups are listed: MTSIntegrator
    silently drops any group it is not given."""
    return mtsintegrator.MTSIntegrator(step * unit.picoseconds, [(SOFT_GROUP, 1), (STIFF_GROUP, inner)])


def verlet(h, groups=None):
    """VerletIntegrator(h), restricted to the force groups `groups` if given."""
    integrator = mm.VerletIntegrator(h)
    if groups is not None:
        integrator.setIntegrationForceGroups(groups)
    return integrator


# ----------------------------------------------------------------------------------------------------------------------
# State

def masses_of(system):
    return np.array([system.getParticleMass(i).value_in_unit(unit.dalton) for i in range(system.getNumParticles())])


def leapfrog_start(context, v0, dt, masses):
    """v0 - dt/2 F(q)/m at the context's positions (arrays (particles, 3))."""
    f0 = context.getState(getForces=True).getForces(asNumpy=True).value_in_unit(FORCE_UNIT)
    return v0 - 0.5 * dt * np.asarray(f0) / masses[:, None]


def synchronized(state, v, dt, masses):
    """v + dt/2 F/m from a state read with getForces=True (v: (particles, 3))."""
    f = np.asarray(state.getForces(asNumpy=True).value_in_unit(FORCE_UNIT))
    return v + 0.5 * dt * f / masses[:, None]


def set_state(context, dt, positions, velocities=None, leapfrog=False):
    """Time 0 at (positions, velocities; None: at rest); for a leapfrog run the velocities are set to v(-dt/2)."""
    context.setTime(0.0)
    context.setPositions(positions)
    n = context.getSystem().getNumParticles()
    v0 = np.zeros((n, 3)) if velocities is None else np.array(velocities, dtype=float)
    if leapfrog:
        v0 = leapfrog_start(context, v0, dt, masses_of(context.getSystem()))
    context.setVelocities(v0)


def start_context(system, integrator, dt, positions, velocities=None, leapfrog=False, platform="Reference",
                  properties=None):
    """A Context at (positions, velocities): see set_state."""
    context = mm.Context(system, integrator, mm.Platform.getPlatformByName(platform), properties or {})
    set_state(context, dt, positions, velocities, leapfrog)
    return context


def read_state(context, dt, leapfrog, masses, energy=False):
    """Positions and velocities (synchronized for a leapfrog run) as arrays (particles, 3), and the State."""
    state = context.getState(getPositions=True, getVelocities=True, getEnergy=energy, getForces=leapfrog)
    q = np.asarray(state.getPositions(asNumpy=True).value_in_unit(unit.nanometer))
    v = np.asarray(state.getVelocities(asNumpy=True).value_in_unit(unit.nanometer / unit.picosecond))
    if leapfrog:
        v = synchronized(state, v, dt, masses)
    return q, v, state


# ----------------------------------------------------------------------------------------------------------------------
# Runs

def sample_steps(times, dt, hint):
    """The step counts at `times`; hint (with {dt}) is the message when dt does not divide them."""
    steps = np.rint(np.asarray(times) / dt).astype(np.int64)
    if np.max(np.abs(steps * dt - times)) > 1e-9 * max(1.0, times[-1]):
        raise SystemExit(hint.format(dt=dt))
    return steps


def positions_velocities(q, v, state):
    """What simulate() keeps of a sample by default."""
    return {"q": q, "v": v}


def simulate(system, integrator, dt, positions, velocities, times, label, leapfrog=False, platform="Reference",
             properties=None, energy=False, observe=positions_velocities, progress=None, hint=None, warm_up=False,
             blowup=None):
    """Run `integrator` (step dt) from (positions, velocities) and sample at `times` (multiples of dt).

    observe(q, v, state) -> {name: array}: what is kept of each sample (q, v: arrays (particles, 3), velocities
    synchronized for a leapfrog run); energy=True also keeps the potential energy ("pe", kJ/mol).
    warm_up: take one untimed step first and start again from the initial state, so that one-time work (SIM's
    measurement of the stiff modes, a CustomIntegrator's compilation) is not timed with the steps.
    progress: a Progress (default: one for `label`), or False for none.
    blowup: stop at the first sample with a coordinate that is not finite or exceeds blowup in size, or when OpenMM
    throws; the remaining samples are NaN and "finite" is False.
    Wall times count integrator.step() only; the first step is also timed on its own (first_step_s).  Returns dict
    with the observations stacked over the samples, t, masses, wall_s, walls (cumulative wall time at each sample),
    first_step_s, warm_up_s, steps, dt, us_per_step, finite."""
    context = start_context(system, integrator, dt, positions, velocities, leapfrog, platform, properties)
    masses = masses_of(system)
    steps = sample_steps(times, dt, hint or (label + ": step {dt:g} does not divide the sampling times"))
    run = {"t": np.asarray(times), "masses": masses, "dt": dt, "steps": int(steps[-1]), "warm_up_s": 0.0,
           "first_step_s": None, "finite": True, "walls": np.full(len(times), np.nan)}
    if warm_up:
        start = time.perf_counter()
        integrator.step(1)
        run["warm_up_s"] = time.perf_counter() - start
        set_state(context, dt, positions, velocities, leapfrog)
    progress = Progress(label, times[-1]) if progress is None else progress
    rows, wall, done = [], 0.0, 0
    for k, target in enumerate(steps):
        if target > done:
            start = time.perf_counter()
            try:
                if done == 0:
                    integrator.step(1)
                    run["first_step_s"] = time.perf_counter() - start
                if target > max(done, 1):
                    integrator.step(int(target - max(done, 1)))
            except mm.OpenMMException:
                if blowup is None:
                    raise
                run["finite"] = False
            finally:
                wall += time.perf_counter() - start
            done = int(target)
        if not run["finite"]:
            break
        run["walls"][k] = wall
        q, v, state = read_state(context, dt, leapfrog, masses, energy)
        if blowup is not None and not (np.all(np.isfinite(q)) and np.all(np.isfinite(v)) and
                                       np.max(np.abs(q)) < blowup):
            run["finite"] = False
            break
        row = observe(q, v, state)
        if energy:
            row["pe"] = state.getPotentialEnergy().value_in_unit(unit.kilojoule_per_mole)
        rows.append(row)
        if progress:
            progress.update(times[k], times[-1])
    if progress:
        progress.update(times[k], times[-1], force=True)
    del context
    for name in rows[0] if rows else ():
        values = np.array([row[name] for row in rows], dtype=float)
        stacked = np.full((len(times),) + values.shape[1:], np.nan)
        stacked[:len(rows)] = values
        run[name] = stacked
    run.update(wall_s=wall, us_per_step=1e6 * wall / max(1, run["steps"]))
    return run


def simulate_fpu(system, integrator, dt, leapfrog, positions, times, omega, label, fmt, hint):
    """simulate() from `positions` at rest, returned as the FPU chain's observables (systems.observables of the x
    coordinates) and total energy E at `times`, with steps and wall_s.  fmt: the progress format of the time."""
    run = simulate(system, integrator, dt, positions, None, times, label, leapfrog, energy=True,
                   progress=Progress(label, fmt=fmt), hint=hint)
    q, v = run["q"][:, :, 0], run["v"][:, :, 0]
    energy = 0.5 * np.sum(run["masses"] * v * v, axis=1) + run["pe"]
    return {"steps": run["steps"], "wall_s": run["wall_s"], "E": energy, **observables(q, v, omega)}


def best_time(start, steps, repeats, enough=math.inf, first=None):
    """Minimum wall time of integrator.step(steps) over fresh runs (the machine may be shared: the minimum is the
    least disturbed).  start() -> (context, integrator); the runs stop after `repeats` of them or once they took
    `enough` seconds together.  first(context): called after the first run; returns (minimum, what it returned)."""
    walls, result = [], None
    while len(walls) < repeats and sum(walls) <= enough:
        context, integrator = start()
        begin = time.perf_counter()
        integrator.step(steps)
        walls.append(time.perf_counter() - begin)
        if first is not None and len(walls) == 1:
            result = first(context)
        del context, integrator  # the integrator is bound to the context until here
    return min(walls), result


def time_batches(cases, target, repeats, label=None):
    """Per-step times of several integrators: cases {name: (context, integrator)}.  Each takes batches of
    integrator.step(N), N sized so that a batch lasts about `target` seconds, round-robin over the cases `repeats`
    times (background load then hits them alike).  Returns {name: us_per_step (minimum), us_per_step_median, all,
    steps_per_batch}; progress on stderr if label is given."""
    sizes = {}
    for name, (_, integrator) in cases.items():
        integrator.step(2)
        n = 1
        while True:
            start = time.perf_counter()
            integrator.step(n)
            elapsed = time.perf_counter() - start
            if elapsed > 0.2 * target or n > 10**8:
                break
            n *= 4
        sizes[name] = max(1, int(n * target / elapsed))
    times = {name: [] for name in cases}
    for r in range(repeats):
        for name, (_, integrator) in cases.items():
            start = time.perf_counter()
            integrator.step(sizes[name])
            times[name].append(1e6 * (time.perf_counter() - start) / sizes[name])
        if label:
            print(f"  [{label}] repeat {r + 1}/{repeats}: " +
                  ", ".join(f"{name} {times[name][-1]:.4g}" for name in cases) + " us/step", file=sys.stderr,
                  flush=True)
    return {name: {"us_per_step": min(t), "us_per_step_median": statistics.median(t), "all": t,
                   "steps_per_batch": sizes[name]} for name, t in times.items()}
