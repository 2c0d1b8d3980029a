"""Energy drift of the artificial FLAVOR's frozen stage on real molecules, without a thermostat.

A Langevin run hides an integrator that pumps energy into a few coordinates behind the thermostat (a warmer protein,
wider angles); without one the pump shows as a drift of the total energy. Two molecules in vacuum (NoCutoff, X-H
bonds constrained, bonds and angles stiff, CPU platform with 1 thread), each started from one state equilibrated by
LangevinMiddleIntegrator at 0.5 fs and 300 K, then integrated without friction by

  - VerletIntegrator at 0.5 fs (the control: a symplectic integrator with a small step, no drift), and
  - FlavorIntegrator, ArtificialProjected averaging, Verlet scheme, tau = 1 fs, at each delta of --deltas, with
    every bond and angle stiff, and with the angles of the planar centres soft (FlavorIntegrator.separatePlanarAngles:
    sp2 carbons and nitrogens, whose out-of-plane motion no frozen distance holds):

  villin headpiece (the protein of examples/villin, its water removed; 582 atoms, rings: 3 Phe, 1 Trp, 1 His, 1 Pro),
  whose frozen set is nearly dependent at the rings (the cluster gives back scaled rates), and
  one POPC lipid (amber14 lipid17; 134 atoms, no rings), whose frozen set is well conditioned (held momenta).

Reported per run: the drift of the total energy (slope of a straight-line fit, kJ/mol/ps) with the standard deviation
of the residuals, the kinetic energy at the start and at the end, per residue the mean kinetic energy gained per atom
(last quarter of the run against the first), and the energy the stiff bond and angle terms gained over the same
quarters, in all and the terms that gained most, which say where the energy goes.

    PYTHONPATH=build/python .venv/bin/python benchmarks/frozen_energy_drift.py [--quick] [--out DIR]
        [--ps PS] [--deltas FS ...] [--replot JSON]

Outputs: DIR/frozen_energy_drift.json and DIR/frozen_energy_drift.png (total energy against time, one panel per
molecule); progress on stderr.
"""
import os
import sys

import numpy as np
import openmm as mm
import openmm.app as app
import openmm.unit as unit

import openmmflavors
from flavorbench import reporting
from flavorbench.progress import Progress
from flavorbench.systems import harmonic_angles

HERE = os.path.dirname(os.path.abspath(__file__))
VILLIN_PDB = os.path.join(HERE, "..", "examples", "villin", "villin.pdb")
POPC_PDB = os.path.join(os.path.dirname(app.__file__), "data", "POPC.pdb")
TAU_FS = 1.0
SAMPLE_PS = 0.02
TOLERANCE = 1e-8
BOND_GROUP, ANGLE_GROUP, PLANAR_ANGLE_GROUP = 1, 2, 3


def molecule(name):
    """(System, topology, positions) of a molecule in vacuum, bonds in group 1, the angles of planar centres in group 3,
    the other angles in group 2, the rest in 0."""
    if name == "villin":
        pdb = app.PDBFile(VILLIN_PDB)
        forcefield = app.ForceField("amber14-all.xml", "amber14/tip3p.xml")
        modeller = app.Modeller(pdb.topology, pdb.positions)
        modeller.deleteWater()
        modeller.delete([r for r in modeller.topology.residues() if r.name in ("CL", "Cl", "NA", "Na")])
    else:
        pdb = app.PDBFile(POPC_PDB)
        forcefield = app.ForceField("amber14-all.xml")  # which includes amber14/lipid17.xml
        modeller = app.Modeller(pdb.topology, pdb.positions)
        first = next(modeller.topology.residues())
        modeller.delete([r for r in modeller.topology.residues() if r != first])
    modeller.topology.setPeriodicBoxVectors(None)
    system = forcefield.createSystem(modeller.topology, nonbondedMethod=app.NoCutoff, constraints=app.HBonds,
                                     removeCMMotion=False)
    for force in system.getForces():
        force.setForceGroup(BOND_GROUP if isinstance(force, mm.HarmonicBondForce) else
                            ANGLE_GROUP if isinstance(force, mm.HarmonicAngleForce) else 0)
    openmmflavors.FlavorIntegrator.separatePlanarAngles(system, PLANAR_ANGLE_GROUP)
    return system, modeller.topology, modeller.positions


def context(system, integrator):
    return mm.Context(system, integrator, mm.Platform.getPlatformByName("CPU"), {"Threads": "1"})


def equilibrated(system, positions, ps):
    """Minimized, then ps of LangevinMiddle 0.5 fs at 300 K (fixed seeds): positions and velocities."""
    integrator = mm.LangevinMiddleIntegrator(300, 5, 0.0005)
    integrator.setRandomNumberSeed(5)
    c = context(system, integrator)
    c.setPositions(positions)
    mm.LocalEnergyMinimizer.minimize(c, 10, 1000)
    c.setVelocitiesToTemperature(300, 1)
    integrator.step(int(round(ps / 0.0005)))
    state = c.getState(getPositions=True, getVelocities=True)
    return state.getPositions(asNumpy=True), state.getVelocities(asNumpy=True)


def integrators(deltas):
    """(label, step in fs, factory) of the peers."""
    peers = [("Verlet 0.5 fs", 0.5, lambda: mm.VerletIntegrator(0.0005))]
    for planar_soft in (False, True):
        stiff = {BOND_GROUP, ANGLE_GROUP} | (set() if planar_soft else {PLANAR_ANGLE_GROUP})
        for delta in deltas:
            def factory(delta=delta, stiff=stiff):
                integrator = openmmflavors.FlavorIntegrator(delta * unit.femtosecond, TAU_FS * unit.femtosecond, stiff)
                integrator.setAveraging(openmmflavors.FlavorIntegrator.ArtificialProjected)
                return integrator
            peers.append(("FLAVOR δ=%g fs τ=%g fs%s" % (delta, TAU_FS, ", planar angles soft" if planar_soft else ""),
                          delta, factory))
    return peers


class StiffTerms:
    """The energies of the stiff bonds and angles, each term on its own, at given positions (kJ/mol)."""

    def __init__(self, system, topology):
        atoms = list(topology.atoms())
        self.names = []
        bonds = next(f for f in system.getForces() if isinstance(f, mm.HarmonicBondForce))
        b = [bonds.getBondParameters(i) for i in range(bonds.getNumBonds())]
        self.bond_ij = np.array([x[:2] for x in b], dtype=int).reshape(-1, 2)
        self.bond_r0 = np.array([x[2].value_in_unit(unit.nanometer) for x in b])
        self.bond_k = np.array([x[3].value_in_unit(unit.kilojoule_per_mole / unit.nanometer**2) for x in b])
        a = [x for x, _ in harmonic_angles(system)]
        self.angle_ijk = np.array([x[:3] for x in a], dtype=int).reshape(-1, 3)
        self.angle_t0 = np.array([x[3].value_in_unit(unit.radian) for x in a])
        self.angle_k = np.array([x[4].value_in_unit(unit.kilojoule_per_mole / unit.radian**2) for x in a])
        label = lambda i: "%s%s:%s" % (atoms[i].residue.name, atoms[i].residue.id, atoms[i].name)
        self.names = (["bond " + "-".join(label(i) for i in ij) for ij in self.bond_ij] +
                      ["angle " + "-".join(label(i) for i in ijk) for ijk in self.angle_ijk])

    def energies(self, q):
        r = np.linalg.norm(q[self.bond_ij[:, 0]] - q[self.bond_ij[:, 1]], axis=1)
        d1 = q[self.angle_ijk[:, 0]] - q[self.angle_ijk[:, 1]]
        d2 = q[self.angle_ijk[:, 2]] - q[self.angle_ijk[:, 1]]
        cosine = np.sum(d1 * d2, axis=1) / (np.linalg.norm(d1, axis=1) * np.linalg.norm(d2, axis=1))
        theta = np.arccos(np.clip(cosine, -1.0, 1.0))
        return np.concatenate([0.5 * self.bond_k * (r - self.bond_r0)**2, 0.5 * self.angle_k * (theta - self.angle_t0)**2])


def run(system, topology, start, label, step_fs, factory, ps):
    """Total and kinetic energy every SAMPLE_PS, the per-residue kinetic energy gained per atom, and the energy gained
    by the stiff terms (last quarter of the run against the first)."""
    terms = StiffTerms(system, topology)
    integrator = factory()
    integrator.setConstraintTolerance(TOLERANCE)
    c = context(system, integrator)
    c.setPositions(start[0])
    c.setVelocities(start[1])
    masses = np.array([system.getParticleMass(i).value_in_unit(unit.dalton) for i in range(system.getNumParticles())])
    every = max(1, int(round(SAMPLE_PS / (step_fs * 1e-3))))
    samples = int(round(ps / SAMPLE_PS))
    times, total, kinetic, per_atom, term_energies = [], [], [], [], []
    progress = Progress(label, ps, fmt=".2f")
    try:
        for n in range(samples):
            integrator.step(every)
            state = c.getState(getEnergy=True, getVelocities=True, getPositions=True)
            v = state.getVelocities(asNumpy=True).value_in_unit(unit.nanometer / unit.picosecond)
            term_energies.append(terms.energies(state.getPositions(asNumpy=True).value_in_unit(unit.nanometer)))
            times.append(state.getTime().value_in_unit(unit.picosecond))
            kinetic.append(state.getKineticEnergy().value_in_unit(unit.kilojoule_per_mole))
            total.append(kinetic[-1] + state.getPotentialEnergy().value_in_unit(unit.kilojoule_per_mole))
            per_atom.append(0.5 * masses * np.sum(v * v, axis=1))
            progress.update((n + 1) * SAMPLE_PS)
    except mm.OpenMMException as error:
        return {"label": label, "failed": str(error).splitlines()[0]}
    times, total = np.array(times), np.array(total)
    fit = np.polyfit(times, total, 1)
    quarter = max(1, len(per_atom) // 4)
    gain = np.mean(per_atom[-quarter:], axis=0) - np.mean(per_atom[:quarter], axis=0)
    residues = {}
    for atom in topology.atoms():
        key = atom.residue.name + atom.residue.id
        residues.setdefault(key, []).append(gain[atom.index])
    by_residue = sorted(((key, float(np.mean(v))) for key, v in residues.items()), key=lambda kv: -kv[1])
    # Gains, not levels: some terms are strained at any step (a five-membered ring whose equilibrium angles do not
    # close the ring holds several kJ/mol in each of its angles).
    term_gain = np.mean(term_energies[-quarter:], axis=0) - np.mean(term_energies[:quarter], axis=0)
    loaded = [(terms.names[i], float(term_gain[i])) for i in np.argsort(-term_gain)[:6]]
    return {"label": label, "step_fs": step_fs, "time_ps": times.tolist(), "total_energy": total.tolist(),
            "drift_kj_mol_ps": float(fit[0]), "residual_sd": float(np.std(total - np.polyval(fit, times))),
            "kinetic_start": float(np.mean(kinetic[:quarter])), "kinetic_end": float(np.mean(kinetic[-quarter:])),
            "gain_per_atom_by_residue": by_residue[:6], "stiff_terms_gain": float(np.sum(term_gain)),
            "stiff_terms_gaining_most": loaded}


def plot(data, path):
    plt = reporting.pyplot()
    fig, axes = plt.subplots(1, len(data["molecules"]), figsize=(7.5 * len(data["molecules"]), 6.2), squeeze=False)
    for ax, entry in zip(axes[0], data["molecules"]):
        for r in entry["runs"]:
            label = r["label"].replace("δ=", "δ = ").replace(" fs τ=", " fs, τ = ")
            if "failed" in r:
                ax.plot([], [], label="%s: failed" % label)
                continue
            e = np.array(r["total_energy"])
            drift = round(r["drift_kj_mol_ps"], 1) + 0.0  # no "-0.0"
            ax.plot(r["time_ps"], e - e[0], label="%s: drift %+.1f kJ/mol/ps" % (label, drift))
        ax.set_xlabel("time (ps)")
        ax.set_ylabel("total energy − its first sample (kJ/mol)")
        ax.set_title("%s in vacuum, %d atoms" % (entry["name"], entry["atoms"]))
        # Below the panel: the curves fill the plot area.
        ax.legend(fontsize=7.5, loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=1)
        ax.grid(alpha=0.3)
    fig.suptitle("Energy without a thermostat: artificial FLAVOR (bonds and angles stiff, or the angles of planar "
                 "centres soft) against Verlet 0.5 fs")
    fig.tight_layout()
    reporting.save_figure(fig, path, dpi=110)


def main():
    p = reporting.parser(__doc__, "frozen_energy_drift", quick_help="a few tens of femtoseconds per run (smoke test)")
    p.add_argument("--ps", type=float, default=4.0, help="ps per run without a thermostat")
    p.add_argument("--deltas", type=float, nargs="+", default=[2.0, 2.5, 3.0], help="FLAVOR mesosteps in fs")
    p.add_argument("--replot", help="only redraw the chart of an earlier run's JSON into --out")
    args = p.parse_args()
    if args.replot:
        reporting.replot(args.replot, args.out, "frozen_energy_drift", plot)
        return
    for delta in args.deltas:
        if not TAU_FS < delta <= 4.0:
            sys.exit("--deltas: %g fs is not allowed; each mesostep must be above tau = %g fs and at most 4 fs"
                     % (delta, TAU_FS))
    ps = 0.06 if args.quick else args.ps
    equilibration = 0.01 if args.quick else 5.0
    data = {"ps": ps, "tau_fs": TAU_FS, "constraint_tolerance": TOLERANCE, "molecules": []}
    for name in ("villin", "POPC"):
        system, topology, positions = molecule(name)
        print("%s: %d atoms, equilibrating %g ps" % (name, system.getNumParticles(), equilibration),
              file=sys.stderr, flush=True)
        start = equilibrated(system, positions, equilibration)
        runs = [run(system, topology, start, label, step, factory, ps)
                for label, step, factory in integrators(args.deltas)]
        data["molecules"].append({"name": name, "atoms": system.getNumParticles(), "runs": runs})
        reporting.table("%s in vacuum, %g ps without a thermostat" % (name, ps),
                        [("integrator", 46, "s"), ("drift (kJ/mol/ps)", 18, ".1f"), ("residual sd", 12, ".1f"),
                         ("KE start", 9, ".0f"), ("KE end", 9, ".0f"), ("stiff terms gain", 17, ".1f"),
                         ("most heated residues (kJ/mol per atom); stiff terms gaining most (kJ/mol)", 0, "s")],
                        [[r["label"], r.get("drift_kj_mol_ps", float("nan")), r.get("residual_sd", float("nan")),
                          r.get("kinetic_start", float("nan")), r.get("kinetic_end", float("nan")),
                          r.get("stiff_terms_gain", float("nan")),
                          r.get("failed") or ", ".join("%s %+.1f" % kv for kv in r["gain_per_atom_by_residue"][:3]) +
                          "; " + ", ".join("%s %+.1f" % kv for kv in r["stiff_terms_gaining_most"][:2])]
                         for r in runs])
    reporting.save_outputs(args.out, "frozen_energy_drift", data, lambda path: plot(data, path))


if __name__ == "__main__":
    main()
