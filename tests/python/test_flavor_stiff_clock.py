"""FlavorIntegrator.setStiffClockParameter from Python: the clock is in ps and advances the microstep per mesostep,
it survives XmlSerializer, copy and pickle, older documents still load, and a parameter the Context lacks is
rejected by name with the old setting kept."""
import copy
import pickle

import openmm
import openmm.unit as unit
import pytest

import openmmflavors  # noqa: F401
from openmmflavors import FlavorIntegrator

DELTA = 4 * unit.femtosecond
TAU = 1 * unit.femtosecond


def clock_system():
    """One particle: a soft spring (group 0) and a stiff force that oscillates with the global parameter t (group 1)."""
    system = openmm.System()
    system.addParticle(2.0)
    soft = openmm.CustomExternalForce("0.5*x^2")
    soft.addParticle(0, [])
    system.addForce(soft)
    stiff = openmm.CustomExternalForce("300*sin(2000*t)*cos(x)")
    stiff.addGlobalParameter("t", 0.0)
    stiff.addParticle(0, [])
    stiff.setForceGroup(1)
    system.addForce(stiff)
    return system


def make(integrator, platform="Reference"):
    context = openmm.Context(clock_system(), integrator, openmm.Platform.getPlatformByName(platform))
    context.setPositions([openmm.Vec3(0.3, 0, 0)] * unit.nanometer)
    context.setVelocities([openmm.Vec3(0.1, 0, 0)] * unit.nanometer / unit.picosecond)
    return context


def test_default_is_off():
    assert FlavorIntegrator(DELTA, TAU, {1}).getStiffClockParameter() == ""


@pytest.mark.parametrize("platform", ["Reference", "CPU"])
def test_clock_is_in_picoseconds_and_advances_tau_per_mesostep(platform):
    integrator = FlavorIntegrator(DELTA, TAU, {1})
    integrator.setStiffClockParameter("t")
    assert integrator.getStiffClockParameter() == "t"
    context = make(integrator, platform)
    integrator.step(10)
    # The Verlet step's closing kick evaluates the stiff forces at the clock 10 tau: 0.010 ps, while the Context's
    # time is 10 delta = 0.040 ps.
    assert context.getParameter("t") == pytest.approx(0.010, abs=1e-15)
    assert context.getState().getTime().value_in_unit(unit.picosecond) == pytest.approx(0.040, abs=1e-15)


def test_without_clock_the_parameter_stays():
    integrator = FlavorIntegrator(DELTA, TAU, {1})
    context = make(integrator)
    context.setParameter("t", 0.5)
    integrator.step(10)
    assert context.getParameter("t") == 0.5


def copies(integrator):
    return {
        "xml": openmm.XmlSerializer.deserialize(openmm.XmlSerializer.serialize(integrator)),
        "copy": copy.copy(integrator),
        "deepcopy": copy.deepcopy(integrator),
        "pickle": pickle.loads(pickle.dumps(integrator)),
        "clone": openmm.XmlSerializer.clone(integrator),
    }


def test_serialization_copy_and_pickle_keep_the_clock():
    integrator = FlavorIntegrator(DELTA, TAU, {1})
    integrator.setStiffClockParameter("t")
    text = openmm.XmlSerializer.serialize(integrator)
    assert 'version="4"' in text and 'stiffClockParameter="t"' in text
    for name, other in copies(integrator).items():
        assert isinstance(other, FlavorIntegrator), name
        assert other.getStiffClockParameter() == "t", name
    # The copy integrates exactly like the original.
    reference = make(integrator)
    integrator.step(25)
    twin = copies(integrator)["pickle"]
    twin_context = make(twin)
    twin.step(25)
    x = reference.getState(getPositions=True).getPositions(asNumpy=True)
    y = twin_context.getState(getPositions=True).getPositions(asNumpy=True)
    assert (x == y).all()


def test_without_clock_the_document_is_version_3():
    integrator = FlavorIntegrator(DELTA, TAU, {1})
    text = openmm.XmlSerializer.serialize(integrator)
    assert 'version="3"' in text and "stiffClockParameter" not in text
    assert openmm.XmlSerializer.deserialize(text).getStiffClockParameter() == ""


def test_unknown_parameter_is_rejected_at_context_creation():
    integrator = FlavorIntegrator(DELTA, TAU, {1})
    integrator.setStiffClockParameter("time")
    with pytest.raises(openmm.OpenMMException) as info:
        make(integrator)
    message = str(info.value)
    assert "stiffClockParameter" in message and '"time"' in message and "t" in message


def test_unknown_parameter_is_rejected_on_a_bound_integrator_which_keeps_its_setting():
    integrator = FlavorIntegrator(DELTA, TAU, {1})
    integrator.setStiffClockParameter("t")
    context = make(integrator)
    with pytest.raises(openmm.OpenMMException, match='stiffClockParameter.*"tick"'):
        integrator.setStiffClockParameter("tick")
    assert integrator.getStiffClockParameter() == "t"
    integrator.step(2)
    assert context.getParameter("t") == pytest.approx(0.002, abs=1e-15)



def test_checkpoint_continues_the_clock_and_a_version_2_checkpoint_still_loads():
    integrator = FlavorIntegrator(DELTA, TAU, {1})
    integrator.setStiffClockParameter("t")
    context = make(integrator)
    integrator.step(7)
    checkpoint = context.createCheckpoint()
    integrator.step(5)
    expected = context.getState(getPositions=True).getPositions(asNumpy=True)
    context.loadCheckpoint(checkpoint)
    integrator.step(5)
    assert (context.getState(getPositions=True).getPositions(asNumpy=True) == expected).all()
    # Version 2 had no stiff clock and no proposal counts (version 4): their 16 + 16 bytes before the end tag gone,
    # the clock restarts from the Context's time times tau/delta, the same clock to rounding.  Its step history (the
    # constraint shares, the force differences) is, both empty here, the bytes of version 5's (the force differences,
    # the constraint processing).
    tag = b"openmm-flavors integrator state\n"
    end = b"end of openmm-flavors integrator state\n"
    start, stop = checkpoint.index(tag), checkpoint.index(end)
    name_length = int.from_bytes(checkpoint[start + len(tag):start + len(tag) + 4], "little")
    version_at = start + len(tag) + 4 + name_length
    assert int.from_bytes(checkpoint[version_at:version_at + 4], "little") == 5
    old = (checkpoint[:version_at] + (2).to_bytes(4, "little") + checkpoint[version_at + 4:stop - 32] +
           checkpoint[stop:])
    context.loadCheckpoint(old)
    integrator.step(5)
    x = context.getState(getPositions=True).getPositions(asNumpy=True).value_in_unit(unit.nanometer)
    assert abs(x[0][0] - expected.value_in_unit(unit.nanometer)[0][0]) < 1e-12
    assert context.getParameter("t") == pytest.approx(0.012, abs=1e-15)
