"""Ensembles of non-interacting (y, x) copies on the x axis, shared by examples/langevin_fast_noise and
examples/langevin_slow_noise: the sampled run, ensemble means with standard errors, and the window z-score agreement
of one run with another.  Copy k is particle 2k (y) and 2k+1 (x); unit masses.
"""
import math
import time

import numpy as np
import openmm as mm
import openmm.unit as unit

from scene import Progress

# Verdict thresholds on the window z-scores z = (run - reference) / sqrt(SE_run^2 + SE_ref^2): windows are correlated
# in time, so mean z^2 fluctuates more than chi^2/dof would; 2 is loose enough for agreement, tight enough for a bias.
MEAN_Z2_AGREE = 2.0
LATE_Z_AGREE = 3.0


def simulate(system, integrator, dt, n, y0, x0, sample, T, label, blowup_y):
    """Run the ensemble on the Reference platform; sample x, y, p_x, p_y of every copy every `sample`.  A copy is
    marked blown up (time in blown_at) once |y| >= blowup_y or a coordinate is not finite."""
    every = int(round(sample / dt))
    if every < 1 or abs(every * dt - sample) > 1e-9 * sample:
        raise SystemExit(f"{label}: the step {dt:g} does not divide the sampling interval {sample:g}")
    num = int(round(T / sample))
    context = mm.Context(system, integrator, mm.Platform.getPlatformByName("Reference"))
    context.setPositions([mm.Vec3(p, 0.0, 0.0) for _ in range(n) for p in (y0, x0)])
    context.setVelocities([mm.Vec3(0.0, 0.0, 0.0)] * (2 * n))
    shape = (num + 1, n)
    ys, xs, pys, pxs = np.empty(shape), np.empty(shape), np.empty(shape), np.empty(shape)
    ys[0], xs[0], pys[0], pxs[0] = y0, x0, 0.0, 0.0
    blown_at = np.full(n, np.nan)
    wall = 0.0
    progress = Progress(label, fmt="7.2f")
    for k in range(1, num + 1):
        start = time.perf_counter()
        integrator.step(every)
        wall += time.perf_counter() - start
        state = context.getState(getPositions=True, getVelocities=True)
        q = state.getPositions(asNumpy=True).value_in_unit(unit.nanometer)[:, 0]
        v = state.getVelocities(asNumpy=True).value_in_unit(unit.nanometer / unit.picosecond)[:, 0]
        ys[k], xs[k], pys[k], pxs[k] = q[0::2], q[1::2], v[0::2], v[1::2]
        bad = ~(np.isfinite(ys[k]) & np.isfinite(xs[k]) & (np.abs(ys[k]) < blowup_y)) & np.isnan(blown_at)
        blown_at[bad] = k * sample
        progress.update(k * sample, T)
    progress.update(T, T, force=True)
    del context
    steps = num * every
    return {"label": label, "step": dt, "steps": steps, "wall_s": wall, "us_per_step": 1e6 * wall / steps,
            "x": xs, "y": ys, "px": pxs, "py": pys, "blown_at": blown_at}


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


def series_statistics(series, width, t, late_from):
    """Per quantity (series: {key: samples x copies}): mean and SE per sample, per window of `width` samples, and of
    the per-copy average over t >= late_from."""
    late = t >= late_from - 1e-12
    stats = {}
    for key, values in series.items():
        mean, se = mean_se(values)
        w_mean, w_se = mean_se(window_means(values, width))
        l_mean, l_se = mean_se(values[late].mean(axis=0))
        stats[key] = {"mean": mean, "se": se, "w_mean": w_mean, "w_se": w_se, "late_mean": float(l_mean),
                      "late_se": float(l_se)}
    return stats


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
