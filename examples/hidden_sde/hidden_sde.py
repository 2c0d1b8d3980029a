#!/usr/bin/env python3
"""The nonautonomous SDE with a hidden slow variable (FLAVORS paper §6.7, eqs. 6.16-6.18, Fig. 6.13): the nonintrusive
FLAVOR (3.7) against Euler-Maruyama at the fine step, ensembles of 100 paths.

    (6.16)  du = g dt - (1/eps) q dt - sqrt(2/eps) dW,   dv = g dt + (1/eps) q dt + sqrt(2/eps) dW,
            g = 4/(3 (u+v)^2) (-((v-u)/2)^2/2 + 5 sin(2 pi t)),   q = ((u+v)/2)^3 + c - (v-u)/2
    (6.17)  x = ((u+v)/2)^3 + c (slow, hidden),  y = (v-u)/2 (fast)
    (6.18)  dx = (-y^2/2 + 5 sin(2 pi t)) dt,  dy = (1/eps)(x - y) dt + sqrt(2/eps) dW   ((6.16) in x, y)

The paper prints (6.18) with 5 sin(2 pi t) dW on x; (6.16) gives a drift there (the noises of u and v cancel in
u + v), so the scene integrates the drift and runs the printed form once to show what it does.  The paper's
parameters: eps = 1e-4, c = 10, x(0) = 1 + eps, y(0) = 1, T = 2, 100 paths, FLAVOR delta = 0.01, Euler-Maruyama
h = 1e-4; the FLAVOR's tau is not stated: tau = h = 1e-4 (its 100x acceleration is delta/tau).  Also run, because
h = tau = eps does not resolve the fast process (Euler-Maruyama's stationary variance of y is 2/(2 - h/eps) = 2, not
1): Euler-Maruyama at h = eps/10 and FLAVOR at tau = eps/10.  As eps -> 0 and at fixed Var y = v, E x follows the
averaged equation X' = -(X^2 + v)/2 + 5 sin(2 pi t) (solved here with SciPy), v = 1 for the SDE itself.  Units are
the paper's: dimensionless.

    PYTHONPATH=build/python .venv/bin/python examples/hidden_sde/hidden_sde.py [--quick] [--out DIR] [--docs DIR]

Outputs: DIR/hidden_sde.json and DIR/hidden_sde.png (default DIR results/hidden_sde); --docs DIR also writes a small
copy of the chart there.  The loops run in C++ (the program hidden_sde built with the project, one call per run);
speedups are ratios of processor times of whole ensembles (the fastest of --repeat runs; wall times in the JSON).
"""
import math
import sys

import numpy as np
from scipy.integrate import solve_ivp

from flavorbench import firstorder, reporting
from flavorbench.progress import Progress

NAME = "hidden_sde"


def runs_of(args):
    """key: (system, delta, tau, label)."""
    h, fine = args.h, args.eps / 10
    return {
        "flavor": ("hidden", args.delta, h, "FLAVOR (6.16)"),
        "euler": ("hidden", h, h, "Euler–Maruyama (6.16)"),
        "euler_slowfast": ("slowfast", h, h, "Euler–Maruyama (6.18)"),
        "euler_printed": ("printed", h, h, "Euler–Maruyama (6.18) as printed"),
        "flavor_resolved": ("hidden", args.delta, fine, "FLAVOR (6.16)"),
        "euler_resolved": ("hidden", fine, fine, "Euler–Maruyama (6.16)"),
    }


def averaged(T, variance, samples):
    """E x of the averaged equation X' = -(X^2 + variance)/2 + 5 sin(2 pi t), X(0) = 1, at `samples` times."""
    t = np.linspace(0, T, samples)
    sol = solve_ivp(lambda s, X: [-(X[0] ** 2 + variance) / 2 + 5 * math.sin(2 * math.pi * s)], (0, T), [1.0],
                    t_eval=t, rtol=1e-11, atol=1e-12)
    return {"variance_y": variance, "t": t.tolist(), "x": sol.y[0].tolist()}


def compare(a, b):
    """E x of run a against run b at their common times: the largest |difference| and that in combined standard
    errors, and both at T."""
    ta, tb = np.round(np.array(a["t"]), 9), np.round(np.array(b["t"]), 9)
    common, ia, ib = np.intersect1d(ta, tb, return_indices=True)
    d = np.array(a["mean_x"], dtype=float)[ia] - np.array(b["mean_x"], dtype=float)[ib]
    se = np.hypot(np.array(a["se_x"], dtype=float)[ia], np.array(b["se_x"], dtype=float)[ib])
    z = np.where(se > 0, np.abs(d) / np.where(se > 0, se, 1), 0.0)
    return {"max_abs": float(np.max(np.abs(d))), "max_in_se": float(np.max(z)), "at_T": float(d[-1]),
            "at_T_in_se": float(z[-1]), "common_times": int(common.size)}


def against_curve(run, curve):
    """E x of a run against a curve (interpolated at the run's times): largest |difference| and that at T."""
    t, x = np.array(run["t"]), np.array(run["mean_x"], dtype=float)
    d = x - np.interp(t, curve["t"], curve["x"])
    return {"max_abs": float(np.max(np.abs(d))), "at_T": float(d[-1]), "at_T_in_se": float(d[-1] / run["se_x"][-1])}


def measure(args):
    runs_spec = runs_of(args)
    progress = Progress(NAME, len(runs_spec))
    runs = {}
    for key, (system, delta, tau, label) in runs_spec.items():
        run = firstorder.run(NAME, system=system, eps=args.eps, c=args.c, delta=delta, tau=tau, T=args.T,
                             paths=args.paths, samples=args.samples, seed=args.seed, repeat=args.repeat)
        run.update(label=label, delta=delta, tau=tau)
        runs[key] = run
        progress.step(f"{label}, δ = {delta:g}, τ = {tau:g}: {run['cpu_s']:.3g} s, E x(T) = {run['mean_x'][-1]}")
    h, fine = args.h, args.eps / 10
    limits = {"exact": averaged(args.T, 1.0, 401),
              "euler_h": averaged(args.T, 2 / (2 - h / args.eps), 401),
              "euler_fine": averaged(args.T, 2 / (2 - fine / args.eps), 401)}
    comparisons = {
        "flavor_vs_euler": compare(runs["flavor"], runs["euler"]),
        "euler_slowfast_vs_euler": compare(runs["euler_slowfast"], runs["euler"]),
        "flavor_resolved_vs_euler_resolved": compare(runs["flavor_resolved"], runs["euler_resolved"]),
        "euler_vs_its_averaged_limit": against_curve(runs["euler"], limits["euler_h"]),
        "euler_vs_exact_limit": against_curve(runs["euler"], limits["exact"]),
        "euler_resolved_vs_exact_limit": against_curve(runs["euler_resolved"], limits["exact"]),
        "flavor_resolved_vs_exact_limit": against_curve(runs["flavor_resolved"], limits["exact"]),
    }
    speedups = {"paper": {"cpu": runs["euler"]["cpu_s"] / runs["flavor"]["cpu_s"],
                          "wall": runs["euler"]["wall_s"] / runs["flavor"]["wall_s"],
                          "steps": runs["euler"]["steps"] / runs["flavor"]["steps"]},
                "resolved": {"cpu": runs["euler_resolved"]["cpu_s"] / runs["flavor_resolved"]["cpu_s"],
                             "wall": runs["euler_resolved"]["wall_s"] / runs["flavor_resolved"]["wall_s"],
                             "steps": runs["euler_resolved"]["steps"] / runs["flavor_resolved"]["steps"]}}
    printed = runs["euler_printed"]
    return {"scene": NAME, "command": " ".join(sys.argv),
            "parameters": {"eps": args.eps, "c": args.c, "T": args.T, "h": h, "h_resolved": fine,
                           "delta": args.delta, "paths": args.paths, "seed": args.seed, "x0": 1 + args.eps, "y0": 1.0,
                           "units": "dimensionless (the paper's)"},
            "runs": runs, "averaged": limits, "comparisons": comparisons, "speedups": speedups,
            "printed_6_18": {"first_blowup_t": printed["blowup_t"], "finite_paths_at_T": printed["finite"][-1]}}


STYLE = {"euler": dict(color="k", lw=2.2), "flavor": dict(color="tab:blue", lw=1.3, ls="--"),
         "euler_slowfast": dict(color="tab:green", lw=1.0, ls="-."),
         "euler_resolved": dict(color="k", lw=2.2), "flavor_resolved": dict(color="tab:orange", lw=1.3, ls="--")}


def plot(data, path, small=False):
    plt = reporting.pyplot()
    p, runs, limits, cmp, sp = (data["parameters"], data["runs"], data["averaged"], data["comparisons"],
                                data["speedups"])
    fig, axes = plt.subplots(1, 3, figsize=(16, 5.4), gridspec_kw={"width_ratios": [1.25, 1.25, 0.8]})

    def band(ax, key):
        run = runs[key]
        t, m = np.array(run["t"]), np.array(run["mean_x"], dtype=float)
        se = np.array(run["se_x"], dtype=float)
        label = (f"{run['label']}, h = {run['delta']:g}" if key.startswith("euler") else
                 f"{run['label']}, δ = {run['delta']:g}, τ = {run['tau']:g}")
        line, = ax.plot(t, m, label=label, **STYLE[key])
        ax.fill_between(t, m - 2 * se, m + 2 * se, color=line.get_color(), alpha=0.15, lw=0)

    def limit(ax, key, color, text):
        ax.plot(limits[key]["t"], limits[key]["x"], color=color, lw=1.0, ls=":", label=text)

    eps = p["eps"]
    for key in ("euler", "flavor", "euler_slowfast"):
        band(axes[0], key)
    limit(axes[0], "euler_h", "tab:purple", f"averaged, Var y = 2/(2 − h/ε) = {limits['euler_h']['variance_y']:.3g}")
    limit(axes[0], "exact", "tab:red", "averaged, Var y = 1 (ε → 0)")
    axes[0].set_title(f"(a) the paper's steps: h = τ = {p['h']:g} = {p['h'] / eps:g} ε")
    for key in ("euler_resolved", "flavor_resolved"):
        band(axes[1], key)
    limit(axes[1], "euler_fine", "tab:purple",
          f"averaged, Var y = 2/(2 − h/ε) = {limits['euler_fine']['variance_y']:.3g}")
    limit(axes[1], "exact", "tab:red", "averaged, Var y = 1 (ε → 0)")
    axes[1].set_title(f"(b) resolved: h = τ = {p['h_resolved']:g} = ε/10")
    for ax in axes[:2]:
        ax.set_xlabel("t (dimensionless)")
        ax.set_ylabel("E x (dimensionless), bands ±2 standard errors")
        ax.legend(fontsize=8, loc="lower left")
    printed = runs["euler_printed"]
    axes[2].plot(printed["t"], printed["finite"], color="tab:brown", lw=1.5)
    axes[2].set_ylim(0, p["paths"] * 1.05)
    axes[2].set_xlabel(f"t (dimensionless); Euler–Maruyama, h = {p['h']:g}")
    axes[2].set_ylabel(f"paths with |x| < 10⁶ (of {p['paths']})")
    axes[2].set_title("(c) (6.18) as printed (5 sin(2πt) dW)")
    fc = cmp["flavor_vs_euler"]
    fr = cmp["flavor_resolved_vs_euler_resolved"]
    fig.suptitle(
        f"Nonautonomous hidden SDE (6.16), ε = {eps:g}, {p['paths']} paths: FLAVOR (δ = {p['delta']:g}) gives "
        f"Euler–Maruyama's E x within {fc['max_in_se']:.1f} standard errors at the paper's τ = h "
        f"({sp['paper']['cpu']:.0f}× faster) and {fr['max_in_se']:.1f} at τ = h = ε/10 ({sp['resolved']['cpu']:.0f}× "
        f"faster);\n"
        f"but at the paper's h = ε both are off the ε → 0 limit by {cmp['euler_vs_exact_limit']['at_T']:+.2f} at "
        f"T = {p['T']:g} (resolved Euler–Maruyama: {cmp['euler_resolved_vs_exact_limit']['at_T']:+.2f})",
        fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.93))
    reporting.save_figure(fig, path, 70 if small else 110, small=small)


def report(data):
    rows = []
    for key, run in data["runs"].items():
        rows.append([run["label"], f"{run['delta']:g}", f"{run['tau']:g}", run["steps"], run["cpu_s"],
                     run["mean_x"][-1] if run["mean_x"][-1] is not None else float("nan"),
                     run["se_x"][-1] if run["se_x"][-1] is not None else float("nan"), int(run["finite"][-1])])
    reporting.table(f"Hidden SDE, T = {data['parameters']['T']:g} (E x, its standard error, paths still finite)",
                    [("run", 34, "s"), ("delta", 7, "s"), ("tau", 7, "s"), ("steps", 8, ".3g"), ("cpu s", 8, ".3g"),
                     ("E x(T)", 9, ".4f"), ("SE", 7, ".4f"), ("finite", 6, "d")], rows)
    for name, curve in data["averaged"].items():
        print(f"averaged equation, Var y = {curve['variance_y']:.4g}: X(T) = {curve['x'][-1]:.4f}")
    for name, c in data["comparisons"].items():
        print(f"{name}: " + ", ".join(f"{k} {v:.3g}" for k, v in c.items()))
    for name, s in data["speedups"].items():
        print(f"speedup ({name}): processor time {s['cpu']:.1f}x, wall {s['wall']:.1f}x, steps {s['steps']:.0f}x")
    print(f"(6.18) as printed: first path escaped at t = {data['printed_6_18']['first_blowup_t']}, "
          f"{data['printed_6_18']['finite_paths_at_T']:.0f} paths finite at T")


def main():
    parser = reporting.parser(__doc__, NAME, quick_help="smoke run of a few seconds (T = 0.5, 20 paths)")
    parser.add_argument("--eps", type=float, default=1e-4)
    parser.add_argument("--c", type=float, default=10.0)
    parser.add_argument("--T", type=float, default=None, help="end time (default 2, --quick 0.5)")
    parser.add_argument("--h", type=float, default=1e-4, help="Euler-Maruyama's step and the FLAVOR's tau")
    parser.add_argument("--delta", type=float, default=0.01)
    parser.add_argument("--paths", type=int, default=None, help="paths per ensemble (default 100, --quick 20)")
    parser.add_argument("--samples", type=int, default=200, help="sampled times per run")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--repeat", type=int, default=None, help="timed repetitions (default 3, --quick 1)")
    firstorder.add_chart_arguments(parser)
    args = parser.parse_args()
    if firstorder.replot(args, NAME, plot):
        return
    args.T = args.T if args.T is not None else (0.5 if args.quick else 2.0)
    args.paths = args.paths if args.paths is not None else (20 if args.quick else 100)
    args.repeat = args.repeat if args.repeat is not None else (1 if args.quick else 3)
    if args.quick:
        args.samples = min(args.samples, 50)
    data = measure(args)
    report(data)
    firstorder.save(args, NAME, data, plot)


if __name__ == "__main__":
    main()
