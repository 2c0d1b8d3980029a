"""describeStep() and describeContext(): the compiled step and the configured Context as text."""
import openmm
import openmm.app as app
import openmm.unit as unit
import pytest

from conftest import protein_recipe_flavor
from openmmflavors import FlavorIntegrator, StochasticImpulseIntegrator


def water_context(integrator, waters):
    """A Reference Context of flexible water, its bonds and angles stiff (group 1)."""
    forcefield = app.ForceField("tip3p.xml")
    modeller = app.Modeller(app.Topology(), [])
    modeller.addSolvent(forcefield, model="tip3p", numAdded=waters)
    system = forcefield.createSystem(modeller.topology, nonbondedMethod=app.NoCutoff, rigidWater=False)
    for force in system.getForces():
        force.setForceGroup(1 if isinstance(force, (openmm.HarmonicBondForce, openmm.HarmonicAngleForce)) else 0)
    context = openmm.Context(system, integrator, openmm.Platform.getPlatformByName("Reference"))
    context.setPositions(modeller.positions)
    return context


def test_the_flavor_step_names_what_freezes_once_the_first_step_has_measured_it():
    integrator = protein_recipe_flavor()
    step = "K_S(τ) θK_S(δ−τ) θ((δ−τ)/2) K_F(τ) D(τ/2) O(δ) D(τ/2) θ((δ−τ)/2)   [O: 300 K, 1/ps; θ holds "
    assert integrator.describeStep() == step + ("the stiff modes if the stiff groups are quadratic, else their bonded "
                                                "distances (measured at the first step)]")
    context = water_context(integrator, 20)
    integrator.step(1)
    # 20 waters: two bonds and the H-H distance of the angle each.
    assert integrator.describeStep() == step + "the 60 stiff bonded distances]"
    # The description follows the settings.
    integrator.setThermostatPlacement(FlavorIntegrator.Edges)
    assert integrator.describeStep().startswith("O(δ/2) K_S(τ/2) θK_S((δ−τ)/2) θ((δ−τ)/2) K_F(τ/2) D(τ) K_F(τ/2)")


def test_the_sim_step_names_its_splitting_placement_and_baths():
    integrator = StochasticImpulseIntegrator(300 * unit.kelvin, 5 / unit.picosecond, 2.5 * unit.femtoseconds, {1})
    assert integrator.describeStep() == "K_S(H/2) E(H) K_S(H/2)   [E: zero modes 300 K, 5/ps, stiff modes 300 K, 5/ps]"
    integrator.setSplitting(StochasticImpulseIntegrator.Warped)
    integrator.setThermostatPlacement(StochasticImpulseIntegrator.Middle)
    integrator.setStiffModeTemperature(1 * unit.kelvin)
    integrator.setStiffModeFriction(20 / unit.picosecond)
    assert integrator.describeStep() == ("K_S(H/2) E^ω̃M(H) K_S(H/2)   [E: zero modes 300 K, 5/ps, stiff modes 1 K, "
                                         "20/ps]")
    integrator.setSplitting(StochasticImpulseIntegrator.Filtered)
    assert integrator.describeStep().startswith("K^κ_S(H/2) E^M(H) K^κ_S(H/2)")


def test_describe_context_lists_every_force_with_its_role_and_what_freezes():
    integrator = protein_recipe_flavor()
    with pytest.raises(openmm.OpenMMException, match="bound to a Context"):
        integrator.describeContext()
    context = water_context(integrator, 10)
    text = integrator.describeContext()
    assert text.startswith("FlavorIntegrator, mesostep δ = 2 fs, microstep τ = 0.5 fs\nstep: K_S(τ)")
    assert "force 0 (HarmonicBondForce, force group 1): stiff" in text
    assert "(NonbondedForce, force group 0): soft" in text
    assert text.endswith("frozen: measured when the first step starts\n")
    integrator.step(1)
    assert integrator.describeContext().endswith("frozen: 30 distances of the stiff bonded forces\n")


def test_describe_context_gives_the_stiff_modes_and_omega_h():
    system = openmm.System()
    for mass in (15.6, 0.4, 12.0):
        system.addParticle(mass)
    spring = openmm.HarmonicBondForce()
    spring.addBond(0, 1, 0.0, 418400.0)
    spring.setForceGroup(1)
    system.addForce(spring)
    tether = openmm.CustomExternalForce("x^2+y^2+z^2")
    for i in range(3):
        tether.addParticle(i, [])
    system.addForce(tether)
    integrator = StochasticImpulseIntegrator(300 * unit.kelvin, 5 / unit.picosecond, 2.5 * unit.femtoseconds, {1})
    context = openmm.Context(system, integrator, openmm.Platform.getPlatformByName("Reference"))
    context.setPositions([openmm.Vec3(0, 0, 0), openmm.Vec3(0.001, 0, 0), openmm.Vec3(0.3, 0, 0)])
    text = integrator.describeContext()
    # The Drude-like pair's relative mode: omega = sqrt(k/mu) = 1035.8/ps (mu = 0.39 amu), 3 directions,
    # omega H = 0.8242 pi.
    assert "force 0 (HarmonicBondForce, force group 1): stiff\n" in text
    assert "force 1 (CustomExternalForce, force group 0): soft\n" in text
    assert "stiff modes: 3, ω from 1036 to 1036 /ps, ωH from 0.8242π to 0.8242π\n" in text
