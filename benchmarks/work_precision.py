#!/usr/bin/env python3
"""Work-precision benchmark on the Fermi-Pasta-Ulam chain: error against cost for every integrator, in one run.

The chain is eq. (6.7) of the FLAVORS paper with m = 3 stiff springs (flavorbench.systems.fpu_system), on OpenMM's
Reference platform:
- omega = 50 from the Hairer-Lubich-Wanner start (x0,1 = 1, y0,1 = 1, x1,1 = 1/omega, y1,1 = 1),
- omega = 200 and 1000 from the start of the FLAVORS paper's Fig. 6.5 (x0 = (1,0,0), x1 = (1/omega,0,0), y = 0).

Methods, each over a sweep of its step sizes: OpenMM's VerletIntegrator; r-RESPA (openmm.mtsintegrator.MTSIntegrator,
soft group outer, stiff group inner); FlavorIntegrator, Verlet and SymplecticEuler schemes, two sweeps each (tau
fixed at 0.1/omega with delta = k tau, and tau/delta = 1/8 fixed with delta varied); StochasticImpulseIntegrator
LieTrotter, Strang and Yoshida4 with friction 0.  SIM and r-RESPA outer steps are nudged away from omega*H = k pi.

Checkpoints T: omega = 50 at T = omega = 50; omega = 200 at T = 100 and T = omega = 200; omega = 1000 at T = 100 and
200 (--T OMEGA=T,... changes them).  The paper-start chain is chaotic beyond t ~ 100: a 1e-10 change of x0,1 grows
to ~3e-6 by t = 200 at omega = 200 and ~2e-7 to 7e-7 at omega = 1000, and two high-accuracy reference runs at
omega = 1000 disagree by O(1) from t ~ 400 on, so T = omega = 1000 cannot be computed by anyone; the first
checkpoint of each omega is the one the cost-vs-omega chart uses, and the table flags chaotic checkpoints.

Reference: SciPy's DOP853 at rtol 1e-12 (flavorbench.reference), independent of OpenMM and of this plugin, run again
at rtol 1e-10; the difference of the two runs bounds its error and is reported.  A second chain from x0,1 + 1e-10,
integrated alongside the reference with the same steps, measures how much the chain amplifies a perturbation by each
checkpoint.

Errors at each checkpoint T, pointwise (the maximum over the samples of the window [T - W, T], W = 1: the error at
one instant can be lucky, as it oscillates through zero; the value at T alone is in the JSON) and of the window mean:
- slow: |x0,1 - x0,1_ref| / max_t |x0,1_ref| (the slow variable's amplitude, so a zero crossing does not inflate it),
- stiff: max_j |I_j - I_j,ref| / sum_j I_j,ref with I_j = (y1_j^2 + omega^2 x1_j^2)/2 from the state; also, averaged
  only, with omega^2 x1_j^2 in place of I_j (from positions alone).  FLAVOR's fast velocities are scaled by
  sqrt(tau/delta), so its I_j from the state is biased even on average; the ratio sum <y1^2> / sum <omega^2 x1^2>
  (1 for a resolving method) is reported for every run.
Cost: force-group evaluations (an all-groups evaluation counts once per group: Verlet 1 soft + 1 stiff per step;
FLAVOR Verlet 2 soft + 1 all = 3 soft + 1 stiff; FLAVOR SymplecticEuler 2 soft + 1 stiff; SIM LieTrotter and
Strang 1 soft, Yoshida4 3 soft, and no stiff evaluation; MTSIntegrator with n inner steps 1 soft + (n + 1) stiff,
because OpenMM's CustomIntegrator caches forces of one group set only), soft evaluations alone, and the wall time
of the integrator.step() calls.

The tables: per method and checkpoint, the run with the fewest force-group evaluations whose slow error is <= 1e-2
(and, second table, whose window-mean stiff-energy error is <= 1e-2 too), with speedups over the cheapest Verlet and
r-RESPA runs.

    PYTHONPATH=build/python .venv/bin/python benchmarks/work_precision.py            # full, ~4-7 min
    PYTHONPATH=build/python .venv/bin/python benchmarks/work_precision.py --demo     # omega 50, 200 at short T, ~15 s
    PYTHONPATH=build/python .venv/bin/python benchmarks/work_precision.py --quick    # seconds (smoke test)
"""
import json
import math
import os
import textwrap
import time
import warnings

import numpy as np
import openmm as mm

from flavorbench import reporting
from flavorbench.progress import Progress
from flavorbench.reference import reference
from flavorbench.runners import flavor, mts, sim, simulate
from flavorbench.systems import SQRT2, as_vec3, fpu_energy, fpu_initial, fpu_system, observables
from openmmflavors import ResonanceWarning
M = 3
TOL = 1e-2
DOCS_DPI = 70
CHAOS = 100.0  # perturbation amplification by T above which the table flags the checkpoint as chaotic

METHODS = {
    # key: label, color, marker
    "verlet": ("Verlet (VerletIntegrator)", "k", "o"),
    "rrespa": ("r-RESPA (MTSIntegrator)", "tab:blue", "s"),
    "flavor_verlet": ("FLAVOR Verlet", "tab:red", "^"),
    "flavor_euler": ("FLAVOR SymplecticEuler", "tab:orange", "v"),
    "sim_lietrotter": ("SIM LieTrotter", "tab:olive", "D"),
    "sim_strang": ("SIM Strang", "tab:green", "P"),
    "sim_yoshida4": ("SIM Yoshida4", "tab:purple", "X"),
}

# Step grids.  Verlet and FLAVOR are set by the stiff frequency (in units of 1/omega); SIM and r-RESPA outer steps
# by the soft forces (absolute).
FULL_SWEEPS = {
    "verlet_wh": [0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 1.5, 1.9],
    "outer_H": [0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2],
    "rrespa_inner_wh": [0.2, 1.0],
    "flavor_tau_w": 0.1, "flavor_k": [1, 2, 4, 8, 16, 32, 64, 128],
    "flavor_ratio": 1 / 8, "flavor_delta_w": [0.5, 1.0, 2.0, 3.0, 4.0, 5.0],
}
QUICK_SWEEPS = {
    "verlet_wh": [0.1, 1.0], "outer_H": [0.005, 0.05], "rrespa_inner_wh": [0.5],
    "flavor_tau_w": 0.1, "flavor_k": [2, 8], "flavor_ratio": 1 / 8, "flavor_delta_w": [2.0],
}
# omega: (initial condition, checkpoints; the first is the primary one, the others integer multiples of it)
FULL_CASES = {50.0: ("hlw", [50.0]), 200.0: ("paper", [100.0, 200.0]), 1000.0: ("paper", [100.0, 200.0])}
DEMO_CASES = {50.0: ("hlw", [20.0]), 200.0: ("paper", [40.0])}
QUICK_CASES = {50.0: ("hlw", [4.0])}
WINDOW, WINDOW_SAMPLES = 1.0, 200
START = {"hlw": "Hairer–Lubich–Wanner start", "paper": "start of FLAVORS Fig. 6.5"}


def snap(step, T0):
    """The step nearest to `step` that divides T0."""
    return T0 / max(1, round(T0 / step))


def nonresonant(step, omega, margin=0.25):
    """step nudged so that omega*step is at least margin*pi away from every positive multiple of pi (impulse methods
    resonate there; SIM paper section 3.3, README 'Which integrator when')."""
    k = round(omega * step / math.pi)
    if k >= 1 and abs(omega * step - k * math.pi) < margin * math.pi:
        low, high = (k - margin) * math.pi / omega, (k + margin) * math.pi / omega
        step = low if step - low <= high - step else high
    return step


def build_runs(omega, T0, sweeps):
    """Every run of every method for one omega: dicts with the integrator factory and its costs per step."""
    runs = []

    def add(method, sweep, params, step, make, soft, stiff, leapfrog=False):
        runs.append({"method": method, "sweep": sweep, "params": params, "step": step, "make": make, "soft": soft,
                     "stiff": stiff, "leapfrog": leapfrog})

    for wh in sweeps["verlet_wh"]:
        h = snap(wh / omega, T0)
        add("verlet", "h", {"h": h, "omega_h": omega * h}, h, lambda h=h: mm.VerletIntegrator(h), 1, 1, True)
    for inner in sweeps["rrespa_inner_wh"]:
        for H in sweeps["outer_H"]:
            H = snap(nonresonant(H, omega), T0)
            n = max(1, math.ceil(omega * H / inner - 1e-9))
            add("rrespa", f"inner omega*h <= {inner:g}", {"H": H, "omega_H": omega * H, "inner_steps": n,
                                                          "omega_h_inner": omega * H / n},
                H, lambda H=H, n=n: mts(H, n), 1, n + 1)
    for key, scheme, soft in (("flavor_verlet", "Verlet", 3), ("flavor_euler", "SymplecticEuler", 2)):
        tau0 = sweeps["flavor_tau_w"] / omega
        for k in sweeps["flavor_k"]:
            delta = snap(k * tau0, T0)
            tau = delta / k
            add(key, f"tau = {sweeps['flavor_tau_w']:g}/omega", {"delta": delta, "tau": tau, "delta_over_tau": k,
                                                                 "omega_tau": omega * tau,
                                                                 "delta_tau_omega2": delta * tau * omega ** 2},
                delta, lambda d=delta, t=tau, s=scheme: flavor(d, t, s), soft, 1)
        ratio = sweeps["flavor_ratio"]
        for dw in sweeps["flavor_delta_w"]:
            delta = snap(dw / omega, T0)
            tau = delta * ratio
            add(key, f"tau/delta = {ratio:g}", {"delta": delta, "tau": tau, "delta_over_tau": 1 / ratio,
                                                "omega_tau": omega * tau, "delta_tau_omega2": delta * tau * omega ** 2},
                delta, lambda d=delta, t=tau, s=scheme: flavor(d, t, s), soft, 1)
    for key, splitting, soft in (("sim_lietrotter", "LieTrotter", 1), ("sim_strang", "Strang", 1),
                                 ("sim_yoshida4", "Yoshida4", 3)):
        for H in sweeps["outer_H"]:
            H = snap(nonresonant(H, omega), T0)
            add(key, "H", {"H": H, "omega_H": omega * H}, H, lambda H=H, s=splitting: sim(H, s), soft, 0)
    return runs


def sample_plan(step, checkpoints):
    """Step counts to sample at: the window before each checkpoint (about WINDOW_SAMPLES samples on the run's own step
    grid) and the checkpoint itself.  Returns (sorted steps, {checkpoint: (index of T, indices of the window)})."""
    per = {}
    steps = set()
    for T in checkpoints:
        n = int(round(T / step))
        window = min(WINDOW, T / 10)
        stride = max(1, int(round(window / WINDOW_SAMPLES / step)))
        count = int(math.floor(window / (stride * step) + 1e-9))
        w = [n - j * stride for j in range(count + 1)]
        per[T] = (n, w)
        steps.update(w)
    ordered = np.array(sorted(steps), dtype=np.int64)
    where = {s: i for i, s in enumerate(ordered)}
    return ordered, {T: (where[n], np.array([where[s] for s in w])) for T, (n, w) in per.items()}


def key_time(t):
    return round(float(t), 11)


def errors_at(obs, ref, iT, iw, amplitude):
    """The error measures of one run at one checkpoint (obs, ref: observables at the run's sample times)."""
    e = {}
    e["slow_T"] = abs(obs["x0"][iT, 0] - ref["x0"][iT, 0]) / amplitude
    e["slow_Tmax"] = np.max(np.abs(obs["x0"][iw, 0] - ref["x0"][iw, 0])) / amplitude
    e["slow_avg"] = abs(obs["x0"][iw, 0].mean() - ref["x0"][iw, 0].mean()) / amplitude
    e["stiff_T"] = np.max(np.abs(obs["I"][iT] - ref["I"][iT])) / ref["I"][iT].sum()
    e["stiff_Tmax"] = np.max(np.max(np.abs(obs["I"][iw] - ref["I"][iw]), axis=1) / ref["I"][iw].sum(axis=1))
    ref_mean = ref["I"][iw].mean(axis=0)
    e["stiff_avg"] = np.max(np.abs(obs["I"][iw].mean(axis=0) - ref_mean)) / ref_mean.sum()
    e["stiff_avg_positions"] = np.max(np.abs(obs["Ix"][iw].mean(axis=0) - ref_mean)) / ref_mean.sum()
    e["velocity_bias"] = (obs["y1"][iw] ** 2).mean(axis=0).sum() / obs["Ix"][iw].mean(axis=0).sum()
    e["I_T"] = obs["I"][iT].tolist()
    e["I_avg"] = obs["I"][iw].mean(axis=0).tolist()
    e["omega2_x1sq_avg"] = obs["Ix"][iw].mean(axis=0).tolist()
    return {k: (float(v) if not isinstance(v, list) else v) for k, v in e.items()}


def run_case(omega, setup, checkpoints, sweeps, progress, rtol, check_rtol):
    system = fpu_system(M, omega)
    q0, v0 = fpu_initial(M, omega, setup)
    T0, T_end = checkpoints[0], checkpoints[-1]
    runs = build_runs(omega, T0, sweeps)
    for run in runs:
        run["sample_steps"], run["plan"] = sample_plan(run["step"], checkpoints)
        run["times"] = run["sample_steps"] * run["step"]

    # The reference at every sample time of every run, and on a coarse grid for the slow variable's amplitude.
    coarse = np.arange(1, int(round(T_end / 0.05)) + 1) * 0.05
    all_times = sorted({key_time(t) for run in runs for t in run["times"]} | {key_time(t) for t in coarse})
    all_times = np.array([t for t in all_times if t > 0])
    # With a second chain from x0,1 + 1e-10, integrated alongside: how much the chain amplifies a perturbation.
    perturbation = np.zeros_like(q0)
    perturbation[:2] = 1e-10 / SQRT2  # x0,1 = (q2 + q1)/sqrt2 moves by 1e-10
    ref = reference(q0, v0, omega, all_times, rtol, check_rtol, perturbation)
    progress.step(f"omega={omega:g} reference ({ref['wall_s'] + ref['check_wall_s']:.1f} s)")
    index = {t: i for i, t in enumerate(all_times)}

    def ref_at(times):
        rows = [index[key_time(t)] for t in times]
        return ref["q"][rows], ref["v"][rows], ref["q_check"][rows], ref["q_perturbed"][rows]

    ref_info = {"method": ref["method"], "wall_s": ref["wall_s"] + ref["check_wall_s"], "samples": len(all_times),
                "checkpoints": {}}
    amplitude = {}
    for T in checkpoints:
        q, v, qc, qp = ref_at([T])
        obs, chk, per = observables(q, v, omega), observables(qc, v, omega), observables(qp, v, omega)
        cq = ref_at(coarse[coarse <= T + 1e-9])[0]
        amplitude[T] = float(np.max(np.abs(observables(cq, cq, omega)["x0"][:, 0])))
        ref_info["checkpoints"][f"{T:g}"] = {
            "x0_1": float(obs["x0"][0, 0]), "I": obs["I"][0].tolist(),
            "self_check_x0_1": float(abs(obs["x0"][0, 0] - chk["x0"][0, 0])),
            "self_check_q_max": float(np.max(np.abs(q - qc))), "slow_amplitude": amplitude[T],
            "energy": float(fpu_energy(q[0], v[0], omega)), "energy_0": float(fpu_energy(q0, v0, omega)),
            "perturbation_1e-10_amplification": float(abs(per["x0"][0, 0] - obs["x0"][0, 0]) / 1e-10)}

    results = []
    for run in runs:
        label, _, _ = METHODS[run["method"]]
        desc = ", ".join(f"{k}={v:.4g}" for k, v in run["params"].items())
        r = simulate(system, run["make"](), run["step"], as_vec3(q0), as_vec3(v0), run["times"], label, run["leapfrog"],
                     progress=False, warm_up=True, blowup=1e6)
        qs, finite, walls = r["q"][:, :, 0], r["finite"], r["walls"]
        obs = observables(qs, r["v"][:, :, 0], omega)
        rq, rv = ref_at(run["times"])[:2]
        robs = observables(rq, rv, omega)
        entry = {"method": run["method"], "label": label, "sweep": run["sweep"], "params": run["params"],
                 "step": run["step"], "soft_per_step": run["soft"], "stiff_per_step": run["stiff"],
                 "finite": bool(finite), "warm_up_step_s": r["warm_up_s"], "checkpoints": {}}
        for T in checkpoints:
            iT, iw = run["plan"][T]
            n = int(run["sample_steps"][iT])
            c = {"steps": n, "soft_evals": n * run["soft"], "stiff_evals": n * run["stiff"],
                 "group_evals": n * (run["soft"] + run["stiff"]), "wall_s": float(walls[iT])}
            ok = np.all(np.isfinite(qs[iw])) and np.all(np.isfinite(qs[iT]))
            if ok:
                c.update(errors_at(obs, robs, iT, iw, amplitude[T]))
            else:
                c.update({k: math.inf for k in ("slow_T", "slow_Tmax", "slow_avg", "stiff_T", "stiff_Tmax", "stiff_avg",
                                                "stiff_avg_positions")})
                c["blew_up"] = True
            entry["checkpoints"][f"{T:g}"] = c
        results.append(entry)
        last = entry["checkpoints"][f"{T0:g}"]
        progress.step(f"omega={omega:g} {label} {desc}: slow err {last['slow_Tmax']:.2e} "
                      f"({last['group_evals']} evals, {last['wall_s']:.2f} s)")
    return {"omega": omega, "setup": setup, "checkpoints": checkpoints, "reference": ref_info, "runs": results}


def finite(x):
    return x is not None and math.isfinite(x)


def value(x):
    """An error from the JSON, where a blown-up run's is None."""
    return math.inf if x is None else x


def slow_ok(c):
    return finite(c["slow_Tmax"]) and c["slow_Tmax"] <= TOL


def slow_and_stiff_ok(c):
    return slow_ok(c) and finite(c["stiff_avg"]) and c["stiff_avg"] <= TOL


def best_runs(case, T, accept=slow_ok):
    """Per method: the run with the fewest force-group evaluations whose slow error (pointwise, the maximum over the
    final window: a single time can be lucky, as the error oscillates through zero) is <= TOL, and the most accurate
    run (for a method with none under TOL)."""
    out = {}
    for method in METHODS:
        mine = [r for r in case["runs"] if r["method"] == method]
        good = [r for r in mine if accept(r["checkpoints"][T])]
        best = min(good, key=lambda r: (r["checkpoints"][T]["group_evals"], r["checkpoints"][T]["wall_s"])) \
            if good else None
        ran = [r for r in mine if finite(r["checkpoints"][T]["slow_Tmax"])]
        closest = min(ran, key=lambda r: r["checkpoints"][T]["slow_Tmax"]) if ran else None
        out[method] = (best, closest)
    return out


def describe(run):
    p = run["params"]
    m = run["method"]
    if m == "verlet":
        return f"h={p['h']:.3g} (wh={p['omega_h']:.3g})"
    if m == "rrespa":
        return f"H={p['H']:.3g} (wH={p['omega_H']:.3g}), {p['inner_steps']} inner"
    if m.startswith("flavor"):
        return f"d={p['delta']:.3g}, t={p['tau']:.3g} (d/t={p['delta_over_tau']:.3g}, wt={p['omega_tau']:.2g})"
    return f"H={p['H']:.3g} (wH={p['omega_H']:.3g})"


def make_table(cases, accept=slow_ok):
    rows = []
    for case in cases:
        for T in case["checkpoints"]:
            key = f"{T:g}"
            best = best_runs(case, key, accept)
            base = {}
            for ref_method in ("verlet", "rrespa"):
                b = best[ref_method][0]
                base[ref_method] = (b["checkpoints"][key]["group_evals"], b["checkpoints"][key]["wall_s"]) if b \
                    else None
            for method, (run, closest) in best.items():
                row = {"omega": case["omega"], "setup": case["setup"], "T": T, "method": method,
                       "label": METHODS[method][0],
                       "amplification": case["reference"]["checkpoints"][key].get("perturbation_1e-10_amplification")}
                if run is None:
                    row["run"] = None
                    if closest is not None:
                        c = closest["checkpoints"][key]
                        row["closest"] = {"params": closest["params"], "description": describe(closest),
                                          "slow_Tmax": c["slow_Tmax"], "group_evals": c["group_evals"]}
                    row["verdict"] = "no run reached the accuracy"
                    rows.append(row)
                    continue
                c = run["checkpoints"][key]
                row.update({"run": run["params"], "description": describe(run), "slow_Tmax": c["slow_Tmax"],
                            "slow_T": c["slow_T"], "slow_avg": c["slow_avg"], "stiff_avg": c["stiff_avg"],
                            "group_evals": c["group_evals"],
                            "soft_evals": c["soft_evals"], "wall_s": c["wall_s"]})
                for ref_method in ("verlet", "rrespa"):
                    if base[ref_method]:
                        row[f"speedup_evals_vs_{ref_method}"] = base[ref_method][0] / c["group_evals"]
                        row[f"speedup_wall_vs_{ref_method}"] = base[ref_method][1] / max(c["wall_s"], 1e-9)
                if method.startswith(("flavor", "sim")):
                    losses = [n for n in ("verlet", "rrespa") if row.get(f"speedup_evals_vs_{n}", math.inf) < 1]
                    if not base["verlet"] and not base["rrespa"]:
                        row["verdict"] = "wins: neither Verlet nor r-RESPA reached the accuracy"
                    elif losses:
                        row["verdict"] = "LOSES to " + " and ".join("Verlet" if n == "verlet" else "r-RESPA"
                                                                     for n in losses) + " (force evaluations)"
                    else:
                        row["verdict"] = "wins"
                rows.append(row)
    return rows


def markdown_table(rows, also=""):
    lines = [f"| omega (start, T) | method | cheapest run with slow error <= {TOL:g} {also} | slow err | "
             "stiff err (mean) | force-group evals | soft evals | wall s | speedup vs Verlet (evals / wall) | "
             "speedup vs r-RESPA (evals / wall) | verdict |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        amp = r.get("amplification")
        chaos = f"; chaotic: 1e-10 grows x{amp:.1e}" if amp is not None and amp > CHAOS else ""
        head = f"| {r['omega']:g} ({r['setup']}, T={r['T']:g}{chaos}) | {r['label']} "
        if r["run"] is None:
            closest = r.get("closest")
            text = (f"none (best: {closest['slow_Tmax']:.1e} at {closest['description']}, "
                    f"{closest['group_evals']:.3g} evals)") if closest else "none (all blew up)"
            lines.append(head + f"| {text} | | | | | | | | {r['verdict']} |")
            continue

        def sp(name):
            if f"speedup_evals_vs_{name}" not in r:
                return "n/a"
            return f"{r[f'speedup_evals_vs_{name}']:.2g}x / {r[f'speedup_wall_vs_{name}']:.2g}x"

        lines.append(head + f"| {r['description']} | {r['slow_Tmax']:.1e} | {r['stiff_avg']:.1e} | "
                            f"{r['group_evals']:.3g} | {r['soft_evals']:.3g} | {r['wall_s']:.3g} | {sp('verlet')} | "
                            f"{sp('rrespa')} | {r.get('verdict', '')} |")
    return "\n".join(lines)


CHARTS = ("work_precision_slow.png", "work_precision_stiff.png", "work_precision_cost.png")
MEASURES = {"slow": "slow variable x₀,₁: relative error", "stiff": "stiff energies I_j: relative error"}


def plot_all(cases, rows, folder, dpi, small=False):
    """The three charts: error against cost of the slow variable, of the stiff energies, and cost against omega."""
    for measure in MEASURES:
        plot_errors(cases, measure, os.path.join(folder, f"work_precision_{measure}.png"), dpi, small)
    plot_cost(cases, rows, os.path.join(folder, "work_precision_cost.png"), dpi, small)


def method_handles():
    from matplotlib.lines import Line2D
    return [Line2D([], [], color=color, marker=marker, ms=5, lw=1, label=label)
            for label, color, marker in METHODS.values()]


def front(runs, key, field):
    """(cost, error) of the runs that no cheaper run beats (the method's lower envelope over its sweeps)."""
    points = sorted((r["checkpoints"][key]["group_evals"], value(r["checkpoints"][key][field])) for r in runs)
    out, best = [], math.inf
    for cost, error in points:
        if finite(error) and error < best:
            out.append((cost, error))
            best = error
    return out


def cheapest(rows, omega, T):
    """(label, evaluations, fewer than Verlet by) of the cheapest run at the tolerance, or None."""
    good = [r for r in rows if r["omega"] == omega and r["T"] == T and r["run"] is not None]
    if not good:
        return None
    best = min(good, key=lambda r: r["group_evals"])
    return METHODS[best["method"]][0], best["group_evals"], best.get("speedup_evals_vs_verlet")


def plot_errors(cases, measure, path, dpi, small=False):
    """One panel per stiff frequency omega at its first checkpoint T (the later ones are chaotic: in the JSON and the
    tables): each method's lower envelope of error against cost over its sweeps, the tolerance, and the cheapest run
    within it; the title says which method reaches the tolerance with the fewest force-group evaluations."""
    plt = reporting.pyplot()
    field = "slow_Tmax" if measure == "slow" else "stiff_avg"
    rows = make_table(cases, slow_ok if measure == "slow" else slow_and_stiff_ok)
    fig, axes = plt.subplots(1, len(cases), figsize=(6.2 * len(cases), 7.4), squeeze=False)
    verdicts = []
    for ax, case in zip(axes[0], cases):
        T = case["checkpoints"][0]
        key = f"{T:g}"
        lowest = 1.0
        for method, (label, color, marker) in METHODS.items():
            points = front([r for r in case["runs"] if r["method"] == method], key, field)
            if points:
                ax.loglog(*zip(*points), color=color, marker=marker, ms=6, lw=1.6, label=label)
                lowest = min(lowest, min(e for _, e in points))
        ax.axhline(TOL, color="gray", lw=1, ls="--", label=f"tolerance {TOL:g}")
        winner = cheapest(rows, case["omega"], T)
        if winner is not None:
            label, evaluations, fewer = winner
            run = next(r for r in rows if r["omega"] == case["omega"] and r["T"] == T and r["run"] is not None and
                       r["group_evals"] == evaluations)
            ax.plot(evaluations, run["slow_Tmax"] if measure == "slow" else run["stiff_avg"], "*", ms=18, mfc="none",
                    mec="black", mew=1.5, zorder=5)
            verdicts.append(f"ω = {case['omega']:g}: {label}" + (f", {fewer:.1f}× fewer than Verlet" if fewer else ""))
            ax.set_title(f"ω = {case['omega']:g} ps⁻¹, T = {T:g} ps\ncheapest within: {label}"
                         + (f" ({fewer:.1f}× fewer than Verlet)" if fewer else ""))
        else:
            verdicts.append(f"ω = {case['omega']:g}: none")
            ax.set_title(f"ω = {case['omega']:g} ps⁻¹, T = {T:g} ps\nno method within the tolerance")
        ax.set_ylim(max(lowest / 3, 1e-12), 3)
        ax.set_xlabel("cost: force-group evaluations to T")
        ax.grid(alpha=0.3, which="both", lw=0.3)
    axes[0][0].set_ylabel("slow variable x₀,₁: relative error at T" if measure == "slow" else
                          "stiff energies I_j: relative error of their mean")
    handles, labels = axes[0][0].get_legend_handles_labels()
    for ax in axes[0][1:]:  # a method missing from the first panel's lines
        for h, lab in zip(*ax.get_legend_handles_labels()):
            if lab not in labels:
                handles.append(h)
                labels.append(lab)
    handles.append(plt.Line2D([], [], ls="", marker="*", ms=14, mfc="none", mec="black"))
    labels.append("the cheapest run within the tolerance")
    width = fig.get_figwidth()
    fig.legend(handles, labels, loc="lower center", ncol=4, frameon=False, fontsize=11, bbox_to_anchor=(0.5, 0.085))
    what = ("slow variable: |x₀,₁ − x₀,₁(ref)| / max_t |x₀,₁(ref)|, the largest over [T − 1 ps, T]" if measure == "slow"
            else "stiff energies: max_j |⟨I_j⟩ − ⟨I_j(ref)⟩| / Σ_j ⟨I_j(ref)⟩, means over [T − 1 ps, T] "
                 f"(the ★ also has the slow error ≤ {TOL:g})")
    fig.text(0.5, 0.01, textwrap.fill(f"Error: {what}. Each line: a method's lowest error for its cost over its step "
                                      "sweeps; reference DOP853 (rtol 1e-12); each ω's later checkpoints (chaotic "
                                      "at T = 200 ps: every error O(1)) are in the JSON and the tables.",
                                      int(width * 12)), ha="center", va="bottom", fontsize=10)
    fig.suptitle(textwrap.fill("FPU toy chain (m = 3, Reference platform): the fewest force-group evaluations to a "
                               f"relative error ≤ {TOL:g} — " + "; ".join(verdicts), int(width * 9.5)), fontsize=12.5)
    fig.tight_layout(rect=(0, 0.2, 1, 0.93))
    reporting.save_figure(fig, path, max(dpi, 85), small)  # at least 85 dpi: the docs' copies stay readable


def plot_cost(cases, rows, path, dpi, small=False):
    """Cost at fixed accuracy against omega, per unit simulated time, at each omega's primary checkpoint."""
    plt = reporting.pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(14, 6.2))
    for ax, (field, name) in zip(axes, (("group_evals", "force-group evaluations per ps of simulated time"),
                                        ("wall_s", "wall time per ps of simulated time (s)"))):
        for method, (label, color, marker) in METHODS.items():
            pts = [(r["omega"], r[field] / r["T"]) for r in rows
                   if r["method"] == method and r["run"] is not None and
                   r["T"] == next(c["checkpoints"][0] for c in cases if c["omega"] == r["omega"])]
            if pts:  # markers only: a few ω, not a trend to read between them
                ax.loglog(*zip(*pts), color=color, marker=marker, ls="none", ms=8, label=label)
        ax.set_xlabel("stiff frequency ω (ps⁻¹)")
        ax.set_ylabel(name)
        ax.grid(alpha=0.3, which="both", lw=0.3)
    primary = ", ".join(f"ω = {c['omega']:g}: T = {c['checkpoints'][0]:g} ps" for c in cases)
    cheapest = []
    for c in cases:
        T = c["checkpoints"][0]
        costs = [(r["group_evals"] / r["T"], r["method"]) for r in rows
                 if r["omega"] == c["omega"] and r["run"] is not None and r["T"] == T]
        if costs:
            cheapest.append(f"ω = {c['omega']:g}: {METHODS[min(costs)[1]][0]}")
    fig.suptitle(textwrap.fill(f"FPU toy chain (6 particles, m = {M}, Reference platform): fewest force evaluations "
                               f"at slow error ≤ {TOL:g}: " + ("; ".join(cheapest) or "none reached it"), 110),
                 fontsize=12.5)
    fig.legend(handles=method_handles(), loc="lower center", ncol=4, fontsize=11, frameon=False,
               bbox_to_anchor=(0.5, 0.07))
    fig.text(0.5, 0.01, textwrap.fill(f"Each method's cheapest run at the first checkpoint of each ω ({primary}); a "
                                      "method missing at an ω reached the tolerance with none of its runs.", 140),
             ha="center", va="bottom", fontsize=10)
    fig.tight_layout(rect=(0, 0.2, 1, 0.9))
    reporting.save_figure(fig, path, max(dpi, 85), small)


def main():
    parser = reporting.parser(__doc__, "work_precision", quick_help="omega 50, T 4, two steps per method (smoke test)")
    parser.add_argument("--demo", action="store_true", help="omega 50 (T 20) and 200 (T 40), all methods, ~15 s")
    parser.add_argument("--T", action="append", default=[], metavar="OMEGA=T[,T2...]",
                        help="checkpoints for one omega, e.g. --T 1000=1000 (repeatable; adds the omega if new; "
                             "setup 'hlw' for omega 50, 'paper' otherwise)")
    parser.add_argument("--rtol", type=float, default=1e-12, help="reference DOP853 rtol")
    parser.add_argument("--rtol-check", type=float, default=1e-10, help="rtol of the reference's check run")
    parser.add_argument("--docs", default=None,
                        help="also write a small copy of the chart (dpi 70, 64 colours) to this folder")
    parser.add_argument("--replot", action="store_true",
                        help="run nothing: redraw the charts (and --docs copy) from OUT/work_precision.json")
    args = parser.parse_args()
    if args.demo and args.quick:
        parser.error("--demo and --quick exclude each other")
    if args.replot:
        with open(os.path.join(args.out, "work_precision.json")) as f:
            data = json.load(f)
        data["table"] = make_table(data["cases"])
        data["table_slow_and_stiff"] = make_table(data["cases"], slow_and_stiff_ok)
        plot_all(data["cases"], data["table"], args.out, 100)
        if args.docs:
            os.makedirs(args.docs, exist_ok=True)
            plot_all(data["cases"], data["table"], args.docs, DOCS_DPI, small=True)
        print(markdown_table(data["table"]))
        print()
        print(markdown_table(data["table_slow_and_stiff"], "and window-mean stiff-energy error (from the state)"))
        return
    cases = dict(DEMO_CASES if args.demo else QUICK_CASES if args.quick else FULL_CASES)
    for spec in args.T:
        w, ts = spec.split("=")
        w = float(w)
        cases[w] = ("hlw" if w == 50 else "paper", sorted(float(t) for t in ts.split(",")))
    sweeps = QUICK_SWEEPS if args.quick else FULL_SWEEPS
    for w, (_, cps) in cases.items():
        for T in cps:
            if abs(T / cps[0] - round(T / cps[0])) > 1e-9:
                raise SystemExit(f"checkpoints of omega={w:g} must be multiples of the first: {cps}")
    total = sum(len(build_runs(w, cps[0], sweeps)) + 1 for w, (_, cps) in cases.items())
    progress = Progress("work-precision", total, fmt="d")
    started = time.perf_counter()
    data = {"mode": "demo" if args.demo else "quick" if args.quick else "full", "tolerance": TOL, "m": M,
            "window": WINDOW, "openmm_version": mm.__version__, "platform": "Reference", "sweeps": sweeps,
            "load_average_at_start": os.getloadavg(), "cases": []}
    # The SIM sweeps step across omega*H = k pi on purpose (Yoshida4's substeps land there even where its step is
    # nudged away): the integrator's ResonanceWarning for each is expected here, counted and explained in one line.
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ResonanceWarning)
        for omega, (setup, checkpoints) in sorted(cases.items()):
            data["cases"].append(run_case(omega, setup, checkpoints, sweeps, progress, args.rtol, args.rtol_check))
    for warning in caught:
        if not issubclass(warning.category, ResonanceWarning):
            warnings.warn_explicit(warning.message, warning.category, warning.filename, warning.lineno)
    resonant = sum(1 for warning in caught if issubclass(warning.category, ResonanceWarning))
    if resonant:
        print(f"{resonant} of the SIM runs put a stiff mode within 5 % of omega H = k pi (a resonance band of the "
              "splitting, where openmmflavors warns); the sweeps cross the bands on purpose: their errors are in the "
              "tables and charts.")
    rows = make_table(data["cases"])
    data["table"] = rows
    data["table_slow_and_stiff"] = make_table(data["cases"], slow_and_stiff_ok)
    data["wall_s_total"] = time.perf_counter() - started

    reporting.write_json(os.path.join(args.out, "work_precision.json"), data)
    table = markdown_table(rows)
    table2 = markdown_table(data["table_slow_and_stiff"], "and window-mean stiff-energy error (from the state)")
    with open(os.path.join(args.out, "work_precision.md"), "w") as f:
        f.write(f"Cheapest run with slow-variable error <= {TOL:g}\n\n{table}\n\nCheapest run with slow-variable "
                f"error <= {TOL:g} and window-mean stiff-energy error <= {TOL:g}\n\n{table2}\n")
    plot_all(data["cases"], rows, args.out, 100)
    if args.docs:
        os.makedirs(args.docs, exist_ok=True)
        plot_all(data["cases"], rows, args.docs, DOCS_DPI, small=True)

    print(f"\nFPU work-precision ({data['mode']}), Reference platform, {data['wall_s_total']:.0f} s.  Reference "
          f"(DOP853, rtol {args.rtol:g}):")
    for case in data["cases"]:
        for T, info in case["reference"]["checkpoints"].items():
            print(f"  omega={case['omega']:g} T={T}: |x0,1 - x0,1(rtol {args.rtol_check:g})| = "
                  f"{info['self_check_x0_1']:.1e}, a 1e-10 perturbation of x0,1 grows "
                  f"x{info['perturbation_1e-10_amplification']:.3g}")
    print(f"\nCheapest run per method with slow-variable error <= {TOL:g} at T (cost: force-group evaluations, all "
          f"groups = soft + stiff; wall: integrator.step() only)\n")
    print(table)
    print(f"\nThe same with the window-mean stiff-energy error (I_j from the state) also <= {TOL:g}\n")
    print(table2)
    print(f"\nwrote {args.out}/work_precision.json, work_precision.md and {', '.join(CHARTS)}")


if __name__ == "__main__":
    main()
