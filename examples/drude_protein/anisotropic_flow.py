#!/usr/bin/env python3
"""Anisotropic Drude springs: their anisotropic terms left soft against taken into the stiff flow, where both are exact.

A Drude-2019 anisotropic Drude particle (the carbonyl oxygens' of examples/drude_protein) has the spring
0.5 k |d|^2 + 0.5 k1 (d.u1)^2 + 0.5 k2 (d.u2)^2, d its displacement from its core, u1 and u2 unit vectors along axes
that its core's neighbours define.  separateDrudeSprings puts the isotropic term into the stiff group and leaves the
anisotropic terms soft; a locally quadratic stiff flow would take them into the Drude's exact flow with the axes of
the step's start.  Here the axes are fixed in space, so that the anisotropic terms are exactly quadratic and both
treatments integrate one System, differing only in what the stiff flow holds: `Soft:H` (the anisotropic terms
soft, as separateDrudeSprings leaves them) against `Flow:H` (in the stiff group: what the locally quadratic flow
would do at H, without the error of axes turning within a step).

The System: --pairs Drude pairs with the carbonyl oxygen's masses (core 15.5994, Drude 0.4 amu), Drude charge
(-1.3205 e), polarizability and anisotropy (aniso12 0.82322, aniso34 1.14332: k = 404,854 kJ/mol/nm^2,
k1 = +0.255 k, k2 = -0.096 k; --aniso12, --aniso34 for others), the core's charge +0.8205 e; each pair's axes drawn at
random; each core tethered (--trap, kJ/mol/nm^2) to its start in caged_molecules.py's static field with a gradient,
E0 + g (x + y/2, y + x/2, -2 z) about its start (--e0, --gradient), so that each Drude follows a field that changes as
its core moves.  Baths: the cores 300 K at 5/ps, the Drudes 1 K at 20/ps (DrudeLangevinIntegrator's pairs' centres
of mass and relative motion; the SIM's zero and stiff modes, Warped with the Middle placement).

Peers: `DrudeLangevin:H`, `Soft:H`, `Flow:H`, the SIM ones with `:PHASE` appended run setMaxWarpedPhase(PHASE) and
setWarpedFrictionScaling(True).  Observables (every 10 fs, standard errors of 20 block means): the induced dipoles
relative to the self-consistent ones along u1, u2 and u3 = u1 x u2 (sum of d.u d_SCF.u over sum of (d_SCF.u)^2; the
field is linear, so d_SCF solves (K - q_D G) d = q_D E(core) exactly), the Drude temperature from the relative
velocities and from the positions, (d - d_SCF)^T (K - q_D G) (d - d_SCF) / (3 k_B), which does not depend on the
Drude's mass, and the cores' temperature.

    PYTHONPATH=build/python .venv/bin/python examples/drude_protein/anisotropic_flow.py \
        --peers DrudeLangevin:0.25 Soft:2 Flow:2 Soft:3:1.77 Flow:3:1.77 [--pairs 512] [--ps 100] [--out DIR]
    PYTHONPATH=build/python .venv/bin/python examples/drude_protein/anisotropic_flow.py --seed-table JSON ...

Writes anisotropic_flow.json to --out and prints each peer as it finishes.
"""
import argparse
import json
import math
import os
import time

import numpy as np
import openmm
import openmm.unit as unit
from flavorbench import seeds
from flavorbench.runners import KB
from flavorbench.timeseries import block_error
from openmmflavors import StochasticImpulseIntegrator

ONE_4PI_EPS0 = 138.935456  # kJ/mol nm / e^2, as OpenMM's kernels
CORE_MASS, DRUDE_MASS = 15.5994, 0.4
DRUDE_CHARGE, CORE_CHARGE = -1.32047010809149, 0.82047010809149
POLARIZABILITY = 0.000579  # nm^3
CAGE_GROUP, SPRING_GROUP, ANISOTROPIC_GROUP = 0, 1, 2
SAMPLE_FS, BLOCKS, BURN_IN_PS = 10.0, 20, 1.0
RUN_AWAY_NM = 0.05  # a Drude this far from its core (ten times its displacement in the field) has blown up
SPACING = 1.0  # nm between the pairs' cages: they do not interact, the spacing only keeps coordinates readable
OBSERVABLES = ("induced_u1", "induced_u2", "induced_u3", "t_drude", "t_drude_config", "t_cores")


def spring_constants(aniso12, aniso34):
    """(k, k1, k2) of OpenMM's DrudeForce: the isotropic term and the two anisotropic ones, kJ/mol/nm^2."""
    a3 = 3.0 - aniso12 - aniso34
    scale = ONE_4PI_EPS0 * DRUDE_CHARGE**2 / POLARIZABILITY
    return scale / a3, scale * (1 / aniso12 - 1 / a3), scale * (1 / aniso34 - 1 / a3)


def field_gradient(gradient):
    """G of the cage's field E0 + G (r - c)."""
    return gradient * np.array([[1.0, 0.5, 0.0], [0.5, 1.0, 0.0], [0.0, 0.0, -2.0]])


class Pairs:
    """The System of independent caged anisotropic Drude pairs, and its analysis."""

    def __init__(self, pairs, aniso12, aniso34, e0, gradient, trap, seed):
        self.k, self.k1, self.k2 = spring_constants(aniso12, aniso34)
        rng = np.random.default_rng(seed)
        u1 = rng.normal(size=(pairs, 3))
        u1 /= np.linalg.norm(u1, axis=1)[:, None]
        u2 = np.cross(u1, rng.normal(size=(pairs, 3)))
        u2 /= np.linalg.norm(u2, axis=1)[:, None]
        self.axes = np.stack([u1, u2, np.cross(u1, u2)], axis=1)  # pairs x 3 x 3, rows the unit vectors
        self.e0 = e0 * np.array([0.6, 0.0, 0.8])
        self.gradient = field_gradient(gradient)
        side = int(np.ceil(pairs ** (1 / 3) - 1e-9))
        n = np.arange(pairs)
        self.centres = SPACING * np.stack([n % side, (n // side) % side, n // side**2], axis=1).astype(float)
        self.cores, self.drudes = 2 * n, 2 * n + 1
        spring = (self.k * np.eye(3) + self.k1 * np.einsum("pi,pj->pij", u1, u1)
                  + self.k2 * np.einsum("pi,pj->pij", u2, u2))
        self.response = spring - DRUDE_CHARGE * self.gradient  # the Drude's stiffness in the cage: K - q_D G
        self.system = self._system(e0, gradient, trap, u1, u2)
        self.positions = np.repeat(self.centres, 2, axis=0)

    def _system(self, e0, gradient, trap, u1, u2):
        system = openmm.System()
        drude = openmm.DrudeForce()
        drude.setForceGroup(SPRING_GROUP)
        anisotropic = openmm.CustomCompoundBondForce(
            2, "0.5*k1*p1^2 + 0.5*k2*p2^2; p1 = (x2-x1)*u1x + (y2-y1)*u1y + (z2-z1)*u1z;"
               " p2 = (x2-x1)*u2x + (y2-y1)*u2y + (z2-z1)*u2z")
        for name in ("k1", "k2", "u1x", "u1y", "u1z", "u2x", "u2y", "u2z"):
            anisotropic.addPerBondParameter(name)
        anisotropic.setForceGroup(ANISOTROPIC_GROUP)
        cage = openmm.CustomExternalForce(
            "q*(-(e0x*dx + e0y*dy + e0z*dz) - 0.5*g*(dx*dx + dy*dy - 2*dz*dz + dx*dy)) + 0.5*tether*(dx^2 + dy^2 + dz^2);"
            " dx = x - cx; dy = y - cy; dz = z - cz")
        for name in ("q", "cx", "cy", "cz", "tether"):
            cage.addPerParticleParameter(name)
        for axis, value in zip("xyz", self.e0):
            cage.addGlobalParameter("e0" + axis, value)
        cage.addGlobalParameter("g", gradient)
        cage.setForceGroup(CAGE_GROUP)
        # The DrudeForce's polarizability is scaled by a3 so that its isotropic spring (no axes given) is k.
        a3 = ONE_4PI_EPS0 * DRUDE_CHARGE**2 / (POLARIZABILITY * self.k)
        for i, centre in enumerate(self.centres):
            core, particle = system.addParticle(CORE_MASS), system.addParticle(DRUDE_MASS)
            drude.addParticle(particle, core, -1, -1, -1, DRUDE_CHARGE, POLARIZABILITY * a3, 1, 1)
            anisotropic.addBond([core, particle], [self.k1, self.k2, *u1[i], *u2[i]])
            cage.addParticle(core, [CORE_CHARGE, *centre, trap])
            cage.addParticle(particle, [DRUDE_CHARGE, *centre, 0.0])
        for force in (drude, anisotropic, cage):
            system.addForce(force)
        return system

    def self_consistent(self, x):
        """The Drude displacements that zero the force on each Drude at the cores' positions x[cores]."""
        field = self.e0 + (x[self.cores] - self.centres) @ self.gradient.T
        return np.linalg.solve(self.response, DRUDE_CHARGE * field[:, :, None])[:, :, 0]

    def observables(self, x, v):
        d = x[self.drudes] - x[self.cores]
        scf = self.self_consistent(x)
        lag = d - scf
        along, along_scf = np.einsum("pai,pi->pa", self.axes, d), np.einsum("pai,pi->pa", self.axes, scf)
        values = {f"induced_u{a + 1}": (np.sum(along[:, a] * along_scf[:, a]), np.sum(along_scf[:, a]**2))
                  for a in range(3)}
        total = CORE_MASS + DRUDE_MASS
        centre_of_mass = (CORE_MASS * v[self.cores] + DRUDE_MASS * v[self.drudes]) / total
        relative = v[self.drudes] - v[self.cores]
        dof = 3 * len(self.cores)
        values["t_cores"] = total * np.sum(centre_of_mass**2) / (dof * KB)
        values["t_drude"] = CORE_MASS * DRUDE_MASS / total * np.sum(relative**2) / (dof * KB)
        values["t_drude_config"] = np.einsum("pi,pij,pj->", lag, self.response, lag) / (dof * KB)
        return values


def parse_peer(text):
    """"KIND:H" or "KIND:H:PHASE" (KIND DrudeLangevin, Soft or Flow) -> (kind, H, phase); ValueError naming the
    problem."""
    parts = text.split(":")
    try:
        if parts[0] not in ("DrudeLangevin", "Soft", "Flow") or len(parts) not in (2, 3):
            raise ValueError
        step, phase = float(parts[1]), float(parts[2]) if len(parts) == 3 else 0.0
        if not step > 0 or phase < 0 or (phase and parts[0] == "DrudeLangevin"):
            raise ValueError
        return parts[0], step, phase
    except ValueError:
        raise ValueError(f"peer {text!r}: expected DrudeLangevin:H, Soft:H[:PHASE] or Flow:H[:PHASE] with H > 0 and "
                         "PHASE > 0") from None


def make_integrator(kind, step_fs, phase, seed):
    if kind == "DrudeLangevin":
        integrator = openmm.DrudeLangevinIntegrator(300, 5, 1, 20, step_fs * 1e-3)
    else:
        stiff = {SPRING_GROUP, ANISOTROPIC_GROUP} if kind == "Flow" else {SPRING_GROUP}
        integrator = StochasticImpulseIntegrator(300, 5, step_fs * 1e-3, stiff)
        integrator.setSplitting(StochasticImpulseIntegrator.Warped)
        integrator.setThermostatPlacement(StochasticImpulseIntegrator.Middle)
        integrator.setStiffModeTemperature(1.0)
        integrator.setStiffModeFriction(20.0)
        # Without a phase Warped's own step (the limit off), as this scene measured it.
        integrator.setMaxWarpedPhase(phase if phase > 0 else math.pi)
        integrator.setWarpedFrictionScaling(phase > 0)
    integrator.setRandomNumberSeed(seed)
    return integrator


def equilibrated(pairs, seed, steps):
    """The state every peer starts from: DrudeLangevin at 0.5 fs, `steps` steps from the Drudes on their cores."""
    integrator = make_integrator("DrudeLangevin", 0.5, 0.0, seed)
    context = openmm.Context(pairs.system, integrator, openmm.Platform.getPlatformByName("CPU"), {"Threads": "1"})
    context.setPositions(pairs.positions)
    context.setVelocitiesToTemperature(300, seed)
    integrator.step(steps)
    return context.getState(getPositions=True, getVelocities=True)


def run_peer(pairs, state, kind, step_fs, phase, picoseconds, seed):
    """Each observable's mean and standard error, or {"failed": message} where the run blew up."""
    integrator = make_integrator(kind, step_fs, phase, seed)
    context = openmm.Context(pairs.system, integrator, openmm.Platform.getPlatformByName("CPU"), {"Threads": "1"})
    context.setState(state)
    every = max(1, int(round(SAMPLE_FS / step_fs)))
    samples = max(BLOCKS, int(round(picoseconds * 1000 / step_fs)) // every)
    frames = []
    try:
        integrator.step(int(round(BURN_IN_PS * 1000 / step_fs)))
        for _ in range(samples):
            integrator.step(every)
            frame = context.getState(getPositions=True, getVelocities=True)
            x = frame.getPositions(asNumpy=True).value_in_unit(unit.nanometer)
            v = frame.getVelocities(asNumpy=True).value_in_unit(unit.nanometer / unit.picosecond)
            with np.errstate(invalid="ignore", over="ignore"):
                farthest = float(np.max(np.linalg.norm(x[pairs.drudes] - x[pairs.cores], axis=1)))
            if not (farthest < RUN_AWAY_NM and np.all(np.isfinite(v))):
                return {"failed": f"a Drude particle {farthest:.3g} nm from its core at sample {len(frames) + 1}"}
            frames.append(pairs.observables(x, v))
    except openmm.OpenMMException as error:
        return {"failed": str(error)}
    result = {}
    for name in OBSERVABLES:
        if name.startswith("induced"):
            # A ratio of sums: each block's ratio, so that the error is that of the ratio.
            usable = len(frames) // BLOCKS * BLOCKS
            numerator = np.array([f[name][0] for f in frames[:usable]]).reshape(BLOCKS, -1).sum(axis=1)
            denominator = np.array([f[name][1] for f in frames[:usable]]).reshape(BLOCKS, -1).sum(axis=1)
            ratios = numerator / denominator
            result[name] = [float(numerator.sum() / denominator.sum()),
                            float(np.std(ratios, ddof=1) / np.sqrt(BLOCKS))]
        else:
            result[name] = list(block_error([f[name] for f in frames], BLOCKS))
    if kind != "DrudeLangevin":
        frequencies = np.array(integrator.getStiffModeFrequencies())
        result["stiff_mode_frequencies_per_ps"] = sorted({round(float(w), 1) for w in frequencies if w > 0})
    return result


SEED_ROWS = [("induced_u1", "induced / SCF along u1 (k1 = %+.3f k)", "%.5f", 1),
             ("induced_u2", "induced / SCF along u2 (k2 = %+.3f k)", "%.5f", 1),
             ("induced_u3", "induced / SCF along u3", "%.5f", 1),
             ("t_drude", "T Drude, kinetic (K)", "%.3f", 1),
             ("t_drude_config", "T Drude, configurational (K)", "%.3f", 1),
             ("t_cores", "T cores (K)", "%.2f", 1)]


def seed_table(files, reference):
    """The Markdown table of several replicas' anisotropic_flow.json, a row per peer: each observable's mean ± standard
    error over the replicas (from each run's block errors), t against `reference` in brackets."""
    columns, ratios = {}, None
    for path in files:
        with open(path) as f:
            report = json.load(f)
        ratios = ratios or (report["k1_over_k"], report["k2_over_k"])
        for label, result in report["peers"].items():
            columns.setdefault(label, []).append(result)
    if reference not in columns:
        raise ValueError(f"reference peer {reference!r} is in none of the files (peers: {', '.join(columns)})")
    ordered = [(reference, columns.pop(reference))] + list(columns.items())
    rows = [(key, name % ratios[0] if key == "induced_u1" else name % ratios[1] if key == "induced_u2" else name,
             fmt, scale) for key, name, fmt, scale in SEED_ROWS]
    return seeds.markdown(ordered, rows, within=True, peers_as_rows=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--peers", nargs="+", metavar="KIND:H[:PHASE]", help="the peers (required unless "
                        "--seed-table)")
    parser.add_argument("--seed-table", nargs="+", metavar="JSON", help="only print the table of these "
                        "anisotropic_flow.json files pooled over their replicas")
    parser.add_argument("--reference", default="DrudeLangevin:0.25", help="the --seed-table's reference peer")
    parser.add_argument("--pairs", type=int, default=512, help="Drude pairs (default 512)")
    parser.add_argument("--ps", type=float, default=100.0, help="picoseconds sampled per peer (default 100)")
    parser.add_argument("--aniso12", type=float, default=0.82322, help="DrudeForce aniso12 (default: carbonyl O's)")
    parser.add_argument("--aniso34", type=float, default=1.14332, help="DrudeForce aniso34 (default: carbonyl O's)")
    parser.add_argument("--e0", type=float, default=1500.0, help="uniform field, kJ/mol/nm/e (default 1500)")
    parser.add_argument("--gradient", type=float, default=3e4, help="field gradient g, kJ/mol/nm^2/e (default 3e4)")
    parser.add_argument("--trap", type=float, default=1e5, help="the cores' tether, kJ/mol/nm^2 (default 1e5)")
    parser.add_argument("--seed", type=int, default=0, help="replica: the axes, the start and the random numbers")
    parser.add_argument("--out", default=".", help="folder for anisotropic_flow.json (default .)")
    parser.add_argument("--quick", action="store_true", help="a small, short run (smoke test): 27 pairs, 0.4 ps")
    args = parser.parse_args()
    peers = seeds.print_table_or_parse_peers(parser, args, seed_table, lambda text: (text, *parse_peer(text)))
    if peers is None:
        return
    if not (0 < args.aniso12 and 0 < args.aniso34 and args.aniso12 + args.aniso34 < 3):
        parser.error(f"--aniso12 and --aniso34 must be positive with a sum below 3 (got {args.aniso12:g}, "
                     f"{args.aniso34:g})")
    for name in ("ps", "trap"):
        if not getattr(args, name) > 0:
            parser.error(f"--{name} must be positive (got {getattr(args, name):g})")
    if args.pairs < 1:
        parser.error(f"--pairs must be at least 1 (got {args.pairs})")
    count, picoseconds = (27, 0.4) if args.quick else (args.pairs, args.ps)
    pairs = Pairs(count, args.aniso12, args.aniso34, args.e0, args.gradient, args.trap, 100 + args.seed)
    state = equilibrated(pairs, 7 + args.seed, 400 if args.quick else 4000)
    report = {"pairs": count, "picoseconds": picoseconds, "aniso12": args.aniso12, "aniso34": args.aniso34,
              "k": pairs.k, "k1_over_k": pairs.k1 / pairs.k, "k2_over_k": pairs.k2 / pairs.k, "e0": args.e0,
              "gradient": args.gradient, "trap": args.trap, "seed": args.seed, "blocks": BLOCKS, "quick": args.quick,
              "peers": {}}
    print(f"{count} pairs: k = {pairs.k:.0f} kJ/mol/nm^2, k1 = {pairs.k1 / pairs.k:+.3f} k, "
          f"k2 = {pairs.k2 / pairs.k:+.3f} k", flush=True)
    os.makedirs(args.out, exist_ok=True)
    for label, kind, step_fs, phase in peers:
        started = time.time()
        result = run_peer(pairs, state, kind, step_fs, phase, picoseconds, 11 + args.seed)
        report["peers"][label] = result
        if "failed" in result:
            line = "failed: " + result["failed"]
        else:
            line = "   ".join(f"{name} {result[name][0]:.5f} ± {result[name][1]:.5f}" for name in OBSERVABLES)
        print(f"{label:22s} {line}   ({time.time() - started:.0f} s)", flush=True)
        with open(os.path.join(args.out, "anisotropic_flow.json"), "w") as f:
            json.dump(report, f, indent=1)


if __name__ == "__main__":
    main()
