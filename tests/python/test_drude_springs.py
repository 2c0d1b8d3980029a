"""StochasticImpulseIntegrator.separateDrudeSprings from Python, on villin and its two chloride ions in the Drude-2019
force field (OpenMM's test.pdb without its water, through Modeller.addExtraParticles with charmm_polar_2019.xml: 984
particles, 291 Drude particles, 51 of them anisotropic, 691 Thole-screened pairs, 109 lone pairs): the isotropic
springs move to the stiff group with the force constants written here from DrudeForce's formulas, the energy and
forces stay the same, the SIM takes the separated System (its stiff modes are the springs' sqrt(k/mu)) and rejects
the DrudeForce as stiff, a short SIM run stays on the original energy surface, and bad input is rejected by name
without changing the System."""
import os

import numpy as np
import openmm as mm
import openmm.app as app
import openmm.unit as unit
import pytest

from openmmflavors import StochasticImpulseIntegrator

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PDB = os.path.join(REPO_ROOT, "examples", "villin", "villin.pdb")
SOFT, STIFF, DRUDE = 0, 1, 2   # groups: everything else, the separated springs, the DrudeForce
ONE_4PI_EPS0 = 138.935457644382  # kJ nm/(mol e^2)


@pytest.fixture(scope="module")
def protein():
    pdb = app.PDBFile(PDB)
    modeller = app.Modeller(pdb.topology, pdb.positions)
    modeller.deleteWater()
    forcefield = app.ForceField("charmm_polar_2019.xml")
    modeller.addExtraParticles(forcefield)
    system = forcefield.createSystem(modeller.topology, nonbondedMethod=app.NoCutoff)
    drude = next(f for f in system.getForces() if isinstance(f, mm.DrudeForce))
    # Modeller puts the Drude particles on their cores: displace them by up to 0.005 nm so the springs and the
    # anisotropic terms carry energy.
    positions = np.array(modeller.positions.value_in_unit(unit.nanometer))
    rng = np.random.default_rng(11)
    for i in range(drude.getNumParticles()):
        positions[drude.getParticleParameters(i)[0]] += rng.uniform(-0.005, 0.005, 3)
    return mm.XmlSerializer.serialize(system), positions


def new_system(protein):
    system = mm.XmlSerializer.deserialize(protein[0])
    for force in system.getForces():
        force.setForceGroup(DRUDE if isinstance(force, mm.DrudeForce) else SOFT)
    return system


def evaluate(system, positions, groups=-1):
    context = mm.Context(system, mm.VerletIntegrator(0.001), mm.Platform.getPlatformByName("Reference"))
    context.setPositions(positions)
    context.computeVirtualSites()
    state = context.getState(getEnergy=True, getForces=True, getPositions=True, groups=groups)
    return (state.getPotentialEnergy().value_in_unit(unit.kilojoule_per_mole),
            state.getForces(asNumpy=True).value_in_unit(unit.kilojoule_per_mole / unit.nanometer),
            state.getPositions(asNumpy=True).value_in_unit(unit.nanometer))


def isotropic_springs(system):
    """(Drude particle, core, k) of every Drude particle, k = q^2/(4 pi eps0 alpha a3) as DrudeForce defines it."""
    drude = next(f for f in system.getForces() if isinstance(f, mm.DrudeForce))
    springs = []
    for i in range(drude.getNumParticles()):
        p, p1, p2, p3, p4, q, alpha, aniso12, aniso34 = drude.getParticleParameters(i)
        a1 = 1.0 if p2 == -1 else aniso12
        a2 = 1.0 if p3 == -1 or p4 == -1 else aniso34
        q = q.value_in_unit(unit.elementary_charge)
        alpha = alpha.value_in_unit(unit.nanometer**3)
        springs.append((p, p1, ONE_4PI_EPS0 * q * q / (alpha * (3 - a1 - a2))))
    return springs


def test_the_protein_is_the_drude_2019_villin(protein):
    system = new_system(protein)
    drude = next(f for f in system.getForces() if isinstance(f, mm.DrudeForce))
    anisotropic = sum(1 for i in range(drude.getNumParticles()) if drude.getParticleParameters(i)[2] != -1)
    lone_pairs = sum(1 for i in range(system.getNumParticles()) if system.isVirtualSite(i))
    assert (system.getNumParticles(), drude.getNumParticles(), anisotropic, drude.getNumScreenedPairs(), lone_pairs) \
        == (984, 291, 51, 691, 109)


def test_the_isotropic_springs_move_and_energy_and_forces_stay(protein):
    system = new_system(protein)
    positions = protein[1]
    energy, forces, q = evaluate(system, positions)
    drude_energy, drude_forces, _ = evaluate(system, positions, {DRUDE})
    forces_before = system.getNumForces()
    StochasticImpulseIntegrator.separateDrudeSprings(system, STIFF)
    assert system.getNumForces() == forces_before + 2
    stiff = [f for f in system.getForces() if f.getForceGroup() == STIFF]
    assert len(stiff) == 1 and isinstance(stiff[0], mm.HarmonicBondForce) and stiff[0].getNumBonds() == 291

    energy_after, forces_after, _ = evaluate(system, positions)
    assert abs(energy_after - energy) <= 1e-10 * abs(energy)
    assert np.max(np.abs(forces_after - forces)) <= 1e-10 * np.max(np.abs(forces))
    # What the DrudeForce computed is now its group and the stiff group together, to rounding of its own size.
    split_energy, split_forces, _ = evaluate(system, positions, {STIFF, DRUDE})
    assert abs(split_energy - drude_energy) <= 1e-10 * abs(drude_energy)
    assert np.max(np.abs(split_forces - drude_forces)) <= 1e-10 * np.max(np.abs(drude_forces))

    # The stiff group is 0.5 k |d|^2 per Drude particle, with k from the formulas above.
    stiff_energy, stiff_forces, _ = evaluate(system, positions, {STIFF})
    expected_energy, expected_forces = 0.0, np.zeros_like(forces)
    for p, p1, k in isotropic_springs(system):
        d = q[p] - q[p1]
        expected_energy += 0.5 * k * d @ d
        expected_forces[p] -= k * d
        expected_forces[p1] += k * d
    assert expected_energy > 100   # the displaced Drude particles load their springs
    assert abs(stiff_energy - expected_energy) <= 1e-10 * expected_energy
    assert np.max(np.abs(stiff_forces - expected_forces)) <= 1e-9 * np.max(np.abs(expected_forces))
    # The soft remainder (anisotropic terms and Thole screening) is what the DrudeForce computed less the springs.
    remainder, _, _ = evaluate(system, positions, {DRUDE})
    assert abs(remainder - (drude_energy - expected_energy)) <= 1e-9 * abs(drude_energy)


def test_the_impulse_integrator_takes_the_separated_springs_and_rejects_the_drude_force(protein):
    system = new_system(protein)
    platform = mm.Platform.getPlatformByName("CPU")
    integrator = StochasticImpulseIntegrator(300, 5, 0.0005, {DRUDE})
    context = mm.Context(system, integrator, platform)
    context.setPositions(protein[1])
    with pytest.raises(mm.OpenMMException, match="not quadratic"):
        integrator.getStiffModeFrequencies()
    del context

    StochasticImpulseIntegrator.separateDrudeSprings(system, STIFF)
    integrator = StochasticImpulseIntegrator(300, 5, 0.0005, {STIFF})
    context = mm.Context(system, integrator, platform)
    context.setPositions(protein[1])
    omega = integrator.getStiffModeFrequencies().value_in_unit(unit.picosecond**-1)
    omega = np.sort(omega[omega > 1.0])
    mass = [system.getParticleMass(i).value_in_unit(unit.dalton) for i in range(system.getNumParticles())]
    expected = np.sort([np.sqrt(k * (mass[p] + mass[p1]) / (mass[p] * mass[p1]))
                        for p, p1, k in isotropic_springs(system) for _ in range(3)])
    assert len(omega) == 3 * 291
    assert np.max(np.abs(omega - expected) / expected) < 1e-7


def test_a_short_impulse_run_stays_on_the_original_energy_surface(protein):
    """20 fs of the separated protein (Warped, Middle, 0.5 fs, Drudes at 1 K): finite, and its energy and forces where
    it ends are those of the unseparated System."""
    original = new_system(protein)
    system = new_system(protein)
    StochasticImpulseIntegrator.separateDrudeSprings(system, STIFF)
    integrator = StochasticImpulseIntegrator(300 * unit.kelvin, 5 / unit.picosecond, 0.5 * unit.femtosecond, {STIFF})
    integrator.setSplitting(StochasticImpulseIntegrator.Warped)
    integrator.setThermostatPlacement(StochasticImpulseIntegrator.Middle)
    integrator.setStiffModeTemperature(1 * unit.kelvin)
    integrator.setStiffModeFriction(20 / unit.picosecond)
    integrator.setRandomNumberSeed(3)
    context = mm.Context(system, integrator, mm.Platform.getPlatformByName("CPU"), {"Threads": "1"})
    context.setPositions(protein[1])
    context.computeVirtualSites()
    integrator.step(40)
    q = context.getState(getPositions=True).getPositions(asNumpy=True).value_in_unit(unit.nanometer)
    assert np.all(np.isfinite(q))
    # Both Systems where the run ended, on the Reference platform (the run's CPU nonbonded forces are single precision).
    energy, forces, _ = evaluate(original, q)
    separated_energy, separated_forces, _ = evaluate(system, q)
    assert abs(separated_energy - energy) <= 1e-10 * abs(energy)
    assert np.max(np.abs(separated_forces - forces)) <= 1e-10 * np.max(np.abs(forces))
    displacement = [np.linalg.norm(q[p] - q[p1]) for p, p1, _ in isotropic_springs(system)]
    assert max(displacement) < 0.02


@pytest.mark.parametrize("group, exception, fragments", [
    (32, mm.OpenMMException, ("separateDrudeSprings", "stiffGroup = 32", "force groups are 0 to 31")),
    (-1, mm.OpenMMException, ("stiffGroup = -1", "0 to 31")),
    (DRUDE, mm.OpenMMException, (f"stiffGroup = {DRUDE}", "group of the DrudeForce")),
    (1.0, TypeError, ("stiffGroup",)),
])
def test_bad_arguments_are_rejected_by_name_and_change_nothing(protein, group, exception, fragments):
    system = new_system(protein)
    forces = system.getNumForces()
    with pytest.raises(exception) as info:
        StochasticImpulseIntegrator.separateDrudeSprings(system, group)
    for fragment in fragments:
        assert fragment in str(info.value), str(info.value)
    assert system.getNumForces() == forces


def test_a_numpy_group_is_taken_and_a_second_call_or_a_system_without_drude_force_is_rejected(protein):
    system = new_system(protein)
    StochasticImpulseIntegrator.separateDrudeSprings(system, np.int64(STIFF))
    forces = system.getNumForces()
    with pytest.raises(mm.OpenMMException, match="already separated"):
        StochasticImpulseIntegrator.separateDrudeSprings(system, 3)
    assert system.getNumForces() == forces
    plain = mm.System()
    plain.addParticle(1.0)
    with pytest.raises(mm.OpenMMException, match="without a DrudeForce"):
        StochasticImpulseIntegrator.separateDrudeSprings(plain, STIFF)
    assert plain.getNumForces() == 0
