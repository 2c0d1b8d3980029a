#!/usr/bin/env python3
"""The Fermi-Pasta-Ulam chain of the FLAVORS paper (section 6.3, eq. 6.7, Fig. 6.5) with FlavorIntegrator.

    H = 1/2 sum p^2 + omega^2/4 sum_{i=1..m} (q_2i - q_2i-1)^2 + sum_{i=0..m} (q_2i+1 - q_2i)^4,  q_0 = q_2m+1 = 0

Unit masses, particles on the x axis.  Stiff springs: HarmonicBondForce (length 0, k = omega^2/2) in force group 1;
soft quartic springs (CustomBondForce "r^4") and the walls (CustomExternalForce "x^4") in group 0.

FLAVOR (mesostep delta, microstep tau) is compared with OpenMM's VerletIntegrator at a step that resolves the stiff
springs, both against a fine VerletIntegrator reference whose own error is estimated by step halving.  Everything
is measured in this run; speedups are wall-clock ratios of the integrator.step() calls.

    PYTHONPATH=build/python .venv/bin/python examples/fpu/fpu.py [--quick] [--out DIR]
"""
import math
import sys

import numpy as np
import openmm as mm

from flavorbench import reporting
from flavorbench.runners import flavor, simulate_fpu
from flavorbench.systems import as_vec3, fpu_initial, fpu_system

HINT = "step size {dt} does not divide the sampling times; choose --sample/--fine accordingly"


def main():
    parser = reporting.parser(__doc__, "fpu",
                          quick_help="smoke run of a few seconds (T = 4, coarser reference)")
    parser.add_argument("--T", type=float, default=None, help="simulated time (default omega = 200; 4 with --quick)")
    parser.add_argument("--omega", type=float, default=200.0)
    parser.add_argument("--m", type=int, default=3, help="number of stiff springs")
    parser.add_argument("--delta", type=float, default=2e-3, help="FLAVOR mesostep")
    parser.add_argument("--tau", type=float, nargs="+", default=[1e-4, 5e-4],
                        help="FLAVOR microsteps, one Verlet-scheme run each (default: Figs. 6.5/6.7 and 6.8 values)")
    parser.add_argument("--h", type=float, default=1e-4, help="VerletIntegrator step")
    parser.add_argument("--href", type=float, default=None, help="reference step (default 1e-5; 2e-5 with --quick)")
    parser.add_argument("--sample", type=float, default=None, help="sampling interval (default 0.1; 0.02 --quick)")
    parser.add_argument("--window", type=float, default=None,
                        help="final averaging window for I_j, finely sampled (default 2.0; 0.5 with --quick)")
    parser.add_argument("--fine", type=float, default=0.01, help="sampling interval inside the final window")
    parser.add_argument("--no-euler", action="store_true", help="skip the SymplecticEuler FLAVOR (first tau)")
    parser.add_argument("--no-effective", action="store_true",
                        help="skip the comparison of each Verlet FLAVOR with the FPU at omega sqrt(tau/delta)")
    parser.add_argument("--replot", metavar="JSON", help="run nothing: redraw OUT/fpu.png from an earlier fpu.json")
    args = parser.parse_args()
    if args.replot:
        reporting.replot(args.replot, args.out, "fpu", plot)
        return

    omega, m = args.omega, args.m
    T = args.T if args.T is not None else (4.0 if args.quick else omega)
    href = args.href if args.href is not None else (2e-5 if args.quick else 1e-5)
    sample = args.sample if args.sample is not None else (0.02 if args.quick else 0.1)
    window = args.window if args.window is not None else (0.5 if args.quick else 2.0)
    window = min(window, T)

    # Fig. 6.5: energy starts in the leftmost soft and stiff springs.
    x0_init = [1.0] + [0.0] * (m - 1)
    x1_init = [1.0 / omega] + [0.0] * (m - 1)
    system = fpu_system(m, omega)
    positions = as_vec3(fpu_initial(m, omega)[0])

    coarse = np.arange(0, int(round(T / sample)) + 1) * sample
    fine = T - window + np.arange(0, int(round(window / args.fine)) + 1) * args.fine
    times = np.unique(np.round(np.concatenate([coarse[coarse < T - window], fine]), 12))
    in_window = times >= T - window - 1e-12
    on_grid = np.abs(times / sample - np.rint(times / sample)) < 1e-6
    checkpoints = [T / 20, T / 4, T]
    checkpoint_index = [int(np.argmin(np.abs(times - t))) for t in checkpoints]

    # key, label, make integrator, step, leapfrog velocities, tau/delta (the weight of the stiff forces)
    runs = [
        ("reference_check", f"Verlet h={2 * href:g} (ref. check)", lambda: mm.VerletIntegrator(2 * href),
         2 * href, True, 1.0),
        ("reference", f"Verlet h={href:g} (reference)", lambda: mm.VerletIntegrator(href), href, True, 1.0),
        ("verlet", f"Verlet h={args.h:g}", lambda: mm.VerletIntegrator(args.h), args.h, True, 1.0),
    ]
    for k, tau in enumerate(args.tau):
        key = "flavor_verlet" if k == 0 else f"flavor_verlet_tau{tau:g}"
        runs.append((key, f"FLAVOR Verlet d={args.delta:g} t={tau:g}",
                     lambda tau=tau: flavor(args.delta, tau, "Verlet"), args.delta, False, tau / args.delta))
    if not args.no_euler:
        tau = args.tau[0]
        runs.append(("flavor_euler", f"FLAVOR SympEuler d={args.delta:g} t={tau:g}",
                     lambda: flavor(args.delta, tau, "SymplecticEuler"), args.delta, False, tau / args.delta))

    print(f"FPU m={m} omega={omega:g} T={T:g}: {len(times)} samples (every {sample:g}, every {args.fine:g} in the "
          f"final window of {window:g})", file=sys.stderr)
    results = {}
    for key, label, make, dt, leapfrog, weight in runs:
        print(f"running {label}: {int(round(T / dt))} steps", file=sys.stderr, flush=True)
        r = simulate_fpu(system, make(), dt, leapfrog, positions, times, omega, label, "8.2f", HINT)
        # Per mesostep FLAVOR drifts for delta but applies the stiff forces for tau only: to leading order (BCH) it
        # is the flow of H_F = K + V_soft + (tau/delta) U_stiff, so its stiff oscillation keeps omega^2 <x1^2> but
        # has <y1^2> scaled by tau/delta.  H_F = H for Verlet.
        r["Ht"] = r["E"] - (1.0 - weight) * 0.5 * np.sum(r["Ix"], axis=1)
        r.update(label=label, step=dt)
        results[key] = r

    ref, check = results["reference"], results["reference_check"]
    verlet_wall = results["verlet"]["wall_s"]
    summary = {}
    for key, _, _, dt, _, _ in runs:
        r = results[key]
        err = np.abs(r["x0"][:, 0] - ref["x0"][:, 0])
        if key == "reference":
            # Velocity Verlet is second order: halving the step removes 3/4 of the error.
            err = np.abs(check["x0"][:, 0] - ref["x0"][:, 0]) / 3.0
        summary[key] = {
            "label": r["label"],
            "step": dt,
            "steps": r["steps"],
            "wall_s": r["wall_s"],
            "us_per_step": 1e6 * r["wall_s"] / r["steps"],
            "speedup_vs_verlet": verlet_wall / r["wall_s"],
            "x0_1_T": float(r["x0"][-1, 0]),
            "x0_1_error_at": {f"{times[i]:g}": float(err[i]) for i in checkpoint_index},
            "x0_1_error_T": float(err[-1]),
            "x0_1_error_max": float(err.max()),
            "I_T": r["I"][-1].tolist(),
            "I_window_mean": r["I"][in_window].mean(axis=0).tolist(),
            "Ix_window_mean": r["Ix"][in_window].mean(axis=0).tolist(),
            "stiff_total_window_mean": float(r["I"][in_window].sum(axis=1).mean()),
            "stiff_total_Ix_window_mean": float(r["Ix"][in_window].sum(axis=1).mean()),
            "energy_drift_T": float(r["E"][-1] - r["E"][0]),
            "energy_drift_max": float(np.abs(r["E"] - r["E"][0]).max()),
            "H_F_drift_T": float(r["Ht"][-1] - r["Ht"][0]),
            "H_F_drift_max": float(np.abs(r["Ht"] - r["Ht"][0]).max()),
        }
    summary["reference"]["note"] = ("errors of the reference are its own estimate, |x(h) - x(2h)|/3 (step halving, "
                                    "second order)")

    # H_F above is the FPU Hamiltonian with omega replaced by omega sqrt(tau/delta).  Integrate that system from the
    # same state with OpenMM's Verlet and compare: it tells what each Verlet FLAVOR run actually simulates.
    effective = {}
    if not args.no_effective:
        for key, _, _, _, _, weight in runs:
            if not key.startswith("flavor_verlet"):
                continue
            omega_eff = omega * math.sqrt(weight)
            label = f"Verlet h={args.h:g}, FPU omega_eff={omega_eff:.4g}"
            print(f"running {label} (compared with {results[key]['label']})", file=sys.stderr, flush=True)
            e = simulate_fpu(fpu_system(m, omega_eff), mm.VerletIntegrator(args.h), args.h, True, positions, times,
                             omega, label, "8.2f", HINT)
            err = np.abs(results[key]["x0"][:, 0] - e["x0"][:, 0])
            results[key]["effective_error"] = err
            effective[key] = {
                "label": label, "flavor": results[key]["label"], "omega_eff": omega_eff,
                "x0_1_difference_at": {f"{times[i]:g}": float(err[i]) for i in checkpoint_index},
                "x0_1_difference_max": float(err.max()),
                "Ix_window_mean_effective": e["Ix"][in_window].mean(axis=0).tolist(),
                "Ix_window_mean_flavor": summary[key]["Ix_window_mean"],
            }

    print_tables(summary, effective, [times[i] for i in checkpoint_index], T, window, omega)
    data = {
        "scene": "FPU (6.7), Fig. 6.5 initial condition",
        "platform": "Reference",
        "parameters": {"m": m, "omega": omega, "T": T, "delta": args.delta, "tau": args.tau, "h": args.h,
                       "href": href, "sample": sample, "fine": args.fine, "window": window,
                       "x0": x0_init, "x1": x1_init, "quick": args.quick},
        "openmm_version": mm.__version__,
        "summary": summary,
        "flavor_vs_effective_fpu": effective,
        "series": {"t": times.tolist(),
                   **{key: {"x0_1": results[key]["x0"][:, 0].tolist(), "I": results[key]["I"].tolist(),
                            "omega2_x1sq": results[key]["Ix"].tolist(), "E": results[key]["E"].tolist(),
                            "H_F": results[key]["Ht"].tolist()} for key in results}},
    }
    reporting.save_outputs(args.out, "fpu", reporting.jsonable(data), lambda png_path: plot(reporting.jsonable(data),
                                                                                            png_path))


def print_tables(summary, effective, checkpoints, T, window, omega):
    print(f"\nFPU, omega = {omega:g}, T = {T:g}.  Error |dx0,1| in the slow variable x0,1 against the reference "
          f"(reference row: its own step-halving estimate).\nWall time: integrator.step() only; speedup = Verlet "
          f"wall time / wall time.")
    at = " ".join(f"{'t=' + format(t, 'g'):>10s}" for t in checkpoints)
    head = f"{'method':36s} {'steps':>9s} {'wall s':>8s} {'us/step':>8s} {'speedup':>8s}   |dx0,1| at {at} " \
           f"{'max':>10s}"
    print(head)
    print("-" * len(head))
    for s in summary.values():
        errs = " ".join(f"{v:10.2e}" for v in s["x0_1_error_at"].values())
        print(f"{s['label']:36s} {s['steps']:9d} {s['wall_s']:8.3f} {s['us_per_step']:8.3f} "
              f"{s['speedup_vs_verlet']:7.1f}x              {errs} {s['x0_1_error_max']:10.2e}")

    print(f"\nStiff energies I_j = (y1_j^2 + omega^2 x1_j^2)/2: at T, and means over the final window [T-{window:g}, T]"
          f" of I_j and of omega^2 x1_j^2\n(the position-only estimate of I_j: a harmonic oscillator's kinetic and "
          f"potential energies have equal time averages)")
    head = f"{'method':36s} {'I1(T)':>7s} {'I2(T)':>7s} {'I3(T)':>7s} | {'<I1>':>7s} {'<I2>':>7s} {'<I3>':>7s} " \
           f"{'sum':>7s} | {'<w2x1²>':>7s} {'<w2x2²>':>7s} {'<w2x3²>':>7s} {'sum':>7s}"
    print(head)
    print("-" * len(head))
    for s in summary.values():
        print(f"{s['label']:36s} " + " ".join(f"{v:7.4f}" for v in s["I_T"]) + " | " +
              " ".join(f"{v:7.4f}" for v in s["I_window_mean"]) + f" {s['stiff_total_window_mean']:7.4f} | " +
              " ".join(f"{v:7.4f}" for v in s["Ix_window_mean"]) + f" {s['stiff_total_Ix_window_mean']:7.4f}")

    print("\nTotal energy H(t) - H(0) at T and its maximum over the samples; for FLAVOR also H_F = K + V_soft + "
          "(tau/delta) U_stiff,\nthe energy its step conserves to leading order (H_F = H for Verlet)")
    head = f"{'method':36s} {'H(T)-H(0)':>11s} {'max|dH|':>10s} {'H_F(T)-H_F(0)':>14s} {'max|dH_F|':>10s}"
    print(head)
    print("-" * len(head))
    for s in summary.values():
        print(f"{s['label']:36s} {s['energy_drift_T']:11.3e} {s['energy_drift_max']:10.3e} "
              f"{s['H_F_drift_T']:14.3e} {s['H_F_drift_max']:10.3e}")

    if effective:
        print("\nEach Verlet FLAVOR against OpenMM's Verlet on the FPU with omega_eff = omega sqrt(tau/delta), same "
              "start: |x0,1 difference| and final-window omega^2 <x1_j^2>")
        at = " ".join(f"{'t=' + format(t, 'g'):>10s}" for t in checkpoints)
        head = f"{'FLAVOR run':36s} {'omega_eff':>9s} {at} {'max':>10s}   {'FLAVOR <w2x_j²>':>23s}   " \
               f"{'FPU(omega_eff) <w2x_j²>':>23s}"
        print(head)
        print("-" * len(head))
        for e in effective.values():
            print(f"{e['flavor']:36s} {e['omega_eff']:9.4g} " +
                  " ".join(f"{v:10.2e}" for v in e["x0_1_difference_at"].values()) +
                  f" {e['x0_1_difference_max']:10.2e}   " + " ".join(f"{v:7.4f}" for v in e["Ix_window_mean_flavor"]) +
                  "   " + " ".join(f"{v:7.4f}" for v in e["Ix_window_mean_effective"]))


def envelope(t, values, width, reduce=np.max):
    """reduce (the maximum, or the mean) of values over bins (t - width, t] for t = width, 2 width, ...: where each
    curve lies, without its oscillations."""
    t = np.asarray(t)
    bins = np.ceil(t / width - 1e-9).astype(int)
    ends, out = [], []
    for b in np.unique(bins):
        inside = bins == b
        ends.append(b * width)
        out.append(reduce(np.asarray(values)[inside]))
    return np.array(ends), np.array(out)


def plot(data, path):
    """fpu.png from the run's JSON (fpu.json): the slow variable's error, the energy in the first stiff spring and
    the conserved energy's drift, each method in its own colour and line style; the title states the verdict."""
    plt = reporting.pyplot()
    plt.rcParams.update({"font.size": 11})
    p, summary, series = data["parameters"], data["summary"], data["series"]
    t = np.array(series["t"])
    T, omega, window = p["T"], p["omega"], p["window"]
    coarse = np.abs(t / p["sample"] - np.rint(t / p["sample"])) < 1e-6
    keys = [k for k in series if k not in ("t", "reference_check")]
    styles = {"reference": ("black", "-", 2.2), "verlet": ("tab:blue", "-", 1.8)}
    flavor_styles = [("tab:red", "--", 1.8), ("tab:purple", "-.", 1.8), ("tab:orange", ":", 2.2),
                     ("tab:brown", "--", 1)]
    styles.update({k: flavor_styles[i % len(flavor_styles)] for i, k in enumerate(k for k in keys if k not in styles)})

    def label(key):
        s = summary[key]
        name = reporting.greek(s["label"]).replace("(reference)", "").strip()
        if key == "reference":
            return f"reference: {name} (its own error by step halving)"
        return f"{name}: {s['speedup_vs_verlet']:.1f}× Verlet's speed, error ≤ {s['x0_1_error_max']:.1g}"

    fig, axes = plt.subplots(1, 3, figsize=(18, 6.6))
    bin_ps = max(T / 50, p["sample"])
    ax = axes[0]
    reference = np.array(series["reference"]["x0_1"])
    for key in keys:
        x = np.array(series[key]["x0_1"])
        error = np.abs(x - reference)
        if key == "reference":
            error = np.abs(np.array(series["reference_check"]["x0_1"]) - reference) / 3.0
        color, ls, lw = styles[key]
        ax.semilogy(*envelope(t[coarse][1:], np.maximum(error[coarse][1:], 1e-16), bin_ps), color=color, ls=ls, lw=lw,
                    label=label(key))
    ax.set_xlabel("t (ps)")
    ax.set_ylabel("|x₀,₁ − x₀,₁(reference)| (nm), largest per %g ps" % bin_ps)
    ax.set_title("slow variable x₀,₁ = (q₂ + q₁)/√2: error")

    ax = axes[1]
    for key in keys:
        color, ls, lw = styles[key]
        # ω²x₁,₁² averaged over bins of the window's length: the first stiff spring's energy, from positions alone
        # (right in distribution for FLAVOR, whose fast velocities are scaled)
        ax.plot(*envelope(t[coarse][1:], np.array(series[key]["omega2_x1sq"])[coarse][1:, 0], window, np.mean),
                color=color, ls=ls, lw=lw, marker=".")
    ax.set_xlabel("t (ps)")
    ax.set_ylabel("ω²⟨x₁,₁²⟩, mean per %g ps (kJ/mol)" % window)
    ax.set_title("energy of the first stiff spring (it starts with all of it)")

    ax = axes[2]
    for key in keys:
        color, ls, lw = styles[key]
        conserved = np.array(series[key]["H_F" if key.startswith("flavor") else "E"])
        drift = np.abs(conserved - conserved[0])
        ax.semilogy(*envelope(t[coarse][1:], np.maximum(drift[coarse][1:], 1e-16), bin_ps), color=color, ls=ls,
                    lw=lw)
    ax.set_xlabel("t (ps)")
    ax.set_ylabel("|H(t) − H(0)| (kJ/mol), largest per %g ps" % bin_ps)
    ax.set_title("energy drift (FLAVOR: H_F = K + V_soft + (τ/δ) U_stiff)")
    for ax in axes:
        ax.grid(alpha=0.3, which="both", lw=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=2, frameon=False, fontsize=11)
    flavors = [summary[k] for k in keys if k.startswith("flavor")]
    verlet = summary["verlet"]
    fig.suptitle(f"FPU toy chain (6 particles, ω = {omega:g} ps⁻¹, T = {T:g} ps, Reference platform): FlavorIntegrator "
                 f"(non-intrusive) runs {min(f['speedup_vs_verlet'] for f in flavors):.0f}–"
                 f"{max(f['speedup_vs_verlet'] for f in flavors):.0f}× VerletIntegrator h = {p['h']:g} ps\n"
                 f"with errors in the slow variable up to {min(f['x0_1_error_max'] for f in flavors):.1g}–"
                 f"{max(f['x0_1_error_max'] for f in flavors):.1g} against Verlet's {verlet['x0_1_error_max']:.0e}, "
                 "and moves the stiff springs' energy too fast (it integrates the chain at ω√(τ/δ))", fontsize=13)
    fig.tight_layout(rect=(0, 0.12, 1, 0.92))
    reporting.save_figure(fig, path, 80)


if __name__ == "__main__":
    main()
