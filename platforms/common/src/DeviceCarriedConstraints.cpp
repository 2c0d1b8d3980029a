#include "DeviceCarriedConstraints.h"
#include "DeviceUploads.h"
#include "Mixed4Staging.h"
#include "openmm/OpenMMException.h"
#include "openmm/common/IntegrationUtilities.h"
#include <algorithm>
#include <map>

using namespace FlavorPlugin;
using namespace OpenMM;
using std::vector;

namespace {

/**
 * The particles that OpenMM's IntegrationUtilities hold by SETTLE: the triangles of three constraints whose atoms
 * have two constraints each and one atom at equal distance from the other two (the same rule, the same float
 * distances).
 */
vector<bool> settledParticles(const System& system) {
    const int numParticles = system.getNumParticles();
    vector<int> atom1, atom2, count(numParticles, 0);
    vector<double> distance;
    for (int c = 0; c < system.getNumConstraints(); ++c) {
        int p1, p2;
        double d;
        system.getConstraintParameters(c, p1, p2, d);
        if (system.getParticleMass(p1) != 0 || system.getParticleMass(p2) != 0) {
            atom1.push_back(p1);
            atom2.push_back(p2);
            distance.push_back(d);
            count[p1]++;
            count[p2]++;
        }
    }
    vector<std::map<int, float>> partners(numParticles);
    for (size_t c = 0; c < atom1.size(); ++c)
        if (count[atom1[c]] == 2 && count[atom2[c]] == 2) {
            partners[atom1[c]][atom2[c]] = (float)distance[c];
            partners[atom2[c]][atom1[c]] = (float)distance[c];
        }
    vector<bool> settled(numParticles, false);
    for (int i = 0; i < numParticles; ++i) {
        if (partners[i].size() != 2)
            continue;
        const int j = partners[i].begin()->first, k = (++partners[i].begin())->first;
        if (partners[j].size() != 2 || partners[k].size() != 2 || partners[j].count(k) == 0)
            continue;
        const float dij = partners[i][j], dik = partners[i][k], djk = partners[j][k];
        if (dij == dik || dij == djk || dik == djk)
            settled[i] = settled[j] = settled[k] = true;
    }
    return settled;
}

} // namespace

DeviceCarriedConstraints::DeviceCarriedConstraints(ComputeContext& cc, ComputeProgram& program, ComputeArray& slotOf,
                                                   const System& system)
    : cc(cc), program(program), slotOf(slotOf), settled(settledParticles(system)) {
    const int numParticles = system.getNumParticles();
    ownInverseMass.resize(numParticles);
    for (int i = 0; i < numParticles; ++i)
        ownInverseMass[i] = system.getParticleMass(i) == 0.0 ? 0.0 : 1.0 / system.getParticleMass(i);
    uploadInts(cc, carrierOf, vector<int>(numParticles, -1), "flavorCarrierOf");
    uploadInts(cc, carriedMember, vector<int>(numParticles, 0), "flavorCarriedMember");
    initializeMixed4(cc, uncorrected, cc.getPaddedNumAtoms(), "flavorUncorrected");
    initializeMixed4(cc, applied, numParticles, "flavorConstraintProcessing");
    initializeMixed4(cc, stepImpulses, 1, "flavorCarrierImpulses");
    initializeMixed4(cc, carrierVelocity, 1, "flavorCarrierVelocity");
    takeOffKernel = program->createKernel("takeOffCarriedProcessing");
    takeOffKernel->addArg(cc.getNumAtoms());
    takeOffKernel->addArg(cc.getVelm());
    takeOffKernel->addArg(cc.getAtomIndexArray());
    takeOffKernel->addArg(applied);
}

bool DeviceCarriedConstraints::setCarriers(const vector<int>& newCarriers, const vector<int>& members) {
    active = std::all_of(newCarriers.begin(), newCarriers.end(), [this](int p) { return settled[p]; });
    carriers = newCarriers;
    const int numParticles = (int)settled.size();
    vector<int> componentOf(numParticles, -1), member(numParticles, 0);
    for (size_t k = 0; k < carriers.size(); ++k)
        componentOf[carriers[k]] = (int)k;
    for (int p : members)
        member[p] = 1;
    carrierOf.upload(componentOf);
    carriedMember.upload(member);
    const int numCarried = std::max<int>(1, (int)carriers.size());
    if ((int)stepImpulses.getSize() != numCarried) {
        stepImpulses.resize(numCarried);
        carrierVelocity.resize(numCarried);
    }
    return active;
}

void DeviceCarriedConstraints::setNumPasses(size_t numPasses) {
    passes.clear();
    passes.resize(numPasses);
    processing = false;
    takeOffFused = false;
}

void DeviceCarriedConstraints::setCarrying(size_t p, const ConstraintProjector::StiffFlowCarrying& carrying,
                                           bool firstOfStep) {
    using Carrying = ConstraintProjector::StiffFlowCarrying;
    PassArrays& pass = passes[p];
    const int numCarried = (int)carriers.size();
    vector<double> carrierReals(21 * (size_t)numCarried, 0.0), motionReals;
    for (int k = 0; k < numCarried; ++k) {
        carrierReals[21 * (size_t)k] = carrying.positions.inverseMasses[carriers[k]];
        carrierReals[21 * (size_t)k + 1] = carrying.velocities.inverseMasses[carriers[k]];
        carrierReals[21 * (size_t)k + 2] = ownInverseMass[carriers[k]];
    }
    auto putImpulses = [&](const vector<Carrying::Impulse>& impulses, int offset) {
        for (const Carrying::Impulse& impulse : impulses) {
            if (impulse.carrier != carriers[impulse.carried])
                throw OpenMMException("DeviceCarriedConstraints: a carrying's carriers differ from the stiff modes'");
            for (int a = 0; a < 3; ++a)
                for (int b = 0; b < 3; ++b)
                    carrierReals[21 * (size_t)impulse.carried + offset + 3 * a + b] = impulse.perCorrection[a][b];
        }
    };
    putImpulses(carrying.positions.impulses, 3);
    putImpulses(carrying.velocities.impulses, 12);
    // Three lists of motions, each grouped by carried component as carryingThrough() makes them: numCarried + 1
    // offsets each into one list of particles; 18 reals per position motion, then 9 per other motion.
    vector<int> starts, particles;
    auto addList = [&](const vector<Carrying::Motion>& motions, bool positions) {
        size_t next = 0;
        for (int k = 0; k <= numCarried; ++k) {
            while (next < motions.size() && motions[next].carried < k)
                ++next;
            starts.push_back((int)(particles.size() + next));
        }
        for (size_t j = 0; j < motions.size(); ++j) {
            if (j > 0 && motions[j].carried < motions[j - 1].carried)
                throw OpenMMException("DeviceCarriedConstraints: a carrying's motions are not grouped by component");
            particles.push_back(motions[j].particle);
            for (const auto* matrix : {&motions[j].position, &motions[j].velocity}) {
                if (!positions && matrix == &motions[j].position)
                    continue;
                for (int a = 0; a < 3; ++a)
                    for (int b = 0; b < 3; ++b)
                        motionReals.push_back((*matrix)[a][b]);
            }
        }
    };
    addList(carrying.positions.motions, true);
    const int numPositionMotions = (int)carrying.positions.motions.size();
    addList(carrying.velocities.motions, false);
    addList(carrying.processing, false);
    pass.process = !carrying.processing.empty() && !firstOfStep;
    processing = processing || !carrying.processing.empty();
    uploadInts(cc, pass.carriers, carriers, "flavorCarriers");
    uploadInts(cc, pass.motionStart, starts, "flavorMotionStart");
    uploadInts(cc, pass.motionParticle, particles, "flavorMotionParticle");
    uploadMixed(cc, pass.carrierReals, carrierReals, "flavorCarrierReals");
    uploadMixed(cc, pass.motionReals, motionReals, "flavorMotionReals");
    pass.set = true;
    pass.numPositionMotions = numPositionMotions;

    IntegrationUtilities& integration = cc.getIntegrationUtilities();
    ArrayInterface& correction = cc.getUseMixedPrecision() ? cc.getPosqCorrection() : cc.getPosq();
    pass.finishPositions = program->createKernel("finishCarriedPositions");
    ComputeKernel& finish = pass.finishPositions;
    finish->addArg(cc.getNumAtoms());
    finish->addArg(cc.getPosq());
    finish->addArg(correction);
    finish->addArg(cc.getVelm());
    finish->addArg(integration.getPosDelta());
    finish->addArg(uncorrected);
    finish->addArg(cc.getAtomIndexArray());
    finish->addArg(slotOf);
    finish->addArg(carriedMember);
    addMixedArg(cc, finish, carrying.velocityPerCorrection);
    finish->addArg(numCarried);
    finish->addArg(pass.carriers);
    finish->addArg(pass.motionStart);
    finish->addArg(pass.motionParticle);
    finish->addArg(pass.carrierReals);
    finish->addArg(pass.motionReals);
    finish->addArg(stepImpulses);
    finish->addArg(carrierVelocity);
    finish->addArg(firstOfStep ? 1 : 0);
    finish->addArg(0);
    pass.finishVelocities = program->createKernel("finishCarriedVelocities");
    ComputeKernel& end = pass.finishVelocities;
    end->addArg(numCarried);
    end->addArg(cc.getVelm());
    end->addArg(slotOf);
    end->addArg(pass.carriers);
    end->addArg(pass.motionStart);
    end->addArg(pass.motionParticle);
    end->addArg(pass.carrierReals);
    end->addArg(pass.motionReals);
    end->addArg(numPositionMotions);
    end->addArg(stepImpulses);
    end->addArg(carrierVelocity);
    // After a position solve in the same pass the step's impulses have started.
    end->addArg(0);
    pass.velocitiesFirstOfStep = firstOfStep;
}

void DeviceCarriedConstraints::addFlowArgs(ComputeKernel& kernel, size_t p, bool displaced, FlowKernel kind) {
    // Any array of the type where the pass has no carrying: read only where it has.
    const bool carried = displaced && passes[p].set;
    PassArrays& pass = passes[p];
    kernel->addArg(kind == FlowKernel::StiffFlow || kind == FlowKernel::Response ? (displaced ? 1 : 0) : 0);
    kernel->addArg(cc.getIntegrationUtilities().getPosDelta());
    kernel->addArg(uncorrected);
    if (kind == FlowKernel::StiffFlow) {
        kernel->addArg(carrierOf);
        kernel->addArg(carried ? pass.carrierReals : uncorrected);
        kernel->addArg(applied);
        kernel->addArg(0); // takeOff: set by fuseTakeOff()
        return;
    }
    const bool preparing = kind == FlowKernel::ClosingResponse && carried && !carriers.empty();
    kernel->addArg(preparing ? 1 : 0);
    kernel->addArg(carrierOf);
    kernel->addArg(preparing ? pass.carrierReals : uncorrected);
    kernel->addArg(preparing ? pass.motionStart : carrierOf);
    kernel->addArg(preparing ? pass.motionParticle : carrierOf);
    kernel->addArg(preparing ? pass.motionReals : uncorrected);
    kernel->addArg(preparing ? pass.numPositionMotions : 0);
    kernel->addArg((int)carriers.size());
    kernel->addArg(stepImpulses);
    kernel->addArg(carrierVelocity);
    kernel->addArg(applied);
    kernel->addArg(preparing && pass.process ? 1 : 0);
}

void DeviceCarriedConstraints::fuseTakeOff(ComputeKernel& firstStiffFlow) {
    if (!processing)
        return;
    firstStiffFlow->setArg(StiffFlowTakeOffArg, 1);
    takeOffFused = true;
}

void DeviceCarriedConstraints::constrainAfterFlow(size_t p, double tolerance, bool projectVelocities) {
    PassArrays& pass = passes[p];
    IntegrationUtilities& integration = cc.getIntegrationUtilities();
    integration.applyConstraints(tolerance);
    pass.finishPositions->setArg(19, projectVelocities ? 1 : 0);
    pass.finishPositions->execute(cc.getNumAtoms());
    if (!projectVelocities)
        return;
    integration.applyVelocityConstraints(tolerance);
    if (!carriers.empty())
        pass.finishVelocities->execute((int)carriers.size());
}

void DeviceCarriedConstraints::constrainVelocities(size_t p, double tolerance) {
    // The closing force response readied the carriers (addFlowArgs, FlowKernel::ClosingResponse).
    PassArrays& pass = passes[p];
    cc.getIntegrationUtilities().applyVelocityConstraints(tolerance);
    if (!carriers.empty()) {
        pass.finishVelocities->setArg(11, pass.velocitiesFirstOfStep ? 1 : 0);
        pass.finishVelocities->execute((int)carriers.size());
    }
}

void DeviceCarriedConstraints::takeOffProcessing() {
    if (processing && !takeOffFused)
        takeOffKernel->execute(cc.getNumAtoms());
}

void DeviceCarriedConstraints::downloadProcessing(vector<Vec3>& target) const {
    Mixed4Staging staging(mixedIsDouble(cc), (int)target.size());
    applied.download(staging.data());
    staging.toVec3(target);
}

void DeviceCarriedConstraints::uploadProcessing(const vector<Vec3>& values) {
    Mixed4Staging staging(mixedIsDouble(cc), (int)values.size());
    staging.fromVec3(values);
    applied.upload(staging.data());
}
