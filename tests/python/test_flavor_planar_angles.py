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
