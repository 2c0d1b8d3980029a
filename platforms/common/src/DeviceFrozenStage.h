#ifndef OPENMM_FLAVORS_DEVICE_FROZEN_STAGE_H_
#define OPENMM_FLAVORS_DEVICE_FROZEN_STAGE_H_

#include "DeviceFailureFlag.h"
#include "FrozenDistances.h"
#include "internal/FlowSchedule.h"
#include "openmm/common/ComputeArray.h"
#include "openmm/common/ComputeContext.h"
#include "openmm/common/ComputeKernel.h"
#include "openmm/common/ComputeProgram.h"
#include <string>

namespace FlavorPlugin {

/**
 * The artificial FLAVOR's frozen stage (FrozenDrift, FrozenKick on frozen distances) on the device, for Systems whose
 * clusters FrozenDistances::describeSmallClusters() lays out: every cluster at most four frozen distances and no System
 * constraint (flexible water: one triangle per molecule).  One work-item per cluster runs the host's iterations
 * (kernels/frozenClusters.cc); the host's FrozenDistances, which HostFrozenStage runs for every other System, is the
 * oracle its tests compare with.  Nothing is copied to or from the host per pass: a drift that cannot be held sets a
 * flag on the device (code 1 of the step's DeviceFailureFlag), which the stepper reads where the next step starts.
 */
class DeviceFrozenStage {
public:
    /**
     * program: compiled from flowPasses.cc and frozenClusters.cc; slotOf: each particle's atom (current whenever run()
     * is called).
     */
    DeviceFrozenStage(OpenMM::ComputeContext& cc, OpenMM::ComputeProgram& program, OpenMM::ComputeArray& slotOf,
                      DeviceFailureFlag& failure);
    /**
     * Takes the clusters of distances onto the device if they fit; returns whether they did (false and inactive for
     * null or clusters that do not fit: the host stage runs them).
     */
    bool setDistances(const FrozenDistances* distances);
    /** Whether run() serves frozen flows on distances. */
    bool isActive() const { return active; }
    /**
     * One frozen drift (flow.h) or kick with the forces of a slot (mixed4, System order); first, if preKickForces is
     * not null, the plain kick v += preKick M^-1 F of a pass that runs just before, its forces read from the
     * platform's force buffer where preKickFromBuffer (not yet copied into their slot).
     */
    void run(const SubFlow& flow, OpenMM::ComputeArray* forces, double tolerance,
             OpenMM::ComputeArray* preKickForces = nullptr, double preKick = 0.0, bool preKickFromBuffer = false);
    /** Forgets every cluster's factorization (FrozenDistances::forgetFactorizations). */
    void forgetFactorizations();
    /** The host's exception for a drift that could not be held (failure code 1). */
    std::string failureMessage() const { return FrozenDistances::unstableMessage(lastTolerance); }
    /** The failure code its kernels set. */
    static const int FailureCode = 1;

private:
    OpenMM::ComputeContext& cc;
    OpenMM::ComputeProgram& program;
    OpenMM::ComputeArray& slotOf;
    OpenMM::ComputeKernel driftKernel, kickKernel;
    DeviceFailureFlag& failure;
    OpenMM::ComputeArray particles, ends, order, counts, flags, reals, freeParticles;
    int numClusters = 0, numFree = 0;
    bool active = false;
    double lastTolerance = 0.0;
};

} // namespace FlavorPlugin

#endif
