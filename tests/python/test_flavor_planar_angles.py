"""FlavorIntegrator.separatePlanarAngles from Python: on OpenMM's villin protein (amber14) it moves the angles of the
sp2 centres, takes an angle Quantity for the threshold, keeps the System's energy, and rejects bad input by name."""
import math
import os

import openmm as mm
import openmm.app as app
import openmm.unit as unit
import pytest

from openmmflavors import FlavorIntegrator

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PDB = os.path.join(REPO_ROOT, "examples", "villin", "villin.pdb")


@pytest.fixture(scope="module")
def protein():
    pdb = app.PDBFile(PDB)
    modeller = app.Modeller(pdb.topology, pdb.positions)
    modeller.deleteWater()
    modeller.delete([r for r in modeller.topology.residues() if r.name in ("CL", "Cl", "NA", "Na")])
    forcefield = app.ForceField("amber14-all.xml", "amber14/tip3p.xml")
    return forcefield, modeller


def new_system(protein):
    forcefield, modeller = protein
    system = forcefield.createSystem(modeller.topology, nonbondedMethod=app.NoCutoff, constraints=app.HBonds)
    for force in system.getForces():
        force.setForceGroup(2 if isinstance(force, mm.HarmonicAngleForce) else 0)
    return system


def energy(system, positions):
    context = mm.Context(system, mm.VerletIntegrator(0.001), mm.Platform.getPlatformByName("Reference"))
    context.setPositions(positions)
    return context.getState(getEnergy=True).getPotentialEnergy().value_in_unit(unit.kilojoule_per_mole)


def test_the_angles_of_sp2_centres_are_moved_and_the_energy_is_kept(protein):
    system = new_system(protein)
    atoms = list(protein[1].topology.atoms())
    before = energy(system, protein[1].positions)
    moved = FlavorIntegrator.separatePlanarAngles(system, 3)
    planar = system.getForce(system.getNumForces() - 1)
    assert isinstance(planar, mm.HarmonicAngleForce) and planar.getForceGroup() == 3
    assert planar.getNumAngles() == moved
    centres = {planar.getAngleParameters(i)[1] for i in range(moved)}
    assert moved == 3 * len(centres)
    names = {atoms[c].name for c in centres}
    # Every backbone carbonyl carbon and every amide nitrogen but the N-terminal one (NH3+, four neighbours);
    # no sp3 carbon (CA) and no tetrahedral centre.
    residues = list(protein[1].topology.residues())
    assert sum(1 for c in centres if atoms[c].name == "C") == len(residues)
    assert sum(1 for c in centres if atoms[c].name == "N") == len(residues) - 1
    assert "CA" not in names and "CB" not in names
    assert math.isclose(energy(system, protein[1].positions), before, rel_tol=1e-9)
    assert FlavorIntegrator.separatePlanarAngles(system, 3) == 0


def test_the_threshold_takes_an_angle_quantity(protein):
    by_radians = FlavorIntegrator.separatePlanarAngles(new_system(protein), 3, math.radians(340))
    by_quantity = FlavorIntegrator.separatePlanarAngles(new_system(protein), 3, 340 * unit.degree)
    default = FlavorIntegrator.separatePlanarAngles(new_system(protein), 3)
    assert by_radians == by_quantity >= default > 0
    assert FlavorIntegrator.separatePlanarAngles(new_system(protein), group=3, minAngleSum=350 * unit.degree) == default


@pytest.mark.parametrize("arguments, exception, fragments", [
    ((32,), mm.OpenMMException, ("group = 32", "force groups are 0 to 31")),
    ((-1,), mm.OpenMMException, ("group = -1", "force groups are 0 to 31")),
    ((3, 7.0), mm.OpenMMException, ("minAngleSum = 7", "at most 2 pi")),
    ((3, float("nan")), mm.OpenMMException, ("minAngleSum = nan",)),
    ((3, 1 * unit.nanometer), TypeError, ("minAngleSum", "not compatible")),
    ((2.5,), TypeError, ("group",)),
])
def test_bad_arguments_are_rejected_by_name_and_change_nothing(protein, arguments, exception, fragments):
    system = new_system(protein)
    forces = system.getNumForces()
    with pytest.raises(exception) as info:
        FlavorIntegrator.separatePlanarAngles(system, *arguments)
    for fragment in fragments:
        assert fragment in str(info.value), str(info.value)
    assert system.getNumForces() == forces


def test_the_protein_keeps_its_temperature_with_the_middle_placement(protein):
    """Villin in vacuum, X-H constrained, bonds and the other angles frozen, Middle placement at delta = 2 fs: its
    second frozen drift follows the microstep's constrained drift, whose chord velocities satisfy the X-H constraints
    only to first order; read as they were, the frozen rates heated the protein to 344 +- 5 K within 0.2 ps.  The
    kinetic temperature must stay within 4 standard errors of 10 block means of the bath's."""
    forcefield, modeller = protein
    system = forcefield.createSystem(modeller.topology, nonbondedMethod=app.NoCutoff, constraints=app.HBonds,
                                     removeCMMotion=False)
    for force in system.getForces():
        force.setForceGroup(1 if isinstance(force, (mm.HarmonicBondForce, mm.HarmonicAngleForce)) else 0)
    FlavorIntegrator.separatePlanarAngles(system, 3)
    platform = mm.Platform.getPlatformByName("CPU")
    start = mm.LangevinMiddleIntegrator(300, 5, 0.0005)
    start.setRandomNumberSeed(2)
    context = mm.Context(system, start, platform, {"Threads": "1"})
    context.setPositions(modeller.positions)
    mm.LocalEnergyMinimizer.minimize(context, 10, 200)
    context.setVelocitiesToTemperature(300, 4)
    start.step(400)
    state = context.getState(getPositions=True, getVelocities=True)
    integrator = FlavorIntegrator(2 * unit.femtosecond, 1 * unit.femtosecond, {1})
    integrator.setAveraging(FlavorIntegrator.ArtificialProjected)
    integrator.setTemperature(300 * unit.kelvin)
    integrator.setFriction(5 / unit.picosecond)
    integrator.setThermostatPlacement(FlavorIntegrator.Middle)
    integrator.setRandomNumberSeed(6)
    context = mm.Context(system, integrator, platform, {"Threads": "1"})
    context.setPositions(state.getPositions())
    context.setVelocities(state.getVelocities())
    integrator.step(100)
    dof = 3 * system.getNumParticles() - system.getNumConstraints()
    blocks = []
    for _ in range(10):
        temperatures = []
        for _ in range(10):
            integrator.step(10)
            kinetic = context.getState(getEnergy=True).getKineticEnergy()
            temperatures.append(2 * kinetic / (dof * unit.MOLAR_GAS_CONSTANT_R) / unit.kelvin)
        blocks.append(sum(temperatures) / len(temperatures))
    mean = sum(blocks) / len(blocks)
    error = math.sqrt(sum((b - mean) ** 2 for b in blocks) / (len(blocks) - 1) / len(blocks))
    assert abs(mean - 300) < 4 * error, (mean, error, blocks)
