#!/usr/bin/env python3
"""Stability domains of the nonintrusive and the artificial FLAVOR on system (5.1) (FLAVORS paper, Fig. 5.1(a) and
(b), Theorem 5.1), found by running FlavorIntegrator; with --errors their errors (Fig. 5.2).

    H = p_x^2/2 + p_y^2/2 + x^2/2 + omega^2/2 (y - x)^2,   omega = 1/sqrt(eps) = 1000

x is particle 0 (soft potential x^2/2, force group 0) and y particle 1 (a HarmonicBondForce of length 0 and
constant omega^2, force group 1, stiff); both move along x only.  For each mesostep delta and microstep tau (given
as tau/eps), the SymplecticEuler FlavorIntegrator runs --steps mesosteps from x = 0.8, y = x + 1.1/omega at rest;
the run counts as stable when |x| and |y| stay below 100.  Beside each domain: the boundaries of Theorem 5.1 for
tau -> 0 (delta = 2 nonintrusive, delta = 2 sqrt(2) artificial), the artificial FLAVOR's fast-stability line
tau = sqrt(2 eps) (symplectic Euler on the stiff mode of frequency sqrt(2) omega needs tau sqrt(2) omega <= 2), and
the spectral radius of the one-step matrix computed here with NumPy, eq. (5.5) for the artificial FLAVOR.

    PYTHONPATH=build/python .venv/bin/python examples/stability_5_1/stability_5_1.py [--quick] [--out DIR]

Outputs: DIR/stability_5_1.json and DIR/stability_5_1.png.

With --errors, Fig. 5.2 instead: the error of both FLAVORs at T = 10 against the exact solution of (5.1) (its two
normal modes, computed here), as a function of delta and tau/eps; the optimal tau/eps for each delta and the error
there; the error against tau/eps at fixed delta.  Outputs DIR/errors_5_2.json and DIR/errors_5_2.png.
"""
import argparse
import json
import math
import os
import warnings

import numpy as np
import openmm as mm

import openmmflavors
from flavorbench import reporting

# System (5.1) is in reduced units: mesosteps of order 1 are meant as they are.
warnings.filterwarnings("ignore", category=openmmflavors.UnitlessStepWarning)

OMEGA = 1000.0
EPS = 1 / OMEGA ** 2
BOUND = 100.0


def make_system():
    system = mm.System()
    system.addParticle(1.0)
    system.addParticle(1.0)
    soft = mm.CustomExternalForce("0.5*x^2")
    soft.addParticle(0, [])
    soft.setForceGroup(0)
    stiff = mm.HarmonicBondForce()
    stiff.addBond(0, 1, 0.0, OMEGA ** 2)
    stiff.setForceGroup(1)
    system.addForce(soft)
    system.addForce(stiff)
    return system


def flavor_context(system, platform, averaging, delta, tau):
    """A SymplecticEuler FlavorIntegrator and its Context at the start x = 0.8, y = x + 1.1/omega, at rest."""
    integrator = openmmflavors.FlavorIntegrator(delta, tau, {1})
    integrator.setScheme(openmmflavors.FlavorIntegrator.SymplecticEuler)
    integrator.setAveraging(averaging)
    context = mm.Context(system, integrator, platform)
    context.setPositions([mm.Vec3(0.8, 0, 0), mm.Vec3(0.8 + 1.1 / OMEGA, 0, 0)])
    return integrator, context


def run_stable(system, platform, averaging, delta, tau, steps):
    integrator, context = flavor_context(system, platform, averaging, delta, tau)
    done = 0
    while done < steps:
        integrator.step(min(50, steps - done))
        done += 50
        x = context.getState(getPositions=True).getPositions(asNumpy=True)._value[:, 0]
        if not np.all(np.isfinite(x)) or np.max(np.abs(x)) > BOUND:
            return False
    return True


def positions_after(system, platform, averaging, delta, tau, T):
    """(x, y) after round(T / delta) SymplecticEuler mesosteps from the start of run_stable, or None if unstable."""
    integrator, context = flavor_context(system, platform, averaging, delta, tau)
    integrator.step(int(round(T / delta)))
    x = context.getState(getPositions=True).getPositions(asNumpy=True)._value[:, 0]
    return x if np.all(np.isfinite(x)) and np.max(np.abs(x)) < BOUND else None


def exact_positions(t):
    """(x, y) at time t: (5.1) is linear, q'' = -K q with K = [[1 + w^2, -w^2], [-w^2, w^2]] on (x, y)."""
    k = np.array([[1 + OMEGA ** 2, -OMEGA ** 2], [-OMEGA ** 2, OMEGA ** 2]])
    values, vectors = np.linalg.eigh(k)
    frequencies = np.sqrt(values)
    q0 = np.array([0.8, 0.8 + 1.1 / OMEGA])
    return vectors @ (np.cos(frequencies * t) * (vectors.T @ q0))


def errors_5_2(args):
    T = 10.0
    deltas = np.logspace(-2, 0, 5) if args.quick else np.logspace(-3, 0, 13)
    ratios = np.logspace(-1, 3, 5) if args.quick else np.logspace(-1, 3, 17)  # tau / eps
    system = make_system()
    platform = mm.Platform.getPlatformByName("Reference")
    exact = exact_positions(T)
    result = {"omega": OMEGA, "T": T, "delta": list(deltas), "tau_over_eps": list(ratios),
              "error": "Euclidean norm of (x, y) - exact at T", "averagings": {}}
    for name, averaging in (("Nonintrusive", openmmflavors.FlavorIntegrator.Nonintrusive),
                            ("Artificial", openmmflavors.FlavorIntegrator.Artificial)):
        error = np.full((len(ratios), len(deltas)), np.nan)  # NaN: tau > delta or unstable
        for i, ratio in enumerate(ratios):
            for j, delta in enumerate(deltas):
                if ratio * EPS <= delta:
                    q = positions_after(system, platform, averaging, delta, ratio * EPS, T)
                    if q is not None:
                        error[i, j] = float(np.linalg.norm(q - exact))
        best = [int(np.nanargmin(error[:, j])) if np.any(np.isfinite(error[:, j])) else -1 for j in range(len(deltas))]
        result["averagings"][name] = {
            "error": [[None if np.isnan(e) else e for e in row] for row in error],
            "optimal_tau_over_eps": [float(ratios[b]) if b >= 0 else None for b in best],
            "optimal_error": [float(error[b, j]) if b >= 0 else None for j, b in enumerate(best)]}
        print("%-13s optimal tau/eps by delta: %s; error there: %s" % (
            name, ", ".join("%.3g" % ratios[b] if b >= 0 else "-" for b in best),
            ", ".join("%.2g" % error[b, j] if b >= 0 else "-" for j, b in enumerate(best))))
    reporting.save_outputs(args.out, "errors_5_2", result, lambda path: plot_errors(result, path))


def plot_errors(result, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm
    deltas, ratios = np.array(result["delta"]), np.array(result["tau_over_eps"])
    fig, axes = plt.subplots(3, 2, figsize=(12, 14))
    for col, name in enumerate(("Nonintrusive", "Artificial")):
        data = result["averagings"][name]
        error = np.array([[np.nan if e is None else e for e in row] for row in data["error"]])
        ax = axes[0, col]
        mesh = ax.pcolormesh(deltas, ratios, error, norm=LogNorm(vmin=1e-6, vmax=1), shading="nearest")
        fig.colorbar(mesh, ax=ax, label="error |(x, y) − exact| at T = %g (reduced units)" % result["T"])
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("mesostep δ")
        ax.set_ylabel("τ/ε")
        ax.set_title("(%s) %s FLAVOR: error (white: τ > δ or unstable)" % ("ab"[col], name))
        ax = axes[1, col]
        ax.loglog(deltas, [np.nan if v is None else v for v in data["optimal_tau_over_eps"]], "o-",
                  label="optimal τ/ε")
        ax.loglog(deltas, [np.nan if v is None else v for v in data["optimal_error"]], "s-", label="error there")
        ax.set_xlabel("mesostep δ")
        ax.set_ylabel("optimal τ/ε (circles); error at T = %g (squares)" % result["T"])
        ax.set_title("(%s) %s FLAVOR: optimal τ/ε and its error" % ("cd"[col], name))
        ax.legend(fontsize=8)
        ax = axes[2, col]
        for j in range(0, len(deltas), max(1, len(deltas) // 4)):
            ax.loglog(ratios, error[:, j], "o-", ms=3, label="δ = %.3g" % deltas[j])
        ax.set_xlabel("τ/ε")
        ax.set_ylabel("error |(x, y) − exact| at T = %g" % result["T"])
        ax.set_title("(%s) %s FLAVOR: error against τ/ε at fixed δ" % ("ef"[col], name))
        ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=3)
    fig.suptitle("Errors of the SymplecticEuler FLAVORs on system (5.1), ω = %g, against its exact solution "
                 "(FLAVORS paper, Fig. 5.2)" % result["omega"])
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    reporting.save_figure(fig, path, dpi=90)


def one_step_matrix(artificial, delta, tau):
    """The one-step map on (y, x, p_y, p_x), composed from the flows (rightmost acts first)."""
    def kick(h, soft, stiff):
        m = np.eye(4)
        k = h * OMEGA ** 2 * stiff
        m[2, 0] += -k
        m[2, 1] += k
        m[3, 0] += k
        m[3, 1] += -k - h * soft
        return m

    def drift(h):
        m = np.eye(4)
        m[0, 2] = m[1, 3] = h
        return m

    if artificial:  # eq. (5.5)
        frozen = np.eye(4)
        frozen[0:2, 2:4] = (delta - tau) / 2
        return frozen @ kick(tau, 0, 1) @ drift(tau) @ kick(delta, 1, 0)
    # eq. (2.17): K_all(tau) D(tau) K_soft(delta - tau) D(delta - tau), applied left to right.
    return drift(delta - tau) @ kick(delta - tau, 1, 0) @ drift(tau) @ kick(tau, 1, 1)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="a coarse grid")
    parser.add_argument("--out", default="results/stability_5_1")
    parser.add_argument("--steps", type=int, default=400)
    parser.add_argument("--replot", metavar="JSON", help="only redraw the chart of an earlier run's JSON into --out")
    parser.add_argument("--errors", action="store_true", help="Fig. 5.2 (errors against delta and tau) instead")
    args = parser.parse_args()
    reporting.set_smoke_run(args.quick)
    if args.errors:
        errors_5_2(args)
        return
    if args.replot:
        reporting.replot(args.replot, args.out, "stability_5_1",
                         lambda data, path: plot(data, np.array(data["delta"]), np.array(data["tau_over_eps"]), path))
        return
    n_delta, n_tau = (8, 6) if args.quick else (44, 36)
    deltas = np.linspace(0.1, 3.5, n_delta)
    ratios = np.logspace(-1, 4, n_tau)  # tau / eps
    system = make_system()
    platform = mm.Platform.getPlatformByName("Reference")
    averagings = {"Nonintrusive": openmmflavors.FlavorIntegrator.Nonintrusive,
                  "Artificial": openmmflavors.FlavorIntegrator.Artificial}
    result = {"omega": OMEGA, "steps": args.steps, "bound": BOUND, "delta": list(deltas), "tau_over_eps": list(ratios),
              "domains": {}}
    for name, averaging in averagings.items():
        stable = np.zeros((n_tau, n_delta), dtype=int)
        radius = np.full((n_tau, n_delta), np.nan)
        for i, ratio in enumerate(ratios):
            tau = ratio * EPS
            for j, delta in enumerate(deltas):
                if tau > delta:
                    stable[i, j] = -1  # not a FLAVOR (tau > delta)
                    continue
                stable[i, j] = int(run_stable(system, platform, averaging, delta, tau, args.steps))
                radius[i, j] = np.max(np.abs(np.linalg.eigvals(one_step_matrix(name == "Artificial", delta, tau))))
        agree = np.sum((stable == 1) == (radius <= 1 + 1e-6)) - np.sum(stable == -1)
        result["domains"][name] = {"stable": stable.tolist(), "spectral_radius": radius.tolist(),
                                   "runs_agreeing_with_matrix": int(agree), "runs": int(np.sum(stable >= 0))}
        # The largest stable delta at the smallest tau, against Theorem 5.1.
        row = stable[0]
        result["domains"][name]["largest_stable_delta_at_smallest_tau"] = float(
            max((d for d, s in zip(deltas, row) if s == 1), default=float("nan")))
        print("%-13s stable %d of %d runs; %d agree with the spectral radius of the one-step matrix; largest stable "
              "delta at tau/eps = %.2g: %.3f" % (name, np.sum(stable == 1), np.sum(stable >= 0), agree, ratios[0],
                                                result["domains"][name]["largest_stable_delta_at_smallest_tau"]))
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "stability_5_1.json"), "w") as f:
        json.dump(result, f, indent=1)
    plot(result, deltas, ratios, os.path.join(args.out, "stability_5_1.png"))


def plot(result, deltas, ratios, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap
    fig, axes = plt.subplots(1, 2, figsize=(13, 6.2), sharey=True)
    cmap = ListedColormap(["#dddddd", "#d62728", "#2ca02c"])  # tau > delta, unstable, stable
    for ax, (name, boundary, label) in zip(axes, [("Nonintrusive", 2.0, "δ = 2"),
                                                   ("Artificial", 2 * math.sqrt(2), "δ = 2√2")]):
        stable = np.array(result["domains"][name]["stable"])
        ax.pcolormesh(deltas, ratios, stable + 1, cmap=cmap, vmin=0, vmax=2, shading="nearest")
        radius = np.array(result["domains"][name]["spectral_radius"])
        ax.contour(deltas, ratios, np.where(np.isnan(radius), 10, radius), levels=[1 + 1e-6], colors="k",
                   linewidths=1.2)
        ax.axvline(boundary, color="b", ls="--", label="Theorem 5.1, τ → 0: " + label)
        if name == "Artificial":
            ax.axhline(math.sqrt(2 * EPS) / EPS, color="m", ls=":", label="τ = √(2ε)")
        ax.plot([], [], color="k", label="spectral radius 1 of the one-step matrix")
        ax.plot([], [], "s", color="#2ca02c", label="stable run")
        ax.plot([], [], "s", color="#d62728", label="unstable run")
        if np.any(stable < 0):
            ax.plot([], [], "s", color="#dddddd", label="τ > δ (not run)")
        ax.set_yscale("log")
        ax.set_xlabel("mesostep δ")
        ax.set_title("(%s) %s FLAVOR (SymplecticEuler)" % ("a" if name == "Nonintrusive" else "b", name))
        ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2)
    axes[0].set_ylabel("τ/ε (ε = 1/ω², ω = 1000)")
    fig.suptitle("Stability domains on system (5.1), found by running FlavorIntegrator for %d mesosteps "
                 "(FLAVORS paper, Fig. 5.1)" % result["steps"])
    fig.tight_layout()
    reporting.save_figure(fig, path, dpi=100)


if __name__ == "__main__":
    main()
