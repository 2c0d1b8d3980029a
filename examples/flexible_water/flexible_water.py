#!/usr/bin/env python3
"""Flexible TIP3P water (501 molecules, 1,503 atoms, PME) on the CPU platform: the artificial FLAVOR against
OpenMM's integrators, all run here from the same equilibrated start.

Peers (Langevin, 300 K, friction 1/ps):
  - LangevinMiddleIntegrator, flexible water, 0.25 fs (the reference) and 0.5 fs;
  - LangevinMiddleIntegrator, rigid water (SETTLE), 2 fs;
  - MTSLangevinIntegrator, flexible, 2 fs outer with 4 inner steps for the bonds and angles;
  - FlavorIntegrator (Verlet scheme), O-H bonds stiff: Nonintrusive, Artificial and ArtificialProjected averaging
    over a sweep of the mesostep delta and microstep tau; with "+angles" also the H-O-H angles stiff (the
    artificial FLAVOR then freezes the H-H distance as well); "Middle": the thermostat in the middle of the
    microstep (FlavorIntegrator.Middle) instead of at the edges of the mesostep.

Observables, each with a block-average error bar (the standard error of the block means): mean O-H length and its
spread, mean H-O-H angle and its spread, potential energy per molecule, kinetic temperature of O and of H
separately, and g_OO(r) (the first-peak height).  ns/day is measured over the production run of each peer.

    PYTHONPATH=build/python /usr/bin/python3 examples/flexible_water/flexible_water.py [--quick] [--out DIR]
        [--start PS] [--equilibration PS] [--production PS] [--threads N] [--peers NAME ...]

--peers runs only the peers whose names contain one of the given strings (the first of them is the chart's reference
line); several runs with the same --peers give independent replicas (each builds and equilibrates its own start).

Every peer starts from the same state: minimized, then --start ps of LangevinMiddle (flexible, 0.5 fs); each peer
then equilibrates for --equilibration ps with its own integrator before --production ps of measurement.

Outputs: DIR/flexible_water.json (every number) and DIR/flexible_water.png.
"""
import argparse
import json
import os

import numpy as np
import openmm as mm
import openmm.app as app
import openmm.unit as unit

import openmmflavors
from flavorbench import reporting
from flavorbench.runners import KB
from flavorbench.systems import assign_force_groups
from flavorbench.timeseries import ProductionFrames, add_block_errors

TEMPERATURE = 300.0  # K
FRICTION = 1.0  # 1/ps
BOND_GROUP, ANGLE_GROUP = 1, 2


def build_box(molecules):
    """A cubic box of TIP3P water with the given number of molecules."""
    forcefield = app.ForceField("tip3p.xml")
    modeller = app.Modeller(app.Topology(), [])
    modeller.addSolvent(forcefield, model="tip3p", numAdded=molecules, neutralize=False)
    return forcefield, modeller


def make_system(forcefield, topology, rigid):
    system = forcefield.createSystem(topology, nonbondedMethod=app.PME, nonbondedCutoff=0.9 * unit.nanometer,
                                     rigidWater=rigid, constraints=None, removeCMMotion=False)
    return assign_force_groups(system, {mm.HarmonicBondForce: BOND_GROUP, mm.HarmonicAngleForce: ANGLE_GROUP})


def common_start(forcefield, modeller, start_ps, threads, minimizer_iterations=200, friction=FRICTION):
    """The peers' common start: the box minimized, then start_ps of LangevinMiddle (flexible, 0.5 fs, at `friction`
    in 1/ps); its positions."""
    system = make_system(forcefield, modeller.topology, False)
    integrator = mm.LangevinMiddleIntegrator(TEMPERATURE, friction, 0.5e-3)
    context = mm.Context(system, integrator, mm.Platform.getPlatformByName("CPU"), {"Threads": str(threads)})
    context.setPositions(modeller.positions)
    mm.LocalEnergyMinimizer.minimize(context, 10.0, minimizer_iterations)
    context.setVelocitiesToTemperature(TEMPERATURE * unit.kelvin, 3)
    integrator.step(int(round(start_ps * 2000)))
    return context.getState(getPositions=True).getPositions()


def peers(flavor_settings):
    """(name, rigid, factory) for every peer; factory() returns the integrator."""
    result = [
        ("LangevinMiddle flexible 0.25 fs", False, lambda: mm.LangevinMiddleIntegrator(TEMPERATURE, FRICTION, 0.25e-3)),
        ("LangevinMiddle flexible 0.5 fs", False, lambda: mm.LangevinMiddleIntegrator(TEMPERATURE, FRICTION, 0.5e-3)),
        ("LangevinMiddle rigid 2 fs", True, lambda: mm.LangevinMiddleIntegrator(TEMPERATURE, FRICTION, 2e-3)),
        ("MTSLangevin 2 fs / 4", False,
         lambda: mm.MTSLangevinIntegrator(TEMPERATURE, FRICTION, 2e-3, [(0, 1), (BOND_GROUP, 4), (ANGLE_GROUP, 4)])),
    ]
    averagings = {"Nonintrusive": openmmflavors.FlavorIntegrator.Nonintrusive,
                  "Artificial": openmmflavors.FlavorIntegrator.Artificial,
                  "ArtificialProjected": openmmflavors.FlavorIntegrator.ArtificialProjected}
    for averaging, delta, tau, angles, middle in flavor_settings:
        groups = {BOND_GROUP} | ({ANGLE_GROUP} if angles else set())

        def factory(averaging=averaging, delta=delta, tau=tau, groups=groups, middle=middle):
            integrator = openmmflavors.FlavorIntegrator(delta * unit.femtosecond, tau * unit.femtosecond, groups)
            integrator.setAveraging(averagings[averaging])
            integrator.setTemperature(TEMPERATURE * unit.kelvin)
            integrator.setFriction(FRICTION / unit.picosecond)
            if middle:
                integrator.setThermostatPlacement(openmmflavors.FlavorIntegrator.Middle)
            integrator.setRandomNumberSeed(1234)
            return integrator

        name = "FLAVOR %s%s%s δ=%g fs τ=%g fs" % (averaging, " +angles" if angles else "", " Middle" if middle else "",
                                                 delta, tau)
        result.append((name, False, factory))
    return result


def frame_observables(positions, velocities, box, oxygens, masses, rdf_edges):
    """Per-frame averages: O-H length mean and spread, H-O-H angle mean and spread (degrees), T of O and H, g_OO."""
    o = positions[oxygens]
    h1 = positions[oxygens + 1]
    h2 = positions[oxygens + 2]
    d1, d2 = h1 - o, h2 - o
    r1, r2 = np.linalg.norm(d1, axis=1), np.linalg.norm(d2, axis=1)
    oh = np.concatenate([r1, r2])
    angle = np.degrees(np.arccos(np.clip(np.sum(d1 * d2, axis=1) / (r1 * r2), -1, 1)))
    v2 = np.sum(velocities ** 2, axis=1) * masses
    hydrogens = np.concatenate([oxygens + 1, oxygens + 2])
    t_o = np.sum(v2[oxygens]) / (3 * len(oxygens) * KB)
    t_h = np.sum(v2[hydrogens]) / (3 * len(hydrogens) * KB)
    # g_OO with the minimum image in the cubic box.
    diff = o[:, None, :] - o[None, :, :]
    diff -= box * np.round(diff / box)
    dist = np.linalg.norm(diff, axis=2)[np.triu_indices(len(o), 1)]
    counts, _ = np.histogram(dist, bins=rdf_edges)
    shells = 4 / 3 * np.pi * (rdf_edges[1:] ** 3 - rdf_edges[:-1] ** 3)
    density = len(o) / box ** 3
    g = counts / (shells * density * len(o) / 2)
    return oh.mean(), oh.std(), angle.mean(), angle.std(), t_o, t_h, g


def run_peer(name, rigid, factory, forcefield, topology, start_positions, equilibration_ps, production_ps, frames,
             threads):
    system = make_system(forcefield, topology, rigid)
    integrator = factory()
    platform = mm.Platform.getPlatformByName("CPU")
    context = mm.Context(system, integrator, platform, {"Threads": str(threads)})
    context.setPositions(start_positions)
    if rigid:
        context.applyConstraints(1e-6)
    context.setVelocitiesToTemperature(TEMPERATURE * unit.kelvin, 7)
    step_fs = integrator.getStepSize().value_in_unit(unit.femtosecond)
    n_molecules = topology.getNumResidues()
    masses = np.array([system.getParticleMass(i).value_in_unit(unit.dalton) for i in range(system.getNumParticles())])
    oxygens = np.arange(0, system.getNumParticles(), 3)
    box = context.getState().getPeriodicBoxVectors()[0][0].value_in_unit(unit.nanometer)
    rdf_edges = np.linspace(0.2, min(0.9, box / 2), 71)
    record = {"name": name, "step_fs": step_fs, "rigid": rigid, "stable": True}
    try:
        integrator.step(int(round(equilibration_ps * 1000 / step_fs)))
        production = ProductionFrames(context, integrator, int(round(production_ps * 1000 / step_fs)), frames)
        series = {key: [] for key in ("oh_mean", "oh_sd", "angle_mean", "angle_sd", "T_O", "T_H", "pe_per_molecule")}
        g_sum = np.zeros(len(rdf_edges) - 1)
        for frame in production:
            values = frame_observables(frame.positions, frame.velocities, box, oxygens, masses, rdf_edges)
            for key, value in zip(("oh_mean", "oh_sd", "angle_mean", "angle_sd", "T_O", "T_H"), values[:6]):
                series[key].append(value)
            series["pe_per_molecule"].append(frame.potential_energy / n_molecules)
            g_sum += values[6]
        record["ns_per_day"] = production.ns_per_day(step_fs)
        add_block_errors(record, series, 5 if len(series["oh_mean"]) >= 10 else 2)
        g = g_sum / len(series["oh_mean"])
        record["g_OO"] = {"r": list(0.5 * (rdf_edges[1:] + rdf_edges[:-1])), "g": list(g)}
        record["g_OO_peak"] = float(g.max())
        record["g_OO_peak_r"] = float(record["g_OO"]["r"][int(np.argmax(g))])
    except mm.OpenMMException as error:
        record["stable"] = False
        record["error"] = str(error)
    return record


def plot(records, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    stable = [r for r in records if r["stable"]]
    reference = records[0]
    panels = [("oh_mean", "mean O–H length (nm)"), ("angle_mean", "mean H–O–H angle (°)"),
              ("pe_per_molecule", "potential energy per molecule (kJ/mol)"), ("T_O", "kinetic T of O (K)"),
              ("T_H", "kinetic T of H (K)"), ("ns_per_day", "speed (ns/day, CPU platform)")]
    fig, axes = plt.subplots(2, 4, figsize=(22, 10))
    axes = axes.ravel()
    labels = [r["name"] for r in stable]
    y = np.arange(len(stable))
    for ax, (key, label) in zip(axes, panels):
        values = [r[key] for r in stable]
        errors = [r.get(key + "_error", 0.0) for r in stable]
        ax.errorbar(values, y, xerr=errors, fmt="o", capsize=3)
        if key != "ns_per_day" and reference["stable"]:
            ax.axvline(reference[key], color="gray", ls="--", lw=1)
        ax.set_yticks(y)
        ax.set_yticklabels(labels if ax in (axes[0], axes[4]) else [], fontsize=7)
        ax.set_xlabel(label)
        ax.invert_yaxis()
    ax = axes[6]
    for r in stable:
        # One colour per peer (the default cycle repeats after ten).
        ax.plot(r["g_OO"]["r"], r["g_OO"]["g"], label=r["name"], lw=1,
                color=plt.get_cmap("tab20")(stable.index(r) % 20))
    ax.set_xlabel("r (nm)")
    ax.set_ylabel("g_OO(r)")
    ax.legend(fontsize=6)
    ax = axes[7]
    values = [r["oh_sd"] for r in stable]
    errors = [r["oh_sd_error"] for r in stable]
    ax.errorbar(values, y, xerr=errors, fmt="o", capsize=3)
    if reference["stable"]:
        ax.axvline(reference["oh_sd"], color="gray", ls="--", lw=1)
    ax.set_yticks(y)
    ax.set_yticklabels([])
    ax.set_xlabel("O–H spread, standard deviation (nm)")
    ax.invert_yaxis()
    unstable = [r["name"] for r in records if not r["stable"]]
    fig.text(0.01, 0.005, "Dashed lines: the reference (%s).  " % reference["name"] +
             "Rigid water: its kinetic temperatures count 3 degrees of freedom per atom, but SETTLE "
             "removes 3 per molecule, so they are not comparable.  " +
             ("Unstable (blew up): " + ", ".join(unstable) if unstable else "Every peer stayed stable."), fontsize=9)
    fig.suptitle("Flexible TIP3P water (1,503 atoms, PME, 300 K): FLAVOR averagings against OpenMM's Langevin "
                 "integrators, block-average error bars")
    fig.tight_layout(rect=(0, 0.02, 1, 1))
    reporting.save_figure(fig, path, dpi=90)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="a few femtoseconds per peer (smoke test)")
    parser.add_argument("--out", default="results/flexible_water")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--equilibration", type=float, default=1.0, help="ps per peer before measuring")
    parser.add_argument("--production", type=float, default=3.0, help="ps per peer")
    parser.add_argument("--start", type=float, default=3.0, help="ps of common equilibration before the peers")
    parser.add_argument("--molecules", type=int, default=501)
    parser.add_argument("--replot", metavar="JSON", help="only redraw the chart of an earlier run's JSON into --out")
    parser.add_argument("--peers", nargs="+", metavar="NAME",
                        help="run only the peers whose names contain one of these strings (default: all)")
    args = parser.parse_args()
    reporting.set_smoke_run(args.quick)
    if args.replot:
        reporting.replot(args.replot, args.out, "flexible_water", lambda data, path: plot(data["peers"], path))
        return
    if args.quick:
        args.equilibration, args.production, args.start = 0.005, 0.02, 0.1
    # (averaging, delta, tau, H-O-H angles stiff too, thermostat in the middle of the microstep)
    flavor_settings = [("Nonintrusive", 2.0, 0.5, False, False), ("Artificial", 2.0, 0.5, False, False),
                       ("ArtificialProjected", 2.0, 0.5, False, False), ("ArtificialProjected", 2.0, 0.25, False, False),
                       ("ArtificialProjected", 2.5, 0.5, False, False), ("ArtificialProjected", 2.0, 0.5, True, False),
                       ("ArtificialProjected", 4.0, 0.5, True, False), ("ArtificialProjected", 2.0, 0.5, True, True),
                       ("ArtificialProjected", 4.0, 0.5, True, True)]
    if args.quick:
        flavor_settings = [("Nonintrusive", 2.0, 0.5, False, False), ("ArtificialProjected", 2.0, 0.5, True, False),
                           ("ArtificialProjected", 2.0, 0.5, True, True)]
    forcefield, modeller = build_box(args.molecules)
    start = common_start(forcefield, modeller, args.start, args.threads, 20 if args.quick else 200)
    frames = 10 if args.quick else 60
    records = []
    selected = [peer for peer in peers(flavor_settings)
                if args.peers is None or any(part in peer[0] for part in args.peers)]
    if not selected:
        parser.error("--peers %s matches none of the peers" % " ".join(args.peers))
    for name, rigid, factory in selected:
        record = run_peer(name, rigid, factory, forcefield, modeller.topology, start, args.equilibration,
                          args.production, frames, args.threads)
        records.append(record)
        summary = ("%-48s " % name) + (
            "O-H %.4f±%.4f  HOH %.1f±%.1f  PE %.2f±%.2f  T_O %.0f±%.0f  T_H %.0f±%.0f  %.1f ns/day" % (
                record["oh_mean"], record["oh_mean_error"], record["angle_mean"], record["angle_mean_error"],
                record["pe_per_molecule"], record["pe_per_molecule_error"], record["T_O"], record["T_O_error"],
                record["T_H"], record["T_H_error"], record["ns_per_day"]) if record["stable"] else "UNSTABLE")
        print(summary, flush=True)
    os.makedirs(args.out, exist_ok=True)
    result = {"atoms": 3 * args.molecules, "temperature_K": TEMPERATURE, "friction_per_ps": FRICTION,
              "start_equilibration_ps": args.start,
              "equilibration_ps": args.equilibration, "production_ps": args.production, "threads": args.threads,
              "quick": args.quick, "peers": records}
    with open(os.path.join(args.out, "flexible_water.json"), "w") as f:
        json.dump(result, f, indent=1)
    plot(records, os.path.join(args.out, "flexible_water.png"))


if __name__ == "__main__":
    main()
