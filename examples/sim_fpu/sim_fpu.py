#!/usr/bin/env python3
"""The Fermi-Pasta-Ulam chain of the SIM paper (section 4.2, eq. 9, Fig. 4) with StochasticImpulseIntegrator.

    H = 1/2 sum p^2 + omega^2/4 sum_{i=1..m} (q_2i - q_2i-1)^2 + sum_{i=0..m} (q_2i+1 - q_2i)^4,  q_0 = q_2m+1 = 0
    m = 3, omega = 200, T = 5 omega = 1000, x(0) = (1, 0, 0, 1/omega, 0, 0), y(0) = 0.

Unit masses on the x axis.  Stiff springs: HarmonicBondForce (length 0, k = omega^2/2) in force group 1; soft
quartic springs (CustomBondForce "r^4") and the walls (CustomExternalForce "x^4") in group 0.  The SIM runs are
deterministic (temperature 0, friction 0): LieTrotter is the paper's Integrator 1 (Fig. 4), Strang the
Verlet-I/r-RESPA impulse method with exact stiff flow.

Reference: OpenMM's VerletIntegrator at a small step, its velocities synchronized (leapfrog-corrected, as in
examples/fpu/fpu.py), with its own error estimated by step halving (|X(h) - X(2h)|/3, second order).  A
VerletIntegrator at a step that resolves the stiff springs is the cost peer.  Wall times are those of the
integrator.step() calls (minimum of the sampled run and unsampled repeats: three for SIM, one for the Verlet peer);
speedup = Verlet peer wall time / wall time.

    PYTHONPATH=build/python .venv/bin/python examples/sim_fpu/sim_fpu.py [--quick] [--out DIR]
"""
import sys

import numpy as np
import openmm as mm

from flavorbench import reporting
from flavorbench.runners import best_time, sim, simulate_fpu, start_context
from flavorbench.systems import as_vec3, fpu_initial, fpu_system

HINT = "step {dt} does not divide the sampling times; choose --sample accordingly"


def main():
    parser = reporting.parser(__doc__, "sim_fpu",
                          quick_help="smoke run of a few seconds (T = 4, coarse reference)")
    parser.add_argument("--omega", type=float, default=200.0)
    parser.add_argument("--m", type=int, default=3, help="number of stiff springs")
    parser.add_argument("--T", type=float, default=None, help="simulated time (default 5 omega; 4 with --quick)")
    parser.add_argument("--H", type=float, nargs="+", default=[0.01, 0.002],
                        help="SIM steps; LieTrotter and Strang run at each (default 0.01 0.002)")
    parser.add_argument("--h", type=float, default=1e-4, help="VerletIntegrator peer step")
    parser.add_argument("--href", type=float, default=None, help="reference step (default 2e-5; 5e-5 with --quick)")
    parser.add_argument("--sample", type=float, default=None, help="sampling interval (default 0.1; 0.02 --quick)")
    parser.add_argument("--window", type=float, default=None,
                        help="final window for the means of I_j (default 20; 1 with --quick)")
    args = parser.parse_args()

    omega, m = args.omega, args.m
    T = args.T if args.T is not None else (4.0 if args.quick else 5.0 * omega)
    href = args.href if args.href is not None else (5e-5 if args.quick else 2e-5)
    sample = args.sample if args.sample is not None else (0.02 if args.quick else 0.1)
    window = min(args.window if args.window is not None else (1.0 if args.quick else 20.0), T)
    times = np.arange(0, int(round(T / sample)) + 1) * sample
    in_window = times >= T - window - 1e-12
    checkpoints = [T / 100, T / 20, T / 10, T]
    checkpoint_index = [int(np.argmin(np.abs(times - t))) for t in checkpoints]

    x0_init = [1.0] + [0.0] * (m - 1)
    x1_init = [1.0 / omega] + [0.0] * (m - 1)
    system = fpu_system(m, omega)
    positions = as_vec3(fpu_initial(m, omega)[0])
    runs = [
        ("reference_check", f"Verlet h={2 * href:g} (ref. check)", lambda: mm.VerletIntegrator(2 * href), 2 * href,
         True),
        ("reference", f"Verlet h={href:g} (reference)", lambda: mm.VerletIntegrator(href), href, True),
        ("verlet", f"Verlet h={args.h:g}", lambda: mm.VerletIntegrator(args.h), args.h, True),
    ]
    for H in args.H:
        runs.append((f"sim_lietrotter_H{H:g}", f"SIM LieTrotter (Int. 1) H={H:g}",
                     lambda H=H: sim(H, "LieTrotter"), H, False))
        runs.append((f"sim_strang_H{H:g}", f"SIM Strang H={H:g}", lambda H=H: sim(H, "Strang"), H, False))

    print(f"FPU m={m} omega={omega:g} T={T:g}: {len(times)} samples every {sample:g}", file=sys.stderr)
    results = {}
    for key, label, make, dt, leapfrog in runs:
        print(f"running {label}: {int(round(T / dt))} steps", file=sys.stderr, flush=True)
        r = simulate_fpu(system, make(), dt, leapfrog, positions, times, omega, label, "9.2f", HINT)
        r.update(label=label, step=dt, wall_s_sampled=r["wall_s"])
        if not key.startswith("reference"):
            # Timed again without sampling: SIM runs (cheap) three times, the Verlet peer once; minimum kept.
            repeats = 1 if leapfrog else 3
            def start():
                integrator = make()
                return start_context(system, integrator, dt, positions, None, leapfrog), integrator
            r["wall_s"] = min(r["wall_s"], best_time(start, r["steps"], repeats)[0])
        results[key] = r

    ref, check = results["reference"], results["reference_check"]
    # Running means of I_j over `window`: the energy exchange among the stiff springs without the fast beats.
    width = max(1, int(round(window / sample)))
    kernel = np.ones(width) / width

    def smooth(values):
        return np.array([np.convolve(values[:, j], kernel, mode="valid") for j in range(values.shape[1])]).T

    ref_smooth = smooth(ref["I"])
    ref_err_x0 = np.abs(check["x0"][:, 0] - ref["x0"][:, 0]) / 3.0
    ref_err_I = np.abs(check["I"] - ref["I"]) / 3.0
    verlet_wall = results["verlet"]["wall_s"]
    summary = {}
    for key, label, _, dt, _ in runs:
        r = results[key]
        err = np.abs(r["x0"][:, 0] - ref["x0"][:, 0])
        err_I = np.abs(r["I"] - ref["I"])
        # For the reference itself, the horizon and running-mean rows describe the halving check against it.
        x0_diff = np.abs((check if key == "reference" else r)["x0"][:, 0] - ref["x0"][:, 0])
        if key == "reference":
            err, err_I = ref_err_x0, ref_err_I
        summary[key] = {
            "label": label, "step": dt, "steps": r["steps"], "wall_s": r["wall_s"],
            "wall_s_sampled_run": r["wall_s_sampled"],
            "us_per_step": 1e6 * r["wall_s"] / r["steps"],
            "speedup_vs_verlet": verlet_wall / r["wall_s"],
            "x0_1_T": float(r["x0"][-1, 0]),
            "x0_1_error_at": {f"{times[i]:g}": float(err[i]) for i in checkpoint_index},
            "x0_1_error_max": float(err.max()),
            "I_T": r["I"][-1].tolist(),
            "I_error_T": err_I[-1].tolist(),
            "I_relative_error_T": (err_I[-1] / np.abs(ref["I"][-1])).tolist(),
            "I_error_max": err_I.max(axis=0).tolist(),
            "I_window_mean": r["I"][in_window].mean(axis=0).tolist(),
            "stiff_total_window_mean": float(r["I"][in_window].sum(axis=1).mean()),
            "stiff_total_range": [float(r["I"].sum(axis=1).min()), float(r["I"].sum(axis=1).max())],
            "energy_drift_max": float(np.abs(r["E"] - r["E"][0]).max()),
            # The slow dynamics is chaotic at this energy: every run, the reference's own halving check included,
            # leaves the reference after some time.  The first time |dx0,1| exceeds each level:
            "x0_1_agreement_horizon": {f"{level:g}": (float(times[np.argmax(x0_diff > level)])
                                                      if np.any(x0_diff > level) else None)
                                       for level in (1e-4, 1e-3, 1e-2, 1e-1)},
            "I_running_mean_max_abs_difference": np.abs(smooth(r["I"]) - ref_smooth).max(axis=0).tolist(),
        }
    summary["reference"]["note"] = ("its errors are its own estimate |X(h) - X(2h)|/3 (step halving, second order); "
                                    "its horizon and running-mean differences are those of the h -> 2h check")
    summary["reference"]["I_running_mean_max_abs_difference"] = np.abs(smooth(check["I"]) - ref_smooth).max(
        axis=0).tolist()

    print_tables(summary, [times[i] for i in checkpoint_index], T, window, omega)
    print_horizons(summary, window)
    data = {
        "scene": "FPU, SIM paper eq. (9), Fig. 4 initial condition",
        "platform": "Reference",
        "openmm_version": mm.__version__,
        "parameters": {"m": m, "omega": omega, "T": T, "H": args.H, "h": args.h, "href": href, "sample": sample,
                       "window": window, "x0": x0_init, "x1": x1_init, "quick": args.quick},
        "summary": summary,
        "series": {"t": times.tolist(),
                   **{key: {"x0_1": r["x0"][:, 0].tolist(), "x1": r["x1"].tolist(), "I": r["I"].tolist(),
                            "E": r["E"].tolist()} for key, r in results.items()}},
    }
    reporting.save_outputs(args.out, "sim_fpu", data,
                       lambda png_path: plot(times, results, summary, T, omega, window, png_path))


def print_tables(summary, checkpoints, T, window, omega):
    print(f"\nFPU (SIM paper Fig. 4), omega = {omega:g}, T = {T:g}.  |dx0,1|: error of the slow variable x0,1 = x_1 "
          f"against the reference (reference row: its own step-halving estimate).\nWall time: integrator.step() only, "
          f"minimum over the sampled run and unsampled repeats (SIM 3, Verlet peer 1); speedup = Verlet peer wall time "
          f"/ wall time.")
    at = " ".join(f"{'t=' + format(t, 'g'):>10s}" for t in checkpoints)
    head = f"{'method':32s} {'steps':>9s} {'wall s':>8s} {'us/step':>8s} {'speedup':>8s}  |dx0,1| at {at} " \
           f"{'max':>10s}"
    print(head)
    print("-" * len(head))
    for s in summary.values():
        errs = " ".join(f"{v:10.2e}" for v in s["x0_1_error_at"].values())
        print(f"{s['label']:32s} {s['steps']:9d} {s['wall_s']:8.3f} {s['us_per_step']:8.3f} "
              f"{s['speedup_vs_verlet']:7.1f}x            {errs} {s['x0_1_error_max']:10.2e}")

    m = len(next(iter(summary.values()))["I_T"])
    print(f"\nStiff energies I_j = (y_m+j^2 + omega^2 x_m+j^2)/2 at T, their relative errors at T, the largest "
          f"absolute error over [0, T],\nand the mean of sum_j I_j over the final {window:g} with its range over "
          f"[0, T]")
    names = " ".join(f"{'I' + str(j + 1) + '(T)':>10s}" for j in range(m))
    rel = " ".join(f"{'rel' + str(j + 1):>8s}" for j in range(m))
    mx = " ".join(f"{'max|d' + str(j + 1) + '|':>8s}" for j in range(m))
    head = f"{'method':32s} {names} | {rel} | {mx} | {'<sum I>':>8s} {'min sum':>8s} {'max sum':>8s} {'max|dH|':>9s}"
    print(head)
    print("-" * len(head))
    for s in summary.values():
        print(f"{s['label']:32s} " + " ".join(f"{v:10.4e}" for v in s["I_T"]) + " | " +
              " ".join(f"{v:8.1e}" for v in s["I_relative_error_T"]) + " | " +
              " ".join(f"{v:8.1e}" for v in s["I_error_max"]) +
              f" | {s['stiff_total_window_mean']:8.5f} {s['stiff_total_range'][0]:8.5f} "
              f"{s['stiff_total_range'][1]:8.5f} {s['energy_drift_max']:9.2e}")


def print_horizons(summary, window):
    print(f"\nThe slow dynamics is chaotic: pointwise agreement lasts only so long for every run (the reference row "
          f"is its h -> 2h check).\nFirst time |dx0,1| exceeds each level, and the largest difference of the "
          f"{window:g}-long running means of I_j from the reference's")
    levels = list(next(iter(summary.values()))["x0_1_agreement_horizon"])
    m = len(next(iter(summary.values()))["I_T"])
    head = f"{'method':32s} " + " ".join(f"{'t(>' + level + ')':>10s}" for level in levels) + " | " + \
        " ".join(f"{'<I' + str(j + 1) + '> diff':>10s}" for j in range(m))
    print(head)
    print("-" * len(head))
    for s in summary.values():
        hz = " ".join(f"{v:10.4g}" if v is not None else f"{'> T':>10s}" for v in s["x0_1_agreement_horizon"].values())
        print(f"{s['label']:32s} {hz} | " + " ".join(f"{v:10.2e}" for v in s["I_running_mean_max_abs_difference"]))


def plot(times, results, summary, T, omega, window, path):
    from matplotlib.lines import Line2D
    plt = reporting.pyplot()

    shown = [k for k in results if k not in ("reference_check", "verlet")]
    colors = {"reference": "k"}
    palette = ["tab:red", "tab:blue", "tab:orange", "tab:cyan", "tab:green", "tab:purple"]
    colors.update({k: palette[i % len(palette)] for i, k in enumerate(k for k in shown if k != "reference")})
    names = {k: reporting.greek(summary[k]["label"]) for k in shown}
    fig, axes = plt.subplots(2, 2, figsize=(14, 11))
    fig.suptitle(f"FPU chain (SIM paper eq. 9, Fig. 4 start): StochasticImpulseIntegrator (LieTrotter, Strang) against "
                 f"a fine Verlet reference,\nω = {omega:g} ps⁻¹, T = {T:g} ps, Reference platform (dimensionless "
                 f"units: 1 amu, 1 nm, 1 ps; energies in kJ/mol)")

    ax = axes[0, 0]
    w = times <= min(T, 5.0)
    for key in shown:
        ax.plot(times[w], results[key]["x0"][w, 0], color=colors[key], lw=1.4 if key == "reference" else 1,
                ls="-" if key == "reference" else "--")
    ax.set_title(f"slow variable x₀,₁ = (q₂ + q₁)/√2, first {min(T, 5.0):g} ps", fontsize=10)
    ax.set_xlabel("t (ps)")
    ax.set_ylabel("x₀,₁ (nm)")

    ax = axes[0, 1]
    for key in shown:
        err = np.abs(results[key]["x0"][:, 0] - results["reference"]["x0"][:, 0])
        if key == "reference":
            err = np.abs(results["reference_check"]["x0"][:, 0] - results["reference"]["x0"][:, 0]) / 3.0
        ax.semilogy(times[1:], np.maximum(err[1:], 1e-16), color=colors[key], lw=0.7)
    ax.set_title("slow-variable error |x₀,₁ − x₀,₁(reference)|\n(black: the reference's own error, from step "
                 "halving)", fontsize=10)
    ax.set_xlabel("t (ps)")
    ax.set_ylabel("absolute error (nm)")

    ax = axes[1, 0]
    m = results["reference"]["I"].shape[1]
    width = max(1, int(round(window / (times[1] - times[0]))))
    kernel = np.ones(width) / width
    styles = []
    for j in range(m):
        for key in shown:
            ls = "-" if key == "reference" else ["--", ":", "-.", (0, (1, 3)), (0, (5, 2, 1, 2))][shown.index(key) % 5]
            mean = np.convolve(results[key]["I"][:, j], kernel, mode="valid")
            ax.plot(times[width - 1:], mean, color=f"C{j}", lw=1.6 if key == "reference" else 0.8, ls=ls)
            if j == 0:
                styles.append(Line2D([], [], color="0.3", lw=1.6 if key == "reference" else 0.8, ls=ls,
                                     label=names[key]))
    ax.set_title(f"stiff energies I₁ (blue), I₂ (orange), I₃ (green): running means over {window:g} ps", fontsize=10)
    ax.set_xlabel("t (ps)")
    ax.set_ylabel("energy (kJ/mol)")
    ax.legend(handles=styles, fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2, frameon=False,
              title="line style: method", title_fontsize=8)

    ax = axes[1, 1]
    for key in shown:
        ax.plot(times, results[key]["I"].sum(axis=1), color=colors[key], lw=1.2 if key == "reference" else 0.8)
    ax.set_title("total stiff energy I₁ + I₂ + I₃", fontsize=10)
    ax.set_xlabel("t (ps)")
    ax.set_ylabel("energy (kJ/mol)")
    # The methods' colours, once for the three panels that use them, below the right-hand column.
    fig.legend(handles=[Line2D([], [], color=colors[k], lw=1.4 if k == "reference" else 1, label=names[k])
                        for k in shown], fontsize=8, loc="lower center", bbox_to_anchor=(0.75, 0.0), ncol=2,
               frameon=False, title="colour: method", title_fontsize=8)
    fig.tight_layout(rect=(0, 0.1, 1, 0.98))
    reporting.save_figure(fig, path, 110)


if __name__ == "__main__":
    main()
