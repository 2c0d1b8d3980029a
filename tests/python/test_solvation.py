"""flavorbench.solvation: boxes brought to a liquid's density, molecules moved rigidly; the scenes built at it."""

import os
import sys

import numpy as np
import openmm.app as app
import openmm.unit as unit
import pytest
from flavorbench import solvation

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _tip3p_box(waters):
    modeller = app.Modeller(app.Topology(), [])
    modeller.addSolvent(app.ForceField("tip3p.xml"), model="tip3p", numAdded=waters, neutralize=False)
    return modeller


def _density(topology, system=None):
    edge = topology.getPeriodicBoxVectors()[0][0].value_in_unit(unit.nanometer)
    if system is None:
        mass = solvation.topology_mass(topology)
    else:
        mass = sum(system.getParticleMass(i).value_in_unit(unit.dalton) for i in range(system.getNumParticles()))
    return mass / (edge**3 * solvation.AMU_PER_NM3)


def test_add_solvent_leaves_the_box_below_water_density():
    # What the helper is for: Modeller's numAdded box is 13 % short of water's density.
    assert _density(_tip3p_box(256).topology) < 0.9


def test_compressing_moves_each_molecule_rigidly_to_the_density_asked_for():
    modeller = _tip3p_box(64)
    before = np.array(modeller.positions.value_in_unit(unit.nanometer)).reshape(-1, 3, 3)
    old_edge = modeller.topology.getPeriodicBoxVectors()[0][0].value_in_unit(unit.nanometer)
    volume = solvation.water_volume(modeller.topology)
    edge = solvation.compress_to_volume(modeller, volume)
    after = np.array(modeller.positions.value_in_unit(unit.nanometer)).reshape(-1, 3, 3)
    assert edge == pytest.approx(volume ** (1 / 3), rel=1e-12)
    assert _density(modeller.topology) == pytest.approx(solvation.WATER_DENSITY_300K, rel=1e-12)
    # Each molecule translated as a whole: its internal vectors unchanged, its centroid (wrapped) scaled.
    np.testing.assert_allclose(after - after[:, :1], before - before[:, :1], atol=1e-12)
    wrapped = before.mean(axis=1) - old_edge * np.floor(before.mean(axis=1) / old_edge)
    np.testing.assert_allclose(after.mean(axis=1), wrapped * edge / old_edge, atol=1e-12)


def test_molecules_are_the_bonded_groups():
    groups = solvation.molecules(_tip3p_box(10).topology)
    assert sorted(len(g) for g in groups) == [3] * 10


@pytest.mark.parametrize("volume", [0.0, -1.0, float("nan")])
def test_a_volume_that_is_not_positive_is_refused_and_the_box_kept(volume):
    modeller = _tip3p_box(10)
    box = modeller.topology.getPeriodicBoxVectors()
    with pytest.raises(ValueError, match="volume must be positive"):
        solvation.compress_to_volume(modeller, volume)
    assert modeller.topology.getPeriodicBoxVectors() == box


def test_a_box_that_is_not_cubic_is_refused():
    modeller = _tip3p_box(10)
    modeller.topology.setPeriodicBoxVectors(np.diag([2.0, 2.0, 3.0]) * unit.nanometer)
    with pytest.raises(ValueError, match="cubic"):
        solvation.compress_to_volume(modeller, 8.0)


def test_the_water_scenes_are_built_at_water_density():
    sys.path.insert(0, os.path.join(REPO_ROOT, "examples", "drude_water"))
    sys.path.insert(0, os.path.join(REPO_ROOT, "examples", "flexible_water"))
    import drude_water
    import flexible_water
    system, topology, _, _ = drude_water.build_water(256)
    assert _density(topology) == pytest.approx(solvation.WATER_DENSITY_300K, rel=1e-9)
    # The force field's masses (the Drude particle's 0.4 amu taken from its oxygen) differ from the elements' by 2e-5.
    assert _density(topology, system) == pytest.approx(solvation.WATER_DENSITY_300K, rel=1e-4)
    _, modeller = flexible_water.build_box(216)
    assert _density(modeller.topology) == pytest.approx(solvation.WATER_DENSITY_300K, rel=1e-9)


def test_the_solution_scenes_hold_their_waters_at_water_density():
    sys.path.insert(0, os.path.join(REPO_ROOT, "examples", "drude_ions"))
    sys.path.insert(0, os.path.join(REPO_ROOT, "examples", "drude_protein"))
    import drude_ions
    import drude_protein
    _, topology, _ = drude_ions.build(248, 4, 0.8, 1)
    edge = topology.getPeriodicBoxVectors()[0][0].value_in_unit(unit.nanometer)
    assert edge**3 == pytest.approx(solvation.water_volume(topology) + 4 * drude_ions.NACL_PAIR_VOLUME, rel=1e-9)
    _, topology, _ = drude_protein.build(250, 0.8)
    edge = topology.getPeriodicBoxVectors()[0][0].value_in_unit(unit.nanometer)
    peptide = solvation.topology_mass(topology, {drude_protein.PEPTIDE}) * solvation.PROTEIN_SPECIFIC_VOLUME
    assert edge**3 == pytest.approx(solvation.water_volume(topology) + peptide / solvation.AMU_PER_NM3, rel=1e-9)
