#!/usr/bin/env python3
"""Villin headpiece (N68H) in explicit water, 8,867 atoms (OpenMM's own example input, amber14 + TIP3P, PME,
X-H bonds constrained, rigid water), on the CPU platform: the artificial FLAVOR against OpenMM's Langevin
integrators, every peer run here from the same equilibrated start.

Force groups: HarmonicBondForce (the heavy-atom bonds; the X-H bonds are constraints) in group 1,
HarmonicAngleForce in group 2 but the angles of the planar centres (sp2 carbons and nitrogens: carbonyls, amides,
aromatic rings; FlavorIntegrator.separatePlanarAngles) in group 3, everything else (PME, torsions) in group 0.

Peers (Langevin, 300 K, friction 1/ps):
  - LangevinMiddleIntegrator 2 fs (the reference for the observables);
  - MTSLangevinIntegrator 4 fs outer, the bonds and angles 4 times per step (1 fs) (--no-mts leaves it out);
  - LangevinMiddleIntegrator at the further steps of --langevin-steps (e.g. 0.5 fs: the small-step limit);
  - LangevinMiddleIntegrator with hydrogen mass repartitioning (--hmr-langevin 4:1.5: 4 fs, createSystem's
    hydrogenMass = 1.5 amu, OpenMM's documented way to run at 4 fs);
  - FlavorIntegrator, ArtificialProjected averaging, Verlet scheme, at the mesostep delta and microstep tau of
    --flavors, with the bonds and angles stiff ("4:1", groups 1-3), the bonds and the angles of the other centres
    stiff ("2.5:1:planar", groups 1-2: the angles of the planar centres soft), or the bonds alone ("4:1:bonds",
    angles soft), the thermostat at the edges of the mesostep or in the middle of the drifts ("4:1:middle"), on the
    System with hydrogen mass repartitioning ("5:1:planar:middle:hmr3": hydrogenMass = 3 amu, as the LangevinMiddle
    peers; ":water" adds the rigid water's hydrogens, a probe of what limits the mesostep, not a recipe).

Every stable peer is then timed interleaved with 2 threads (--rounds rounds of --round-ps each, in turn), and its
speed given as the median over the rounds of its ratio to LangevinMiddle 4 fs HMR 1.5 amu of the same round.  A peer
that fails is recorded with the step after which it failed and where its heat was before (kinetic temperatures of
the water, the protein's hydrogens and heavy atoms every --watch fs; its hottest atoms).

Observables, each with a block-average error bar (the standard error of the block means): kinetic temperature of
the whole system and of the protein (degrees of freedom less the constraints), RMS deviation of the bond lengths
from their equilibrium lengths per element pair, RMS deviation of the angles from their equilibrium angles (angles
with and without a hydrogen), backbone (N, CA, C) RMSD from the common start after superposition.  ns/day with 2
threads is measured over the production run; ns/day with 1 thread over a further --timing ps in a new Context.

    PYTHONPATH=build/python .venv/bin/python examples/villin/villin.py [--quick] [--out DIR]
        [--start PS] [--equilibration PS] [--production PS] [--timing PS] [--flavors ...] [--langevin-steps FS ...]

Outputs: DIR/villin.json (every number and the RMSD series) and DIR/villin.png.
"""
import json
import math
import os
import re
import textwrap
import time
import warnings

import numpy as np
import openmm as mm
import openmm.app as app
import openmm.unit as unit

import openmmflavors
from flavorbench import reporting
from flavorbench.timeseries import ProductionFrames, add_block_errors
from flavorbench.progress import Progress
from flavorbench.runners import KB
from flavorbench.systems import assign_force_groups, harmonic_angles

HERE = os.path.dirname(os.path.abspath(__file__))
PDB = os.path.join(HERE, "villin.pdb")
TEMPERATURE = 300.0  # K
FRICTION = 1.0  # 1/ps
BOND_GROUP, ANGLE_GROUP, PLANAR_ANGLE_GROUP = 1, 2, 3
# This scene is the measurement the warning about mesosteps beyond 2.5 fs names: its 3-fs run is meant.
warnings.filterwarnings("ignore", message=".*longer than any mesostep measured", category=openmmflavors.FlavorsWarning)


def make_system(forcefield, topology, hydrogen_mass=None, water_hydrogen_mass=False):
    """The scene's System; hydrogen_mass (amu): OpenMM's hydrogen mass repartitioning (createSystem's hydrogenMass:
    the protein's hydrogens get this mass, taken from the heavy atom they are bonded to; with rigid water the water's
    hydrogens keep theirs).  water_hydrogen_mass (a probe of what limits the step, not a recipe): the water's
    hydrogens get hydrogen_mass too, taken from their oxygen."""
    extra = {} if hydrogen_mass is None else {"hydrogenMass": hydrogen_mass * unit.amu}
    system = forcefield.createSystem(topology, nonbondedMethod=app.PME, nonbondedCutoff=1.0 * unit.nanometer,
                                     constraints=app.HBonds, rigidWater=True, removeCMMotion=False, **extra)
    if water_hydrogen_mass and hydrogen_mass is not None:
        for residue in topology.residues():
            if residue.name in ("HOH", "WAT"):
                oxygen = next(a.index for a in residue.atoms() if a.element.symbol == "O")
                for atom in residue.atoms():
                    if atom.element.symbol == "H":
                        added = hydrogen_mass * unit.amu - system.getParticleMass(atom.index)
                        system.setParticleMass(atom.index, hydrogen_mass * unit.amu)
                        system.setParticleMass(oxygen, system.getParticleMass(oxygen) - added)
    assign_force_groups(system, {mm.HarmonicBondForce: BOND_GROUP, mm.HarmonicAngleForce: ANGLE_GROUP})
    openmmflavors.FlavorIntegrator.separatePlanarAngles(system, PLANAR_ANGLE_GROUP)
    return system


def hmr_label(hydrogen_mass, water=False):
    return "" if hydrogen_mass is None else " HMR %g amu%s" % (hydrogen_mass, " (water too)" if water else "")


def peers(flavor_settings, langevin_steps=(), hmr_langevin=(), mts=True, seed=0):
    """(name, factory) for every peer; factory() returns the integrator, factory.system_options are make_system's
    keyword arguments (hydrogen_mass, water_hydrogen_mass) for the peer's System.  flavor_settings: (delta, tau,
    stiff terms, middle[, hydrogen mass, water too])."""
    plain = {"hydrogen_mass": None, "water_hydrogen_mass": False}

    def langevin(step):
        integrator = mm.LangevinMiddleIntegrator(TEMPERATURE, FRICTION, step * 1e-3)
        integrator.setRandomNumberSeed(seed)  # 0 (the default): OpenMM picks one
        return integrator

    result = [("LangevinMiddle 2 fs", lambda: langevin(2), plain)]
    if mts:
        result.append(("MTSLangevin 4 fs / 4",
                       lambda: mm.MTSLangevinIntegrator(TEMPERATURE, FRICTION, 4e-3, [(0, 1), (BOND_GROUP, 4),
                                                                                      (ANGLE_GROUP, 4),
                                                                                      (PLANAR_ANGLE_GROUP, 4)]),
                       plain))
    for step in langevin_steps:
        result.append(("LangevinMiddle %g fs" % step, lambda step=step: langevin(step), plain))
    for setting in hmr_langevin:
        step, mass, water = tuple(setting) + (False,)[len(setting) - 2:]
        result.append(("LangevinMiddle %g fs%s" % (step, hmr_label(mass, water)), lambda step=step: langevin(step),
                       {"hydrogen_mass": mass, "water_hydrogen_mass": water}))
    for setting in flavor_settings:
        delta, tau, stiff_terms, middle, mass, water = tuple(setting) + (None, False)[len(setting) - 4:]
        stiff = {"bonds": {BOND_GROUP}, "bonds+angles": {BOND_GROUP, ANGLE_GROUP, PLANAR_ANGLE_GROUP},
                 "bonds+nonplanar angles": {BOND_GROUP, ANGLE_GROUP}}[stiff_terms]

        def factory(delta=delta, tau=tau, stiff=stiff, middle=middle):
            integrator = openmmflavors.FlavorIntegrator(delta * unit.femtosecond, tau * unit.femtosecond, stiff)
            integrator.setAveraging(openmmflavors.FlavorIntegrator.ArtificialProjected)
            integrator.setTemperature(TEMPERATURE * unit.kelvin)
            integrator.setFriction(FRICTION / unit.picosecond)
            if middle:
                integrator.setThermostatPlacement(openmmflavors.FlavorIntegrator.Middle)
            integrator.setRandomNumberSeed(1234 + seed)
            return integrator

        what = stiff_terms + (" Middle" if middle else "") + hmr_label(mass, water)
        result.append(("FLAVOR ArtificialProjected %s δ=%g fs τ=%g fs" % (what, delta, tau), factory,
                       {"hydrogen_mass": mass, "water_hydrogen_mass": water}))
    for _, factory, options in result:
        factory.system_options = options
    return [(name, factory) for name, factory, _ in result]


class Geometry:
    """Index arrays of the System's bonds, angles, constraints and backbone, and the per-frame observables."""

    def __init__(self, system, topology):
        atoms = list(topology.atoms())
        element = [a.element.symbol if a.element is not None else "?" for a in atoms]
        self.masses = np.array([system.getParticleMass(i).value_in_unit(unit.dalton)
                                for i in range(system.getNumParticles())])
        water = {"HOH", "WAT"}
        ions = {"Cl", "CL", "Na", "NA"}
        self.protein = np.array([a.index for a in atoms if a.residue.name not in water | ions])
        in_protein = np.zeros(len(atoms), bool)
        in_protein[self.protein] = True
        constraints = [system.getConstraintParameters(i)[:2] for i in range(system.getNumConstraints())]
        self.dof = 3 * len(atoms) - len(constraints)
        self.protein_dof = 3 * len(self.protein) - sum(1 for i, j in constraints if in_protein[i] and in_protein[j])
        self.backbone = np.array([a.index for a in atoms if in_protein[a.index] and a.name in ("N", "CA", "C")])
        # Atom classes for the diagnosis of a failing run: which heats first.
        is_h = np.array([e == "H" for e in element])
        is_water = np.array([a.residue.name in water for a in atoms])
        self.atom_classes = {"water": np.flatnonzero(is_water), "protein H": np.flatnonzero(in_protein & is_h),
                             "protein heavy atoms": np.flatnonzero(in_protein & ~is_h)}
        self.atom_labels = ["%s%d %s" % (a.residue.name, int(a.residue.id) if a.residue.id.isdigit() else 0, a.name)
                            for a in atoms]
        bonds = next(f for f in system.getForces() if isinstance(f, mm.HarmonicBondForce))
        b = [bonds.getBondParameters(i) for i in range(bonds.getNumBonds())]
        self.bond_i = np.array([x[0] for x in b])
        self.bond_j = np.array([x[1] for x in b])
        self.bond_r0 = np.array([x[2].value_in_unit(unit.nanometer) for x in b])
        self.bond_class = {}
        for n, (i, j) in enumerate(zip(self.bond_i, self.bond_j)):
            self.bond_class.setdefault("–".join(sorted((element[i], element[j]))), []).append(n)
        self.bond_class = {k: np.array(v) for k, v in sorted(self.bond_class.items())}
        terms = harmonic_angles(system)
        a = [x for x, _ in terms]
        planar = [group == PLANAR_ANGLE_GROUP for _, group in terms]
        self.angle_ijk = np.array([x[:3] for x in a])
        self.angle_t0 = np.degrees(np.array([x[3].value_in_unit(unit.radian) for x in a]))
        has_h = np.array([any(element[p] == "H" for p in x[:3]) for x in a])
        planar = np.array(planar)
        self.angle_class = {"with H": np.flatnonzero(has_h), "heavy atoms": np.flatnonzero(~has_h),
                            "planar centres, with H": np.flatnonzero(planar & has_h),
                            "planar centres, heavy atoms": np.flatnonzero(planar & ~has_h),
                            "other centres, with H": np.flatnonzero(~planar & has_h),
                            "other centres, heavy atoms": np.flatnonzero(~planar & ~has_h)}

    def class_temperatures(self, v, masses):
        """Kinetic temperature of each atom class with 3 degrees of freedom per atom (constraints not subtracted: a
        measure of where the heat is, for a failing run)."""
        ke2 = np.sum(v ** 2, axis=1) * masses
        return {name: float(ke2[idx].sum() / (3 * len(idx) * KB)) for name, idx in self.atom_classes.items()}

    def hottest_atoms(self, v, masses, count=12):
        """The count atoms of the largest kinetic energy, as (label, m v^2 / 3k in K)."""
        t = np.sum(v ** 2, axis=1) * masses / (3 * KB)
        return [(self.atom_labels[i], float(t[i])) for i in np.argsort(t)[::-1][:count]]

    def frame(self, q, v, reference_backbone, masses=None):
        """Per-frame values: T (whole system, protein), bond RMS deviation per class (nm), angle RMS deviation per
        class (degrees), backbone RMSD (nm).  masses: the peer's System's (with hydrogen mass repartitioning they
        differ from the scene's)."""
        out = {}
        ke2 = np.sum(v ** 2, axis=1) * (self.masses if masses is None else masses)
        out["T"] = ke2.sum() / (self.dof * KB)
        out["T_protein"] = ke2[self.protein].sum() / (self.protein_dof * KB)
        dr = np.linalg.norm(q[self.bond_i] - q[self.bond_j], axis=1) - self.bond_r0
        for name, idx in self.bond_class.items():
            out["bond_rms " + name] = math.sqrt(np.mean(dr[idx] ** 2))
        out["bond_rms all"] = math.sqrt(np.mean(dr ** 2))
        out["bond_mean_dev all"] = float(np.mean(dr))
        d1 = q[self.angle_ijk[:, 0]] - q[self.angle_ijk[:, 1]]
        d2 = q[self.angle_ijk[:, 2]] - q[self.angle_ijk[:, 1]]
        cos = np.sum(d1 * d2, axis=1) / (np.linalg.norm(d1, axis=1) * np.linalg.norm(d2, axis=1))
        dt = np.degrees(np.arccos(np.clip(cos, -1, 1))) - self.angle_t0
        for name, idx in self.angle_class.items():
            out["angle_rms " + name] = math.sqrt(np.mean(dt[idx] ** 2))
        out["angle_rms all"] = math.sqrt(np.mean(dt ** 2))
        out["backbone_rmsd"] = kabsch_rmsd(q[self.backbone], reference_backbone)
        return out


def kabsch_rmsd(x, y):
    """RMSD of x from y after the optimal superposition."""
    x = x - x.mean(axis=0)
    y = y - y.mean(axis=0)
    u, s, vt = np.linalg.svd(x.T @ y)
    d = np.sign(np.linalg.det(u @ vt))
    s[-1] *= d
    return math.sqrt(max(0.0, (np.sum(x ** 2) + np.sum(y ** 2) - 2 * np.sum(s)) / len(x)))


def new_context(system, integrator, threads):
    return mm.Context(system, integrator, mm.Platform.getPlatformByName("CPU"), {"Threads": str(threads)})


def run_peer(name, factory, options, forcefield, topology, start_positions, geometry, args, frames, seed=0):
    """One peer from the common start: equilibration, production (the observables), a 1-thread timing.  Returns the
    JSON record and, for a stable peer, (system, final state) for the interleaved timing.  A run that fails (an
    OpenMMException or a non-finite state) is recorded with the step it failed at and where its heat was: the kinetic
    temperature of the water, the protein's hydrogens and its heavy atoms every --watch fs before it, and its hottest
    atoms at the last finite frame."""
    system = make_system(forcefield, topology, **options)
    masses = np.array([system.getParticleMass(i).value_in_unit(unit.dalton) for i in range(system.getNumParticles())])
    integrator = factory()
    context = new_context(system, integrator, 2)
    context.setPositions(start_positions)
    context.setVelocitiesToTemperature(TEMPERATURE * unit.kelvin, 7 + seed)
    step_fs = integrator.getStepSize().value_in_unit(unit.femtosecond)
    reference_backbone = np.asarray(start_positions.value_in_unit(unit.nanometer))[geometry.backbone]
    record = {"name": name, "step_fs": step_fs, "stable": True, "hydrogen_mass_amu": options["hydrogen_mass"]}
    progress = Progress(name, args.equilibration + args.production + args.timing, fmt=".3f")
    history = []  # (step, class temperatures) of the last watched frames
    last_velocities = None
    steps_done = 0

    def watch(v):
        history.append((steps_done, geometry.class_temperatures(v, masses)))
        del history[:-12]

    try:
        steps = int(round(args.equilibration * 1000 / step_fs))
        chunk = max(1, int(round(args.watch / step_fs)))
        while steps_done < steps:
            n = min(chunk, steps - steps_done)
            integrator.step(n)
            steps_done += n
            state = context.getState(getVelocities=True, getEnergy=True)
            v = state.getVelocities(asNumpy=True).value_in_unit(unit.nanometer / unit.picosecond)
            if not np.all(np.isfinite(v)) or not math.isfinite(state.getPotentialEnergy()._value):
                raise mm.OpenMMException("non-finite state")
            watch(v)
            last_velocities = v
            progress.update(steps_done * step_fs / 1000, note="  equilibration")
        equilibration_steps = steps_done
        production = ProductionFrames(context, integrator, int(round(args.production * 1000 / step_fs)), frames)
        series = {}
        times = []
        for frame in production:
            steps_done = equilibration_steps + production.steps_done
            watch(frame.velocities)
            last_velocities = frame.velocities
            for key, value in geometry.frame(frame.positions, frame.velocities, reference_backbone, masses).items():
                series.setdefault(key, []).append(value)
            series.setdefault("potential_energy", []).append(frame.potential_energy)
            times.append(production.steps_done * step_fs / 1000)
            progress.update(args.equilibration + production.steps_done * step_fs / 1000, note="  production")
        record["ns_per_day_2_threads"] = production.ns_per_day(step_fs)
        blocks = 5 if len(times) >= 10 else 2
        record["blocks"] = blocks
        add_block_errors(record, series, blocks)
        record["backbone_rmsd_final"] = series["backbone_rmsd"][-1]
        record["series"] = {"t_ps": times, "backbone_rmsd": series["backbone_rmsd"], "T": series["T"]}
        final = context.getState(getPositions=True, getVelocities=True)
        # ns/day with 1 thread: a new Context at the last state.
        del context
        integrator = factory()
        context = new_context(system, integrator, 1)
        context.setState(final)
        integrator.step(1)
        steps = max(2, int(round(args.timing * 1000 / step_fs)))
        begin = time.perf_counter()
        integrator.step(steps)
        record["ns_per_day_1_thread"] = steps * step_fs * 1e-6 / (time.perf_counter() - begin) * 86400
        progress.update(args.equilibration + args.production + args.timing, force=True, note="  1-thread timing")
        return record, (system, final)
    except mm.OpenMMException as error:
        record["stable"] = False
        record["error"] = str(error)
        # The failure happened in the steps after the last watched frame (production: after the last frame).
        record["failed_after_step"] = steps_done
        record["failed_after_fs"] = steps_done * step_fs
        record["heat_before_failure"] = [{"step": n, "time_fs": n * step_fs, "T_K": t} for n, t in history]
        if last_velocities is not None:
            record["hottest_atoms_last_finite_frame"] = geometry.hottest_atoms(last_velocities, masses)
        return record, None


BASELINE = "LangevinMiddle 4 fs HMR 1.5 amu"  # OpenMM's documented way to run at 4 fs: the speed to beat


def interleaved_timing(entries, rounds, round_ps):
    """Wall-clock ns/day of every stable peer with 2 threads, interleaved: one Context each at its final state, then
    `rounds` rounds in which each steps round_ps in turn (the order rotated each round), so that a change of the
    machine's load hits every peer alike.  entries: [(record, factory, system, state)].  Adds to each record the
    rounds' ns/day, their median and standard error, and the median over the rounds of its ratio to BASELINE (or,
    without it, to the first peer) of the same round."""
    runs = []
    for record, factory, system, state in entries:
        integrator = factory()
        context = new_context(system, integrator, 2)
        context.setState(state)
        integrator.step(1)
        runs.append([record, integrator, context])
    speeds = {r["name"]: [] for r, _, _ in runs}
    for n in range(rounds):
        order = runs[n % len(runs):] + runs[:n % len(runs)]
        for record, integrator, context in order:
            if record["name"] not in speeds:
                continue
            step_fs = record["step_fs"]
            steps = max(1, int(round(round_ps * 1000 / step_fs)))
            try:
                begin = time.perf_counter()
                integrator.step(steps)
                context.getState(getEnergy=True)
                speeds[record["name"]].append(steps * step_fs * 1e-6 / (time.perf_counter() - begin) * 86400)
            except mm.OpenMMException as error:
                record["interleaved_timing_error"] = str(error)
                del speeds[record["name"]]
        print("interleaved round %d/%d: " % (n + 1, rounds) +
              ", ".join("%s %.2f" % (name, v[-1]) for name, v in speeds.items()) + " ns/day", flush=True)
    baseline = BASELINE if BASELINE in speeds else next(iter(speeds))
    for record, _, _ in runs:
        values = speeds.get(record["name"])
        if not values:
            continue
        record["ns_per_day_interleaved_rounds"] = values
        record["ns_per_day_interleaved"] = float(np.median(values))
        record["ns_per_day_interleaved_error"] = (float(np.std(values, ddof=1) / math.sqrt(len(values)))
                                                  if len(values) > 1 else 0.0)
        record["interleaved_ratio_baseline"] = baseline
        record["interleaved_ratio"] = float(np.median(np.array(values) / np.array(speeds[baseline])))
    del runs
    return baseline


def summary_line(r):
    if not r["stable"]:
        heat = r["heat_before_failure"][-1]["T_K"] if r["heat_before_failure"] else {}
        return "%-44s FAILED after step %d (%g fs): %s; last watched T: %s; hottest: %s" % (
            r["name"], r["failed_after_step"], r["failed_after_fs"], r["error"],
            ", ".join("%s %.0f K" % kv for kv in heat.items()),
            ", ".join("%s %.0f K" % kv for kv in r.get("hottest_atoms_last_finite_frame", [])[:5]))
    return ("%-44s %6.1f / %6.1f ns/day (1/2 thr)  T %.1f±%.1f  T_prot %.1f±%.1f  bond %.5f±%.5f nm  "
            "angle %.2f±%.2f°  RMSD %.4f±%.4f nm" % (
                r["name"], r["ns_per_day_1_thread"], r["ns_per_day_2_threads"], r["T"], r["T_error"],
                r["T_protein"], r["T_protein_error"], r["bond_rms all"], r["bond_rms all_error"],
                r["angle_rms all"], r["angle_rms all_error"], r["backbone_rmsd"], r["backbone_rmsd_error"]))


def within_error(run, reference, key):
    """|run - reference| <= 2 sqrt(se_run^2 + se_ref^2) for the observable key."""
    return abs(run[key] - reference[key]) <= 2 * math.hypot(run.get(key + "_error", 0.0),
                                                           reference.get(key + "_error", 0.0))


def short_name(name):
    """A peer's name in the charts: the notation of reporting.greek, "δ = 2.5 fs, τ = 1 fs", without
    "ArtificialProjected" (every FLAVOR here averages so)."""
    label = re.sub(r"([δτ])=", r"\1 = ", reporting.greek(name)).replace(" fs τ", " fs, τ")
    return label.replace("FLAVOR ArtificialProjected ", "FLAVOR ")


def chart_name(name):
    """short_name without "bonds+nonplanar angles Middle" (the scene's recipe; the footer says so)."""
    return short_name(name).replace("FLAVOR bonds+nonplanar angles Middle ", "FLAVOR ")


def busy_machine(stable):
    """Whether the timings say the machine was busy: 2 threads slower than 1 for some peer."""
    return any(r["ns_per_day_2_threads"] < r["ns_per_day_1_thread"] for r in stable)


def observable_keys(reference):
    """The observables with an error bar (the speeds left out)."""
    return [k for k in reference if k + "_error" in reference and not k.startswith("ns_per_day")]


def speed(r):
    """ns/day with 2 threads: interleaved where measured, else during the production."""
    return r.get("ns_per_day_interleaved", r["ns_per_day_2_threads"])


def verdict(stable, reference):
    """The title's verdict: among the peers within 2 s.e. of the reference on every observable (within_error), the
    fastest OpenMM setting and the fastest FLAVOR by interleaved ns/day (2 threads), and their ratio; without such a
    FLAVOR, the FLAVOR off in the fewest observables, named with their σ."""
    keys = observable_keys(reference)

    def misses(r):
        return [k for k in keys if not within_error(r, reference, k)]

    def sigma(r, k):
        return abs(r[k] - reference[k]) / math.hypot(r.get(k + "_error", 0.0), reference.get(k + "_error", 0.0))

    good = [r for r in stable if r is not reference and not misses(r)]
    openmm_best = max((r for r in good if not r["name"].startswith("FLAVOR")), key=speed, default=None)
    flavors = [r for r in stable if r["name"].startswith("FLAVOR")]
    flavor_best = max((r for r in good if r["name"].startswith("FLAVOR")), key=speed, default=None)
    text = "within 2 s.e. of LangevinMiddle 2 fs on all %d observables, fastest (2 threads, interleaved): " % len(keys)
    text += "OpenMM %s (%.1f ns/day)" % (short_name(openmm_best["name"]), speed(openmm_best)) if openmm_best else \
        "OpenMM none besides the reference"
    if flavor_best:
        text += ", FLAVOR %s (%.1f ns/day%s)" % (
            short_name(flavor_best["name"]).replace("FLAVOR ", ""), speed(flavor_best),
            ", %.2f× it" % (speed(flavor_best) / speed(openmm_best)) if openmm_best else "")
    elif flavors:
        closest = min(flavors, key=lambda r: (len(misses(r)), -speed(r)))
        text += "; no FLAVOR; closest %s, off in %s" % (
            short_name(closest["name"]), ", ".join("%s (%.1fσ)" % (k.replace("_rms", " RMS").replace("_", " "),
                                                                   sigma(closest, k)) for k in misses(closest)))
    return text


def plot(data, path):
    plt = reporting.pyplot()
    records = data["peers"]
    stable = [r for r in records if r["stable"]]
    reference = records[0] if records[0]["stable"] else None
    labels = [chart_name(r["name"]).replace(" δ", "\nδ") for r in stable]
    y = np.arange(len(stable))
    fig, axes = plt.subplots(2, 4, figsize=(24, 13))
    axes = axes.ravel()
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]

    def errorbar_panel(ax, keys, xlabel, show_labels, relative=False):
        """Each observable against the peers; with a reference, a grey band of its ±1 s.e.; relative: several
        observables as % deviation from the reference, which is then one line at 0."""
        offsets = np.linspace(-0.15, 0.15, len(keys)) if len(keys) > 1 else [0.0]
        drawn = []
        for n, (key, legend) in enumerate(keys):
            scale = 100.0 / reference[key] if relative else 1.0
            shift = reference[key] if relative else 0.0
            values = np.array([(r.get(key, math.nan) - shift) * scale for r in stable])
            errors = np.array([r.get(key + "_error", 0.0) * scale for r in stable])
            drawn.append((n, key, legend, values, errors))
        # With several classes, one whose error bars are far wider than the others' (a class of a few bonds) sets no
        # scale: its bars are cut at the panel's edge and its points beyond it drawn there as arrows with the value.
        wide = set()
        if relative and len(drawn) > 2:
            typical = np.median([np.median(e) for _, _, _, _, e in drawn])
            wide = {key for _, key, _, _, e in drawn if np.median(e) > 4 * typical}
        for n, key, legend, values, errors in drawn:
            ax.errorbar(values, y + offsets[n], xerr=errors, fmt="o", capsize=3, color=colors[n],
                        label=legend + (" (bars cut)" if key in wide else ""))
        if wide:
            narrow = [(v, e) for _, key, _, v, e in drawn if key not in wide]
            span = max(max(np.max(np.abs(v) + e) for v, e in narrow), 1.0) * 1.3
            ax.set_xlim(-span, span)
            for n, key, legend, values, errors in drawn:
                if key in wide:
                    for value, row in zip(values, y + offsets[n]):
                        if abs(value) > span:
                            edge = math.copysign(span, value)
                            ax.plot(edge, row, ">" if value > 0 else "<", color=colors[n], ms=8, clip_on=False)
                            ax.annotate(("%+.0f %%" % value).replace("-", "−"), (edge, row), textcoords="offset points",
                                        xytext=(-6 if value > 0 else 6, 6), ha="right" if value > 0 else "left",
                                        fontsize=9, color=colors[n])
        if reference is not None and not keys[0][0].startswith("ns_per_day"):
            if relative:
                ax.axvline(0.0, color="k", ls="--", lw=0.8, label="reference (LangevinMiddle 2 fs)")
            else:
                key = keys[0][0]
                ax.axvspan(reference[key] - reference.get(key + "_error", 0.0),
                           reference[key] + reference.get(key + "_error", 0.0), color="0.88",
                           label="reference ±1 s.e. (LangevinMiddle 2 fs)")
        ax.set_yticks(y)
        ax.set_yticklabels(labels if show_labels else [], fontsize=11)
        ax.tick_params(axis="x", labelsize=11)
        ax.set_ylim(len(stable) - 0.5, -0.5)
        ax.set_xlabel(xlabel, fontsize=12)
        ax.locator_params(axis="x", nbins=5)
        # Below the axes, so that no legend hides a point.
        ax.legend(fontsize=10, loc="upper center", bbox_to_anchor=(0.5, -0.14),
                  ncol=2 if len(keys) > 1 and not keys[0][0].startswith("ns_per_day") else 1)

    errorbar_panel(axes[0], [("ns_per_day_interleaved", "2 threads, interleaved (median of rounds ± s.e.)"),
                             ("ns_per_day_2_threads", "2 threads, during the production"),
                             ("ns_per_day_1_thread", "1 thread, after the production")],
                   "speed (ns/day, CPU platform)", True)
    errorbar_panel(axes[1], [("T", "whole system")], "kinetic temperature (K)", False)
    errorbar_panel(axes[2], [("T_protein", "protein")], "kinetic temperature of the protein (K)", False)
    errorbar_panel(axes[3], [("bond_rms all", "all heavy-atom bonds")],
                   "bond length RMS deviation from r0 (nm)", False)
    axes[3].locator_params(axis="x", nbins=3)
    bond_classes = [k[len("bond_rms "):] for k in stable[0] if k.startswith("bond_rms ") and
                    not k.endswith("_error") and k != "bond_rms all"] if stable else []
    relative = reference is not None
    errorbar_panel(axes[4], [("bond_rms " + c, c) for c in bond_classes],
                   "bond RMS deviation, change from the reference (%)" if relative else
                   "bond length RMS deviation per element pair (nm)", True, relative)
    errorbar_panel(axes[5], [("angle_rms with H", "angles with H"), ("angle_rms heavy atoms", "heavy-atom angles")],
                   "angle RMS deviation, change from the reference (%)" if relative else
                   "angle RMS deviation from θ0 (°)", False, relative)
    errorbar_panel(axes[6], [("backbone_rmsd", "mean over production")], "backbone RMSD from the start (nm)", False)
    ax = axes[7]
    for r in stable:
        ax.plot(r["series"]["t_ps"], r["series"]["backbone_rmsd"],
                label=chart_name(r["name"]))
    ax.set_xlabel("production time (ps)", fontsize=12)
    ax.set_ylabel("backbone (N, CA, C) RMSD from the start (nm)", fontsize=12)
    ax.tick_params(labelsize=11)
    # Right of the panel, so that it hides neither a curve nor the legend of the panel beside it.
    ax.legend(fontsize=9, loc="upper left", bbox_to_anchor=(1.02, 1.0), ncol=1)
    unstable = [short_name(r["name"]) + (" (failed after step %d, %g fs)" % (r["failed_after_step"],
                                                                              r["failed_after_fs"])
                                         if "failed_after_step" in r else "") for r in records if not r["stable"]]
    footer = ("Error bars: standard error of %d block means over %g ps of production per peer "
             "(after %g ps of equilibration); FLAVOR: ArtificialProjected, the angles of the planar centres soft and the "
             "thermostat in the middle (Middle) unless its label says otherwise.  %s\n"
             "ns/day: 2 threads interleaved, the median of %d rounds of %g ps per peer (± s.e. of the rounds); the "
             "other two one timing each%s" % (
                 stable[0]["blocks"] if stable else 0, data["production_ps"], data["equilibration_ps"],
                 "Failed (not drawn): " + ", ".join(unstable) if unstable else "Every peer stayed stable.",
                 data.get("interleaved_rounds", 0), data.get("interleaved_ps_per_round", 0),
                 " (2 threads slower than 1 for some peers: the machine was busy, so the sequential ns/day are not "
                 "the integrators' speeds)" if busy_machine(stable) else "."))
    fig.text(0.01, 0.005, "\n".join(textwrap.fill(line, 250) for line in footer.split("\n")), fontsize=11)
    what = ("Villin in TIP3P water (8,867 atoms, amber14, PME, X–H constrained, rigid water, bath 300 K): FLAVOR "
            "ArtificialProjected (mesostep δ, microstep τ) against LangevinMiddle 2 fs (the reference), LangevinMiddle "
            "with hydrogen mass repartitioning (HMR: H mass in amu)" +
            (" and MTSLangevin" if any(r["name"].startswith("MTSLangevin") for r in records) else ""))
    fig.suptitle(textwrap.fill(what, 190) + "\n" + textwrap.fill(
        "Verdict: " + (verdict(stable, reference) if reference is not None else "the reference failed"), 190),
                 fontsize=13)
    fig.tight_layout(rect=(0, 0.035, 1, 0.94))
    reporting.save_figure(fig, path, dpi=80)


def ratio_text(r, records):
    """The median over the rounds of r's ratio to the interleaved baseline, and the rounds' range."""
    if "interleaved_ratio" not in r:
        return "—"
    base = next((b for b in records if b["name"] == r["interleaved_ratio_baseline"]), None)
    if base is None or len(base.get("ns_per_day_interleaved_rounds", [])) < 2:
        return "%.2f" % r["interleaved_ratio"]
    ratios = np.array(r["ns_per_day_interleaved_rounds"]) / np.array(base["ns_per_day_interleaved_rounds"])
    return "%.2f (%.2f–%.2f)" % (r["interleaved_ratio"], ratios.min(), ratios.max())


def markdown_table(data):
    """The README's table of a run: per peer the interleaved ns/day (2 threads) and its ratio to the baseline, the
    chart's observables with their block errors, and the observables (of all in the JSON) more than 2 combined s.e.
    from LangevinMiddle 2 fs, with their σ; a failed peer with the step it failed after and where its heat was."""
    records = data["peers"]
    reference = records[0]
    keys = observable_keys(reference) if reference["stable"] else []
    columns = [("T", "T (K)", "%.1f ± %.1f"), ("T_protein", "T protein (K)", "%.1f ± %.1f"),
               ("bond_rms all", "bond RMS (nm)", "%.5f ± %.5f"), ("angle_rms with H", "angles with H (°)",
                                                                   "%.3f ± %.3f"),
               ("angle_rms heavy atoms", "heavy angles (°)", "%.3f ± %.3f"),
               ("angle_rms planar centres, with H", "planar centres with H (°)", "%.3f ± %.3f"),
               ("backbone_rmsd", "backbone RMSD (nm)", "%.4f ± %.4f")]
    lines = ["| peer | ns/day (2 threads, interleaved) | × %s (rounds) | " % data.get("interleaved_baseline") +
             " | ".join(c[1] for c in columns) + " | beyond 2 s.e. of LangevinMiddle 2 fs (σ) |",
             "|---" * (len(columns) + 4) + "|"]
    for r in records:
        name = short_name(r["name"]).replace("FLAVOR bonds+nonplanar angles Middle", "FLAVOR")
        if not r["stable"]:
            heat = r["heat_before_failure"]
            first = heat[0]["T_K"] if heat else {}
            last = heat[-1]["T_K"] if heat else {}
            lines.append("| %s | failed after step %d (%g fs): %s; T water / protein H / protein heavy %s → %s K "
                         "over the last %g fs watched; hottest atoms %s |" % (
                             name, r["failed_after_step"], r["failed_after_fs"], r["error"],
                             " / ".join("%.0f" % v for v in first.values()),
                             " / ".join("%.0f" % v for v in last.values()),
                             (heat[-1]["time_fs"] - heat[0]["time_fs"]) if heat else 0,
                             ", ".join("%s %.0f K" % (a, t) for a, t in r.get("hottest_atoms_last_finite_frame", [])[:4])))
            continue
        off = [] if r is reference else [
            "%s %.1f" % (k.replace("_rms", " RMS").replace("_", " "),
                         abs(r[k] - reference[k]) / math.hypot(r[k + "_error"], reference[k + "_error"]))
            for k in keys if not within_error(r, reference, k)]
        lines.append("| %s | %s | %s | " % (
            name, "%.2f ± %.2f" % (r["ns_per_day_interleaved"], r["ns_per_day_interleaved_error"])
            if "ns_per_day_interleaved" in r else "—",
            ratio_text(r, records)) +
            " | ".join(fmt % (r[k], r[k + "_error"]) for k, _, fmt in columns) + " | %s |" % (
                "reference" if r is reference else ", ".join(off) if off else "none of %d" % len(keys)))
    return "\n".join(lines)


def main():
    p = reporting.parser(__doc__, "villin", quick_help="a few femtoseconds per peer (smoke test)")
    p.add_argument("--equilibration", type=float, default=1.0, help="ps per peer before measuring")
    p.add_argument("--production", type=float, default=4.0, help="ps per peer")
    p.add_argument("--timing", type=float, default=0.4, help="ps per peer timed with 1 thread")
    p.add_argument("--start", type=float, default=2.0, help="ps of common LangevinMiddle 2 fs before the peers")
    p.add_argument("--flavors", default="2.5:1:planar:middle,3:1:planar:middle,2.5:1:planar,2:1",
                   help="delta:tau[:bonds|:planar][:middle] in fs, comma separated (':bonds': only the bonds stiff; "
                        "':planar': the angles of the planar centres soft; ':middle': the thermostat in the middle "
                        "of the microstep, FlavorIntegrator.Middle)")
    p.add_argument("--langevin-steps", type=float, nargs="+", default=[], metavar="FS",
                   help="further LangevinMiddle peers at these steps in fs (e.g. 0.5: how far the 2-fs reference is "
                        "from the small-step limit)")
    p.add_argument("--hmr-langevin", default="", metavar="STEP:MASS[:water],...",
                   help="LangevinMiddle peers with hydrogen mass repartitioning: step in fs and hydrogen mass in amu "
                        "(createSystem's hydrogenMass), comma separated, e.g. 4:1.5,4:3 (':water': the rigid water's "
                        "hydrogens too, a probe)")
    p.add_argument("--no-mts", action="store_true", help="leave MTSLangevin out")
    p.add_argument("--seed", type=int, default=0,
                   help="added to every random seed (0: the scene's seeds, LangevinMiddle's chosen by OpenMM)")
    p.add_argument("--rounds", type=int, default=5, help="rounds of the interleaved 2-thread timing (default 5)")
    p.add_argument("--round-ps", type=float, default=0.2, help="ps per peer and round of the interleaved timing")
    p.add_argument("--watch", type=float, default=20.0,
                   help="fs between the watched frames of the equilibration (the failure diagnosis; default 20)")
    p.add_argument("--replot", metavar="JSON", help="only redraw the chart of an earlier run's JSON into --out")
    p.add_argument("--table", metavar="JSON", help="only print the markdown table of an earlier run's JSON")
    args = p.parse_args()
    if args.table:
        with open(args.table) as f:
            print(markdown_table(json.load(f)))
        return
    if args.replot:
        reporting.replot(args.replot, args.out, "villin", plot)
        return
    if any(not (0 < step <= 4) for step in args.langevin_steps):
        p.error("--langevin-steps: every step must be in (0, 4] fs, got %s" % args.langevin_steps)
    flavor_settings = []
    for setting in args.flavors.split(","):
        fields = setting.split(":")
        flags = set(fields[2:])
        masses = [f for f in flags if re.fullmatch(r"hmr\d+(\.\d*)?", f)]
        flags -= set(masses)
        if (len(fields) < 2 or not flags <= {"bonds", "planar", "middle", "water"} or {"bonds", "planar"} <= flags
                or len(masses) > 1 or ("water" in flags and not masses)):
            p.error("--flavors: %r is not delta:tau[:bonds|:planar][:middle][:hmrMASS[:water]]" % setting)
        stiff_terms = "bonds" if "bonds" in flags else "bonds+nonplanar angles" if "planar" in flags else "bonds+angles"
        flavor_settings.append((float(fields[0]), float(fields[1]), stiff_terms, "middle" in flags,
                                float(masses[0][3:]) if masses else None, "water" in flags))
    hmr_langevin = []
    for setting in filter(None, args.hmr_langevin.split(",")):
        fields = setting.split(":")
        try:
            if len(fields) not in (2, 3) or fields[2:] not in ([], ["water"]):
                raise ValueError(setting)
            hmr_langevin.append((float(fields[0]), float(fields[1]), fields[2:] == ["water"]))
        except ValueError:
            p.error("--hmr-langevin: %r is not STEP:MASS[:water]" % setting)
    if args.quick:
        args.equilibration, args.production, args.timing, args.start = 0.008, 0.04, 0.008, 0.01
        args.rounds, args.round_ps, args.watch = 1, 0.008, 4.0
        flavor_settings = flavor_settings[-1:]
        hmr_langevin = hmr_langevin[-1:]
    pdb = app.PDBFile(PDB)
    forcefield = app.ForceField("amber14-all.xml", "amber14/tip3p.xml")
    geometry = Geometry(make_system(forcefield, pdb.topology), pdb.topology)
    # The common start: minimized, then --start ps of LangevinMiddle at 2 fs.
    system = make_system(forcefield, pdb.topology)
    integrator = mm.LangevinMiddleIntegrator(TEMPERATURE, FRICTION, 2e-3)
    context = new_context(system, integrator, 2)
    context.setPositions(pdb.positions)
    progress = Progress("common start", args.start, fmt=".3f")
    mm.LocalEnergyMinimizer.minimize(context, 10.0, 20 if args.quick else 500)
    context.setVelocitiesToTemperature(TEMPERATURE * unit.kelvin, 3 + args.seed)
    integrator.setRandomNumberSeed(args.seed)
    steps = int(round(args.start * 500))
    for done in range(0, steps, 25):
        integrator.step(min(25, steps - done))
        progress.update(min(done + 25, steps) / 500, note="  LangevinMiddle 2 fs")
    start = context.getState(getPositions=True, enforcePeriodicBox=False).getPositions(asNumpy=True)
    del context, integrator
    frames = 10 if args.quick else 80
    records = []
    timing_entries = []
    for name, factory in peers(flavor_settings, args.langevin_steps, hmr_langevin, not args.no_mts, args.seed):
        record, final = run_peer(name, factory, factory.system_options, forcefield, pdb.topology, start, geometry, args, frames,
                                 args.seed)
        records.append(record)
        if final is not None:
            timing_entries.append((record, factory) + final)
        print(summary_line(record), flush=True)
    baseline = interleaved_timing(timing_entries, args.rounds, args.round_ps) if timing_entries else None
    del timing_entries
    for record in records:
        if "interleaved_ratio" in record:
            print("%-60s interleaved %6.2f ± %.2f ns/day, %.2f× %s" % (
                record["name"], record["ns_per_day_interleaved"], record["ns_per_day_interleaved_error"],
                record["interleaved_ratio"], baseline), flush=True)
    data = {"system": "villin N68H in TIP3P water (OpenMM examples/input.pdb)", "atoms": pdb.topology.getNumAtoms(),
            "force_field": ["amber14-all.xml", "amber14/tip3p.xml"], "constraints": "HBonds, rigid water",
            "nonbonded": "PME, cutoff 1.0 nm", "temperature_K": TEMPERATURE, "friction_per_ps": FRICTION,
            "degrees_of_freedom": geometry.dof, "protein_degrees_of_freedom": geometry.protein_dof,
            "heavy_bonds": len(geometry.bond_r0), "angles": len(geometry.angle_t0),
            "backbone_atoms": len(geometry.backbone), "start_ps": args.start,
            "equilibration_ps": args.equilibration, "production_ps": args.production, "timing_ps": args.timing,
            "interleaved_rounds": args.rounds, "interleaved_ps_per_round": args.round_ps,
            "interleaved_baseline": baseline, "seed": args.seed, "quick": args.quick, "peers": records}
    os.makedirs(args.out, exist_ok=True)
    reporting.save_outputs(args.out, "villin", data, lambda path: plot(data, path))


if __name__ == "__main__":
    main()
