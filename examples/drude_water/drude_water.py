"""SWM4-NDP polarizable water: StochasticImpulseIntegrator (exact Drude flow, cold Drude modes, rigid water) against
OpenMM's DrudeLangevinIntegrator, every run from the same equilibrated state in one process.

Writes drude_water.json and drude_water.png to --out.  Observables (block averages, error = standard error of the
block means): the induced dipoles relative to their self-consistent values at the same nuclear positions, the mean
molecular dipole, the potential energy per molecule, g_OO(r), the centre-of-mass and Drude temperatures, and ns/day.
"""
import argparse
import itertools
import json
import math
import os
import re
import textwrap

import numpy as np
import openmm
import openmm.app as app
import openmm.unit as unit
from flavorbench import reporting
from flavorbench.ensemble import mean_se
from flavorbench.interleaved import interleaved_ns_per_day
from flavorbench.runners import KB as BOLTZ
from flavorbench.solvation import AMU_PER_NM3, WATER_DENSITY_300K, volume_nm3
from flavorbench.timeseries import ProductionFrames, block_error
from openmmflavors import StochasticImpulseIntegrator

DRUDE_GROUP = 1
E_NM_TO_DEBYE = 48.0321  # 1 e nm in debye
WATER_MASS_AMU = (app.element.oxygen.mass + 2 * app.element.hydrogen.mass).value_in_unit(unit.dalton)


def water_description(parameters):
    """"256 molecules, 1.97-nm box, 1.00 g/cm^3" from a scene run's parameters (molecules and box_nm)."""
    molecules, box = parameters["molecules"], parameters["box_nm"]
    density = molecules * WATER_MASS_AMU / (box**3 * AMU_PER_NM3)
    return f"{molecules} molecules, {box:.2f}-nm box, {density:.2f} g/cm³"


def build_water(molecules, density=WATER_DENSITY_300K):
    """SWM4-NDP water (OpenMM's swm4ndp.xml) at `density` (g/cm^3): rigid, PME, Drude particles from
    addExtraParticles.  The molecules sit on the sites of a cubic lattice that fills the box, spread evenly over its
    sites when there are fewer molecules than sites (minimization and equilibration make a liquid of it)."""
    forcefield = app.ForceField("swm4ndp.xml")
    topology = app.Topology()
    chain = topology.addChain()
    side = int(math.ceil(molecules ** (1 / 3) - 1e-9))
    box = volume_nm3(molecules * WATER_MASS_AMU, density) ** (1 / 3)
    spacing = box / side
    angle = math.radians(104.52)
    geometry = np.array([[0, 0, 0], [0.09572, 0, 0], [0.09572 * math.cos(angle), 0.09572 * math.sin(angle), 0]])
    sites = list(itertools.product(range(side), repeat=3))
    positions = []
    for site in np.linspace(0, len(sites), molecules, endpoint=False).astype(int):
        residue = topology.addResidue("HOH", chain)
        o = topology.addAtom("O", app.element.oxygen, residue)
        h1 = topology.addAtom("H1", app.element.hydrogen, residue)
        h2 = topology.addAtom("H2", app.element.hydrogen, residue)
        topology.addBond(o, h1)
        topology.addBond(o, h2)
        for g in geometry:
            positions.append(openmm.Vec3(*(np.array(sites[site]) * spacing + 0.05 + g)))
    topology.setPeriodicBoxVectors(np.eye(3) * box * unit.nanometer)
    modeller = app.Modeller(topology, positions * unit.nanometer)
    modeller.addExtraParticles(forcefield)
    cutoff = min(0.8, 0.49 * box)
    system = forcefield.createSystem(modeller.topology, nonbondedMethod=app.PME, nonbondedCutoff=cutoff * unit.nanometer,
                                     constraints=app.HBonds, rigidWater=True)
    for force in system.getForces():
        force.setForceGroup(DRUDE_GROUP if isinstance(force, openmm.DrudeForce) else 0)
    return system, modeller.topology, modeller.positions, box


class Analysis:
    """Index sets and charges of the water system, and the observables of one frame."""

    def __init__(self, system):
        drude = next(f for f in system.getForces() if isinstance(f, openmm.DrudeForce))
        nonbonded = next(f for f in system.getForces() if isinstance(f, openmm.NonbondedForce))
        n = system.getNumParticles()
        self.masses = np.array([system.getParticleMass(i).value_in_unit(unit.dalton) for i in range(n)])
        self.charges = np.array([nonbonded.getParticleParameters(i)[0].value_in_unit(unit.elementary_charge)
                                 for i in range(n)])
        pairs = [drude.getParticleParameters(i)[:2] for i in range(drude.getNumParticles())]
        self.drudes = np.array([p[0] for p in pairs])
        self.cores = np.array([p[1] for p in pairs])
        self.molecules = len(self.cores)
        # Each molecule's particles (O, H, H, M, D in swm4ndp.xml order) as the consecutive block of its oxygen.
        per = n // self.molecules
        self.blocks = np.arange(n).reshape(self.molecules, per)
        self.hydrogens = np.array([i for i in range(n) if self.masses[i] > 0 and i not in set(self.cores)
                                   and i not in set(self.drudes)])
        # Degrees of freedom of the centre-of-mass motion: 3 per pair and per hydrogen, less the constraints and the
        # removed total momentum; 3 per Drude pair for the relative motion.
        self.com_dof = 3 * (len(self.cores) + len(self.hydrogens)) - system.getNumConstraints() - 3
        self.drude_dof = 3 * len(self.drudes)

    def temperatures(self, v):
        m = self.masses
        mc, md = m[self.cores][:, None], m[self.drudes][:, None]
        vc, vd = v[self.cores], v[self.drudes]
        com = (mc * vc + md * vd) / (mc + md)
        rel = vd - vc
        mu = mc * md / (mc + md)
        ke_com = 0.5 * np.sum((mc + md) * com**2) + 0.5 * np.sum(m[self.hydrogens][:, None] * v[self.hydrogens]**2)
        ke_rel = 0.5 * np.sum(mu * rel**2)
        return 2 * ke_com / (self.com_dof * BOLTZ), 2 * ke_rel / (self.drude_dof * BOLTZ)

    def molecular_dipole(self, x, box):
        """Mean |dipole| per molecule in debye (positions unwrapped about each oxygen)."""
        dipoles = []
        for block in self.blocks:
            r = x[block] - x[block[0]]
            r -= box * np.round(r / box)
            dipoles.append(np.linalg.norm(self.charges[block] @ r))
        return float(np.mean(dipoles)) * E_NM_TO_DEBYE

    def drude_displacements(self, x, box):
        d = x[self.drudes] - x[self.cores]
        return d - box * np.round(d / box)

    def oo_histogram(self, x, box, edges):
        o = x[self.cores]
        d = o[:, None, :] - o[None, :, :]
        d -= box * np.round(d / box)
        r = np.sqrt(np.sum(d**2, axis=-1))[np.triu_indices(len(o), 1)]
        return np.histogram(r, bins=edges)[0]


class SelfConsistent:
    """Drude positions that minimize the energy with every other particle held (massless) where it is."""

    def __init__(self, system, analysis):
        fixed = openmm.XmlSerializer.deserialize(openmm.XmlSerializer.serialize(system))
        for i in range(fixed.getNumParticles()):
            if i not in set(analysis.drudes):
                fixed.setParticleMass(i, 0.0)
        for c in reversed(range(fixed.getNumConstraints())):
            fixed.removeConstraint(c)
        self.context = openmm.Context(fixed, openmm.VerletIntegrator(0.001), openmm.Platform.getPlatformByName("CPU"),
                                      {"Threads": "2"})

    def drude_positions(self, positions, box_vectors):
        self.context.setPeriodicBoxVectors(*box_vectors)
        self.context.setPositions(positions)
        openmm.LocalEnergyMinimizer.minimize(self.context, 1e-3, 2000)
        return self.context.getState(getPositions=True).getPositions(asNumpy=True).value_in_unit(unit.nanometer)


WALL_NM = 0.02  # DrudeLangevinIntegrator.setMaxDrudeDistance of the "DrudeLangevinWall" peers (the hard wall)
# setMaxWarpedPhase of the "WarpedMiddleLimited" peers: the phase per step that Warped has at 2.5 fs (--max-warped-phase).
MAX_WARPED_PHASE = 2.05
# The Drude (stiff-mode) bath's friction, 1/ps, of every peer (--drude-friction): Lamoureux and Roux's 20/ps.
DRUDE_FRICTION_PER_PS = 20.0


def sim_kind(kind):
    """A SIM peer's kind split into its splitting and options: "WarpedMiddleLimitedScaled" -> ("Warped", middle,
    limited, scaled); the suffixes are ...Middle (setThermostatPlacement(Middle)), ...Limited (setMaxWarpedPhase) and
    ...Scaled (setWarpedFrictionScaling), in that order."""
    flags = []
    for suffix in ("Scaled", "Limited", "Middle"):
        flags.append(kind.endswith(suffix))
        kind = kind[:-len(suffix)] if flags[-1] else kind
    scaled, limited, middle = flags
    return kind, middle, limited, scaled


def make_integrator(kind, step_fs, seed, drude_friction_scale=1.0, drude_kelvin=1.0):
    """A peer's integrator; drude_friction_scale multiplies the Drude friction (DrudeLangevin's, the SIM's stiff-mode
    one), drude_kelvin is the Drude bath's temperature (DrudeLangevin's drudeTemperature, the SIM's stiff-mode one)."""
    if kind in ("DrudeLangevin", "DrudeLangevinWall", "DrudeLangevinHeavy", "DrudeLangevinLeastHeavy"):
        integrator = openmm.DrudeLangevinIntegrator(300 * unit.kelvin, 5 / unit.picosecond, drude_kelvin * unit.kelvin,
                                                    drude_friction_scale * DRUDE_FRICTION_PER_PS / unit.picosecond,
                                                    step_fs * unit.femtosecond)
        if kind == "DrudeLangevinWall":
            # The hard wall: a Drude particle farther than WALL_NM from its core is reflected (OpenMM raises an
            # exception when one is found far beyond it).
            integrator.setMaxDrudeDistance(WALL_NM * unit.nanometer)
        integrator.setRandomNumberSeed(seed)
        return integrator
    integrator = StochasticImpulseIntegrator(300 * unit.kelvin, 5 / unit.picosecond, step_fs * unit.femtosecond,
                                             {DRUDE_GROUP})
    # "WarpedMiddle", "FilteredMiddle": the splitting with the zero modes' thermostat placed as LangevinMiddle's;
    # "WarpedMiddleLimited": WarpedMiddle with its phase per step limited (setMaxWarpedPhase); "...Scaled": with the
    # stiff modes' friction scaled to their inertia (setWarpedFrictionScaling).
    splitting, middle, limited, scaled = sim_kind(kind)
    integrator.setSplitting(getattr(StochasticImpulseIntegrator, splitting))
    if middle:
        integrator.setThermostatPlacement(StochasticImpulseIntegrator.Middle)
    # Unlimited: Warped's own step (the limit off), as this scene measured it, not the limit the integrator would choose.
    if splitting == "Warped":
        integrator.setMaxWarpedPhase(MAX_WARPED_PHASE if limited else math.pi)
    if scaled:
        integrator.setWarpedFrictionScaling(True)
    integrator.setStiffModeTemperature(drude_kelvin * unit.kelvin)
    integrator.setStiffModeFriction(drude_friction_scale * DRUDE_FRICTION_PER_PS / unit.picosecond)
    integrator.setRandomNumberSeed(seed)
    return integrator


# ONE_4PI_EPS0 in kJ nm/mol/e^2, as OpenMM has it: a Drude spring's constant is ONE_4PI_EPS0 q^2/alpha.
ONE_4PI_EPS0 = 138.935457644382
# The step of the heavier-Drude peers (fs): DrudeLangevin on heavier Drude particles.
HEAVY_DRUDE_STEP_FS = 0.5


def response_frequency(step_fs, phase):
    """omega_d = 2 sin(phase/2)/H (1/ps): a step that flows a Drude mode by `phase` and keeps its exact mean makes it
    follow a field as a spring of this frequency would (docs/sim_drude.md section 6).  Its largest value, 2/H at the
    phase pi, bounds every step that samples the field once (section 8)."""
    return 2 * math.sin(0.5 * phase) / (step_fs * 1e-3)


def drude_spring(drude, index):
    """The spring constant k (kJ/mol/nm^2) of the DrudeForce's pair `index`: ONE_4PI_EPS0 q^2 / alpha."""
    charge, alpha = drude.getParticleParameters(index)[5:7]
    return ONE_4PI_EPS0 * charge.value_in_unit(unit.elementary_charge)**2 / alpha.value_in_unit(unit.nanometer**3)


def heavy_drude_system(system, omega_d):
    """The System with each Drude particle as heavy as a step whose response frequency is omega_d makes it act: its
    pair's relative motion gets the reduced mass k/omega_d^2, the pair's total mass kept.  Returns the copy, the
    Drude mass (amu) and the ratio of the true reduced mass to the new one (the same for every pair of one k/mu)."""
    heavy = openmm.XmlSerializer.deserialize(openmm.XmlSerializer.serialize(system))
    drude = next(f for f in heavy.getForces() if isinstance(f, openmm.DrudeForce))
    masses, ratios = set(), set()
    for i in range(drude.getNumParticles()):
        particle, core = drude.getParticleParameters(i)[:2]
        k = drude_spring(drude, i)
        pair = [heavy.getParticleMass(p).value_in_unit(unit.dalton) for p in (particle, core)]
        total = sum(pair)
        reduced = k / omega_d**2
        if 4 * reduced >= total:
            raise ValueError(f"no Drude mass gives the reduced mass {reduced:.3g} amu of a {total:.3g}-amu pair")
        mass = 0.5 * (total - math.sqrt(total * total - 4 * total * reduced))
        heavy.setParticleMass(particle, mass)
        heavy.setParticleMass(core, total - mass)
        masses.add(round(mass, 6))
        ratios.add(round(pair[0] * pair[1] / total / reduced, 9))
    return heavy, max(masses), max(ratios)


def heavy_peer(system, kind, step_fs):
    """(System, Drude mass, Drude friction scale) of a heavier-Drude peer standing at the SIM step step_fs:
    DrudeLangevinHeavy as heavy as the phase-limited SIM there (friction per unit mass kept); DrudeLangevinLeastHeavy
    as heavy as any step that samples the field once must make it at least (omega_d = 2/H), its friction scaled as
    setWarpedFrictionScaling scales the SIM's, so that the friction force for a given velocity is the true one."""
    if kind == "DrudeLangevinHeavy":
        heavy, mass, _ = heavy_drude_system(system, response_frequency(step_fs, MAX_WARPED_PHASE))
        return heavy, mass, 1.0
    heavy, mass, ratio = heavy_drude_system(system, response_frequency(step_fs, math.pi))
    if ratio >= 1:
        raise ValueError(f"at {step_fs:g} fs a step that samples the field once can keep the Drude's own mass "
                         "(2/H is above its frequency)")
    return heavy, mass, ratio


def equilibrated_state(system, positions, step_fs, steps, seed, threads=2):
    """Minimized positions and `steps` DrudeLangevin steps of step_fs from velocities at 300 K (integrator seed `seed`,
    velocity seed `seed` + 1), on the CPU platform: the state with positions and velocities."""
    integrator = make_integrator("DrudeLangevin", step_fs, seed)
    context = openmm.Context(system, integrator, openmm.Platform.getPlatformByName("CPU"), {"Threads": str(threads)})
    context.setPositions(positions)
    openmm.LocalEnergyMinimizer.minimize(context, 10, 500)
    context.setVelocitiesToTemperature(300 * unit.kelvin, seed + 1)
    integrator.step(steps)
    return context.getState(getPositions=True, getVelocities=True)


def run_one(system, state, analysis, scf, kind, step_fs, settings, edges, seed, counter=None, drude_friction_scale=1.0):
    """One peer from the common state: burn-in, then the production's observables.  counter["steps"] counts the steps
    done (the burn-in one at a time), so that a run that raises can say at which step it failed."""
    counter = {} if counter is None else counter
    counter["steps"], counter["interval"] = 0, 1
    integrator = make_integrator(kind, step_fs, seed, drude_friction_scale)
    context = openmm.Context(system, integrator, openmm.Platform.getPlatformByName("CPU"), {"Threads": "2"})
    context.setState(state)
    burn = int(round(settings["burn_ps"] * 1000 / step_fs))
    for _ in range(burn):
        integrator.step(1)
        counter["steps"] += 1
    samples = settings["samples"]
    stride = max(1, int(round(settings["production_ps"] * 1000 / step_fs / samples)))
    series = {"pe_per_molecule": [], "dipole": [], "t_com": [], "t_drude": [], "induced_ratio": []}
    histograms = []
    scf_every = max(1, samples // settings["scf_frames"])
    production = ProductionFrames(context, integrator, samples * stride, samples)
    counter["interval"] = production.interval
    for s, frame in enumerate(production):
        counter["steps"] = burn + production.steps_done
        x, st = frame.positions, frame.state
        box = st.getPeriodicBoxVectors(asNumpy=True).value_in_unit(unit.nanometer)[0][0]
        series["pe_per_molecule"].append(frame.potential_energy / analysis.molecules)
        series["dipole"].append(analysis.molecular_dipole(x, box))
        t_com, t_drude = analysis.temperatures(frame.velocities)
        series["t_com"].append(t_com)
        series["t_drude"].append(t_drude)
        histograms.append(analysis.oo_histogram(x, box, edges))
        if s % scf_every == 0:
            d = analysis.drude_displacements(x, box)
            d_scf = analysis.drude_displacements(scf.drude_positions(st.getPositions(), st.getPeriodicBoxVectors()),
                                                 box)
            series["induced_ratio"].append(float(np.sum(d * d_scf) / np.sum(d_scf * d_scf)))
    steps = production.steps_done
    ns_per_day = production.ns_per_day(step_fs)
    blocks = settings["blocks"]
    result = {"integrator": kind, "step_fs": step_fs, "steps": steps, "ns_per_day": ns_per_day}
    for name, values in series.items():
        result[name] = block_error(values, blocks if name != "induced_ratio" else min(blocks, len(values)))
    shell = 4 / 3 * math.pi * (edges[1:]**3 - edges[:-1]**3)
    density = analysis.molecules / box**3
    g = np.array(histograms) / (0.5 * analysis.molecules * density * shell)
    usable = len(g) // blocks * blocks
    block_g = g[:usable].reshape(blocks, -1, len(shell)).mean(axis=1)
    result["g_oo"] = block_g.mean(axis=0).tolist()
    result["g_oo_error"] = (block_g.std(axis=0, ddof=1) / math.sqrt(blocks)).tolist()
    result["g_oo_peak"] = block_error(block_g.max(axis=1), blocks)
    return result


OBSERVABLES = [("induced_ratio", "induced dipole / self-consistent"), ("dipole", "mean molecular dipole (D)"),
               ("pe_per_molecule", "potential energy per molecule (kJ/mol)"), ("g_oo_peak", "first peak of g_OO"),
               ("t_com", "centre-of-mass temperature (K)"), ("t_drude", "Drude temperature (K)")]


def blew_up(run, reference):
    """A run that completed but whose water heated or fell apart: its centre-of-mass temperature more than 20 % from
    the reference's, or its induced dipoles off by more than half."""
    values = [run[key][0] for key, _ in OBSERVABLES]
    return (not all(math.isfinite(v) for v in values) or abs(run["t_com"][0] / reference["t_com"][0] - 1) > 0.2
            or abs(run["induced_ratio"][0] - reference["induced_ratio"][0]) > 0.5)


# How the tables print each observable's value ± error.
OBSERVABLE_FORMATS = {"induced_ratio": "%.4f ± %.4f", "dipole": "%.3f ± %.3f", "pe_per_molecule": "%.2f ± %.2f",
                      "g_oo_peak": "%.3f ± %.3f", "t_com": "%.1f ± %.1f", "t_drude": "%.3f ± %.3f"}

SHORT_NAMES = {"induced_ratio": "induced/SCF", "dipole": "dipole", "pe_per_molecule": "PE", "g_oo_peak": "g_OO peak",
               "t_com": "T_COM", "t_drude": "T_Drude"}


def verdict(runs, reference_label):
    """The title's verdict: the fastest SIM run within 2 s.e. of the reference on every observable (the JSON's
    within_error_of_reference), or else the SIM run off in the fewest observables, which it names (and whether
    DrudeLangevin at its smallest further step is off in them too)."""
    def misses(run):
        return [key for key, _ in OBSERVABLES if not run.get("within_error_of_reference", {}).get(key, False)]

    sims = [r for r in runs.values() if not r["integrator"].startswith("DrudeLangevin")
            and r.get("within_error_of_reference")]
    baseline = runs.get("DrudeLangevin_1fs")

    def speed(run):
        return (f" ({run['ns_per_day'] / baseline['ns_per_day']:.2f}× the speed of DrudeLangevin H = 1 fs)"
                if baseline else "")

    good = [r for r in sims if not misses(r)]
    if good:
        best = max(good, key=lambda r: r["ns_per_day"])
        return (f"SIM {best['integrator']} H = {best['step_fs']:g} fs is within 2 s.e. of the reference on every "
                f"observable{speed(best)}")
    if not sims:
        return "no SIM run completed"
    closest = min(sims, key=lambda r: (len(misses(r)), -r["ns_per_day"]))
    off = misses(closest)
    text = (f"no SIM run is within 2 s.e. of the reference on every observable; closest: {closest['integrator']} "
            f"H = {closest['step_fs']:g} fs{speed(closest)}, off only in " + ", ".join(SHORT_NAMES[k] for k in off))
    peers = sorted((r for label, r in runs.items() if r["integrator"] == "DrudeLangevin" and label != reference_label
                    and r.get("within_error_of_reference")), key=lambda r: r["step_fs"])
    if peers and set(off) <= set(misses(peers[0])):
        text += f", as is DrudeLangevin H = {peers[0]['step_fs']:g} fs"
    return text


def seed_summary(paths, out):
    """Pools scene runs of several seeds (their drude_water.json): per peer and observable the mean over the seeds ±
    its standard error over the seeds, and t, the difference from the reference's mean in their combined standard
    errors.  Writes seed_summary.json and seed_summary.png (each observable against H, the reference as a band of
    ± 2 s.e.) to out and prints the Markdown table."""
    loaded = []
    for path in paths:
        with open(path) as f:
            loaded.append(json.load(f))
    reference_label = loaded[0]["reference"]
    labels = list(dict.fromkeys(label for data in loaded for label in data["runs"]))

    def completed(label):
        return [d["runs"][label] for d in loaded if label in d["runs"] and "failed" not in d["runs"][label]]

    def pooled(label, key):
        values = np.array([run[key][0] for run in completed(label)])
        mean, error = mean_se(values)
        return float(mean), float(error), len(values)

    summary = {"files": [os.path.relpath(p) for p in paths], "reference": reference_label,
               "max_warped_phase": loaded[0]["parameters"].get("max_warped_phase"), "runs": {}}
    for label in labels:
        runs = [d["runs"][label] for d in loaded if label in d["runs"]]
        # DrudeLangevinHeavy peers stand at the SIM step whose Drude mass they have.
        entry = {"integrator": runs[0]["integrator"], "step_fs": runs[0].get("emulates_fs", runs[0]["step_fs"]),
                 "failed": sum(1 for r in runs if "failed" in r), "of": len(runs)}
        if "drude_mass_amu" in runs[0]:
            entry["drude_mass_amu"] = runs[0]["drude_mass_amu"]
        if completed(label):
            ratios = [d["runs"][label]["ns_per_day"] / d["runs"]["DrudeLangevin_1fs"]["ns_per_day"] for d in loaded
                      if label in d["runs"] and "failed" not in d["runs"][label] and "DrudeLangevin_1fs" in d["runs"]]
            entry["ns_per_day_over_DrudeLangevin_1fs"] = float(np.mean(ratios)) if ratios else None
            for key, _ in OBSERVABLES:
                mean, error, n = pooled(label, key)
                entry[key] = [mean, error, n]
                if label != reference_label:
                    ref_mean, ref_error, _ = pooled(reference_label, key)
                    entry[key + "_t"] = (mean - ref_mean) / math.hypot(error, ref_error)
        summary["runs"][label] = entry
    with open(os.path.join(out, "seed_summary.json"), "w") as f:
        json.dump(summary, f, indent=1)
    lines = ["| integrator | H (fs) | × DL 1 fs (sequential) | " + " | ".join(SHORT_NAMES[k] for k, _ in OBSERVABLES) +
             " |", "|---" * (3 + len(OBSERVABLES)) + "|"]
    for label, entry in summary["runs"].items():
        if entry["failed"] == entry["of"]:
            lines.append(f"| {kind_label(entry['integrator'])} | {entry['step_fs']:g} | failed in every run |" +
                         " |" * len(OBSERVABLES))
            continue
        cells = [OBSERVABLE_FORMATS[k] % tuple(entry[k][:2]) + (f" ({entry[k + '_t']:+.1f})" if k + "_t" in entry else "")
                 for k, _ in OBSERVABLES]
        speed = entry.get("ns_per_day_over_DrudeLangevin_1fs")
        heavy = ""
        if "drude_mass_amu" in entry:
            stands_for = ("friction scaled, the lightest for" if entry["integrator"] == "DrudeLangevinLeastHeavy"
                          else "as the SIM at")
            heavy = f", m_D = {entry['drude_mass_amu']:.2f} amu, {stands_for}"
        lines.append(f"| {kind_label(entry['integrator'])}{heavy} | {entry['step_fs']:g} | " +
                     (f"{speed:.2f}" if speed else "—") + " | " + " | ".join(cells) + " |")
    print("\n".join(lines))
    counts = sorted({e["t_com"][2] for e in summary["runs"].values() if "t_com" in e})
    seeds = f"{counts[0]}" if len(counts) == 1 else f"{counts[0]}–{counts[-1]}"
    waters = {water_description(d["parameters"]) for d in loaded}
    if len(waters) != 1:
        raise ValueError(f"--seed-summary: the runs are of different boxes: {sorted(waters)}")
    plot_seed_summary(summary, seeds, waters.pop(), os.path.join(out, "seed_summary.png"))


def plot_seed_summary(summary, seeds, water, path):
    """Each observable against H: the reference as a band of ± 2 s.e., every other peer as its seed means ± s.e."""
    plt = reporting.pyplot()
    fig, axes = plt.subplots(2, 3, figsize=(14, 7.5))
    reference_label = summary["reference"]
    reference = summary["runs"][reference_label]
    others = {label: e for label, e in summary["runs"].items() if label != reference_label and "t_com" in e}
    kinds = list(dict.fromkeys(e["integrator"] for e in others.values()))
    styles = {"DrudeLangevin": ("s", "black"), "DrudeLangevinWall": ("D", "tab:purple"),
              "DrudeLangevinHeavy": ("^", "tab:brown"), "DrudeLangevinLeastHeavy": ("<", "tab:gray"),
              "WarpedMiddleScaled": ("v", "tab:orange"),
              "WarpedMiddleLimitedScaled": ("v", "tab:orange")}
    for ax, (key, name) in zip(axes.flat, OBSERVABLES):
        mean, error = reference[key][:2]
        ax.axhspan(mean - 2 * error, mean + 2 * error, color="0.85",
                   label=f"DrudeLangevin H = {reference['step_fs']:g} fs (reference), mean ± 2 s.e.")
        for kind in kinds:
            if key == "t_drude" and kind in HEAVY_DESCRIPTIONS:
                continue  # the kinetic temperature of heavier particles, not comparable
            points = sorted((e["step_fs"], e[key][0], e[key][1]) for e in others.values() if e["integrator"] == kind)
            h, y, err = zip(*points)
            marker, color = styles.get(kind, ("o", "tab:cyan"))
            label = ("SIM " + kind_description(kind, summary["max_warped_phase"]) if kind.startswith("Warped")
                     else "DrudeLangevin at H" if kind == "DrudeLangevin"
                     else kind_label(kind) + HEAVY_DESCRIPTIONS.get(kind, "")) + ", mean ± s.e."
            ax.errorbar(h, y, yerr=err, fmt=marker + "-", capsize=3, color=color, label=label)
        ax.set_xlabel("step H (fs)")
        ax.set_ylabel(name)
        if key == "t_drude" and any(kind in HEAVY_DESCRIPTIONS for kind in kinds):
            ax.set_title("heavier-Drude peers left out (not comparable)", fontsize=9)
        ax.ticklabel_format(axis="y", useOffset=False)
    handles, names = axes.flat[0].get_legend_handles_labels()
    fig.legend(handles, names, loc="lower center", ncol=2, fontsize=9, frameon=False)
    fig.suptitle(textwrap.fill(f"SWM4-NDP water ({water}, PME, rigid, 300 K): the SIM and DrudeLangevin "
                               f"peers (legend) against DrudeLangevin H = {reference['step_fs']:g} fs, each observable "
                               f"against the step H; mean ± s.e. over {seeds} seeds per peer", 130), fontsize=11)
    failed = [f"{kind_label(e['integrator'])} H = {e['step_fs']:g} fs" for e in summary["runs"].values()
              if e["failed"] == e["of"]]
    if failed:
        # Above the legend, which takes the figure's bottom.
        fig.text(0.5, 0.085, "failed in every run (not drawn): " + ", ".join(failed), color="tab:red", fontsize=9,
                 ha="center")
    fig.tight_layout(rect=(0, 0.11 if failed else 0.09, 1, 0.95))
    fig.savefig(path, dpi=110)
    plt.close(fig)


def kind_description(kind, max_phase):
    """A SIM peer's kind in words: its splitting, placement, phase limit and friction scaling."""
    splitting, middle, limited, scaled = sim_kind(kind)
    return (splitting + (" with the Middle placement" if middle else "") + (f", ω̃H ≤ {max_phase:g}" if limited else "") +
            (", friction scaled" if scaled else ""))


# What the heavier-Drude peers' masses stand for, as the seed summary's chart says it.
HEAVY_DESCRIPTIONS = {"DrudeLangevinHeavy": ", Drude mass as the SIM's at H",
                      "DrudeLangevinLeastHeavy": ", friction scaled: the lightest Drude any once-per-step "
                                                 "field sampling at H allows"}


def kind_label(kind):
    """A peer's kind as the charts name it."""
    labels = {"DrudeLangevinWall": "DrudeLangevin + wall",
              "DrudeLangevinHeavy": "DrudeLangevin %g fs, heavier Drudes" % HEAVY_DRUDE_STEP_FS,
              "DrudeLangevinLeastHeavy": "DrudeLangevin %g fs, Drudes of ω_d = 2/H" % HEAVY_DRUDE_STEP_FS}
    return labels.get(kind, kind)


def plot(data, path):
    runs = data["runs"]
    reference = runs[data["reference"]]
    labels = list(runs)
    blown = {lb for lb in labels if blew_up(runs[lb], reference)}
    ticks = [f"{kind_label(runs[lb]['integrator'])}\nH = {runs[lb]['step_fs']:g} fs" +
             (f"\nm_D = {runs[lb]['drude_mass_amu']:.2f} amu" if "drude_mass_amu" in runs[lb] else "") +
             ("\n(blew up)" if lb in blown else "") for lb in labels]
    colors = {"DrudeLangevin": "black", "DrudeLangevinWall": "tab:purple", "Strang": "tab:blue", "Filtered": "tab:red",
              "Warped": "tab:green", "FilteredMiddle": "tab:pink", "WarpedMiddle": "tab:olive",
              "WarpedMiddleLimited": "tab:cyan", "DrudeLangevinHeavy": "tab:brown", "WarpedMiddleScaled": "tab:orange",
              "DrudeLangevinLeastHeavy": "tab:gray",
              "WarpedMiddleLimitedScaled": "tab:orange"}
    plt = reporting.pyplot()
    fig, axes = plt.subplots(2, 4, figsize=(18, 8.5))
    for ax, (key, title) in zip(axes.flat, OBSERVABLES):
        band = ax.axhspan(reference[key][0] - reference[key][1], reference[key][0] + reference[key][1], color="0.85",
                          label="reference ±1 s.e. (DrudeLangevin, H = %g fs)" % reference["step_fs"])
        for index, label in enumerate(labels):
            if label not in blown:
                run = runs[label]
                ax.errorbar(index, run[key][0], yerr=run[key][1], fmt="o", color=colors[run["integrator"]])
        # Runs that blew up set no scale: a marker at the top edge with their value.
        low, high = ax.get_ylim()
        for index, label in enumerate(labels):
            if label in blown:
                value = runs[label][key][0]
                inside = low <= value <= high
                ax.plot(index, value if inside else (high if value > high else low), "x" if inside else
                        ("^" if value > high else "v"), color=colors[runs[label]["integrator"]], ms=8, clip_on=False)
                if not inside:
                    ax.annotate(f"{value:.3g}", (index, high if value > high else low), textcoords="offset points",
                                xytext=(4, -10 if value > high else 4), fontsize=7, color="tab:red")
        ax.set_ylim(low, high)
        ax.set_xticks(range(len(labels)))
        ax.set_xticklabels(ticks, rotation=90, fontsize=9)
        ax.set_ylabel(title)
        ax.ticklabel_format(axis="y", useOffset=False)  # ratios near 1 read as themselves, not as +1
    ax = axes.flat[6]
    for index, label in enumerate(labels):
        run = runs[label]
        if label in blown:  # hollow: a speed that bought nothing
            ax.bar(index, run["ns_per_day"], facecolor="none", edgecolor=colors[run["integrator"]], hatch="//")
        else:
            ax.bar(index, run["ns_per_day"], color=colors[run["integrator"]])
    kept = [runs[lb]["ns_per_day"] for lb in labels if lb not in blown]
    if kept:
        ax.set_ylim(0, 1.15 * max(kept))
    ax.set_xticks(range(len(labels)))
    ax.set_xticklabels(ticks, rotation=90, fontsize=9)
    ax.set_ylabel("speed (ns/day, CPU platform, 2 threads)")
    ax = axes.flat[7]
    r = np.array(data["g_oo_r_nm"])
    styles = {}  # runs of one integrator told apart by line style
    for label in labels:
        run = runs[label]
        if label not in blown:
            style = ("-", "--", ":", "-.")[styles.setdefault(run["integrator"], 0) % 4]
            styles[run["integrator"]] += 1
            ax.plot(r, run["g_oo"], color=colors[run["integrator"]], ls=style, lw=1.0, alpha=0.8,
                    label=f"{kind_label(run['integrator'])} H = {run['step_fs']:g} fs")
    ax.set_xlabel("r (nm)")
    ax.set_ylabel("g_OO(r)")
    # Below the panel (its neighbours have their tick labels there), so that it hides no curve.
    ax.legend(fontsize=9, ncol=2, loc="upper center", bbox_to_anchor=(0.5, -0.32), frameon=False)
    failed = [f"{kind_label(r['integrator'])} H = {r['step_fs']:g} fs (" +
              (f"fails at step {r['failed_at_step']}" if r.get("failed_at_step") == r.get("failed_by_step") else
               f"fails in steps {r['failed_at_step']}–{r['failed_by_step']}" if "failed_at_step" in r else "NaN") +
              (": Drude beyond the wall" if "hard wall" in r["failed"] else "") + ")"
              for r in data.get("failed_runs", [])]
    failed += [f"{runs[lb]['integrator']} H = {runs[lb]['step_fs']:g} fs (blew up: ▲▼ × hollow bar)"
               for lb in labels if lb in blown]
    # The failed runs below the panels (a box in a panel would hide part of a curve), with the reference band's
    # legend, so that neither hides a point.
    if failed:
        fig.text(0.01, 0.004, textwrap.fill("failed (not drawn) or blew up (drawn as marked): " + "; ".join(failed),
                                            120), fontsize=9, color="tab:red", va="bottom")
    fig.legend(handles=[band], loc="lower right", fontsize=9, frameon=False)
    kind_names = {kind: kind_description(kind, data["parameters"].get("max_warped_phase", 0))
                  for kind in ("Strang", "Filtered", "Warped", "FilteredMiddle", "WarpedMiddle", "WarpedMiddleLimited",
                               "WarpedMiddleScaled", "WarpedMiddleLimitedScaled")}
    shown = [k for k in kind_names if any(runs[lb]["integrator"] == k for lb in labels)]
    what = (f"SWM4-NDP water ({water_description(data['parameters'])}, PME, rigid, 300 K): "
            "StochasticImpulseIntegrator (" + ", ".join(f"{kind_names[k]} {colors[k][4:]}" for k in shown) +
            ") against DrudeLangevinIntegrator (black; with the hard wall setMaxDrudeDistance(%g nm): purple), "
            "reference DrudeLangevin H = %g fs" % (WALL_NM, reference["step_fs"]))
    def fill(text):
        # A step ("H = 1 fs") stays on one line: textwrap breaks only at ASCII whitespace.
        return textwrap.fill(re.sub(r"H = ([0-9.]+) fs", "H\u00a0=\u00a0\\1\u00a0fs", text), 190)

    fig.suptitle(fill(what) + "\n" + fill(verdict(runs, data["reference"])) +
                 "\nDrude modes at 1 K, 20/ps; error bars ±1 s.e. of block means", fontsize=11)
    fig.tight_layout(rect=(0, 0.05, 1, 0.92))
    reporting.save_figure(fig, path, 110)


def constraint_cost(out, molecules=64, step_fs=0.005):
    """The SIM's constrained flow of rigid Drude water against the exact one.

    SIM applies a constrained core's constraint impulses around the pair's exact flow, which carries them to the Drude
    particle (docs/sim_drude.md section 2); the exact dynamics constrain the core alone, with its own mass.  Both run
    without friction from the same equilibrated state (no cutoff, rigid water) at H = 0.005 fs (omega H = 0.005,
    splitting error negligible): OpenMM's VerletIntegrator for the exact flow (SETTLE with the true masses, the Drude
    particle free), StochasticImpulseIntegrator (Strang, friction 0) for the SIM's.  Reported after t = 5, 10, 20 fs:
    the RMS difference of the Drude displacement vectors relative to their RMS size and the RMS difference of the atom
    positions; and each run's total-energy drift per molecule.  Writes constraint_cost.json.
    """
    system, topology, positions, box = build_water(molecules)
    for force in system.getForces():
        if isinstance(force, openmm.NonbondedForce):
            force.setNonbondedMethod(openmm.NonbondedForce.CutoffPeriodic)
            force.setCutoffDistance(0.49 * box)
    analysis = Analysis(system)
    state = equilibrated_state(system, positions, 0.5, 400, 3)
    exact = openmm.VerletIntegrator(step_fs * unit.femtosecond)
    sim = StochasticImpulseIntegrator(0.0, 0.0, step_fs * unit.femtosecond, {DRUDE_GROUP})
    for integrator in (exact, sim):
        integrator.setConstraintTolerance(1e-10)
    contexts = [openmm.Context(system, integrator, openmm.Platform.getPlatformByName("CPU"), {"Threads": "2"})
                for integrator in (exact, sim)]
    energies = []
    for context in contexts:
        context.setState(state)
        s = context.getState(getEnergy=True)
        energies.append([(s.getPotentialEnergy() + s.getKineticEnergy()).value_in_unit(unit.kilojoule_per_mole)])
    report = {"molecules": molecules, "step_fs": step_fs, "times_fs": [], "drude_displacement_relative_rms": [],
              "atom_position_rms_nm": []}
    done = 0
    for t_fs in (5, 10, 20):
        steps = int(round(t_fs / step_fs)) - done
        done += steps
        frames = []
        for context, energy in zip(contexts, energies):
            context.getIntegrator().step(steps)
            s = context.getState(getPositions=True, getEnergy=True, enforcePeriodicBox=False)
            energy.append((s.getPotentialEnergy() + s.getKineticEnergy()).value_in_unit(unit.kilojoule_per_mole))
            frames.append(s.getPositions(asNumpy=True).value_in_unit(unit.nanometer))
        d = [analysis.drude_displacements(x, box) for x in frames]
        atoms = np.array([i for i in range(len(analysis.masses)) if analysis.masses[i] > 0
                          and i not in set(analysis.drudes)])
        report["times_fs"].append(t_fs)
        report["drude_displacement_relative_rms"].append(float(np.sqrt(np.mean((d[1] - d[0])**2) / np.mean(d[0]**2))))
        report["atom_position_rms_nm"].append(float(np.sqrt(np.mean((frames[1][atoms] - frames[0][atoms])**2))))
    report["energy_drift_per_molecule_kJ_per_mol"] = {
        "exact (VerletIntegrator)": (energies[0][-1] - energies[0][0]) / molecules,
        "SIM Strang": (energies[1][-1] - energies[1][0]) / molecules}
    with open(os.path.join(out, "constraint_cost.json"), "w") as f:
        json.dump(report, f, indent=1)
    print(json.dumps(report, indent=1))


def filter_bias(out):
    """The filter's effect, measured: (1) the converged mean displacement of one stiff mode (a tethered particle of mass
    0.39, omega = xi/H with H = 2 fs, friction 20/ps, temperature 0) under a constant force, relative to f/omega^2,
    for Strang, Filtered and Warped against (xi/2) cot(xi/2); (2) the largest total-energy error of the 6-particle FPU
    chain (omega = 50, stiff springs (0,1), (2,3), (4,5), soft r^4 between them and x^4 walls, no friction, 20 ps) for
    the three splittings against xi; (3) the largest relative stiffness r of a soft force along the mode that each
    splitting keeps stable, against xi (the mutual polarization of neighbouring Drude particles is such a force, with
    r between -0.27 and 0.34 in SWM4-NDP water: drude_coupling.py).  Writes filter_bias.json."""
    reference = openmm.Platform.getPlatformByName("Reference")

    def mean_displacement(splitting, xi, gamma=20.0, h=0.002, force=10.0):
        omega = xi / h
        mass = 0.39
        k = mass * omega**2
        system = openmm.System()
        system.addParticle(mass)
        tether = openmm.CustomExternalForce("0.5*k*x^2")
        tether.addGlobalParameter("k", k)
        tether.addParticle(0)
        tether.setForceGroup(DRUDE_GROUP)
        push = openmm.CustomExternalForce("-f*x")
        push.addGlobalParameter("f", force)
        push.addParticle(0)
        system.addForce(tether)
        system.addForce(push)
        integrator = StochasticImpulseIntegrator(0.0, gamma, h, {DRUDE_GROUP})
        integrator.setSplitting(splitting)
        context = openmm.Context(system, integrator, reference)
        context.setPositions([openmm.Vec3(0, 0, 0)])
        integrator.step(int(60 / (gamma * h)) + 1)
        x = context.getState(getPositions=True).getPositions(asNumpy=True).value_in_unit(unit.nanometer)[0][0]
        return x / (force / k)

    def fpu_energy_error(splitting, xi, omega=50.0, duration=20.0):
        system = openmm.System()
        for _ in range(6):
            system.addParticle(1.0)
        stiff = openmm.HarmonicBondForce()
        for i, j in [(0, 1), (2, 3), (4, 5)]:
            stiff.addBond(i, j, 0.0, omega**2 / 2)
        stiff.setForceGroup(DRUDE_GROUP)
        soft = openmm.CustomBondForce("r^4")
        for i, j in [(1, 2), (3, 4)]:
            soft.addBond(i, j, [])
        walls = openmm.CustomExternalForce("x^4")
        for i in (0, 5):
            walls.addParticle(i, [])
        for force in (stiff, soft, walls):
            system.addForce(force)
        h = xi / omega
        integrator = StochasticImpulseIntegrator(0.0, 0.0, h, {DRUDE_GROUP})
        integrator.setSplitting(splitting)
        context = openmm.Context(system, integrator, reference)
        context.setPositions([openmm.Vec3(x, 0, 0) for x in (-0.55, -0.42, -0.12, 0.03, 0.36, 0.51)])
        context.setVelocities([openmm.Vec3(v, 0, 0) for v in (0.3, -0.2, 0.5, -0.4, 0.1, 0.25)])

        def energy():
            state = context.getState(getEnergy=True)
            return (state.getPotentialEnergy() + state.getKineticEnergy()).value_in_unit(unit.kilojoule_per_mole)

        e0, worst = energy(), 0.0
        for _ in range(int(duration / h)):
            integrator.step(1)
            worst = max(worst, abs(energy() - e0))
        return worst

    def stability_threshold(splitting, xi, omega=1000.0):
        """The largest r (to 0.002) for which a tethered particle whose soft force is a spring r k along its stiff
        mode stays within 20 times its start over 300 steps: found by running, bisecting on r."""
        def bounded(r):
            system = openmm.System()
            system.addParticle(1.0)
            tether = openmm.CustomExternalForce("0.5*k*x^2")
            tether.addGlobalParameter("k", omega**2)
            tether.addParticle(0)
            tether.setForceGroup(DRUDE_GROUP)
            soft = openmm.CustomExternalForce("0.5*rk*x^2")
            soft.addGlobalParameter("rk", r * omega**2)
            soft.addParticle(0)
            system.addForce(tether)
            system.addForce(soft)
            integrator = StochasticImpulseIntegrator(0.0, 0.0, xi / omega, {DRUDE_GROUP})
            integrator.setSplitting(splitting)
            context = openmm.Context(system, integrator, reference)
            context.setPositions([openmm.Vec3(1e-3, 0, 0)])
            for _ in range(30):
                integrator.step(10)
                x = context.getState(getPositions=True).getPositions(asNumpy=True).value_in_unit(unit.nanometer)[0][0]
                if not abs(x) < 20e-3:
                    return False
            return True

        low, high = 0.0, 2.0
        if not bounded(low):
            return 0.0
        while high - low > 0.002:
            middle = 0.5 * (low + high)
            low, high = (middle, high) if bounded(middle) else (low, middle)
        return low

    splittings = {"Strang": StochasticImpulseIntegrator.Strang, "Filtered": StochasticImpulseIntegrator.Filtered,
                  "Warped": StochasticImpulseIntegrator.Warped}
    report = {"mean_displacement": [], "fpu_energy_error_kJ_per_mol": [], "stability_threshold_r": []}
    print("| xi = omega H | (xi/2) cot(xi/2) | Strang | Filtered | Warped |")
    for xi in [0.1, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0, 2 * math.pi, 7.0, 8.0, 10.0]:
        row = {"xi": xi, "strang_bias_formula": 0.5 * xi / math.tan(0.5 * xi)}
        row.update({name: mean_displacement(s, xi) for name, s in splittings.items()})
        report["mean_displacement"].append(row)
        print(f"| {xi:.4g} | {row['strang_bias_formula']:.4g} | {row['Strang']:.4g} | {row['Filtered']:.10f} | "
              f"{row['Warped']:.10f} |")
    print("| xi = omega H | Strang | Filtered | Warped |  (largest FPU energy error, kJ/mol)")
    for xi in [1.0, 2.0, 4.5, 5.0, 5.8, 6.0, 6.2, 2 * math.pi, 6.4, 6.6, 7.5, 8.0]:
        row = {"xi": xi}
        row.update({name: fpu_energy_error(s, xi) for name, s in splittings.items()})
        report["fpu_energy_error_kJ_per_mol"].append(row)
        print(f"| {xi:.4g} | {row['Strang']:.3g} | {row['Filtered']:.3g} | {row['Warped']:.3g} |")
    print("| xi = omega H | Strang | Filtered | Warped |  (largest stable r of a soft spring r k along the mode)")
    for xi in [1.0, 1.5, 2.072, 2.331, 2.59, 3.108, 4.0]:
        row = {"xi": xi}
        row.update({name: stability_threshold(s, xi) for name, s in splittings.items()})
        report["stability_threshold_r"].append(row)
        print(f"| {xi:.4g} | {row['Strang']:.3f} | {row['Filtered']:.3f} | {row['Warped']:.3f} |")
    with open(os.path.join(out, "filter_bias.json"), "w") as f:
        json.dump(report, f, indent=1)


def step_end_velocity_variance(omega, h, gamma=5.0):
    """<v^2>/kT at the ends of a step K(h/2) E(h) K(h/2) for a harmonic motion of angular frequency omega, where E is
    the exact free flow with friction gamma and its noise (a zero mode of the SIM): the stationary covariance of the
    step's linear map, iterated to its fixed point."""
    e = math.exp(-gamma * h)
    flow = np.array([[1.0, (1 - e) / gamma], [0.0, e]])
    noise = np.array([[(2 * gamma * h - 3 + 4 * e - e * e) / gamma**2, (1 - e)**2 / gamma],
                      [(1 - e)**2 / gamma, 1 - e * e]])
    kick = np.array([[1.0, 0.0], [-0.5 * h * omega**2, 1.0]])
    step = kick @ flow @ kick
    source = kick @ noise @ kick.T
    covariance = np.eye(2)
    for _ in range(20000):
        covariance = step @ covariance @ step.T + source
    return covariance[1, 1]


def heat_draw(out, steps_fs=(1.0, 2.0, 2.5, 3.0, 3.5, 4.0), picoseconds=2.0):
    """The heat the cold Drude bath draws from the molecules, measured directly: every peer runs `picoseconds` from
    one equilibrated state with the molecules' thermostat off (friction 1e-6/ps) and the Drude bath on (1 K at
    --drude-friction), and the slope of the total energy (potential plus kinetic from the reported velocities) is the
    heat drawn.  Peers: DrudeLangevin at 0.25 and 0.5 fs; the SIM (WarpedMiddleLimited, plain Warped up to 2.5 fs)
    unscaled and scaled at steps_fs; the same SIM without any bath (stiff friction 0), whose slope is the step's own
    energy drift.  The bath's draw of a SIM is its slope less that drift.  Writes heat_draw.json."""
    system, topology, positions, _ = build_water(256)
    state = equilibrated_state(system, positions, 1.0, 2000, 1)
    masses = np.array([system.getParticleMass(i).value_in_unit(unit.dalton) for i in range(system.getNumParticles())])
    molecules = topology.getNumResidues()

    def slope(kind, step_fs, bath=True):
        integrator = make_integrator(kind, step_fs, 3)
        integrator.setFriction(1e-6)
        if not bath:
            integrator.setStiffModeFriction(0.0)
            integrator.setStiffModeTemperature(0.0)
        context = openmm.Context(system, integrator, openmm.Platform.getPlatformByName("CPU"), {"Threads": "2"})
        context.setState(state)
        steps = int(round(picoseconds * 1000 / step_fs))
        times, energies = [], []
        counts = np.linspace(0, steps, 41).astype(int)
        for i, done in enumerate(counts):
            if i:
                integrator.step(int(done - counts[i - 1]))
            current = context.getState(getEnergy=True, getVelocities=True)
            v = current.getVelocities(asNumpy=True).value_in_unit(unit.nanometer / unit.picosecond)
            kinetic = 0.5 * np.sum(masses[:, None] * v * v)
            times.append(done * step_fs / 1000)
            energies.append(current.getPotentialEnergy().value_in_unit(unit.kilojoule_per_mole) + kinetic)
        return float(np.polyfit(times, energies, 1)[0]) / molecules

    # What a drawn power P (kJ/mol/ps per molecule) costs the molecules under their 5/ps thermostat in steady state:
    # P / (friction k_B degrees of freedom), 6 degrees of freedom per rigid molecule.
    kelvin_per_power = 1 / (5 * BOLTZ * 6)
    report = {"picoseconds": picoseconds, "kelvin_per_kJ_per_mol_ps": kelvin_per_power, "peers": {}}
    for step_fs in (0.25, 0.5):
        draw = -slope("DrudeLangevin", step_fs)
        report["peers"][f"DrudeLangevin_{step_fs:g}fs"] = {"step_fs": step_fs, "draw": draw}
        print(f"DrudeLangevin {step_fs:g} fs: the Drude bath draws {draw:.3f} kJ/mol/ps per molecule", flush=True)
    for step_fs in steps_fs:
        drift = slope("WarpedMiddleLimited", step_fs, bath=False)
        for kind in ("WarpedMiddleLimited", "WarpedMiddleLimitedScaled"):
            draw = -slope(kind, step_fs) + drift
            report["peers"][f"{kind}_{step_fs:g}fs"] = {"step_fs": step_fs, "draw": draw, "step_drift": drift}
            print(f"{kind} {step_fs:g} fs: the Drude bath draws {draw:.3f} kJ/mol/ps per molecule (the step's own "
                  f"drift without baths {drift:.3f})", flush=True)
    with open(os.path.join(out, "heat_draw.json"), "w") as f:
        json.dump(report, f, indent=1)


def cold_hot_pairs(out, pairs, step_fs=2.5, picoseconds=12.0):
    """Does the molecules' temperature lean of the scaled SIM need the cold Drude bath?  For each of `pairs`
    equilibrated starts, WarpedMiddleScaled at step_fs twice, its Drude bath at 1 K and at 300 K (both 20/ps), 1 ps
    of burn-in and `picoseconds` sampled 120 times; the centre-of-mass temperature of each, and the paired
    difference cold - hot, mean ± s.e. over the pairs.  Writes cold_hot_pairs.json."""
    system, _, positions, _ = build_water(256)
    analysis = Analysis(system)
    report = {"step_fs": step_fs, "picoseconds": picoseconds, "pairs": []}
    for pair in range(pairs):
        state = equilibrated_state(system, positions, 1.0, 2000, 100 + pair)
        temperatures = {}
        for label, drude_kelvin in (("cold", 1.0), ("hot", 300.0)):
            integrator = make_integrator("WarpedMiddleScaled", step_fs, 200 + pair, drude_kelvin=drude_kelvin)
            context = openmm.Context(system, integrator, openmm.Platform.getPlatformByName("CPU"), {"Threads": "2"})
            context.setState(state)
            integrator.step(int(round(1000 / step_fs)))
            every = max(1, int(round(picoseconds * 1000 / step_fs)) // 120)
            samples = []
            for _ in range(120):
                integrator.step(every)
                v = context.getState(getVelocities=True).getVelocities(asNumpy=True)
                samples.append(analysis.temperatures(v.value_in_unit(unit.nanometer / unit.picosecond))[0])
            temperatures[label] = float(np.mean(samples))
        report["pairs"].append(temperatures)
        for key, values in (("cold_K", [p["cold"] for p in report["pairs"]]),
                            ("hot_K", [p["hot"] for p in report["pairs"]]),
                            ("cold_minus_hot_K", [p["cold"] - p["hot"] for p in report["pairs"]])):
            report[key] = [float(v) for v in mean_se(np.array(values))]
        print(f"pair {pair + 1}/{pairs}: cold {temperatures['cold']:.2f} K, hot {temperatures['hot']:.2f} K; "
              f"cold - hot so far {report['cold_minus_hot_K'][0]:.2f} K", flush=True)
    with open(os.path.join(out, "cold_hot_pairs.json"), "w") as f:
        json.dump(report, f, indent=1)


def velocity_bias(out, steps_fs=(1.0, 2.0, 2.25, 2.5)):
    """What the step-end velocities of a kick-flow-kick step do to the centre-of-mass temperature of rigid water:
    <Omega^2> of the molecules' translations and rotations from the mean squared force and torque of 20 frames of
    DrudeLangevin at 0.5 fs (<F^2/M> = 3 kT <Omega^2> for harmonic motion), and the step-end <v^2>/kT of a harmonic
    motion at each rms frequency (step_end_velocity_variance, about 1 - (Omega H)^2/6).  Writes velocity_bias.json."""
    system, topology, positions, _ = build_water(256)
    state = equilibrated_state(system, positions, 1.0, 1000, 3)
    integrator = make_integrator("DrudeLangevin", 0.5, 4)
    context = openmm.Context(system, integrator, openmm.Platform.getPlatformByName("CPU"), {"Threads": "2"})
    context.setState(state)
    masses = np.array([system.getParticleMass(i).value_in_unit(unit.dalton) for i in range(system.getNumParticles())])
    molecules = [[atom.index for atom in residue.atoms()] for residue in topology.residues()]
    kT = BOLTZ * 300
    translation, rotation = [], []
    for _ in range(20):
        integrator.step(200)
        st = context.getState(getPositions=True, getForces=True)
        x = st.getPositions(asNumpy=True).value_in_unit(unit.nanometer)
        f = st.getForces(asNumpy=True).value_in_unit(unit.kilojoule_per_mole / unit.nanometer)
        for molecule in molecules:
            body = [i for i in molecule if masses[i] > 0]  # O, its Drude and the hydrogens (the M site is massless)
            m = masses[body]
            arm = x[body] - (m[:, None] * x[body]).sum(axis=0) / m.sum()
            force = f[molecule].sum(axis=0)
            torque = np.cross(arm, f[body]).sum(axis=0)
            inertia = sum(mi * (a @ a * np.eye(3) - np.outer(a, a)) for mi, a in zip(m, arm))
            translation.append(force @ force / m.sum())
            rotation.append(torque @ np.linalg.solve(inertia, torque))
    omega2 = {"translation": float(np.mean(translation) / (3 * kT)), "rotation": float(np.mean(rotation) / (3 * kT))}
    report = {"omega_rms_per_ps": {k: math.sqrt(v) for k, v in omega2.items()}, "predicted_t_com_bias_K": {}}
    print("rms angular frequency: translation %.1f/ps, rotation %.1f/ps" % (
        report["omega_rms_per_ps"]["translation"], report["omega_rms_per_ps"]["rotation"]))
    for h in steps_fs:
        ratio = np.mean([step_end_velocity_variance(math.sqrt(w2), h * 1e-3) for w2 in omega2.values()])
        report["predicted_t_com_bias_K"][h] = 300 * (ratio - 1)
        print("H = %g fs: step-end T_COM %.2f K from 300 K" % (h, 300 * (ratio - 1)))
    with open(os.path.join(out, "velocity_bias.json"), "w") as f:
        json.dump(report, f, indent=1)


def interleaved_timing(out, rounds, picoseconds=0.5, wall_steps=(), limited_steps=()):
    """Wall-clock speed of DrudeLangevin at 1 fs, Filtered at 2 fs, Warped at 2.5 fs (both placements) and
    WarpedMiddleLimited at limited_steps (fs) on the scene's system, with 1 and 2 threads: one Context each from one
    equilibrated state, timed interleaved over `rounds` rounds of `picoseconds` (flavorbench.interleaved).  Writes
    interleaved_timing.json with each round's ns/day and, per thread count, each SIM's median ratio to DrudeLangevin
    over the rounds."""
    system, _, positions, _ = build_water(256)
    state = equilibrated_state(system, positions, 1.0, 1000, 1)
    peers = [("DrudeLangevin", 1.0)] + [("DrudeLangevinWall", h) for h in wall_steps]
    peers += [("Filtered", 2.0), ("Warped", 2.5), ("WarpedMiddle", 2.5)]
    peers += [("WarpedMiddleLimited", h) for h in limited_steps]
    names = [f"{kind} {step_fs:g} fs" for kind, step_fs in peers]
    report = {"system": "256 SWM4-NDP molecules, rigid, PME", "ps_per_round": picoseconds, "threads": {},
              "wall_nm": WALL_NM}
    for threads in (1, 2):
        timed = []
        for name, (kind, step_fs) in zip(names, peers):
            integrator = make_integrator(kind, step_fs, 7)
            context = openmm.Context(system, integrator, openmm.Platform.getPlatformByName("CPU"),
                                     {"Threads": str(threads)})
            context.setState(state)
            timed.append((name, step_fs, integrator, context))
        timing = interleaved_ns_per_day(timed, rounds, picoseconds,
                                        report=lambda line: print(f"{threads} thread(s), {line}", flush=True))
        ratios = timing["median_ratio_to_first"]
        report["threads"][threads] = {"ns_per_day": timing["ns_per_day"],
                                      "median_ns_per_day": timing["median_ns_per_day"],
                                      "median_ratio_to_DrudeLangevin_1fs": ratios, "failed": timing["failed"]}
        print(f"{threads} thread(s): median ratio to DrudeLangevin 1 fs: " +
              ", ".join(f"{kind} {ratio:.2f}" for kind, ratio in ratios.items()), flush=True)
        del timed
    with open(os.path.join(out, "interleaved_timing.json"), "w") as f:
        json.dump(report, f, indent=1)


def main():
    global MAX_WARPED_PHASE, DRUDE_FRICTION_PER_PS
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="a small, short run (smoke test)")
    repo_root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    parser.add_argument("--out", default=os.path.join(repo_root, "results", "drude_water"),
                        help="output folder (default results/drude_water)")
    parser.add_argument("--constraint-cost", action="store_true",
                        help="only compare the SIM's constrained flow of the Drude waters with the exact one")
    parser.add_argument("--filter-bias", action="store_true",
                        help="only measure the mean displacement of a stiff mode, the FPU energy error and the "
                             "stability threshold against omega H")
    parser.add_argument("--velocity-bias", action="store_true",
                        help="only predict the step-end bias of the centre-of-mass temperature from forces and torques")
    parser.add_argument("--cold-hot-pairs", type=int, metavar="PAIRS",
                        help="only compare the scaled SIM's molecules at 2.5 fs with a 1-K and a 300-K Drude bath, "
                             "PAIRS paired runs")
    parser.add_argument("--heat-draw", action="store_true",
                        help="only measure the heat the Drude bath draws from the molecules (thermostat off), per peer")
    parser.add_argument("--interleaved-timing", type=int, metavar="ROUNDS",
                        help="only time DrudeLangevin 1 fs, Filtered 2 fs and Warped 2.5 fs (Throughout, Middle) in "
                             "turn, ROUNDS rounds")
    parser.add_argument("--production", type=float, default=3.0, help="ps sampled per run (default 3)")
    parser.add_argument("--burn-in", type=float, default=0.5, help="ps per run before sampling (default 0.5)")
    parser.add_argument("--reference-steps", type=float, nargs="+", default=[0.5, 1.0],
                        help="DrudeLangevinIntegrator steps in fs; the first is the reference (default 0.5 1)")
    parser.add_argument("--sim-steps", type=float, nargs="+", default=[1.0, 1.5, 2.0, 2.5, 3.0, 4.0],
                        help="StochasticImpulseIntegrator steps in fs (default 1 1.5 2 2.5 3 4)")
    parser.add_argument("--wall-steps", type=float, nargs="*", default=[],
                        help="DrudeLangevinIntegrator peers with setMaxDrudeDistance(%g nm), the hard wall, at these "
                             "steps in fs (e.g. 1.5 2); with --interleaved-timing, timed beside the others" % WALL_NM)
    parser.add_argument("--seed", type=int, default=0,
                        help="added to every random seed: independent replicas of a run (default 0)")
    parser.add_argument("--splittings", nargs="+",
                        choices=["Strang", "Filtered", "Warped", "FilteredMiddle", "WarpedMiddle",
                                 "WarpedMiddleLimited", "WarpedMiddleScaled", "WarpedMiddleLimitedScaled"],
                        default=["Strang", "Filtered", "Warped"],
                        help="StochasticImpulseIntegrator splittings, ...Middle with setThermostatPlacement(Middle), "
                             "...Limited with setMaxWarpedPhase, ...Scaled with setWarpedFrictionScaling "
                             "(default Strang Filtered Warped)")
    parser.add_argument("--heavy-drudes", type=float, nargs="*", default=[], metavar="FS",
                        help="DrudeLangevinHeavy peers: DrudeLangevin at %g fs on Drude particles as heavy as the "
                             "WarpedMiddleLimited SIM at these steps (fs) makes them act" % HEAVY_DRUDE_STEP_FS)
    parser.add_argument("--least-heavy-drudes", type=float, nargs="*", default=[], metavar="FS",
                        help="DrudeLangevinLeastHeavy peers: DrudeLangevin at %g fs on Drude particles as heavy as any "
                             "step of these lengths (fs) that samples the field once must make them act (omega_d = "
                             "2/H), Drude friction scaled to keep the friction force" % HEAVY_DRUDE_STEP_FS)
    parser.add_argument("--limited-steps", type=float, nargs="*", default=[], metavar="FS",
                        help="--interleaved-timing: WarpedMiddleLimited peers at these steps (fs)")
    parser.add_argument("--max-warped-phase", type=float, default=MAX_WARPED_PHASE,
                        help="setMaxWarpedPhase (radians) of the WarpedMiddleLimited peers (default %(default)g)")
    parser.add_argument("--drude-friction", type=float, default=DRUDE_FRICTION_PER_PS, metavar="PER_PS",
                        help="friction (1/ps) of the Drude bath of every peer: DrudeLangevin's drudeFriction, the "
                             "SIM's setStiffModeFriction (default %(default)g)")
    parser.add_argument("--seed-summary", metavar="JSON", nargs="+",
                        help="only pool the drude_water.json of runs with several seeds into --out (table and chart)")
    parser.add_argument("--replot", metavar="JSON", help="only redraw the chart of an earlier run's JSON into --out")
    parser.add_argument("--table", metavar="JSON", nargs="+",
                        help="only print the markdown table of an earlier run's JSON (and of its interleaved_timing.json)")
    args = parser.parse_args()
    if args.seed_summary:
        os.makedirs(args.out, exist_ok=True)
        seed_summary(args.seed_summary, args.out)
        return
    if args.table:
        loaded = []
        for path in args.table:
            with open(path) as f:
                loaded.append(json.load(f))
        print(markdown_table(loaded[0], loaded[1] if len(loaded) > 1 else None))
        return
    reporting.set_smoke_run(args.quick)
    if args.replot:
        reporting.replot(args.replot, args.out, "drude_water", lambda data, path: plot(split_failed(data), path))
        return
    if args.seed < 0:
        parser.error("--seed must be non-negative (got %d)" % args.seed)
    MAX_WARPED_PHASE = args.max_warped_phase
    if not args.drude_friction > 0:
        parser.error("--drude-friction must be positive (got %g)" % args.drude_friction)
    DRUDE_FRICTION_PER_PS = args.drude_friction
    if args.filter_bias:
        os.makedirs(args.out, exist_ok=True)
        filter_bias(args.out)
        return
    if args.velocity_bias:
        os.makedirs(args.out, exist_ok=True)
        velocity_bias(args.out)
        return
    if args.cold_hot_pairs is not None:
        if args.cold_hot_pairs < 2:
            parser.error("--cold-hot-pairs needs at least 2 pairs (got %d)" % args.cold_hot_pairs)
        os.makedirs(args.out, exist_ok=True)
        cold_hot_pairs(args.out, args.cold_hot_pairs)
        return
    if args.heat_draw:
        os.makedirs(args.out, exist_ok=True)
        heat_draw(args.out)
        return
    if args.interleaved_timing is not None:
        if args.interleaved_timing < 1:
            parser.error("--interleaved-timing needs at least 1 round (got %d)" % args.interleaved_timing)
        os.makedirs(args.out, exist_ok=True)
        interleaved_timing(args.out, args.interleaved_timing, wall_steps=args.wall_steps,
                           limited_steps=args.limited_steps)
        return
    if args.constraint_cost:
        os.makedirs(args.out, exist_ok=True)
        constraint_cost(args.out)
        return
    if args.quick:
        args.wall_steps = args.wall_steps[-1:]
        settings = dict(molecules=125, equilibration_ps=0.05, burn_ps=0.01, production_ps=0.02, samples=4, blocks=2,
                        scf_frames=2, sim_steps=[1.0, 2.0, 4.0])
    else:
        settings = dict(molecules=256, equilibration_ps=2.0, burn_ps=args.burn_in, production_ps=args.production,
                        samples=60, blocks=6, scf_frames=12, sim_steps=args.sim_steps)
    os.makedirs(args.out, exist_ok=True)
    system, topology, positions, box = build_water(settings["molecules"])
    analysis = Analysis(system)
    scf = SelfConsistent(system, analysis)
    # Equilibrate with the reference integrator (1 fs) from a minimized lattice.
    state = equilibrated_state(system, positions, 1.0, int(settings["equilibration_ps"] * 1000), 1 + args.seed)
    edges = np.linspace(0.2, min(0.8, 0.5 * box), 61)
    runs = {}
    peers = [("DrudeLangevin", h) for h in ([0.5, 1.0] if args.quick else args.reference_steps)]
    peers += [(kind, h) for kind in (("Strang", "Filtered", "Warped") if args.quick else args.splittings)
              for h in settings["sim_steps"]]
    peers += [("DrudeLangevinWall", h) for h in args.wall_steps]
    # DrudeLangevin on Drude particles as heavy as the phase-limited SIM at H makes them act, and as heavy as any step
    # H that samples the field once must make them (labelled by that H).
    peers += [("DrudeLangevinHeavy", h) for h in args.heavy_drudes]
    peers += [("DrudeLangevinLeastHeavy", h) for h in args.least_heavy_drudes]
    for seed, (kind, step_fs) in enumerate(peers, start=10 + args.seed):
        label = f"{kind}_{step_fs:g}fs"
        counter = {}
        try:
            if kind in ("DrudeLangevinHeavy", "DrudeLangevinLeastHeavy"):
                heavy, mass, friction_scale = heavy_peer(system, kind, step_fs)
                runs[label] = run_one(heavy, state, Analysis(heavy), scf, kind, HEAVY_DRUDE_STEP_FS, settings, edges,
                                      seed, counter, friction_scale)
                runs[label].update(emulates_fs=step_fs, drude_mass_amu=mass, drude_friction_scale=friction_scale)
            else:
                runs[label] = run_one(system, state, analysis, scf, kind, step_fs, settings, edges, seed, counter)
        except (openmm.OpenMMException, FloatingPointError, ValueError) as error:
            # The step it failed at: exact in the burn-in (one step at a time), else within the production frame.
            first, last = counter.get("steps", 0) + 1, counter.get("steps", 0) + counter.get("interval", 1)
            runs[label] = {"integrator": kind, "step_fs": step_fs, "failed": str(error), "failed_at_step": first,
                           "failed_by_step": last, "failed_at_fs": first * step_fs}
        print(label, json.dumps({k: v for k, v in runs[label].items() if not k.startswith("g_oo")}), flush=True)
    completed = {k: v for k, v in runs.items() if "failed" not in v}
    reference_label = "DrudeLangevin_%gfs" % peers[0][1]
    reference = completed[reference_label]
    observables = ["induced_ratio", "dipole", "pe_per_molecule", "g_oo_peak", "t_com", "t_drude"]
    for run in completed.values():
        run["within_error_of_reference"] = {
            key: abs(run[key][0] - reference[key][0]) <= 2 * math.hypot(run[key][1], reference[key][1])
            for key in observables}
        run["speedup_over_DrudeLangevin_1fs"] = run["ns_per_day"] / completed["DrudeLangevin_1fs"]["ns_per_day"]
    data = {"scene": "drude_water", "model": "SWM4-NDP (swm4ndp.xml), rigid water, PME", "platform": "CPU, 2 threads",
            "parameters": dict(settings, box_nm=box, temperature_K=300, friction_per_ps=5,
                               drude_temperature_K=1, drude_friction_per_ps=DRUDE_FRICTION_PER_PS, max_warped_phase=MAX_WARPED_PHASE,
                               seed=args.seed),
            "criterion": "within_error_of_reference: |run - reference| <= 2 sqrt(se_run^2 + se_ref^2)",
            "reference": reference_label, "g_oo_r_nm": (0.5 * (edges[1:] + edges[:-1])).tolist(), "runs": runs}
    data["quick"] = args.quick
    with open(os.path.join(args.out, "drude_water.json"), "w") as f:
        json.dump(data, f, indent=1)
    plot(split_failed(data), os.path.join(args.out, "drude_water.png"))


def markdown_table(data, interleaved=None):
    """The README's table of a run: per peer its ns/day (sequential; with interleaved, the JSON of --interleaved-timing,
    also the 2-thread interleaved median and ratio to DrudeLangevin 1 fs), the observables with their block errors and
    σ against the reference; a failed peer with the step it failed at."""
    runs = data["runs"]
    reference = runs[data["reference"]]
    timing = (interleaved or {}).get("threads", {}).get("2", {})
    lines = ["| integrator | H (fs) | ns/day | interleaved ns/day (× DL 1 fs) | induced / SCF | dipole (D) | "
             "PE per molecule (kJ/mol) | g_OO first peak | T_COM (K) | T_Drude (K) | σ |", "|---" * 11 + "|"]
    for label, run in runs.items():
        name = kind_label(run["integrator"]) + (" %g nm" % WALL_NM if run["integrator"] == "DrudeLangevinWall" else "")
        timed = f"{run['integrator']} {run['step_fs']:g} fs"
        fast = timing.get("median_ns_per_day", {}).get(timed)
        ratio = timing.get("median_ratio_to_DrudeLangevin_1fs", {}).get(timed, 1.0 if timed == "DrudeLangevin 1 fs"
                                                                       else None)
        failed_timing = timing.get("failed", {}).get(timed)
        interleaved_text = ("%.1f (%.2f×)" % (fast, ratio) if fast is not None and ratio is not None else
                            "failed in steps %d–%d" % tuple(failed_timing["failed_in_steps"]) if failed_timing else "—")
        if "failed" in run:
            at = ("fails at step %d (%g fs)" % (run["failed_at_step"], run["failed_at_fs"])
                  if run.get("failed_at_step") == run.get("failed_by_step") else
                  "fails in steps %d–%d" % (run["failed_at_step"], run["failed_by_step"]) if "failed_at_step" in run
                  else "fails")
            lines.append(f"| {name} | {run['step_fs']:g} | {at}: {run['failed']} | {interleaved_text} |" + " |" * 7)
            continue
        sigma = "—" if run is reference else ", ".join(
            "%.1f" % (abs(run[k][0] - reference[k][0]) / math.hypot(run[k][1], reference[k][1])) for k in OBSERVABLE_FORMATS)
        lines.append(f"| {name} | {run['step_fs']:g} | {run['ns_per_day']:.1f} | {interleaved_text} | " +
                     " | ".join((OBSERVABLE_FORMATS[k] % tuple(run[k])).replace("-", "−") for k in OBSERVABLE_FORMATS) + f" | {sigma} |")
    return "\n".join(lines)


def split_failed(data):
    """data with the runs that failed (NaN) moved from "runs" to "failed_runs"."""
    data = dict(data)
    data["failed_runs"] = [run for run in data["runs"].values() if "failed" in run]
    data["runs"] = {k: v for k, v in data["runs"].items() if "failed" not in v}
    return data


if __name__ == "__main__":
    main()
