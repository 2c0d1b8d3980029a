#include "DeviceFrozenStage.h"
#include "MixedArguments.h"
#include "openmm/OpenMMException.h"
#include <algorithm>
#include <string>
#include <vector>

using namespace FlavorPlugin;
using namespace OpenMM;
using std::vector;

namespace {

/** Uploads values into array, created with at least one element (filler where values is empty). */
template <class T>
void uploadList(ComputeContext& cc, ComputeArray& array, vector<T> values, const T& filler, const char* name) {
    if (values.empty())
        values.push_back(filler);
    if (array.isInitialized())
        array.resize((int)values.size());
    else
        array.initialize<T>(cc, (int)values.size(), name);
    array.upload(values);
}

} // namespace

DeviceFrozenStage::DeviceFrozenStage(ComputeContext& cc, ComputeProgram& program, ComputeArray& slotOf,
                                     DeviceFailureFlag& failure)
    : cc(cc), program(program), slotOf(slotOf), failure(failure) {}

bool DeviceFrozenStage::setDistances(const FrozenDistances* distances) {
    using Table = SmallClusterTable;
    Table table;
    active = distances != nullptr && distances->describeSmallClusters(table);
    if (!active)
        return false;
    numClusters = (int)table.counts.size() / 4;
    numFree = (int)table.freeParticles.size();
    uploadList(cc, particles, table.particles, 0, "flavorFrozenParticles");
    uploadList(cc, ends, table.ends, 0, "flavorFrozenEnds");
    uploadList(cc, order, table.order, 0, "flavorFrozenOrder");
    vector<mm_int4> clusterCounts(numClusters);
    for (int k = 0; k < numClusters; ++k)
        clusterCounts[k] = mm_int4(table.counts[4 * k], table.counts[4 * k + 1], table.counts[4 * k + 2], 0);
    uploadList(cc, counts, clusterCounts, mm_int4(0, 0, 0, 0), "flavorFrozenCounts");
    uploadList(cc, flags, vector<mm_int4>(numClusters, mm_int4(0, 0, 0, 0)), mm_int4(0, 0, 0, 0), "flavorFrozenFlags");
    uploadList(cc, freeParticles, table.freeParticles, 0, "flavorFrozenFree");
    // Per cluster: G, the directions and where it was factorized (frozenClusters.cc's CLUSTER_REALS).
    const int realsPerCluster =
        Table::MaxConstraints * Table::MaxConstraints + 3 * Table::MaxConstraints + 3 * Table::MaxParticles;
    const int numReals = std::max(1, numClusters * realsPerCluster);
    if (reals.isInitialized())
        reals.resize(numReals);
    else
        reals.initialize(cc, numReals, mixedIsDouble(cc) ? sizeof(double) : sizeof(float), "flavorFrozenReals");
    cc.clearBuffer(reals);
    // The arguments are set once here; run() sets the step, the tolerance and a kick's forces.
    driftKernel = program->createKernel("frozenDrift");
    kickKernel = program->createKernel("frozenKick");
    for (ComputeKernel* kernel : {&driftKernel, &kickKernel}) {
        ComputeKernel& k = *kernel;
        k->addArg(numClusters);
        k->addArg(numFree);
        k->addArg(particles);
        k->addArg(ends);
        k->addArg(order);
        k->addArg(counts);
        k->addArg(flags);
        k->addArg(reals);
        k->addArg(freeParticles);
        k->addArg(slotOf);
        k->addArg(cc.getPosq());
        k->addArg(cc.getUseMixedPrecision() ? cc.getPosqCorrection() : cc.getPosq());
        k->addArg(cc.getVelm());
        k->addArg(failure.getArray());
    }
    kickKernel->addArg(slotOf); // the forces, set per kick
    for (ComputeKernel* kernel : {&driftKernel, &kickKernel}) {
        addMixedArg(cc, *kernel, 0.0);
        addMixedArg(cc, *kernel, 0.0);
        (*kernel)->addArg(slotOf); // a pre-kick's forces, set per pass
        (*kernel)->addArg(cc.getLongForceBuffer());
        (*kernel)->addArg(0);
        addMixedArg(cc, *kernel, 0.0);
    }
    return true;
}

void DeviceFrozenStage::run(const SubFlow& flow, ComputeArray* forces, double tolerance, ComputeArray* preKickForces,
                            double preKick, bool preKickFromBuffer) {
    const bool drift = flow.kind == SubFlow::FrozenDrift;
    ComputeKernel& kernel = drift ? driftKernel : kickKernel;
    // Arguments: 14 in common, a kick's forces, then h, the tolerance, the pre-kick's forces (its slot and the
    // platform's buffer, and which holds them) and its step.
    const int first = drift ? 14 : 15;
    if (!drift)
        kernel->setArg(14, *forces);
    setMixedArg(cc, kernel, first, flow.h);
    setMixedArg(cc, kernel, first + 1, tolerance);
    if (preKickForces != nullptr)
        kernel->setArg(first + 2, *preKickForces);
    kernel->setArg(first + 4, preKickFromBuffer ? 1 : 0);
    setMixedArg(cc, kernel, first + 5, preKickForces != nullptr ? preKick : 0.0);
    lastTolerance = tolerance;
    kernel->execute(numClusters + numFree);
    failure.markUsed();
}

void DeviceFrozenStage::forgetFactorizations() {
    if (active)
        cc.clearBuffer(flags);
}
