"""A protein in water: villin (8,867 atoms, amber14 + TIP3P, PME, X-H bonds constrained) in OpenMM's Simulation.

NOT A WIN: for a protein in water, use OpenMM's LangevinMiddleIntegrator at 4 fs with hydrogen mass repartitioning
(createSystem(..., hydrogenMass=1.5*amu)); --openmm runs it here. FlavorIntegrator's best recipe for proteins (run by
default): the heavy-atom bonds and the angles of the non-planar centres frozen between 1-fs microsteps, 2.5-fs
mesosteps, within the error bars of LangevinMiddle at 2 fs but slower than that 4-fs run (README.md's table). With
repartitioned hydrogens too it takes longer mesosteps, and is faster than the 4-fs run only where its heavy-atom
angles come out wide (examples/villin/README.md).

    PYTHONPATH=build/python .venv/bin/python examples/scripts/protein.py [--steps N] [--openmm] [--quick]
"""
import argparse
import sys

import openmm
from openmm import app, unit
from openmmflavors import FlavorIntegrator

parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
parser.add_argument("--steps", type=int, default=1200, help="steps of 2.5 fs (4 fs with --openmm; default 1200)")
parser.add_argument("--openmm", action="store_true", help="run LangevinMiddleIntegrator at 4 fs instead (the winner)")
parser.add_argument("--quick", action="store_true", help="a smoke run of a few seconds (make test runs it)")
args = parser.parse_args()
steps, equilibration, minimization = (20, 20, 20) if args.quick else (args.steps, 250 if args.openmm else 400, 500)

pdb = app.PDBFile("examples/villin/villin.pdb")
forcefield = app.ForceField("amber14-all.xml", "amber14/tip3p.xml")
hydrogen_mass = 1.5*unit.amu if args.openmm else None              # repartitioning for OpenMM's 4-fs step
system = forcefield.createSystem(pdb.topology, nonbondedMethod=app.PME, nonbondedCutoff=1.0*unit.nanometer,
                                 constraints=app.HBonds, rigidWater=True, removeCMMotion=False,
                                 hydrogenMass=hydrogen_mass)
if args.openmm:
    integrator = openmm.LangevinMiddleIntegrator(300*unit.kelvin, 1/unit.picosecond, 4*unit.femtoseconds)
else:
    # Stiff: the bonds (group 1) and angles (group 2). Soft: everything else (group 0).
    for force in system.getForces():
        force.setForceGroup({openmm.HarmonicBondForce: 1, openmm.HarmonicAngleForce: 2}.get(type(force), 0))
    # The angles at planar (sp2) centres move to group 3, left soft: frozen distances cannot hold a planar centre's
    # motion out of its plane. Give it a group of its own, not the stiff angles' group 2.
    print(FlavorIntegrator.separatePlanarAngles(system, 3), "angles at planar centres left soft")
    integrator = FlavorIntegrator(2.5*unit.femtoseconds, 1*unit.femtoseconds, {1, 2})  # mesostep, microstep, stiff
    integrator.setAveraging(FlavorIntegrator.ArtificialProjected)   # stiff terms frozen between microsteps
    integrator.setThermostatPlacement(FlavorIntegrator.Middle)      # as LangevinMiddleIntegrator
    integrator.setTemperature(300*unit.kelvin)
simulation = app.Simulation(pdb.topology, system, integrator, openmm.Platform.getPlatformByName("CPU"))
simulation.context.setPositions(pdb.positions)
simulation.minimizeEnergy(maxIterations=minimization)
simulation.context.setVelocitiesToTemperature(300*unit.kelvin)
# The minimized structure, started at 300 K, gives half its kinetic energy to the potential: 1 ps at friction 10/ps
# brings it back to 300 K, then the run at 1/ps (the villin scene's friction).
integrator.setFriction(10/unit.picosecond)
simulation.step(equilibration)
integrator.setFriction(1/unit.picosecond)
simulation.reporters.append(app.StateDataReporter(sys.stdout, max(1, steps // 10), time=True, potentialEnergy=True,
                                                  temperature=True, speed=True))
simulation.step(steps)
