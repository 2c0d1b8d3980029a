#!/usr/bin/env python3
"""Langevin equations with slow noise and friction: the FLAVORS paper, section 6.8, eq. (6.19), Figs. 6.14-6.15.

    dy = p_y dt,  dp_y = -y^3/eps dt - 4(y - x)^3 dt - c p_y dt + sigma dW1
    dx = p_x dt,  dp_x = -4(x - y)^3 dt - c p_x dt + sigma dW2

i.e. H = (p_y^2 + p_x^2)/2 + y^4/(4 eps) + (x - y)^4 with friction c and noise sigma on both particles, which is
the Langevin equation at k_B T = 1/beta = sigma^2/(2c).  Unit masses, particles on the x axis: y is pinned to the
wall at 0 by the stiff quartic spring (CustomExternalForce, force group 1), x is tied to y by the soft quartic
spring (CustomCompoundBondForce on the x coordinates, group 0).  The ensemble is one System holding n
non-interacting copies of the pair.

FLAVOR: FlavorIntegrator(delta, tau, {1}), SymplecticEuler scheme, friction over the whole mesostep, i.e. eqs. (4.7)
and (2.9) as in the paper.  GLA, the paper's benchmark (the geometric Langevin algorithm): the same integrator with
tau = delta = h, which is O(h) K_all(h) D(h) per step.  Both run from the same deterministic start; moments and the
autocorrelations of Fig. 6.14 are ensemble means with standard errors, compared window by window.

    PYTHONPATH=build/python .venv/bin/python examples/langevin_slow_noise/langevin_slow_noise.py [--quick] [--out DIR]
"""
import math
import sys

import numpy as np
import openmm as mm

from flavorbench import ensemble, reporting
from flavorbench.ensemble import LATE_Z_AGREE, MEAN_Z2_AGREE, compare, run_ensemble, window_means
from flavorbench.runners import KB, flavor
from flavorbench.systems import SOFT_GROUP, STIFF_GROUP
# A copy is declared blown up once |y| exceeds this (V_stiff would be 1/(4 eps) ~ 1e7 kT) or a coordinate is not finite.
BLOWUP_Y = 0.5

QUANTITIES = {
    # key: (label, function of (x, y, px, py, x0, y0, kT) -> per-copy series)
    "acf_y": ("E[y(t) y(0)]  (Fig. 6.14, dominantly fast)", lambda x, y, px, py, x0, y0, kT: y * y0),
    "acf_s": ("E[(x-y)(t) (x-y)(0)]  (Fig. 6.14, dominantly slow)",
              lambda x, y, px, py, x0, y0, kT: (x - y) * (x0 - y0)),
    "s": ("E[x-y]", lambda x, y, px, py, x0, y0, kT: x - y),
    "y": ("E[y]", lambda x, y, px, py, x0, y0, kT: y),
    "x": ("E[x]", lambda x, y, px, py, x0, y0, kT: x),
    "s2": ("E[(x-y)^2]", lambda x, y, px, py, x0, y0, kT: (x - y) ** 2),
    "y2": ("E[y^2]", lambda x, y, px, py, x0, y0, kT: y * y),
    "px2": ("E[p_x^2] / kT", lambda x, y, px, py, x0, y0, kT: px * px / kT),
    "py2": ("E[p_y^2] / kT", lambda x, y, px, py, x0, y0, kT: py * py / kT),
}


def build_system(n, eps):
    """n copies of the two-particle chain; copy k is particle 2k (y) and 2k+1 (x)."""
    system = mm.System()
    stiff = mm.CustomExternalForce("x^4 / (4*eps)")
    stiff.addGlobalParameter("eps", eps)
    # Only the x coordinates interact: the thermostat also kicks the y and z components, which must stay inert.
    soft = mm.CustomCompoundBondForce(2, "(x2 - x1)^4")
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


def quartic_second_moment(a, beta):
    """<u^2> for the density exp(-beta a u^4)."""
    return (beta * a) ** -0.5 * math.gamma(0.75) / math.gamma(0.25)


def mesoscale_stability(delta, tau, eps, beta):
    """Where the mesostep stops being stable for the stiff quartic spring, and how often H_eff reaches there.

    Averaged over a mesostep, the stiff force acts with weight tau/delta, so y oscillates in (tau/delta) y^4/(4 eps)
    and is integrated with step delta.  Linearised at amplitude A the frequency is A sqrt(3 tau/(delta eps)), and
    symplectic Euler is unstable for delta omega > 2: A_crit = 2/(delta sqrt(3 tau/(delta eps))).  The probability
    of |y| > A_crit is taken under the H_eff Boltzmann density exp(-beta (tau/delta) y^4/(4 eps)).
    """
    a_crit = 2.0 / (delta * math.sqrt(3.0 * tau / (delta * eps)))
    a = beta * (tau / delta) / (4.0 * eps)
    scale = a ** -0.25
    u = np.linspace(0.0, 12.0, 200001) * scale
    density = np.exp(-a * u ** 4)
    tail = ensemble.trapezoid(np.where(u > a_crit, density, 0.0), u) / ensemble.trapezoid(density, u)
    return {"A_crit": a_crit, "beta_V_eff_at_A_crit": a * a_crit ** 4, "P_abs_y_gt_A_crit_H_eff": float(tail),
            "rms_y_H_eff": math.sqrt(quartic_second_moment(a / beta, beta))}


def main():
    parser = reporting.parser(__doc__, "langevin_slow_noise",
                          quick_help="smoke run of a few seconds (n = 8, T = 1)", out_help=None)
    parser.add_argument("--n", type=int, default=None, help="ensemble size (default 100, the paper's; 8 with --quick)")
    parser.add_argument("--T", type=float, default=None, help="simulated time (default 30; 1 with --quick)")
    parser.add_argument("--eps", type=float, default=1e-8)
    parser.add_argument("--c", type=float, default=0.1, help="friction (1/ps)")
    parser.add_argument("--sigma", type=float, default=0.5, help="noise amplitude; k_B T = sigma^2 / (2c)")
    parser.add_argument("--flavor", nargs="+", default=["0.01,0.001", "0.01,0.0001"], metavar="DELTA,TAU",
                        help="FLAVOR runs (default: the paper's delta = 0.01, tau = 0.001, and delta = 0.01, "
                             "tau = 1e-4, which stays stable)")
    parser.add_argument("--h", type=float, default=0.001, help="GLA step (the paper's 0.001)")
    parser.add_argument("--sample", type=float, default=0.01, help="sampling interval")
    parser.add_argument("--window", type=float, default=0.2, help="averaging window for the comparison")
    parser.add_argument("--regime", type=float, default=8.0,
                        help="end of the regime dominated by deterministic dynamics (paper: about t = 8)")
    parser.add_argument("--seed", type=int, default=6819)
    args = parser.parse_args()

    n = args.n if args.n is not None else (8 if args.quick else 100)
    T = args.T if args.T is not None else (1.0 if args.quick else 30.0)
    omega = 1.0 / math.sqrt(args.eps)
    y0 = 2.1 / omega
    x0 = y0 + 1.8
    kT = args.sigma ** 2 / (2 * args.c)
    beta = 1.0 / kT
    temperature = kT / KB
    flavors = [tuple(float(v) for v in spec.split(",")) for spec in args.flavor]
    width = max(1, int(round(args.window / args.sample)))
    late_from = 2.0 * T / 3.0
    system = build_system(n, args.eps)

    print(f"eq. (6.19): n = {n} copies in one System, T = {T:g}, eps = {args.eps:g}, c = {args.c:g}, "
          f"sigma = {args.sigma:g} (kT = {kT:g} kJ/mol, {temperature:.2f} K)", file=sys.stderr)
    runs = {}
    seed = args.seed
    label = f"GLA h={args.h:g}"
    print(f"running {label}: FlavorIntegrator(h, h), SymplecticEuler, friction over the whole step", file=sys.stderr)
    runs["gla"] = run_ensemble(system, flavor(args.h, args.h, "SymplecticEuler", temperature, args.c, seed, False),
                               args.h, n, y0, x0, args.sample, T, label, BLOWUP_Y)
    runs["gla"].update(delta=args.h, tau=args.h)
    for delta, tau in flavors:
        seed += 1
        key = f"flavor_d{delta:g}_t{tau:g}"
        label = f"FLAVOR d={delta:g} t={tau:g}"
        print(f"running {label}: SymplecticEuler, friction over the whole mesostep (eq. 4.7)", file=sys.stderr)
        runs[key] = run_ensemble(system, flavor(delta, tau, "SymplecticEuler", temperature, args.c, seed, False),
                                 delta, n, y0, x0, args.sample, T, label, BLOWUP_Y)
        runs[key].update(delta=delta, tau=tau)

    t = np.arange(int(round(T / args.sample)) + 1) * args.sample
    t_window = (np.arange(window_means(t[:, None], width).shape[0]) + 0.5) * width * args.sample
    stats, used = {}, {}
    for key, run in runs.items():
        stats[key], used[key] = ensemble.series_statistics(
            run, lambda x, y, px, py: {q: f(x, y, px, py, x[0], y[0], kT) for q, (_, f) in QUANTITIES.items()},
            width, t, late_from)

    # Exact Boltzmann values: V = y^4/(4 eps) + s^4 separates in (y, s = x - y).  The Langevin FLAVOR samples
    # H_eff = K + V_soft + (tau/delta) V_stiff, i.e. eps -> eps delta/tau.
    equilibrium = {"true": {"s2": quartic_second_moment(1.0, beta), "y2": quartic_second_moment(0.25 / args.eps, beta),
                            "s": 0.0, "y": 0.0, "x": 0.0, "px2": 1.0, "py2": 1.0}}
    for delta, tau in flavors:
        key = f"flavor_d{delta:g}_t{tau:g}"
        equilibrium[key] = dict(equilibrium["true"], y2=quartic_second_moment(0.25 * tau / (delta * args.eps), beta))

    stability = {key: mesoscale_stability(run["delta"], run["tau"], args.eps, beta) for key, run in runs.items()}

    comparison = {}
    for key in runs:
        if key == "gla":
            continue
        comparison[key] = {q: compare(stats[key][q], stats["gla"][q], t_window, late_from, args.regime,
                                   names=("flavor", "gla"))
                           for q in QUANTITIES}

    gla_wall = runs["gla"]["wall_s"]
    summary = {}
    for key, run in runs.items():
        blown = np.isfinite(run["blown_at"])
        summary[key] = {"label": run["label"], "delta": run["delta"], "tau": run["tau"], "steps": run["steps"],
                        "wall_s": run["wall_s"], "us_per_step": run["us_per_step"],
                        "speedup_vs_gla": gla_wall / run["wall_s"], "copies_used": used[key],
                        "copies_blown_up": int(blown.sum()),
                        "blowup_times": sorted(float(v) for v in run["blown_at"][blown]),
                        "stability": stability[key]}
    print_tables(summary, comparison, stats, equilibrium, late_from, args.regime, T, n)

    data = {
        "scene": "FLAVORS paper section 6.8, eq. (6.19), Figs. 6.14-6.15: Langevin with slow noise and friction",
        "platform": "Reference",
        "openmm_version": mm.__version__,
        "model": {"particles": "copy k: particle 2k = y, 2k+1 = x, unit masses, x axis",
                  "stiff (group 1)": "CustomExternalForce x^4/(4 eps) on y",
                  "soft (group 0)": "CustomCompoundBondForce (x2-x1)^4 on (y, x)",
                  "gla": "FlavorIntegrator(h, h, {1}), SymplecticEuler, friction over the whole step: "
                         "O(h) K_all(h) D(h), the geometric Langevin algorithm",
                  "flavor": "FlavorIntegrator(delta, tau, {1}), SymplecticEuler, setStiffFriction(False): eq. (4.7)"},
        "parameters": {"n": n, "T": T, "eps": args.eps, "omega": omega, "c": args.c, "sigma": args.sigma, "kT": kT,
                       "temperature_K": temperature, "y0": y0, "x0": x0, "p0": 0.0, "h": args.h,
                       "flavor": [list(f) for f in flavors], "sample": args.sample, "window": width * args.sample,
                       "late_from": late_from, "regime_split": args.regime, "seed": args.seed, "quick": args.quick,
                       "verdict": f"agree if mean z^2 over the windows <= {MEAN_Z2_AGREE} and |z| of the late-time "
                                  f"average <= {LATE_Z_AGREE}"},
        "quantities": {k: v[0] for k, v in QUANTITIES.items()},
        "runs": summary,
        "equilibrium": equilibrium,
        "comparison": comparison,
        "series": {"t": t.tolist(), "t_window": t_window.tolist(),
                   **{key: {q: {"mean": s["mean"].tolist(), "se": s["se"].tolist(), "window_mean": s["w_mean"].tolist(),
                                "window_se": s["w_se"].tolist()} for q, s in stats[key].items()} for key in stats}},
    }
    reporting.save_outputs(args.out, "langevin_slow_noise", data,
                       lambda png_path: plot(t, t_window, stats, summary, equilibrium, data["parameters"], png_path))


def print_tables(summary, comparison, stats, equilibrium, late_from, regime, T, n):
    print(f"\neq. (6.19), {n} trajectories, T = {T:g}.  Wall time: integrator.step() only; speedup = GLA wall time / "
          f"wall time.")
    head = f"{'method':28s} {'steps':>7s} {'wall s':>7s} {'us/step':>8s} {'speedup':>8s} {'copies used':>12s} " \
           f"{'blown up':>9s} {'A_crit':>7s} {'rms y':>7s} {'P(|y|>A_crit)':>13s}  first blow-ups (t)"
    print(head)
    print("-" * len(head))
    for s in summary.values():
        first = ", ".join(f"{v:.2f}" for v in s["blowup_times"][:4]) + (" ..." if len(s["blowup_times"]) > 4 else "")
        print(f"{s['label']:28s} {s['steps']:7d} {s['wall_s']:7.2f} {s['us_per_step']:8.1f} "
              f"{s['speedup_vs_gla']:7.1f}x {s['copies_used']:12d} {s['copies_blown_up']:9d} "
              f"{s['stability']['A_crit']:7.4f} {s['stability']['rms_y_H_eff']:7.4f} "
              f"{s['stability']['P_abs_y_gt_A_crit_H_eff']:13.2e}  {first}")
    print("A_crit: amplitude of y above which a step of delta is unstable for the stiff spring (linearised); rms y and "
          "P(|y| > A_crit) under the Boltzmann density of H_eff = K + V_soft + (tau/delta) V_stiff")
    for key, comp in comparison.items():
        print(f"\n{summary[key]['label']} against {summary['gla']['label']} (copies that stayed finite).  Window "
              f"z = (F - G)/sqrt(SE_F^2 + SE_G^2); late = per-copy time average over t >= {late_from:g}, "
              f"mean +- SE; eq = exact Boltzmann value (FLAVOR column: of H_eff).")
        head = f"{'quantity':46s} {'mean z2':>8s} {'t<' + format(regime, 'g'):>7s} {'t>=' + format(regime, 'g'):>7s} " \
               f"{'max|z|':>7s} {'late GLA':>19s} {'late FLAVOR':>19s} {'z':>6s} {'F/G':>6s} {'eq G':>8s} " \
               f"{'eq F':>8s}  verdict"
        print(head)
        print("-" * len(head))
        for q, c in comp.items():
            early = c.get(f"t<{regime:g}", {}).get("mean_z2", float("nan"))
            later = c.get(f"t>={regime:g}", {}).get("mean_z2", float("nan"))
            late = c["late"]
            ratio = f"{late['ratio']:6.2f}" if late["ratio"] is not None else "     -"
            eq_g = equilibrium["true"].get(q)
            eq_f = equilibrium[key].get(q)
            fmt = lambda v: f"{v:8.3g}" if v is not None else "       -"
            print(f"{QUANTITIES[q][0]:46s} {c['all']['mean_z2']:8.2f} {early:7.2f} {later:7.2f} "
                  f"{c['all']['max_abs_z']:7.1f} {late['gla']:10.4g}+-{late['gla_se']:7.2g} "
                  f"{late['flavor']:10.4g}+-{late['flavor_se']:7.2g} {late['z']:6.1f} {ratio} {fmt(eq_g)} "
                  f"{fmt(eq_f)}  {'agree' if c['agree'] else 'DIFFER'}")


TITLES = {"acf_y": "E[y(t) y(0)]  (Fig. 6.14, dominantly fast)", "acf_s": "E[(x−y)(t) (x−y)(0)]  (Fig. 6.14, "
          "dominantly slow)", "s": "E[x − y]", "y": "E[y]", "s2": "E[(x − y)²]", "y2": "E[y²]",
          "px2": "E[p_x²] / kT", "py2": "E[p_y²] / kT"}
UNITS = {"acf_y": "nm²", "acf_s": "nm²", "s": "nm", "y": "nm", "s2": "nm²", "y2": "nm²",
         "px2": "dimensionless (m = 1 amu)", "py2": "dimensionless (m = 1 amu)"}


def plot(t, t_window, stats, summary, equilibrium, params, path):
    """Two charts: path (correlations and means, Figs. 6.14-6.15) and path with _moments (second moments against
    their Boltzmann values)."""
    plt = reporting.pyplot()

    colors = {"gla": "k"}
    palette = ["tab:red", "tab:blue", "tab:green", "tab:purple"]
    colors.update({k: palette[i % len(palette)] for i, k in enumerate(k for k in stats if k != "gla")})
    charts = [(path, "correlations and means", [("acf_y", False), ("acf_s", False), ("s", False), ("y", False)]),
              (path[:-len(".png")] + "_moments.png", "second moments",
               [("s2", False), ("y2", True), ("px2", False), ("py2", False)])]
    for chart_path, what, panels in charts:
        fig, axes = plt.subplots(2, 2, figsize=(14, 9.5))
        fig.suptitle(f"Eq. (6.19), FLAVORS paper Figs. 6.14-6.15, {what}: FLAVOR against GLA = FlavorIntegrator(h, h), "
                     f"{params['n']} trajectories\nε = {params['eps']:g} ps², friction γ (the paper's c) = "
                     f"{params['c']:g} ps⁻¹, σ = {params['sigma']:g}, kT = {params['kT']:g} kJ/mol (dimensionless "
                     f"units: 1 amu, 1 nm, 1 ps)\nlines: means over windows of {params['window']:g} ps, bands: ±2 "
                     f"standard errors" + ("; thin: every sample (first row)" if what.startswith("corr") else
                                          "; dotted: exact Boltzmann values (FLAVOR: of H_eff = K + V_soft + "
                                          "(τ/δ) V_stiff)") +
                     "\nFLAVOR statistics use the copies that did not blow up", fontsize=10)
        for ax, (q, logy) in zip(axes.flat, panels):
            for key, s in stats.items():
                lab = f"{reporting.greek(summary[key]['label'])} ({summary[key]['copies_used']} copies)"
                if q.startswith("acf"):
                    ax.plot(t, s[q]["mean"], color=colors[key], lw=0.4, alpha=0.5)
                ax.plot(t_window, s[q]["w_mean"], color=colors[key], lw=1.2, label=lab)
                ax.fill_between(t_window, s[q]["w_mean"] - 2 * s[q]["w_se"], s[q]["w_mean"] + 2 * s[q]["w_se"],
                                color=colors[key], alpha=0.2, lw=0)
                eq = equilibrium["true" if key == "gla" else key].get(q)
                if eq is not None and q in ("s2", "y2", "px2", "py2"):
                    ax.axhline(eq, color=colors[key], ls=":", lw=1)
            ax.set_title(TITLES.get(q, QUANTITIES[q][0]))
            ax.set_xlabel("t (ps)")
            ax.set_ylabel(f"{TITLES.get(q, q).split('  ')[0]} ({UNITS[q]})" if q in UNITS else "")
            if logy:
                ax.set_yscale("log")
        # One legend below the panels: inside, it hid the curves.
        fig.legend(*axes.flat[0].get_legend_handles_labels(), loc="lower center", ncol=3, fontsize=9, frameon=False)
        fig.tight_layout(rect=(0, 0.05, 1, 1))
        reporting.save_figure(fig, chart_path, 100)


if __name__ == "__main__":
    main()
