"""Shared plumbing for the deterministic example scenes (nonlinear_stiff_soft, primitive_md_2d, propane_clipper).

Each scene script puts this folder on sys.path and imports `scene`; the FPU, Langevin and SIM examples use its
command line, progress and output helpers too.  What is here: the command line (--out, --quick),
running one integrator on one System while sampling positions and velocities at given times (timing only the
integrator.step() calls), the step-halving estimate of a reference's own error, oscillation periods of a sampled
signal, JSON output and a few printing helpers.
"""
import argparse
import json
import math
import os
import sys
import time

import numpy as np
import openmm as mm
import openmm.unit as unit

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SOFT_GROUP, STIFF_GROUP = 0, 1
# Boltzmann constant in kJ/mol/K: temperature = kT / KB.
KB = (unit.BOLTZMANN_CONSTANT_kB * unit.AVOGADRO_CONSTANT_NA).value_in_unit(unit.kilojoule_per_mole / unit.kelvin)


def parser(doc, scene, quick_help="smoke run of a few seconds (short T, coarser reference)",
           out_help="output directory"):
    """--quick and --out (default results/<scene>); out_help=None leaves --out without help text."""
    p = argparse.ArgumentParser(description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--quick", action="store_true", help=quick_help)
    p.add_argument("--out", default=os.path.join(REPO_ROOT, "results", scene), help=out_help)
    return p


class Progress:
    """Progress lines on stderr, at most every `every` seconds.  fmt: the format of the current time t (each
    example keeps its own width)."""

    def __init__(self, label, total=None, every=2.0, fmt="9.4g"):
        self.label, self.total, self.every, self.fmt = label, total, every, fmt
        self.start = self.last = time.perf_counter()

    def update(self, t, total=None, force=False):
        total = self.total if total is None else total
        now = time.perf_counter()
        if force or now - self.last >= self.every:
            self.last = now
            print(f"  [{self.label}] t = {t:{self.fmt}} / {total:g}  ({100 * t / total:5.1f}%)  "
                  f"{now - self.start:6.1f} s", file=sys.stderr, flush=True)


def grid(T, dt):
    """0, dt, 2 dt, ..., T (T must be a multiple of dt)."""
    n = int(round(T / dt))
    if abs(n * dt - T) > 1e-9 * max(1.0, T):
        raise SystemExit(f"sampling interval {dt:g} does not divide T = {T:g}")
    return np.arange(n + 1) * dt


def masses_of(system):
    return np.array([system.getParticleMass(i).value_in_unit(unit.dalton) for i in range(system.getNumParticles())])


# OpenMM's VerletIntegrator is a leapfrog: the velocities it stores lag the positions by dt/2 and the initial
# velocities are read as v(-dt/2).  Starting from v0 - dt/2 F(q0)/m and reading v + dt/2 F(q)/m makes a run exactly
# velocity Verlet from (q0, v0).  FlavorIntegrator's and StochasticImpulseIntegrator's velocities are synchronous.
FORCE_UNIT = unit.kilojoule_per_mole / unit.nanometer


def leapfrog_start(context, v0, dt, masses):
    """v0 - dt/2 F(q)/m at the context's positions (arrays (particles, 3))."""
    f0 = context.getState(getForces=True).getForces(asNumpy=True).value_in_unit(FORCE_UNIT)
    return v0 - 0.5 * dt * np.asarray(f0) / masses[:, None]


def synchronized(state, v, dt, masses):
    """v + dt/2 F/m from a state read with getForces=True (v: (particles, 3) or its x column)."""
    f = np.asarray(state.getForces(asNumpy=True).value_in_unit(FORCE_UNIT))
    if v.ndim == 1:
        return v + 0.5 * dt * f[:, 0] / masses
    return v + 0.5 * dt * f / masses[:, None]


def start_context(system, integrator, dt, positions, velocities, leapfrog=False, platform="Reference", properties=None):
    """A Context at (positions, velocities); for a leapfrog run the velocities are set to v(-dt/2)."""
    context = mm.Context(system, integrator, mm.Platform.getPlatformByName(platform), properties or {})
    context.setPositions(positions)
    v0 = np.array(velocities, dtype=float)
    if leapfrog:
        v0 = leapfrog_start(context, v0, dt, masses_of(system))
    context.setVelocities(v0)
    return context


def read_state(context, dt, leapfrog, masses, energy=False):
    """Positions and velocities (synchronized for a leapfrog run) as arrays (particles, 3), and the State."""
    state = context.getState(getPositions=True, getVelocities=True, getEnergy=energy, getForces=leapfrog)
    q = np.asarray(state.getPositions(asNumpy=True).value_in_unit(unit.nanometer))
    v = np.asarray(state.getVelocities(asNumpy=True).value_in_unit(unit.nanometer / unit.picosecond))
    if leapfrog:
        v = synchronized(state, v, dt, masses)
    return q, v, state


def sample_steps(times, dt, hint):
    """The step counts at `times`; hint (with {dt}) is the message when dt does not divide them."""
    steps = np.rint(times / dt).astype(np.int64)
    if np.max(np.abs(steps * dt - times)) > 1e-9 * max(1.0, times[-1]):
        raise SystemExit(hint.format(dt=dt))
    return steps


def simulate(system, integrator, dt, positions, velocities, times, label, leapfrog=False, platform="Reference",
             energy=False, progress=None, hint=None):
    """Run `integrator` (step size dt) from (positions, velocities) and sample q, v at `times`.

    leapfrog=True is for OpenMM's VerletIntegrator (see leapfrog_start): the run is exactly velocity Verlet from
    (q0, v0).  energy=True samples the potential energy too ("pe").  Wall time counts integrator.step() only.
    """
    context = start_context(system, integrator, dt, positions, velocities, leapfrog, platform)
    masses = masses_of(system)
    steps = sample_steps(times, dt, hint or (label + ": step {dt:g} does not divide the sampling times"))
    n = system.getNumParticles()
    qs = np.empty((len(times), n, 3))
    vs = np.empty((len(times), n, 3))
    pe = np.empty(len(times))
    wall, done = 0.0, 0
    progress = progress or Progress(label, times[-1])
    for k, target in enumerate(steps):
        if target > done:
            start = time.perf_counter()
            integrator.step(int(target - done))
            wall += time.perf_counter() - start
            done = int(target)
        qs[k], vs[k], state = read_state(context, dt, leapfrog, masses, energy)
        if energy:
            pe[k] = state.getPotentialEnergy().value_in_unit(unit.kilojoule_per_mole)
        progress.update(times[k], times[-1])
    progress.update(times[-1], times[-1], force=True)
    del context
    run = {"t": np.asarray(times), "q": qs, "v": vs, "masses": masses, "wall_s": wall, "steps": int(steps[-1]),
           "dt": dt, "us_per_step": 1e6 * wall / max(1, int(steps[-1]))}
    if energy:
        run["pe"] = pe
    return run


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


def jsonable(obj):
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, (np.floating, float)):
        return None if not math.isfinite(float(obj)) else float(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    return obj


def write_json(path, data):
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(path, "w") as f:
        json.dump(jsonable(data), f, indent=1)


def save_outputs(out, name, data, plot):
    """<out>/<name>.json (json.dump as is: unlike write_json, NaN stays NaN) and <out>/<name>.png drawn by
    plot(path)."""
    os.makedirs(out, exist_ok=True)
    json_path = os.path.join(out, f"{name}.json")
    with open(json_path, "w") as f:
        json.dump(data, f, indent=1)
    png_path = os.path.join(out, f"{name}.png")
    plot(png_path)
    print(f"\nwrote {json_path} and {png_path}")


def pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def table(title, columns, rows):
    """columns: [(header, width, format)], rows: lists of values (str values are left as they are)."""
    print(f"\n{title}")
    head = " ".join(f"{h:>{w}s}" if i else f"{h:{w}s}" for i, (h, w, _) in enumerate(columns))
    print(head)
    print("-" * len(head))
    for row in rows:
        cells = []
        for i, ((_, w, fmt), v) in enumerate(zip(columns, row)):
            text = v if isinstance(v, str) else format(v, fmt)
            cells.append(f"{text:>{w}s}" if i else f"{text:{w}s}")
        print(" ".join(cells))


def flavor(delta, tau, scheme):
    """FlavorIntegrator(delta, tau, {stiff group}) with the named scheme ("SymplecticEuler" or "Verlet")."""
    import openmmflavors
    integrator = openmmflavors.FlavorIntegrator(delta * unit.picoseconds, tau * unit.picoseconds, {STIFF_GROUP})
    integrator.setScheme(getattr(openmmflavors.FlavorIntegrator, scheme))
    return integrator


# ---------------------------------------------------------------------------------------------------------------------
# The comparison every scene makes.
#
# A scene is an object with
#   name, title                          strings
#   system(scale)                        the OpenMM System with its stiff terms multiplied by `scale`
#   positions, velocities                initial state (lists of 3-vectors, nm and nm/ps)
#   slow(run) -> {name: array}           slow variables, compared pointwise with the reference
#   fast(run) -> {name: array}           fast variables, compared in the averaged sense (time means)
#   fast_signal(run) -> array            one fast coordinate whose oscillation period is measured
#   energies(run) -> (K, V_soft, V_stiff) arrays (V_stiff unscaled)
# and `run` is what simulate() returns.
# ---------------------------------------------------------------------------------------------------------------------

def timed(key):
    """Runs whose wall time is measured without sampling: the legacy integrator and every FLAVOR."""
    return key == "legacy" or key.startswith("flavor")


def step_costs(items, budget=0.3, chunk_s=0.02):
    """Seconds per step of integrator.step() without sampling, for several integrators at once.

    items: {key: (system, make_integrator, positions, velocities)}.  Each integrator continues its trajectory from
    the initial state in chunks of about chunk_s seconds (one step() call each); the integrators take turns, chunk by
    chunk, until each has spent `budget` seconds (at least three chunks), and each one's fastest chunk counts: other
    jobs share the machine, and taking turns exposes every integrator to the same load."""
    state = {}
    for key, (system, make, positions, velocities) in items.items():
        integrator = make()
        context = mm.Context(system, integrator, mm.Platform.getPlatformByName("Reference"))
        context.setPositions(positions)
        context.setVelocities([mm.Vec3(*v) for v in velocities])
        start = time.perf_counter()
        integrator.step(100)
        n = max(1, int(chunk_s / max((time.perf_counter() - start) / 100, 1e-9)))
        state[key] = {"integrator": integrator, "context": context, "n": n, "best": float("inf"), "spent": 0.0,
                      "chunks": 0}
    while any(st["chunks"] < 3 or st["spent"] < budget for st in state.values()):
        for st in state.values():
            if st["chunks"] < 3 or st["spent"] < budget:
                start = time.perf_counter()
                st["integrator"].step(st["n"])
                elapsed = time.perf_counter() - start
                st["best"] = min(st["best"], elapsed / st["n"])
                st["spent"] += elapsed
                st["chunks"] += 1
    return {key: st["best"] for key, st in state.items()}


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
    costs = step_costs({key: (sc.system(specs[key][4]), specs[key][1], sc.positions, sc.velocities)
                        for key in specs if timed(key)},
                       budget=0.03 if p.get("quick") else 0.4, chunk_s=0.005 if p.get("quick") else 0.02)
    for key, cost in costs.items():
        runs[key]["wall_s"], runs[key]["us_per_step"] = cost * runs[key]["steps"], 1e6 * cost
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
    """panels: [(title, function(run) -> array, kind)] with kind "slow" (whole run, every method), "slow_end" (the
    last p["zoom_end"] of the run, every method), "fast" (zoom on [0, zoom], reference / legacy / FLAVOR), "band"
    (running mean and mean +- std over p["avg_window"], reference / legacy / FLAVOR); then energies and the
    running maximum of the first slow variable's error are added."""
    plt = pyplot()
    n = len(panels) + 2
    cols = 3
    rows = (n + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(5.2 * cols, 3.8 * rows))
    axes = axes.ravel()
    fig.suptitle(f"{sc.title}: T = {p['T']:g}, delta = {p['delta']:g}, tau = {p['tau']:g}, Reference platform",
                 fontsize=11)
    for ax, (title, fn, kind) in zip(axes, panels):
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
                ax.plot(t, mean, label=run["label"], **STYLE[key])
                ax.plot(t, mean + std, **{**STYLE[key], "lw": 0.6})
                ax.plot(t, mean - std, **{**STYLE[key], "lw": 0.6})
            else:
                ax.plot(t, y, label=run["label"], **STYLE[key])
        ax.set_title(title, fontsize=9)
        ax.set_xlabel("t")
    ax = axes[len(panels)]
    for key in ("reference", "legacy", "flavor"):
        run = runs[key]
        ax.plot(run["t"], run["H"] / run["H"][0], label=f"{run['label']}: H", **STYLE[key])
    run = runs["flavor"]
    ax.plot(run["t"], run["H_eff"] / run["H_eff"][0], color="tab:orange", lw=1.0, label="FLAVOR SympEuler: H_eff")
    ax.set_title("H(t) / H(0); for FLAVOR also H_eff(t) / H_eff(0),\nH_eff = K + V_soft + (tau/delta) V_stiff",
                 fontsize=9)
    ax.set_xlabel("t")
    ax.legend(fontsize=6, loc="lower right")
    ax = axes[len(panels) + 1]
    name = next(iter(sc.slow(runs["reference"])))
    ref = runs["reference"]
    tc = ref["t"][ref["coarse"]]
    for key in runs:
        if key != "effective" and "slow_error" in runs[key]:
            label = runs[key]["label"] + (": own error (step halving)" if key == "reference" else "")
            style = STYLE.get(key, dict(color="tab:red" if key.startswith("flavor_r") else "tab:purple",
                                        lw=0.6, alpha=0.6, ls="-" if key.startswith("flavor_r") else ":"))
            err = np.maximum.accumulate(runs[key]["slow_error"][name])
            ax.semilogy(tc[1:], np.maximum(err[1:], 1e-16), label=label, **style)
    ax.set_title(f"running max of |{name} - {name}(reference)|\n(thin lines: FLAVORs at delta/k, tau/k)",
                 fontsize=9)
    ax.set_xlabel("t")
    ax.legend(fontsize=6, loc="lower right")
    axes[0].legend(fontsize=6, loc="lower left")
    for ax in axes[n:]:
        ax.axis("off")
    # Fixed spacing: tight_layout and legend placement "best" cost seconds with long series.
    fig.subplots_adjust(left=0.05, right=0.98, bottom=0.05, top=0.93, wspace=0.22, hspace=0.42)
    fig.savefig(path, dpi=110)
    plt.close(fig)


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
