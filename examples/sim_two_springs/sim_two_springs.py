#!/usr/bin/env python3
"""The two-spring Langevin system of the SIM paper (section 4.1, Fig. 2) with StochasticImpulseIntegrator.

    wall -- stiff linear spring -- mass x -- soft quartic spring -- mass y,  both masses with friction c and noise:
    dp_x = -(omega^2 x + (x - y)^3) dt - c p_x dt + sigma dW1,   dp_y = -(y - x)^3 dt - c p_y dt + sigma dW2,
    H = p_x^2/2 + p_y^2/2 + omega^2 x^2/2 + (y - x)^4/4,  omega = 100, c = 0.1, beta = 2c/sigma^2 = 10,
    x(0) = 0.8/omega, y(0) = 1.1 + x(0), p(0) = 0.

The smallest System that holds the scene: ONE particle of mass 1 per realization, whose x and y coordinates are the
paper's x and y.  The stiff force (group 1) is CustomExternalForce "0.5*w2*x^2", the soft one (group 0)
CustomExternalForce "0.25*(y-x)^4".  OpenMM applies friction and noise isotropically, which is the paper's
friction c on both masses; the particle's z coordinate is a free Langevin coordinate that nothing reads.  The
ensemble of realizations is that many non-interacting particles in one System (one Context, one step call).
k_B T = 1/beta = 0.1 kJ/mol, i.e. T = 0.1/R K with R = 0.0083144626 kJ/mol/K (12.03 K).

Compared (same platform, same ensemble size, independent random streams):
  - SIM Integrator 2 (LieTrotter: exact damped-oscillator flow with exact noise, then a soft kick) at the large step
    H = k pi/omega (default k = 10, H = 0.314: resonant, omega*H a multiple of pi, and not scaling with omega);
  - SIM Integrator 3 (Strang) at the same H;
  - GLA (the paper's benchmark, ref. [3]): FlavorIntegrator(h, h, {1}) with the SymplecticEuler scheme, friction c
    and the same temperature, i.e. an exact Ornstein-Uhlenbeck step followed by symplectic Euler with all forces,
    at h = H/n, n = ceil(H omega/0.1): the paper's h = 0.1/omega rounded down so that n h = H (common sample times).
  - the same GLA at h/4 on a smaller ensemble (default 1000 copies): GLA at h = 0.1/omega has its own error, a drift
    of the stiff oscillation's phase (symplectic Euler's frequency is 2 asin(omega h/2)/h, 0.8 rad off by t = 20),
    which the finer run resolves; it tells whose error a SIM-GLA difference is.
Also both SIMs at a non-resonant step (omega H ~ 10.5 pi).  Empirical first and second moments at every t = jH are
compared with their sampling errors (z-scores).  Speedups are ratios of the wall time of integrator.step() calls
over the same simulated time, same platform, same ensemble size.

    PYTHONPATH=build/python .venv/bin/python examples/sim_two_springs/sim_two_springs.py [--quick] [--out DIR]
"""
import math
import sys
import warnings

import numpy as np
import openmm as mm

import openmmflavors
from flavorbench import reporting
from flavorbench.progress import Progress
from flavorbench.runners import KB, best_time, flavor, sim, simulate, start_context
from flavorbench.systems import SOFT_GROUP, STIFF_GROUP

# The paper's scene runs Strang at the resonant omega*H = 10 pi on purpose.
warnings.filterwarnings("ignore", category=openmmflavors.ResonanceWarning)

# Positions are compared with the paper's uniform error bound; momenta are shown but SIM's p error is not uniform.
POSITION_MOMENTS = ["E[x]", "E[y]", "E[x^2]", "E[y^2]"]
MOMENTUM_MOMENTS = ["E[px^2]", "E[py^2]"]
MOMENTS = POSITION_MOMENTS + MOMENTUM_MOMENTS


def build_system(copies, omega):
    system = mm.System()
    stiff = mm.CustomExternalForce("0.5*w2*x^2")
    stiff.addGlobalParameter("w2", omega * omega)
    soft = mm.CustomExternalForce("0.25*(y-x)^4")
    stiff.setForceGroup(STIFF_GROUP)
    soft.setForceGroup(SOFT_GROUP)
    for i in range(copies):
        system.addParticle(1.0)
        stiff.addParticle(i, [])
        soft.addParticle(i, [])
    system.addForce(stiff)
    system.addForce(soft)
    return system


def initial_positions(n, x0, y0):
    """Every realization at the paper's initial data (x0, y0)."""
    q = np.zeros((n, 3))
    q[:, 0], q[:, 1] = x0, y0
    return q


def moments(q, v, state):
    """Ensemble means and their standard errors of the MOMENTS."""
    x, y, px, py = q[:, 0], q[:, 1], v[:, 0], v[:, 1]
    values = np.stack([x, y, x * x, y * y, px * px, py * py])
    return {"mean": values.mean(axis=1), "se": values.std(axis=1, ddof=1) / math.sqrt(len(x))}


def run(system, integrator, platform, properties, x0, y0, samples, steps_per_sample, dt, label):
    """Run all realizations from the paper's initial data at rest; sample the moments every steps_per_sample
    steps.  The first step (which measures the stiff potential, SIM, or builds caches) is also timed alone."""
    times = np.arange(samples + 1) * steps_per_sample * dt
    r = simulate(system, integrator, dt, initial_positions(system.getNumParticles(), x0, y0), None, times, label,
                 platform=platform, properties=properties, observe=moments, progress=Progress(label, fmt="7.3f"))
    return {key: r[key] for key in ("wall_s", "first_step_s", "steps", "us_per_step", "mean", "se")} | {"step": dt}


def compare(a, b, skip_first=True):
    """z-scores of the difference of two independent ensembles' moments, per sample time and moment."""
    start = 1 if skip_first else 0
    diff = a["mean"][start:] - b["mean"][start:]
    err = np.sqrt(a["se"][start:] ** 2 + b["se"][start:] ** 2)
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(err > 0, diff / err, 0.0)
    return z


def bonferroni_threshold(tests, alpha=0.01):
    """Two-sided normal quantile for family-wise level alpha over `tests` comparisons (bisection on erfc)."""
    target = alpha / max(tests, 1)
    lo, hi = 0.0, 40.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if math.erfc(mid / math.sqrt(2.0)) > target:
            lo = mid
        else:
            hi = mid
    return hi


def main():
    parser = reporting.parser(__doc__, "sim_two_springs",
                          quick_help="smoke run of a few seconds (400 copies, T = 2)")
    parser.add_argument("--copies", type=int, default=None, help="realizations (default 5000 as in the paper)")
    parser.add_argument("--fine-copies", type=int, default=None,
                        help="realizations of the GLA run at h/fine-factor (default 1000; 200 with --quick; 0 skips)")
    parser.add_argument("--fine-factor", type=int, default=4)
    parser.add_argument("--T", type=float, default=None, help="simulated time (default 20; 2 with --quick)")
    parser.add_argument("--omega", type=float, default=100.0)
    parser.add_argument("--c", type=float, default=0.1, help="friction coefficient (1/ps)")
    parser.add_argument("--beta", type=float, default=10.0, help="inverse temperature 1/(k_B T) in mol/kJ")
    parser.add_argument("--resonance", type=float, default=10.0,
                        help="SIM step H = resonance*pi/omega (default 10: H = 0.314 at omega = 100)")
    parser.add_argument("--nonresonant", type=float, default=0.5,
                        help="also run both SIMs at omega*H/pi ~ resonance + this (default 0.5: far from resonance; "
                             "negative to skip)")
    parser.add_argument("--gla-h", type=float, default=None,
                        help="largest allowed GLA step (default 0.1/omega); h = H/ceil(H/gla_h)")
    parser.add_argument("--platform", default="Reference", choices=["Reference", "CPU"])
    parser.add_argument("--threads", type=int, default=2, help="CPU platform threads")
    parser.add_argument("--seed", type=int, default=2010, help="random seeds are seed, seed+1, ...")
    args = parser.parse_args()

    omega, c, beta = args.omega, args.c, args.beta
    copies = args.copies if args.copies is not None else (400 if args.quick else 5000)
    fine_copies = args.fine_copies if args.fine_copies is not None else (200 if args.quick else 1000)
    T = args.T if args.T is not None else (2.0 if args.quick else 20.0)
    H = args.resonance * math.pi / omega
    gla_h_max = args.gla_h if args.gla_h is not None else 0.1 / omega
    substeps = int(math.ceil(H / gla_h_max * (1 - 1e-12)))
    h = H / substeps
    kT = 1.0 / beta
    temperature = kT / KB
    x0 = 0.8 / omega
    y0 = 1.1 + x0
    properties = {"Threads": str(args.threads)} if args.platform == "CPU" else {}

    # Every SIM step is a whole number of GLA steps, so all runs are sampled at exactly the same times.  The
    # non-resonant step is the multiple of h near (resonance + nonresonant) pi/omega with the largest common divisor
    # with the resonant one (GLA is sampled every gcd steps).
    sim_steps = {"res": substeps}
    if args.nonresonant >= 0:
        target = (args.resonance + args.nonresonant) * math.pi / omega / h
        window = [n for n in range(int(target * 0.99), int(target * 1.01) + 2) if n > 0]
        sim_steps["nonres"] = max(window, key=lambda n: (math.gcd(n, substeps), -abs(n - target)))
    gla_every = 0
    for n in sim_steps.values():
        gla_every = math.gcd(gla_every, n)

    # key, label, factory, copies, steps per sample, step size, samples, sample interval in units of h
    runs = []
    seed = args.seed
    for tag, n in sim_steps.items():
        step = n * h
        samples = max(1, int(math.floor(T / step + 1e-9)))
        suffix = "" if tag == "res" else "_nonresonant"
        where = f"H={step:.4g}, omega H={omega * step / math.pi:.3f} pi"
        for name, splitting, number in (("lietrotter", "LieTrotter", 2), ("strang", "Strang", 3)):
            runs.append((f"sim_{name}{suffix}", f"SIM {name} (Int. {number}) {where}",
                         lambda splitting=splitting, step=step, seed=seed: sim(step, splitting, temperature, c, seed),
                         copies, 1, step, samples, n))
            seed += 1
    sim_end = max(r[5] * r[6] for r in runs)
    gla_samples = int(round(sim_end / (gla_every * h)))
    def gla(step, seed):
        return flavor(step, step, "SymplecticEuler", temperature=temperature, friction=c, seed=seed)

    runs.append(("gla", f"GLA (FLAVOR SympEuler tau=delta) h={h:.4g}", lambda seed=seed: gla(h, seed), copies,
                 gla_every, h, gla_samples, gla_every))
    if fine_copies > 0:
        hf = h / args.fine_factor
        runs.append(("gla_fine", f"GLA h={hf:.4g} ({fine_copies} copies)", lambda seed=seed + 1: gla(hf, seed),
                     fine_copies, gla_every * args.fine_factor, hf, gla_samples, gla_every))
    print(f"two springs: omega={omega:g} c={c:g} beta={beta:g} (T={temperature:.4f} K), {copies} copies in one "
          f"System on {args.platform}, T={sim_end:.4f}; SIM steps {', '.join(f'{n} h' for n in sim_steps.values())}; "
          f"GLA h = H/{substeps} = {h:.5g} (omega*h = {omega * h:.4f}), sampled every {gla_every} steps",
          file=sys.stderr)
    results = {}
    for key, label, make, n_copies, per_sample, dt, samples, every in runs:
        print(f"running {label}: {samples * per_sample} steps, {n_copies} copies", file=sys.stderr, flush=True)
        system = build_system(n_copies, omega)
        r = run(system, make(), args.platform, properties, x0, y0, samples, per_sample, dt, label)
        if key.startswith("sim"):
            # SIM runs are short: timed again unsampled (same seed, so the same work) and the minimum kept, which is
            # the least disturbed by other jobs on the machine.
            r["wall_s_sampled_run"] = r["wall_s"]
            def start():
                integrator = make()
                return start_context(system, integrator, 0.0, initial_positions(n_copies, x0, y0),
                                     platform=args.platform, properties=properties), integrator
            r["wall_s"] = min(r["wall_s"], best_time(start, samples * per_sample, 2)[0])
            r["us_per_step"] = 1e6 * r["wall_s"] / r["steps"]
        r.update(label=label, copies=n_copies, times=np.arange(samples + 1) * per_sample * dt, every=every)
        results[key] = r

    references = [k for k in ("gla", "gla_fine") if k in results]
    comparison = {}
    for key in results:
        for ref in references:
            if key == ref or (key == "gla_fine"):
                continue
            comparison[f"{key} vs {ref}"] = compare_runs(results[key], results[ref])
    gla_wall_per_time = results["gla"]["wall_s"] / (results["gla"]["steps"] * h)
    speedups = {key: gla_wall_per_time * r["steps"] * r["step"] / r["wall_s"] for key, r in results.items()}

    # GLA's own discretization error in the fast phase: symplectic Euler turns omega into 2 asin(omega h/2)/h, so
    # the (slowly decaying) initial stiff oscillation drifts in phase.
    omega_d = math.sqrt(omega ** 2 - c ** 2 / 4)
    gla_phase = {key: (2 * math.asin(omega * results[key]["step"] / 2) / results[key]["step"] - omega_d) * sim_end
                 for key in references}

    print_tables(results, comparison, speedups, gla_phase)
    data = {
        "scene": "SIM paper section 4.1, Fig. 2: wall - stiff spring - x - soft quartic spring - y, Langevin",
        "model": "one particle per realization: x,y coordinates = paper's x,y; stiff CustomExternalForce "
                 "0.5*w2*x^2 (group 1), soft CustomExternalForce 0.25*(y-x)^4 (group 0); isotropic friction/noise",
        "platform": args.platform,
        "openmm_version": mm.__version__,
        "parameters": {"omega": omega, "c": c, "beta": beta, "kT_kJ_per_mol": kT, "temperature_K": temperature,
                       "x0": x0, "y0": y0, "copies": copies, "fine_copies": fine_copies, "T": sim_end, "H": H,
                       "omega_H_over_pi": omega * H / math.pi, "gla_h": h, "gla_substeps_per_H": substeps,
                       "fine_factor": args.fine_factor, "sim_steps_in_h": sim_steps, "gla_sample_every": gla_every,
                       "quick": args.quick, "first_seed": args.seed},
        "runs": {key: {"label": r["label"], "copies": r["copies"], "step": r["step"], "steps": r["steps"],
                       "wall_s": r["wall_s"], "first_step_s": r["first_step_s"], "us_per_step": r["us_per_step"],
                       "speedup_vs_gla": speedups[key],
                       "moments_at_T": {name: [float(r["mean"][-1, j]), float(r["se"][-1, j])]
                                        for j, name in enumerate(MOMENTS)}}
                 for key, r in results.items()},
        "comparison": {pair: {k: v for k, v in comp.items() if k not in ("z", "t")}
                       for pair, comp in comparison.items()},
        "gla_fast_phase_error_at_T_rad": gla_phase,
        "series": {"moments": MOMENTS,
                   **{key: {"t": r["times"].tolist(), "mean": r["mean"].tolist(), "se": r["se"].tolist()}
                      for key, r in results.items()}},
    }
    reporting.save_outputs(args.out, "sim_two_springs", data,
                       lambda png_path: plot(results, comparison, data["parameters"], args.platform, png_path))


def compare_runs(a, b):
    """z-scores of a - b at a's sample times (which are b's every (a.every/b.every)-th); t = 0 excluded."""
    stride = a["every"] // b["every"]
    count = len(a["times"])
    other = {"mean": b["mean"][::stride][:count], "se": b["se"][::stride][:count]}
    if len(other["mean"]) != count:
        raise RuntimeError("sample times do not line up")
    z = compare(a, other)
    zpos = z[:, :len(POSITION_MOMENTS)]
    threshold = bonferroni_threshold(zpos.size)
    return {
        "moments": {name: {"max_abs_z": float(np.max(np.abs(z[:, j]))),
                           "rms_z": float(np.sqrt(np.mean(z[:, j] ** 2))),
                           "fraction_abs_z_below_2": float(np.mean(np.abs(z[:, j]) < 2.0)),
                           "z_at_T": float(z[-1, j]),
                           "difference_at_T": float(a["mean"][-1, j] - other["mean"][-1, j]),
                           "sampling_error_at_T": float(math.hypot(a["se"][-1, j], other["se"][-1, j]))}
                    for j, name in enumerate(MOMENTS)},
        "positions": {"max_abs_z": float(np.max(np.abs(zpos))),
                      "fraction_abs_z_below_2": float(np.mean(np.abs(zpos) < 2.0)),
                      "comparisons": int(zpos.size), "bonferroni_1pct_threshold": threshold,
                      "agree": bool(np.max(np.abs(zpos)) <= threshold)},
        "z": z,
        "t": a["times"][1:],
    }


def print_tables(results, comparison, speedups, gla_phase):
    print("\nTwo-spring Langevin system.  Wall time: integrator.step() only (the first step, which measures the stiff "
          "modes, is included and also shown alone;\nSIM: minimum of the sampled run and two unsampled repeats); "
          "speedup = GLA (h) wall time for the same simulated time and ensemble size / wall time.")
    head = f"{'method':52s} {'copies':>6s} {'step':>9s} {'steps':>7s} {'wall s':>8s} {'1st step s':>10s} " \
           f"{'us/step':>9s} {'speedup':>8s}"
    print(head)
    print("-" * len(head))
    for key, r in results.items():
        speed = f"{speedups[key]:7.1f}x" if r["copies"] == results["gla"]["copies"] else "      -"
        print(f"{r['label']:52s} {r['copies']:6d} {r['step']:9.4g} {r['steps']:7d} {r['wall_s']:8.3f} "
              f"{r['first_step_s']:10.4f} {r['us_per_step']:9.1f} {speed}")

    print("\nMoments at the last sample time (mean +- standard error of the ensemble mean)")
    head = f"{'method':28s} {'t':>7s} " + " ".join(f"{name:>21s}" for name in MOMENTS)
    print(head)
    print("-" * len(head))
    for key, r in results.items():
        print(f"{key:28s} {r['times'][-1]:7.3f} " +
              " ".join(f"{r['mean'][-1, j]:10.3e}+-{r['se'][-1, j]:8.1e}" for j in range(len(MOMENTS))))

    print("\nz = (A - B)/combined standard error at every sample time of A (t = 0 excluded): max|z| per moment.  "
          "Positions agree if max|z| over the four\nposition moments <= the Bonferroni 1% family-wise threshold "
          "(samples are correlated in time, so it is conservative).  Momentum moments are shown\nfor information: "
          "SIM's error in p is not uniform in omega.")
    head = f"{'A vs B':44s} " + " ".join(f"{name:>8s}" for name in MOMENTS) + \
           f" {'thresh':>7s} {'|z|<2':>6s}  positions"
    print(head)
    print("-" * len(head))
    for pair, comp in comparison.items():
        p = comp["positions"]
        print(f"{pair:44s} " + " ".join(f"{comp['moments'][name]['max_abs_z']:8.2f}" for name in MOMENTS) +
              f" {p['bonferroni_1pct_threshold']:7.2f} {100 * p['fraction_abs_z_below_2']:5.1f}%  "
              f"{'AGREE' if p['agree'] else 'DIFFER'}")
    print("\nGLA's own error in the phase of the stiff oscillation at the end (symplectic Euler's frequency "
          "2 asin(omega h/2)/h against the damped omega): " +
          ", ".join(f"{key} {value:.3f} rad" for key, value in gla_phase.items()) +
          "; it shows in E[x] while the initial oscillation lasts.")


def plot(results, comparison, parameters, platform, path):
    from matplotlib.lines import Line2D
    plt = reporting.pyplot()

    palette = {"gla": "k", "gla_fine": "tab:gray", "sim_lietrotter": "tab:red", "sim_strang": "tab:blue",
               "sim_lietrotter_nonresonant": "tab:orange", "sim_strang_nonresonant": "tab:cyan"}
    styles = {"gla": "-", "gla_fine": "-", "sim_lietrotter": "--", "sim_strang": "--",
              "sim_lietrotter_nonresonant": ":", "sim_strang_nonresonant": ":"}
    fig, axes = plt.subplots(2, 3, figsize=(17, 11.5))
    fig.suptitle(f"Two-spring Langevin system (SIM paper Fig. 2): moments from StochasticImpulseIntegrator (SIM) "
                 f"against GLA, {parameters['copies']} realizations in one System, {platform} platform\n"
                 f"ω = {parameters['omega']:g} ps⁻¹, friction γ (the paper's c) = {parameters['c']:g} ps⁻¹, "
                 f"β = {parameters['beta']:g} mol/kJ; resonant SIM step H = {parameters['H']:.4g} ps "
                 f"(ωH = {parameters['omega_H_over_pi']:g}π), GLA step h = {parameters['gla_h']:.4g} ps "
                 f"(dimensionless units: 1 amu, 1 nm, 1 ps)", fontsize=11)
    panels = [(0, "E[x]", "E[x] (nm)"), (1, "E[y]", "E[y] (nm)"), (2, "E[x²]", "E[x²] (nm²)"),
              (3, "E[y²]", "E[y²] (nm²)"), (4, "E[p_x²]", "E[p_x²] (amu² nm² ps⁻²)")]
    # GLA is drawn at the SIM sample times (stroboscopically): sampled densely, the stiff oscillation fills the panels.
    sim_keys = [k for k in results if k.startswith("sim")]
    strobe = {}
    for key in sim_keys:
        stride = results[key]["every"] // results["gla"]["every"]
        tag = "nonresonant" if key.endswith("nonresonant") else "resonant"
        strobe[tag] = (stride, len(results[key]["times"]))
    for ax, (j, name, ylabel) in zip(axes.flat, panels):
        for key, r in results.items():
            if key.startswith("gla"):
                for tag, (stride, count) in strobe.items():
                    t, m, s = r["times"][::stride][:count], r["mean"][::stride][:count, j], r["se"][::stride][:count, j]
                    ax.plot(t, m, color=palette[key], lw=1.2 if tag == "resonant" else 0.8,
                            ls="-" if tag == "resonant" else (0, (1, 1)),
                            label=f"{reporting.greek(r['label'])} at {tag} SIM times")
                    ax.fill_between(t, m - 2 * s, m + 2 * s, color=palette[key], alpha=0.15, lw=0)
                continue
            m, s = r["mean"][:, j], r["se"][:, j]
            ax.plot(r["times"], m, color=palette.get(key, "gray"), ls=styles.get(key, "-"), lw=1.3, marker=".", ms=3,
                    label=reporting.greek(r["label"]))
            ax.fill_between(r["times"], m - 2 * s, m + 2 * s, color=palette.get(key, "gray"), alpha=0.15, lw=0)
        ax.set_title(f"{name} (bands: ±2 standard errors)", fontsize=10)
        if j == 4:
            ax.set_yscale("log")
        ax.set_xlabel("t (ps)")
        ax.set_ylabel(ylabel)
    # One legend for the five moment panels, below them: inside, it hid curves.
    fig.legend(*axes[0, 1].get_legend_handles_labels(), fontsize=8.5, loc="lower center",
               bbox_to_anchor=(0.36, 0.0), ncol=2, frameon=False, title="methods", title_fontsize=9)
    ax = axes.flat[5]
    markers = "ox+."
    reference = "gla_fine" if "gla_fine" in results else "gla"
    for pair, comp in comparison.items():
        if not pair.endswith(f"vs {reference}") or pair.startswith("gla"):
            continue
        key = pair.split(" vs ")[0]
        for j, name in enumerate(POSITION_MOMENTS):
            ax.plot(comp["t"], comp["z"][:, j], color=palette.get(key, "gray"), marker=markers[j], ms=3, ls="none")
    thresholds = sorted({round(comp["positions"]["bonferroni_1pct_threshold"], 2) for comp in comparison.values()})
    for level in [2.0, thresholds[0]]:
        ax.axhline(level, color="gray", lw=0.6, ls="--")
        ax.axhline(-level, color="gray", lw=0.6, ls="--")
    ax.set_yscale("symlog", linthresh=5)
    ax.set_title(f"z = (SIM − {reporting.greek(results[reference]['label'])}) / standard error, position moments\n"
                 f"(dashed: |z| = 2 and the Bonferroni 1 % threshold {thresholds[0]:g}; colour: method)", fontsize=9)
    ax.set_xlabel("t (ps)")
    ax.set_ylabel("z (dimensionless; symmetric log scale)")
    names = [n.replace("^2", "²") for n in POSITION_MOMENTS]
    ax.legend(handles=[Line2D([], [], color="0.3", marker=mk, ls="none", label=n) for mk, n in zip(markers, names)],
              fontsize=8.5, loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=4, frameon=False,
              title="marker: moment", title_fontsize=9)
    fig.tight_layout(rect=(0, 0.12, 1, 0.97))
    reporting.save_figure(fig, path, 110)


if __name__ == "__main__":
    main()
