#include "StochasticImpulseIntegratorProxy.h"
#include "StochasticImpulseIntegrator.h"
#include "openmm/OpenMMException.h"
#include "openmm/serialization/SerializationNode.h"
#include <memory>
#include <string>

using namespace FlavorPlugin;
using namespace OpenMM;

StochasticImpulseIntegratorProxy::StochasticImpulseIntegratorProxy()
    : SerializationProxy("StochasticImpulseIntegrator") {}

void StochasticImpulseIntegratorProxy::serialize(const void* object, SerializationNode& node) const {
    const StochasticImpulseIntegrator& integrator = *reinterpret_cast<const StochasticImpulseIntegrator*>(object);
    // Version 4 added the Metropolis adjustment and the hard wall, version 5 the Warped phase limit, version 6 the
    // Warped friction scaling, each written only where it is on: without them the document is the version 3 one,
    // which older builds read.
    const bool version4 = integrator.getMetropolis() || integrator.getMaxDrudeDistance() > 0.0;
    const int version = integrator.getWarpedFrictionScaling()  ? 6
                        : integrator.getMaxWarpedPhase() > 0.0 ? 5
                        : version4                             ? 4
                                                               : 3;
    node.setIntProperty("version", version);
    node.setDoubleProperty("stepSize", integrator.getStepSize());
    node.setDoubleProperty("temperature", integrator.getTemperature());
    node.setDoubleProperty("friction", integrator.getFriction());
    node.setIntProperty("stiffGroups", integrator.getStiffGroups());
    node.setIntProperty("splitting", integrator.getSplitting());
    node.setIntProperty("randomSeed", integrator.getRandomNumberSeed());
    node.setDoubleProperty("constraintTolerance", integrator.getConstraintTolerance());
    node.setIntProperty("integrationForceGroups", integrator.getIntegrationForceGroups());
    // Version 2: the stiff modes' own bath, written only where it was set (otherwise it follows the integrator's).
    if (integrator.hasStiffModeTemperature())
        node.setDoubleProperty("stiffModeTemperature", integrator.getStiffModeTemperature());
    if (integrator.hasStiffModeFriction())
        node.setDoubleProperty("stiffModeFriction", integrator.getStiffModeFriction());
    // Version 3: where the zero modes' thermostat acts.
    node.setIntProperty("thermostatPlacement", integrator.getThermostatPlacement());
    if (integrator.getMetropolis())
        node.setBoolProperty("metropolis", true);
    if (integrator.getMaxDrudeDistance() > 0.0)
        node.setDoubleProperty("maxDrudeDistance", integrator.getMaxDrudeDistance());
    if (integrator.getMaxWarpedPhase() > 0.0)
        node.setDoubleProperty("maxWarpedPhase", integrator.getMaxWarpedPhase());
    if (integrator.getWarpedFrictionScaling())
        node.setBoolProperty("warpedFrictionScaling", true);
}

void* StochasticImpulseIntegratorProxy::deserialize(const SerializationNode& node) const {
    int version = node.getIntProperty("version");
    if (version < 1 || version > 6)
        throw OpenMMException("StochasticImpulseIntegrator: unsupported serialization version " +
                              std::to_string(version) + "; this library reads versions 1 to 6");
    auto integrator = std::make_unique<StochasticImpulseIntegrator>(
        node.getDoubleProperty("temperature"), node.getDoubleProperty("friction"), node.getDoubleProperty("stepSize"),
        node.getIntProperty("stiffGroups"));
    if (version >= 2 && node.hasProperty("stiffModeTemperature"))
        integrator->setStiffModeTemperature(node.getDoubleProperty("stiffModeTemperature"));
    if (version >= 2 && node.hasProperty("stiffModeFriction"))
        integrator->setStiffModeFriction(node.getDoubleProperty("stiffModeFriction"));
    integrator->setSplitting((StochasticImpulseIntegrator::Splitting)node.getIntProperty("splitting"));
    if (version >= 3) // earlier versions had the thermostat throughout the flow
        integrator->setThermostatPlacement(
            (StochasticImpulseIntegrator::ThermostatPlacement)node.getIntProperty("thermostatPlacement"));
    integrator->setRandomNumberSeed(node.getIntProperty("randomSeed"));
    integrator->setConstraintTolerance(node.getDoubleProperty("constraintTolerance"));
    integrator->setIntegrationForceGroups(node.getIntProperty("integrationForceGroups"));
    if (version >= 4 && node.hasProperty("metropolis"))
        integrator->setMetropolis(node.getBoolProperty("metropolis"));
    if (version >= 4 && node.hasProperty("maxDrudeDistance"))
        integrator->setMaxDrudeDistance(node.getDoubleProperty("maxDrudeDistance"));
    if (version >= 5 && node.hasProperty("maxWarpedPhase"))
        integrator->setMaxWarpedPhase(node.getDoubleProperty("maxWarpedPhase"));
    if (version >= 6 && node.hasProperty("warpedFrictionScaling"))
        integrator->setWarpedFrictionScaling(node.getBoolProperty("warpedFrictionScaling"));
    return integrator.release();
}
