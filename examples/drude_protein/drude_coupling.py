#!/usr/bin/env python3
"""How far the soft forces stiffen a Drude-2019 protein's Drude modes, and so the phase per step the SIM's Warped
splitting can take on it.

After separateDrudeSprings the isotropic springs are stiff (their exact flow) and everything else is soft: the
Thole-screened coupling between neighbouring Drude particles, the anisotropic remainders, electrostatics.  Along a
direction v of the Drude coordinates the soft forces add a stiffness r k (k each Drude's spring), and Warped is stable
while (1 + r) sin^2(phase / 2) < 1 for every such direction (docs/sim_drude.md section 4): the largest r over the
protein's Drude coordinates sets the largest phase per step, 2 arcsin(1 / sqrt(1 + r)), the value to give
setMaxWarpedPhase (plain Warped has 1.77 at 2 fs for k = 418,400 kJ/mol/nm^2 and a 0.4-amu Drude particle).

This script measures r: the Hessian of the soft forces over the protein's Drude coordinates (cores and water held),
by central differences of OpenMM's forces on the CPU platform (steps of 1e-3 nm: flavorbench.hessian) at the built
positions (Drude particles on their cores),
scaled by 1/sqrt(k_i k_j); its largest eigenvalues with the residues that carry them, the largest eigenvalue of each
residue's own block, and the phase limit.

    PYTHONPATH=build/python .venv/bin/python examples/drude_protein/drude_coupling.py [--system dipeptide|villin] \
        [--quick] [--out DIR]

dipeptide: the scene's box (250 SWM4-NDP molecules; --quick: 80); villin: OpenMM's villin box (examples/villin's PDB)
through Modeller.addExtraParticles, 14,789 particles, 289 protein Drude particles (the water's and the two Cl- ions'
held), about 10 minutes here.  Writes drude_coupling.json to --out."""
import argparse
import json
import math
import os
import sys
import time

import numpy as np
import openmm
import openmm.app as app
import openmm.unit as unit

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:0] = [HERE, os.path.join(HERE, "..", "drude_ions"), os.path.join(HERE, "..", "villin")]
from drude_protein import SPRING_GROUP, build, polar_system  # noqa: E402
from flavorbench import hessian  # noqa: E402
from openmmflavors import StochasticImpulseIntegrator  # noqa: E402

ONE_4PI_EPS0 = 138.935456  # kJ/mol nm / e^2
SOLVENT = ("HOH", "NA", "CL", "K")  # residue names, compared in upper case (villin's PDB names its ions "Cl")


def villin_box():
    import villin
    pdb = app.PDBFile(villin.PDB)
    return polar_system(app.Modeller(pdb.topology, pdb.positions), 1.0)


def protein_pairs(system, topology):
    """(drude, core, k) of every Drude pair outside the solvent, k = q^2 / (4 pi eps0 alpha) in kJ/mol/nm^2."""
    atoms = list(topology.atoms())
    drude = next(f for f in system.getForces() if isinstance(f, openmm.DrudeForce))
    pairs = []
    for i in range(drude.getNumParticles()):
        d, c, *_, charge, alpha, _, _ = drude.getParticleParameters(i)
        if atoms[c].residue.name.upper() not in SOLVENT:
            q = charge.value_in_unit(unit.elementary_charge)
            pairs.append((d, c, ONE_4PI_EPS0 * q * q / alpha.value_in_unit(unit.nanometer**3)))
    return pairs


def soft_hessian(system, positions, drudes, progress):
    """The Hessian (kJ/mol/nm^2) of the soft forces (every group but the springs') over the Drude coordinates."""
    context = openmm.Context(system, openmm.VerletIntegrator(0.001), openmm.Platform.getPlatformByName("CPU"))
    began = time.time()

    def report(done, columns):
        if progress and done % 150 == 0:
            print(f"  {done} of {columns} columns, {time.time() - began:.0f} s", file=sys.stderr, flush=True)

    return hessian.hessian_over(context, positions.value_in_unit(unit.nanometer), drudes,
                                0xFFFFFFFF & ~(1 << SPRING_GROUP), progress=report)


def max_stable_phase(r):
    """The largest phase per step at which Warped is stable under a soft stiffness r k: (1 + r) sin^2(phase/2) < 1."""
    return 2 * math.asin(1 / math.sqrt(1 + r)) if r > 0 else math.pi


def coupling(system, topology, positions, progress=True):
    atoms = list(topology.atoms())
    pairs = protein_pairs(system, topology)
    drudes = [d for d, _, _ in pairs]
    scale = np.repeat([1 / math.sqrt(k) for _, _, k in pairs], 3)
    relative = scale[:, None] * soft_hessian(system, positions, drudes, progress) * scale[None, :]
    values, vectors = np.linalg.eigh(relative)
    residue_of = [f"{atoms[c].residue.name}{atoms[c].residue.id}" for _, c, _ in pairs]
    largest = []
    for m in range(1, min(6, len(values)) + 1):
        weight = (vectors[:, -m].reshape(-1, 3)**2).sum(axis=1)
        shares = {}
        for name, w in zip(residue_of, weight):
            shares[name] = shares.get(name, 0.0) + float(w)
        largest.append({"r": float(values[-m]),
                        "residues": sorted(shares.items(), key=lambda kv: -kv[1])[:3]})
    per_residue = {}
    for name in dict.fromkeys(residue_of):
        rows = np.concatenate([[3 * i, 3 * i + 1, 3 * i + 2] for i, n in enumerate(residue_of) if n == name])
        per_residue[name] = float(np.linalg.eigvalsh(relative[np.ix_(rows, rows)])[-1])
    r = float(values[-1])
    return {"drude_pairs": len(pairs), "r_max": r, "r_min": float(values[0]), "max_stable_phase": max_stable_phase(r),
            "largest": largest, "per_residue_max": per_residue}


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--system", choices=["dipeptide", "villin"], default="dipeptide")
    parser.add_argument("--quick", action="store_true", help="the dipeptide in 80 waters (smoke test)")
    parser.add_argument("--out", default=os.path.join(HERE, "..", "..", "results", "drude_protein"))
    args = parser.parse_args()
    if args.system == "villin":
        system, topology, positions = villin_box()
    else:
        system, topology, positions = build(80, 0.55) if args.quick else build(250, 0.8)
    StochasticImpulseIntegrator.separateDrudeSprings(system, SPRING_GROUP)
    result = coupling(system, topology, positions)
    result["system"] = args.system
    result["particles"] = system.getNumParticles()
    print(f"{args.system}: {result['drude_pairs']} protein Drude pairs, {result['particles']} particles")
    print(f"soft stiffness along the Drude modes, relative to the springs: {result['r_min']:.3f} to "
          f"{result['r_max']:.3f}; Warped stable up to the phase {result['max_stable_phase']:.3f} per step")
    for entry in result["largest"]:
        print(f"  r = {entry['r']:.3f}: " + ", ".join(f"{name} {share:.2f}" for name, share in entry["residues"]))
    top = sorted(result["per_residue_max"].items(), key=lambda kv: -kv[1])[:8]
    print("largest r within one residue: " + ", ".join(f"{name} {r:.2f}" for name, r in top))
    os.makedirs(args.out, exist_ok=True)
    path = os.path.join(args.out, "drude_coupling.json")
    with open(path, "w") as f:
        json.dump(result, f, indent=1)
    print(f"written to {path}")


if __name__ == "__main__":
    main()
