"""NaCl in SWM4-NDP water with Drude-2019's polarizable ions (charmm_polar_2019.xml): StochasticImpulseIntegrator on
the System split by separateDrudeSprings, against OpenMM's DrudeLangevinIntegrator, every run from the same
equilibrated state in one process.

    PYTHONPATH=build/python .venv/bin/python examples/drude_ions/drude_ions.py [--quick] [--out DIR] \
        [--production PS] [--burn-in PS] [--sim-steps 1.5 2] [--seed N]
    PYTHONPATH=build/python .venv/bin/python examples/drude_ions/drude_ions.py --seed-table JSON [JSON ...]
    PYTHONPATH=build/python .venv/bin/python examples/drude_ions/drude_ions.py --interleaved-timing ROUNDS \
        [--round-ps PS] [--sim-steps 1.5 2] [--wall NM] [--wall-peers 1]
    PYTHONPATH=build/python .venv/bin/python examples/drude_ions/drude_ions.py --wall-cost STEPS --wall NM \
        [--sim-steps 2]

Writes drude_ions.json to --out.  Observables (block averages; error = standard error of the block means): the induced
dipoles relative to the self-consistent ones at the same nuclear positions (all Drude particles, and the ions' alone),
the centre-of-mass and Drude temperatures, the potential energy per Drude pair, and ns/day.
"""
import argparse
import json
import math
import os
import random
import time

import numpy as np
import openmm
import openmm.app as app
import openmm.unit as unit
from flavorbench import seeds
from flavorbench.interleaved import interleaved_ns_per_day
from flavorbench.runners import KB as BOLTZ
from flavorbench.solvation import compress_to_volume, water_volume
from flavorbench.timeseries import ProductionFrames, block_error
from openmmflavors import StochasticImpulseIntegrator

SPRING_GROUP = 1  # the isotropic Drude springs after separateDrudeSprings; everything else in group 0
# NaCl's apparent molar volume in water near 1 mol/kg, 25 C (16.6 cm^3/mol at infinite dilution), in nm^3 per pair:
# with the waters at their density, 4 pairs in 248 waters make a 1.031 g/cm^3 solution (measured: 1.032 at 5 % NaCl).
NACL_PAIR_VOLUME = 19.0 / 602.214076


def build(waters, pairs, cutoff, seed):
    """A cubic box of `waters` SWM4-NDP molecules and `pairs` Na+/Cl- pairs (Drude-2019 SOD and CLA), PME (cutoff in
    nm), rigid water, X-H bonds constrained; the box holds the waters at water's density at 300 K and the pairs at
    NaCl's apparent molar volume.  Modeller puts the ions in place of waters it draws from Python's `random`: drawn
    here from `seed`, so that a seed names one box."""
    modeller = app.Modeller(app.Topology(), [])
    outer = random.getstate()
    random.seed(seed)
    # Modeller adds round(n_water * I / 55.4 M) pairs: ask for exactly `pairs`.
    modeller.addSolvent(app.ForceField("amber14/tip3p.xml"), model="tip3p", numAdded=waters + 2 * pairs,
                        positiveIon="Na+", negativeIon="Cl-", ionicStrength=pairs * 55.4 / waters * unit.molar)
    random.setstate(outer)
    compress_to_volume(modeller, water_volume(modeller.topology) + pairs * NACL_PAIR_VOLUME)
    relax_without_drudes(modeller, cutoff)
    return polar_system(modeller, cutoff)


def relax_without_drudes(modeller, cutoff):
    """Minimizes the box as TIP3P water and amber14 ions (rigid water), in place: compressed to water's density, the
    molecules overlap.  Minimized with their Drude particles instead, a Drude particle can run into a neighbour's field:
    OpenMM 8.6's minimizer did so from the quick box of seed 1 (NaN), and so `equilibrated` starts these boxes from
    here (minimize=False)."""
    system = app.ForceField("amber14/tip3p.xml").createSystem(
        modeller.topology, nonbondedMethod=app.PME, nonbondedCutoff=cutoff * unit.nanometer, rigidWater=True)
    context = openmm.Context(system, openmm.VerletIntegrator(0.001), openmm.Platform.getPlatformByName("CPU"),
                             {"Threads": "1"})
    context.setPositions(modeller.positions)
    openmm.LocalEnergyMinimizer.minimize(context, 10, 500)
    modeller.positions = context.getState(getPositions=True).getPositions()


def polar_system(modeller, cutoff):
    """Drude-2019 for the Modeller's topology (TIP3P water becomes SWM4-NDP): its Drude particles and lone pairs
    added, PME (cutoff in nm), rigid water, X-H bonds constrained, every force in group 0.  Returns the System, the
    topology and the positions."""
    forcefield = app.ForceField("charmm_polar_2019.xml")
    modeller.addExtraParticles(forcefield)
    system = forcefield.createSystem(modeller.topology, nonbondedMethod=app.PME,
                                     nonbondedCutoff=cutoff * unit.nanometer, constraints=app.HBonds, rigidWater=True)
    for force in system.getForces():
        force.setForceGroup(0)
    return system, modeller.topology, modeller.positions


class Analysis:
    """The Drude pairs and the other massive particles of a System, for temperatures per class of degrees of freedom;
    `solute` names the residues whose pairs are told apart (solute_pairs: the ions here)."""

    def __init__(self, system, topology, solute=("NA", "CL")):
        drude = next(f for f in system.getForces() if isinstance(f, openmm.DrudeForce))
        n = system.getNumParticles()
        self.masses = np.array([system.getParticleMass(i).value_in_unit(unit.dalton) for i in range(n)])
        pairs = np.array([drude.getParticleParameters(i)[:2] for i in range(drude.getNumParticles())])
        self.drudes, self.cores = pairs[:, 0], pairs[:, 1]
        self.residue = [a.residue.name for a in topology.atoms()]
        self.solute_pairs = np.array([i for i, core in enumerate(self.cores) if self.residue[core] in solute], dtype=int)
        self.ion_pairs = self.solute_pairs
        self.ions = {name: sum(1 for r in topology.residues() if r.name == name) for name in ("NA", "CL")}
        in_pair = set(self.drudes) | set(self.cores)
        self.others = np.array([i for i in range(n) if self.masses[i] > 0 and i not in in_pair])
        self.constraints = [system.getConstraintParameters(c)[:2] for c in range(system.getNumConstraints())]
        # 3 per pair (centre of mass) and per other massive particle, less constraints and the removed momentum.
        self.com_dof = 3 * (len(self.cores) + len(self.others)) - system.getNumConstraints() - 3
        self.drude_dof = 3 * len(self.drudes)

    def kinetic_parts(self, v):
        """Kinetic energies (kJ/mol): of each pair's centre of mass, of each other particle, of each pair's relative
        motion."""
        m = self.masses
        mc, md = m[self.cores][:, None], m[self.drudes][:, None]
        com = (mc * v[self.cores] + md * v[self.drudes]) / (mc + md)
        rel = v[self.drudes] - v[self.cores]
        return (0.5 * np.sum((mc + md) * com**2, axis=1), 0.5 * np.sum(m[self.others][:, None] * v[self.others]**2,
                                                                          axis=1),
                0.5 * np.sum(mc * md / (mc + md) * rel**2, axis=1))

    def temperatures(self, v):
        pairs, others, relative = self.kinetic_parts(v)
        return (2 * (pairs.sum() + others.sum()) / (self.com_dof * BOLTZ),
                2 * relative.sum() / (self.drude_dof * BOLTZ))

    def class_selection(self, residues):
        """The pairs and other particles of the given residue names, and their degrees of freedom (3 each, less the
        constraints among them)."""
        pairs = np.array([i for i, c in enumerate(self.cores) if self.residue[c] in residues], dtype=int)
        others = np.array([k for k, i in enumerate(self.others) if self.residue[i] in residues], dtype=int)
        constrained = sum(1 for i, j in self.constraints if self.residue[i] in residues and self.residue[j] in residues)
        return pairs, others, 3 * (len(pairs) + len(others)) - constrained

    def class_temperature(self, parts, selection):
        """The centre-of-mass temperature of one class (class_selection) from kinetic_parts."""
        pairs, others, dof = selection
        return 2 * (parts[0][pairs].sum() + parts[1][others].sum()) / (dof * BOLTZ)

    def displacements(self, x):
        return x[self.drudes] - x[self.cores]


class SelfConsistent:
    """Drude positions that minimize the energy of the original System with every other particle held where it is."""

    def __init__(self, system):
        fixed = openmm.XmlSerializer.deserialize(openmm.XmlSerializer.serialize(system))
        drude = next(f for f in system.getForces() if isinstance(f, openmm.DrudeForce))
        drudes = {drude.getParticleParameters(i)[0] for i in range(drude.getNumParticles())}
        for i in range(fixed.getNumParticles()):
            if i not in drudes:
                fixed.setParticleMass(i, 0.0)
        for c in reversed(range(fixed.getNumConstraints())):
            fixed.removeConstraint(c)
        self.context = openmm.Context(fixed, openmm.VerletIntegrator(0.001), openmm.Platform.getPlatformByName("CPU"),
                                      {"Threads": "2"})

    def positions(self, positions, box):
        """positions (nm, in the box's vectors) with every Drude particle moved to its self-consistent place."""
        self.context.setPeriodicBoxVectors(*box)
        self.context.setPositions(positions)
        openmm.LocalEnergyMinimizer.minimize(self.context, 1e-3, 2000)
        return self.context.getState(getPositions=True).getPositions(asNumpy=True).value_in_unit(unit.nanometer)

    def displacements(self, state, analysis):
        return analysis.displacements(self.positions(state.getPositions(), state.getPeriodicBoxVectors()))


def make_integrator(kind, step_fs, seed, max_warped_phase=0.0, scaled_friction=False):
    """DrudeLangevin, or the SIM ("WarpedMiddle"; max_warped_phase > 0: setMaxWarpedPhase, radians, else Warped's own
    step, the limit off (pi), as this scene measured it; scaled_friction: setWarpedFrictionScaling)."""
    if kind == "DrudeLangevin":
        integrator = openmm.DrudeLangevinIntegrator(300 * unit.kelvin, 5 / unit.picosecond, 1 * unit.kelvin,
                                                    20 / unit.picosecond, step_fs * unit.femtosecond)
    else:  # "WarpedMiddle": the Warped splitting with the zero modes' thermostat placed as LangevinMiddle's
        integrator = StochasticImpulseIntegrator(300 * unit.kelvin, 5 / unit.picosecond, step_fs * unit.femtosecond,
                                                 {SPRING_GROUP})
        integrator.setSplitting(StochasticImpulseIntegrator.Warped)
        integrator.setThermostatPlacement(StochasticImpulseIntegrator.Middle)
        integrator.setStiffModeTemperature(1 * unit.kelvin)
        integrator.setStiffModeFriction(20 / unit.picosecond)
        integrator.setMaxWarpedPhase(max_warped_phase if max_warped_phase > 0 else math.pi)
        integrator.setWarpedFrictionScaling(scaled_friction)
    integrator.setRandomNumberSeed(seed)
    return integrator


EQUILIBRATION_STEP_FS = 0.5


def equilibrated(system, positions, seed, ps, minimize=True):
    """The original System minimized (for boxes relaxed without their Drude particles, `build`, minimize=False: only
    the Drude particles, moved to their self-consistent places), then run ps with DrudeLangevin at 0.5 fs behind the
    0.02-nm hard wall: the state every peer starts from.  At the solution's density DrudeLangevin at 1 fs blew up from the minimized box in one of
    four starts without the wall (CHARMM's practice) and in one of ten with it.  Both run on one thread, so that a seed
    names one equilibrated state: with two the CPU platform's sums change from run to run, and so the paths: in the
    quick box about one minimizer path in ten ran a Drude particle into its neighbour's field (NaN), and about one
    equilibration in two hundred moved a Drude particle past twice the wall in one step (OpenMM's exception)."""
    platform = openmm.Platform.getPlatformByName("CPU")
    one_thread = {"Threads": "1"}
    if minimize:
        minimizer = openmm.Context(system, openmm.VerletIntegrator(0.001), platform, one_thread)
        minimizer.setPositions(positions)
        openmm.LocalEnergyMinimizer.minimize(minimizer, 10, 500)
        positions = minimizer.getState(getPositions=True).getPositions()
    else:
        positions = SelfConsistent(system).positions(positions, system.getDefaultPeriodicBoxVectors())
    integrator = make_integrator("DrudeLangevin", EQUILIBRATION_STEP_FS, seed)
    integrator.setMaxDrudeDistance(0.02 * unit.nanometer)
    context = openmm.Context(system, integrator, platform, one_thread)
    context.setPositions(positions)
    context.setVelocitiesToTemperature(300 * unit.kelvin, seed + 1)
    integrator.step(int(round(ps * 1000 / EQUILIBRATION_STEP_FS)))
    return context.getState(getPositions=True, getVelocities=True)


def run_one(system, state, analysis, scf, kind, step_fs, settings, seed, wall_nm=0.0, induced_groups=None,
            extra=None, max_warped_phase=0.0, scaled_friction=False):
    """One peer from the common state: burn-in, then the production's block averages.  induced_groups: name -> pair
    indices, each reported as induced_ratio_<name> beside all pairs'; extra(frame) -> {name: value} more observables
    per frame (default: the ions' induced ratio, nothing more); max_warped_phase, scaled_friction: the SIM's
    setMaxWarpedPhase and setWarpedFrictionScaling."""
    if induced_groups is None:
        induced_groups = {"ions": analysis.ion_pairs}
    integrator = make_integrator(kind, step_fs, seed, max_warped_phase, scaled_friction)
    if wall_nm > 0:
        integrator.setMaxDrudeDistance(wall_nm)
    context = openmm.Context(system, integrator, openmm.Platform.getPlatformByName("CPU"), {"Threads": "2"})
    context.setState(state)
    integrator.step(int(round(settings["burn_ps"] * 1000 / step_fs)))
    samples = settings["samples"]
    steps = int(round(settings["production_ps"] * 1000 / step_fs))
    series = {"t_com": [], "t_drude": [], "pe_per_pair": [], "induced_ratio": []}
    series.update({"induced_ratio_" + name: [] for name in induced_groups})
    scf_every = max(1, samples // settings["scf_frames"])
    production = ProductionFrames(context, integrator, steps, samples)
    for s, frame in enumerate(production):
        t_com, t_drude = analysis.temperatures(frame.velocities)
        series["t_com"].append(t_com)
        series["t_drude"].append(t_drude)
        series["pe_per_pair"].append(frame.potential_energy / len(analysis.drudes))
        for name, value in (extra(frame) if extra else {}).items():
            series.setdefault(name, []).append(value)
        if s % scf_every == 0:
            d = analysis.displacements(frame.positions)
            d_scf = scf.displacements(frame.state, analysis)
            series["induced_ratio"].append(float(np.sum(d * d_scf) / np.sum(d_scf * d_scf)))
            for name, group in induced_groups.items():
                series["induced_ratio_" + name].append(float(np.sum(d[group] * d_scf[group]) /
                                                             np.sum(d_scf[group]**2)))
    result = {"integrator": kind, "step_fs": step_fs, "wall_nm": wall_nm, "steps": production.steps_done,
              "ns_per_day": production.ns_per_day(step_fs)}
    for name, values in series.items():
        blocks = settings["blocks"] if not name.startswith("induced") else min(settings["blocks"], len(values))
        result[name] = block_error(values, blocks)
    result["t_drude_max"] = max(series["t_drude"])  # the hottest frame: a transient the block means would blur
    return result


def interleaved_timing(system, separated, state, dl_steps, sim_steps, wall_nm, rounds, round_ps,
                       max_warped_phase=0.0, scaled_friction=False, threads=2):
    """ns/day of DrudeLangevin at dl_steps (fs) on the original System and of the SIM at sim_steps on the separated
    one, every peer with the wall (wall_nm > 0), one Context each from `state`, timed interleaved
    (flavorbench.interleaved) with `threads` threads; each peer's median ratio to the first DrudeLangevin."""
    platform = openmm.Platform.getPlatformByName("CPU")
    peers = [(system, "DrudeLangevin", h) for h in dl_steps] + [(separated, "WarpedMiddle", h) for h in sim_steps]
    timed = []
    for run_system, kind, step_fs in peers:
        integrator = make_integrator(kind, step_fs, 5, max_warped_phase, scaled_friction)
        if wall_nm > 0:
            integrator.setMaxDrudeDistance(wall_nm)
        context = openmm.Context(run_system, integrator, platform, {"Threads": str(threads)})
        context.setState(state)
        timed.append((f"{kind} {step_fs:g} fs", step_fs, integrator, context))
    timing = interleaved_ns_per_day(timed, rounds, round_ps, report=lambda line: print(line, flush=True))
    timing.update({"threads": threads, "ps_per_round": round_ps, "wall_nm": wall_nm,
                   "max_warped_phase": max_warped_phase, "scaled_friction": scaled_friction})
    print("median ratio to " + timed[0][0] + ": " +
          ", ".join(f"{name} {ratio:.2f}" for name, ratio in timing["median_ratio_to_first"].items()), flush=True)
    return timing


def wall_cost(separated, state, step_fs, wall_nm, steps, max_warped_phase=0.0, scaled_friction=False):
    """Single SIM steps at step_fs from `state`, one thread, with the wall and without it, each step timed alone: a
    step that evaluates the forces twice (as every step did where the earlier wall, after the closing kick, had moved a
    pair) shows as about twice the median time.  Returns {label: {"median_ms", "mean_ms", "slow_fraction"}}, slow
    meaning over 1.6 times the median."""
    result = {}
    for wall in (wall_nm, 0.0):
        integrator = make_integrator("WarpedMiddle", step_fs, 5, max_warped_phase, scaled_friction)
        integrator.setMaxDrudeDistance(wall)
        context = openmm.Context(separated, integrator, openmm.Platform.getPlatformByName("CPU"), {"Threads": "1"})
        context.setState(state)
        integrator.step(3)
        times = []
        for _ in range(steps):
            start = time.perf_counter()
            integrator.step(1)
            times.append(1e3 * (time.perf_counter() - start))
        median = float(np.median(times))
        label = f"WarpedMiddle {step_fs:g} fs, wall {wall:g} nm"
        result[label] = {"median_ms": median, "mean_ms": float(np.mean(times)),
                         "slow_fraction": float(np.mean(np.array(times) > 1.6 * median))}
        print(f"{label}: median {median:.2f} ms, mean {result[label]['mean_ms']:.2f} ms, steps over 1.6 x the median "
              f"{result[label]['slow_fraction']:.3f}", flush=True)
    return result


def add_timing_arguments(parser):
    """The options of the interleaved timing (the scenes' other runs time each peer alone)."""
    parser.add_argument("--interleaved-timing", type=int, metavar="ROUNDS",
                        help="only time DrudeLangevin at the --wall-peers steps (1 fs without them) and the SIM at "
                             "--sim-steps, all with the --wall, interleaved over ROUNDS rounds from one equilibrated "
                             "state; writes interleaved_timing.json")
    parser.add_argument("--round-ps", type=float, default=0.5, help="ps per peer and round of the timing (default 0.5)")
    parser.add_argument("--wall-cost", type=int, metavar="STEPS",
                        help="only time STEPS single SIM steps at the largest --sim-steps with the --wall and without "
                             "it, one thread; writes wall_cost.json")


def check_timing_arguments(parser, args):
    if args.interleaved_timing is not None and args.interleaved_timing < 1:
        parser.error(f"--interleaved-timing needs at least 1 round (got {args.interleaved_timing})")
    if not args.round_ps > 0:
        parser.error(f"--round-ps must be positive (got {args.round_ps})")
    if args.wall_cost is not None and (args.wall_cost < 1 or not args.wall > 0):
        parser.error(f"--wall-cost needs at least 1 step and a --wall (got {args.wall_cost} steps, wall {args.wall})")


def run_timing(args, system, separated, state):
    """The timing modes (--interleaved-timing, --wall-cost) of a scene's command line: runs the one asked for, writes
    its JSON to --out and returns True; False when none was asked for."""
    phase, scaled = getattr(args, "max_warped_phase", 0.0), getattr(args, "scaled_friction", False)
    if args.interleaved_timing:
        name, data = "interleaved_timing.json", interleaved_timing(
            system, separated, state, args.wall_peers or [1.0], args.sim_steps, args.wall, args.interleaved_timing,
            args.round_ps, phase, scaled)
    elif args.wall_cost:
        name, data = "wall_cost.json", {"steps": args.wall_cost, "runs": wall_cost(
            separated, state, max(args.sim_steps), args.wall, args.wall_cost, phase, scaled)}
    else:
        return False
    os.makedirs(args.out, exist_ok=True)
    path = os.path.join(args.out, name)
    with open(path, "w") as out:
        json.dump(dict(data, seed=args.seed), out, indent=1)
    print(f"written to {path}")
    return True


def print_runs(runs, names, width=24):
    """One row per run: each observable (key, label) of `names` as mean ± error, or the run's failure."""
    print(f"\n{'run':32s}" + "".join(f"{label:>{width}s}" for _, label in names))
    for run in runs:
        wall = f" wall {run['wall_nm']:g}" if run.get("wall_nm") else ""
        row = f"{run['integrator'] + ' ' + str(run['step_fs']) + ' fs' + wall:32s}"
        if "failed" in run:
            print(row + "  failed: " + run["failed"][:80])
            continue
        for key, _ in names:
            value = run[key]
            if isinstance(value, (list, tuple)):
                row += f"{value[0]:{width - 9}.4f} ± {value[1]:6.4f}"
            else:
                row += f"{value:{width}.2f}"
        print(row)


# The observables of the seed table: JSON key, row name, format, scale.
SEED_TABLE_ROWS = [("induced_ratio", "induced / SCF, all", "%.4f", 1),
                   ("induced_ratio_ions", "induced / SCF, ions", "%.4f", 1),
                   ("t_drude", "T Drude (K)", "%.3f", 1), ("t_com", "T centre of mass (K)", "%.1f", 1),
                   ("pe_per_pair", "PE per Drude pair (kJ/mol)", "%.2f", 1)]


def seed_table(files):
    """The Markdown table of several seeds' drude_ions.json: the DrudeLangevin runs at the reference step (the
    smallest) against the other DrudeLangevin steps and the SIM's, mean over the seeds ± its standard error, t against
    the reference in brackets; a column counts its runs that failed."""
    runs = seeds.load_runs(files)
    reference = seeds.steps_of(runs, "DrudeLangevin")[0]
    return seeds.markdown(seeds.drude_peer_columns(runs, runs, reference), SEED_TABLE_ROWS)


def main():
    repo_root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="a small, short run (smoke test)")
    parser.add_argument("--out", default=os.path.join(repo_root, "results", "drude_ions"), help="output folder")
    parser.add_argument("--production", type=float, default=3.0, help="ps sampled per run (default 3)")
    parser.add_argument("--burn-in", type=float, default=0.5, help="ps per run before sampling (default 0.5)")
    parser.add_argument("--reference-step", type=float, default=0.5, help="DrudeLangevin's step in fs (default 0.5)")
    parser.add_argument("--sim-steps", type=float, nargs="+", default=[1.5, 2.0],
                        help="SIM steps H in fs (default 1.5 2; README: 2.5 fs is not stable here)")
    parser.add_argument("--seed", type=int, default=1, help="random seed of the run (default 1)")
    parser.add_argument("--wall", type=float, default=0.0,
                        help="the hard wall (setMaxDrudeDistance) in nm of the SIM runs and the --wall-peers; 0 "
                             "(default) for none")
    parser.add_argument("--wall-peers", type=float, nargs="*", default=[], metavar="FS",
                        help="DrudeLangevin at these steps (fs) with the same --wall, the practitioner's peer "
                             "(default none)")
    parser.add_argument("--seed-table", nargs="+", metavar="JSON",
                        help="only print the table of these drude_ions.json files pooled over their seeds")
    add_timing_arguments(parser)
    args = parser.parse_args()
    if args.seed_table:
        print(seed_table(args.seed_table))
        return
    check_timing_arguments(parser, args)
    if args.quick:
        waters, pairs, cutoff, equilibration_ps = 64, 2, 0.55, 0.1
        settings = dict(production_ps=0.1, burn_ps=0.02, samples=6, blocks=2, scf_frames=2)
    else:
        waters, pairs, cutoff, equilibration_ps = 248, 4, 0.8, 1.0
        settings = dict(production_ps=args.production, burn_ps=args.burn_in, samples=60, blocks=6, scf_frames=6)
    begin = time.time()
    system, topology, positions = build(waters, pairs, cutoff, args.seed)
    analysis = Analysis(system, topology)
    print(f"{analysis.ions['NA']} Na+ and {analysis.ions['CL']} Cl- (SOD, CLA) in {waters} SWM4-NDP molecules: "
          f"{system.getNumParticles()} particles, {len(analysis.drudes)} Drude particles", flush=True)

    state = equilibrated(system, positions, args.seed, equilibration_ps, minimize=False)
    scf = SelfConsistent(system)   # on the original System

    separated = openmm.XmlSerializer.deserialize(openmm.XmlSerializer.serialize(system))
    StochasticImpulseIntegrator.separateDrudeSprings(separated, SPRING_GROUP)
    if run_timing(args, system, separated, state):
        return

    runs = [run_one(system, state, analysis, scf, "DrudeLangevin", args.reference_step, settings, args.seed + 2)]
    print(f"DrudeLangevin {args.reference_step} fs done", flush=True)
    def walled(run_system, kind, step_fs, seed):
        """A run with the --wall, or the record of its failure (a step too large blows up)."""
        try:
            runs.append(run_one(run_system, state, analysis, scf, kind, step_fs, settings, seed, args.wall))
        except openmm.OpenMMException as e:
            runs.append({"integrator": kind, "step_fs": step_fs, "failed": str(e)})
        print(f"{kind} {step_fs} fs (wall {args.wall:g} nm) done", flush=True)

    for step_fs in args.wall_peers:
        walled(system, "DrudeLangevin", step_fs, args.seed + 4)
    for step_fs in args.sim_steps:
        walled(separated, "WarpedMiddle", step_fs, args.seed + 3)

    names = [("induced_ratio", "induced / SCF, all"), ("induced_ratio_ions", "induced / SCF, ions"),
             ("t_drude", "T Drude (K)"), ("t_drude_max", "hottest frame (K)"), ("t_com", "T centre of mass (K)"),
             ("pe_per_pair", "PE per Drude pair"), ("ns_per_day", "ns/day")]
    print_runs(runs, names)
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "drude_ions.json"), "w") as out:
        json.dump({"waters": waters, "ions": analysis.ions, "settings": settings, "seed": args.seed,
                   "wall_seconds": time.time() - begin, "runs": runs}, out, indent=1)
    print(f"\n{time.time() - begin:.0f} s; written to {os.path.join(args.out, 'drude_ions.json')}")


if __name__ == "__main__":
    main()
