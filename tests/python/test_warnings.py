"""Configurations that run but are probably not what was meant give an openmmflavors.FlavorsWarning (errors stay
errors): a NonbondedForce in a stiff group of the nonintrusive FLAVOR (the bitmask 1 given for group 1), a planar
angle group that holds other forces, a step size without unit above 0.1 ps, a SIM's stiff mode in a resonance band,
a mesostep beyond the measured ones with frozen angles.  Correct configurations give none."""
import math
import warnings

import openmm
import openmm.unit as unit
import pytest

import openmmflavors
from conftest import OMEGA, build_fpu_system, fpu_positions
from openmmflavors import (FlavorIntegrator, FlavorsWarning, PlanarAngleGroupWarning, ResonanceWarning,
                           StiffGroupWarning, StochasticImpulseIntegrator, UnitlessStepWarning)

FS = unit.femtosecond
PS = unit.picosecond


@pytest.fixture(autouse=True)
def every_flavors_warning_is_an_error_unless_expected():
    with warnings.catch_warnings():
        warnings.simplefilter("error", FlavorsWarning)
        yield


def messages(record):
    return [str(w.message) for w in record]


# ---------------------------------------------------------------------------------------------------------------
# A nonbonded force made stiff by a bitmask meant as a group number


def water_molecule():
    """One flexible water: O-H bonds in group 1, a NonbondedForce in group 0 (its 1-2 and 1-3 pairs excluded)."""
    system = openmm.System()
    for mass in (16.0, 1.0, 1.0):
        system.addParticle(mass)
    bonds = openmm.HarmonicBondForce()
    bonds.addBond(0, 1, 0.09572, 4.6e5)
    bonds.addBond(0, 2, 0.09572, 4.6e5)
    bonds.setForceGroup(1)
    angle = openmm.HarmonicAngleForce()
    angle.addAngle(1, 0, 2, 1.824, 836.8)
    nonbonded = openmm.NonbondedForce()
    for charge in (-0.834, 0.417, 0.417):
        nonbonded.addParticle(charge, 0.3, 0.5)
    for i, j in ((0, 1), (0, 2), (1, 2)):
        nonbonded.addException(i, j, 0.0, 1.0, 0.0)
    for force in (bonds, angle, nonbonded):
        system.addForce(force)
    positions = [openmm.Vec3(0, 0, 0), openmm.Vec3(0.0957, 0, 0), openmm.Vec3(-0.024, 0.0927, 0)] * unit.nanometer
    return system, positions


def step_once(system, positions, integrator):
    context = openmm.Context(system, integrator, openmm.Platform.getPlatformByName("Reference"))
    context.setPositions(positions)
    integrator.step(1)
    return context


def test_a_nonbonded_force_in_a_stiff_nonintrusive_group_names_the_force_the_group_and_the_fix():
    system, positions = water_molecule()
    integrator = FlavorIntegrator(2 * FS, 0.5 * FS, 1)  # 1 is the bitmask of group 0: the NonbondedForce's
    with pytest.warns(StiffGroupWarning) as record:
        context = step_once(system, positions, integrator)
    text = " ".join(messages(record))
    for fragment in ("force 2 (NonbondedForce, force group 0) is stiff", "stiffGroups = 1", "{0}", "0.25",
                     "pass {1}"):
        assert fragment in text, text
    integrator.step(2)  # once per Context
    del context


def test_the_set_of_group_numbers_gives_no_warning():
    system, positions = water_molecule()
    step_once(system, positions, FlavorIntegrator(2 * FS, 0.5 * FS, {1}))


# ---------------------------------------------------------------------------------------------------------------
# separatePlanarAngles into a group that holds other forces


def planar_molecule(angle_group):
    """A planar centre 0 with neighbours 1-3 (three angles of 120 degrees) and a bent one, 2 between 0 and 4: bonds in
    group 1, angles in angle_group."""
    system = openmm.System()
    for mass in (12.0, 16.0, 12.0, 1.0, 1.0):
        system.addParticle(mass)
    bonds = openmm.HarmonicBondForce()
    for i, j in ((0, 1), (0, 2), (0, 3), (2, 4)):
        bonds.addBond(i, j, 0.11, 3e5)
    bonds.setForceGroup(1)
    angles = openmm.HarmonicAngleForce()
    for i, k in ((1, 2), (2, 3), (1, 3)):
        angles.addAngle(i, 0, k, 2 * math.pi / 3, 400.0)
    angles.addAngle(0, 2, 4, 1.9, 300.0)
    angles.setForceGroup(angle_group)
    system.addForce(bonds)
    system.addForce(angles)
    return system


def test_separating_into_the_stiff_angle_group_moves_nothing_and_says_why():
    system = planar_molecule(angle_group=2)
    with pytest.warns(PlanarAngleGroupWarning) as record:
        assert FlavorIntegrator.separatePlanarAngles(system, 2) == 0
    text = " ".join(messages(record))
    for fragment in ("force group 2 holds force 1 (HarmonicAngleForce, 1 angle at centres that are not planar)",
                     "moved nothing", "already in group 2", "a force group of their own, left soft",
                     "separatePlanarAngles(system, 0)"):
        assert fragment in text, text


def test_separating_into_a_group_with_other_forces_warns_after_moving():
    system = planar_molecule(angle_group=2)
    with pytest.warns(PlanarAngleGroupWarning) as record:
        assert FlavorIntegrator.separatePlanarAngles(system, 1) == 3
    text = " ".join(messages(record))
    assert "force 0 (HarmonicBondForce)" in text and "moved 3 angles" in text, text


def test_separating_into_a_group_of_its_own_gives_no_warning_and_a_second_call_none_either():
    system = planar_molecule(angle_group=2)
    assert FlavorIntegrator.separatePlanarAngles(system, 3) == 3
    assert FlavorIntegrator.separatePlanarAngles(system, 3) == 0


# ---------------------------------------------------------------------------------------------------------------
# Step sizes without units


@pytest.mark.parametrize("make, parameter", [
    (lambda: FlavorIntegrator(2, 0.0005, {1}), "mesoStep = 2"),
    (lambda: FlavorIntegrator(2, 0.5, {1}), "microStep = 0.5"),
    (lambda: FlavorIntegrator(0.002, 0.0005, {1}).setMesoStep(3), "mesoStep = 3"),
    (lambda: FlavorIntegrator(0.002, 0.0005, {1}).setStepSize(3), "stepSize = 3"),
    (lambda: FlavorIntegrator(5, 0.0005, {1}).setMicroStep(0.5), "microStep = 0.5"),
    (lambda: StochasticImpulseIntegrator(300, 1, 2, {1}), "stepSize = 2"),
    (lambda: StochasticImpulseIntegrator(300, 1, 0.002, {1}).setStepSize(2.5), "stepSize = 2.5"),
])
def test_a_unitless_step_above_a_tenth_of_a_picosecond_is_taken_as_ps_with_a_warning(make, parameter):
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always", FlavorsWarning)
        make()
    text = [m for m in messages(record) if parameter in m]
    assert text and "ps" in text[0] and "unit.femtoseconds" in text[0], messages(record)
    assert all(issubclass(w.category, UnitlessStepWarning) for w in record)


def test_quantities_and_small_plain_numbers_give_no_warning():
    FlavorIntegrator(2 * FS, 0.5 * FS, {1}).setMesoStep(0.5 * PS)
    FlavorIntegrator(0.002, 0.0005, {1}).setMicroStep(0.001)
    StochasticImpulseIntegrator(300, 1, 2 * FS, {1}).setStepSize(0.004)


def test_the_warning_points_at_the_callers_line():
    with pytest.warns(UnitlessStepWarning) as record:
        FlavorIntegrator(2, 0.0005, {1})
    assert record[0].filename == __file__


# ---------------------------------------------------------------------------------------------------------------
# SIM resonances: the FPU chain's stiff modes have omega = OMEGA (40/ps)


def sim(step, friction=0.0, splitting=None):
    integrator = StochasticImpulseIntegrator(0, friction, step * PS, {1})
    if splitting is not None:
        integrator.setSplitting(splitting)
    context = openmm.Context(build_fpu_system(), integrator, openmm.Platform.getPlatformByName("Reference"))
    context.setPositions(fpu_positions())
    return integrator, context


def test_strang_at_omega_h_two_pi_without_friction_warns_with_the_band():
    integrator, context = sim(2 * math.pi / OMEGA)
    with pytest.warns(ResonanceWarning) as record:
        integrator.step(1)
    text = " ".join(messages(record))
    for fragment in ("9 of 9 stiff modes", "omega H = 2.000 pi", "Strang", "|omega H - k pi| <= 0.05 k pi", "Warped"):
        assert fragment in text, text
    integrator.step(1)  # once, until the step size changes
    integrator.setStepSize(1.0 / OMEGA * PS)
    integrator.step(1)
    integrator.setStepSize(3.1 / OMEGA * PS)
    with pytest.warns(ResonanceWarning):
        integrator.step(1)


def test_friction_that_closes_the_band_warped_and_steps_off_the_bands_give_no_warning():
    for step, friction, splitting in ((2 * math.pi / OMEGA, 5.0, None),
                                      (2 * math.pi / OMEGA, 0.0, StochasticImpulseIntegrator.Warped),
                                      (2 * math.pi / OMEGA, 0.0, StochasticImpulseIntegrator.Filtered),
                                      (1.0 / OMEGA, 0.0, None), (2.5 / OMEGA, 0.0, None)):
        integrator, context = sim(step, friction, splitting)
        integrator.step(2)


def test_without_soft_forces_every_step_is_exact_and_gives_no_warning():
    system = build_fpu_system()
    for index in reversed(range(system.getNumForces())):
        if system.getForce(index).getForceGroup() != 1:
            system.removeForce(index)
    integrator = StochasticImpulseIntegrator(0, 0, 2 * math.pi / OMEGA * PS, {1})
    context = openmm.Context(system, integrator, openmm.Platform.getPlatformByName("Reference"))
    context.setPositions(fpu_positions())
    integrator.step(1)


def test_filtered_warns_at_its_pole_at_omega_h_pi_even_with_friction():
    integrator, context = sim(math.pi / OMEGA, 5.0, StochasticImpulseIntegrator.Filtered)
    with pytest.warns(ResonanceWarning, match="Filtered splitting's filter has a pole"):
        integrator.step(1)


def test_a_warning_can_be_made_an_error():
    integrator, context = sim(2 * math.pi / OMEGA)
    with pytest.raises(ResonanceWarning):
        integrator.step(1)


def test_the_warnings_are_exported():
    assert issubclass(openmmflavors.ResonanceWarning, openmmflavors.FlavorsWarning)
    assert issubclass(openmmflavors.FlavorsWarning, UserWarning)
