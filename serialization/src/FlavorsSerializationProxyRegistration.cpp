#include "FlavorIntegrator.h"
#include "FlavorIntegratorProxy.h"
#include "StochasticImpulseIntegrator.h"
#include "StochasticImpulseIntegratorProxy.h"
#include "openmm/serialization/SerializationProxy.h"
#include <typeinfo>

using namespace FlavorPlugin;
using namespace OpenMM;

// Runs when the library is loaded, so XmlSerializer knows the integrators without any call from the user.
__attribute__((constructor)) static void registerFlavorsSerializationProxies() {
    SerializationProxy::registerProxy(typeid(FlavorIntegrator), new FlavorIntegratorProxy());
    SerializationProxy::registerProxy(typeid(StochasticImpulseIntegrator), new StochasticImpulseIntegratorProxy());
}
