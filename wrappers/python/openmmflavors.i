%module(package="openmmflavors") openmmflavors

%include "std_string.i"
%include "std_vector.i"
%import "OpenMMBase.i"

%{
#include "FlavorIntegrator.h"
#include "StochasticImpulseIntegrator.h"
#include "openmm/OpenMMException.h"
#include <Python.h>
%}

// C++ exceptions become openmm.OpenMMException, as in OpenMM's own wrapper.
%exception {
    try {
        $action
    } catch (std::exception& e) {
        PyObject* mm = PyImport_AddModule("openmm");
        PyObject* openmmException = PyObject_GetAttrString(mm, "OpenMMException");
        PyErr_SetString(openmmException, e.what());
        Py_XDECREF(openmmException);
        SWIG_fail;
    }
}

// Stepping releases the GIL, like OpenMM's integrators.
%exception *::step {
    PyThreadState* savedThreadState = PyEval_SaveThread();
    try {
        $action
    } catch (std::exception& e) {
        PyEval_RestoreThread(savedThreadState);
        PyObject* mm = PyImport_AddModule("openmm");
        PyObject* openmmException = PyObject_GetAttrString(mm, "OpenMMException");
        PyErr_SetString(openmmException, e.what());
        Py_XDECREF(openmmException);
        SWIG_fail;
    }
    PyEval_RestoreThread(savedThreadState);
}

%pythonbegin %{
import openmm
import openmm.unit as unit
import numpy as _numpy
from openmmflavors._units import stripUnits as _stripUnits, groupMask as _groupMask, toInt as _toInt, \
    toBool as _toBool, toIntList as _toIntList
from openmmflavors import _warnings as _flavorsWarnings
%}

%template(DoubleVector) std::vector<double>;
%template(IntVector) std::vector<int>;
%template(StringVector) std::vector<std::string>;

// Quantities in, plain numbers in OpenMM's units to C++.
%pythonprepend FlavorPlugin::FlavorIntegrator::FlavorIntegrator %{
    _flavorsWarnings.checkUnitlessStep(mesoStep, "mesoStep", "FlavorIntegrator")
    _flavorsWarnings.checkUnitlessStep(microStep, "microStep", "FlavorIntegrator")
    mesoStep = _stripUnits(mesoStep, unit.picosecond, "mesoStep")
    microStep = _stripUnits(microStep, unit.picosecond, "microStep")
    stiffGroups = _groupMask(stiffGroups, "stiffGroups")
%}
%pythonprepend FlavorPlugin::FlavorIntegrator::setMesoStep %{
    _flavorsWarnings.checkUnitlessStep(size, "mesoStep", "FlavorIntegrator")
    size = _stripUnits(size, unit.picosecond, "mesoStep")
%}
%pythonprepend FlavorPlugin::FlavorIntegrator::setStepSize %{
    _flavorsWarnings.checkUnitlessStep(size, "stepSize", "FlavorIntegrator")
    size = _stripUnits(size, unit.picosecond, "stepSize")
%}
%pythonprepend FlavorPlugin::FlavorIntegrator::setMicroStep %{
    _flavorsWarnings.checkUnitlessStep(size, "microStep", "FlavorIntegrator")
    size = _stripUnits(size, unit.picosecond, "microStep")
%}
%pythonprepend FlavorPlugin::FlavorIntegrator::setStiffGroups %{
    groups = _groupMask(groups, "stiffGroups")
%}
%pythonprepend FlavorPlugin::FlavorIntegrator::setTemperature %{
    temp = _stripUnits(temp, unit.kelvin, "temperature")
%}
%pythonprepend FlavorPlugin::FlavorIntegrator::setFriction %{
    coeff = _stripUnits(coeff, unit.picosecond**-1, "friction")
%}
%pythonprepend FlavorPlugin::FlavorIntegrator::setScheme %{
    scheme = _toInt(scheme, "scheme")
%}
%pythonprepend FlavorPlugin::FlavorIntegrator::setThermostatPlacement %{
    placement = _toInt(placement, "thermostatPlacement")
%}
%pythonprepend FlavorPlugin::FlavorIntegrator::setStiffFriction %{
    stiff = _toBool(stiff, "stiffFriction")
%}
%pythonprepend FlavorPlugin::FlavorIntegrator::setFrictionParticles %{
    particles = _toIntList(particles, "frictionParticles")
%}
%pythonprepend FlavorPlugin::FlavorIntegrator::setRandomNumberSeed %{
    seed = _toInt(seed, "randomNumberSeed")
%}
%pythonprepend FlavorPlugin::FlavorIntegrator::separatePlanarAngles %{
    group = _toInt(group, "group")
    minAngleSum = _stripUnits(minAngleSum, unit.radian, "minAngleSum")
    _groupBefore = _flavorsWarnings.forcesInGroup(system, group) if 0 <= group <= 31 else []
%}
%pythonappend FlavorPlugin::FlavorIntegrator::separatePlanarAngles %{
    _flavorsWarnings.checkPlanarAngleGroup(system, group, minAngleSum, val, _groupBefore)
%}
%pythonprepend FlavorPlugin::FlavorIntegrator::step %{
    steps = _toInt(steps, "steps")
    _flavorsWarnings.checkFlavorContext(self)
%}
%pythonprepend FlavorPlugin::StochasticImpulseIntegrator::setSplitting %{
    splitting = _toInt(splitting, "splitting")
    _flavorsWarnings.stepChanged(self)
%}
%pythonprepend FlavorPlugin::StochasticImpulseIntegrator::setThermostatPlacement %{
    placement = _toInt(placement, "thermostatPlacement")
%}
%pythonprepend FlavorPlugin::StochasticImpulseIntegrator::setRandomNumberSeed %{
    seed = _toInt(seed, "randomNumberSeed")
%}
%pythonprepend FlavorPlugin::StochasticImpulseIntegrator::separateDrudeSprings %{
    stiffGroup = _toInt(stiffGroup, "stiffGroup")
%}
%pythonprepend FlavorPlugin::StochasticImpulseIntegrator::step %{
    steps = _toInt(steps, "steps")
    _flavorsWarnings.checkResonance(self)
%}

%pythonprepend FlavorPlugin::StochasticImpulseIntegrator::StochasticImpulseIntegrator %{
    temperature = _stripUnits(temperature, unit.kelvin, "temperature")
    frictionCoeff = _stripUnits(frictionCoeff, unit.picosecond**-1, "frictionCoeff")
    _flavorsWarnings.checkUnitlessStep(stepSize, "stepSize", "StochasticImpulseIntegrator")
    stepSize = _stripUnits(stepSize, unit.picosecond, "stepSize")
    stiffGroups = _groupMask(stiffGroups, "stiffGroups")
%}
%pythonprepend FlavorPlugin::StochasticImpulseIntegrator::setStepSize %{
    _flavorsWarnings.checkUnitlessStep(size, "stepSize", "StochasticImpulseIntegrator")
    _flavorsWarnings.stepChanged(self)
    size = _stripUnits(size, unit.picosecond, "stepSize")
%}
%pythonprepend FlavorPlugin::StochasticImpulseIntegrator::setTemperature %{
    temp = _stripUnits(temp, unit.kelvin, "temperature")
%}
%pythonprepend FlavorPlugin::StochasticImpulseIntegrator::setFriction %{
    _flavorsWarnings.stepChanged(self)
    coeff = _stripUnits(coeff, unit.picosecond**-1, "friction")
%}
%pythonprepend FlavorPlugin::StochasticImpulseIntegrator::setStiffModeTemperature %{
    temp = _stripUnits(temp, unit.kelvin, "stiffModeTemperature")
%}
%pythonprepend FlavorPlugin::StochasticImpulseIntegrator::setStiffModeFriction %{
    _flavorsWarnings.stepChanged(self)
    coeff = _stripUnits(coeff, unit.picosecond**-1, "stiffModeFriction")
%}
%pythonprepend FlavorPlugin::StochasticImpulseIntegrator::setMaxDrudeDistance %{
    distance = _stripUnits(distance, unit.nanometer, "maxDrudeDistance")
%}
%pythonprepend FlavorPlugin::StochasticImpulseIntegrator::setMaxWarpedPhase %{
    phase = _stripUnits(phase, unit.radian, "maxWarpedPhase")
%}
%pythonprepend FlavorPlugin::StochasticImpulseIntegrator::setStiffGroups %{
    groups = _groupMask(groups, "stiffGroups")
%}

// Getters return Quantities, as OpenMM's integrators do.
%pythonappend FlavorPlugin::StochasticImpulseIntegrator::getTemperature %{
    val = unit.Quantity(val, unit.kelvin)
%}
%pythonappend FlavorPlugin::StochasticImpulseIntegrator::getFriction %{
    val = unit.Quantity(val, unit.picosecond**-1)
%}
%pythonappend FlavorPlugin::StochasticImpulseIntegrator::getStiffModeTemperature %{
    val = unit.Quantity(val, unit.kelvin)
%}
%pythonappend FlavorPlugin::StochasticImpulseIntegrator::getStiffModeFriction %{
    val = unit.Quantity(val, unit.picosecond**-1)
%}
%pythonappend FlavorPlugin::StochasticImpulseIntegrator::getMaxDrudeDistance %{
    val = unit.Quantity(val, unit.nanometer)
%}
%pythonappend FlavorPlugin::StochasticImpulseIntegrator::getMaxWarpedPhase %{
    val = unit.Quantity(val, unit.radian)
%}
%pythonappend FlavorPlugin::StochasticImpulseIntegrator::getStiffModeFrequencies %{
    val = unit.Quantity(_numpy.array(val, dtype=float), unit.picosecond**-1)
%}
%pythonappend FlavorPlugin::FlavorIntegrator::getMesoStep %{
    val = unit.Quantity(val, unit.picosecond)
%}
%pythonappend FlavorPlugin::FlavorIntegrator::getMicroStep %{
    val = unit.Quantity(val, unit.picosecond)
%}
%pythonappend FlavorPlugin::FlavorIntegrator::getFrictionParticles %{
    val = list(val)
%}
%pythonappend FlavorPlugin::FlavorIntegrator::getTemperature %{
    val = unit.Quantity(val, unit.kelvin)
%}
%pythonappend FlavorPlugin::FlavorIntegrator::getFriction %{
    val = unit.Quantity(val, unit.picosecond**-1)
%}

// The protected Integrator interface is OpenMM's business, not Python's.
// OpenMM's own Integrator.setIntegrationForceGroups calls the C++ override; the Python override below first makes the
// bitmask, so that numpy integers are groups too (OpenMM 8.6's shifts them in numpy arithmetic, which overflows).
%ignore FlavorPlugin::FlavorIntegrator::setIntegrationForceGroups;
%ignore FlavorPlugin::StochasticImpulseIntegrator::setIntegrationForceGroups;
%ignore FlavorPlugin::FlavorIntegrator::initialize;
%ignore FlavorPlugin::FlavorIntegrator::cleanup;
%ignore FlavorPlugin::FlavorIntegrator::getKernelNames;
%ignore FlavorPlugin::FlavorIntegrator::stateChanged;
%ignore FlavorPlugin::FlavorIntegrator::computeKineticEnergy;
%ignore FlavorPlugin::FlavorIntegrator::kineticEnergyRequiresForce;
%ignore FlavorPlugin::FlavorIntegrator::createCheckpoint;
%ignore FlavorPlugin::FlavorIntegrator::loadCheckpoint;
%ignore FlavorPlugin::StochasticImpulseIntegrator::initialize;
%ignore FlavorPlugin::StochasticImpulseIntegrator::cleanup;
%ignore FlavorPlugin::StochasticImpulseIntegrator::getKernelNames;
%ignore FlavorPlugin::StochasticImpulseIntegrator::stateChanged;
%ignore FlavorPlugin::StochasticImpulseIntegrator::computeKineticEnergy;
%ignore FlavorPlugin::StochasticImpulseIntegrator::kineticEnergyRequiresForce;
%ignore FlavorPlugin::StochasticImpulseIntegrator::createCheckpoint;
%ignore FlavorPlugin::StochasticImpulseIntegrator::loadCheckpoint;

#define OPENMM_EXPORT_FLAVORS
%include "typemaps.i"
%apply int& OUTPUT { int& particle1, int& particle2 };
%include "FlavorIntegrator.h"
%clear int& particle1, int& particle2;
%include "StochasticImpulseIntegrator.h"

%extend FlavorPlugin::FlavorIntegrator {
    %pythoncode %{
    def setIntegrationForceGroups(self, groups):
        """Set which force groups to use for integration: a bitmask or a set of group numbers, as OpenMM's."""
        openmm.Integrator.setIntegrationForceGroups(self, _groupMask(groups, "integrationForceGroups"))
    %}
    /** Returns integrator as a FlavorIntegrator, or None if it is another kind of Integrator. */
    static FlavorPlugin::FlavorIntegrator* _cast(OpenMM::Integrator* integrator) {
        return dynamic_cast<FlavorPlugin::FlavorIntegrator*>(integrator);
    }
}

%extend FlavorPlugin::StochasticImpulseIntegrator {
    %pythoncode %{
    def setIntegrationForceGroups(self, groups):
        """Set which force groups to use for integration: a bitmask or a set of group numbers, as OpenMM's."""
        openmm.Integrator.setIntegrationForceGroups(self, _groupMask(groups, "integrationForceGroups"))
    %}
    /** Returns integrator as a StochasticImpulseIntegrator, or None if it is another kind of Integrator. */
    static FlavorPlugin::StochasticImpulseIntegrator* _cast(OpenMM::Integrator* integrator) {
        return dynamic_cast<FlavorPlugin::StochasticImpulseIntegrator*>(integrator);
    }
}
