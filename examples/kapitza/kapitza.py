#!/usr/bin/env python3
"""Kapitza's inverted pendulum (FLAVORS paper, section 6.6, eqs. 6.13-6.15, Fig. 6.12) with FlavorIntegrator on a
stiff clock.

    l theta'' = [g + omega^2 sin(2 pi omega t)] sin(theta)                                              (6.13)

theta is the angle from the upward vertical.  As an OpenMM System: one particle of mass l whose x coordinate is theta,
the potential U = [g + a sin(2 pi w t)] cos(x) with a = omega^2 and w = omega, split into the soft
CustomExternalForce "g*cos(x)" (group 0) and the stiff "a*sin(2*pi*w*t)*cos(x)" (group 1), where t is a Context
global parameter.  The paper's quantities are dimensionless; OpenMM reads them as nm, ps and amu.

Runs, all from theta(0) = 0.2, theta'(0) = 0, with omega = 1000, l = 9, g = 9.8:
- reference: velocity Verlet at h = 0.2/omega/sqrt(l) with t the physical time (a CustomIntegrator that advances t
  with the step: the discrete d'Alembert principle of eq. 6.14 in its velocity Verlet form);
- Verlet (tau = delta = h): FlavorIntegrator(h, h) with the stiff clock, which is the same velocity Verlet on the
  same engine as the FLAVOR runs (the fair baseline of the speedup);
- FLAVOR, stiff clock: FlavorIntegrator(delta = 0.002, tau = h) with setStiffClockParameter("t"): the forcing runs on
  the tau time scale, omega^2 sin(2 pi omega n tau) as in eq. 6.15;
- FLAVOR, physical time: the same with t set to the Context's time before each step: 2 pi omega delta = 4 pi, the
  forcing aliases to zero and the pendulum falls.

The slow period (from the zero crossings of theta) is compared with the reference's and with the period of Kapitza's
effective potential U_eff = (g/l) cos(theta) + a^2 sin^2(theta) / (4 l^2 (2 pi omega)^2) at the reference's slow
amplitude.  Speedups are
wall-clock ratios of the integrator.step() calls over the whole run, timed in chunks of 100 steps (the median chunk's
time per step times the steps: the machine may be shared), in runs without sampling.

    PYTHONPATH=build/python .venv/bin/python examples/kapitza/kapitza.py [--quick] [--out DIR] [--T 10]
"""
import math
import time

import numpy as np
import openmm as mm

import openmmflavors  # noqa: F401  (loads the plugin)
from flavorbench import reporting
from flavorbench.progress import Progress
from openmmflavors import FlavorIntegrator

NAME = "kapitza"
STIFF_GROUP = 1


def pendulum_system(l, g, omega):
    system = mm.System()
    system.addParticle(l)
    soft = mm.CustomExternalForce("g*cos(x)")
    soft.addGlobalParameter("g", g)
    soft.addParticle(0, [])
    system.addForce(soft)
    stiff = mm.CustomExternalForce("a*sin(2*pi*w*t)*cos(x)")
    stiff.addGlobalParameter("a", omega**2)
    stiff.addGlobalParameter("w", omega)
    stiff.addGlobalParameter("pi", math.pi)
    stiff.addGlobalParameter("t", 0.0)
    stiff.addParticle(0, [])
    stiff.setForceGroup(STIFF_GROUP)
    system.addForce(stiff)
    return system


def reference_integrator(h):
    """Velocity Verlet with the forcing at the physical time: t advances with the drift, before the closing kick."""
    integrator = mm.CustomIntegrator(h)
    integrator.addComputePerDof("v", "v+0.5*dt*f/m")
    integrator.addComputePerDof("x", "x+dt*v")
    integrator.addComputeGlobal("t", "t+dt")
    integrator.addComputePerDof("v", "v+0.5*dt*f/m")
    return integrator


def make_run(kind, p):
    """(integrator, per-step hook or None, step, label) of one run."""
    h, delta = p["h"], p["delta"]
    if kind == "reference":
        return reference_integrator(h), None, h, "reference: velocity Verlet, h, physical time"
    if kind == "verlet":
        integrator = FlavorIntegrator(h, h, {STIFF_GROUP})
        integrator.setStiffClockParameter("t")
        return integrator, None, h, "Verlet (FlavorIntegrator τ = δ = h)"
    integrator = FlavorIntegrator(delta, h, {STIFF_GROUP})
    if kind == "flavor_clock":
        integrator.setStiffClockParameter("t")
        return integrator, None, delta, f"FLAVOR δ = {delta:g}, τ = h, stiff clock"
    # Physical time: t is the Context's time when each step starts.
    return integrator, (lambda context: context.setParameter("t", context.getTime())), delta, \
        f"FLAVOR δ = {delta:g}, τ = h, physical time"


def context_for(integrator, p):
    context = mm.Context(pendulum_system(p["l"], p["g"], p["omega"]), integrator,
                         mm.Platform.getPlatformByName("Reference"))
    context.setPositions([mm.Vec3(p["theta0"], 0, 0)])
    context.setVelocities([mm.Vec3(0, 0, 0)])
    return context


def hamiltonian(theta, v, t, p):
    """H = p^2/(2 l) + [g + a sin(2 pi omega t)] cos(theta), with p = l theta'."""
    return 0.5 * p["l"] * v**2 + (p["g"] + p["omega"]**2 * np.sin(2 * np.pi * p["omega"] * t)) * np.cos(theta)


def sampled_run(kind, p):
    """theta, theta', the clock the stiff force last saw and H every `sample` of physical time."""
    integrator, hook, step, label = make_run(kind, p)
    context = context_for(integrator, p)
    per_sample = int(round(p["sample"] / step))
    samples = int(round(p["T"] / p["sample"]))
    t, theta, v, clock = [0.0], [p["theta0"]], [0.0], [0.0]
    progress = Progress(label, p["T"])
    for _ in range(samples):
        if hook is None:
            integrator.step(per_sample)
        else:
            for _ in range(per_sample):
                hook(context)
                integrator.step(1)
        state = context.getState(getPositions=True, getVelocities=True)
        t.append(state.getTime()._value)
        theta.append(state.getPositions()[0][0]._value)
        v.append(state.getVelocities()[0][0]._value)
        clock.append(context.getParameter("t"))
        progress.update(t[-1])
        if not math.isfinite(theta[-1]):
            break
    progress.update(t[-1], force=True)
    t, theta, v, clock = map(np.array, (t, theta, v, clock))
    return {"label": label, "step": step, "t": t, "theta": theta, "v": v, "clock": clock,
            "H": hamiltonian(theta, v, clock, p)}


def timed_run(kind, p, chunk=100):
    """The wall seconds of the steps over T (no sampling) and the number of steps.  The machine may be shared, so
    the steps are timed in chunks of `chunk` and the run's time is the median chunk's per step times the steps: load
    spikes hit the long and the short runs alike."""
    integrator, _, step, _ = make_run(kind, p)
    context = context_for(integrator, p)  # noqa: F841  (bound to the integrator while it steps)
    steps = int(round(p["T"] / step))
    chunks = []
    for done in range(0, steps, chunk):
        n = min(chunk, steps - done)
        start = time.perf_counter()
        integrator.step(n)
        chunks.append((time.perf_counter() - start) / n)
    return float(np.median(chunks)) * steps, steps


def crossings(t, theta):
    """The times where theta crosses zero (linear interpolation)."""
    s = np.sign(theta)
    idx = np.nonzero(s[:-1] * s[1:] < 0)[0]
    return t[idx] - theta[idx] * (t[idx + 1] - t[idx]) / (theta[idx + 1] - theta[idx])


def slow_period(t, theta):
    """Twice the mean spacing of the zero crossings of theta (None if it does not oscillate around the top)."""
    c = crossings(t, theta)
    if len(c) < 3 or np.max(np.abs(theta)) > math.pi / 2:
        return None
    return 2 * (c[-1] - c[0]) / (len(c) - 1)


def kapitza_period(p, theta0):
    """The period of U_eff at amplitude theta0, by quadrature, and its small-amplitude limit."""
    l, g, a, nu = p["l"], p["g"], p["omega"]**2, 2 * math.pi * p["omega"]
    k = a**2 / (4 * l**2 * nu**2)

    def u(theta):
        return (g / l) * np.cos(theta) + k * np.sin(theta)**2

    n = 200000
    phi = (np.arange(n) + 0.5) * (math.pi / 2) / n
    theta = theta0 * np.sin(phi)
    integrand = theta0 * np.cos(phi) / np.sqrt(2 * (u(theta0) - u(theta)))
    period = 4 * np.sum(integrand) * (math.pi / 2) / n
    small = 2 * math.pi / math.sqrt(2 * k - g / l)
    return period, small


def measure(p):
    runs = {kind: sampled_run(kind, p) for kind in ("reference", "verlet", "flavor_clock", "flavor_physical")}
    ref = runs["reference"]
    # The slow amplitude: theta(0) = 0.2 with theta'(0) = 0 puts the fast motion's velocity a sin(theta0) / (l 2 pi
    # omega) into the slow one, so the slow oscillation's amplitude is larger than 0.2; measured on the reference
    # (its fast part is 1e-4).
    amplitude = float(np.max(np.abs(ref["theta"])))
    kapitza, kapitza_small = kapitza_period(p, amplitude)
    times = {}
    for kind in ("reference", "verlet", "flavor_clock"):
        times[kind] = timed_run(kind, p)
    ref_period = slow_period(ref["t"], ref["theta"])
    summary = {}
    for kind, run in runs.items():
        period = slow_period(run["t"], run["theta"])
        entry = {"label": run["label"], "step": run["step"], "max_abs_theta": float(np.nanmax(np.abs(run["theta"]))),
                 "period": period,
                 "period_vs_reference": None if period is None or ref_period is None else period / ref_period - 1,
                 "period_vs_kapitza": None if period is None else period / kapitza - 1,
                 "H_min": float(np.nanmin(run["H"])), "H_max": float(np.nanmax(run["H"])),
                 "stays_inverted": bool(np.nanmax(np.abs(run["theta"])) < math.pi / 2)}
        if kind in times:
            entry["wall_s"], entry["steps"] = times[kind]
        summary[kind] = entry
    for kind in ("verlet", "flavor_clock"):
        summary[kind]["speedup_vs_reference"] = times["reference"][0] / times[kind][0]
    summary["flavor_clock"]["speedup_vs_verlet"] = times["verlet"][0] / times["flavor_clock"][0]
    summary["flavor_clock"]["step_ratio"] = times["verlet"][1] / times["flavor_clock"][1]
    # The tau = delta FlavorIntegrator is velocity Verlet on physical time: it follows the reference to rounding.
    n = min(len(runs["verlet"]["theta"]), len(ref["theta"]))
    summary["verlet"]["max_abs_diff_from_reference"] = float(np.max(np.abs(runs["verlet"]["theta"][:n] -
                                                                           ref["theta"][:n])))
    return {"quick": p["quick"], "parameters": p, "slow_amplitude": amplitude, "kapitza_period": kapitza,
            "kapitza_small_amplitude_period":
            kapitza_small, "summary": summary,
            "runs": {k: {name: r[name] for name in ("label", "step", "t", "theta", "clock", "H")}
                     for k, r in runs.items()}}


STYLE = {"reference": dict(color="k", lw=1.6),
         "verlet": dict(color="0.6", lw=0.8, ls="--"),
         "flavor_clock": dict(color="tab:blue", lw=1.0),
         "flavor_physical": dict(color="tab:red", lw=1.0, ls="-.")}


def plot(data, path):
    plt = reporting.pyplot()
    s, p = data["summary"], data["parameters"]
    fig, axes = plt.subplots(2, 1, figsize=(13, 8.5), sharex=True)
    for kind, run in data["runs"].items():
        t = np.array(run["t"], dtype=float)
        axes[0].plot(t, np.array(run["theta"], dtype=float), label=run["label"], **STYLE[kind])
        axes[1].plot(t, np.array(run["H"], dtype=float), **STYLE[kind])
    axes[0].set_ylim(-0.6, 2 * math.pi + 0.3)
    axes[0].axhline(0, color="0.8", lw=0.5, zorder=0)
    axes[0].axhline(math.pi, color="0.8", lw=0.5, ls=":", zorder=0)
    axes[0].text(0.0, math.pi + 0.1, "θ = π: hanging down", fontsize=8, color="0.5")
    axes[0].set_ylabel("θ (rad, from the upward vertical)")
    axes[1].set_ylabel("H = p²/2l + (g + ω² sin 2πωt) cos θ\n(dimensionless)")
    axes[1].set_xlabel("t (dimensionless; OpenMM reads it as ps)")
    axes[1].set_ylim(-1.3 * p["omega"]**2, 1.3 * p["omega"]**2)
    axes[0].legend(loc="upper left", fontsize=9)
    fc, ref = s["flavor_clock"], s["reference"]

    def pct(x):
        return "n/a" if x is None else f"{100 * x:+.1f} %"
    verdict = ("FLAVOR on the stiff clock keeps the pendulum inverted" if fc["stays_inverted"] else
               "FLAVOR on the stiff clock does NOT keep the pendulum inverted")
    fell = "falls" if not s["flavor_physical"]["stays_inverted"] else "does not fall"
    ref_period = "n/a" if ref["period"] is None else f"{ref['period']:.4f}"
    fig.suptitle(f"Kapitza's inverted pendulum (ω = {p['omega']:g}, l = {p['l']:g}, g = {p['g']:g}, T = {p['T']:g}): "
                 f"{verdict},\nslow period {pct(fc['period_vs_reference'])} from the reference's ({ref_period}; "
                 f"Kapitza's effective potential {data['kapitza_period']:.4f}), {fc['speedup_vs_verlet']:.0f}× faster "
                 f"than velocity Verlet on the same engine ({fc['speedup_vs_reference']:.0f}× the CustomIntegrator "
                 f"reference);\non physical time the forcing aliases (2πωδ = 4π) and the pendulum {fell}", fontsize=9.5)
    axes[1].text(0.01, 0.03, "H with the forcing at the time the stiff force last saw: the reference and the "
                 "physical-time FLAVOR are sampled every δ, where sin 2πωt = 0;\nthe FLAVOR on the stiff clock at its "
                 "clock nτ, which sweeps the forcing's phase.  Bounded in every run: no drift.", fontsize=8,
                 transform=axes[1].transAxes, va="bottom")
    fig.tight_layout(rect=(0, 0, 1, 0.9))
    reporting.save_figure(fig, path, 100)


def report(data):
    rows = []
    for kind, e in data["summary"].items():
        rows.append([e["label"], f"{e['step']:.4g}", "-" if e["period"] is None else f"{e['period']:.4f}",
                     "-" if e["period_vs_reference"] is None else f"{100 * e['period_vs_reference']:+.2f}",
                     "-" if e["period_vs_kapitza"] is None else f"{100 * e['period_vs_kapitza']:+.2f}",
                     f"{e['max_abs_theta']:.3g}", f"{e.get('wall_s', float('nan')):.3g}",
                     "-" if "speedup_vs_reference" not in e else f"{e['speedup_vs_reference']:.1f}"])
    reporting.table(f"Kapitza's inverted pendulum (Kapitza's effective-potential period {data['kapitza_period']:.4f} "
                    f"at the reference's slow amplitude {data['slow_amplitude']:.3f}; small amplitude "
                    f"{data['kapitza_small_amplitude_period']:.4f})",
                    [("run", 42, "s"), ("step", 9, "s"), ("period", 8, "s"), ("vs ref %", 9, "s"),
                     ("vs Kap %", 9, "s"), ("max|θ|", 7, "s"), ("wall s", 7, "s"), ("speedup", 8, "s")], rows)
    fc = data["summary"]["flavor_clock"]
    print(f"\nFLAVOR on the stiff clock: {fc['step_ratio']:.0f}x fewer steps, {fc['speedup_vs_verlet']:.1f}x faster than "
          f"velocity Verlet (tau = delta) on the same engine, {fc['speedup_vs_reference']:.1f}x the CustomIntegrator "
          f"reference; the tau = delta run differs from the reference by "
          f"{data['summary']['verlet']['max_abs_diff_from_reference']:.2g} in theta.")


def main():
    parser = reporting.parser(__doc__, NAME, quick_help="smoke run of a few seconds (T = 3 instead of 10)")
    parser.add_argument("--T", type=float, default=None, help="simulated time (default 10; 3 with --quick)")
    parser.add_argument("--omega", type=float, default=1000.0)
    parser.add_argument("--l", type=float, default=9.0)
    parser.add_argument("--g", type=float, default=9.8)
    parser.add_argument("--theta0", type=float, default=0.2)
    parser.add_argument("--delta", type=float, default=0.002, help="FLAVOR mesostep")
    args = parser.parse_args()
    T = args.T if args.T is not None else (3.0 if args.quick else 10.0)
    h = 0.2 / args.omega / math.sqrt(args.l)
    p = {"quick": args.quick, "T": T, "omega": args.omega, "l": args.l, "g": args.g, "theta0": args.theta0,
         "delta": args.delta, "h": h, "tau": h, "sample": args.delta}
    data = measure(p)
    report(data)
    data = reporting.jsonable(data)
    reporting.save_outputs(args.out, NAME, data, lambda path: plot(data, path))


if __name__ == "__main__":
    main()
