#!/usr/bin/env python3
"""The hidden Van der Pol oscillator (FLAVORS paper §6.1, eqs. 6.1/6.2, Fig. 6.1): the nonintrusive FLAVOR (1.34)
against forward Euler at the fine step, on the Cartesian system (6.2) and on its polar form (6.1), where the slow and
fast variables are hidden.

    (6.2)  x' = -eps y,   y' = (1/eps) (x + y - y^3/3)          (x slow, y fast; a Van der Pol relaxation oscillator)
    (6.1)  the same in r, theta with x = r sin(theta), y = r cos(theta)

The stiffness parameter 1/eps is switched on for tau and off for delta - tau in each mesostep; the legacy integrator is
forward Euler.  The paper's parameters: eps = 1e-3, x(0) = y(0) = 1, T = 5/eps, forward Euler h = 0.05 eps = 5e-5,
FLAVOR delta = 0.01, tau = 5e-5 (a 200x acceleration claimed).  The loops run in C++ (the program van_der_pol built
with the project, one call per run); a reference solution comes from SciPy's Radau (rtol 1e-10).  Units are the
paper's: dimensionless.

    PYTHONPATH=build/python .venv/bin/python examples/van_der_pol/van_der_pol.py [--quick] [--out DIR] [--docs DIR]

Outputs: DIR/van_der_pol.json and DIR/van_der_pol.png (default DIR results/van_der_pol); --docs DIR also writes a
small copy of the chart there (docs/van_der_pol.png comes from the full run).  Speedups are ratios of the processor
time of the C++ loops (one thread; the wall times are in the JSON too).
"""
import math
import sys

import numpy as np
from scipy.integrate import solve_ivp

from flavorbench import firstorder, reporting
from flavorbench.progress import Progress

NAME = "van_der_pol"
RUNS = {  # key: (system, label)
    "euler_cartesian": ("cartesian", "forward Euler (6.2)"),
    "flavor_cartesian": ("cartesian", "FLAVOR (6.2)"),
    "euler_polar": ("polar", "forward Euler (6.1)"),
    "flavor_polar": ("polar", "FLAVOR (6.1), hidden"),
}


def reference(eps, T, x0, y0):
    """(6.2) by Radau with its exact Jacobian: a dense solution."""
    def f(t, u):
        return [-eps * u[1], (u[0] + u[1] - u[1] ** 3 / 3) / eps]

    def jacobian(t, u):
        return [[0.0, -eps], [1 / eps, (1 - u[1] ** 2) / eps]]
    return solve_ivp(f, (0, T), [x0, y0], method="Radau", jac=jacobian, rtol=1e-10, atol=1e-12, dense_output=True)


def jumps(t, y):
    """The times where y jumps from the lower to the upper branch (crosses 0 upwards), linearly interpolated."""
    t, y = np.asarray(t), np.asarray(y)
    up = np.nonzero((y[:-1] < 0) & (y[1:] >= 0))[0]
    return t[up] - y[up] * (t[up + 1] - t[up]) / (y[up + 1] - y[up])


def period(t, y):
    """The mean time between upward jumps (None with fewer than two)."""
    times = jumps(t, y)
    return float(np.mean(np.diff(times))) if len(times) >= 2 else None


def measure(args):
    eps, T, h, delta, tau = args.eps, args.T, args.h, args.delta, args.tau
    progress = Progress(NAME, len(RUNS) + 1)
    runs = {}
    for key, (system, label) in RUNS.items():
        step, micro = (h, h) if key.startswith("euler") else (delta, tau)
        run = firstorder.run(NAME, system=system, eps=eps, delta=step, tau=micro, T=T, samples=args.samples,
                             x0=args.x0, y0=args.y0)
        run.update(label=label, delta=step, tau=micro)
        runs[key] = run
        progress.step(f"{label}: {run['steps']:.3g} steps, {run['cpu_s']:.3g} s")
    ref = reference(eps, T, args.x0, args.y0)
    progress.step(f"Radau reference: {ref.t.size} steps")
    tt = np.linspace(0, T, 20 * args.samples + 1)
    ref_period = period(tt, ref.sol(tt)[1])
    errors = {}
    for key, run in runs.items():
        t = np.array(run["t"])
        exact = ref.sol(t)
        p = period(t, run["y"])
        errors[key] = {
            "max_abs_x": float(np.max(np.abs(np.array(run["x"]) - exact[0]))),
            "x_at_T": run["x"][-1], "y_at_T": run["y"][-1],
            "period": p,
            "period_rel_error": (p / ref_period - 1) if (p and ref_period) else None,
            "first_jump": float(jumps(t, run["y"])[0]) if len(jumps(t, run["y"])) else None,
        }
    for system in ("cartesian", "polar"):
        euler, flavor = runs[f"euler_{system}"], runs[f"flavor_{system}"]
        errors[f"flavor_{system}"]["speedup_cpu"] = euler["cpu_s"] / flavor["cpu_s"]
        errors[f"flavor_{system}"]["speedup_wall"] = euler["wall_s"] / flavor["wall_s"]
        errors[f"flavor_{system}"]["step_ratio"] = euler["steps"] / flavor["steps"]
    mu = 1 / eps
    first_jumps = jumps(tt, ref.sol(tt)[1])
    return {
        "scene": NAME, "command": " ".join(sys.argv),
        "parameters": {"eps": eps, "T": T, "h": h, "delta": delta, "tau": tau, "x0": args.x0, "y0": args.y0,
                       "units": "dimensionless (the paper's)"},
        "reference": {"method": "scipy Radau rtol 1e-10 atol 1e-12", "steps": int(ref.t.size), "period": ref_period,
                      "first_jump": float(first_jumps[0]) if len(first_jumps) else None,
                      "x_at_T": float(ref.y[0, -1]), "y_at_T": float(ref.y[1, -1]),
                      "t": tt[::20].tolist(), "x": ref.sol(tt[::20])[0].tolist(),
                      "y": ref.sol(tt[::20])[1].tolist()},
        # The relaxation period of y'' + y = mu (1 - y^2) y' for large mu: (3 - 2 ln 2) mu + 3 * 2.338 mu^(-1/3)
        # (Dorodnitsyn's expansion, first two terms).
        "asymptotic_period": (3 - 2 * math.log(2)) * mu + 3 * 2.338107 * mu ** (-1 / 3),
        "runs": runs, "errors": errors,
    }


STYLE = {"euler_cartesian": dict(color="0.55", lw=3.0, ls="-"),
         "flavor_cartesian": dict(color="tab:blue", lw=1.3, ls="--"),
         "euler_polar": dict(color="tab:green", lw=1.0, ls="-."),
         "flavor_polar": dict(color="tab:orange", lw=1.3, ls=":")}


def plot(data, path, small=False):
    plt = reporting.pyplot()
    p, runs, errors, ref = data["parameters"], data["runs"], data["errors"], data["reference"]
    fig, axes = plt.subplots(1, 3, figsize=(16, 5.2), gridspec_kw={"width_ratios": [1.3, 1.3, 1]})
    for key, run in runs.items():
        d = run["delta"]
        label = (f"{run['label']}, h = {d:g}" if key.startswith("euler") else
                 f"{run['label']}, δ = {d:g}, τ = {run['tau']:g}")
        axes[0].plot(run["t"], run["x"], label=label, **STYLE[key])
        axes[1].plot(run["t"], run["y"], **STYLE[key])
        axes[2].plot(run["x"], run["y"], **STYLE[key])
    for ax, name in ((axes[0], "x"), (axes[1], "y")):
        ax.plot(ref["t"], ref[name], color="k", lw=0.6, label="reference (Radau, rtol 1e-10)")
        ax.set_xlabel("t (dimensionless)")
        ax.set_ylabel(f"{name} (dimensionless)")
    axes[2].plot(ref["x"], ref["y"], color="k", lw=0.6)
    axes[2].set_xlabel("x (dimensionless)")
    axes[2].set_ylabel("y (dimensionless)")
    axes[0].set_title("(a) slow variable x")
    axes[1].set_title("(b) fast variable y")
    axes[2].set_title("(c) phase plane")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=5, fontsize=9, frameon=False)
    fc, fp = errors["flavor_cartesian"], errors["flavor_polar"]

    def rel(e):
        return "n/a" if e["period_rel_error"] is None else f"{100 * e['period_rel_error']:+.2f} %"
    fig.suptitle(f"Hidden Van der Pol, ε = {p['eps']:g}, T = {p['T']:g}: FLAVOR (δ = {p['delta']:g}, τ = {p['tau']:g}) "
                 f"follows the relaxation oscillation {fc['speedup_cpu']:.0f}× (6.2) and {fp['speedup_cpu']:.0f}× "
                 f"(6.1) faster than forward Euler (h = {p['h']:g});\nperiod error {rel(fc)} (6.2), {rel(fp)} (6.1); "
                 f"forward Euler {rel(errors['euler_cartesian'])} (6.2), {rel(errors['euler_polar'])} (6.1)",
                 fontsize=11)
    fig.tight_layout(rect=(0, 0.07, 1, 0.93))
    reporting.save_figure(fig, path, 70 if small else 110, small=small)


def report(data):
    errors = data["errors"]
    rows = []
    for key, run in data["runs"].items():
        e = errors[key]
        rows.append([run["label"], f"{run['delta']:g}", f"{run['tau']:g}", run["steps"], run["cpu_s"],
                     e.get("speedup_cpu", 1.0), e["max_abs_x"],
                     "-" if e["period"] is None else f"{e['period']:.1f}",
                     "-" if e["period_rel_error"] is None else f"{100 * e['period_rel_error']:+.2f}"])
    ref = data["reference"]
    rows.append(["reference (Radau)", "-", "-", ref["steps"], float("nan"), float("nan"), 0.0,
                 "-" if ref["period"] is None else f"{ref['period']:.1f}", "0"])
    reporting.table(f"Hidden Van der Pol (asymptotic period {data['asymptotic_period']:.1f})",
                    [("run", 24, "s"), ("delta", 8, "s"), ("tau", 8, "s"), ("steps", 10, ".3g"),
                     ("cpu s", 8, ".3g"), ("speedup", 8, ".1f"), ("max|x err|", 11, ".3g"), ("period", 8, "s"),
                     ("err %", 7, "s")], rows)


def main():
    parser = reporting.parser(__doc__, NAME, quick_help="smoke run of a few seconds (T = 500 instead of 5000)")
    parser.add_argument("--eps", type=float, default=1e-3)
    parser.add_argument("--T", type=float, default=None, help="end time (default 5/eps, --quick 0.5/eps)")
    parser.add_argument("--h", type=float, default=5e-5, help="forward Euler's step")
    parser.add_argument("--delta", type=float, default=0.01)
    parser.add_argument("--tau", type=float, default=5e-5)
    parser.add_argument("--x0", type=float, default=1.0)
    parser.add_argument("--y0", type=float, default=1.0)
    parser.add_argument("--samples", type=int, default=5000, help="samples per run")
    firstorder.add_chart_arguments(parser)
    args = parser.parse_args()
    if firstorder.replot(args, NAME, plot):
        return
    if args.T is None:
        args.T = (0.5 if args.quick else 5.0) / args.eps
    if args.quick:
        args.samples = min(args.samples, 1000)
    data = measure(args)
    report(data)
    firstorder.save(args, NAME, data, plot)


if __name__ == "__main__":
    main()
