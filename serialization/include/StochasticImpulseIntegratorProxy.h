#ifndef OPENMM_FLAVORS_STOCHASTIC_IMPULSE_INTEGRATOR_PROXY_H_
#define OPENMM_FLAVORS_STOCHASTIC_IMPULSE_INTEGRATOR_PROXY_H_

#include "internal/windowsExportFlavors.h"
#include "openmm/serialization/SerializationProxy.h"

namespace FlavorPlugin {

/**
 * Serializes a StochasticImpulseIntegrator with every one of its parameters.
 */
class OPENMM_EXPORT_FLAVORS StochasticImpulseIntegratorProxy : public OpenMM::SerializationProxy {
public:
    StochasticImpulseIntegratorProxy();
    void serialize(const void* object, OpenMM::SerializationNode& node) const override;
    void* deserialize(const OpenMM::SerializationNode& node) const override;
};

} // namespace FlavorPlugin

#endif
