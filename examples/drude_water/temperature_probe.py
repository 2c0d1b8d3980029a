#!/usr/bin/env python3
"""Long single runs of SWM4-NDP water for the molecules' temperature, split into its classes of degrees of freedom.

Each peer (KIND:H:DRUDE_K: DrudeLangevin or a drude_water.py SIM kind, its step in fs and the Drude bath's
temperature in K) runs from one state (drude_water's 2-ps equilibration, seed 7), 1 ps of burn-in and --ps
picoseconds sampled every 10 fs, with the molecules' friction --friction and the Drude bath's --drude-friction (1/ps);
--neutral-drudes (diagnostic) switches the Drude pairs' charges off, --max-warped-phase sets the ...Limited kinds'
phase limit, --twin-of H:PHASE runs the DrudeLangevin peers on Drude particles as heavy as that SIM step makes them.
Per peer, mean ± standard error of 20 block means: T_COM as drude_water reports it (the Drude pairs' centres of mass
and the hydrogens, 6 degrees of freedom per rigid molecule), its translational and rotational parts, and the Drudes'
temperature.  Writes temperature_probe.json to --out and prints each peer as it finishes (progress every tenth of a
run).
"""

import argparse
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

BLOCKS = 20
SAMPLE_FS = 10.0


def parse_peer(text):
    """"KIND:H:DRUDE_K" -> (kind, step in fs, Drude bath in K); ValueError naming what is wrong."""
    parts = text.split(":")
    if len(parts) != 3:
        raise ValueError(f"peer {text!r}: expected KIND:H:DRUDE_K, e.g. WarpedMiddleLimitedScaled:2.5:1")
    kind, step, kelvin = parts[0], float(parts[1]), float(parts[2])
    if kind != "DrudeLangevin" and drude_water.sim_kind(kind)[0] not in ("Strang", "Filtered", "Warped"):
        raise ValueError(f"peer {text!r}: unknown kind {kind!r}")
    if not step > 0 or not kelvin > 0:
        raise ValueError(f"peer {text!r}: the step and the Drude temperature must be positive")
    return kind, step, kelvin


def parse_twin(text):
    """"H:PHASE" -> (step in fs, phase in rad) of the SIM step whose heavier-acting Drude a twin copies; ValueError
    naming what is wrong."""
    try:
        step, phase = (float(x) for x in text.split(":"))
    except ValueError:
        raise ValueError(f"--twin-of {text!r}: expected H:PHASE, e.g. 2.5:1.0") from None
    if not step > 0 or not 0 < phase <= math.pi:
        raise ValueError(f"--twin-of {text!r}: H must be positive and PHASE in (0, pi]")
    return step, phase


def temperature_classes(analysis, masses, blocks, v):
    """(T_COM, translational, rotational, Drude) temperatures of one frame of velocities (nm/ps)."""
    t_com, t_drude = analysis.temperatures(v)
    block_masses = masses[blocks]
    molecule_masses = block_masses.sum(axis=1)
    centre_velocities = np.einsum("mp,mpk->mk", block_masses, v[blocks]) / molecule_masses[:, None]
    translational = 0.5 * np.sum(molecule_masses[:, None] * centre_velocities**2)
    molecules = len(blocks)
    total = 0.5 * t_com * analysis.com_dof * drude_water.BOLTZ
    return (t_com, 2 * translational / ((3 * molecules - 3) * drude_water.BOLTZ),
            2 * (total - translational) / (3 * molecules * drude_water.BOLTZ), t_drude)


def neutral_drudes(system):
    """Diagnostic: the Drude pairs' charges off in the NonbondedForce (each pair is neutral in SWM4-NDP, so the
    System stays neutral), springs, masses and constraints kept: a Drude is then a neutral mass on its core's spring,
    which no field moves."""
    drude = next(f for f in system.getForces() if isinstance(f, openmm.DrudeForce))
    nonbonded = next(f for f in system.getForces() if isinstance(f, openmm.NonbondedForce))
    paired = set()
    for i in range(drude.getNumParticles()):
        particle, core = drude.getParticleParameters(i)[:2]
        paired.update((particle, core))
    if abs(sum(nonbonded.getParticleParameters(p)[0].value_in_unit(unit.elementary_charge) for p in paired)) > 1e-9:
        raise ValueError("the Drude pairs are not neutral")
    for p in paired:
        _, sigma, epsilon = nonbonded.getParticleParameters(p)
        nonbonded.setParticleParameters(p, 0.0, sigma, epsilon)
    for i in range(nonbonded.getNumExceptions()):
        a, b, _, sigma, epsilon = nonbonded.getExceptionParameters(i)
        if a in paired or b in paired:
            nonbonded.setExceptionParameters(i, a, b, 0.0, sigma, epsilon)


def run_peer(system, state, analysis, kind, step_fs, drude_kelvin, friction, picoseconds, burn_ps,
             drude_friction_scale=1.0):
    integrator = drude_water.make_integrator(kind, step_fs, 11, drude_kelvin=drude_kelvin,
                                             drude_friction_scale=drude_friction_scale)
    integrator.setFriction(friction / unit.picosecond)
    context = openmm.Context(system, integrator, openmm.Platform.getPlatformByName("CPU"), {"Threads": "2"})
    context.setState(state)
    integrator.step(int(round(burn_ps * 1000 / step_fs)))
    every = max(1, int(round(SAMPLE_FS / step_fs)))
    samples = int(round(picoseconds * 1000 / step_fs)) // every
    blocks = np.array(analysis.blocks)
    series = []
    started = time.time()
    for i in range(samples):
        integrator.step(every)
        v = context.getState(getVelocities=True).getVelocities(asNumpy=True)
        series.append(temperature_classes(analysis, analysis.masses, blocks,
                                          v.value_in_unit(unit.nanometer / unit.picosecond)))
        if (i + 1) % max(1, samples // 10) == 0:
            print(f"  {kind} {step_fs:g} fs, Drudes {drude_kelvin:g} K: {100 * (i + 1) // samples} % "
                  f"({time.time() - started:.0f} s)", flush=True)
    series = np.array(series)
    usable = len(series) // BLOCKS * BLOCKS
    block_means = series[:usable].reshape(BLOCKS, -1, series.shape[1]).mean(axis=1)
    result = {}
    for column, name in enumerate(("t_com", "t_translational", "t_rotational", "t_drude")):
        result[name] = [float(series[:, column].mean()),
                        float(block_means[:, column].std(ddof=1) / math.sqrt(BLOCKS))]
    return result


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--peers", nargs="+", required=True, metavar="KIND:H:DRUDE_K",
                        help="e.g. DrudeLangevin:1:1 WarpedMiddleLimitedScaled:2.5:1 WarpedMiddleLimitedScaled:2.5:300")
    parser.add_argument("--ps", type=float, default=200.0, help="picoseconds sampled per peer (default 200)")
    parser.add_argument("--friction", type=float, default=5.0, help="the molecules' friction, 1/ps (default 5)")
    parser.add_argument("--drude-friction", type=float, default=drude_water.DRUDE_FRICTION_PER_PS,
                        help="the Drude bath's friction, 1/ps (default %(default)g)")
    parser.add_argument("--max-warped-phase", type=float, default=drude_water.MAX_WARPED_PHASE,
                        help="the ...Limited kinds' setMaxWarpedPhase, radians (default %(default)g)")
    parser.add_argument("--twin-of", metavar="H:PHASE", help="DrudeLangevin peers on Drude particles as heavy as a "
                        "SIM step H (fs) that flows the Drude by PHASE makes them act, their friction scaled as "
                        "setWarpedFrictionScaling scales the SIM's (drude_water.heavy_drude_system)")
    parser.add_argument("--out", default=".", help="folder for temperature_probe.json (default .)")
    parser.add_argument("--neutral-drudes", action="store_true", help="diagnostic: the Drude pairs' charges off "
                        "(neutral_drudes), so that no field drives the Drudes")
    parser.add_argument("--quick", action="store_true", help="a small, short run (smoke test): 125 molecules, "
                        "0.05 ps of equilibration and burn-in, 0.2 ps sampled")
    args = parser.parse_args()
    try:
        peers = [parse_peer(p) for p in args.peers]
    except ValueError as error:
        parser.error(str(error))
    if not args.ps > 0:
        parser.error("--ps must be positive (got %g)" % args.ps)
    if not args.friction > 0:
        parser.error("--friction must be positive (got %g)" % args.friction)
    if not args.drude_friction > 0:
        parser.error("--drude-friction must be positive (got %g)" % args.drude_friction)
    if not 0 < args.max_warped_phase < math.pi:
        parser.error("--max-warped-phase must be in (0, pi) (got %g)" % args.max_warped_phase)
    drude_water.MAX_WARPED_PHASE = args.max_warped_phase
    try:
        twin_of = parse_twin(args.twin_of) if args.twin_of else None
    except ValueError as error:
        parser.error(str(error))
    molecules, equilibration_steps, burn_ps = (125, 50, 0.05) if args.quick else (256, 2000, 1.0)
    picoseconds = 0.2 if args.quick else args.ps
    system, _, positions, _ = drude_water.build_water(molecules)
    if args.neutral_drudes:
        neutral_drudes(system)
    # What each kind runs on: (System, its Analysis, Drude friction scale, label suffix).
    runs_on = {"SIM": (system, drude_water.Analysis(system), 1.0, "")}
    runs_on["DrudeLangevin"] = runs_on["SIM"]
    if twin_of:
        heavy, mass, ratio = drude_water.heavy_drude_system(system, drude_water.response_frequency(*twin_of))
        runs_on["DrudeLangevin"] = (heavy, drude_water.Analysis(heavy), ratio, "_twin")
    state = drude_water.equilibrated_state(system, positions, 1.0, equilibration_steps, 7)
    report = {"molecules": molecules, "picoseconds": picoseconds, "burn_in_ps": burn_ps,
              "neutral_drudes": args.neutral_drudes,
              "friction_per_ps": args.friction, "drude_friction_per_ps": args.drude_friction,
              "max_warped_phase": args.max_warped_phase, "blocks": BLOCKS, "quick": args.quick, "peers": {}}
    os.makedirs(args.out, exist_ok=True)
    if twin_of:
        report["twin_of"], report["twin_drude_mass_amu"] = args.twin_of, mass
    for kind, step_fs, kelvin in peers:
        peer_system, analysis, friction_scale, suffix = runs_on["DrudeLangevin" if kind == "DrudeLangevin" else "SIM"]
        label = f"{kind}_{step_fs:g}fs_Drudes{kelvin:g}K{suffix}"
        report["peers"][label] = run_peer(
            peer_system, state, analysis, kind, step_fs, kelvin, args.friction, picoseconds, burn_ps,
            friction_scale * args.drude_friction / drude_water.DRUDE_FRICTION_PER_PS)
        print(label, ", ".join(f"{k} {m:.2f} ± {e:.2f}" for k, (m, e) in report["peers"][label].items()), flush=True)
        with open(os.path.join(args.out, "temperature_probe.json"), "w") as f:
            json.dump(report, f, indent=1)


if __name__ == "__main__":
    main()
