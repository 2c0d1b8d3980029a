"""Ensembles of non-interacting (y, x) copies on the x axis (examples/langevin_fast_noise and langevin_slow_noise): the
sampled run, ensemble means with standard errors, and the window z-score agreement of one run with another.  Copy k
is particle 2k (y) and 2k+1 (x); unit masses.
"""
import math

import numpy as np

from .progress import Progress
from .runners import simulate

# Verdict thresholds on the window z-scores z = (run - reference) / sqrt(SE_run^2 + SE_ref^2): windows are correlated
# in time, so mean z^2 fluctuates more than chi^2/dof would; 2 is loose enough for agreement, tight enough for a bias.
MEAN_Z2_AGREE = 2.0
LATE_Z_AGREE = 3.0


def run_ensemble(system, integrator, dt, n, y0, x0, sample, T, label, blowup_y):
    """Run the ensemble from (y0, x0) at rest on the Reference platform; sample x, y, p_x, p_y of every copy every
    `sample`.  A copy is marked blown up (time in blown_at) once |y| >= blowup_y or a coordinate is not finite."""
    times = np.arange(int(round(T / sample)) + 1) * sample
    positions = np.zeros((2 * n, 3))
    positions[0::2, 0], positions[1::2, 0] = y0, x0
    run = simulate(system, integrator, dt, positions, None, times, label, progress=Progress(label, fmt="7.2f"),
                   hint=f"{label}: the step {{dt:g}} does not divide the sampling interval {sample:g}")
    q, v = run["q"][:, :, 0], run["v"][:, :, 0]
    ys, xs = q[:, 0::2], q[:, 1::2]
    bad = ~(np.isfinite(ys) & np.isfinite(xs) & (np.abs(ys) < blowup_y))
    bad[0] = False
    blown_at = np.where(bad.any(axis=0), times[np.argmax(bad, axis=0)], np.nan)
    return {"label": label, "step": dt, "steps": run["steps"], "wall_s": run["wall_s"],
            "us_per_step": run["us_per_step"], "x": xs, "y": ys, "px": v[:, 1::2], "py": v[:, 0::2],
            "blown_at": blown_at}


def window_means(values, width):
    """Means over consecutive windows of `width` samples (samples 1..end; sample 0 is the deterministic start)."""
    body = values[1:]
    m = body.shape[0] // width
    return body[: m * width].reshape(m, width, -1).mean(axis=1)


def mean_se(values):
    """Ensemble mean and its standard error along the last axis (copies)."""
    n = values.shape[-1]
    mean = values.mean(axis=-1)
    se = values.std(axis=-1, ddof=1) / math.sqrt(n) if n > 1 else np.full_like(mean, np.nan)
    return mean, se


def series_statistics(run, series, width, t, late_from):
    """Per quantity of the copies of run_ensemble() that stayed finite (series(x, y, px, py) -> {key: samples x
    copies}): mean and SE per sample, per window of `width` samples, and of the per-copy average over t >= late_from.
    Returns them and the number of copies used."""
    keep = np.isnan(run["blown_at"])
    late = t >= late_from - 1e-12
    stats = {}
    for key, values in series(*(run[k][:, keep] for k in ("x", "y", "px", "py"))).items():
        mean, se = mean_se(values)
        w_mean, w_se = mean_se(window_means(values, width))
        l_mean, l_se = mean_se(values[late].mean(axis=0))
        stats[key] = {"mean": mean, "se": se, "w_mean": w_mean, "w_se": w_se, "late_mean": float(l_mean),
                      "late_se": float(l_se)}
    return stats, int(keep.sum())


def compare(other, ref, t_window, late_from, regime_split, names=("run", "reference")):
    """One run against a reference run for one quantity: window z-scores, and the late-time average with its standard
    error.  names: the JSON keys of the two late-time values."""
    diff = other["w_mean"] - ref["w_mean"]
    se = np.sqrt(other["w_se"] ** 2 + ref["w_se"] ** 2)
    z = np.where(se > 0, diff / np.where(se > 0, se, 1.0), np.nan)
    out = {}
    for name, mask in (("all", np.ones_like(t_window, dtype=bool)), (f"t<{regime_split:g}", t_window < regime_split),
                       (f"t>={regime_split:g}", t_window >= regime_split)):
        zz = z[mask & np.isfinite(z)]
        if zz.size:
            out[name] = {"windows": int(zz.size), "mean_z2": float(np.mean(zz ** 2)),
                         "max_abs_z": float(np.max(np.abs(zz))), "frac_abs_z_gt_2": float(np.mean(np.abs(zz) > 2)),
                         "max_abs_diff": float(np.max(np.abs(diff[mask])))}
    late_z = (other["late_mean"] - ref["late_mean"]) / math.sqrt(other["late_se"] ** 2 + ref["late_se"] ** 2)
    a, b = names
    out["late"] = {"from_t": late_from, a: other["late_mean"], f"{a}_se": other["late_se"],
                   b: ref["late_mean"], f"{b}_se": ref["late_se"], "z": float(late_z),
                   "ratio": float(other["late_mean"] / ref["late_mean"]) if ref["late_mean"] != 0 else None}
    out["agree"] = bool(out["all"]["mean_z2"] <= MEAN_Z2_AGREE and abs(late_z) <= LATE_Z_AGREE)
    return out


def trapezoid(y, x):
    """The trapezoidal rule over the samples y at the points x (numpy's trapezoid; numpy before 2.0 names it trapz)."""
    y, x = np.asarray(y, dtype=float), np.asarray(x, dtype=float)
    return float(np.sum((y[1:] + y[:-1]) * np.diff(x)) / 2)
