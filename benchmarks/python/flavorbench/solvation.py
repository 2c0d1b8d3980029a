"""Solvent boxes at a liquid's density.

`Modeller.addSolvent(numAdded=N)` sizes its box so that N waters fit with room to spare at the faces: 256 TIP3P
waters come in a 2.07-nm box, 0.87 g/cm^3 (OpenMM 7.7).  Run at constant volume, such a box is stretched water.
`compress_to_volume` moves every molecule rigidly (its centroid scaled towards the origin) and scales the box until it
has the volume asked for; minimization then relaxes the closer contacts.
"""

import numpy as np
import openmm
import openmm.unit as unit

WATER_DENSITY_300K = 0.9965  # g/cm^3, liquid water at 300 K and 1 atm
AMU_PER_NM3 = 602.214076  # amu per nm^3 in 1 g/cm^3
PROTEIN_SPECIFIC_VOLUME = 0.73  # cm^3/g, the partial specific volume of proteins in water


def volume_nm3(mass_amu, density):
    """The volume (nm^3) of mass_amu at density (g/cm^3)."""
    return mass_amu / (density * AMU_PER_NM3)


def topology_mass(topology, residues=None):
    """The mass (amu) of the topology's atoms, or of those in residues named in `residues`; particles without an
    element (extra particles) count nothing."""
    return sum(atom.element.mass.value_in_unit(unit.dalton) for atom in topology.atoms()
               if atom.element is not None and (residues is None or atom.residue.name in residues))


def water_volume(topology, density=WATER_DENSITY_300K):
    """The volume (nm^3) of the topology's waters (residues HOH) at density (g/cm^3)."""
    return volume_nm3(topology_mass(topology, {"HOH"}), density)


def molecules(topology):
    """The atom indices of each molecule (a connected set of bonded atoms) of the topology."""
    parent = list(range(topology.getNumAtoms()))

    def root(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i
    for a, b in topology.bonds():
        parent[root(a.index)] = root(b.index)
    groups = {}
    for i in range(len(parent)):
        groups.setdefault(root(i), []).append(i)
    return list(groups.values())


def compress_to_volume(modeller, volume):
    """Scales the Modeller's cubic box to `volume` (nm^3), moving each molecule rigidly with its centroid (wrapped
    into the box); returns the new box edge (nm).  ValueError if the box is not cubic or the volume not positive."""
    vectors = np.array(modeller.topology.getPeriodicBoxVectors().value_in_unit(unit.nanometer))
    edge = vectors[0, 0]
    if not np.allclose(vectors, edge * np.eye(3)):
        raise ValueError("compress_to_volume: the box must be cubic")
    if not volume > 0:
        raise ValueError(f"compress_to_volume: volume must be positive (got {volume})")
    scale = (volume / edge**3) ** (1 / 3)
    positions = np.array(modeller.positions.value_in_unit(unit.nanometer))
    for atoms in molecules(modeller.topology):
        centroid = positions[atoms].mean(axis=0)
        wrapped = centroid - edge * np.floor(centroid / edge)
        positions[atoms] += scale * wrapped - centroid
    modeller.topology.setPeriodicBoxVectors(vectors * scale * unit.nanometer)
    modeller.positions = [openmm.Vec3(*p) for p in positions] * unit.nanometer
    return edge * scale
