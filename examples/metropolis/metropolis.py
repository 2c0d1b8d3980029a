#!/usr/bin/env python3
"""The Metropolis-adjusted FLAVOR and SIM (setMetropolis): where the adjustment pays and where it does not.

Part 1, acceptance against step and system size, on N pairs of unit masses (amu) in a soft harmonic well
0.5 k |r|^2 (group 0), each pair joined by a stiff zero-length spring 0.5 K |r1 - r2|^2 (HarmonicBondForce, group 1:
quadratic).  Per coordinate a pair's centre c is Gaussian with <c^2> = kT/2k exactly.  300 K, Reference platform,
each run started from an exact Boltzmann draw, N = 1, 10, 100:
- SIM Strang (StochasticImpulseIntegrator), k = 100, K = 1e5 kJ/mol/nm^2 (omega_soft = 10/ps, stiff omega = 447/ps),
  friction 5/ps, H = x / omega_soft;
- FLAVOR ArtificialProjected, Verlet, k = 1e4, K = 1e6 (omega_soft = 100/ps, omega = 1414/ps), tau = 0.5 fs,
  friction 50/ps, delta = x / omega_soft;
- the same with setExactFastFlow(True): the microstep is the stiff group's exact flow;
- FLAVOR Nonintrusive, Verlet, the same model and steps;
with x = omega_soft * step from 0.1 to 1.5.  A least-squares fit of log(1 - acceptance) against log x and log N
(where 0.002 < 1 - acceptance < 0.3) gives the rejection's order in the step and in N.  The acceptance's error bar is
the standard error of 20 block means.  At N = 10 each step also runs unadjusted, and <c^2> of both is compared with
kT/2k (20-block standard errors).

Part 2, effective sample size (ESS) per wall-clock second against OpenMM's LangevinMiddleIntegrator at the same
friction, all peers stepped in interleaved chunks (round robin) so that the machine's load falls on all alike; only
integrator.step() is timed.  ESS = n / tau_int, tau_int = 1 + 2 sum_{t=1..M} rho(t) in samples, with Sokal's
automatic window (the smallest M >= 5 tau_int(M)), and Sokal's error sqrt(2 (2M + 1) / n) tau_int.
(a) the SIM model above, N = 10 pairs, 5/ps, Reference platform; observables: the potential energy U and C2, the mean
    of c^2 over the pairs; samples every 0.1 ps.
(b) alanine dipeptide (ACE-ALA-NME) in vacuum, Amber14 (amber14-all.xml), NoCutoff, no constraints and no
    CMMotionRemover, 300 K, 1/ps, Reference platform; bonds (HarmonicBondForce, group 1) stiff.  Harmonic
    bonds of nonzero length are not quadratic in the Cartesian coordinates: the SIM refuses them, and the artificial
    FLAVORs hold them by an iterative solve, which the adjustment refuses (reversible only to its tolerance); the
    Nonintrusive Verlet FLAVOR is the one adjusted.  Observables: U and cos psi (N-CA-C-N); samples every 20 fs.
(c) 10 copies of the FLAVORS paper's FPU chain (m = 3, omega = 200/ps, unit masses), every force acting per Cartesian
    component (three independent one-dimensional chains per copy), 300 K, 5/ps, Reference platform; stiff springs
    zero-length harmonic (quadratic) in group 1.  Peers: LangevinMiddle at 1 fs and 8 fs, the SIM Strang adjusted and
    unadjusted at H = 40 and 100 fs, the artificial FLAVOR with the exact fast flow (tau = 2.5 fs) adjusted at
    delta = 100 and 200 fs and unadjusted at 200 fs.  Observables: U and the mean of the slow variables' squares
    x0^2 = (q_2i-1 + q_2i)^2 / 2, both with exact averages from a transfer-matrix quadrature; samples every 0.1 ps.
The adjustment's cost per step: adjusted against unadjusted (same integrator, same step) and against LangevinMiddle
(1 fs), timed in 30 rounds taking turns, without sampling; the median and quartiles of the per-round ratios.  And the
dipeptide's acceptance over a grid of delta (0.5-3 fs) and tau = delta, delta/2, delta/4.

    PYTHONPATH=build/python .venv/bin/python examples/metropolis/metropolis.py [--quick] [--out DIR] [--replot JSON]
        [--fpu-into JSON]   (run only part (c) and write JSON with it added into --out)
"""
import json
import math
import os
import time
import warnings

import numpy as np
import openmm as mm
import openmm.app as app
import openmm.unit as unit

import openmmflavors  # loads the plugin
from flavorbench import reporting
from flavorbench.progress import Progress
from openmmflavors import FlavorIntegrator, StochasticImpulseIntegrator

NAME = "metropolis"
HERE = os.path.dirname(os.path.abspath(__file__))
TEMPERATURE = 300.0
KT = 0.00831446261815324 * TEMPERATURE  # kJ/mol
STIFF_GROUP = 1
FPU_M = 3  # stiff springs per FPU chain, as in the FLAVORS paper

# Part 1's three schemes: model (k, K), friction (1/ps), tau (ps, FLAVOR only).
SCHEMES = {
    "sim_strang": dict(label="SIM Strang", k=100.0, K=1e5, friction=5.0),
    "flavor_artificial": dict(label="FLAVOR ArtificialProjected", k=1e4, K=1e6, friction=50.0, tau=0.0005),
    "flavor_artificial_exact": dict(label="FLAVOR ArtificialProjected, exact fast flow", k=1e4, K=1e6, friction=50.0,
                                    tau=0.0005),
    "flavor_nonintrusive": dict(label="FLAVOR Nonintrusive", k=1e4, K=1e6, friction=50.0, tau=0.0005),
}


def stiff_omega(K):
    """A pair's stiff angular frequency (reduced mass 1/2)."""
    return math.sqrt(2 * K)


# ---------------------------------------------------------------------------------------------------------------------
# Models and integrators


def pair_system(n, k, K):
    system = mm.System()
    springs = mm.HarmonicBondForce()
    springs.setForceGroup(STIFF_GROUP)
    well = mm.CustomExternalForce("0.5*k*(x^2+y^2+z^2)")
    well.addGlobalParameter("k", k)
    for i in range(n):
        system.addParticle(1.0)
        system.addParticle(1.0)
        well.addParticle(2 * i, [])
        well.addParticle(2 * i + 1, [])
        springs.addBond(2 * i, 2 * i + 1, 0.0, K)
    system.addForce(well)
    system.addForce(springs)
    return system


def pair_start(context, n, k, K, seed):
    """Exact Boltzmann draw of positions (pair centres and separations) and velocities."""
    rng = np.random.default_rng(seed)
    c = rng.normal(size=(n, 3)) * math.sqrt(KT / (2 * k))
    d = rng.normal(size=(n, 3)) * math.sqrt(KT / (K + k / 2))
    q = np.empty((2 * n, 3))
    q[0::2], q[1::2] = c + d / 2, c - d / 2
    context.setPositions(q)
    context.setVelocities(rng.normal(size=(2 * n, 3)) * math.sqrt(KT))


def centre_square(q):
    """Mean over the pairs and coordinates of c^2."""
    c = 0.5 * (q[0::2] + q[1::2])
    return float(np.mean(c * c))


def sim(step, friction, adjusted, seed):
    integrator = StochasticImpulseIntegrator(TEMPERATURE * unit.kelvin, friction / unit.picosecond,
                                             step * unit.picoseconds, {STIFF_GROUP})
    integrator.setSplitting(StochasticImpulseIntegrator.Strang)
    integrator.setMetropolis(adjusted)
    integrator.setRandomNumberSeed(seed)
    return integrator


def flavor(delta, tau, averaging, friction, adjusted, seed):
    integrator = FlavorIntegrator(delta * unit.picoseconds, tau * unit.picoseconds, {STIFF_GROUP})
    integrator.setScheme(FlavorIntegrator.Verlet)
    integrator.setAveraging(averaging)
    integrator.setTemperature(TEMPERATURE * unit.kelvin)
    integrator.setFriction(friction / unit.picosecond)
    integrator.setMetropolis(adjusted)
    integrator.setRandomNumberSeed(seed)
    return integrator


def scheme_integrator(key, step, adjusted, seed):
    s = SCHEMES[key]
    if key == "sim_strang":
        return sim(step, s["friction"], adjusted, seed)
    averaging = FlavorIntegrator.Nonintrusive if key == "flavor_nonintrusive" else FlavorIntegrator.ArtificialProjected
    integrator = flavor(step, s["tau"], averaging, s["friction"], adjusted, seed)
    integrator.setExactFastFlow(key == "flavor_artificial_exact")
    return integrator


def reference_platform():
    return mm.Platform.getPlatformByName("Reference")


def dipeptide_platform():
    """Reference: for 22 atoms it steps 4-8 times faster than the CPU platform with 1 thread on this machine, for
    LangevinMiddle and the FLAVOR alike (measured), since the CPU platform's per-step overhead dominates."""
    return mm.Platform.getPlatformByName("Reference"), {}


# ---------------------------------------------------------------------------------------------------------------------
# Statistics


def block_estimate(values, blocks=20):
    """Mean and the standard error of `blocks` block means."""
    values = np.asarray(values, dtype=float)
    usable = len(values) // blocks * blocks
    means = values[:usable].reshape(blocks, -1).mean(axis=1)
    return float(values.mean()), float(means.std(ddof=1) / math.sqrt(blocks))


def integrated_time(series, c=5.0):
    """Sokal: tau_int = 1 + 2 sum_{t=1..M} rho(t) (in samples) with the smallest window M >= c tau_int(M), and its
    error sqrt(2 (2M + 1) / n) tau_int.  Returns (tau, error, M)."""
    x = np.asarray(series, dtype=float)
    n = len(x)
    x = x - x.mean()
    f = np.fft.rfft(x, 2 * n)
    acf = np.fft.irfft(f * np.conj(f))[:n]
    if acf[0] <= 0:
        return float("nan"), float("nan"), 0
    rho = acf / acf[0]
    taus = 2.0 * np.cumsum(rho) - 1.0
    window = np.arange(n) >= c * taus
    m = int(np.argmax(window)) if window.any() else n - 1
    tau = max(float(taus[m]), 1.0 / n)
    return tau, tau * math.sqrt(2 * (2 * m + 1) / n), m


# ---------------------------------------------------------------------------------------------------------------------
# Part 1: acceptance against step and N, and the bias of <c^2>


def acceptance_run(key, n, x, adjusted, steps, sample_every, seed):
    """One run: acceptance per block (20 blocks) and, when sample_every, c^2 every sample_every steps."""
    s = SCHEMES[key]
    step = x / math.sqrt(s["k"])
    integrator = scheme_integrator(key, step, adjusted, seed)
    context = mm.Context(pair_system(n, s["k"], s["K"]), integrator, reference_platform())
    pair_start(context, n, s["k"], s["K"], seed + 1000)
    blocks, per_block = 20, []
    block_steps = max(1, steps // blocks)
    if sample_every:
        block_steps = max(1, block_steps // sample_every) * sample_every
    samples, done, accepted = [], 0, 0.0
    begin = time.perf_counter()
    for b in range(blocks):
        if sample_every:
            for _ in range(block_steps // sample_every):
                integrator.step(sample_every)
                q = context.getState(getPositions=True).getPositions(asNumpy=True).value_in_unit(unit.nanometer)
                samples.append(centre_square(q))
        else:
            integrator.step(block_steps)
        done += block_steps
        if adjusted:
            # getAcceptanceRate() counts since the Context was created: the block's accepted count is the difference.
            now = integrator.getAcceptanceRate() * done
            per_block.append((now - accepted) / block_steps)
            accepted = now
    wall = time.perf_counter() - begin
    run = {"scheme": key, "N": n, "x": x, "step_ps": step, "adjusted": adjusted, "wall_s": wall,
           "stiff_omega_step": stiff_omega(s["K"]) * step}
    if adjusted:
        run["acceptance"], run["acceptance_error"] = block_estimate(per_block, len(per_block))
        run["acceptance_total"] = integrator.getAcceptanceRate()
        run["steps"] = done
    if samples:
        finite = bool(np.all(np.isfinite(samples)))
        run["finite"] = finite
        exact = KT / (2 * s["k"])
        # A chain that accepts (almost) nothing keeps its positions: its samples are not a sample of anything.
        frozen = adjusted and run["acceptance_total"] * done < 20
        run["frozen"] = bool(frozen)
        if finite and not frozen:
            mean, error = block_estimate(samples)
            run.update(c2=mean, c2_error=error, c2_exact=exact, c2_bias=mean / exact - 1, c2_bias_error=error / exact,
                       c2_z=(mean - exact) / error if error > 0 else None, samples=len(samples))
    return run


def part1(p):
    runs = []
    total = len(SCHEMES) * len(p["x"]) * (len(p["N"]) + 1)
    progress = Progress("acceptance runs", total, fmt="4d")
    seed = 1
    for key in SCHEMES:
        for x in p["x"]:
            for n in p["N"]:
                seed += 1
                if n == p["bias_N"]:
                    steps = int(round(p["bias_time"] / x))
                    every = max(1, int(round(p["sample_x"] / x)))
                else:
                    steps, every = p["steps_by_N"][str(n)], 0
                run = acceptance_run(key, n, x, True, steps, every, seed)
                runs.append(run)
                progress.step(f"{SCHEMES[key]['label']}, N = {n}, x = {x:g}: acceptance {run['acceptance']:.3f}")
            n = p["bias_N"]
            try:
                run = acceptance_run(key, n, x, False, int(round(p["bias_time"] / x)),
                                     max(1, int(round(p["sample_x"] / x))), seed + 500)
            except mm.OpenMMException as e:
                run = {"scheme": key, "N": n, "x": x, "adjusted": False, "finite": False, "error": str(e)[:200]}
            runs.append(run)
            progress.step(f"{SCHEMES[key]['label']}, N = {n}, x = {x:g}: unadjusted")
    return runs


def fit_rejection(runs, key, p):
    """Least-squares fit of log(1 - acceptance) = a + b log x + c log N over the points with
    0.002 < 1 - acceptance < 0.3 (the asymptotic regime, away from zero counts), weighted equally."""
    rows = [(math.log(r["x"]), math.log(r["N"]), math.log(1 - r["acceptance"])) for r in runs
            if r["scheme"] == key and r.get("adjusted") and 0.002 < 1 - r["acceptance"] < 0.3]
    if len(rows) < 4:
        return None
    A = np.array([[1.0, lx, ln] for lx, ln, _ in rows])
    y = np.array([ly for _, _, ly in rows])
    coef = np.linalg.lstsq(A, y, rcond=None)[0]
    dof = len(rows) - 3
    sigma2 = float(np.sum((y - A @ coef) ** 2) / dof) if dof > 0 else float("nan")
    cov = sigma2 * np.linalg.inv(A.T @ A)
    return {"points": len(rows), "step_power": float(coef[1]), "step_power_error": float(math.sqrt(cov[1, 1])),
            "N_power": float(coef[2]), "N_power_error": float(math.sqrt(cov[2, 2]))}


# ---------------------------------------------------------------------------------------------------------------------
# Part 2: ESS per wall second, interleaved


class Peer:
    def __init__(self, key, label, context, integrator, step_ps, sample_every, observe, adjusted=None):
        self.key, self.label, self.context, self.integrator = key, label, context, integrator
        self.step_ps, self.sample_every, self.observe, self.adjusted = step_ps, sample_every, observe, adjusted
        self.wall, self.steps, self.samples, self.chunk_times = 0.0, 0, [], []


def run_interleaved(peers, chunk_ps, total_ps, burn_ps, label):
    for peer in peers:
        peer.integrator.step(max(1, int(round(burn_ps / peer.step_ps))))
    chunks = max(1, int(round(total_ps / chunk_ps)))
    progress = Progress(label, chunks, fmt="4d")
    for chunk in range(chunks):
        order = peers if chunk % 2 == 0 else peers[::-1]
        for peer in order:
            samples = int(round(chunk_ps / (peer.step_ps * peer.sample_every)))
            elapsed = 0.0
            for _ in range(samples):
                begin = time.perf_counter()
                peer.integrator.step(peer.sample_every)
                elapsed += time.perf_counter() - begin
                peer.samples.append(peer.observe(peer.context))
            peer.wall += elapsed
            peer.steps += samples * peer.sample_every
            peer.chunk_times.append(elapsed / (samples * peer.sample_every))
        progress.update(chunk + 1)
    progress.update(chunks, force=True)


def summarize_peer(peer, names):
    samples = np.array(peer.samples, dtype=float)
    entry = {"label": peer.label, "step_fs": peer.step_ps * 1000, "steps": peer.steps, "wall_s": peer.wall,
             "us_per_step": peer.wall / peer.steps * 1e6,
             "us_per_step_chunk_median": float(np.median(peer.chunk_times)) * 1e6,
             "samples": len(samples), "sample_interval_ps": peer.step_ps * peer.sample_every,
             "finite": bool(np.all(np.isfinite(samples)))}
    if peer.adjusted:
        entry["acceptance"] = peer.integrator.getAcceptanceRate()
    for i, name in enumerate(names):
        column = samples[:, i]
        tau, tau_error, window = integrated_time(column)
        mean, error = block_estimate(column)
        ess = len(column) / tau
        entry[name] = {"mean": mean, "mean_error": error, "tau_int_samples": tau, "tau_int_error": tau_error,
                       "tau_int_ps": tau * entry["sample_interval_ps"], "window": window, "ess": ess,
                       "ess_error": ess * tau_error / tau, "ess_per_s": ess / peer.wall,
                       "ess_per_s_error": ess / peer.wall * tau_error / tau}
    return entry


def energy_and(of_positions):
    """An observer of a Context: its potential energy (kJ/mol) and of_positions(positions in nm)."""
    def observe(context):
        state = context.getState(getPositions=True, getEnergy=True)
        q = state.getPositions(asNumpy=True).value_in_unit(unit.nanometer)
        return (state.getPotentialEnergy().value_in_unit(unit.kilojoule_per_mole), of_positions(q))
    return observe


def pair_peers(p):
    s = SCHEMES["sim_strang"]
    n = p["ess_pairs"]
    system = pair_system(n, s["k"], s["K"])
    sample_ps = p["pair_sample_ps"]

    observe = energy_and(centre_square)

    peers = []
    for i, (kind, step, adjusted) in enumerate(p["pair_peers"]):
        if kind == "langevin":
            integrator = mm.LangevinMiddleIntegrator(TEMPERATURE, s["friction"], step)
            integrator.setRandomNumberSeed(100 + i)
            label = f"LangevinMiddle h = {step * 1000:g} fs"
        else:
            integrator = sim(step, s["friction"], adjusted, 100 + i)
            label = f"SIM Strang H = {step * 1000:g} fs" + (", adjusted" if adjusted else ", unadjusted")
        context = mm.Context(system, integrator, reference_platform())
        pair_start(context, n, s["k"], s["K"], 7)
        key = f"{kind}_{step * 1000:g}fs" + ("" if kind == "langevin" else ("_adjusted" if adjusted else "_plain"))
        peers.append(Peer(key, label, context, integrator, step, max(1, int(round(sample_ps / step))), observe,
                          adjusted if kind != "langevin" else None))
    return peers


def dipeptide_system():
    pdb = app.PDBFile(os.path.join(HERE, "alanine_dipeptide.pdb"))
    forcefield = app.ForceField("amber14-all.xml")
    system = forcefield.createSystem(pdb.topology, nonbondedMethod=app.NoCutoff, constraints=None,
                                     removeCMMotion=False)
    for force in system.getForces():
        if isinstance(force, mm.HarmonicBondForce):
            force.setForceGroup(STIFF_GROUP)
    psi = [a.index for a in pdb.topology.atoms() if (a.residue.name, a.name) in
           (("ALA", "N"), ("ALA", "CA"), ("ALA", "C"), ("NME", "N"))]
    return system, pdb, psi


def dihedral(q, idx):
    b0, b1, b2 = q[idx[1]] - q[idx[0]], q[idx[2]] - q[idx[1]], q[idx[3]] - q[idx[2]]
    n1, n2 = np.cross(b0, b1), np.cross(b1, b2)
    m1 = np.cross(n1, b1 / np.linalg.norm(b1))
    return math.atan2(float(np.dot(m1, n2)), float(np.dot(n1, n2)))


def thermal_start(system, pdb, platform, properties, equilibrate_ps, seed):
    """A thermal state of the dipeptide: minimized, then LangevinMiddle at 0.5 fs for equilibrate_ps."""
    warm = mm.LangevinMiddleIntegrator(TEMPERATURE, 1.0, 0.0005)
    warm.setRandomNumberSeed(seed)
    context = mm.Context(system, warm, platform, properties)
    context.setPositions(pdb.positions)
    mm.LocalEnergyMinimizer.minimize(context)
    context.setVelocitiesToTemperature(TEMPERATURE, seed)
    warm.step(int(round(equilibrate_ps / 0.0005)))
    return context.getState(getPositions=True, getVelocities=True)


def dipeptide_peers(p):
    system, pdb, psi = dipeptide_system()
    platform, properties = dipeptide_platform()
    state = thermal_start(system, pdb, platform, properties, p["mol_equilibrate_ps"], 3)
    sample_ps = p["mol_sample_ps"]

    observe = energy_and(lambda q: math.cos(dihedral(q, psi)))

    peers = []
    for i, (kind, step, tau, adjusted) in enumerate(p["mol_peers"]):
        if kind == "langevin":
            integrator = mm.LangevinMiddleIntegrator(TEMPERATURE, 1.0, step)
            integrator.setRandomNumberSeed(200 + i)
            label = f"LangevinMiddle h = {step * 1000:g} fs"
            key = f"langevin_{step * 1000:g}fs"
        else:
            integrator = flavor(step, tau, FlavorIntegrator.Nonintrusive, 1.0, adjusted, 200 + i)
            label = (f"FLAVOR Nonintrusive δ = {step * 1000:g} fs, τ = {tau * 1000:g} fs, "
                     + ("adjusted" if adjusted else "unadjusted"))
            key = f"flavor_{step * 1000:g}_{tau * 1000:g}fs" + ("_adjusted" if adjusted else "_plain")
        ctx = mm.Context(system, integrator, platform, properties)
        ctx.setPositions(state.getPositions())
        ctx.setVelocities(state.getVelocities())
        peers.append(Peer(key, label, ctx, integrator, step, max(1, int(round(sample_ps / step))), observe,
                          adjusted if kind != "langevin" else None))
    return peers, len(psi) == 4


def dipeptide_acceptance(p):
    """Acceptance of the adjusted Nonintrusive FLAVOR on the dipeptide over a grid of delta and delta/tau (20-block
    standard errors), each from the same equilibrated start."""
    system, pdb, _ = dipeptide_system()
    platform, properties = dipeptide_platform()
    state = thermal_start(system, pdb, platform, properties, p["mol_equilibrate_ps"], 5)
    grid = []
    progress = Progress("dipeptide acceptance grid", len(p["mol_grid_delta_fs"]) * len(p["mol_grid_ratio"]), fmt="4d")
    for delta_fs in p["mol_grid_delta_fs"]:
        for ratio in p["mol_grid_ratio"]:
            tau_fs = delta_fs / ratio
            integrator = flavor(delta_fs / 1000, tau_fs / 1000, FlavorIntegrator.Nonintrusive, 1.0, True, 300)
            ctx = mm.Context(system, integrator, platform, properties)
            ctx.setPositions(state.getPositions())
            ctx.setVelocities(state.getVelocities())
            block = max(1, p["mol_grid_steps"] // 20)
            per_block, accepted = [], 0.0
            for b in range(20):
                integrator.step(block)
                now = integrator.getAcceptanceRate() * block * (b + 1)
                per_block.append((now - accepted) / block)
                accepted = now
            acceptance, error = block_estimate(per_block, 20)
            grid.append({"delta_fs": delta_fs, "tau_fs": tau_fs, "delta_over_tau": ratio, "steps": 20 * block,
                         "acceptance": acceptance, "acceptance_error": error})
            progress.step(f"delta = {delta_fs:g} fs, tau = {tau_fs:g} fs: acceptance {acceptance:.3f}")
            del ctx
    return grid


def fpu_system(chains, omega):
    """`chains` copies of the FLAVORS paper's FPU chain (m = 3), unit masses, in three dimensions with every force
    acting per Cartesian component, so each copy is three independent copies of the paper's one-dimensional chain:
    stiff zero-length springs 0.5 (omega^2/2) |r1 - r2|^2 (HarmonicBondForce, group 1: quadratic), soft quartic springs
    (dx^4 + dy^4 + dz^4) between neighbouring pairs and quartic walls x^4 + y^4 + z^4 on the end particles (group 0).
    (examples/fpu uses r^4 and x^4 on the x axis; off the axis that leaves y and z unconfined.)"""
    system = mm.System()
    stiff = mm.HarmonicBondForce()
    stiff.setForceGroup(STIFF_GROUP)
    soft = mm.CustomCompoundBondForce(2, "(x2-x1)^4+(y2-y1)^4+(z2-z1)^4")
    walls = mm.CustomExternalForce("x^4+y^4+z^4")
    for _ in range(chains):
        first = system.getNumParticles()
        for _ in range(2 * FPU_M):
            system.addParticle(1.0)
        for i in range(FPU_M):
            stiff.addBond(first + 2 * i, first + 2 * i + 1, 0.0, omega * omega / 2)
        for i in range(FPU_M - 1):
            soft.addBond([first + 2 * i + 1, first + 2 * i + 2], [])
        walls.addParticle(first, [])
        walls.addParticle(first + 2 * FPU_M - 1, [])
    for force in (stiff, soft, walls):
        system.addForce(force)
    return system


def fpu_slow_square(q):
    """Mean over the chains' stiff pairs and the coordinates of the paper's slow variable squared,
    x0^2 = (q_2i-1 + q_2i)^2 / 2."""
    return float(np.mean((q[0::2] + q[1::2]) ** 2) / 2)


def fpu_exact(omega, half_width=7.0, spacing=0.05, hermite=4):
    """Exact Boltzmann averages of one one-dimensional FPU chain (m = 3) at KT: <U> and the mean over the three
    stiff pairs of <x0^2>.  Each pair is (c, d) = (centre, separation); the chain is a product of transfer kernels
    exp(-beta (q_2i+1 - q_2i)^4) between pairs, integrated with the trapezoid rule in c on [-half_width, half_width]
    and Gauss-Hermite in d against exp(-beta omega^2/4 d^2).  (7, 0.05, 4) agrees with (9, 0.0125, 10) to 1e-13."""
    beta, a = 1.0 / KT, omega * omega / 4
    c = np.arange(-half_width, half_width + spacing / 2, spacing)
    nodes, weights = np.polynomial.hermite.hermgauss(hermite)
    scale = math.sqrt(beta * a)
    C, D = np.repeat(c, hermite), np.tile(nodes / scale, len(c))
    phi = spacing * np.tile(weights, len(c)) / scale
    left, right = C - D / 2, C + D / 2
    E = (left[None, :] - right[:, None]) ** 4  # soft spring between pair s (row) and the next pair s' (column)
    K = np.exp(-beta * E)
    u1, v3 = np.exp(-beta * left ** 4) * phi, np.exp(-beta * right ** 4) * phi
    A, B = K.T @ u1, K @ v3
    Z = float(np.sum(A * phi * B))
    marginals = (u1 * (K @ (phi * B)) / Z, A * phi * B / Z, v3 * (K.T @ (phi * A)) / Z)
    KE = K * E
    U = (float(np.sum(marginals[0] * left ** 4) + np.sum(marginals[2] * right ** 4)) + float(u1 @ KE @ (phi * B)) / Z
         + float((A * phi) @ KE @ v3) / Z + a * sum(float(np.sum(m * D ** 2)) for m in marginals))
    return U, float(np.mean([np.sum(m * 2 * C ** 2) for m in marginals]))


def fpu_peers(p, seed=400):
    chains, omega, friction = p["fpu_chains"], p["fpu_omega"], p["fpu_friction"]
    system = fpu_system(chains, omega)
    platform = reference_platform()
    # Shared thermal start: the chains stretched along (1, 1, 1), then LangevinMiddle at 1 fs.
    warm = mm.LangevinMiddleIntegrator(TEMPERATURE, friction, 0.001)
    warm.setRandomNumberSeed(11)
    context = mm.Context(system, warm, platform)
    line = np.repeat((np.arange(2 * FPU_M) - (FPU_M - 0.5)) * 0.3, 3).reshape(-1, 3)
    context.setPositions(np.tile(line, (chains, 1)))
    context.setVelocitiesToTemperature(TEMPERATURE, 11)
    warm.step(int(round(p["fpu_equilibrate_ps"] / 0.001)))
    state = context.getState(getPositions=True, getVelocities=True)
    del context
    sample_ps = p["fpu_sample_ps"]

    observe = energy_and(fpu_slow_square)

    peers = []
    for i, (kind, step, adjusted) in enumerate(p["fpu_peers"]):
        if kind == "langevin":
            integrator = mm.LangevinMiddleIntegrator(TEMPERATURE, friction, step)
            integrator.setRandomNumberSeed(seed + i)
            label = f"LangevinMiddle h = {step * 1000:g} fs (ωh = {omega * step:.2g})"
            key = f"langevin_{step * 1000:g}fs"
        elif kind == "sim":
            integrator = sim(step, friction, adjusted, seed + i)
            label = f"SIM Strang H = {step * 1000:g} fs, " + ("adjusted" if adjusted else "unadjusted")
            key = f"sim_{step * 1000:g}fs" + ("_adjusted" if adjusted else "_plain")
        else:
            tau = p["fpu_tau"]
            integrator = flavor(step, tau, FlavorIntegrator.ArtificialProjected, friction, adjusted, seed + i)
            integrator.setExactFastFlow(True)
            label = (f"FLAVOR ArtificialProjected exact flow δ = {step * 1000:g} fs, τ = {tau * 1000:g} fs, "
                     + ("adjusted" if adjusted else "unadjusted"))
            key = f"flavor_{step * 1000:g}fs" + ("_adjusted" if adjusted else "_plain")
        ctx = mm.Context(system, integrator, platform)
        ctx.setPositions(state.getPositions())
        ctx.setVelocities(state.getVelocities())
        peers.append(Peer(key, label, ctx, integrator, step, max(1, int(round(sample_ps / step))), observe,
                          adjusted if kind != "langevin" else None))
    return peers


def fpu_replicas(p, U_exact, x02_exact):
    """Independent replicas (own seeds, the same thermal start as the peers, fpu_burn_ps discarded) of the adjusted
    peers with the step fpu_replica_step: <U> and <x0^2> against exact, the error the spread of the replicas' means."""
    result = {}
    for kind, step in (("sim", p["fpu_replica_step"]), ("flavor", p["fpu_replica_step"])):
        p1 = dict(p, fpu_peers=[(kind, step, True)] * p["fpu_replica_runs"])
        peers = fpu_peers(p1, seed=600 if kind == "sim" else 700)
        means, accepted = [], []
        for peer in peers:
            peer.integrator.step(int(round(p["fpu_burn_ps"] / step)))
            values = []
            for _ in range(int(round(p["fpu_replica_ps"] / step))):
                peer.integrator.step(1)
                values.append(peer.observe(peer.context))
            means.append(np.mean(values, axis=0))
            accepted.append(peer.integrator.getAcceptanceRate())
        means = np.array(means)
        runs = len(means)
        result[peers[0].key] = {
            "label": peers[0].label, "runs": runs, "ps_per_run": p["fpu_replica_ps"],
            "acceptance": float(np.mean(accepted)),
            "U_bias": float(means[:, 0].mean() / U_exact - 1),
            "U_bias_error": float(means[:, 0].std(ddof=1) / math.sqrt(runs) / U_exact),
            "X0sq_bias": float(means[:, 1].mean() / x02_exact - 1),
            "X0sq_bias_error": float(means[:, 1].std(ddof=1) / math.sqrt(runs) / x02_exact)}
    return result


def fpu_part(p):
    """The FPU chains' ESS per second, interleaved, against the exact <U> and <x0^2>; and replicas of two adjusted
    peers for a check of their averages that does not rest on one chain's error bar."""
    peers = fpu_peers(p)
    run_interleaved(peers, p["fpu_chunk_ps"], p["fpu_total_ps"], p["fpu_burn_ps"], "FPU chains, interleaved")
    u1, x02 = fpu_exact(p["fpu_omega"])
    U_exact = 3 * p["fpu_chains"] * u1
    return {"chains": p["fpu_chains"], "m": FPU_M, "omega": p["fpu_omega"], "friction": p["fpu_friction"],
            "U_exact": U_exact, "X0sq_exact": x02,
            "peers": {peer.key: summarize_peer(peer, ("U", "X0sq")) for peer in peers},
            "replicas": fpu_replicas(p, U_exact, x02)}


def step_costs(integrators, steps, rounds):
    """Time per step of each integrator (already bound to a Context), timed in `rounds` rounds of `steps` steps, the
    integrators taking turns (the order reversed every other round).  Returns {name: [us per step, one per round]}."""
    times = {name: [] for name in integrators}
    names = list(integrators)
    for r in range(rounds):
        for name in (names if r % 2 == 0 else names[::-1]):
            begin = time.perf_counter()
            integrators[name].step(steps)
            times[name].append((time.perf_counter() - begin) / steps * 1e6)
    return times


def cost_summary(times, numerator, denominator):
    """Median and quartiles of the per-round ratio of two integrators' step times."""
    ratios = np.array(times[numerator]) / np.array(times[denominator])
    q1, median, q3 = np.percentile(ratios, [25, 50, 75])
    return {"numerator": numerator, "denominator": denominator, "median": float(median), "q1": float(q1),
            "q3": float(q3), "rounds": len(ratios)}


def cost_of(makers, new_context, steps, rounds, adjusted, unadjusted, step_fs, langevin_step_fs):
    """Interleaved cost per step of the integrators makers[name]() on contexts from new_context(integrator), and the
    adjusted one against the unadjusted one and against LangevinMiddle ("langevin_middle")."""
    integrators, contexts = {}, []
    for name, make in makers:
        integrator = make()
        contexts.append(new_context(integrator))
        integrators[name] = integrator
    times = step_costs(integrators, steps, rounds)
    return {"step_fs": step_fs, "langevin_step_fs": langevin_step_fs,
            "us_per_step_median": {k: float(np.median(v)) for k, v in times.items()},
            "adjusted_over_unadjusted": cost_summary(times, adjusted, unadjusted),
            "adjusted_over_langevin": cost_summary(times, adjusted, "langevin_middle")}


def overhead(p):
    """The adjustment's cost per step: adjusted against unadjusted, same integrator and step, and against
    LangevinMiddle at the same step, on each scene's system and platform."""
    s = SCHEMES["sim_strang"]
    n = p["ess_pairs"]
    system = pair_system(n, s["k"], s["K"])

    def pair_context(integrator):
        context = mm.Context(system, integrator, reference_platform())
        pair_start(context, n, s["k"], s["K"], 3)
        return context

    result = {"pairs": cost_of(
        (("sim_adjusted", lambda: sim(0.1, s["friction"], True, 1)),
         ("sim_unadjusted", lambda: sim(0.1, s["friction"], False, 2)),
         # LangevinMiddle at its own stable step (a step costs the same at any h).
         ("langevin_middle", lambda: mm.LangevinMiddleIntegrator(TEMPERATURE, s["friction"], 0.001))),
        pair_context, p["cost_steps_pairs"], p["cost_rounds"], "sim_adjusted", "sim_unadjusted", 100.0, 1.0)}
    dipeptide, pdb, _ = dipeptide_system()
    platform, properties = dipeptide_platform()

    def dipeptide_context(integrator):
        context = mm.Context(dipeptide, integrator, platform, properties)
        context.setPositions(pdb.positions)
        mm.LocalEnergyMinimizer.minimize(context)
        context.setVelocitiesToTemperature(TEMPERATURE, 4)
        return context

    result["dipeptide"] = cost_of(
        (("flavor_adjusted", lambda: flavor(0.001, 0.001, FlavorIntegrator.Nonintrusive, 1.0, True, 1)),
         ("flavor_unadjusted", lambda: flavor(0.001, 0.001, FlavorIntegrator.Nonintrusive, 1.0, False, 2)),
         ("langevin_middle", lambda: mm.LangevinMiddleIntegrator(TEMPERATURE, 1.0, 0.001))),
        dipeptide_context, p["cost_steps_dipeptide"], p["cost_rounds"], "flavor_adjusted", "flavor_unadjusted", 1.0,
        1.0)
    return result


def part2(p):
    result = {}
    peers = pair_peers(p)
    run_interleaved(peers, p["pair_chunk_ps"], p["pair_total_ps"], p["pair_burn_ps"], "pairs, interleaved")
    result["pairs"] = {"N": p["ess_pairs"], "c2_exact": KT / (2 * SCHEMES["sim_strang"]["k"]),
                       "U_exact": KT * 3 * 2 * p["ess_pairs"] / 2,
                       "peers": {peer.key: summarize_peer(peer, ("U", "C2")) for peer in peers}}
    peers, ok = dipeptide_peers(p)
    assert ok
    run_interleaved(peers, p["mol_chunk_ps"], p["mol_total_ps"], p["mol_burn_ps"], "alanine dipeptide, interleaved")
    result["dipeptide"] = {"peers": {peer.key: summarize_peer(peer, ("U", "cos_psi")) for peer in peers},
                           "acceptance_grid": dipeptide_acceptance(p)}
    result["fpu"] = fpu_part(p)
    result["step_cost"] = overhead(p)
    return result


# ---------------------------------------------------------------------------------------------------------------------
# Report and charts


MARKERS = {1: "o", 10: "s", 100: "^"}
COLORS = {"sim_strang": "tab:blue", "flavor_artificial": "tab:orange", "flavor_artificial_exact": "tab:green",
          "flavor_nonintrusive": "tab:red"}


def plot(data, path):
    plt = reporting.pyplot()
    fpu = data["part2"].get("fpu")
    fig = plt.figure(figsize=(22, 21 if fpu else 14))
    outer = fig.add_gridspec(3 if fpu else 2, 1, hspace=0.55 if fpu else 0.5, top=0.93 if fpu else 0.9,
                             bottom=0.06 if fpu else 0.1, left=0.05, right=0.98)
    top = outer[0].subgridspec(1, 4, wspace=0.3)
    # Empty columns leave room for the ESS panels' long tick labels and the last panel's axis label.
    bottom = outer[1].subgridspec(1, 6, wspace=0.05, width_ratios=[0.34, 1, 0.42, 1, 0.14, 0.75])
    third = outer[2].subgridspec(1, 6, wspace=0.05, width_ratios=[0.34, 1, 0.42, 1, 0.14, 0.75]) if fpu else None
    runs = data["part1"]
    # (a) acceptance against x, each scheme, each N.
    ax = fig.add_subplot(top[0, 0])
    for key, s in SCHEMES.items():
        for n in data["parameters"]["N"]:
            rs = sorted((r for r in runs if r["scheme"] == key and r["N"] == n and r.get("adjusted")),
                        key=lambda r: r["x"])
            ax.errorbar([r["x"] for r in rs], [r["acceptance"] for r in rs], [r["acceptance_error"] for r in rs],
                        color=COLORS[key], marker=MARKERS[n], ms=4, lw=1, capsize=2,
                        ls="-" if n == 1 else ("--" if n == 10 else ":"), label=f"{s['label']}, N = {n}")
    ax.set_xlabel("ω_soft × step  (step: H for SIM, δ for FLAVOR)")
    ax.set_ylabel("acceptance rate")
    ax.set_ylim(-0.03, 1.03)
    ax.set_title("acceptance against the step, N pairs\n(20-block standard errors)", fontsize=10)
    ax.legend(fontsize=6.5, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2)
    # (b) rejection log-log.
    ax = fig.add_subplot(top[0, 1])
    for key, s in SCHEMES.items():
        if key == "flavor_nonintrusive":
            continue
        for n in data["parameters"]["N"]:
            rs = sorted((r for r in runs if r["scheme"] == key and r["N"] == n and r.get("adjusted")
                         and 1 - r["acceptance"] > 0), key=lambda r: r["x"])
            ax.errorbar([r["x"] for r in rs], [(1 - r["acceptance"]) for r in rs],
                        [r["acceptance_error"] for r in rs], color=COLORS[key], marker=MARKERS[n], ms=4, lw=1,
                        capsize=2, ls="-" if n == 1 else ("--" if n == 10 else ":"), label=f"{s['label']}, N = {n}")
    fits = data["rejection_fits"]
    text = []
    for key in ("sim_strang", "flavor_artificial", "flavor_artificial_exact"):
        f = fits.get(key)
        if f:
            text.append(f"{SCHEMES[key]['label']}:\n    order {f['step_power']:.2f} ± {f['step_power_error']:.2f} in "
                        f"the step, {f['N_power']:.2f} ± {f['N_power_error']:.2f} in N")
    ax.text(0.02, 0.98, "fit of log(1 − acceptance) where 0.002 < 1 − acceptance < 0.3:\n" + "\n".join(text),
            transform=ax.transAxes, va="top", fontsize=7)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("ω_soft × step")
    ax.set_ylabel("rejection rate 1 − acceptance")
    ax.set_ylim(top=300)
    ax.set_title("rejection: SIM Strang and the artificial FLAVORs\n(styles as in the first panel; "
                 "no rejection: not drawn)", fontsize=10)
    # (c) bias of <c^2> at N = bias_N.
    ax = fig.add_subplot(top[0, 2])
    n = data["parameters"]["bias_N"]
    for key, s in SCHEMES.items():
        for adjusted in (False, True):
            rs = sorted((r for r in runs if r["scheme"] == key and r["N"] == n and r.get("adjusted") == adjusted
                         and "c2_bias" in r), key=lambda r: r["x"])
            ax.errorbar([r["x"] * (1.02 if adjusted else 0.98) for r in rs], [100 * r["c2_bias"] for r in rs],
                        [100 * r["c2_bias_error"] for r in rs], color=COLORS[key], marker="o" if adjusted else "x",
                        ms=4, lw=1, capsize=2, ls="-" if adjusted else "--",
                        label=f"{s['label']}, " + ("adjusted" if adjusted else "unadjusted"))
    blew = [r["x"] for r in runs if r["N"] == n and r.get("finite") is False and r["scheme"] == "flavor_nonintrusive"]
    failed = ["FLAVOR Nonintrusive unadjusted, ω_soft step = " + ", ".join(f"{x:g}" for x in blew) + ": blew up"
              ] if blew else []
    failed += [f"{SCHEMES[r['scheme']]['label']} unadjusted, ω_soft step = {r['x']:g}: blew up" for r in runs
               if r["N"] == n and r.get("finite") is False and r["scheme"] != "flavor_nonintrusive"]
    frozen = [r["x"] for r in runs if r["N"] == n and r.get("frozen") and r["scheme"] == "flavor_nonintrusive"]
    if frozen:
        failed.append("FLAVOR Nonintrusive adjusted, ω_soft step = " + ", ".join(f"{x:g}" for x in frozen) +
                      ":\n< 20 proposals accepted, positions frozen")
    if failed:
        ax.text(0.99, 0.02, "not drawn:\n" + "\n".join(failed), transform=ax.transAxes, ha="right", va="bottom",
                fontsize=7, color="tab:red", zorder=10,
                bbox=dict(boxstyle="round", facecolor="white", edgecolor="tab:red", alpha=0.9))
    ax.axhline(0, color="k", lw=0.6)
    ax.set_yscale("symlog", linthresh=1)
    ticks = [-10, -3, -1, 0, 1, 3, 10, 30, 100]
    ax.set_yticks(ticks)
    ax.set_yticklabels([f"{t:+g}" if t else "0" for t in ticks])
    ax.set_xlabel("ω_soft × step")
    ax.set_ylabel("⟨c²⟩ / (kT/2k) − 1  (%)")
    ax.set_title(f"bias of a pair centre's ⟨c²⟩, N = {n}\n(exact kT/2k; 20-block standard errors)", fontsize=10)
    ax.legend(fontsize=6.5, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2)
    # (d), (e) ESS per second.
    panels = [(bottom[0, 1], "pairs", ("U", "C2"), f"{data['part2']['pairs']['N']} spring pairs (SIM model), "
               "Reference"),
              (bottom[0, 3], "dipeptide", ("U", "cos_psi"), "alanine dipeptide in vacuum, Amber14, Reference")]
    if fpu:
        panels.append((third[0, 1], "fpu", ("U", "X0sq"), f"{fpu['chains']} FPU chains (m = {fpu['m']}, "
                       f"ω = {fpu['omega']:g}/ps, {fpu['friction']:g}/ps), Reference"))
    for where, scene, names, title in panels:
        ax = fig.add_subplot(where)
        peers = data["part2"][scene]["peers"]
        labels = list(peers)
        width = 0.38
        for j, name in enumerate(names):
            values = [peers[k][name]["ess_per_s"] for k in labels]
            errors = [peers[k][name]["ess_per_s_error"] for k in labels]
            # Log axis: the lower error bar stops at 10 % of the value.
            lower = [min(e, 0.9 * v) for v, e in zip(values, errors)]
            ax.barh(np.arange(len(labels)) + (j - 0.5) * width, values, width, xerr=[lower, errors], capsize=2,
                    color=["tab:gray", "tab:green"][j], label={"U": "potential energy U", "C2": "C2 = mean c²",
                                                               "cos_psi": "cos ψ", "X0sq": "mean x0²"}[name])
        ticks = []
        for k in labels:
            e = peers[k]
            extra = f"\nacc {e['acceptance']:.2f}, " if e.get("acceptance") is not None else "\n"
            tick = reporting.greek(e["label"].replace(" exact flow δ", ", exact flow\nδ")) + extra + \
                f"{e['us_per_step']:.0f} µs/step"
            if scene == "pairs":
                exact = data["part2"]["pairs"]["c2_exact"]
                tick += (f"\n⟨C2⟩ {100 * (e['C2']['mean'] / exact - 1):+.1f} ± "
                         f"{100 * e['C2']['mean_error'] / exact:.1f} % from kT/2k")
            ticks.append(tick)
        ax.set_yticks(np.arange(len(labels)))
        ax.set_yticklabels(ticks, fontsize=6.5)
        ax.invert_yaxis()
        ax.set_xscale("log")
        ax.set_xlabel("effective samples per wall second (ESS/s; Sokal error bars)")
        ax.set_title(f"ESS per wall second, {title}\n(peers interleaved, only step() timed)", fontsize=9.5)
        ax.legend(fontsize=7, loc="lower right")
        if scene == "fpu":
            continue
        cost = data["part2"]["step_cost"][scene]
        a, b = cost["adjusted_over_unadjusted"], cost["adjusted_over_langevin"]
        ax.text(0.5, -0.11, f"cost of a step, {cost['step_fs']:g} fs, median of {a['rounds']} interleaved rounds:\n"
                f"adjusted / unadjusted {a['median']:.2f} (quartiles {a['q1']:.2f}–{a['q3']:.2f})\n"
                f"adjusted / LangevinMiddle ({cost['langevin_step_fs']:g} fs) {b['median']:.2f} "
                f"({b['q1']:.2f}–{b['q3']:.2f})", transform=ax.transAxes, ha="center", va="top", fontsize=8,
                bbox=dict(boxstyle="round", facecolor="white", edgecolor="0.6", alpha=0.9))
    if fpu:
        # The FPU peers' deviation from the exact averages (transfer-matrix quadrature).
        ax = fig.add_subplot(third[0, 3])
        labels = list(fpu["peers"])
        width = 0.38
        for j, (name, exact, text) in enumerate((("U", fpu["U_exact"], "⟨U⟩"), ("X0sq", fpu["X0sq_exact"],
                                                                                 "⟨x0²⟩"))):
            e = [fpu["peers"][k][name] for k in labels]
            ax.barh(np.arange(len(labels)) + (j - 0.5) * width, [100 * (o["mean"] / exact - 1) for o in e], width,
                    xerr=[100 * o["mean_error"] / exact for o in e], capsize=2, color=["tab:gray", "tab:green"][j],
                    label=f"{text} (exact {exact:.4g} {'kJ/mol' if name == 'U' else 'nm²'})")
        replicas = fpu.get("replicas", {})
        for j, (name, marker) in enumerate((("U", "D"), ("X0sq", "s"))):
            rows = [(labels.index(k), r) for k, r in replicas.items() if k in labels]
            if rows:
                ax.errorbar([100 * r[f"{name}_bias"] for _, r in rows], [i + (j - 0.5) * width for i, _ in rows],
                            xerr=[100 * r[f"{name}_bias_error"] for _, r in rows], fmt=marker, color="k", ms=4,
                            capsize=2, zorder=5, label=f"{'⟨U⟩' if name == 'U' else '⟨x0²⟩'}: "
                            f"{rows[0][1]['runs']} independent replicas × {rows[0][1]['ps_per_run']:g} ps "
                            "(error: their spread)")
        ax.axvline(0, color="k", lw=0.6)
        ax.set_yticks(np.arange(len(labels)))
        ax.set_yticklabels([reporting.greek(fpu["peers"][k]["label"].replace(" exact flow δ", ", exact flow\nδ"))
                            for k in labels], fontsize=6.5)
        ax.invert_yaxis()
        ax.set_xlabel("deviation from the exact Boltzmann average (%; bars: the ESS runs, 20-block standard errors)")
        ax.set_title(f"{fpu['chains']} FPU chains: bias against the exact averages\n(x0 = (q₂ᵢ₋₁ + q₂ᵢ)/√2, "
                     "mean over pairs, coordinates, chains)", fontsize=9.5)
        ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=2)
    # (f) acceptance of the nonintrusive FLAVOR against the stiff omega delta.
    ax = fig.add_subplot(top[0, 3])
    for key in ("flavor_artificial", "flavor_artificial_exact", "flavor_nonintrusive"):
        for n in data["parameters"]["N"]:
            rs = sorted((r for r in runs if r["scheme"] == key and r["N"] == n and r.get("adjusted")),
                        key=lambda r: r["x"])
            ax.errorbar([r["stiff_omega_step"] for r in rs], [r["acceptance"] for r in rs],
                        [r["acceptance_error"] for r in rs], color=COLORS[key], marker=MARKERS[n], ms=4, lw=1,
                        capsize=2, ls="-" if n == 1 else ("--" if n == 10 else ":"),
                        label=f"{SCHEMES[key]['label']}, N = {n}")
    ax.set_xscale("log")
    ticks = [1.4, 2, 3, 5, 7, 10, 14, 21]
    ax.set_xticks(ticks)
    ax.set_xticklabels([f"{t:g}" for t in ticks])
    ax.minorticks_off()
    ax.set_xlabel("ω δ  (stiff ω = 1414/ps, τ = 0.5 fs: ωτ = 0.71)")
    ax.set_ylabel("acceptance rate")
    ax.set_title("FLAVOR acceptance against the stiff ωδ: the Nonintrusive\naveraging collapses where ωδ ≫ 1 "
                 "(styles as in the first panel)", fontsize=10)
    # (g) the dipeptide's acceptance grid.
    ax = fig.add_subplot(bottom[0, 5])
    grid = data["part2"]["dipeptide"]["acceptance_grid"]
    for ratio, color in zip(sorted({g["delta_over_tau"] for g in grid}), ("k", "tab:purple", "tab:brown", "tab:olive")):
        gs = [g for g in grid if g["delta_over_tau"] == ratio]
        ax.errorbar([g["delta_fs"] for g in gs], [g["acceptance"] for g in gs], [g["acceptance_error"] for g in gs],
                    color=color, marker="o", ms=4, capsize=2,
                    label="τ = δ (velocity Verlet)" if ratio == 1 else f"τ = δ/{ratio:g}")
    ax.set_xlabel("δ (fs)")
    ax.set_ylabel("acceptance rate")
    ax.set_ylim(-0.03, 1.03)
    ax.set_title("alanine dipeptide: adjusted Nonintrusive FLAVOR,\nbonds stiff (not quadratic), 1/ps", fontsize=9.5)
    ax.legend(fontsize=7)
    fig.suptitle("Metropolis-adjusted SIM and FLAVOR: acceptance against step and system size, the unadjusted bias, "
                 "and effective samples per wall second against LangevinMiddleIntegrator", fontsize=11)
    reporting.save_figure(fig, path, 90)


def report(data):
    runs = data["part1"]
    rows = []
    for r in runs:
        if not r.get("adjusted"):
            continue
        rows.append([SCHEMES[r["scheme"]]["label"], f"{r['N']}", f"{r['x']:g}", f"{r['step_ps'] * 1000:.4g}",
                     f"{r['stiff_omega_step']:.3g}", f"{r['acceptance']:.4f} ± {r['acceptance_error']:.4f}"])
    reporting.table("Acceptance (20-block standard errors)",
                    [("scheme", 28, "s"), ("N", 4, "s"), ("ω_s·step", 9, "s"), ("step fs", 8, "s"),
                     ("ω·step", 7, "s"), ("acceptance", 18, "s")], rows)
    rows = []
    for r in runs:
        if r["N"] != data["parameters"]["bias_N"] or "c2" not in r:
            continue
        rows.append([SCHEMES[r["scheme"]]["label"], "yes" if r["adjusted"] else "no", f"{r['x']:g}",
                     f"{r['c2']:.5g} ± {r['c2_error']:.2g}", f"{r['c2_exact']:.5g}",
                     f"{100 * r['c2_bias']:+.2f} ± {100 * r['c2_bias_error']:.2f}",
                     f"{r['c2_z']:+.1f}" if r.get("c2_z") is not None else "-"])
    reporting.table(f"<c^2> at N = {data['parameters']['bias_N']} (20-block standard errors)",
                    [("scheme", 28, "s"), ("adj", 4, "s"), ("ω_s·step", 9, "s"), ("<c^2>", 22, "s"),
                     ("exact", 9, "s"), ("bias %", 16, "s"), ("z", 6, "s")], rows)
    for key, f in data["rejection_fits"].items():
        if f:
            print(f"{SCHEMES[key]['label']}: 1 - acceptance ~ step^{f['step_power']:.2f} ± {f['step_power_error']:.2f}"
                  f" N^{f['N_power']:.2f} ± {f['N_power_error']:.2f} ({f['points']} points)")
    scenes = [("pairs", ("U", "C2")), ("dipeptide", ("U", "cos_psi"))]
    if "fpu" in data["part2"]:
        scenes.append(("fpu", ("U", "X0sq")))
    for scene, names in scenes:
        rows = []
        for key, e in data["part2"][scene]["peers"].items():
            row = [e["label"], f"{e['us_per_step']:.1f}", "-" if e.get("acceptance") is None else
                   f"{e['acceptance']:.3f}"]
            for name in names:
                o = e[name]
                row += [f"{o['mean']:.5g} ± {o['mean_error']:.2g}", f"{o['tau_int_ps']:.3g} ± "
                        f"{o['tau_int_ps'] * o['tau_int_error'] / o['tau_int_samples']:.2g}",
                        f"{o['ess_per_s']:.3g} ± {o['ess_per_s_error']:.2g}"]
            rows.append(row)
        cols = [("peer", 52, "s"), ("µs/step", 8, "s"), ("acc", 6, "s")]
        for name in names:
            cols += [(f"<{name}>", 20, "s"), (f"τ_int ps", 14, "s"), ("ESS/s", 14, "s")]
        reporting.table(f"ESS per wall second, {scene} (Sokal window, c = 5)", cols, rows)
        if scene == "fpu":
            f = data["part2"]["fpu"]
            print(f"FPU exact: <U> = {f['U_exact']:.4f} kJ/mol, <x0^2> = {f['X0sq_exact']:.6f} nm^2; deviations:")
            for e in f["peers"].values():
                print(f"  {e['label']:72s} U {100 * (e['U']['mean'] / f['U_exact'] - 1):+.2f} ± "
                      f"{100 * e['U']['mean_error'] / f['U_exact']:.2f} %, x0^2 "
                      f"{100 * (e['X0sq']['mean'] / f['X0sq_exact'] - 1):+.2f} ± "
                      f"{100 * e['X0sq']['mean_error'] / f['X0sq_exact']:.2f} %")
            for e in f.get("replicas", {}).values():
                print(f"  {e['runs']} replicas of {e['ps_per_run']:g} ps, {e['label']}: acceptance "
                      f"{e['acceptance']:.3f}, U {100 * e['U_bias']:+.2f} ± {100 * e['U_bias_error']:.2f} %, x0^2 "
                      f"{100 * e['X0sq_bias']:+.2f} ± {100 * e['X0sq_bias_error']:.2f} % (spread of the replicas)")
            continue
        o = data["part2"]["step_cost"][scene]
        a, b = o["adjusted_over_unadjusted"], o["adjusted_over_langevin"]
        print(f"step cost, {scene} ({o['step_fs']:g} fs; µs/step medians {o['us_per_step_median']}): adjusted / "
              f"unadjusted {a['median']:.3f} (quartiles {a['q1']:.3f}-{a['q3']:.3f}), adjusted / LangevinMiddle "
              f"{b['median']:.3f} ({b['q1']:.3f}-{b['q3']:.3f}), {a['rounds']} interleaved rounds")
    for g in data["part2"]["dipeptide"]["acceptance_grid"]:
        print(f"dipeptide, adjusted Nonintrusive FLAVOR delta = {g['delta_fs']:g} fs, tau = {g['tau_fs']:g} fs: "
              f"acceptance {g['acceptance']:.3f} ± {g['acceptance_error']:.3f} ({g['steps']} steps)")


def parameters(quick):
    if quick:
        return {"quick": True, "N": [1, 10], "x": [0.2, 1.0], "bias_N": 10, "bias_time": 200.0, "sample_x": 1.0,
                "steps_by_N": {"1": 500, "10": 500, "100": 200},
                "ess_pairs": 10, "pair_sample_ps": 0.1, "pair_chunk_ps": 2.0, "pair_total_ps": 6.0,
                "pair_burn_ps": 0.5,
                "pair_peers": [("langevin", 0.001, None), ("sim", 0.1, True), ("sim", 0.1, False)],
                "cost_steps_pairs": 100, "cost_steps_dipeptide": 50, "cost_rounds": 4,
                "mol_equilibrate_ps": 0.5, "mol_sample_ps": 0.01, "mol_chunk_ps": 0.2, "mol_total_ps": 0.4,
                "mol_burn_ps": 0.05,
                "mol_peers": [("langevin", 0.001, None, None), ("flavor", 0.001, 0.001, True),
                              ("flavor", 0.001, 0.001, False)],
                "mol_grid_delta_fs": [1.0, 2.0], "mol_grid_ratio": [1], "mol_grid_steps": 100,
                "fpu_chains": 10, "fpu_omega": 200.0, "fpu_friction": 5.0, "fpu_tau": 0.0025,
                "fpu_equilibrate_ps": 2.0, "fpu_sample_ps": 0.1, "fpu_chunk_ps": 2.0, "fpu_total_ps": 6.0,
                "fpu_burn_ps": 0.5,
                "fpu_peers": [("langevin", 0.001, None), ("sim", 0.1, True), ("sim", 0.1, False)],
                "fpu_replica_step": 0.1, "fpu_replica_runs": 2, "fpu_replica_ps": 5.0}
    return {"quick": False, "N": [1, 10, 100], "x": [0.1, 0.2, 0.35, 0.5, 0.7, 1.0, 1.5], "bias_N": 10,
            "bias_time": 6000.0, "sample_x": 1.0, "steps_by_N": {"1": 20000, "10": 6000, "100": 4000},
            "ess_pairs": 10, "pair_sample_ps": 0.1, "pair_chunk_ps": 100.0, "pair_total_ps": 2000.0,
            "pair_burn_ps": 5.0,
            "pair_peers": [("langevin", 0.001, None), ("langevin", 0.004, None), ("sim", 0.05, True),
                           ("sim", 0.1, True), ("sim", 0.1, False)],
            "cost_steps_pairs": 2000, "cost_steps_dipeptide": 1000, "cost_rounds": 30,
            "mol_equilibrate_ps": 10.0, "mol_sample_ps": 0.02, "mol_chunk_ps": 50.0, "mol_total_ps": 1000.0,
            "mol_burn_ps": 2.0,
            "mol_peers": [("langevin", 0.001, None, None), ("langevin", 0.002, None, None),
                          ("flavor", 0.001, 0.001, True), ("flavor", 0.002, 0.002, True),
                          ("flavor", 0.001, 0.001, False)],
            "mol_grid_delta_fs": [0.5, 1.0, 1.5, 2.0, 2.5, 3.0], "mol_grid_ratio": [1, 2, 4], "mol_grid_steps": 2000,
            "fpu_chains": 10, "fpu_omega": 200.0, "fpu_friction": 5.0, "fpu_tau": 0.0025,
            "fpu_equilibrate_ps": 20.0, "fpu_sample_ps": 0.1, "fpu_chunk_ps": 400.0, "fpu_total_ps": 12000.0,
            "fpu_burn_ps": 5.0,
            "fpu_peers": [("langevin", 0.001, None), ("langevin", 0.008, None), ("sim", 0.04, True),
                          ("sim", 0.04, False), ("sim", 0.1, True), ("sim", 0.1, False), ("flavor", 0.1, True),
                          ("flavor", 0.2, True), ("flavor", 0.2, False)],
            "fpu_replica_step": 0.1, "fpu_replica_runs": 20, "fpu_replica_ps": 3000.0}


def main():
    parser = reporting.parser(__doc__, NAME, quick_help="smoke run of about 20 s (fewer steps, N, peers)")
    parser.add_argument("--replot", metavar="JSON", help="redraw the chart from an earlier run's JSON into --out")
    parser.add_argument("--fpu-into", metavar="JSON", help="run only the FPU chains' comparison and write an earlier "
                        "run's JSON with it added (and the chart) into --out")
    args = parser.parse_args()
    if args.replot:
        reporting.replot(args.replot, args.out, NAME, plot)
        return
    # Every stiff mode of the SIM model sits in a resonance band at omega H >> 1 (the warning says so); the
    # adjustment keeps the sampling exact there, and the acceptance measures what the resonance costs.
    warnings.filterwarnings("ignore", category=openmmflavors.ResonanceWarning)
    p = parameters(args.quick)
    if args.fpu_into:
        with open(args.fpu_into) as f:
            data = json.load(f)
        fresh = {k: v for k, v in p.items() if k.startswith("fpu_")}
        data["parameters"].update(fresh)
        begin = time.perf_counter()
        data["part2"]["fpu"] = fpu_part(p)
        data["fpu_wall_s"] = time.perf_counter() - begin
        report(data)
        data = reporting.jsonable(data)
        reporting.save_outputs(args.out, NAME, data, lambda path: plot(data, path))
        return
    begin = time.perf_counter()
    runs = part1(p)
    data = {"quick": args.quick, "parameters": p, "kT_kJ_per_mol": KT, "part1": runs,
            "rejection_fits": {key: fit_rejection(runs, key, p) for key in SCHEMES}}
    data["part1_wall_s"] = time.perf_counter() - begin
    begin = time.perf_counter()
    data["part2"] = part2(p)
    data["part2_wall_s"] = time.perf_counter() - begin
    report(data)
    data = reporting.jsonable(data)
    reporting.save_outputs(args.out, NAME, data, lambda path: plot(data, path))


if __name__ == "__main__":
    main()
