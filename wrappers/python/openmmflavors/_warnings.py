"""Warnings for configurations that run without error but are probably not what was meant.

Errors stay errors (openmm.OpenMMException from C++); these are Python warnings (the `warnings` module), each of a
subclass of FlavorsWarning, so that a script can turn them into errors or silence one kind:

    warnings.simplefilter("error", openmmflavors.FlavorsWarning)

- UnitlessStepWarning: a step size given as a plain number above 0.1 ps (usually femtoseconds meant);
- StiffGroupWarning: from FlavorIntegrator.getConfigurationWarnings() at the first step (a nonbonded force in a
  stiff group of the nonintrusive FLAVOR; a mesostep longer than any measured as accurate with frozen angles);
- PlanarAngleGroupWarning: separatePlanarAngles() into a group that holds other forces;
- ResonanceWarning: from StochasticImpulseIntegrator.getConfigurationWarnings() at the first step and after the step
  size, friction or splitting changes (stiff modes with omega*H in a resonance band of the splitting).
"""
import copy
import math
import numbers
import warnings

import openmm
import openmm.unit as unit


class FlavorsWarning(UserWarning):
    """A configuration of openmmflavors that runs but is probably not what was meant."""


class UnitlessStepWarning(FlavorsWarning):
    """A step size without a unit above 0.1 ps."""


class StiffGroupWarning(FlavorsWarning):
    """The stiff groups or the mesostep of a FlavorIntegrator's Context (getConfigurationWarnings())."""


class PlanarAngleGroupWarning(FlavorsWarning):
    """FlavorIntegrator.separatePlanarAngles() into a force group that holds other forces."""


class ResonanceWarning(FlavorsWarning):
    """A StochasticImpulseIntegrator's stiff mode in a resonance band of its splitting."""


# Above this a plain number is not a molecular time step in ps (0.1 ps = 100 fs).
UNITLESS_STEP_LIMIT = 0.1


def checkUnitlessStep(value, name, owner):
    """Warn if value, a step size about to be taken as picoseconds, is a plain number above 0.1."""
    if unit.is_quantity(value) or not isinstance(value, numbers.Real) or isinstance(value, bool):
        return
    value = float(value)
    if math.isfinite(value) and value > UNITLESS_STEP_LIMIT:
        warnings.warn(f"{owner}: {name} = {value:g} has no unit and is taken as {value:g} ps ({value * 1000:g} fs), "
                      f"longer than any molecular time step; if femtoseconds were meant, pass "
                      f"{value:g}*unit.femtoseconds (a Quantity states its unit and is never warned about)",
                      UnitlessStepWarning, stacklevel=3)


def checkFlavorContext(integrator):
    """At the first step of a FlavorIntegrator's Context: emit getConfigurationWarnings() once."""
    if integrator.__dict__.get("_flavorsChecked"):
        return
    messages = integrator.getConfigurationWarnings()
    integrator.__dict__["_flavorsChecked"] = True
    for message in messages:
        warnings.warn(message, StiffGroupWarning, stacklevel=3)


def stepChanged(integrator):
    """The step size, friction or splitting changed: check the SIM's resonances again at the next step."""
    integrator.__dict__["_flavorsChecked"] = False


def checkResonance(integrator):
    """At the first step of a SIM's Context and after a change of its step size, friction or splitting: emit
    getConfigurationWarnings() (stiff modes in a resonance band of the splitting)."""
    if integrator.__dict__.get("_flavorsChecked"):
        return
    try:
        messages = integrator.getConfigurationWarnings()
    except openmm.OpenMMException:
        return  # no positions yet: the step reports it
    integrator.__dict__["_flavorsChecked"] = True
    for message in messages:
        warnings.warn(message, ResonanceWarning, stacklevel=3)


def forcesInGroup(system, group):
    """The indices of the System's forces in force group group (before separatePlanarAngles() adds its own)."""
    return [f for f in range(system.getNumForces()) if system.getForce(f).getForceGroup() == group]


def _nonPlanarAngles(system, force, group, minAngleSum):
    """How many angles of the HarmonicAngleForce force (nonzero force constant) are not at planar centres, as
    separatePlanarAngles() decides: a copy in a System of the same size, outside group, is separated into group."""
    from .openmmflavors import _openmmflavors
    scratch = openmm.System()
    for _ in range(system.getNumParticles()):
        scratch.addParticle(1.0)
    angles = copy.deepcopy(force)
    angles.setForceGroup((group + 1) % 32)
    scratch.addForce(angles)
    _openmmflavors.FlavorIntegrator_separatePlanarAngles(scratch, group, minAngleSum)
    left = scratch.getForce(0)
    return sum(1 for a in range(left.getNumAngles()) if left.getAngleParameters(a)[4].value_in_unit(
        unit.kilojoule_per_mole / unit.radian**2) != 0.0)


def checkPlanarAngleGroup(system, group, minAngleSum, moved, before):
    """After separatePlanarAngles(system, group): warn if group held forces other than planar centres' angles
    (before: forcesInGroup() before the call)."""
    others, heldPlanar = [], False
    for f in before:
        force = system.getForce(f)
        text = f"force {f} ({force.getName()})"
        if isinstance(force, openmm.HarmonicAngleForce):
            nonPlanar = _nonPlanarAngles(system, force, group, minAngleSum)
            heldPlanar = heldPlanar or nonPlanar < sum(
                1 for a in range(force.getNumAngles())
                if force.getAngleParameters(a)[4].value_in_unit(unit.kilojoule_per_mole / unit.radian**2) != 0.0)
            if nonPlanar == 0:
                continue  # the planar group of an earlier call
            text = (f"force {f} (HarmonicAngleForce, {nonPlanar} angle{'s' if nonPlanar != 1 else ''} at centres that "
                    f"are not planar)")
        others.append(text)
    if not others:
        return
    used = {system.getForce(f).getForceGroup() for f in range(system.getNumForces())}
    free = next((g for g in range(32) if g not in used), None)
    why = (f"it moved nothing: the planar centres' angles are in a HarmonicAngleForce already in group {group}, and "
           f"angles already in the group stay where they are" if moved == 0 and heldPlanar
           else f"it moved {moved} angles into a group that also holds them")
    suggestion = f", e.g. separatePlanarAngles(system, {free})" if free is not None else ""
    warnings.warn(f"FlavorIntegrator.separatePlanarAngles: force group {group} holds {', '.join(others)}; {why}.  "
                  f"The planar centres' angles need a force group of their own, left soft (not in the integrator's "
                  f"stiffGroups): pass a group no force uses{suggestion}.", PlanarAngleGroupWarning, stacklevel=3)
