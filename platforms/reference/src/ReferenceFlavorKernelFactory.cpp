#include "FlavorKernels.h"
#include "internal/FlavorStepKernel.h"
#include "internal/ParticleFlows.h"
#include "openmm/KernelFactory.h"
#include "openmm/OpenMMException.h"
#include "openmm/Platform.h"
#include "openmm/internal/ContextImpl.h"
#include <memory>

using namespace FlavorPlugin;
using namespace OpenMM;

namespace {

/** Plain loops: the obviously correct way to run a pass. */
class SerialParticleLoop : public ParticleLoop {
public:
    void run(const ParticlePass& pass, int numParticles) override { pass.apply(0, numParticles); }
};

class ReferenceFlavorKernelFactory : public KernelFactory {
public:
    KernelImpl* createKernelImpl(std::string name, const Platform& platform, ContextImpl& context) const override {
        if (name == IntegrateFlavorStepKernel::Name())
            return new FlavorStepKernel(name, platform, std::make_unique<SerialParticleLoop>());
        throw OpenMMException((std::string("Tried to create kernel with illegal kernel name '") + name + "'").c_str());
    }
};

void registerReferenceKernels() {
    for (int i = 0; i < Platform::getNumPlatforms(); ++i) {
        Platform& platform = Platform::getPlatform(i);
        if (platform.getName() == "Reference") {
            ReferenceFlavorKernelFactory* factory = new ReferenceFlavorKernelFactory();
            platform.registerKernelFactory(IntegrateFlavorStepKernel::Name(), factory);
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
