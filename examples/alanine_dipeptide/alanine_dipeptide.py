#!/usr/bin/env python3
"""Alanine dipeptide (ACE-ALA-NME, 22 atoms) in implicit solvent (amber14 + OpenMM's OBC2 files, no cutoff, X-H bonds
constrained, 300 K, friction 1/ps) on the CPU platform: the FLAVOR with hydrogen mass repartitioning (HMR) against
OpenMM's LangevinMiddleIntegrator, judged by what a protein user checks first, the backbone's phi/psi basins.

Force groups (as in examples/villin): HarmonicBondForce (the heavy-atom bonds; the X-H bonds are constraints) 1,
HarmonicAngleForce 2 but the 12 angles of the 4 planar centres (FlavorIntegrator.separatePlanarAngles: the two
amide N, the two carbonyl C) 3, everything else (torsions, nonbonded, the OBC2 Born solvation) 0.

Peers (--peers, comma separated; the default is the scene's five):
  lm:STEP[:hmrM]             LangevinMiddleIntegrator at STEP fs (with createSystem(..., hydrogenMass=M*amu));
  flavor:DELTA:TAU[:opt...]  FlavorIntegrator, ArtificialProjected, the thermostat in the middle (Middle), the bonds
                             and the angles of the non-planar centres stiff (groups 1-2), friction 1/ps; options:
                             hmrM (HMR M amu), edges (the thermostat at the edges of the mesostep), fricG (friction
                             G/ps), stifffriction (friction only while the stiff forces act), allangles (the planar
                             angles stiff too: groups 1-3), bonds (only the bonds stiff: every angle soft),
                             artificial (Artificial instead of ArtificialProjected).
Default: lm:1, lm:4:hmr1.5, flavor:4:1:hmr3, flavor:6:1:hmr3, flavor:8:1:hmr3 (the villin HMR runs' tau and friction).

Every peer starts from the same state (minimized, then --start ps of LangevinMiddle 1 fs), equilibrates --equilibration
ps with its own integrator and System, and then the production runs interleaved in one process: --rounds rounds in
which each peer steps --production/--rounds ps in turn (the order rotated each round), one thread
(OPENMM_CPU_THREADS=1 is set unless given).  A frame is taken every 24 fs (a multiple of every step here).  ns/day:
per round, stepping only; the median over the rounds and the median of the ratio to LangevinMiddle 4 fs HMR 1.5 amu
of the same round.

Observables, each with the standard error of --blocks block means (blocks of the production, in time order):
  - phi (C-N-CA-C) / psi (N-CA-C-N) basin populations, the torus split into three regions:
      alpha_L/C7ax: 0 <= phi < 120 deg;
      alpha_R:      otherwise and -120 <= psi < 30 deg;
      beta/C7eq/C5/PII: otherwise (psi >= 30 or psi < -120);
  - transitions between the two main basins per ns, counted between cores (alpha_R core: phi < 0, -90 <= psi < 0;
    beta core: phi < 0, psi >= 100 or psi < -150) each time the other core is entered (recrossings of the
    boundary that do not reach the other core do not count);
  - kinetic temperature of the heavy atoms and of the hydrogens (each X-H constraint takes one degree of freedom,
    shared between its two atoms in the ratio of the other atom's mass to the pair's, as the relative motion's
    kinetic energy is shared) and of everything; potential energy;
  - widths: per class, sqrt of the mean over the terms of the class of the variance of the term's coordinate
    over the production: heavy-heavy bonds (the X-H bonds are constraints: width 0), angles with three heavy atoms and
    angles with a hydrogen, each also split into the non-planar centres (stiff in the FLAVOR) and the planar ones
    (soft); and the ratio of each to the first peer's (the reference) with its combined error.

    OPENMM_CPU_THREADS=1 PYTHONPATH=... python examples/alanine_dipeptide/alanine_dipeptide.py [--quick] [--out DIR]
        [--peers ...] [--start PS] [--equilibration PS] [--production PS] [--rounds N] [--blocks N] [--seed N]

Outputs DIR/NAME.json (NAME: --name, default alanine_dipeptide) and DIR/NAME.png; --replot JSON redraws a chart.
"""
import argparse
import json
import math
import os
import sys
import textwrap
import time
import warnings

os.environ.setdefault("OPENMM_CPU_THREADS", "1")

import numpy as np  # noqa: E402
import openmm as mm  # noqa: E402
import openmm.app as app  # noqa: E402
import openmm.unit as unit  # noqa: E402

import openmmflavors  # noqa: E402
from flavorbench.systems import assign_force_groups, harmonic_angles  # noqa: E402
from flavorbench.timeseries import block_error  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
PDB = os.path.join(HERE, "alanine_dipeptide.pdb")
TEMPERATURE = 300.0  # K
FRICTION = 1.0  # 1/ps
FRAME_FS = 24  # a frame every 24 fs: a multiple of 1, 4, 6 and 8 fs
BOND_GROUP, ANGLE_GROUP, PLANAR_ANGLE_GROUP = 1, 2, 3
KB = 0.0083144626  # kJ/mol/K
DEFAULT_PEERS = "lm:1,lm:4:hmr1.5,flavor:4:1:hmr3,flavor:6:1:hmr3,flavor:8:1:hmr3"
BASELINE = "LangevinMiddle 4 fs HMR 1.5 amu"
BASINS = ("beta", "alphaR", "alphaL")
BASIN_LABELS = {"beta": "β/C7eq/C5/PII", "alphaR": "αR", "alphaL": "αL/C7ax"}
# phi: ACE C, ALA N, CA, C; psi: ALA N, CA, C, NME N (indices in alanine_dipeptide.pdb)
PHI, PSI = (4, 6, 8, 14), (6, 8, 14, 16)
# This scene measures mesosteps beyond the ones the warning names, on purpose.
warnings.filterwarnings("ignore", message=".*longer than any mesostep measured", category=openmmflavors.FlavorsWarning)


def parse_peer(text):
    """A --peers item as a dict: kind, step (fs), tau (fs), hmr (amu or None), and the FLAVOR's options."""
    parts = text.split(":")
    peer = {"kind": parts[0], "step": float(parts[1]), "tau": None, "hmr": None, "placement": "middle",
            "friction": FRICTION, "stiff_friction": False, "stiff": "bonds+nonplanar angles",
            "averaging": "ArtificialProjected"}
    rest = parts[2:]
    if peer["kind"] == "flavor":
        peer["tau"], rest = float(rest[0]), rest[1:]
    elif peer["kind"] != "lm":
        raise ValueError("a peer is lm:STEP[:hmrM] or flavor:DELTA:TAU[:options]: %r" % text)
    for option in rest:
        if option.startswith("hmr"):
            peer["hmr"] = float(option[3:])
        elif option.startswith("fric"):
            peer["friction"] = float(option[4:])
        elif option == "edges":
            peer["placement"] = "edges"
        elif option == "stifffriction":
            peer["stiff_friction"] = True
        elif option == "allangles":
            peer["stiff"] = "bonds+angles"
        elif option == "bonds":
            peer["stiff"] = "bonds"
        elif option == "artificial":
            peer["averaging"] = "Artificial"
        else:
            raise ValueError("unknown option %r in %r" % (option, text))
    peer["name"] = peer_name(peer)
    return peer


def peer_name(peer):
    hmr = "" if peer["hmr"] is None else " HMR %g amu" % peer["hmr"]
    if peer["kind"] == "lm":
        return "LangevinMiddle %g fs%s" % (peer["step"], hmr)
    extra = []
    if peer["placement"] == "edges":
        extra.append("Edges")
    if peer["friction"] != FRICTION:
        extra.append("γ = %g/ps" % peer["friction"])
    if peer["stiff_friction"]:
        extra.append("stiff friction")
    if peer["stiff"] != "bonds+nonplanar angles":
        extra.append({"bonds+angles": "planar angles stiff too", "bonds": "angles soft"}[peer["stiff"]])
    if peer["averaging"] != "ArtificialProjected":
        extra.append(peer["averaging"])
    return "FLAVOR%s δ = %g fs, τ = %g fs%s" % (hmr, peer["step"], peer["tau"],
                                                  (", " + ", ".join(extra)) if extra else "")


def make_system(forcefield, topology, hydrogen_mass=None):
    extra = {} if hydrogen_mass is None else {"hydrogenMass": hydrogen_mass * unit.amu}
    system = forcefield.createSystem(topology, nonbondedMethod=app.NoCutoff, constraints=app.HBonds,
                                     removeCMMotion=False, **extra)
    assign_force_groups(system, {mm.HarmonicBondForce: BOND_GROUP, mm.HarmonicAngleForce: ANGLE_GROUP})
    openmmflavors.FlavorIntegrator.separatePlanarAngles(system, PLANAR_ANGLE_GROUP)
    return system


def make_integrator(peer, seed):
    if peer["kind"] == "lm":
        integrator = mm.LangevinMiddleIntegrator(TEMPERATURE, FRICTION, peer["step"] * 1e-3)
        integrator.setRandomNumberSeed(seed)
        return integrator
    F = openmmflavors.FlavorIntegrator
    stiff = {"bonds": {BOND_GROUP}, "bonds+nonplanar angles": {BOND_GROUP, ANGLE_GROUP},
             "bonds+angles": {BOND_GROUP, ANGLE_GROUP, PLANAR_ANGLE_GROUP}}[peer["stiff"]]
    integrator = F(peer["step"] * unit.femtosecond, peer["tau"] * unit.femtosecond, stiff)
    integrator.setAveraging(getattr(F, peer["averaging"]))
    integrator.setTemperature(TEMPERATURE * unit.kelvin)
    integrator.setFriction(peer["friction"] / unit.picosecond)
    integrator.setStiffFriction(peer["stiff_friction"])
    if peer["placement"] == "middle":
        integrator.setThermostatPlacement(F.Middle)
    integrator.setRandomNumberSeed(seed)
    return integrator


def dihedral(q, idx):
    """Dihedral angles (degrees, -180..180) of atoms idx over frames q (frames x atoms x 3)."""
    b0 = q[:, idx[0]] - q[:, idx[1]]
    b1 = q[:, idx[2]] - q[:, idx[1]]
    b2 = q[:, idx[3]] - q[:, idx[2]]
    b1 = b1 / np.linalg.norm(b1, axis=1)[:, None]
    v = b0 - np.sum(b0 * b1, axis=1)[:, None] * b1
    w = b2 - np.sum(b2 * b1, axis=1)[:, None] * b1
    x = np.sum(v * w, axis=1)
    y = np.sum(np.cross(b1, v) * w, axis=1)
    return np.degrees(np.arctan2(y, x))


def basins(phi, psi):
    """0 beta/C7eq/C5/PII, 1 alpha_R, 2 alpha_L/C7ax per frame (the regions of the module's docstring)."""
    left = (phi >= 0) & (phi < 120)
    alpha_r = ~left & (psi >= -120) & (psi < 30)
    return np.where(left, 2, np.where(alpha_r, 1, 0))


def transitions(phi, psi):
    """Per frame: 1 where the trajectory enters the beta core having last been in the alpha_R core, or the reverse."""
    right = phi < 0
    core = np.where(right & (psi >= -90) & (psi < 0), 1, np.where(right & ((psi >= 100) | (psi < -150)), 0, -1))
    events = np.zeros(len(core))
    last = -1
    for i, c in enumerate(core):
        if c >= 0:
            if last >= 0 and c != last:
                events[i] = 1
            last = c
    return events


def class_dof(system, positions, hydrogen, mass, pairwise=False):
    """Degrees of freedom of the heavy atoms, the hydrogens and all atoms with the System's constraints: per atom 3
    less the diagonal 3x3 block's trace of the projector onto the constraints' normal space in mass-weighted
    coordinates (G = J M^-1/2, N = G^T (G G^T)^-1 G), at the given positions (nm), so that the kinetic energy of a
    class in equilibrium is kT/2 times its degrees of freedom.  pairwise=True: each constraint's degree of freedom
    shared between its two atoms in the ratio of the other atom's mass to the pair's instead (exact for a lone
    constraint only; the first runs used it)."""
    n = system.getNumParticles()
    dof = np.full(n, 3.0)
    if pairwise:
        for i in range(system.getNumConstraints()):
            a, b, _ = system.getConstraintParameters(i)
            dof[a] -= mass[b] / (mass[a] + mass[b])
            dof[b] -= mass[a] / (mass[a] + mass[b])
    elif system.getNumConstraints():
        J = np.zeros((system.getNumConstraints(), 3 * n))
        for i in range(system.getNumConstraints()):
            a, b, _ = system.getConstraintParameters(i)
            u = positions[a] - positions[b]
            u = u / np.linalg.norm(u)
            J[i, 3 * a:3 * a + 3], J[i, 3 * b:3 * b + 3] = u, -u
        G = J / np.sqrt(np.repeat(mass, 3))[None, :]
        N = G.T @ np.linalg.solve(G @ G.T, G)
        dof -= np.array([np.trace(N[3 * i:3 * i + 3, 3 * i:3 * i + 3]) for i in range(n)])
    return {"heavy": float(dof[~hydrogen].sum()), "H": float(dof[hydrogen].sum()), "all": float(dof.sum())}


def rescale_dof(data):
    """A JSON written before the projected degrees of freedom (class_dof) read the class temperatures with the
    pairwise shares; T = 2 K / (k dof) with dof fixed per run, so the projected reading is the stored one times
    dof_pairwise / dof_projected (the same for the error bars).  Rescales data in place once; returns it."""
    if data.get("temperature_dof") == "projected":
        return data
    pdb = app.PDBFile(PDB)
    forcefield = app.ForceField("amber14-all.xml", "implicit/obc2.xml")
    positions = pdb.getPositions(asNumpy=True).value_in_unit(unit.nanometer)
    hydrogen = np.array([a.element.symbol == "H" for a in pdb.topology.atoms()])
    for r in data["results"]:
        if "failed" in r:
            continue
        system = make_system(forcefield, pdb.topology, r["peer"]["hmr"])
        mass = np.array([system.getParticleMass(i).value_in_unit(unit.amu) for i in range(system.getNumParticles())])
        old = class_dof(system, positions, hydrogen, mass, pairwise=True)
        new = class_dof(system, positions, hydrogen, mass)
        for cls in ("heavy", "H", "all"):
            r["T_" + cls] *= old[cls] / new[cls]
            r["T_" + cls + "_error"] *= old[cls] / new[cls]
        r["dof"] = new
    add_ratios(data["results"])
    data["temperature_dof"] = "projected"
    data["temperature_dof_note"] = ("class temperatures rescaled from the pairwise shares of the run to the "
                                    "projected degrees of freedom at the PDB's geometry (rescale_dof)")
    return data


class Terms:
    """The bonded terms and the atom classes of a System, for the widths and the temperatures."""

    def __init__(self, system, topology, positions):
        self.hydrogen = np.array([a.element.symbol == "H" for a in topology.atoms()])
        self.mass = np.array([system.getParticleMass(i).value_in_unit(unit.amu)
                              for i in range(system.getNumParticles())])
        bonds = [f for f in system.getForces() if isinstance(f, mm.HarmonicBondForce)][0]
        self.bonds = np.array([bonds.getBondParameters(i)[:2] for i in range(bonds.getNumBonds())])
        angles = harmonic_angles(system)
        self.angles = np.array([a[:3] for a, _ in angles])
        planar = np.array([group == PLANAR_ANGLE_GROUP for _, group in angles])
        with_h = self.hydrogen[self.angles].any(axis=1)
        self.angle_classes = {"heavy": ~with_h, "withH": with_h, "heavy nonplanar": ~with_h & ~planar,
                              "heavy planar": ~with_h & planar, "withH nonplanar": with_h & ~planar,
                              "withH planar": with_h & planar}
        self.dof = class_dof(system, positions, self.hydrogen, self.mass)
        assert not self.hydrogen[self.bonds].any(), "an X-H bond is not a constraint"


def analyse(q, v, pe, terms, blocks, frame_ps):
    """Every observable of one peer from its production frames: positions q (nm), velocities v (nm/ps), potential
    energies pe (kJ/mol)."""
    record = {"frames": len(q), "production_ps": len(q) * frame_ps, "dof": terms.dof}
    series = {"potential_energy": pe}
    ke = 0.5 * terms.mass[None, :] * np.sum(v * v, axis=2)
    for cls, mask in (("heavy", ~terms.hydrogen), ("H", terms.hydrogen), ("all", np.ones_like(terms.hydrogen))):
        series["T_" + cls] = 2 * ke[:, mask].sum(axis=1) / (KB * terms.dof[cls])
    phi, psi = dihedral(q, PHI), dihedral(q, PSI)
    basin = basins(phi, psi)
    for k, name in enumerate(BASINS):
        series["pop_" + name] = 100.0 * (basin == k)
    series["transitions_per_ns"] = transitions(phi, psi) / (frame_ps * 1e-3)
    # widths: per-frame mean over the class of the squared deviation from each term's mean over the run
    b = np.linalg.norm(q[:, terms.bonds[:, 0]] - q[:, terms.bonds[:, 1]], axis=2)
    square = {"bond heavy": np.mean((b - b.mean(axis=0)) ** 2, axis=1)}
    a0 = q[:, terms.angles[:, 0]] - q[:, terms.angles[:, 1]]
    a2 = q[:, terms.angles[:, 2]] - q[:, terms.angles[:, 1]]
    cos = np.sum(a0 * a2, axis=2) / np.linalg.norm(a0, axis=2) / np.linalg.norm(a2, axis=2)
    theta = np.degrees(np.arccos(np.clip(cos, -1, 1)))
    for cls, mask in terms.angle_classes.items():
        square["angle " + cls] = np.mean((theta[:, mask] - theta[:, mask].mean(axis=0)) ** 2, axis=1)
    for key, values in series.items():
        record[key], record[key + "_error"] = block_error(values, blocks)
    for key, values in square.items():
        ms, ms_error = block_error(values, blocks)
        record["width " + key] = math.sqrt(ms)
        record["width " + key + "_error"] = ms_error / (2 * math.sqrt(ms))
    record["phi_psi_histogram"] = np.histogram2d(phi, psi, bins=36, range=[[-180, 180], [-180, 180]])[0].tolist()
    return record


OBSERVABLES = (["pop_" + b for b in BASINS] + ["transitions_per_ns", "T_heavy", "T_H", "T_all", "potential_energy",
               "width bond heavy"] + ["width angle " + c for c in ("heavy", "withH", "heavy nonplanar",
                                                                     "heavy planar", "withH nonplanar",
                                                                     "withH planar")])


def add_ratios(results):
    reference = results[0]
    for r in results:
        if "failed" in r:
            continue
        for key in OBSERVABLES:
            if key.startswith("width"):
                x, e, x0, e0 = r[key], r[key + "_error"], reference[key], reference[key + "_error"]
                ratio = x / x0
                r["ratio " + key] = ratio
                r["ratio " + key + "_error"] = ratio * math.hypot(e / x, e0 / x0)
            else:
                r["diff " + key] = r[key] - reference[key]
                r["diff " + key + "_error"] = math.hypot(r[key + "_error"], reference[key + "_error"])


def run(args):
    peers = [parse_peer(p) for p in args.peers.split(",")]
    pdb = app.PDBFile(PDB)
    forcefield = app.ForceField("amber14-all.xml", "implicit/obc2.xml")
    platform = mm.Platform.getPlatformByName("CPU")
    properties = {"Threads": os.environ["OPENMM_CPU_THREADS"]}
    began = time.time()
    # the common start: minimized, then --start ps of LangevinMiddle 1 fs
    system = make_system(forcefield, pdb.topology)
    integrator = mm.LangevinMiddleIntegrator(TEMPERATURE, FRICTION, 1e-3)
    integrator.setRandomNumberSeed(4321 + args.seed)
    context = mm.Context(system, integrator, platform, properties)
    context.setPositions(pdb.positions)
    mm.LocalEnergyMinimizer.minimize(context)
    context.setVelocitiesToTemperature(TEMPERATURE * unit.kelvin, 4321 + args.seed)
    integrator.step(int(round(args.start * 1000)))
    start = context.getState(getPositions=True, getVelocities=True)
    del context, integrator
    print("common start: %.1f s" % (time.time() - began), flush=True)
    runs = []
    for k, peer in enumerate(peers):
        system = make_system(forcefield, pdb.topology, peer["hmr"])
        integrator = make_integrator(peer, 1000 + 17 * k + args.seed)
        context = mm.Context(system, integrator, platform, properties)
        context.setPositions(start.getPositions())
        context.setVelocities(start.getVelocities())
        terms = Terms(system, pdb.topology, start.getPositions(asNumpy=True).value_in_unit(unit.nanometer))
        entry = {"peer": peer, "system": system, "integrator": integrator, "context": context, "terms": terms,
                 "q": [], "v": [], "pe": [], "ns_per_day": [], "failed": None}
        t0 = time.time()
        try:
            integrator.step(int(round(args.equilibration * 1000 / peer["step"])))
        except mm.OpenMMException as error:
            entry["failed"] = "equilibration: %s" % error
            print("%s failed: %s" % (peer["name"], entry["failed"]), flush=True)
        print("%s: equilibrated in %.1f s" % (peer["name"], time.time() - t0), flush=True)
        runs.append(entry)
    round_ps = args.production / args.rounds
    frames_per_round = int(round(round_ps * 1000 / FRAME_FS))
    for round_ in range(args.rounds):
        order = runs[round_ % len(runs):] + runs[:round_ % len(runs)]
        for entry in order:
            if entry["failed"]:
                continue
            peer, integrator, context = entry["peer"], entry["integrator"], entry["context"]
            steps = int(round(FRAME_FS / peer["step"]))
            stepping = 0.0
            try:
                for _ in range(frames_per_round):
                    t0 = time.perf_counter()
                    integrator.step(steps)
                    stepping += time.perf_counter() - t0
                    state = context.getState(getPositions=True, getVelocities=True, getEnergy=True)
                    q = state.getPositions(asNumpy=True).value_in_unit(unit.nanometer)
                    pe = state.getPotentialEnergy().value_in_unit(unit.kilojoule_per_mole)
                    if not np.all(np.isfinite(q)) or not math.isfinite(pe):
                        raise mm.OpenMMException("non-finite state")
                    entry["q"].append(q)
                    entry["v"].append(state.getVelocities(asNumpy=True).value_in_unit(unit.nanometer / unit.picosecond))
                    entry["pe"].append(pe)
            except mm.OpenMMException as error:
                entry["failed"] = "production round %d: %s" % (round_ + 1, error)
                print("%s failed: %s" % (peer["name"], error), flush=True)
                continue
            entry["ns_per_day"].append(frames_per_round * FRAME_FS * 1e-6 / (stepping / 86400))
        print("round %d/%d (%.0f s): %s" % (round_ + 1, args.rounds, time.time() - began, ", ".join(
            "%s %.0f" % (e["peer"]["name"], e["ns_per_day"][-1]) for e in runs if not e["failed"])) + " ns/day",
              flush=True)
    baseline = next((e for e in runs if e["peer"]["name"] == BASELINE and not e["failed"]), None)
    results = []
    for entry in runs:
        peer = entry["peer"]
        record = {"name": peer["name"], "peer": peer}
        if entry["failed"]:
            record["failed"] = entry["failed"]
        else:
            record.update(analyse(np.array(entry["q"]), np.array(entry["v"]), np.array(entry["pe"]), entry["terms"],
                                  args.blocks, FRAME_FS * 1e-3))
            speeds = np.array(entry["ns_per_day"])
            record["ns_per_day_rounds"] = speeds.tolist()
            record["ns_per_day"] = float(np.median(speeds))
            if baseline is not None:
                ratios = speeds / np.array(baseline["ns_per_day"])
                record["ratio_to_baseline"] = float(np.median(ratios))
                record["ratio_to_baseline_range"] = [float(ratios.min()), float(ratios.max())]
        results.append(record)
    add_ratios(results)
    return {"command": " ".join(sys.argv), "quick": args.quick, "seconds": time.time() - began,
            "threads": os.environ["OPENMM_CPU_THREADS"], "start_ps": args.start,
            "equilibration_ps": args.equilibration, "production_ps": args.production, "rounds": args.rounds,
            "blocks": args.blocks, "frame_fs": FRAME_FS, "title": args.title, "temperature": TEMPERATURE,
            "baseline": BASELINE, "temperature_dof": "projected",
            "results": results}


def fmt(r, key, digits):
    if key not in r or r[key] is None:
        return "—"
    e = r.get(key + "_error")
    return ("%.*f ± %.*f" % (digits, r[key], digits, e)) if e is not None else "%.*f" % (digits, r[key])


def print_tables(data):
    results = data["results"]
    print("\n| peer | ns/day (1 thread) | × %s (rounds) | β/C7eq (%%) | αR (%%) | αL/C7ax (%%) | β↔αR transitions "
          "per ns | T heavy (K) | T H (K) | potential energy (kJ/mol) |" % BASELINE)
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in results:
        if "failed" in r:
            print("| %s | failed: %s |" % (r["name"], r["failed"]))
            continue
        ratio = ("%.2f (%.2f–%.2f)" % (r["ratio_to_baseline"], *r["ratio_to_baseline_range"])
                 if "ratio_to_baseline" in r else "—")
        print("| %s | %.0f | %s | %s | %s | %s | %s | %s | %s | %s |" % (
            r["name"], r["ns_per_day"], ratio, fmt(r, "pop_beta", 1), fmt(r, "pop_alphaR", 1),
            fmt(r, "pop_alphaL", 1), fmt(r, "transitions_per_ns", 1), fmt(r, "T_heavy", 1), fmt(r, "T_H", 1),
            fmt(r, "potential_energy", 2)))
    print("\nwidths (bond nm, angles degrees) and their ratio to %s" % results[0]["name"])
    keys = ["width bond heavy", "width angle heavy", "width angle withH", "width angle heavy nonplanar",
            "width angle heavy planar", "width angle withH nonplanar", "width angle withH planar"]
    print("| peer | " + " | ".join(k.replace("width ", "") for k in keys) + " |")
    print("|---|" + "---|" * len(keys))
    for r in results:
        if "failed" in r:
            continue
        cells = []
        for k in keys:
            digits = 5 if "bond" in k else 3
            cells.append("%s (%s)" % (fmt(r, k, digits), fmt(r, "ratio " + k, 3)))
        print("| %s | %s |" % (r["name"], " | ".join(cells)))
    print_ratio_table(data)


def print_ratio_table(data):
    """Width ratios to the reference with their errors, and the differences of the temperatures from it."""
    results = data["results"]
    keys = ["width bond heavy", "width angle heavy nonplanar", "width angle heavy", "width angle withH nonplanar",
            "width angle withH planar"]
    print("\nwidth ratios to %s (± combined s.e.; σ where ≥ 2) and T heavy atoms − its (K)" % results[0]["name"])
    print("| setting | heavy bonds | heavy angles, non-planar (frozen) | heavy angles, all | angles with H, non-planar "
          "(frozen) | angles with H, planar (soft) | T heavy atoms − reference (K) |")
    print("|---|" + "---|" * (len(keys) + 1))

    def cell(r, key, scale=1.0, digits=3, shift=0.0):
        x, e = (r[key] - shift) * scale, r[key + "_error"] * scale
        sigma = abs(x - (1.0 if key.startswith("ratio") else 0.0)) / e if e else 0.0
        return "%.*f ± %.*f%s" % (digits, x, digits, e, " (%.1fσ)" % sigma if sigma >= 2 else "")

    for r in results[1:]:
        if "failed" in r:
            print("| %s | failed: %s |" % (r["name"], r["failed"].replace("\n", " ")[:200]))
            continue
        print("| %s | %s | %s |" % (r["name"], " | ".join(cell(r, "ratio " + k) for k in keys),
                                    cell(r, "diff T_heavy", digits=1)))


def verdict(data):
    """One line: the fastest peer and how far its basins and heavy-atom widths are from the reference."""
    results = [r for r in data["results"] if "failed" not in r]
    reference = results[0]
    flavors = [r for r in results if r["peer"]["kind"] == "flavor"]
    if not flavors:
        return ""
    if not any("ratio_to_baseline" in r for r in flavors):  # no baseline peer: which settings are unbiased
        def sigma(r, key):
            return abs(r["ratio " + key] - 1) / max(r["ratio " + key + "_error"], 1e-12)
        off = ["%s (%s)" % (r["name"], ", ".join("%s %+.1f %%" % (label, 100 * (r["ratio " + key] - 1))
                                                 for key, label in (("width bond heavy", "bonds"),
                                                                    ("width angle heavy", "heavy angles"))
                                                 if sigma(r, key) >= 2))
               for r in flavors if sigma(r, "width bond heavy") >= 2 or sigma(r, "width angle heavy") >= 2]
        failed = [r["name"] for r in data["results"] if "failed" in r]
        return ("heavy-atom bond and angle widths within 2 s.e. of %s in %d of %d settings; beyond: %s%s" % (
            reference["name"], len(flavors) - len(off), len(flavors), "; ".join(off) if off else "none",
            ("; failed: " + "; ".join(failed)) if failed else "")).replace("FLAVOR ", "")
    best = max(flavors, key=lambda r: r["ns_per_day"])
    worst_pop = max(abs(best["diff pop_" + b]) / max(best["diff pop_" + b + "_error"], 1e-9) for b in BASINS)
    text = "%s: %.2f× %s;" % (best["name"], best.get("ratio_to_baseline", float("nan")), data["baseline"])
    worst_error = max(best["diff pop_" + b + "_error"] for b in BASINS)
    text += " basins within %.1f s.e. of %s (s.e. of the difference up to %.1f pp: %s the 2 pp aimed at);" % (
        worst_pop, reference["name"], worst_error, "within" if worst_error <= 2 else "far above")
    text += " heavy bonds %+.1f %% (%.1fσ), heavy angles at the non-planar centres %+.1f %% (%.1fσ)" % tuple(
        v for k in ("width bond heavy", "width angle heavy nonplanar")
        for v in (100 * (best["ratio " + k] - 1), abs(best["ratio " + k] - 1) / max(best["ratio " + k + "_error"],
                                                                                    1e-12)))
    return text


def pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def plot(data, path):
    plt = pyplot()
    results = [r for r in data["results"] if "failed" not in r]
    names = [r["name"] for r in results]
    y = np.arange(len(results))
    height = 2.6 + 0.6 * len(results)
    below = (0.5, -0.55 / (0.72 * height))  # legends about half an inch below the axes
    fig, axes = plt.subplots(1, 5, figsize=(21, height), sharey=True)
    colors = {"beta": "tab:blue", "alphaR": "tab:red", "alphaL": "tab:green"}
    ax = axes[0]
    for k, b in enumerate(BASINS):
        ax.errorbar([r["pop_" + b] for r in results], y + (k - 1) * 0.22,
                    xerr=[r["pop_" + b + "_error"] for r in results], fmt="o", color=colors[b],
                    label=BASIN_LABELS[b], capsize=3)
    ax.set_xlabel("φ/ψ basin population (%)")
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=below, ncol=3)
    ax.set_yticks(y)
    ax.set_yticklabels(names, fontsize=8)
    ax.invert_yaxis()
    ax = axes[1]
    ax.errorbar([r["transitions_per_ns"] for r in results], y, xerr=[r["transitions_per_ns_error"] for r in results],
                fmt="o", color="k", capsize=3)
    ax.set_xlabel("β ↔ αR transitions per ns (core to core)")
    ax = axes[2]
    for k, (key, label) in enumerate((("T_heavy", "heavy atoms"), ("T_H", "hydrogens"))):
        ax.errorbar([r[key] for r in results], y + (k - 0.5) * 0.2, xerr=[r[key + "_error"] for r in results],
                    fmt="os"[k], capsize=3, label=label)
    ax.axvline(TEMPERATURE, color="k", lw=0.8, ls="--")
    ax.set_xlabel("kinetic temperature (K)")
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=below, ncol=2)
    ax = axes[3]
    keys = [("width bond heavy", "heavy-atom bonds"), ("width angle heavy nonplanar", "heavy angles, non-planar"),
            ("width angle withH nonplanar", "angles with H, non-planar"), ("width angle heavy planar",
                                                                          "heavy angles, planar")]
    for k, (key, label) in enumerate(keys):
        ax.errorbar([100 * (r["ratio " + key] - 1) for r in results], y + (k - 1.5) * 0.17,
                    xerr=[100 * r["ratio " + key + "_error"] for r in results], fmt="os^v"[k], capsize=3,
                    label=label)
    ax.axvline(0, color="k", lw=0.8, ls="--")
    ax.set_xlabel("width − %s's (%%)" % results[0]["name"])
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=below, ncol=2)
    ax = axes[4]
    ax.barh(y, [r["ns_per_day"] for r in results], color="tab:gray")
    for yi, r in zip(y, results):
        if "ratio_to_baseline" in r:
            ax.text(r["ns_per_day"], yi, " %.2f×" % r["ratio_to_baseline"], va="center", fontsize=8)
    ax.set_xlabel("ns/day, 1 thread, interleaved" + ("\n(× %s)" % data["baseline"] if any(
        "ratio_to_baseline" in r for r in results) else ""))
    ax.set_xlim(0, 1.25 * max(r["ns_per_day"] for r in results))
    failed = [r["name"] for r in data["results"] if "failed" in r]
    if failed:
        axes[4].text(0.99, 0.02, "failed (not drawn):\n" + "\n".join(failed), transform=axes[4].transAxes,
                     ha="right", va="bottom", fontsize=8, color="tab:red")
    title = ("Alanine dipeptide, amber14/OBC2, 300 K: %s (%g ps production per peer; ± block s.e.)\n%s" % (
        data.get("title") or "FLAVOR with HMR 3 amu vs LangevinMiddle", data["production_ps"], verdict(data)))
    fig.suptitle("\n".join(textwrap.fill(line, 190) for line in title.split("\n")), fontsize=10)
    if data.get("quick"):
        fig.text(0.5, 0.5, "smoke run (--quick): not a measurement", ha="center", va="center", rotation=18,
                 fontsize=30, color="tab:red", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--quick", action="store_true", help="a smoke run of seconds (the test runs it)")
    p.add_argument("--out", default=os.path.join(HERE, "..", "..", "results", "alanine_dipeptide"),
                   help="output directory (default results/alanine_dipeptide)")
    p.add_argument("--peers", default=DEFAULT_PEERS, help="comma separated (the docstring); the first is the reference")
    p.add_argument("--start", type=float, default=20.0, help="ps of common LangevinMiddle 1 fs (default 20)")
    p.add_argument("--equilibration", type=float, default=10.0, help="ps per peer with its own integrator (10)")
    p.add_argument("--production", type=float, default=1000.0, help="ps of production per peer (1000)")
    p.add_argument("--rounds", type=int, default=10, help="interleaved rounds (10)")
    p.add_argument("--blocks", type=int, default=10, help="block means for the error bars (10)")
    p.add_argument("--seed", type=int, default=0, help="added to every random seed")
    p.add_argument("--name", default="alanine_dipeptide", help="the outputs' file name without extension")
    p.add_argument("--title", default="", help="what the chart's title says is compared (default: the scene's peers)")
    p.add_argument("--rescale-dof", metavar="JSON", help="rewrite an earlier run's JSON with the class temperatures "
                   "on the projected degrees of freedom (rescale_dof), running nothing")
    p.add_argument("--replot", metavar="JSON", help="redraw the chart of an earlier run, running nothing")
    p.add_argument("--table", metavar="JSON", help="print the tables of an earlier run, running nothing")
    args = p.parse_args()
    if args.rescale_dof:
        with open(args.rescale_dof, encoding="utf-8") as f:
            data = rescale_dof(json.load(f))
        with open(args.rescale_dof, "w", encoding="utf-8") as f:
            json.dump(data, f, indent=1, default=float)
        return
    if args.replot:
        with open(args.replot, encoding="utf-8") as f:
            data = json.load(f)
        os.makedirs(args.out, exist_ok=True)
        plot(data, os.path.join(args.out, args.name + ".png"))
        return
    if args.table:
        with open(args.table, encoding="utf-8") as f:
            print_tables(json.load(f))
        return
    if args.quick:
        args.start, args.equilibration, args.production, args.rounds, args.blocks = 2.0, 1.0, 12.0, 2, 4
    data = run(args)
    print_tables(data)
    os.makedirs(args.out, exist_ok=True)
    json_path, png_path = os.path.join(args.out, args.name + ".json"), os.path.join(args.out, args.name + ".png")
    with open(json_path, "w", encoding="utf-8") as f:
        json.dump(data, f, indent=1, default=float)
    plot(data, png_path)
    print("\nwrote %s and %s" % (json_path, png_path))


if __name__ == "__main__":
    main()
