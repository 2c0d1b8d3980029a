#ifndef OPENMM_FLAVORS_HOST_FROZEN_STAGE_H_
#define OPENMM_FLAVORS_HOST_FROZEN_STAGE_H_

#include "FrozenDistances.h"
#include "FrozenFlowTask.h"
#include "HostStateMirror.h"
#include "Mixed4Staging.h"
#include "ParticleFlows.h"
#include "ParticleTable.h"
#include "StiffModes.h"
#include "internal/FlowSchedule.h"
#include "openmm/System.h"
#include "openmm/Vec3.h"
#include "openmm/common/ComputeArray.h"
#include "openmm/common/ComputeContext.h"
#include "openmm/common/ComputeForceInfo.h"
#include "openmm/common/ComputeVectorTypes.h"
#include <memory>
#include <utility>
#include <vector>

namespace FlavorPlugin {

/**
 * Declares the distances added with FlavorIntegrator::addFrozenDistance() as particle groups, so that the platform's
 * reordering keeps both ends of each in one molecule and one periodic image, as it does for bonded pairs.
 */
class FrozenPairsInfo : public OpenMM::ComputeForceInfo {
public:
    explicit FrozenPairsInfo(std::vector<std::pair<int, int>> pairs) : pairs(std::move(pairs)) {}
    int getNumParticleGroups() override { return (int)pairs.size(); }
    void getParticlesInGroup(int index, std::vector<int>& particles) override {
        particles = {pairs[index].first, pairs[index].second};
    }
    bool areGroupsIdentical(int /*group1*/, int /*group2*/) override { return true; }

private:
    std::vector<std::pair<int, int>> pairs;
};

/**
 * The artificial FLAVOR's frozen stage (FrozenDrift, FrozenKick) on a common compute platform, run on the host by the
 * step engine's own FrozenDistances and FrozenFlowTask: the one implementation of the frozen math, so that a
 * double-precision trajectory follows the Reference one to rounding.  Each pass copies the positions and velocities
 * (and a kick's forces) from the device in the System's particle order and the moved ones back; the device keeps
 * each molecule in one periodic image, and every frozen distance lies within a molecule (bonded, or made one by
 * FrozenPairsInfo), so the differences the frozen math takes are those of the unwrapped positions.  All buffers are
 * sized at construction.
 */
class HostFrozenStage {
public:
    /** state: the host copies of the particle data it works on; particles: their masses. */
    HostFrozenStage(HostStateMirror& state, const ParticleTable& particles);
    /** Freezes these distances (FrozenSet::Distances); null for none. */
    void setDistances(std::shared_ptr<FrozenDistances> distances);
    /** Freezes the nonzero modes of these stiff modes (FrozenSet::StiffModes); null for none. */
    void setStiffModes(std::shared_ptr<const StiffModes> modes);
    /**
     * Runs one frozen sub-flow.  forces: the kick's slot (mixed4, System order), null for a drift.  projectOthers: as
     * FrozenDistances::drift says.  Throws if what the sub-flow freezes has not been set.
     */
    void run(const SubFlow& flow, const OpenMM::ComputeArray* forces, double tolerance, bool projectOthers);
    /** Forgets the frozen distances' factorizations (a state set from outside; FrozenDistances::forgetFactorizations).
     */
    void forgetFactorizations();

private:
    void download(const OpenMM::ComputeArray* forces);
    HostStateMirror& state;
    const ParticleTable& particles;
    std::shared_ptr<FrozenDistances> distances;
    std::shared_ptr<const StiffModes> modes;
    std::unique_ptr<FrozenFlowTask> modeTask;
    SerialLoop loop;
    // A kick's forces in the System's particle order.
    std::vector<OpenMM::Vec3> forceValues;
    // The force slot as downloaded: double or single precision as the platform keeps it.
    Mixed4Staging forcesDownloaded;
};

} // namespace FlavorPlugin

#endif
