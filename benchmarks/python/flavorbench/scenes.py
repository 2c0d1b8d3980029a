"""The comparison every deterministic FLAVOR scene makes (examples/nonlinear_stiff_soft, primitive_md_2d,
propane_clipper): a velocity Verlet reference with its own error by step halving, the legacy integrator (symplectic
Euler at a small step), the FLAVORs (SymplecticEuler and Verlet schemes, also at smaller mesosteps), and the H_eff
system (stiff terms times tau/delta) that a FLAVOR follows to leading order; then the errors of the slow variables,
the averaged statistics of the fast ones, energies, periods and times, as tables, JSON series and a chart.

A scene is an object with
  name, title                          strings
  system(scale)                        the OpenMM System with its stiff terms multiplied by `scale`
  positions, velocities                initial state (lists of 3-vectors, nm and nm/ps)
  slow(run) -> {name: array}           slow variables, compared pointwise with the reference
  fast(run) -> {name: array}           fast variables, compared in the averaged sense (time means)
  fast_signal(run) -> array            one fast coordinate whose oscillation period is measured
  energies(run) -> (K, V_soft, V_stiff) arrays (V_stiff unscaled)
and `run` is what runners.simulate() returns.
"""
import math
import sys

import numpy as np
import openmm as mm

from .reporting import greek, pyplot, save_figure, table
from .runners import flavor, simulate, start_context, time_batches


def grid(T, dt):
    """0, dt, 2 dt, ..., T (T must be a multiple of dt)."""
    n = int(round(T / dt))
    if abs(n * dt - T) > 1e-9 * max(1.0, T):
        raise SystemExit(f"sampling interval {dt:g} does not divide T = {T:g}")
    return np.arange(n + 1) * dt


def on_grid(run_times, coarse):
    """Indices of run_times at the coarse times (both are multiples of a common interval)."""
    idx = np.searchsorted(run_times, coarse - 1e-9 * max(1.0, coarse[-1]))
    if np.max(np.abs(run_times[idx] - coarse)) > 1e-9 * max(1.0, coarse[-1]):
        raise ValueError("a run was not sampled on the common grid")
    return idx


def mean_period(t, signal):
    """Mean time between successive upward crossings of the signal's mean (linear interpolation); nan if < 2."""
    s = np.asarray(signal) - np.mean(signal)
    up = np.nonzero((s[:-1] < 0) & (s[1:] >= 0))[0]
    if len(up) < 2:
        return float("nan")
    tc = t[up] + (t[up + 1] - t[up]) * (-s[up]) / (s[up + 1] - s[up])
    return float((tc[-1] - tc[0]) / (len(tc) - 1))


def running_mean(values, width):
    """Centred running mean over `width` samples; the ends average over what is available."""
    if width <= 1:
        return np.asarray(values)
    kernel = np.ones(width)
    return np.convolve(values, kernel, mode="same") / np.convolve(np.ones(len(values)), kernel, mode="same")


def checkpoints(T, fractions=(0.1, 0.5, 1.0)):
    return [f * T for f in fractions]


def at(times, values, when):
    """{"t": value} at the samples nearest each time in `when`."""
    return {f"{t:g}": float(values[int(np.argmin(np.abs(times - t)))]) for t in when}


def timed(key):
    """Runs whose wall time is measured without sampling: the legacy integrator and every FLAVOR."""
    return key == "legacy" or key.startswith("flavor")


def run_all(sc, p):
    """The runs of one scene.  p: T, delta, tau, h (legacy), href, sample (common grid, a multiple of delta),
    fine_sample (fine runs' sampling), h_eff (step for the effective system)."""
    T, delta, tau = p["T"], p["delta"], p["tau"]
    fine_times, coarse_times = grid(T, p["fine_sample"]), grid(T, p["sample"])
    flavor_times = grid(T, delta)
    specs = {
        "reference": (f"reference: Verlet h={p['href']:g}", lambda: mm.VerletIntegrator(p["href"]), p["href"], True,
                      1.0, fine_times),
        "reference_check": (f"reference check: Verlet h={2 * p['href']:g}",
                            lambda: mm.VerletIntegrator(2 * p["href"]), 2 * p["href"], True, 1.0, fine_times),
        "legacy": (f"symplectic Euler h={p['h']:g}", lambda: flavor(p["h"], p["h"], "SymplecticEuler"), p["h"],
                   False, 1.0, fine_times),
        "flavor": (f"FLAVOR SympEuler d={delta:g} t={tau:g}", lambda: flavor(delta, tau, "SymplecticEuler"), delta,
                   False, 1.0, flavor_times),
        "flavor_verlet": (f"FLAVOR Verlet d={delta:g} t={tau:g}", lambda: flavor(delta, tau, "Verlet"), delta,
                          False, 1.0, flavor_times),
        "effective": (f"H_eff (stiff x tau/delta): Verlet h={p['h_eff']:g}", lambda: mm.VerletIntegrator(p["h_eff"]),
                      p["h_eff"], True, tau / delta, fine_times if p["fine_sample"] >= p["h_eff"] else coarse_times),
    }
    # Same tau/delta (same H_eff), smaller mesostep: the part of FLAVOR's error that is its discretization of H_eff
    # shrinks with the mesostep, the averaging error (H_eff against H) stays.
    for k in p.get("refine", []):
        for key, scheme, name in (("flavor", "SymplecticEuler", "SympEuler"), ("flavor_verlet", "Verlet", "Verlet")):
            if key in specs:
                d, t = delta / k, tau / k
                specs[f"{key}_r{k}"] = (f"FLAVOR {name} d={d:g} t={t:g}",
                                        lambda d=d, t=t, scheme=scheme: flavor(d, t, scheme), d, False, 1.0,
                                        coarse_times)
    runs = {}
    for key, (label, make, dt, leapfrog, scale, times) in specs.items():
        print(f"running {label}", file=sys.stderr, flush=True)
        run = simulate(sc.system(scale), make(), dt, sc.positions, sc.velocities, times, label, leapfrog)
        run["label"], run["stiff_scale"] = label, scale
        run["wall_s_sampled"] = run["wall_s"]
        runs[key] = run
    # Sampling a FLAVOR every mesostep means one step() call per step: the wall time of the legacy integrator and
    # of the FLAVORs is their step cost measured without sampling times their number of steps.
    print("timing symplectic Euler and the FLAVORs without sampling", file=sys.stderr, flush=True)
    cases = {}
    for key in filter(timed, specs):
        integrator = specs[key][1]()
        cases[key] = (start_context(sc.system(specs[key][4]), integrator, 0.0, sc.positions, sc.velocities), integrator)
    quick = p.get("quick")
    for key, cost in time_batches(cases, 0.005 if quick else 0.02, 6 if quick else 20).items():
        runs[key]["us_per_step"] = cost["us_per_step"]
        runs[key]["wall_s"] = 1e-6 * cost["us_per_step"] * runs[key]["steps"]
    for run in runs.values():
        run["coarse"] = on_grid(run["t"], coarse_times)
    return runs, coarse_times


def summarize(sc, runs, p, T_checks):
    """Errors of the slow variables, averaged statistics of the fast ones, energies, periods, times."""
    weight = p["tau"] / p["delta"]
    ref = runs["reference"]
    ref_slow = {k: v[ref["coarse"]] for k, v in sc.slow(ref).items()}
    tc = ref["t"][ref["coarse"]]
    legacy_wall = runs["legacy"]["wall_s"]
    out = {"runs": {}, "slow_error": {}, "flavor_vs_effective": {}, "fast": {}, "energy": {}}
    for key, run in runs.items():
        out["runs"][key] = {"label": run["label"], "dt": run["dt"], "steps": run["steps"], "wall_s": run["wall_s"],
                            "wall_s_sampled": run["wall_s_sampled"],
                            "timed_unsampled": timed(key),
                            "us_per_step": run["us_per_step"], "stiff_scale": run["stiff_scale"],
                            "speedup_vs_legacy": legacy_wall / run["wall_s"] if run["wall_s"] > 0 else None}
        slow = {k: v[run["coarse"]] for k, v in sc.slow(run).items()}
        if key == "reference":
            check = {k: v[runs["reference_check"]["coarse"]] for k, v in sc.slow(runs["reference_check"]).items()}
            # Velocity Verlet is second order: |x(h) - x(2h)| / 3 estimates the error of x(h).
            errs = {k: np.abs(check[k] - ref_slow[k]) / 3.0 for k in slow}
        elif key == "reference_check":
            errs = None
        else:
            errs = {k: np.abs(slow[k] - ref_slow[k]) for k in slow}
        if errs is not None:
            out["slow_error"][key] = {k: {"at": at(tc, e, T_checks), "max": float(np.max(e)),
                                          "rms": float(np.sqrt(np.mean(e * e)))} for k, e in errs.items()}
            run["slow_error"] = errs
        fast = sc.fast(run)
        out["fast"][key] = {k: {"mean": float(np.mean(v)), "std": float(np.std(v))} for k, v in fast.items()}
        window = run["t"] <= p["period_window"] + 1e-12
        out["fast"][key]["period"] = mean_period(run["t"][window], sc.fast_signal(run)[window])
        kin, soft, stiff = sc.energies(run)
        H = kin + soft + stiff
        He = kin + soft + weight * stiff
        run["H"], run["H_eff"] = H, He
        out["energy"][key] = {"H0": float(H[0]), "H_max_dev": float(np.max(np.abs(H - H[0]))),
                              "H_eff_max_dev": float(np.max(np.abs(He - He[0]))),
                              "H_final_dev": float(H[-1] - H[0]), "H_eff_final_dev": float(He[-1] - He[0])}
    if "effective" in runs:
        eff = {k: v[runs["effective"]["coarse"]] for k, v in sc.slow(runs["effective"]).items()}
        for key in runs:
            if key.startswith("flavor"):
                slow = {k: v[runs[key]["coarse"]] for k, v in sc.slow(runs[key]).items()}
                diffs = {k: np.abs(slow[k] - eff[k]) for k in slow}
                runs[key]["effective_diff"] = diffs
                out["flavor_vs_effective"][key] = {k: {"at": at(tc, d, T_checks), "max": float(np.max(d))}
                                                   for k, d in diffs.items()}
    # Fast statistics relative to the reference: positions should agree, squared fast velocities scale by tau/delta.
    for key in out["fast"]:
        for k, v in out["fast"][key].items():
            if isinstance(v, dict):
                r = out["fast"]["reference"][k]["mean"]
                v["ratio_to_reference"] = v["mean"] / r if r != 0 else None
                if "effective" in out["fast"]:
                    e = out["fast"]["effective"][k]["mean"]
                    v["ratio_to_effective"] = v["mean"] / e if e != 0 else None
        r_period = out["fast"]["reference"]["period"]
        out["fast"][key]["period_ratio_to_reference"] = out["fast"][key]["period"] / r_period
    out["predicted"] = {"tau_over_delta": weight, "fast_period_ratio": math.sqrt(1 / weight),
                        "fast_velocity_square_ratio": weight}
    return out


def print_summary(sc, out, T_checks, slow_names, fast_names):
    print(f"\n{sc.title}")
    table("Runs (wall time of integrator.step() only; for symplectic Euler and the FLAVORs: steps x the step cost "
          "measured without sampling;\nspeedup = symplectic Euler wall time / wall time)",
          [("run", 44, ""), ("steps", 9, "d"), ("wall s", 8, ".3f"), ("us/step", 8, ".3f"), ("speedup", 8, ".1f")],
          [[r["label"], r["steps"], r["wall_s"], r["us_per_step"], r["speedup_vs_legacy"]]
           for r in out["runs"].values()])
    for name in slow_names:
        cols = [("run", 44, "")] + [(f"t={t:g}", 10, ".2e") for t in T_checks] + [("max", 10, ".2e")]
        rows = []
        for key, s in out["slow_error"].items():
            label = out["runs"][key]["label"] + (" (own est.)" if key == "reference" else "")
            rows.append([label] + list(s[name]["at"].values()) + [s[name]["max"]])
        for key, s in out["flavor_vs_effective"].items():
            rows.append([out["runs"][key]["label"] + " vs H_eff"] + list(s[name]["at"].values()) + [s[name]["max"]])
        table(f"Slow variable {name}: |error| against the reference (last rows: FLAVOR against the H_eff run)",
              cols, rows)
    cols = [("run", 44, "")]
    for name in fast_names:
        cols.append((f"<{name}>", 11, ".4g"))
        cols.append(("/ref", 6, ".3f"))
        cols.append(("/Heff", 6, ".3f"))
    cols += [("period", 9, ".4g"), ("/ref", 6, ".2f")]
    rows = []
    for key, f in out["fast"].items():
        row = [out["runs"][key]["label"]]
        for name in fast_names:
            row += [f[name]["mean"], f[name]["ratio_to_reference"], f[name].get("ratio_to_effective", float("nan"))]
        row += [f["period"], f["period_ratio_to_reference"]]
        rows.append(row)
    pr = out["predicted"]
    table(f"Fast variables: time means over the run (/ref: ratio to the reference, /Heff: to the H_eff run) and "
          f"fast period (start window).\nFlow averaging predicts /Heff = 1; against the true system, for a fast "
          f"mode started at rest, position statistics /ref = 1,\nsquared fast velocities /ref = tau/delta = "
          f"{pr['tau_over_delta']:.3g}, period /ref = sqrt(delta/tau) = {pr['fast_period_ratio']:.3g}", cols, rows)
    table("Energy: max |H - H(0)| and max |H_eff - H_eff(0)|, H_eff = K + V_soft + (tau/delta) V_stiff",
          [("run", 44, ""), ("H(0)", 11, ".5g"), ("max|dH|", 10, ".3e"), ("max|dH_eff|", 12, ".3e")],
          [[out["runs"][k]["label"], e["H0"], e["H_max_dev"], e["H_eff_max_dev"]] for k, e in out["energy"].items()])


STYLE = {"reference": dict(color="k", lw=1.4), "legacy": dict(color="tab:blue", lw=1.0, ls="--"),
         "flavor": dict(color="tab:red", lw=1.0), "flavor_verlet": dict(color="tab:purple", lw=0.9, ls=":"),
         "effective": dict(color="tab:green", lw=0.9, ls="-.")}


def plot(sc, runs, out, p, path, panels):
    """Two charts.  path: panels [(title, function(run) -> array, kind[, y-axis label])] with kind "slow" (whole run,
    every method), "slow_end" (the last p["zoom_end"] of the run, every method), "fast" (zoom on [0, zoom], reference
    / legacy / FLAVOR), "band" (running mean and mean +- std over p["avg_window"], reference / legacy / FLAVOR).
    path with _energy_error: the energies and the running maximum of the first slow variable's error.  In each, the
    legend takes a free slot (or goes below the panels).  Times are in ps (the scenes' units: 1 amu, 1 nm, 1 ps)."""
    plt = pyplot()
    cols = 3
    rows = (len(panels) + cols - 1) // cols
    free = len(panels) < rows * cols
    fig, axes = plt.subplots(rows, cols, figsize=(5.2 * cols, 3.8 * rows + (0.9 if free else 1.8)), squeeze=False)
    axes = axes.ravel()
    compared = (f"FLAVOR against symplectic Euler and a fine Verlet reference: T = {p['T']:g} ps, δ = {p['delta']:g} "
                f"ps, τ = {p['tau']:g} ps, Reference platform (units: 1 amu, 1 nm, 1 ps)")
    fig.suptitle(f"{sc.title}\n{compared}", fontsize=11)
    for ax, panel in zip(axes, panels):
        title, fn, kind = panel[:3]
        keys = ["reference", "legacy", "flavor"] if kind in ("fast", "band") else \
            [k for k in ("reference", "legacy", "flavor", "flavor_verlet", "effective") if k in runs]
        for key in keys:
            run = runs[key]
            t, y = run["t"], fn(run)
            if kind == "fast":
                m = t <= p["zoom"] + 1e-12
                t, y = t[m], y[m]
            elif kind == "slow_end":
                m = t >= p["T"] - p["zoom_end"] - 1e-12
                t, y = t[m], y[m]
            if kind == "band":
                width = max(1, int(round(p["avg_window"] / (t[1] - t[0]))))
                mean = running_mean(y, width)
                std = np.sqrt(np.maximum(running_mean(y * y, width) - mean * mean, 0.0))
                ax.plot(t, mean, label=greek(run["label"]), **STYLE[key])
                ax.plot(t, mean + std, **{**STYLE[key], "lw": 0.6})
                ax.plot(t, mean - std, **{**STYLE[key], "lw": 0.6})
            else:
                ax.plot(t, y, label=greek(run["label"]), **STYLE[key])
        ax.set_title(title, fontsize=9)
        ax.set_xlabel("t (ps)")
        if len(panel) > 3:
            ax.set_ylabel(panel[3], fontsize=8.5)
    _legend(fig, axes, len(panels), rows * cols)
    # Fixed spacing: tight_layout and legend placement "best" cost seconds with long series.
    fig.subplots_adjust(left=0.06, right=0.98, bottom=0.08 if free else 0.06 + 1.2 / (3.8 * rows + 1.8),
                        top=1 - 1.0 / (3.8 * rows + (0.9 if free else 1.8)), wspace=0.25, hspace=0.42)
    save_figure(fig, path, 110)

    fig, axes = plt.subplots(1, cols, figsize=(5.2 * cols, 4.7))
    fig.suptitle(f"{sc.title}: energies and slow-variable error\n{compared}", fontsize=11)
    ax = axes[0]
    for key in ("reference", "legacy", "flavor"):
        run = runs[key]
        ax.plot(run["t"], run["H"] / run["H"][0], label=greek(run["label"]), **STYLE[key])
    run = runs["flavor"]
    ax.plot(run["t"], run["H_eff"] / run["H_eff"][0], color="tab:orange", lw=1.0, label="FLAVOR SympEuler: H_eff")
    ax.set_title("total energy H(t) / H(0); for FLAVOR also H_eff(t) / H_eff(0),\n"
                 "H_eff = K + V_soft + (τ/δ) V_stiff", fontsize=9)
    ax.set_xlabel("t (ps)")
    ax.set_ylabel("energy / its value at t = 0 (dimensionless)", fontsize=8.5)
    ax = axes[1]
    name = next(iter(sc.slow(runs["reference"])))
    symbol = {"theta": "θ", "phi": "φ"}.get(name, name)
    ref = runs["reference"]
    tc = ref["t"][ref["coarse"]]
    for key in runs:
        if key != "effective" and "slow_error" in runs[key]:
            style = STYLE.get(key, dict(color="tab:red" if key.startswith("flavor_r") else "tab:purple",
                                        lw=0.6, alpha=0.6, ls="-" if key.startswith("flavor_r") else ":"))
            err = np.maximum.accumulate(runs[key]["slow_error"][name])
            ax.semilogy(tc[1:], np.maximum(err[1:], 1e-16), label=greek(runs[key]["label"]), **style)
    ax.set_title(f"slow variable: running max of |{symbol} − {symbol}(reference)|\n(black: the reference's own error, "
                 f"from step halving; thin lines: FLAVORs at δ/k, τ/k)", fontsize=9)
    ax.set_xlabel("t (ps)")
    unit = getattr(sc, "slow_unit", "")
    ax.set_ylabel(f"absolute error{f' ({unit})' if unit else ''}", fontsize=8.5)
    _legend(fig, axes, 2, cols)
    fig.subplots_adjust(left=0.06, right=0.98, bottom=0.12, top=0.8, wspace=0.25)
    save_figure(fig, path[:-len(".png")] + "_energy_error.png", 110)


def _legend(fig, axes, used, slots):
    """One legend for every panel, in the first free slot or below the panels: inside a panel it would hide curves."""
    handles, labels = [], []
    for a in axes[:used]:
        for h, lab in zip(*a.get_legend_handles_labels()):
            if lab not in labels:
                handles.append(h)
                labels.append(lab)
    for ax in axes[used:]:
        ax.axis("off")
    if used < slots:
        axes[used].legend(handles, labels, loc="center", fontsize=8.5, frameon=False, title="methods",
                          title_fontsize=9)
    else:
        fig.legend(handles, labels, loc="lower center", ncol=3, fontsize=8.5, frameon=False)


def series(runs, fields, max_points=2000):
    """Sampled series for the JSON: the main runs on the common grid, thinned to at most max_points samples.
    fields(run) -> {name: array over the run's samples}."""
    out = {}
    for key in ("reference", "legacy", "flavor", "flavor_verlet", "effective"):
        if key not in runs:
            continue
        run = runs[key]
        idx = run["coarse"][::max(1, -(-len(run["coarse"]) // max_points))]
        out[key] = {"t": run["t"][idx], **{k: np.asarray(v)[idx] for k, v in fields(run).items()},
                    "H": run["H"][idx], "H_eff": run["H_eff"][idx]}
    return out
