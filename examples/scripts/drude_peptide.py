"""A polarizable peptide with StochasticImpulseIntegrator: alanine dipeptide in CHARMM Drude-2019
(charmm_polar_2019.xml: anisotropic and Thole-screened Drude particles, lone pairs) in 250 SWM4-NDP waters, PME, X-H
bonds constrained.
separateDrudeSprings puts the isotropic Drude springs in a stiff group of their own (integrated exactly, cold); the
rest is soft. 2-fs steps (Warped splitting, Middle placement) behind CHARMM's 0.02-nm hard wall: faster than
DrudeLangevinIntegrator at 1 fs with the same wall, its observables within the error bars but the Drude temperature
(README.md's table; examples/drude_protein measures both).

    PYTHONPATH=build/python .venv/bin/python examples/scripts/drude_peptide.py [--steps N] [--seed N] [--quick]
"""
import argparse
import time

import numpy as np
import openmm
from openmm import app, unit
from openmmflavors import StochasticImpulseIntegrator

parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
parser.add_argument("--steps", type=int, default=2000, help="steps of 2 fs (default 2000)")
parser.add_argument("--seed", type=int, default=1, help="random seed (default 1)")
parser.add_argument("--quick", action="store_true", help="a smoke run of a few seconds (make test runs it)")
args = parser.parse_args()
steps, equilibration, minimization = (20, 20, 20) if args.quick else (args.steps, 250, 500)

pdb = app.PDBFile("examples/metropolis/alanine_dipeptide.pdb")  # ACE-ALA-NME
modeller = app.Modeller(pdb.topology, pdb.positions)
modeller.addSolvent(app.ForceField("amber14-all.xml", "amber14/tip3p.xml"), model="tip3p", numAdded=250)
# addSolvent leaves room at the faces (0.82 g/cm³): move each molecule with its centroid into the box that holds the
# waters at water's density at 300 K (0.9965 g/cm³) and the peptide at a protein's specific volume (0.73 cm³/g).
residues = list(modeller.topology.residues())
peptide = [r for r in residues if r.name in ("ACE", "ALA", "NME")]
water_mass = 18.0153 * (len(residues) - len(peptide))
peptide_mass = sum(a.element.mass.value_in_unit(unit.dalton) for r in peptide for a in r.atoms())
edge = ((water_mass / 0.9965 + peptide_mass * 0.73) / 602.214) ** (1 / 3)  # nm
old = modeller.topology.getPeriodicBoxVectors()[0][0].value_in_unit(unit.nanometer)
xyz = np.array(modeller.positions.value_in_unit(unit.nanometer))
for atoms in [[a.index for r in peptide for a in r.atoms()]] + [[a.index for a in r.atoms()] for r in residues
                                                                  if r not in peptide]:
    centre = xyz[atoms].mean(axis=0)
    xyz[atoms] += (centre % old) * (edge / old) - centre
# Drude-2019 writes the caps as patches of the residue they cap: the three residues become one, ALA (its ALAD).
topology = app.Topology()
topology.setPeriodicBoxVectors(np.eye(3) * edge * unit.nanometer)
chain = topology.addChain()
joined = topology.addResidue("ALA", chain)
atoms = {}
for residue in residues:
    target = joined if residue in peptide else topology.addResidue(residue.name, chain)
    for atom in residue.atoms():
        atoms[atom] = topology.addAtom(atom.name, atom.element, target)
for a, b in modeller.topology.bonds():
    topology.addBond(atoms[a], atoms[b])
modeller = app.Modeller(topology, [openmm.Vec3(*p) for p in xyz] * unit.nanometer)
forcefield = app.ForceField("charmm_polar_2019.xml")
modeller.addExtraParticles(forcefield)                          # Drude particles and lone pairs
system = forcefield.createSystem(modeller.topology, nonbondedMethod=app.PME, nonbondedCutoff=0.8*unit.nanometer,
                                 constraints=app.HBonds, rigidWater=True)
# Stiff: the isotropic Drude springs, moved into group 1. Soft (group 0): the anisotropic remainders, the Thole
# screening and everything else.
for force in system.getForces():
    force.setForceGroup(0)
StochasticImpulseIntegrator.separateDrudeSprings(system, 1)

integrator = StochasticImpulseIntegrator(300*unit.kelvin, 5/unit.picosecond, 2*unit.femtoseconds, {1})
integrator.setSplitting(StochasticImpulseIntegrator.Warped)
integrator.setThermostatPlacement(StochasticImpulseIntegrator.Middle)
integrator.setStiffModeTemperature(1*unit.kelvin)               # the Drudes' own bath, as DrudeLangevinIntegrator's
integrator.setStiffModeFriction(20/unit.picosecond)
integrator.setMaxDrudeDistance(0.02*unit.nanometer)             # CHARMM's hard wall
integrator.setRandomNumberSeed(args.seed)
simulation = app.Simulation(modeller.topology, system, integrator, openmm.Platform.getPlatformByName("CPU"))
simulation.context.setPositions(modeller.positions)
simulation.minimizeEnergy(maxIterations=minimization)           # the moved molecules' close contacts relaxed
simulation.context.setVelocitiesToTemperature(300*unit.kelvin, args.seed)
simulation.step(equilibration)                                  # 0.5 ps: the Drudes to about 1 K

# Temperatures: of the peptide and of the water (each Drude pair at its centre of mass, 3 degrees of freedom per
# pair and per other massive particle, less the constraints), and of the Drudes' motion relative to their cores.
drude = next(f for f in system.getForces() if isinstance(f, openmm.DrudeForce))
pairs = np.array([drude.getParticleParameters(i)[:2] for i in range(drude.getNumParticles())])  # (Drude, core)
mass = np.array([system.getParticleMass(i).value_in_unit(unit.dalton) for i in range(system.getNumParticles())])
in_peptide = np.array([atom.residue.name == "ALA" for atom in modeller.topology.atoms()])
drudes = np.zeros(len(mass), bool)
drudes[pairs[:, 0]] = True
dof = {}
for name, members in (("peptide", in_peptide), ("water", ~in_peptide)):
    massive = members & (mass > 0) & ~drudes                     # cores and other atoms; Drudes ride with their cores
    constrained = sum(1 for c in range(system.getNumConstraints())
                      if members[system.getConstraintParameters(c)[0]])
    dof[name] = (massive, 3 * massive.sum() - constrained - (3 if name == "water" else 0))  # less the removed momentum
reduced = mass[pairs[:, 0]] * mass[pairs[:, 1]] / (mass[pairs[:, 0]] + mass[pairs[:, 1]])
R = unit.MOLAR_GAS_CONSTANT_R.value_in_unit(unit.kilojoule_per_mole / unit.kelvin)
print(f"{system.getNumParticles()} particles, {len(pairs)} Drude pairs")
print("time (ps)  T peptide (K)  T water (K)  T Drudes (K)")
seconds = 0.0
for _ in range(10):
    begin = time.perf_counter()
    simulation.step(max(1, steps // 10))
    seconds += time.perf_counter() - begin
    v = simulation.context.getState(getVelocities=True).getVelocities(asNumpy=True).value_in_unit(
        unit.nanometer / unit.picosecond)
    com = v.copy()                                               # each core carries its pair's centre of mass
    com[pairs[:, 1]] = ((mass[pairs[:, 1], None] * v[pairs[:, 1]] + mass[pairs[:, 0], None] * v[pairs[:, 0]])
                        / (mass[pairs[:, 1]] + mass[pairs[:, 0]])[:, None])
    pair_mass = mass.copy()
    pair_mass[pairs[:, 1]] += mass[pairs[:, 0]]
    t = {name: np.sum(pair_mass[m, None] * com[m]**2) / (n * R) for name, (m, n) in dof.items()}
    t_drudes = np.sum(reduced[:, None] * (v[pairs[:, 0]] - v[pairs[:, 1]])**2) / (3 * len(pairs) * R)
    time_ps = simulation.context.getState().getTime().value_in_unit(unit.picosecond)
    print(f"{time_ps:9.3f} {t['peptide']:14.1f} {t['water']:12.1f} {t_drudes:13.2f}")
print(f"{10 * max(1, steps // 10) * 2e-6 * 86400 / seconds:.2f} ns/day")
