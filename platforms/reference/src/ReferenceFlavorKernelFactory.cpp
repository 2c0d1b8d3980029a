#include "FlavorKernels.h"
#include "FlavorStepKernel.h"
#include "ImpulseStepKernel.h"
#include "ParticleFlows.h"
#include "openmm/KernelFactory.h"
#include "openmm/OpenMMException.h"
#include "openmm/Platform.h"
#include "openmm/internal/ContextImpl.h"
#include <memory>

using namespace FlavorPlugin;
using namespace OpenMM;

namespace {

class ReferenceFlavorKernelFactory : public KernelFactory {
public:
    KernelImpl* createKernelImpl(std::string name, const Platform& platform, ContextImpl& /*context*/) const override {
        if (name == IntegrateFlavorStepKernel::Name())
            return new FlavorStepKernel(name, platform, std::make_unique<SerialLoop>());
        if (name == IntegrateStochasticImpulseStepKernel::Name())
            return new ImpulseStepKernel(name, platform, std::make_unique<SerialLoop>());
        throw OpenMMException((std::string("Tried to create kernel with illegal kernel name '") + name + "'").c_str());
    }
};

void registerReferenceKernels() {
    for (int i = 0; i < Platform::getNumPlatforms(); ++i) {
        Platform& platform = Platform::getPlatform(i);
        if (platform.getName() == "Reference") {
            ReferenceFlavorKernelFactory* factory = new ReferenceFlavorKernelFactory();
            platform.registerKernelFactory(IntegrateFlavorStepKernel::Name(), factory);
            platform.registerKernelFactory(IntegrateStochasticImpulseStepKernel::Name(), factory);
        }
    }
}

} // namespace

extern "C" OPENMM_EXPORT_FLAVORS void registerPlatforms() {}

extern "C" OPENMM_EXPORT_FLAVORS void registerKernelFactories() {
    registerReferenceKernels();
}

/** Registers the Reference kernels when a program links this library directly (tests, C++ examples). */
extern "C" OPENMM_EXPORT_FLAVORS void registerFlavorReferenceKernelFactories() {
    registerReferenceKernels();
}
