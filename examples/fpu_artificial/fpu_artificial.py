#!/usr/bin/env python3
"""Energy exchange among the stiff springs of the Fermi-Pasta-Ulam chain: the FLAVOR averagings against a fine
velocity-Verlet reference (FLAVORS paper, Figs. 6.4, 6.5 and 6.7).

    H = 1/2 sum p^2 + omega^2/4 sum_{i=1..m} (q_2i - q_2i-1)^2 + sum_{i=0..m} (q_2i+1 - q_2i)^4,  q_0 = q_2m+1 = 0

m = 3, omega = 200, unit masses on the x axis; start x0 = (1, 0, 0), x1 = (1/omega, 0, 0) (slow and fast coordinates
x0_i = (q_2i + q_2i-1)/sqrt2, x1_i = (q_2i - q_2i-1)/sqrt2), at rest.  Observables: the stiff springs' energies
I_j = (x1_j'^2 + omega^2 x1_j^2)/2, whose slow exchange over O(omega) times is what Fig. 6.5 shows.

Runs (Reference platform): OpenMM's VerletIntegrator at h = 1e-5 (the reference, as in the paper), and
FlavorIntegrator SymplecticEuler with delta = 0.002, tau = 0.0005 (the paper's Fig. 6.5 parameters) for the
Nonintrusive, Artificial (eq. (2.11)) and ArtificialProjected averagings, and the Artificial one with the exact fast
flow at tau = 1e-4 (Fig. 6.7).

    PYTHONPATH=build/python .venv/bin/python examples/fpu_artificial/fpu_artificial.py [--quick] [--T T] [--out DIR]

Outputs: DIR/fpu_artificial.json and DIR/fpu_artificial.png.

With --long, the O(omega^2) time scale of Fig. 6.8 instead (T = omega^2 = 40,000): the artificial FLAVOR
(SymplecticEuler, delta = 0.002, tau = 0.0005), the impulse method StochasticImpulseIntegrator Strang without friction
at H = delta (the exact stiff flow: r-RESPA with an exact inner integrator) and VerletIntegrator at h = 1e-4 (a fine
reference at h = 1e-5 would take 4e9 steps), sampled every 10 time units: I_1, I_2, I_3 and the total energy H.
Outputs DIR/fpu_long.json and DIR/fpu_long.png.
"""
import argparse
import json
import math
import os
import re
import time

import numpy as np
import openmm as mm

from flavorbench import reporting
from openmmflavors import FlavorIntegrator, StochasticImpulseIntegrator

M, OMEGA = 3, 200.0


def fpu_system():
    system = mm.System()
    stiff = mm.HarmonicBondForce()
    soft = mm.CustomBondForce("r^4")
    walls = mm.CustomExternalForce("x^4")
    stiff.setForceGroup(1)
    for _ in range(2 * M):
        system.addParticle(1.0)
    for i in range(M):
        stiff.addBond(2 * i, 2 * i + 1, 0.0, OMEGA ** 2 / 2)
    for i in range(M - 1):
        soft.addBond(2 * i + 1, 2 * i + 2, [])
    walls.addParticle(0, [])
    walls.addParticle(2 * M - 1, [])
    for force in (stiff, soft, walls):
        system.addForce(force)
    return system


def start_positions():
    x0, x1 = [1.0, 0.0, 0.0], [1 / OMEGA, 0.0, 0.0]
    positions = []
    for i in range(M):
        positions += [mm.Vec3((x0[i] - x1[i]) / math.sqrt(2), 0, 0), mm.Vec3((x0[i] + x1[i]) / math.sqrt(2), 0, 0)]
    return positions


def stiff_energies(q, v):
    x1 = (q[1::2] - q[0::2]) / math.sqrt(2)
    v1 = (v[1::2] - v[0::2]) / math.sqrt(2)
    return 0.5 * (v1 ** 2 + OMEGA ** 2 * x1 ** 2)


def total_energy(q, v):
    """H of (6.7) with q_0 = q_2m+1 = 0 (the walls x^4 on the end particles)."""
    stiff = OMEGA ** 2 / 4 * np.sum((q[1::2] - q[0::2]) ** 2)
    soft = np.sum((q[2::2] - q[1:-1:2]) ** 4) + q[0] ** 4 + q[-1] ** 4
    return 0.5 * np.sum(v ** 2) + stiff + soft


def run(integrator, dt, times, leapfrog, energy=None):
    """I_j at the given times; leapfrog: OpenMM's VerletIntegrator, whose velocities lag half a step.  If energy is a
    list, H is appended to it at each time."""
    context = mm.Context(fpu_system(), integrator, mm.Platform.getPlatformByName("Reference"))
    context.setPositions(start_positions())

    def forces():
        return context.getState(getForces=True).getForces(asNumpy=True)._value[:, 0]

    if leapfrog:
        f = forces()
        context.setVelocities([mm.Vec3(-0.5 * dt * f[i], 0, 0) for i in range(2 * M)])
    energies, t, elapsed, steps = [], 0.0, 0.0, 0
    for target in times:
        n = int(round((target - t) / dt))
        start = time.perf_counter()
        integrator.step(n)
        elapsed += time.perf_counter() - start
        steps += n
        t = target
        state = context.getState(getPositions=True, getVelocities=True)
        q = state.getPositions(asNumpy=True)._value[:, 0]
        v = state.getVelocities(asNumpy=True)._value[:, 0]
        if leapfrog:
            v = v + 0.5 * dt * forces()
        if not np.all(np.isfinite(q)):
            break
        energies.append(stiff_energies(q, v))
        if energy is not None:
            energy.append(float(total_energy(q, v)))
    return np.array(energies), elapsed, steps


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="T = 5 (smoke test)")
    parser.add_argument("--T", type=float, default=200.0, help="simulated time (default omega = 200)")
    parser.add_argument("--out", default="results/fpu_artificial")
    parser.add_argument("--replot", metavar="JSON", help="only redraw the chart of an earlier run's JSON into --out")
    parser.add_argument("--long", action="store_true", help="Fig. 6.8: the O(omega^2) time scale (T = omega^2)")
    args = parser.parse_args()
    reporting.set_smoke_run(args.quick)
    if args.replot:
        reporting.replot(args.replot, args.out, "fpu_long" if args.long else "fpu_artificial",
                         plot_long if args.long else plot)
        return
    if args.long:
        long_time(args)
        return
    T = 5.0 if args.quick else args.T
    times = list(np.arange(0.5, T + 1e-9, 0.5))
    runs = {}
    h = 1e-5
    energies, elapsed, steps = run(mm.VerletIntegrator(h), h, times, True)
    runs["Verlet h=1e-5 (reference)"] = (energies, elapsed, steps, h)
    settings = [("FLAVOR Nonintrusive δ=0.002 τ=0.0005", FlavorIntegrator.Nonintrusive, 5e-4, False),
                ("FLAVOR Artificial δ=0.002 τ=0.0005", FlavorIntegrator.Artificial, 5e-4, False),
                ("FLAVOR ArtificialProjected δ=0.002 τ=0.0005", FlavorIntegrator.ArtificialProjected, 5e-4, False),
                ("FLAVOR Artificial, exact fast flow, δ=0.002 τ=1e-4", FlavorIntegrator.Artificial, 1e-4, True)]
    for name, averaging, tau, exact in settings:
        integrator = FlavorIntegrator(0.002, tau, {1})
        integrator.setScheme(FlavorIntegrator.SymplecticEuler)
        integrator.setAveraging(averaging)
        integrator.setExactFastFlow(exact)
        energies, elapsed, steps = run(integrator, 0.002, times, False)
        runs[name] = (energies, elapsed, steps, 0.002)
    reference = runs["Verlet h=1e-5 (reference)"][0]
    result = {"m": M, "omega": OMEGA, "T": T, "times": times, "runs": {}}
    for name, (energies, elapsed, steps, dt) in runs.items():
        n = min(len(energies), len(reference))
        error = np.max(np.abs(energies[:n] - reference[:n]), axis=0) if n else [float("nan")] * M
        result["runs"][name] = {
            "I": energies.tolist(), "wall_s": elapsed, "steps": steps, "step": dt,
            "max_error_I": [float(e) for e in error],
            "I_T": [float(e) for e in energies[-1]] if len(energies) == len(times) else None,
            "speedup_vs_reference_wall": runs["Verlet h=1e-5 (reference)"][1] / elapsed if elapsed > 0 else None,
            "stable": len(energies) == len(times)}
        print("%-52s %8d steps %7.2f s  I(T) = %s  max |I - I_ref| = %s" % (
            name, steps, elapsed, np.array2string(energies[-1], precision=4),
            np.array2string(np.array(error), precision=3)))
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "fpu_artificial.json"), "w") as f:
        json.dump(result, f, indent=1)
    plot(result, os.path.join(args.out, "fpu_artificial.png"))


def long_time(args):
    T = 20.0 if args.quick else OMEGA ** 2
    times = list(np.arange(10.0 if not args.quick else 1.0, T + 1e-9, 10.0 if not args.quick else 1.0))
    flavor = FlavorIntegrator(0.002, 5e-4, {1})
    flavor.setScheme(FlavorIntegrator.SymplecticEuler)
    flavor.setAveraging(FlavorIntegrator.Artificial)
    settings = [("FLAVOR Artificial δ=0.002 τ=0.0005", flavor, 0.002, False),
                ("SIM Strang H=0.002 (impulse method, exact stiff flow)",
                 StochasticImpulseIntegrator(0.0, 0.0, 0.002, {1}), 0.002, False),
                ("Verlet h=1e-4", mm.VerletIntegrator(1e-4), 1e-4, True)]
    result = {"m": M, "omega": OMEGA, "T": T, "times": times, "runs": {}}
    for name, integrator, dt, leapfrog in settings:
        energy = []
        energies, elapsed, steps = run(integrator, dt, times, leapfrog, energy)
        total = energies.sum(axis=1) if len(energies) else np.zeros(0)
        result["runs"][name] = {
            "I": energies.tolist(), "H": energy, "wall_s": elapsed, "steps": steps, "step": dt,
            "stable": len(energies) == len(times),
            "I_total_range": [float(total.min()), float(total.max())] if len(total) else None,
            "H_range": [min(energy), max(energy)] if energy else None}
        print("%-55s %10d steps %8.1f s  sum I in [%.4f, %.4f]  H in [%.6f, %.6f]" % (
            name, steps, elapsed, total.min(), total.max(), min(energy), max(energy)), flush=True)
    reporting.save_outputs(args.out, "fpu_long", result, lambda path: plot_long(result, path))


def run_label(name):
    """A run's name in the charts' notation, with the steps' units: "δ=0.002 τ=0.0005" as "δ = 0.002 ps, τ = 0.0005 ps",
    "H=0.002" as "H = 0.002 ps" (the SIM step), "h=1e-4" as "h = 1e-4 ps" (the Verlet step)."""
    label = re.sub(r"([δτHh])=([0-9.e-]+)", r"\1 = \2 ps", name)
    return label.replace("ps τ", "ps, τ")


def initial_energy():
    """E(0): the total energy (6.7) of the start, at rest (every run starts there)."""
    q = np.array([p.x for p in start_positions()])
    return float(total_energy(q, np.zeros_like(q)))


def long_verdict(result):
    """The title's verdict: whether every run stayed finite and its energy error E(t) - E(0) did not grow from the
    first to the second half of the run, with each run's largest |E(t) - E(0)| / E(0)."""
    start = initial_energy()
    parts, bounded = [], True
    for name, run in result["runs"].items():
        energy = np.array(run["H"], dtype=float)
        short = name.split(" ")[0]
        if not run["stable"] or not len(energy) or not np.all(np.isfinite(energy)):
            parts.append("%s blew up" % short)
            bounded = False
            continue
        excursion = np.abs(energy - start)
        half = len(excursion) // 2
        grows = bool(half) and excursion[half:].max() > 2 * excursion[:half].max()
        bounded = bounded and not grows
        parts.append("%s %.2g %%%s" % (short, 100 * excursion.max() / abs(start), " and growing" if grows else ""))
    head = ("all three stay bounded (the energy error does not grow from the first half to the second)" if bounded
            else "not every run stays bounded")
    return "%s; largest |E(t) − E(0)|/E(0): %s" % (head, ", ".join(parts))


def power_of_ten(n):
    """n as "2·10⁷" (or as it is below 1000)."""
    if n < 1000:
        return "%d" % n
    exponent = int(math.floor(math.log10(n)))
    mantissa = n / 10 ** exponent
    digits = str(exponent).translate(str.maketrans("0123456789-", "⁰¹²³⁴⁵⁶⁷⁸⁹⁻"))
    return ("%.3g·10%s" % (mantissa, digits)) if round(mantissa, 3) != 1 else "10" + digits


def plot_long(result, path):
    plt = reporting.pyplot()
    times = np.array(result["times"])
    start = initial_energy()
    fig, axes = plt.subplots(len(result["runs"]), 2, figsize=(16, 3.6 * len(result["runs"]) + 1.2), squeeze=False)
    lines = []
    for row, (name, run) in enumerate(result["runs"].items()):
        energies = np.array(run["I"])
        title = "%s: %s steps in %.0f s" % (run_label(name), power_of_ten(run["steps"]), run["wall_s"])
        ax = axes[row, 0]
        lines = [ax.plot(times[:len(energies)], energies[:, j], lw=0.8, label="$I_%d$" % (j + 1))[0]
                 for j in range(M) if len(energies)]
        ax.set_ylabel("stiff spring energy $I_j$ (kJ/mol)", fontsize=10)
        ax.set_title(title, fontsize=11)
        ax = axes[row, 1]
        ax.plot(times[:len(run["H"])], np.array(run["H"]) - start, "k", lw=0.8)
        ax.axhline(0.0, color="0.6", lw=0.6, zorder=0)
        ax.set_ylabel("E(t) − E(0) (kJ/mol)", fontsize=10)
        ax.set_title("%s: total energy E" % name.split(" ")[0], fontsize=11)
    for ax in axes[-1]:
        ax.set_xlabel("t (ps)", fontsize=10)
    # One legend for the three springs, below the panels, so that it hides no line.
    fig.legend(lines, ["$I_%d$, stiff spring %d" % (j + 1, j + 1) for j in range(len(lines))], loc="lower center",
               ncol=M, fontsize=10, frameon=False, bbox_to_anchor=(0.5, 0.012))
    fig.text(0.01, 0.005, "Eq. (6.7) in OpenMM units (masses 1 amu, lengths in nm, t in ps, energies in kJ/mol); "
             "E: the total energy of (6.7), sampled every %g ps; E(0) = %.6f kJ/mol, the start at rest." % (
                 times[1] - times[0] if len(times) > 1 else 0, start),
             fontsize=9)
    fig.suptitle("FPU chain (m = 3, ω = %g/ps) over T = %g ps (ω² in the paper's units; FLAVORS paper, Fig. 6.8): "
                 "FLAVOR, the impulse method (SIM) and Verlet, no reference\n%s" % (result["omega"], result["T"], long_verdict(result)),
                 fontsize=12)
    fig.tight_layout(rect=(0, 0.05, 1, 0.95))
    reporting.save_figure(fig, path, 80)


def plot(result, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 3, figsize=(18, 5.5), sharex=True)
    times = np.array(result["times"])
    styles = ["k-", "C3--", "C0-", "C2-.", "C1:"]
    for j, ax in enumerate(axes):
        for (name, run), style in zip(result["runs"].items(), styles):
            energies = np.array(run["I"])
            if len(energies):
                ax.plot(times[:len(energies)], energies[:, j], style, lw=1.2, label=name)
        ax.set_xlabel("t (ps; eq. 6.7 in units 1 amu, 1 nm, 1 ps)")
        ax.set_ylabel("$I_%d$, energy of stiff spring %d (kJ/mol)" % (j + 1, j + 1))
        ax.set_yscale("log")
        ax.set_title("$I_%d$" % (j + 1))
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=3, fontsize=9)
    fig.suptitle("FPU chain (m = 3, ω = %g): energy exchange among the stiff springs, FLAVOR averagings (δ = 0.002) "
                 "against velocity Verlet (h = 1e-5)" % result["omega"])
    fig.tight_layout(rect=(0, 0.1, 1, 1))
    reporting.save_figure(fig, path, 90)


if __name__ == "__main__":
    main()
