#!/usr/bin/env python3
"""Stability benchmarks: where FLAVOR, r-RESPA and SIM fail.

(a) Stability domain of FlavorIntegrator (SymplecticEuler and Verlet schemes) on the linear system (5.1) of the
    FLAVORS paper, H = px^2/2 + py^2/2 + x^2/2 + omega^2/2 (y - x)^2 with omega = 1000, over a grid of mesostep delta
    and tau*omega^2 (= tau/epsilon, the axes of the paper's Fig. 5.1).  Each grid point is run with the integrator for N
    mesosteps from x = 0.8, y = x + 1.1/omega (Fig. 5.2's start) and called blown up if |x| or |y| exceeds 100.  The
    same schemes written as 4x4 transfer matrices in NumPy (docs/ARCHITECTURE.md) give the exact linear answer
    (spectral radius <= 1), drawn as a contour, and the two are compared point by point; at a few tau*omega^2 the
    boundary in delta is also found by bisection, from runs and from the matrix.  Lines: Theorem 5.1's delta = 2; the
    averaged oscillator (stiffness scaled by tau/delta) integrated with step delta, whose boundary
    delta^2 lambda_max(K_eff) = 4 tends to delta*tau*omega^2 = 2 (the stiff mode of this bond between two unit masses
    has frequency sqrt(2) omega, so this is the user guide's delta*tau*omega_stiff^2 <= 4); and delta*tau*omega^2 = 4,
    the same rule read with the paper's omega.
(b) Resonance on the FPU chain (m = 3, omega = 200, Fig. 6.5 start): error at the end of a run against omega*H for
    r-RESPA (openmm.mtsintegrator.MTSIntegrator, outer step H, inner steps with omega*h <= 0.1), deterministic SIM
    (Strang, friction 0) and Langevin SIM (Strang, friction 1 and 10 /ps, 10 K, an ensemble of independent chains).
    Deterministic runs: |H(T) - H(0)| / H(0) (and its maximum over the run, in the JSON).  Langevin: the error of the
    kinetic temperature, |<K> / (3/2 N_dof kT) - 1| over the ensemble and the second half of the run, which is exact
    at equilibrium whatever the potential and which an instability sends to infinity (the energy itself has no
    closed-form equilibrium value for the quartic chain).

    PYTHONPATH=build/python .venv/bin/python benchmarks/stability.py            # ~3-4 min
    PYTHONPATH=build/python .venv/bin/python benchmarks/stability.py --quick    # seconds (smoke test)
"""
import json
import math
import os
import time
import warnings

import numpy as np
import openmm as mm
import openmm.unit as unit
import openmmflavors

from flavorbench import reporting
from flavorbench.progress import Progress
from flavorbench.runners import KB, flavor, mts, sim, simulate
from flavorbench.systems import as_vec3, fpu_energy, fpu_initial, fpu_system, two_mass_system


# ----------------------------------------------------------------------------------------------------------------------
# (a) FLAVOR stability on (5.1)

def transfer_matrix(delta, tau, omega, scheme):
    """The exact one-mesostep map of the scheme on (x, y, px, py) for system (5.1)."""
    w2 = omega * omega
    soft_hess = np.array([[1.0, 0.0], [0.0, 0.0]])
    all_hess = soft_hess + w2 * np.array([[1.0, -1.0], [-1.0, 1.0]])

    def kick(h, hess):
        m = np.eye(4)
        m[2:, :2] = -h * hess
        return m

    def drift(h):
        m = np.eye(4)
        m[:2, 2:] = h * np.eye(2)
        return m

    if scheme == "SymplecticEuler":  # K_A(tau) D(tau) K_S(delta-tau) D(delta-tau), applied left to right
        flows = [kick(tau, all_hess), drift(tau), kick(delta - tau, soft_hess), drift(delta - tau)]
    else:
        r = delta - tau
        flows = [kick(tau / 2, all_hess), drift(tau / 2), kick(r / 2, soft_hess), drift(r), kick(r / 2, soft_hess),
                 drift(tau / 2), kick(tau / 2, all_hess)]
    total = np.eye(4)
    for f in flows:
        total = f @ total
    return total


def averaged_boundary(tau_w2, omega):
    """delta with delta^2 lambda_max(K_eff) = 4, K_eff = [[1 + k, -k], [-k, k]], k = omega^2 tau/delta (solved by
    bisection in delta for each tau*omega^2)."""
    out = []
    for tw in tau_w2:
        def f(delta):
            k = tw / delta
            lam = (1 + 2 * k + math.sqrt(1 + 4 * k * k)) / 2
            return delta * delta * lam - 4
        lo, hi = 1e-9, 2.0
        for _ in range(100):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if f(mid) < 0 else (lo, mid)
        out.append(lo)
    return np.array(out)


def flavor_domain(omega, deltas, tau_w2s, steps, scheme, progress):
    """Run-based (bool grid [tau, delta], True = bounded) and matrix-based (spectral radius) stability maps."""
    system = two_mass_system(omega)
    x0 = 0.8
    q0 = as_vec3([x0, x0 + 1.1 / omega])
    v0 = np.zeros((2, 3))
    bounded = np.zeros((len(tau_w2s), len(deltas)), dtype=bool)
    radius = np.zeros((len(tau_w2s), len(deltas)))
    growth = np.zeros((len(tau_w2s), len(deltas)))
    integrator = flavor(deltas[0], tau_w2s[0] / omega ** 2, scheme)
    context = mm.Context(system, integrator, mm.Platform.getPlatformByName("Reference"))
    for i, tw in enumerate(tau_w2s):
        tau = tw / omega ** 2
        for j, delta in enumerate(deltas):
            bounded[i, j], growth[i, j] = run_bounded(context, integrator, q0, v0, delta, tau, steps)
            radius[i, j] = np.max(np.abs(np.linalg.eigvals(transfer_matrix(delta, tau, omega, scheme))))
        progress.step(f"(a) {scheme} tau*omega^2 = {tw:.3g}")
    return bounded, radius, growth


def run_bounded(context, integrator, q0, v0, delta, tau, steps):
    """Run one (delta, tau) point from (q0, v0); True if |x|, |y| stay <= 100 for `steps` mesosteps."""
    integrator.setMicroStep(min(tau, integrator.getMesoStep().value_in_unit(unit.picoseconds)))
    integrator.setMesoStep(delta)
    integrator.setMicroStep(tau)
    context.setTime(0.0)
    context.setPositions(q0)
    context.setVelocities(v0)
    size = 0.0
    try:
        for _ in range(4):
            integrator.step(steps // 4)
            q = context.getState(getPositions=True).getPositions(asNumpy=True).value_in_unit(unit.nanometer)
            size = float(np.max(np.abs(q[:, 0])))
            if not math.isfinite(size) or size > 100:
                break
    except mm.OpenMMException:
        size = math.inf
    return math.isfinite(size) and size <= 100, size


def bisect(stable, lo, hi, iterations=30):
    """The boundary between stable(lo) = True and stable(hi) = False."""
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if stable(mid) else (lo, mid)
    return 0.5 * (lo + hi)


def boundaries(omega, steps, tau_w2s):
    """For each tau*omega^2: the delta where each scheme stops being bounded, found by bisection with runs of the
    integrator, by bisection on the transfer matrix's spectral radius, and from the averaged oscillator."""
    system = two_mass_system(omega)
    q0 = as_vec3([0.8, 0.8 + 1.1 / omega])
    v0 = np.zeros((2, 3))
    out = {"tau_omega2": list(tau_w2s), "averaged": averaged_boundary(tau_w2s, omega).tolist()}
    for scheme in ("SymplecticEuler", "Verlet"):
        integrator = flavor(0.1, 1e-9, scheme)
        context = mm.Context(system, integrator, mm.Platform.getPlatformByName("Reference"))
        runs, matrix = [], []
        for tw in tau_w2s:
            tau = tw / omega ** 2
            runs.append(bisect(lambda d: run_bounded(context, integrator, q0, v0, d, tau, steps)[0], 0.01, 3.0, 20))
            matrix.append(bisect(lambda d: np.max(np.abs(np.linalg.eigvals(transfer_matrix(d, tau, omega, scheme))))
                                 <= 1 + 1e-9, 0.01, 3.0, 40))
        out[scheme] = {"runs": runs, "matrix": matrix}
    return out


def part_a(args, progress):
    omega = 1000.0
    deltas = np.linspace(0.05, 3.0, args.a_deltas)
    tau_w2s = np.logspace(-3, 4, args.a_taus)
    out = {"omega": omega, "deltas": deltas.tolist(), "tau_omega2": tau_w2s.tolist(), "steps": args.a_steps,
           "start": {"x": 0.8, "y": "x + 1.1/omega", "v": 0}, "blow_up_threshold": 100, "schemes": {}}
    for scheme in ("SymplecticEuler", "Verlet"):
        bounded, radius, size = flavor_domain(omega, deltas, tau_w2s, args.a_steps, scheme, progress)
        exact = radius <= 1 + 1e-9
        out["schemes"][scheme] = {
            "bounded": bounded.astype(int).tolist(), "spectral_radius": radius.tolist(),
            "max_abs_position": [[s if math.isfinite(s) else None for s in row] for row in size.tolist()],
            "agreement_with_matrix": float(np.mean(bounded == exact)),
            "run_bounded_but_matrix_unstable": int(np.sum(bounded & ~exact)),
            "run_blew_up_but_matrix_stable": int(np.sum(~bounded & exact)),
        }
    out["averaged_boundary_delta"] = averaged_boundary(tau_w2s, omega).tolist()
    out["boundary"] = boundaries(omega, args.a_steps, [1e-3, 1e-2, 0.1, 1.0, 10.0])
    progress.step("(a) boundaries by bisection")
    return out


# ----------------------------------------------------------------------------------------------------------------------
# (b) Resonance on the FPU chain

def resonance_grid(quick):
    if quick:
        return np.array([0.5, 1.5, math.pi, 4.5, 2 * math.pi, 8.0])
    base = np.arange(0.2, 13.0 + 1e-9, 0.15)
    near = np.concatenate([k * math.pi + np.arange(-0.16, 0.1601, 0.02) for k in range(1, 5)])
    return np.unique(np.round(np.concatenate([base, near]), 6))


def deterministic_run(system, integrator, q0, v0, omega, T, H, samples=20):
    """|H(T) - H(0)|/H(0) and the maximum over `samples` equally spaced times; inf if the run blew up."""
    n = max(1, int(round(T / H)))
    marks = np.unique(np.linspace(0, n, samples + 1).astype(int))[1:]
    run = simulate(system, integrator, H, as_vec3(q0), as_vec3(v0), marks * H, "", progress=False, blowup=1e3)
    if not run["finite"]:
        return math.inf, math.inf
    e0 = fpu_energy(q0, v0, omega)
    errors = [abs(fpu_energy(q[:, 0], v[:, 0], omega) - e0) / e0 for q, v in zip(run["q"], run["v"])]
    return errors[-1], max(errors)


def langevin_run(omega, chains, T, H, temperature, friction, seed):
    """Kinetic-temperature error of a Langevin SIM ensemble over the second half of the run, and the mean total energy
    per chain there; inf if it blew up."""
    m = 3
    system = fpu_system(m, omega, chains)
    q0, v0 = fpu_initial(m, omega)
    n = max(2, int(round(T / H)))
    marks = np.unique(np.linspace(n // 2, n, 40 + 1).astype(int))
    run = simulate(system, sim(H, temperature=temperature, friction=friction, seed=seed), H,
                   as_vec3(np.tile(q0, chains), np.repeat(np.arange(chains, dtype=float), 2 * m)),
                   as_vec3(np.tile(v0, chains)), marks * H, "", energy=True, progress=False, blowup=math.inf)
    # The first sample only starts the averaging window.
    kinetic = [0.5 * float(np.sum(v * v)) for v in run["v"][1:]]
    if not run["finite"] or not all(k <= 1e6 * chains for k in kinetic):
        return math.inf, math.inf, 0
    energy = [(k + pe) / chains for k, pe in zip(kinetic, run["pe"][1:])]
    k_eq = 0.5 * 3 * system.getNumParticles() * KB * temperature
    return abs(np.mean(kinetic) / k_eq - 1.0), float(np.mean(energy)), len(kinetic)


def part_b(args, progress):
    omega = 200.0
    m = 3
    system = fpu_system(m, omega)
    q0, v0 = fpu_initial(m, omega)
    grid = resonance_grid(args.quick)
    frictions = args.frictions
    dof = 3 * 2 * m * args.chains
    out = {"omega": omega, "m": m, "T": args.b_T, "T_langevin": args.b_T_langevin, "start": "paper (Fig. 6.5)",
           "inner_omega_h": args.inner_wh,
           "langevin": {"frictions_per_ps": frictions, "temperature_K": args.temperature, "chains": args.chains,
                        "degrees_of_freedom": dof, "seed": 1234},
           "omega_H": grid.tolist(), "rrespa": [], "sim": [],
           "sim_langevin": {f"{g:g}": [] for g in frictions},
           "langevin_energy_per_chain": {f"{g:g}": [] for g in frictions}}
    samples = 0
    for wH in grid:
        H = wH / omega
        n = max(1, math.ceil(wH / args.inner_wh - 1e-9))
        out["rrespa"].append(deterministic_run(system, mts(H, n), q0, v0, omega, args.b_T, H))
        out["sim"].append(deterministic_run(system, sim(H), q0, v0, omega, args.b_T, H))
        for g in frictions:
            err, energy, count = langevin_run(omega, args.chains, args.b_T_langevin, H, args.temperature, g, 1234)
            out["sim_langevin"][f"{g:g}"].append(err)
            out["langevin_energy_per_chain"][f"{g:g}"].append(energy)
            samples = max(samples, count)
        progress.step(f"(b) omega*H = {wH:.3f}: r-RESPA {out['rrespa'][-1][0]:.2e}, SIM {out['sim'][-1][0]:.2e}, "
                      "Langevin SIM " + ", ".join(f"{out['sim_langevin'][f'{g:g}'][-1]:.2e} ({g:g}/ps)"
                                                  for g in frictions))
    # Statistical floor of the kinetic-temperature error: the relative standard deviation of a mean of `samples`
    # kinetic energies of `dof` degrees of freedom, were they independent (they are not: a lower bound).
    out["langevin"]["noise_floor"] = math.sqrt(2.0 / (dof * max(samples, 1)))
    # Failure summary: omega*H values where the (final) error exceeds a threshold.
    summary = {}
    series = [("rrespa", [v[0] for v in out["rrespa"]]), ("sim", [v[0] for v in out["sim"]])]
    series += [(f"sim_langevin_{g:g}", out["sim_langevin"][f"{g:g}"]) for g in frictions]
    for key, values in series:
        values = np.array(values)
        bad = grid[~(values <= args.threshold)]
        summary[key] = {"threshold": args.threshold, "failing_omega_H": bad.tolist(),
                        "intervals": intervals(grid, values <= args.threshold),
                        "median_error": float(np.median(values[np.isfinite(values)])) if np.isfinite(values).any()
                        else None,
                        "blown_up": int(np.sum(~np.isfinite(values)))}
    out["summary"] = summary
    return out


def intervals(grid, ok):
    """Maximal runs of failing grid points as [first, last] omega*H."""
    spans, start, prev = [], None, None
    for x, good in zip(grid, ok):
        if not good and start is None:
            start = x
        if good and start is not None:
            spans.append([float(start), float(prev)])
            start = None
        prev = x
    if start is not None:
        spans.append([float(start), float(grid[-1])])
    return spans


# ----------------------------------------------------------------------------------------------------------------------
# Charts

def plot_stability(a, path, dpi, small=False):
    from matplotlib.colors import ListedColormap
    plt = reporting.pyplot()

    deltas, tw = np.array(a["deltas"]), np.array(a["tau_omega2"])
    fig, axes = plt.subplots(1, 2, figsize=(12, 5.6), sharey=True)
    avg = np.array(a["averaged_boundary_delta"])
    for ax, (scheme, s) in zip(axes, a["schemes"].items()):
        bounded = np.array(s["bounded"])
        radius = np.array(s["spectral_radius"])
        ax.pcolormesh(deltas, tw, bounded, cmap=ListedColormap(["#f4a6a6", "#a6d8a6"]), shading="nearest")
        ax.contour(deltas, tw, np.log10(np.maximum(radius, 1.0) - 1.0 + 1e-16), levels=[-8.5], colors="k",
                   linewidths=0.8)
        ax.axvline(2.0, color="tab:blue", lw=1.5, ls="--", label="Theorem 5.1: δ = 2 ps")
        ax.plot(avg, tw, color="tab:purple", lw=1.5, label="averaged oscillator: δ² λ_max(K_eff) = 4")
        d = np.linspace(0.05, 3.0, 200)
        ax.plot(d, 2.0 / d, color="tab:purple", lw=0.8, ls=":",
                label="its asymptote δτω_stiff² = 4, the user guide's rule (ω_stiff = √2 ω: δτω² = 2)")
        ax.plot(d, 4.0 / d, color="tab:orange", lw=1.2, ls="--",
                label="δτω² = 4: the same rule read with the paper's ω in place of ω_stiff")
        ax.axhline(math.sqrt(2) * a["omega"], color="gray", lw=0.8, ls="-.",
                   label="inner step limit τ√2 ω = 2")
        ax.set_yscale("log")
        ax.set_xlim(deltas[0], deltas[-1])
        ax.set_ylim(tw[0], tw[-1])
        ax.set_xlabel("mesostep δ (ps)")
        ax.set_title(f"FLAVOR {scheme}: green bounded after {a['steps']} mesosteps, red blew up;\nblack: spectral "
                     f"radius = 1 of the exact transfer matrix (agreement {100 * s['agreement_with_matrix']:.1f} %)",
                     fontsize=9)
    axes[0].set_ylabel("microstep τ times ω²:  τω² = τ/ε (ps⁻¹)")
    # Below the panels: inside, the legend would hide part of the domain.
    fig.legend(*axes[-1].get_legend_handles_labels(), fontsize=8, loc="lower center", ncol=3, frameon=False)
    agreement = min(s["agreement_with_matrix"] for s in a["schemes"].values())
    fig.suptitle(f"Both FLAVOR schemes are stable exactly where the transfer matrix says (≥ {100 * agreement:.1f} % "
                 f"of the grid): δ < 2 ps (Theorem 5.1) and δτω_stiff² ≤ 4\nsystem (5.1) of the FLAVORS paper "
                 f"(Fig. 5.1), ω = {a['omega']:g} ps⁻¹, SymplecticEuler and Verlet; units 1 amu, 1 nm, 1 ps",
                 fontsize=10.5)
    fig.tight_layout(rect=(0, 0.1, 1, 1))
    reporting.save_figure(fig, path, dpi, small)


def resonance_verdict(b):
    """Where each method fails, in multiples of π, for the title."""
    names = [("rrespa", "r-RESPA"), ("sim", "SIM γ = 0")]
    names += [(f"sim_langevin_{float(g):g}", f"SIM γ = {float(g):g} ps⁻¹") for g in b["sim_langevin"]]
    parts = []
    for key, name in names:
        spans = b["summary"][key]["intervals"]
        if not spans:
            parts.append(f"{name} nowhere")
            continue
        centres = sorted({round(0.5 * (lo + hi) / math.pi, 1) for lo, hi in spans})
        parts.append(f"{name} near ωH = " + ", ".join(f"{c:g}π" for c in centres))
    return "Fails (error > %g): " % b["summary"]["sim"]["threshold"] + "; ".join(parts)


def plot_resonance(b, path, dpi, small=False):
    plt = reporting.pyplot()

    grid = np.array(b["omega_H"])
    cap = 1e3
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(12, 8.4), sharex=True)

    def clip(values):
        return np.array([min(v, cap) if v is not None and math.isfinite(v) else cap for v in values])

    top.semilogy(grid, clip([v[0] for v in b["rrespa"]]), color="tab:blue", lw=1, marker=".", ms=3,
                 label=f"r-RESPA (MTSIntegrator, inner ωh ≤ {b['inner_omega_h']:g})")
    top.semilogy(grid, clip([v[0] for v in b["sim"]]), color="tab:green", lw=1, marker=".", ms=3,
                 label="SIM Strang, friction γ = 0")
    top.set_ylabel("total energy error |E(T) − E(0)|/E(0)")
    for g, color in zip(b["sim_langevin"], ("tab:red", "tab:orange", "tab:brown")):
        bottom.semilogy(grid, clip(b["sim_langevin"][g]), color=color, lw=1, marker=".", ms=3,
                        label=f"SIM Strang, friction γ = {float(g):g} ps⁻¹")
    bottom.axhline(b["langevin"]["noise_floor"], color="gray", lw=0.8, ls="--",
                   label="statistical floor of this measure (independent samples)")
    bottom.set_ylabel("kinetic temperature error |⟨K⟩/K_eq − 1|")
    for ax in (top, bottom):
        for k in range(1, int(grid[-1] / math.pi) + 1):
            ax.axvline(k * math.pi, color="gray", lw=0.6, ls=":")
        ax.axhline(cap, color="k", lw=0.5)
        ax.text(grid[0], cap * 1.3, "blown up / ≥ 1e3", fontsize=7)
        ax.set_ylim(1e-7, cap * 5)
        ax.legend(fontsize=8, loc="lower right", framealpha=0.9)
    top.set_title(f"deterministic runs over T = {b['T']:g} ps", fontsize=9)
    bottom.set_title(f"Langevin runs over T = {b['T_langevin']:g} ps, {b['langevin']['temperature_K']:g} K, "
                     f"{b['langevin']['chains']} chains", fontsize=9)
    bottom.set_xlabel("ωH, stiff frequency ω times outer step H (dimensionless; dotted: multiples of π)")
    fig.suptitle(f"Resonances of the impulse methods on the FPU chain (ω = {b['omega']:g} ps⁻¹; units 1 amu, 1 nm, "
                 f"1 ps)\n{resonance_verdict(b)}", fontsize=10)
    fig.tight_layout()
    reporting.save_figure(fig, path, dpi, small)


def main():
    # Reduced units (steps of order 1), and resonances on purpose: these runs measure where the methods fail.
    warnings.filterwarnings("ignore", category=openmmflavors.UnitlessStepWarning)
    warnings.filterwarnings("ignore", category=openmmflavors.ResonanceWarning)
    parser = reporting.parser(__doc__, "stability", quick_help="coarse grids and short runs (smoke test)")
    parser.add_argument("--docs", default=None,
                        help="also write small copies of the charts (dpi 80, 64 colours) to this folder")
    parser.add_argument("--replot", action="store_true",
                        help="run nothing: redraw the charts (and --docs copies) from OUT/stability.json")
    parser.add_argument("--a-deltas", type=int, default=60, help="(a) grid points in delta")
    parser.add_argument("--a-taus", type=int, default=57, help="(a) grid points in tau*omega^2 (log, 1e-3..1e4)")
    parser.add_argument("--a-steps", type=int, default=2000, help="(a) mesosteps per point")
    parser.add_argument("--b-T", type=float, default=50.0, help="(b) deterministic run length")
    parser.add_argument("--b-T-langevin", type=float, default=20.0, help="(b) Langevin run length")
    parser.add_argument("--inner-wh", type=float, default=0.1, help="(b) r-RESPA inner omega*h at most")
    parser.add_argument("--chains", type=int, default=32, help="(b) chains in the Langevin ensemble")
    parser.add_argument("--frictions", type=float, nargs="+", default=[1.0, 10.0],
                        help="(b) Langevin SIM friction coefficients (1/ps)")
    parser.add_argument("--temperature", type=float, default=10.0, help="(b) Langevin temperature (K)")
    parser.add_argument("--threshold", type=float, default=0.1, help="(b) error above which a run counts as failed")
    args = parser.parse_args()
    if args.replot:
        with open(os.path.join(args.out, "stability.json")) as f:
            data = json.load(f)
        reporting.set_smoke_run(data.get("quick", False))
        charts = [(plot_stability, data["flavor_domain"], "stability.png"),
                  (plot_resonance, data["resonance"], "resonance.png")]
        for draw, part, name in charts:
            draw(part, os.path.join(args.out, name), 100)
            if args.docs:
                os.makedirs(args.docs, exist_ok=True)
                draw(part, os.path.join(args.docs, name), 80, small=True)
        return
    if args.quick:
        args.a_deltas, args.a_taus, args.a_steps = 10, 8, 400
        args.b_T, args.b_T_langevin, args.chains, args.frictions = 5.0, 3.0, 4, [1.0]
    started = time.perf_counter()
    progress = Progress("stability", 2 * args.a_taus + 1 + len(resonance_grid(args.quick)), fmt="d")
    a = part_a(args, progress)
    b = part_b(args, progress)
    data = {"quick": args.quick, "openmm_version": mm.__version__, "platform": "Reference", "flavor_domain": a,
            "resonance": b}
    data["wall_s_total"] = time.perf_counter() - started
    reporting.write_json(os.path.join(args.out, "stability.json"), data)
    plot_stability(a, os.path.join(args.out, "stability.png"), 100)
    plot_resonance(b, os.path.join(args.out, "resonance.png"), 100)
    if args.docs:
        os.makedirs(args.docs, exist_ok=True)
        plot_stability(a, os.path.join(args.docs, "stability.png"), 80, small=True)
        plot_resonance(b, os.path.join(args.docs, "resonance.png"), 80, small=True)

    print(f"\nStability ({'quick' if args.quick else 'full'}), Reference platform, {data['wall_s_total']:.0f} s")
    print(f"(a) FLAVOR on (5.1), omega = {a['omega']:g}, {a['steps']} mesosteps per point")
    for scheme, s in a["schemes"].items():
        print(f"  {scheme:15s} grid: agreement of the runs with the exact transfer matrix "
              f"{100 * s['agreement_with_matrix']:.1f} % (bounded but unstable {s['run_bounded_but_matrix_unstable']}, "
              f"blew up but stable {s['run_blew_up_but_matrix_stable']})")
    bd = a["boundary"]
    print("  boundary delta by bisection (runs / transfer matrix), and the averaged oscillator's:")
    for k, tw in enumerate(bd["tau_omega2"]):
        print(f"    tau*omega^2 = {tw:<6g} SymplecticEuler {bd['SymplecticEuler']['runs'][k]:.4f} / "
              f"{bd['SymplecticEuler']['matrix'][k]:.4f}   Verlet {bd['Verlet']['runs'][k]:.4f} / "
              f"{bd['Verlet']['matrix'][k]:.4f}   averaged {bd['averaged'][k]:.4f}   "
              f"(delta*tau*omega^2 = {tw * bd['Verlet']['runs'][k]:.3g})")
    print(f"(b) resonance, FPU omega = {b['omega']:g}: omega*H where the error exceeds {args.threshold:g}")
    names = [("rrespa", "r-RESPA"), ("sim", "SIM Strang")]
    names += [(f"sim_langevin_{g:g}", f"Langevin SIM {g:g}/ps") for g in args.frictions]
    for key, name in names:
        s = b["summary"][key]
        spans = ", ".join(f"[{lo:.2f}, {hi:.2f}]" if hi > lo else f"{lo:.2f}" for lo, hi in s["intervals"]) or "none"
        print(f"  {name:20s} failing: {spans}; median error {s['median_error']:.2e}; blown up at {s['blown_up']} "
              f"points")
    print(f"wrote {args.out}/stability.json, stability.png and resonance.png")


if __name__ == "__main__":
    main()
