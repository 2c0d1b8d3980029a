#!/usr/bin/env python3
"""Langevin equations with fast noise and friction: the FLAVORS paper, section 6.9, eqs. (6.20)-(6.21), Fig. 6.16.

    H = (p_y^2 + p_x^2)/2 + omega^4 y^4/4 + e^y (x - y)^2
    dp_y = -omega^4 y^3 dt - (2 + y - x)(y - x) e^y dt - omega^2 c p_y dt + omega sigma dW
    dp_x = -2 (x - y) e^y dt                                   (no friction, no noise on x)

Friction omega^2 c and noise omega sigma act on y only; k_B T = sigma^2/(2c).  Unit masses on the x axis: y is pinned
to the wall by the stiff quartic spring (CustomExternalForce, force group 1), x is tied to y by e^y (x-y)^2
(CustomCompoundBondForce, group 0).  The ensemble is one System of n non-interacting copies; every copy's y is
listed in setFrictionParticles, so x gets neither friction nor noise.  Runs:
  gla                  GLA of eq. (6.21), the paper's benchmark: FlavorIntegrator(h, h, {1}), SymplecticEuler,
                       friction omega^2 c on y only.  Speedups of the library FLAVOR are measured against it.
  flavor_d*_t*         the paper's fast-friction FLAVOR, eqs. (4.8) + (2.9): FlavorIntegrator(delta, tau, {1}),
                       SymplecticEuler, setStiffFriction(True), friction omega^2 c on y only.
  gla_custom           cross-check of gla: O_y(h) K(h) D(h) as an OpenMM CustomIntegrator (per-DOF coefficients).
  flavor_custom_d*_t*  cross-check of flavor_d*_t*: O_y(tau) K(tau) D(tau) K_soft(delta-tau) D(delta-tau), same.
FLAVOR runs at the paper's delta = 0.01, tau = 1e-4 and at tau = 1e-5, where the mesostep stays stable.

    PYTHONPATH=build/python .venv/bin/python examples/langevin_fast_noise/langevin_fast_noise.py [--quick] [--out DIR]
"""
import math
import sys

import numpy as np
import openmm as mm

from flavorbench import ensemble, reporting
from flavorbench.ensemble import LATE_Z_AGREE, MEAN_Z2_AGREE, compare, run_ensemble, window_means
from flavorbench.runners import KB, flavor
from flavorbench.systems import SOFT_GROUP, STIFF_GROUP
BLOWUP_Y = 0.5

QUANTITIES = {
    "s": "E[x-y]  (Fig. 6.16)",
    "y": "E[y]  (Fig. 6.16)",
    "s2": "E[(x-y)^2]  (Fig. 6.16)",
    "y2": "E[y^2]",
    "px2": "E[p_x^2] / kT",
    "py2": "E[p_y^2] / kT",
}


def build_system(n, omega):
    """n copies; copy k is particle 2k (y) and 2k+1 (x)."""
    system = mm.System()
    stiff = mm.CustomExternalForce("omega4 * x^4 / 4")
    stiff.addGlobalParameter("omega4", omega ** 4)
    # Only the x coordinates interact: the thermostat also kicks the y and z components, which must stay inert.
    soft = mm.CustomCompoundBondForce(2, "exp(x1) * (x2 - x1)^2")
    stiff.setForceGroup(STIFF_GROUP)
    soft.setForceGroup(SOFT_GROUP)
    for k in range(n):
        system.addParticle(1.0)
        system.addParticle(1.0)
        stiff.addParticle(2 * k, [])
        soft.addBond([2 * k, 2 * k + 1], [])
    system.addForce(stiff)
    system.addForce(soft)
    return system


def damped_particles(n):
    """Every copy's y (particle 2k): eq. (6.21) puts friction and noise on y only."""
    return list(range(0, 2 * n, 2))


def flavor_integrator(n, delta, tau, temperature, friction, stiff_friction, seed):
    """FlavorIntegrator(delta, tau), SymplecticEuler, friction and noise on every copy's y only."""
    return flavor(delta, tau, "SymplecticEuler", temperature, friction, seed, stiff_friction, damped_particles(n))


def per_dof_ou(n, kT, h, friction_y):
    """exp(-gamma h) and sqrt(kT/m (1 - exp(-2 gamma h))) per degree of freedom (unit masses); x is undamped."""
    ay, by = math.exp(-friction_y * h), math.sqrt(kT * -math.expm1(-2.0 * friction_y * h))
    a = [mm.Vec3(ay, ay, ay) if i % 2 == 0 else mm.Vec3(1.0, 1.0, 1.0) for i in range(2 * n)]
    b = [mm.Vec3(by, by, by) if i % 2 == 0 else mm.Vec3(0.0, 0.0, 0.0) for i in range(2 * n)]
    return a, b


def custom_gla(n, h, kT, friction_y, seed):
    """Independent GLA with friction on y only: O_y(h) K_all(h) D(h), the order FlavorIntegrator(h, h) uses."""
    integrator = mm.CustomIntegrator(h)
    integrator.addPerDofVariable("a", 1.0)
    integrator.addPerDofVariable("b", 0.0)
    integrator.addComputePerDof("v", "a*v + b*gaussian")
    integrator.addComputePerDof("v", "v + dt*f/m")
    integrator.addComputePerDof("x", "x + dt*v")
    a, b = per_dof_ou(n, kT, h, friction_y)
    integrator.setPerDofVariableByName("a", a)
    integrator.setPerDofVariableByName("b", b)
    integrator.setRandomNumberSeed(seed)
    return integrator


def custom_flavor(n, delta, tau, kT, friction_y, seed):
    """Independent eqs. (4.8) and (2.9) with the Ornstein-Uhlenbeck step on y only:
    O_y(tau) K_all(tau) D(tau) K_soft(delta - tau) D(delta - tau)."""
    integrator = mm.CustomIntegrator(delta)
    integrator.addGlobalVariable("tau", tau)
    integrator.addGlobalVariable("rest", delta - tau)
    integrator.addPerDofVariable("a", 1.0)
    integrator.addPerDofVariable("b", 0.0)
    integrator.addComputePerDof("v", "a*v + b*gaussian")
    integrator.addComputePerDof("v", "v + tau*f/m")
    integrator.addComputePerDof("x", "x + tau*v")
    integrator.addComputePerDof("v", f"v + rest*f{SOFT_GROUP}/m")
    integrator.addComputePerDof("x", "x + rest*v")
    a, b = per_dof_ou(n, kT, tau, friction_y)
    integrator.setPerDofVariableByName("a", a)
    integrator.setPerDofVariableByName("b", b)
    integrator.setRandomNumberSeed(seed)
    return integrator


def boltzmann(omega4, beta):
    """Exact Boltzmann moments of V = omega4 y^4/4 + e^y s^2 (s = x - y): s given y is Gaussian with variance
    1/(2 beta e^y), so the marginal of y is exp(-beta omega4 y^4/4 - y/2)."""
    scale = (beta * omega4 / 4.0) ** -0.25
    y = np.linspace(-10.0, 10.0, 400001) * scale
    w = np.exp(-beta * omega4 * y ** 4 / 4.0 - y / 2.0)
    z = ensemble.trapezoid(w, y)
    avg = lambda f: float(ensemble.trapezoid(w * f, y) / z)
    return {"s": 0.0, "y": avg(y), "s2": avg(np.exp(-y)) / (2.0 * beta), "y2": avg(y * y), "px2": 1.0, "py2": 1.0}


def mesoscale_stability(delta, tau, omega, beta):
    """Where the mesostep stops being stable for the stiff quartic spring, and how often H_eff reaches there.

    Averaged over a mesostep the stiff force acts with weight tau/delta: y oscillates in (tau/delta) omega^4 y^4/4,
    integrated with step delta.  Linearised at amplitude A the frequency is A omega^2 sqrt(3 tau/delta), unstable
    for symplectic Euler when delta times it exceeds 2.  P(|y| > A_crit) is taken under exp(-beta (tau/delta)
    omega^4 y^4/4) (the quartic part of the H_eff Boltzmann density).
    """
    a_crit = 2.0 / (delta * omega ** 2 * math.sqrt(3.0 * tau / delta))
    a = beta * (tau / delta) * omega ** 4 / 4.0
    u = np.linspace(0.0, 12.0, 200001) * a ** -0.25
    density = np.exp(-a * u ** 4)
    tail = ensemble.trapezoid(np.where(u > a_crit, density, 0.0), u) / ensemble.trapezoid(density, u)
    return {"A_crit": a_crit, "beta_V_eff_at_A_crit": a * a_crit ** 4, "P_abs_y_gt_A_crit_H_eff": float(tail)}


def main():
    parser = reporting.parser(__doc__, "langevin_fast_noise",
                          quick_help="smoke run of a few seconds (n = 8, T = 0.2)", out_help=None)
    parser.add_argument("--n", type=int, default=None, help="ensemble size (default 50, the paper's; 8 with --quick)")
    parser.add_argument("--T", type=float, default=None, help="simulated time (default 10; 0.2 with --quick)")
    parser.add_argument("--omega", type=float, default=100.0)
    parser.add_argument("--c", type=float, default=0.1, help="friction on y is omega^2 c (1/ps)")
    parser.add_argument("--sigma", type=float, default=1.0, help="noise on y is omega sigma; k_B T = sigma^2/(2c)")
    parser.add_argument("--flavor", nargs="+", default=["0.01,0.0001", "0.01,0.00001"], metavar="DELTA,TAU",
                        help="FLAVOR parameters (default: the paper's delta = 0.01, tau = 1e-4, and tau = 1e-5, "
                             "which stays stable)")
    parser.add_argument("--h", type=float, default=1e-4, help="GLA step (the paper's 1e-4)")
    parser.add_argument("--sample", type=float, default=0.01, help="sampling interval")
    parser.add_argument("--window", type=float, default=0.1, help="averaging window for the comparison")
    parser.add_argument("--regime", type=float, default=2.0, help="split of the early/late summary (time)")
    parser.add_argument("--no-custom", action="store_true", help="skip the CustomIntegrator cross-checks")
    parser.add_argument("--seed", type=int, default=6921)
    args = parser.parse_args()

    n = args.n if args.n is not None else (8 if args.quick else 50)
    T = args.T if args.T is not None else (0.2 if args.quick else 10.0)
    omega = args.omega
    y0 = 1.1 / omega
    x0 = y0 + 1.8
    kT = args.sigma ** 2 / (2 * args.c)
    beta = 1.0 / kT
    temperature = kT / KB
    gamma = omega ** 2 * args.c
    h = args.h
    flavors = [tuple(float(v) for v in spec.split(",")) for spec in args.flavor]
    width = max(1, int(round(args.window / args.sample)))
    late_from = 2.0 * T / 3.0
    system = build_system(n, omega)

    print(f"eqs. (6.20)-(6.21): n = {n} copies in one System, T = {T:g}, omega = {omega:g}, friction on y "
          f"omega^2 c = {gamma:g}/ps, kT = {kT:g} kJ/mol ({temperature:.2f} K)", file=sys.stderr)
    # (key, label, make(seed), mesostep, microstep, library run it cross-checks)
    plan = [("gla", f"GLA h={h:g} (FlavorIntegrator)",
             lambda seed: flavor_integrator(n, h, h, temperature, gamma, False, seed), h, h, None)]
    for delta, tau in flavors:
        plan.append((f"flavor_d{delta:g}_t{tau:g}", f"FLAVOR d={delta:g} t={tau:g} (FlavorIntegrator)",
                     lambda seed, delta=delta, tau=tau: flavor_integrator(n, delta, tau, temperature, gamma, True,
                                                                          seed), delta, tau, None))
    if not args.no_custom:
        plan.append(("gla_custom", f"GLA h={h:g} (CustomIntegrator)",
                     lambda seed: custom_gla(n, h, kT, gamma, seed), h, h, "gla"))
        for delta, tau in flavors:
            plan.append((f"flavor_custom_d{delta:g}_t{tau:g}", f"FLAVOR d={delta:g} t={tau:g} (CustomIntegrator)",
                         lambda seed, delta=delta, tau=tau: custom_flavor(n, delta, tau, kT, gamma, seed), delta, tau,
                         f"flavor_d{delta:g}_t{tau:g}"))
    runs, twins = {}, {}
    for i, (key, label, make, dt, micro, twin) in enumerate(plan):
        print(f"running {label}", file=sys.stderr, flush=True)
        runs[key] = run_ensemble(system, make(args.seed + i), dt, n, y0, x0, args.sample, T, label, BLOWUP_Y)
        runs[key].update(delta=dt, tau=micro)
        if twin is not None:
            twins[key] = twin

    t = np.arange(int(round(T / args.sample)) + 1) * args.sample
    t_window = (np.arange(window_means(t[:, None], width).shape[0]) + 0.5) * width * args.sample
    stats, used = {}, {}
    for key, run in runs.items():
        stats[key], used[key] = ensemble.series_statistics(
            run, lambda x, y, px, py: {"s": x - y, "y": y, "s2": (x - y) ** 2, "y2": y * y, "px2": px * px / kT,
                                       "py2": py * py / kT}, width, t, late_from)
    comparison = {key: {q: compare(stats[key][q], stats["gla"][q], t_window, late_from, args.regime)
                        for q in QUANTITIES} for key in runs if key != "gla"}
    # Each CustomIntegrator run against the library run of the same scheme (different random streams).
    cross_check = {key: {"against": twin, **{q: compare(stats[key][q], stats[twin][q], t_window, late_from,
                                                        args.regime) for q in QUANTITIES}}
                   for key, twin in twins.items()}
    # FLAVOR samples H_eff = K + V_soft + (tau/delta) V_stiff: omega^4 -> omega^4 tau/delta.
    equilibrium = {"true": boltzmann(omega ** 4, beta)}
    equilibrium.update({f"H_eff_d{delta:g}_t{tau:g}": boltzmann(omega ** 4 * tau / delta, beta)
                        for delta, tau in flavors})

    summary = {}
    for key, run in runs.items():
        blown = np.isfinite(run["blown_at"])
        # Like for like: library runs against the library GLA, CustomIntegrator runs against the custom GLA.
        baseline = "gla_custom" if key in twins else "gla"
        summary[key] = {"label": run["label"], "delta": run["delta"], "tau": run["tau"], "steps": run["steps"],
                        "wall_s": run["wall_s"], "us_per_step": run["us_per_step"],
                        "speedup_vs_gla": runs["gla"]["wall_s"] / run["wall_s"],
                        "speedup_baseline": baseline,
                        "speedup_like_for_like": runs[baseline]["wall_s"] / run["wall_s"],
                        "copies_used": used[key], "copies_blown_up": int(blown.sum()),
                        "blowup_times": sorted(float(v) for v in run["blown_at"][blown]),
                        "stability": mesoscale_stability(run["delta"], run["tau"], omega, beta)}
    print_tables(summary, comparison, cross_check, equilibrium, late_from, args.regime, T, n)

    data = {
        "scene": "FLAVORS paper section 6.9, eqs. (6.20)-(6.21), Fig. 6.16: Langevin with fast noise and friction "
                 "on y only",
        "platform": "Reference",
        "openmm_version": mm.__version__,
        "model": {"particles": "copy k: particle 2k = y, 2k+1 = x, unit masses, x axis",
                  "stiff (group 1)": "CustomExternalForce omega^4 x^4/4 on y",
                  "soft (group 0)": "CustomCompoundBondForce exp(x1) (x2-x1)^2 on (y, x)",
                  "friction particles": "setFrictionParticles([0, 2, ..., 2n-2]): every copy's y; x undamped",
                  "runs": {"gla": "FlavorIntegrator(h, h, {1}), SymplecticEuler, friction omega^2 c on y only: "
                                  "GLA of eq. (6.21), the paper's benchmark",
                           "flavor_d*_t*": "FlavorIntegrator(delta, tau, {1}), SymplecticEuler, "
                                           "setStiffFriction(True), friction omega^2 c on y only: eqs. (4.8) + (2.9)",
                           "gla_custom": "cross-check of gla: O_y(h) K(h) D(h), CustomIntegrator",
                           "flavor_custom_d*_t*": "cross-check of flavor_d*_t*: eqs. (4.8) + (2.9) with the OU step "
                                                  "on y only, CustomIntegrator"}},
        "parameters": {"n": n, "T": T, "omega": omega, "c": args.c, "sigma": args.sigma, "friction_y": gamma,
                       "kT": kT, "temperature_K": temperature, "y0": y0, "x0": x0, "p0": 0.0,
                       "flavor": [list(f) for f in flavors], "h": h, "sample": args.sample,
                       "window": width * args.sample,
                       "late_from": late_from, "regime_split": args.regime, "seed": args.seed, "quick": args.quick,
                       "verdict": f"agree if mean z^2 over the windows <= {MEAN_Z2_AGREE} and |z| of the late-time "
                                  f"average <= {LATE_Z_AGREE}"},
        "quantities": QUANTITIES,
        "runs": summary,
        "equilibrium": equilibrium,
        "comparison": comparison,
        "cross_check": cross_check,
        "series": {"t": t.tolist(), "t_window": t_window.tolist(),
                   **{key: {q: {"mean": s["mean"].tolist(), "se": s["se"].tolist(), "window_mean": s["w_mean"].tolist(),
                                "window_se": s["w_se"].tolist()} for q, s in stats[key].items()} for key in stats}},
    }
    reporting.save_outputs(args.out, "langevin_fast_noise", data,
                       lambda png_path: plot(t_window, stats, summary, equilibrium, data["parameters"], png_path))


def print_tables(summary, comparison, cross_check, equilibrium, late_from, regime, T, n):
    print(f"\neqs. (6.20)-(6.21), {n} trajectories, T = {T:g}, friction and noise on y only.  Wall time: "
          f"integrator.step() only; like-for-like speedup: FlavorIntegrator runs against gla, CustomIntegrator runs "
          f"against gla_custom.")
    head = f"{'run':28s} {'method':40s} {'steps':>7s} {'wall s':>7s} {'us/step':>8s} {'vs gla':>7s} " \
           f"{'like4like':>9s} {'used':>5s} {'blown':>5s} {'A_crit':>7s} {'P(|y|>A_crit)':>13s}"
    print(head)
    print("-" * len(head))
    for key, s in summary.items():
        print(f"{key:28s} {s['label']:40s} {s['steps']:7d} {s['wall_s']:7.2f} {s['us_per_step']:8.1f} "
              f"{s['speedup_vs_gla']:6.1f}x {s['speedup_like_for_like']:8.1f}x {s['copies_used']:5d} "
              f"{s['copies_blown_up']:5d} {s['stability']['A_crit']:7.4f} "
              f"{s['stability']['P_abs_y_gt_A_crit_H_eff']:13.2e}")
    print("A_crit: amplitude of y above which a step of delta is unstable for the stiff spring (linearised); "
          "P(|y| > A_crit) under the H_eff Boltzmann density.  Statistics use the copies that did not blow up.")
    for key, comp in comparison.items():
        if key.startswith("flavor_custom"):
            continue
        print(f"\n{key} ({summary[key]['label']}) against gla.  Window z = (run - GLA)/sqrt(SE_run^2 + SE_GLA^2); "
              f"late = per-copy time average over t >= {late_from:g}, mean +- SE.")
        head = f"{'quantity':26s} {'mean z2':>8s} {'t<' + format(regime, 'g'):>7s} {'t>=' + format(regime, 'g'):>7s} " \
               f"{'max|z|':>7s} {'max|diff|':>9s} {'late GLA':>19s} {'late run':>19s} {'z':>6s} {'ratio':>6s}  verdict"
        print(head)
        print("-" * len(head))
        for q, c in comp.items():
            early = c.get(f"t<{regime:g}", {}).get("mean_z2", float("nan"))
            later = c.get(f"t>={regime:g}", {}).get("mean_z2", float("nan"))
            late = c["late"]
            ratio = f"{late['ratio']:6.2f}" if late["ratio"] is not None else "     -"
            print(f"{QUANTITIES[q]:26s} {c['all']['mean_z2']:8.1f} {early:7.1f} {later:7.1f} "
                  f"{c['all']['max_abs_z']:7.1f} {c['all']['max_abs_diff']:9.3g} "
                  f"{late['reference']:10.4g}+-{late['reference_se']:7.2g} "
                  f"{late['run']:10.4g}+-{late['run_se']:7.2g} {late['z']:6.1f} {ratio}  "
                  f"{'agree' if c['agree'] else 'DIFFER'}")
    if cross_check:
        print("\nCross-checks: each CustomIntegrator run against the FlavorIntegrator run of the same scheme "
              "(independent random streams).  Cell: mean window z2 / late z.")
        names = [QUANTITIES[q].split("  ")[0] for q in QUANTITIES]
        head = f"{'run':28s} {'against':20s} " + " ".join(f"{name:>17s}" for name in names)
        print(head)
        print("-" * len(head))
        for key, comp in cross_check.items():
            cells = []
            for q in QUANTITIES:
                c = comp[q]
                cells.append(f"{c['all']['mean_z2']:5.1f}/{c['late']['z']:5.1f} {'ok' if c['agree'] else 'NO':>4s}")
            print(f"{key:28s} {comp['against']:20s} " + " ".join(f"{cell:>17s}" for cell in cells))
    print("\nExact Boltzmann values of the true H and of H_eff = K + V_soft + (tau/delta) V_stiff, which FLAVOR "
          "samples:")
    for name, values in equilibrium.items():
        print(f"  {name:22s} " + ", ".join(f"{QUANTITIES[q].split('  ')[0]} = {values[q]:.4g}" for q in QUANTITIES))


PLOT_TITLES = {"s": "E[x − y]  (Fig. 6.16)", "y": "E[y]  (Fig. 6.16)", "s2": "E[(x − y)²]  (Fig. 6.16)", "y2": "E[y²]",
               "px2": "E[p_x²] / kT", "py2": "E[p_y²] / kT"}
PLOT_UNITS = {"s": "nm", "y": "nm", "s2": "nm²", "y2": "nm²", "px2": "dimensionless (m = 1 amu)",
              "py2": "dimensionless (m = 1 amu)"}


def plot(t_window, stats, summary, equilibrium, params, path):
    plt = reporting.pyplot()

    fixed = {"gla": ("k", "-", 1.6), "gla_custom": ("tab:gray", "--", 1.0)}
    reds, blues = iter(["tab:red", "tab:orange", "tab:brown"]), iter(["tab:blue", "tab:cyan", "tab:purple"])
    style = {}
    for key in stats:
        if key in fixed:
            style[key] = fixed[key]
        elif key.startswith("flavor_custom"):
            style[key] = (next(blues, "tab:gray"), "--", 1.2)
        else:
            style[key] = (next(reds, "tab:gray"), "-", 1.0)
    panels = ["s", "y", "s2", "y2", "px2", "py2"]
    fig, axes = plt.subplots(3, 2, figsize=(14, 13))
    fig.suptitle(f"Eqs. (6.20)-(6.21), FLAVORS paper Fig. 6.16: FLAVOR (FlavorIntegrator, solid; CustomIntegrator, "
                 f"dashed) against GLA, {params['n']} trajectories\n"
                 f"ω = {params['omega']:g} ps⁻¹, friction γ (the paper's c) = {params['c']:g} ps⁻¹, σ = "
                 f"{params['sigma']:g}, kT = {params['kT']:g} kJ/mol, GLA step h = {params['h']:g} ps, friction and "
                 f"noise on y only (dimensionless units: 1 amu, 1 nm, 1 ps)\n"
                 f"lines: means over windows of {params['window']:g} ps, bands: ±2 standard errors (copies that did "
                 f"not blow up)\ngrey dotted: exact Boltzmann values of H, dash-dot: of H_eff; GLA (black) is drawn on "
                 f"top", fontsize=10)
    for ax, q in zip(axes.flat, panels):
        for key, s in stats.items():
            color, ls, lw = style[key]
            # The reference on top: the other GLA and the FLAVOR slow-variable curves lie on it.
            ax.plot(t_window, s[q]["w_mean"], color=color, ls=ls, lw=lw, zorder=5 if key == "gla" else 2,
                    label=f"{reporting.greek(summary[key]['label'])} ({summary[key]['copies_used']} copies)")
            ax.fill_between(t_window, s[q]["w_mean"] - 2 * s[q]["w_se"], s[q]["w_mean"] + 2 * s[q]["w_se"],
                            color=color, alpha=0.15, lw=0)
        if q in ("s2", "y2", "px2", "py2"):
            ax.axhline(equilibrium["true"][q], color="gray", ls=":", lw=1)
            for name, values in equilibrium.items():
                if name != "true" and values[q] != equilibrium["true"][q]:
                    ax.axhline(values[q], color="gray", ls="-.", lw=1)
        if q == "y2":
            ax.set_yscale("log")
        ax.set_title(PLOT_TITLES.get(q, QUANTITIES[q]))
        ax.set_xlabel("t (ps)")
        ax.set_ylabel(f"{PLOT_TITLES.get(q, q).split('  ')[0]} ({PLOT_UNITS[q]})" if q in PLOT_UNITS else "")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=2, fontsize=9, frameon=False)
    fig.tight_layout(rect=(0, 0.07, 1, 0.98))
    reporting.save_figure(fig, path, 100)


if __name__ == "__main__":
    main()
