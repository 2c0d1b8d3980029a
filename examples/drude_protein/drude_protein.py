"""A polarizable peptide: alanine dipeptide (ACE-ALA-NME) with CHARMM Drude-2019 (charmm_polar_2019.xml: anisotropic
and Thole-screened Drude particles, lone pairs, X-H bonds constrained on cores that carry Drude particles) in SWM4-NDP
water.  StochasticImpulseIntegrator on the System split by separateDrudeSprings (the isotropic springs stiff, the
anisotropic remainders, the Thole screening and everything else soft), with the hard wall, against OpenMM's
DrudeLangevinIntegrator at 0.5 fs (the reference) and at 1 fs with the same wall, every run from the same
equilibrated state in one process, on the CPU platform.

    PYTHONPATH=build/python .venv/bin/python examples/drude_protein/drude_protein.py [--quick] [--out DIR] \\
        [--production PS] [--burn-in PS] [--sim-steps 2 2.5] [--wall NM] [--wall-peers 1] [--seed N] \\
        [--max-warped-phase RAD] [--no-reference]
    PYTHONPATH=build/python .venv/bin/python examples/drude_protein/drude_protein.py --interleaved-timing ROUNDS \\
        [--round-ps PS] [--sim-steps 2 2.5 3] [--wall-peers 1] [--max-warped-phase RAD] [--scaled-friction]

Writes drude_protein.json to --out.  Observables (block averages; error = standard error of the block means):
temperatures of the peptide and of the water (centres of mass of the Drude pairs and the other massive particles),
the Drude temperature, the induced dipoles relative to the self-consistent ones at the same nuclear positions (the
peptide's Drude particles and the water's apart), the peptide's heavy-atom RMSD from the start (aligned), the spread of
its heavy-atom bond lengths and angles (widths of their distributions), the backbone dihedral phi and the share of frames
with psi in the extended (beta/PII) basin, the potential energy per Drude pair, and ns/day.  Force evaluations per ps
come with each run: DrudeLangevin evaluates the forces once per step, the SIM once per step too (Warped), so force
evaluations per ps are 1000/step.

Why a dipeptide: on the CPU platform OpenMM runs DrudeForce and DrudeLangevinIntegrator through its Reference code;
villin in Drude-2019 water (14,789 particles) ran there at 0.11 ns/day at 1 fs, so the 10-ps runs at 0.5 fs that a
reference needs would take months; the dipeptide in 250 waters (1,286 particles) runs at a few ns/day.
"""
import argparse
import json
import os
import sys
import time

import numpy as np
import openmm
import openmm.app as app
import openmm.unit as unit
from flavorbench import seeds
from flavorbench.solvation import AMU_PER_NM3, PROTEIN_SPECIFIC_VOLUME, compress_to_volume, topology_mass, water_volume
from openmmflavors import StochasticImpulseIntegrator

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "drude_ions"))
from drude_ions import (SPRING_GROUP, Analysis, SelfConsistent, add_timing_arguments,  # noqa: E402
                        check_timing_arguments, equilibrated, polar_system, print_runs, run_one, run_timing)

PDB = os.path.join(HERE, "..", "metropolis", "alanine_dipeptide.pdb")
PEPTIDE = "ALA"  # the capped peptide as one residue (below)
WATER = "HOH"


def build(waters, cutoff):
    """The dipeptide in a cubic box of `waters` SWM4-NDP molecules, PME (cutoff in nm), rigid water, X-H bonds
    constrained; the box holds the waters at water's density at 300 K and the peptide at a protein's partial specific
    volume.  Drude-2019 writes the caps as patches (ACE, CT3) of the residue they cap, so the three PDB residues
    become one residue ALA, bonds kept, after the water is added with amber14's templates."""
    pdb = app.PDBFile(PDB)
    solvated = app.Modeller(pdb.topology, pdb.positions)
    solvated.addSolvent(app.ForceField("amber14-all.xml", "amber14/tip3p.xml"), model="tip3p", numAdded=waters)
    peptide_mass = topology_mass(solvated.topology, {"ACE", "ALA", "NME"})
    compress_to_volume(solvated, water_volume(solvated.topology) + peptide_mass * PROTEIN_SPECIFIC_VOLUME / AMU_PER_NM3)
    topology = app.Topology()
    topology.setPeriodicBoxVectors(solvated.topology.getPeriodicBoxVectors())
    chain = topology.addChain()
    atoms, peptide = {}, None
    for residue in solvated.topology.residues():
        if residue.name in ("ACE", "ALA", "NME"):
            peptide = peptide or topology.addResidue(PEPTIDE, chain)
            target = peptide
        else:
            target = topology.addResidue(residue.name, chain)
        for atom in residue.atoms():
            atoms[atom] = topology.addAtom(atom.name, atom.element, target)
    for a, b in solvated.topology.bonds():
        topology.addBond(atoms[a], atoms[b])
    return polar_system(app.Modeller(topology, solvated.positions), cutoff)


class PeptideGeometry:
    """The peptide's heavy atoms: RMSD from a start (aligned), the widths of their bond-length and angle distributions,
    and the backbone dihedrals phi (C'-N-CA-C) and psi (N-CA-C-N')."""

    def __init__(self, system, topology, start):
        atoms = [a for a in topology.atoms() if a.residue.name == PEPTIDE]
        heavy = {a.index for a in atoms if a.element is not None and a.element.symbol != "H"}
        self.heavy = np.array(sorted(heavy))
        self.start = np.asarray(start)[self.heavy]
        bonds = next(f for f in system.getForces() if isinstance(f, openmm.HarmonicBondForce))
        angles = next(f for f in system.getForces() if isinstance(f, openmm.HarmonicAngleForce))
        # The bonded pairs and angles among heavy atoms (not the Urey-Bradley 1-3 terms, which share the bond force).
        bonded = {frozenset((a.index, b.index)) for a, b in topology.bonds()}
        self.bonds = np.array([(i, j) for i, j, *_ in (bonds.getBondParameters(k) for k in range(bonds.getNumBonds()))
                               if i in heavy and j in heavy and frozenset((i, j)) in bonded])
        self.angles = np.array([(i, j, m) for i, j, m, *_ in (angles.getAngleParameters(k)
                                                            for k in range(angles.getNumAngles()))
                                if i in heavy and j in heavy and m in heavy])
        self.frames = {"bonds": [], "angles": []}
        # The backbone from the bonds: CA's nitrogen and carbonyl carbon, the carbonyl carbon before that nitrogen
        # (ACE's) and the nitrogen after that carbon (NME's).
        neighbours = {a.index: set() for a in atoms}
        for a, b in topology.bonds():
            if a.index in neighbours and b.index in neighbours:
                neighbours[a.index].add(b)
                neighbours[b.index].add(a)

        def bonded(index, element, exclude):
            return next(a.index for a in neighbours[index]
                        if a.element is not None and a.element.symbol == element and a.index != exclude)

        ca = next(a.index for a in atoms if a.name == "CA")
        n, c = bonded(ca, "N", -1), next(a.index for a in neighbours[ca] if a.element.symbol == "C" and any(
            b.element is not None and b.element.symbol == "O" for b in neighbours[a.index]))
        order = [bonded(n, "C", ca), n, ca, c, bonded(c, "N", -1)]
        self.phi, self.psi = order[0:4], order[1:5]

    def rmsd(self, x):
        """Heavy-atom RMSD (nm) from the start after the optimal rotation (Kabsch)."""
        a = x[self.heavy] - x[self.heavy].mean(axis=0)
        b = self.start - self.start.mean(axis=0)
        u, _, vt = np.linalg.svd(a.T @ b)
        d = np.sign(np.linalg.det(u @ vt))
        rotation = u @ np.diag([1, 1, d]) @ vt
        return float(np.sqrt(np.mean(np.sum((a @ rotation - b)**2, axis=1))))

    def lengths(self, x):
        return np.linalg.norm(x[self.bonds[:, 0]] - x[self.bonds[:, 1]], axis=1)

    def angles_deg(self, x):
        u = x[self.angles[:, 0]] - x[self.angles[:, 1]]
        w = x[self.angles[:, 2]] - x[self.angles[:, 1]]
        cos = np.sum(u * w, axis=1) / np.linalg.norm(u, axis=1) / np.linalg.norm(w, axis=1)
        return np.degrees(np.arccos(np.clip(cos, -1, 1)))

    @staticmethod
    def spread(frames, blocks):
        """The width of the bond (or angle) distributions: per block, each coordinate's standard deviation about its
        own mean, averaged over the coordinates (root mean square); mean and standard error over the blocks."""
        frames = np.asarray(frames)
        per_block = [np.sqrt(np.mean(np.var(block, axis=0))) for block in np.array_split(frames, blocks)]
        return [float(np.mean(per_block)), float(np.std(per_block, ddof=1) / np.sqrt(len(per_block)))]

    @staticmethod
    def dihedral(x, quartet):
        p0, p1, p2, p3 = (x[i] for i in quartet)
        b0, b1, b2 = p0 - p1, p2 - p1, p3 - p2
        b1 /= np.linalg.norm(b1)
        v, w = b0 - np.dot(b0, b1) * b1, b2 - np.dot(b2, b1) * b1
        return float(np.degrees(np.arctan2(np.dot(np.cross(b1, v), w), np.dot(v, w))))

    def observables(self, x):
        """Per frame: RMSD, phi in (-360, 0] (continuous through the extended region at -180), psi in the extended
        basin or not; the bond lengths and angles go to self.frames for spread()."""
        psi, phi = self.dihedral(x, self.psi), self.dihedral(x, self.phi)
        self.frames["bonds"].append(self.lengths(x))
        self.frames["angles"].append(self.angles_deg(x))
        return {"rmsd_nm": self.rmsd(x), "phi_deg": phi - 360 if phi > 0 else phi,
                "extended": float(psi > 60 or psi < -120)}


# The observables of the seed table: JSON key, row name, format, scale (bond widths are shown in pm).
SEED_TABLE_ROWS = [("t_peptide", "T peptide (K)", "%.1f", 1), ("t_water", "T water (K)", "%.1f", 1),
                   ("t_drude", "T Drude (K)", "%.3f", 1),
                   ("induced_ratio_peptide", "induced / SCF, peptide", "%.4f", 1),
                   ("induced_ratio_water", "induced / SCF, water", "%.4f", 1),
                   ("induced_ratio_anisotropic", "induced / SCF, anisotropic", "%.4f", 1),
                   ("rmsd_nm", "heavy-atom RMSD (nm)", "%.3f", 1), ("bond_width_nm", "bond width (pm)", "%.2f", 1000),
                   ("angle_width_deg", "angle width (°)", "%.2f", 1), ("phi_deg", "φ (°)", "%.0f", 1),
                   ("pe_per_pair", "PE per Drude pair (kJ/mol)", "%.2f", 1)]


def seed_table(reference_files, sim_files, reference_step=0.5):
    """The Markdown table of several seeds: the DrudeLangevin runs at reference_step (fs) of reference_files against
    the DrudeLangevin runs at other steps (the --wall-peers, or the 0.5-fs references of sim_files when the reference
    is a smaller step) and the SIM runs of sim_files, per step; mean over the seeds ± its standard error, t against
    the reference in brackets."""
    columns = seeds.drude_peer_columns(seeds.load_runs(reference_files), seeds.load_runs(sim_files), reference_step,
                                       mark_sim_wall=False)
    return seeds.markdown(columns, SEED_TABLE_ROWS)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="a small, short run (smoke test)")
    parser.add_argument("--out", default=os.path.join(HERE, "..", "..", "results", "drude_protein"),
                        help="output folder")
    parser.add_argument("--production", type=float, default=10.0, help="ps sampled per run (default 10)")
    parser.add_argument("--burn-in", type=float, default=0.5, help="ps per run before sampling (default 0.5)")
    parser.add_argument("--reference-step", type=float, default=0.5,
                        help="DrudeLangevin's step in fs (default 0.5); with --seed-table, the step of the reference "
                             "runs in --reference-files")
    parser.add_argument("--sim-steps", type=float, nargs="+", default=[2.0], help="SIM steps H in fs (default 2)")
    parser.add_argument("--wall", type=float, default=0.02,
                        help="the hard wall (setMaxDrudeDistance) in nm of the SIM runs and the --wall-peers "
                             "(default 0.02, CHARMM's; 0 for none)")
    parser.add_argument("--wall-peers", type=float, nargs="*", default=[1.0], metavar="FS",
                        help="DrudeLangevin at these steps (fs) with the same --wall (default 1)")
    parser.add_argument("--seed", type=int, default=1, help="random seed of the run (default 1)")
    parser.add_argument("--max-warped-phase", type=float, default=0.0,
                        help="setMaxWarpedPhase of the SIM runs in radians (default 0: no limit)")
    parser.add_argument("--scaled-friction", action="store_true",
                        help="the SIM runs with setWarpedFrictionScaling(True)")
    parser.add_argument("--seed-table", nargs="+", metavar="JSON",
                        help="only print the table of the SIM runs in these drude_protein.json files against the "
                             "reference runs of --reference-files")
    parser.add_argument("--reference-files", nargs="+", metavar="JSON", default=[
        os.path.join(HERE, "results", f"seed{s}", "drude_protein.json") for s in range(1, 6)],
                        help="the runs with the DrudeLangevin reference at --reference-step (default results/seed1..5)")
    parser.add_argument("--no-reference", action="store_true",
                        help="only the SIM runs (to set beside the reference of a run with the same --seed)")
    add_timing_arguments(parser)
    args = parser.parse_args()
    if args.seed_table:
        print(seed_table(args.reference_files, args.seed_table, args.reference_step))
        return
    check_timing_arguments(parser, args)
    if args.quick:
        waters, cutoff, equilibration_ps = 80, 0.55, 0.05
        settings = dict(production_ps=0.1, burn_ps=0.02, samples=6, blocks=2, scf_frames=2)
    else:
        waters, cutoff, equilibration_ps = 250, 0.8, 1.0
        settings = dict(production_ps=args.production, burn_ps=args.burn_in, samples=100, blocks=5, scf_frames=10)
    begin = time.time()
    system, topology, positions = build(waters, cutoff)
    analysis = Analysis(system, topology, solute=(PEPTIDE,))
    drude = next(f for f in system.getForces() if isinstance(f, openmm.DrudeForce))
    anisotropic = sum(1 for i in range(drude.getNumParticles()) if drude.getParticleParameters(i)[2] >= 0)
    virtual = sum(1 for i in range(system.getNumParticles()) if system.isVirtualSite(i))
    print(f"ACE-ALA-NME (Drude-2019: {len(analysis.solute_pairs)} Drude particles, {anisotropic} anisotropic, "
          f"{drude.getNumScreenedPairs()} Thole-screened pairs) in {waters} SWM4-NDP molecules: "
          f"{system.getNumParticles()} particles, {virtual} virtual sites, {system.getNumConstraints()} constraints",
          flush=True)

    state = equilibrated(system, positions, args.seed, equilibration_ps)
    start = state.getPositions(asNumpy=True).value_in_unit(unit.nanometer)
    geometry = PeptideGeometry(system, topology, start)
    peptide_class = analysis.class_selection((PEPTIDE,))
    water_class = analysis.class_selection((WATER,))
    water_pairs = np.array([i for i, c in enumerate(analysis.cores) if analysis.residue[c] == WATER], dtype=int)

    def extra(frame):
        parts = analysis.kinetic_parts(frame.velocities)
        values = {"t_peptide": analysis.class_temperature(parts, peptide_class),
                  "t_water": analysis.class_temperature(parts, water_class)}
        values.update(geometry.observables(frame.positions))
        return values

    # The anisotropic Drude particles (the carbonyl oxygens') apart too: their remainders are soft in the split.
    anisotropic_pairs = np.array([i for i in range(drude.getNumParticles()) if drude.getParticleParameters(i)[2] >= 0],
                                 dtype=int)
    groups = {"peptide": analysis.solute_pairs, "water": water_pairs, "anisotropic": anisotropic_pairs}
    scf = SelfConsistent(system)  # on the original System
    separated = openmm.XmlSerializer.deserialize(openmm.XmlSerializer.serialize(system))
    StochasticImpulseIntegrator.separateDrudeSprings(separated, SPRING_GROUP)
    if run_timing(args, system, separated, state):
        return

    runs = []

    def run(run_system, kind, step_fs, seed, wall, max_warped_phase=0.0, scaled_friction=False):
        """A run, or the record of its failure (a step too large blows up)."""
        geometry.frames = {"bonds": [], "angles": []}
        try:
            result = run_one(run_system, state, analysis, scf, kind, step_fs, settings, seed, wall, groups, extra,
                             max_warped_phase, scaled_friction)
            result["max_warped_phase"] = max_warped_phase
            result["scaled_friction"] = scaled_friction
            result["force_evaluations_per_ps"] = 1000.0 / step_fs
            result["bond_width_nm"] = geometry.spread(geometry.frames["bonds"], settings["blocks"])
            result["angle_width_deg"] = geometry.spread(geometry.frames["angles"], settings["blocks"])
            runs.append(result)
        except openmm.OpenMMException as e:
            runs.append({"integrator": kind, "step_fs": step_fs, "wall_nm": wall, "failed": str(e)})
        print(f"{kind} {step_fs} fs (wall {wall:g} nm) done", flush=True)

    if not args.no_reference:
        run(system, "DrudeLangevin", args.reference_step, args.seed + 2, 0.0)
        for step_fs in args.wall_peers:
            run(system, "DrudeLangevin", step_fs, args.seed + 4, args.wall)
    for step_fs in args.sim_steps:
        run(separated, "WarpedMiddle", step_fs, args.seed + 3, args.wall, args.max_warped_phase, args.scaled_friction)

    names = [("t_peptide", "T peptide (K)"), ("t_water", "T water (K)"), ("t_drude", "T Drude (K)"),
             ("induced_ratio_peptide", "ind/SCF peptide"), ("induced_ratio_water", "ind/SCF water"),
             ("induced_ratio_anisotropic", "ind/SCF anisotropic"),
             ("rmsd_nm", "RMSD (nm)"), ("bond_width_nm", "bond width (nm)"), ("angle_width_deg", "angle width (deg)"),
             ("phi_deg", "phi (deg)"), ("extended", "extended"), ("pe_per_pair", "PE/pair"),
             ("ns_per_day", "ns/day")]
    print_runs(runs, names, width=22)
    reference = runs[0] if not args.no_reference and "failed" not in runs[0] else None
    for record in runs:
        if "failed" in record:
            continue
        if reference is not None and record is not reference:
            # Distance from the reference in combined standard errors, per observable.
            record["sigma_from_reference"] = {
                key: (record[key][0] - reference[key][0]) / max(np.hypot(record[key][1], reference[key][1]), 1e-300)
                for key, _ in names if isinstance(record.get(key), (list, tuple))}
    os.makedirs(args.out, exist_ok=True)
    path = os.path.join(args.out, "drude_protein.json")
    with open(path, "w") as out:
        json.dump({"waters": waters, "particles": system.getNumParticles(), "settings": settings, "seed": args.seed,
                   "wall_nm": args.wall, "wall_seconds": time.time() - begin, "runs": runs}, out, indent=1)
    print(f"\n{time.time() - begin:.0f} s; written to {path}")


if __name__ == "__main__":
    main()
