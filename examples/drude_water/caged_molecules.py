#!/usr/bin/env python3
"""The molecules' lean in its smallest setting: independent SWM4-NDP molecules, each in its own cage.

In SWM4-NDP water the SIM's molecules read a little cold (docs/sim_drude.md section 7, "The molecules' lean"), and
100-ps runs of the 256-molecule box take minutes per peer.  Here, with both baths off (--nve), the earlier treatment
of constrained Drude cores showed the step's energy loss that caused most of it (docs/sim_drude.md section 2).  Every
molecule sits alone in a static cage: its atoms tethered to their start positions (harmonic, --trap-o on the oxygen,
--trap-h on each hydrogen; the Drude particle and the virtual site free) and every charge in the same static
potential about its molecule's oxygen site c,

    phi(r) = -E0 . (r - c) - (g/2) (x^2 + y^2 - 2 z^2 + x y),   (x, y, z) = r - c,

a field E0 + g (x + y/2, y + x/2, -2 z) (--e0 in kJ/mol/nm/e along (0.6, 0, 0.8), --gradient g in kJ/mol/nm^2/e),
so that each Drude follows a field that changes as its molecule moves. No intermolecular forces, no PME: 100 ps of 512
molecules take about a minute on one core for the SIM at 2.5 fs, two for DrudeLangevin at 0.5 fs. Peers: KIND:H (fs),
KIND as in drude_water.make_integrator (DrudeLangevin, WarpedMiddle, WarpedMiddleScaled, FilteredMiddle, ...);
"Twin:H:SIM_H:PHASE" runs DrudeLangevin at H on Drude particles as heavy as a SIM step SIM_H that flows the Drude by
PHASE makes them act (drude_water.heavy_drude_system, friction scaled as setWarpedFrictionScaling scales the SIM's).
--no-gradient and --no-field set g = 0 or E0 = g = 0; --free-pairs cages SWM4-NDP's Drude pair alone (no hydrogens, no
constraints). Every peer starts from one equilibrated state (DrudeLangevin 0.5 fs, 2 ps), burns in 1 ps and samples the
molecules' temperature (centres of mass of the Drude pairs and the hydrogens, as drude_water.Analysis), the Drude
temperature and the cage's potential energy per molecule (a configurational reading of the molecules' temperature:
calibrate it with --temperature) every 10 fs; errors are standard errors of 20 block means. --seed S gives an
independent replica (another start, other random numbers); --temperature sets the molecules' bath for every peer; --nve
turns both baths off and reports each peer's energy drift per molecule (KIND Verlet: OpenMM's VerletIntegrator as the
exact peer).

    PYTHONPATH=build/python .venv/bin/python examples/drude_water/caged_molecules.py \
        --peers DrudeLangevin:0.5 WarpedMiddleScaled:2.5 Twin:0.5:2.5:2.05 [--friction 5] [--ps 100] [--out DIR]

Writes caged_molecules.json to --out and prints each peer as it finishes.
"""

import argparse
import copy
import json
import math
import os
import sys
import time

import numpy as np
import openmm
import openmm.unit as unit

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import drude_water  # noqa: E402
from flavorbench import seeds  # noqa: E402
from flavorbench.timeseries import block_error  # noqa: E402

FIELD_DIRECTION = np.array([0.6, 0.0, 0.8])
CAGE_ENERGY = ("q*(-(e0x*dx + e0y*dy + e0z*dz) - 0.5*g*(dx*dx + dy*dy - 2*dz*dz + dx*dy))"
               " + 0.5*tether*((x - x0)^2 + (y - y0)^2 + (z - z0)^2);"
               " dx = x - cx; dy = y - cy; dz = z - cz")
SAMPLE_FS = 10.0
BLOCKS = 20
BURN_IN_PS = 1.0
# Molecules far apart: the cages do not interact, so the spacing only keeps coordinates readable.
CAGE_DENSITY = 0.02  # g/cm^3


def cage_field(e0, gradient, r):
    """The cage's field (kJ/mol/nm/e) at r - c = r: minus the gradient of phi."""
    x, y, z = r
    return e0 * FIELD_DIRECTION + gradient * np.array([x + 0.5 * y, y + 0.5 * x, -2.0 * z])


def make_cage(e0, gradient):
    """The cage force, without particles: per particle (q, c, tether, start position)."""
    cage = openmm.CustomExternalForce(CAGE_ENERGY)
    for name in ("q", "cx", "cy", "cz", "tether", "x0", "y0", "z0"):
        cage.addPerParticleParameter(name)
    for axis, value in zip("xyz", e0 * FIELD_DIRECTION):
        cage.addGlobalParameter("e0" + axis, value)
    cage.addGlobalParameter("g", gradient)
    return cage


def build_caged(molecules, e0, gradient, trap_o, trap_h):
    """(System, positions in nm, Analysis) of `molecules` caged SWM4-NDP molecules: swm4ndp.xml's molecules, their
    NonbondedForce replaced by the cage (each particle's charge in phi about its oxygen's start position; oxygens and
    hydrogens tethered to where they start)."""
    system, _, positions, _ = drude_water.build_water(molecules, density=CAGE_DENSITY)
    analysis = drude_water.Analysis(system)
    nonbonded = next(f for f in system.getForces() if isinstance(f, openmm.NonbondedForce))
    charges = [nonbonded.getParticleParameters(i)[0].value_in_unit(unit.elementary_charge)
               for i in range(system.getNumParticles())]
    for i in reversed(range(system.getNumForces())):
        if isinstance(system.getForce(i), (openmm.NonbondedForce, openmm.CMMotionRemover)):
            system.removeForce(i)
    positions = np.array(positions.value_in_unit(unit.nanometer))
    cage = make_cage(e0, gradient)
    tethers = {int(o): trap_o for o in analysis.cores}
    tethers.update({int(h): trap_h for h in analysis.hydrogens})
    for block in analysis.blocks:
        centre = positions[block[0]]
        for i in block:
            cage.addParticle(int(i), [charges[i], *centre, tethers.get(int(i), 0.0), *positions[i]])
    system.addForce(cage)
    # Every particle's momentum is free to change (tethers), so no degree of freedom is lost to a conserved momentum.
    analysis.com_dof = 3 * (len(analysis.cores) + len(analysis.hydrogens)) - system.getNumConstraints()
    return system, positions, analysis


class FreePairAnalysis:
    """drude_water.Analysis's temperatures for Drude pairs without hydrogens or constraints."""

    temperatures = drude_water.Analysis.temperatures

    def __init__(self, system, cores, drudes):
        self.masses = np.array([system.getParticleMass(i).value_in_unit(unit.dalton)
                                for i in range(system.getNumParticles())])
        self.cores, self.drudes, self.hydrogens = np.array(cores), np.array(drudes), np.array([], dtype=int)
        self.com_dof, self.drude_dof = 3 * len(cores), 3 * len(drudes)


def build_free_pairs(pairs, e0, gradient, trap_o):
    """(System, positions, analysis) of SWM4-NDP's Drude pair alone (its core's and Drude particle's masses, charges
    and spring; no hydrogens, no constraints), each pair in its own cage, the core tethered."""
    water, _, _, _ = drude_water.build_water(1, density=CAGE_DENSITY)
    template = drude_water.Analysis(water)
    spring = next(f for f in water.getForces() if isinstance(f, openmm.DrudeForce))
    _, _, _, _, _, charge, alpha, _, _ = spring.getParticleParameters(0)
    charge = charge.value_in_unit(unit.elementary_charge)
    core_mass, drude_mass = (template.masses[template.cores[0]], template.masses[template.drudes[0]])
    system = openmm.System()
    drude = openmm.DrudeForce()
    drude.setForceGroup(drude_water.DRUDE_GROUP)
    cage = make_cage(e0, gradient)
    side = int(math.ceil(pairs ** (1 / 3) - 1e-9))
    positions, cores, drudes = [], [], []
    for n in range(pairs):
        centre = np.array([n % side, (n // side) % side, n // side**2], dtype=float)
        core, particle = system.addParticle(core_mass), system.addParticle(drude_mass)
        drude.addParticle(particle, core, -1, -1, -1, charge, alpha, 1, 1)
        cage.addParticle(core, [-charge, *centre, trap_o, *centre])
        cage.addParticle(particle, [charge, *centre, 0.0, *centre])
        positions += [centre, centre]
        cores.append(core)
        drudes.append(particle)
    system.addForce(drude)
    system.addForce(cage)
    system.setDefaultPeriodicBoxVectors(*(np.eye(3) * (side + 1)))
    return system, np.array(positions), FreePairAnalysis(system, cores, drudes)


def parse_peer(text):
    """"KIND:H" or "Twin:H:SIM_H:PHASE" -> (label, kind, H, twin or None); ValueError naming what is wrong."""
    parts = text.split(":")
    try:
        if parts[0] == "Twin" and len(parts) == 4:
            step, sim_step, phase = (float(x) for x in parts[1:])
            if not (step > 0 and sim_step > 0 and 0 < phase <= math.pi):
                raise ValueError
            return text, "DrudeLangevin", step, (sim_step, phase)
        if len(parts) != 2 or parts[0] == "Twin" or not float(parts[1]) > 0:
            raise ValueError
        return text, parts[0], float(parts[1]), None
    except ValueError:
        raise ValueError(f"peer {text!r}: expected KIND:H or Twin:H:SIM_H:PHASE with positive steps and "
                         "0 < PHASE <= pi") from None


def run_peer(system, analysis, state, kind, step_fs, twin, friction, picoseconds, threads, seed=11, kelvin=300.0):
    """The peer's mean molecular and Drude temperatures (K), the cage's potential energy per molecule (kJ/mol: tethers
    and field, a configurational measure of the molecules' temperature), each with its standard error, and the mean
    |d| (nm); seed: the integrator's random number seed; kelvin: the molecules' bath."""
    friction_scale = 1.0
    if twin:
        system, _, friction_scale = drude_water.heavy_drude_system(system, drude_water.response_frequency(*twin))
        analysis = copy.copy(analysis)
        analysis.masses = np.array([system.getParticleMass(i).value_in_unit(unit.dalton)
                                    for i in range(system.getNumParticles())])
    integrator = drude_water.make_integrator(kind, step_fs, seed, drude_friction_scale=friction_scale)
    integrator.setFriction(friction / unit.picosecond)
    integrator.setTemperature(kelvin * unit.kelvin)
    context = openmm.Context(system, integrator, openmm.Platform.getPlatformByName("CPU"), {"Threads": str(threads)})
    context.setState(state)
    integrator.step(int(round(BURN_IN_PS * 1000 / step_fs)))
    every = max(1, int(round(SAMPLE_FS / step_fs)))
    samples = max(BLOCKS, int(round(picoseconds * 1000 / step_fs)) // every)
    series, displacement = [], 0.0
    cage_groups = {f.getForceGroup() for f in system.getForces() if isinstance(f, openmm.CustomExternalForce)}
    for _ in range(samples):
        integrator.step(every)
        frame = context.getState(getVelocities=True, getPositions=True)
        v = frame.getVelocities(asNumpy=True).value_in_unit(unit.nanometer / unit.picosecond)
        x = frame.getPositions(asNumpy=True).value_in_unit(unit.nanometer)
        cage = context.getState(getEnergy=True, groups=cage_groups).getPotentialEnergy()
        series.append((*analysis.temperatures(v), cage.value_in_unit(unit.kilojoule_per_mole) / len(analysis.cores)))
        displacement += np.linalg.norm(x[analysis.drudes] - x[analysis.cores], axis=1).mean()
    series = np.array(series)
    result = {name: list(block_error(series[:, k], BLOCKS))
              for k, name in enumerate(("t_com", "t_drude", "cage_energy"))}
    result["drude_displacement_nm"] = displacement / samples
    return result


def energy_drift(system, analysis, state, kind, step_fs, picoseconds, threads, seed=11):
    """Both baths off: the slope of the total energy per molecule (kJ/mol/ps, a line fitted to frames every 20 fs) and
    the molecules' and Drude temperatures over the first and the last picosecond.  KIND "Verlet" runs OpenMM's
    VerletIntegrator (DrudeLangevin has no zero friction); the SIM runs with friction 0 on both baths."""
    if kind == "Verlet":
        integrator = openmm.VerletIntegrator(step_fs * unit.femtosecond)
    elif kind == "DrudeLangevin":
        raise ValueError("--nve: DrudeLangevin cannot run without friction; use Verlet:H")
    else:
        integrator = drude_water.make_integrator(kind, step_fs, seed)
        integrator.setFriction(0.0)
        integrator.setStiffModeFriction(0.0)
    context = openmm.Context(system, integrator, openmm.Platform.getPlatformByName("CPU"), {"Threads": str(threads)})
    context.setState(state)
    every = max(1, int(round(20.0 / step_fs)))
    frames = max(100, int(round(picoseconds * 1000 / (every * step_fs))))
    times, energies, temperatures = [], [], []
    for n in range(frames):
        integrator.step(every)
        frame = context.getState(getEnergy=True, getVelocities=True)
        times.append((n + 1) * every * step_fs / 1000)
        energies.append((frame.getKineticEnergy() + frame.getPotentialEnergy()).value_in_unit(unit.kilojoule_per_mole)
                        / len(analysis.cores))
        temperatures.append(analysis.temperatures(frame.getVelocities(asNumpy=True).value_in_unit(
            unit.nanometer / unit.picosecond)))
    temperatures = np.array(temperatures)
    edge = max(1, int(round(1.0 / (every * step_fs / 1000))))
    return {"drift_per_molecule": float(np.polyfit(times, energies, 1)[0]),
            "t_com_first_last": [float(temperatures[:edge, 0].mean()), float(temperatures[-edge:, 0].mean())],
            "t_drude_first_last": [float(temperatures[:edge, 1].mean()), float(temperatures[-edge:, 1].mean())]}


def seed_table(files, reference):
    """The Markdown table of several replicas' caged_molecules.json (--seed S): per peer the mean over the replicas ±
    its standard error (from each run's block error) and, in brackets, its difference from the `reference` peer in
    combined standard errors.  Peers run with the molecules' bath at another temperature than 300 K are named with it
    ("@ 297 K")."""
    columns = {}
    for path in files:
        with open(path) as f:
            report = json.load(f)
        bath = report.get("temperature", 300.0)
        for label, result in report["peers"].items():
            name = label if bath == 300.0 else f"{label} @ {bath:g} K"
            columns.setdefault(name, []).append(result)
    if reference not in columns:
        raise ValueError(f"reference peer {reference!r} is in none of the files (peers: {', '.join(columns)})")
    ordered = [(reference, columns.pop(reference))] + list(columns.items())
    rows = [("t_com", "T molecules (K)", "%.2f", 1.0), ("t_drude", "T Drude (K)", "%.3f", 1.0),
            ("cage_energy", "cage energy (kJ/mol per molecule)", "%.4f", 1.0)]
    return seeds.markdown(ordered, rows, within=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--peers", nargs="+", metavar="KIND:H", help="the peers to run (required unless --seed-table)")
    parser.add_argument("--seed-table", nargs="+", metavar="JSON",
                        help="only print the table of these caged_molecules.json files pooled over their replicas")
    parser.add_argument("--reference", default="DrudeLangevin:0.25",
                        help="the --seed-table's reference peer (default DrudeLangevin:0.25)")
    parser.add_argument("--molecules", type=int, default=512, help="caged molecules (default 512)")
    parser.add_argument("--ps", type=float, default=100.0, help="picoseconds sampled per peer (default 100)")
    parser.add_argument("--friction", type=float, default=5.0, help="the molecules' friction, 1/ps (default 5)")
    parser.add_argument("--temperature", type=float, default=300.0,
                        help="the molecules' bath, K (default 300; the start is equilibrated at 300 K)")
    parser.add_argument("--e0", type=float, default=1500.0, help="uniform field, kJ/mol/nm/e (default 1500)")
    parser.add_argument("--gradient", type=float, default=3e4, help="field gradient g, kJ/mol/nm^2/e (default 3e4)")
    parser.add_argument("--no-gradient", action="store_true", help="g = 0: each Drude's field stays what it is")
    parser.add_argument("--no-field", action="store_true", help="E0 = g = 0")
    parser.add_argument("--trap-o", type=float, default=1e5, help="oxygen tether, kJ/mol/nm^2 (default 1e5)")
    parser.add_argument("--trap-h", type=float, default=2e4, help="hydrogen tether, kJ/mol/nm^2 (default 2e4)")
    parser.add_argument("--free-pairs", action="store_true", help="SWM4-NDP's Drude pairs alone (no hydrogens, no "
                        "constraints), each core tethered by --trap-o")
    parser.add_argument("--seed", type=int, default=0, help="added to the start's and every peer's random number "
                        "seeds: independent replicas (default 0)")
    parser.add_argument("--nve", action="store_true", help="both baths off: each peer's energy drift per molecule "
                        "(kJ/mol/ps) over --ps (KIND Verlet: OpenMM's VerletIntegrator)")
    parser.add_argument("--threads", type=int, default=1, help="CPU platform threads (default 1)")
    parser.add_argument("--out", default=".", help="folder for caged_molecules.json (default .)")
    parser.add_argument("--quick", action="store_true", help="a small, short run (smoke test): 32 molecules, "
                        "0.2 ps sampled")
    args = parser.parse_args()
    peers = seeds.print_table_or_parse_peers(parser, args, seed_table, parse_peer)
    if peers is None:
        return
    for name in ("ps", "friction", "temperature", "trap_o", "trap_h"):
        if not getattr(args, name) > 0:
            parser.error(f"--{name.replace('_', '-')} must be positive (got {getattr(args, name):g})")
    if args.molecules < 1 or args.threads < 1:
        parser.error("--molecules and --threads must be at least 1")
    e0 = 0.0 if args.no_field else args.e0
    gradient = 0.0 if args.no_field or args.no_gradient else args.gradient
    molecules, picoseconds = (32, 0.2) if args.quick else (args.molecules, args.ps)
    if args.free_pairs:
        system, positions, analysis = build_free_pairs(molecules, e0, gradient, args.trap_o)
    else:
        system, positions, analysis = build_caged(molecules, e0, gradient, args.trap_o, args.trap_h)
    state = drude_water.equilibrated_state(system, positions * unit.nanometer, 0.5, 200 if args.quick else 4000,
                                           7 + args.seed, threads=args.threads)
    report = {"molecules": molecules, "picoseconds": picoseconds, "friction_per_ps": args.friction,
              "temperature": args.temperature, "e0": e0,
              "gradient": gradient, "free_pairs": args.free_pairs, "trap_o": args.trap_o, "trap_h": args.trap_h,
              "blocks": BLOCKS, "quick": args.quick, "seed": args.seed, "nve": args.nve, "peers": {}}
    os.makedirs(args.out, exist_ok=True)
    for label, kind, step_fs, twin in peers:
        started = time.time()
        if args.nve:
            if twin:
                parser.error(f"--nve: {label} runs DrudeLangevin, which cannot run without friction; use Verlet:H")
            try:
                result = energy_drift(system, analysis, state, kind, step_fs, picoseconds, args.threads, 11 + args.seed)
            except ValueError as error:
                parser.error(str(error))
            line = (f"drift {result['drift_per_molecule']:+.5f} kJ/mol/ps per molecule   T_COM "
                    f"{result['t_com_first_last'][0]:.2f} -> {result['t_com_first_last'][1]:.2f} K   T_Drude "
                    f"{result['t_drude_first_last'][0]:.3f} -> {result['t_drude_first_last'][1]:.3f} K")
        else:
            result = run_peer(system, analysis, state, kind, step_fs, twin, args.friction, picoseconds, args.threads,
                              11 + args.seed, args.temperature)
            line = (f"T_COM {result['t_com'][0]:7.2f} ± {result['t_com'][1]:.2f} K   T_Drude "
                    f"{result['t_drude'][0]:.3f} ± {result['t_drude'][1]:.3f} K   cage "
                    f"{result['cage_energy'][0]:.4f} ± {result['cage_energy'][1]:.4f} kJ/mol   |d| "
                    f"{result['drude_displacement_nm']:.5f} nm")
        report["peers"][label] = result
        print(f"{label:24s} {line}   ({time.time() - started:.0f} s)", flush=True)
        with open(os.path.join(args.out, "caged_molecules.json"), "w") as f:
            json.dump(report, f, indent=1)


if __name__ == "__main__":
    main()
