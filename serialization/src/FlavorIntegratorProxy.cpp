#include "FlavorIntegratorProxy.h"
#include "FlavorIntegrator.h"
#include "openmm/OpenMMException.h"
#include "openmm/serialization/SerializationNode.h"
#include <memory>
#include <string>
#include <vector>

using namespace FlavorPlugin;
using namespace OpenMM;

FlavorIntegratorProxy::FlavorIntegratorProxy() : SerializationProxy("FlavorIntegrator") {}

void FlavorIntegratorProxy::serialize(const void* object, SerializationNode& node) const {
    const FlavorIntegrator& integrator = *reinterpret_cast<const FlavorIntegrator*>(object);
    // Version 4 added the stiff clock, version 5 the Metropolis adjustment: without them the document is the version 3
    // one, which older builds read.
    const int version = integrator.getMetropolis() ? 5 : !integrator.getStiffClockParameter().empty() ? 4 : 3;
    node.setIntProperty("version", version);
    node.setDoubleProperty("stepSize", integrator.getStepSize());
    node.setDoubleProperty("microStep", integrator.getMicroStep());
    node.setIntProperty("stiffGroups", integrator.getStiffGroups());
    node.setIntProperty("scheme", integrator.getScheme());
    node.setIntProperty("averaging", integrator.getAveraging());
    node.setBoolProperty("exactFastFlow", integrator.getExactFastFlow());
    node.setDoubleProperty("temperature", integrator.getTemperature());
    node.setDoubleProperty("friction", integrator.getFriction());
    node.setBoolProperty("stiffFriction", integrator.getStiffFriction());
    node.setIntProperty("thermostatPlacement", integrator.getThermostatPlacement());
    node.setIntProperty("randomSeed", integrator.getRandomNumberSeed());
    node.setDoubleProperty("constraintTolerance", integrator.getConstraintTolerance());
    node.setIntProperty("integrationForceGroups", integrator.getIntegrationForceGroups());
    if (version >= 4)
        node.setStringProperty("stiffClockParameter", integrator.getStiffClockParameter());
    if (version >= 5)
        node.setBoolProperty("metropolis", true);
    SerializationNode& particles = node.createChildNode("FrictionParticles");
    for (int p : integrator.getFrictionParticles())
        particles.createChildNode("Particle").setIntProperty("index", p);
    SerializationNode& frozen = node.createChildNode("FrozenDistances");
    for (int i = 0; i < integrator.getNumFrozenDistances(); ++i) {
        int p1, p2;
        integrator.getFrozenDistance(i, p1, p2);
        frozen.createChildNode("Distance").setIntProperty("p1", p1).setIntProperty("p2", p2);
    }
}

void* FlavorIntegratorProxy::deserialize(const SerializationNode& node) const {
    int version = node.getIntProperty("version");
    if (version < 1 || version > 5)
        throw OpenMMException("FlavorIntegrator: unsupported serialization version " + std::to_string(version) +
                              "; this library reads versions 1 to 5");
    auto integrator = std::make_unique<FlavorIntegrator>(
        node.getDoubleProperty("stepSize"), node.getDoubleProperty("microStep"), node.getIntProperty("stiffGroups"));
    integrator->setScheme((FlavorIntegrator::Scheme)node.getIntProperty("scheme"));
    if (version >= 2) {
        // Version 1 predates the artificial averagings: it is the nonintrusive FLAVOR.
        integrator->setAveraging((FlavorIntegrator::Averaging)node.getIntProperty("averaging"));
        integrator->setExactFastFlow(node.getBoolProperty("exactFastFlow"));
    }
    integrator->setTemperature(node.getDoubleProperty("temperature"));
    integrator->setFriction(node.getDoubleProperty("friction"));
    integrator->setStiffFriction(node.getBoolProperty("stiffFriction"));
    if (version >= 3) // earlier versions placed the thermostat at the edges
        integrator->setThermostatPlacement(
            (FlavorIntegrator::ThermostatPlacement)node.getIntProperty("thermostatPlacement"));
    integrator->setRandomNumberSeed(node.getIntProperty("randomSeed"));
    integrator->setConstraintTolerance(node.getDoubleProperty("constraintTolerance"));
    integrator->setIntegrationForceGroups(node.getIntProperty("integrationForceGroups"));
    if (version >= 4) // earlier versions had no stiff clock
        integrator->setStiffClockParameter(node.getStringProperty("stiffClockParameter"));
    if (version >= 5)
        integrator->setMetropolis(node.getBoolProperty("metropolis"));
    std::vector<int> particles;
    for (const SerializationNode& particle : node.getChildNode("FrictionParticles").getChildren())
        particles.push_back(particle.getIntProperty("index"));
    integrator->setFrictionParticles(particles);
    if (version >= 2)
        for (const SerializationNode& distance : node.getChildNode("FrozenDistances").getChildren())
            integrator->addFrozenDistance(distance.getIntProperty("p1"), distance.getIntProperty("p2"));
    return integrator.release();
}
