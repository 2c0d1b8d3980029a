#include "CommonFlavorKernels.h"
#include "CommonFlavorKernelSources.h"
#include "DeviceUploads.h"
#include "FlowCheckpoint.h"
#include "MixedArguments.h"
#include "internal/CounterRandom.h"
#include "internal/ExactModeFlow.h"
#include "internal/StiffGroupChecks.h"
#include "openmm/OpenMMException.h"
#include "openmm/common/ContextSelector.h"
#include "openmm/common/IntegrationUtilities.h"
#include "openmm/internal/ContextImpl.h"
#include <algorithm>
#include <cmath>
#include <map>

using namespace FlavorPlugin;
using namespace OpenMM;
using std::string;
using std::vector;

CommonFlowStepper::CommonFlowStepper(ComputeContext& cc, const System& system, string owner, string platformName,
                                     bool hostConstraints)
    : cc(cc), system(system), owner(std::move(owner)), platformName(std::move(platformName)),
      numParticles(system.getNumParticles()), hasConstraints(system.getNumConstraints() > 0), hasVirtualSites(false),
      history(system.getNumParticles()), particles(system), mirror(cc, system.getNumParticles()),
      frozenStage(mirror, particles), staging(mixedIsDouble(cc), system.getNumParticles()) {
    for (int i = 0; i < numParticles; ++i)
        hasVirtualSites = hasVirtualSites || system.isVirtualSite(i);
    ContextSelector selector(cc);
    std::map<string, string> defines;
    defines["NUM_ATOMS"] = cc.intToString(cc.getNumAtoms());
    defines["PADDED_NUM_ATOMS"] = cc.intToString(cc.getPaddedNumAtoms());
    program =
        cc.compileProgram(string(CommonFlavorKernelSources::flowPasses) + CommonFlavorKernelSources::frozenClusters +
                              CommonFlavorKernelSources::carriedConstraints + CommonFlavorKernelSources::hardWall,
                          defines);
    copyForcesKernel = program->createKernel("copyForces");
    findAtomsKernel = program->createKernel("findAtoms");
    driftDisplacementKernel = program->createKernel("driftDisplacement");
    applyDisplacementKernel = program->createKernel("applyDisplacement");
    snapshotKernel = program->createKernel("snapshotState");
    saveProposalKernel = program->createKernel("saveProposalStart");
    rejectProposalKernel = program->createKernel("rejectProposal");
    const ZigguratTables& tables = ZigguratTables::get();
    kn.initialize<unsigned int>(cc, 128, "flavorZigguratKn");
    kn.upload(vector<unsigned int>(tables.kn, tables.kn + 128));
    uploadMixed(cc, wn, vector<double>(tables.wn, tables.wn + 128), "flavorZigguratWn");
    uploadMixed(cc, fn, vector<double>(tables.fn, tables.fn + 128), "flavorZigguratFn");
    slotOf.initialize<int>(cc, numParticles, "flavorSlotOf");
    failureFlag = std::make_unique<DeviceFailureFlag>(cc);
    deviceFrozen = std::make_unique<DeviceFrozenStage>(cc, program, slotOf, *failureFlag);
    deviceWall = std::make_unique<DeviceHardWall>(cc, program, slotOf, *failureFlag);
    deviceCarried = std::make_unique<DeviceCarriedConstraints>(cc, program, slotOf, system);
    uploadInts(cc, thermostated, vector<int>(numParticles, 1), "flavorThermostated");
    uploadMixed(cc, thermalSpeed, vector<double>(numParticles, 0.0), "flavorThermalSpeed");
    const bool doubles = mixedIsDouble(cc);
    slotForces.resize(MaxForceSlots);
    for (int s = 0; s < MaxForceSlots; ++s)
        slotForces[s].initialize(cc, numParticles, doubles ? 4 * sizeof(double) : 4 * sizeof(float),
                                 "flavorSlotForces" + std::to_string(s));
    slotValid.assign(MaxForceSlots, false);
    initializeMixed4(cc, forceDifferences, numParticles, "flavorForceDifferences");
    initializeMixed4(cc, openingForces, numParticles, "flavorOpeningForces");
    initializeMixed4(cc, savedPositions, numParticles, "flavorSavedPositions");
    initializeMixed4(cc, savedVelocities, numParticles, "flavorSavedVelocities");
    savedCellOffsets.assign(numParticles, mm_int4(0, 0, 0, 0));
    snapshotKernel->addArg(cc.getPosq());
    snapshotKernel->addArg(cc.getUseMixedPrecision() ? cc.getPosqCorrection() : cc.getPosq());
    snapshotKernel->addArg(cc.getVelm());
    snapshotKernel->addArg(cc.getAtomIndexArray());
    snapshotKernel->addArg(savedPositions);
    snapshotKernel->addArg(savedVelocities);
    initializeMixed4(cc, proposalPositions, cc.getPaddedNumAtoms(), "flavorProposalPositions");
    initializeMixed4(cc, proposalVelocities, cc.getPaddedNumAtoms(), "flavorProposalVelocities");
    for (ComputeKernel* kernel : {&saveProposalKernel, &rejectProposalKernel}) {
        (*kernel)->addArg(cc.getPosq());
        (*kernel)->addArg(cc.getUseMixedPrecision() ? cc.getPosqCorrection() : cc.getPosq());
        (*kernel)->addArg(cc.getVelm());
        (*kernel)->addArg(proposalPositions);
        (*kernel)->addArg(proposalVelocities);
    }
    if (hostConstraints && hasConstraints)
        projector = std::make_unique<ConstraintProjector>(system, particles, true);
    slotClock.assign(MaxForceSlots, SlotClock());
    copyForcesKernel->addArg(cc.getLongForceBuffer());
    copyForcesKernel->addArg(slotForces[0]);
    copyForcesKernel->addArg(cc.getAtomIndexArray());
    findAtomsKernel->addArg(cc.getAtomIndexArray());
    findAtomsKernel->addArg(slotOf);
    IntegrationUtilities& integration = cc.getIntegrationUtilities();
    driftDisplacementKernel->addArg(integration.getPosDelta());
    driftDisplacementKernel->addArg(cc.getVelm());
    addMixedArg(cc, driftDisplacementKernel, 0.0);
    applyDisplacementKernel->addArg(cc.getPosq());
    applyDisplacementKernel->addArg(cc.getUseMixedPrecision() ? cc.getPosqCorrection() : cc.getPosq());
    applyDisplacementKernel->addArg(integration.getPosDelta());
    applyDisplacementKernel->addArg(cc.getVelm());
    addMixedArg(cc, applyDisplacementKernel, 0.0);
}

CommonFlowStepper::~CommonFlowStepper() = default;

void CommonFlowStepper::addRandomArgs(ComputeKernel& kernel) {
    kernel->addArg((unsigned int)seed);
    kernel->addArg((unsigned int)(seed >> 32));
    kernel->addArg(kn);
    kernel->addArg(wn);
    kernel->addArg(fn);
}

void CommonFlowStepper::setSchedule(const Schedule& newSchedule) {
    if (newSchedule == schedule && !plan.passes.empty())
        return;
    schedule = newSchedule;
    prepare();
}

void CommonFlowStepper::setStiffModes(std::shared_ptr<const StiffModes> newModes) {
    modes = newModes;
    ContextSelector selector(cc);
    vector<int> table, layout, stiff, particleList, eigenOffsets, scratchOffsets, responseOffsets;
    vector<double> vectors, masses(numParticles, 1.0);
    size_t scratchSize = 0, responseSize = 0;
    for (int c = 0; c < modes->getNumComponents(); ++c) {
        const StiffModes::Component& comp = modes->getComponent(c);
        const int D = comp.rows(), C = comp.columns();
        table.insert(table.end(), {(int)particleList.size(), comp.numParticles, D, C});
        const int* particles = modes->getComponentParticles(c);
        particleList.insert(particleList.end(), particles, particles + comp.numParticles);
        const bool small = StiffModes::hasParticleSpacePropagator(D, C);
        layout.push_back(small ? 1 : 0);
        stiff.push_back(comp.stiff ? 1 : 0);
        // The force responses work in mode space for every component: all eigenvectors.
        eigenOffsets.push_back((int)vectors.size());
        const double* u = modes->getEigenvectors(c);
        vectors.insert(vectors.end(), u, u + (size_t)D * D);
        scratchOffsets.push_back((int)scratchSize);
        if (!small)
            scratchSize += 24 * (size_t)comp.numParticles;
        // Two values per mode, as StiffModes::ForceResponse lays them out.
        responseOffsets.push_back((int)responseSize);
        responseSize += 2 * (size_t)D;
    }
    for (int i = 0; i < numParticles; ++i)
        if (system.getParticleMass(i) != 0.0)
            masses[i] = modes->getSqrtMass(i);
    if (table.empty())
        table.assign(4, 0);
    if (!components.isInitialized())
        components.initialize<mm_int4>(cc, (int)table.size() / 4, "flavorComponents");
    else
        components.resize((int)table.size() / 4);
    components.upload(table.data());
    uploadInts(cc, componentLayout, layout, "flavorComponentLayout");
    uploadInts(cc, componentParticles, particleList, "flavorComponentParticles");
    uploadInts(cc, eigenvectorOffset, eigenOffsets, "flavorEigenvectorOffset");
    uploadInts(cc, scratchOffset, scratchOffsets, "flavorScratchOffset");
    uploadMixed(cc, eigenvectors, vectors, "flavorEigenvectors");
    uploadMixed(cc, sqrtMass, masses, "flavorSqrtMass");
    uploadMixed(cc, scratch, vector<double>(scratchSize, 0.0), "flavorScratch");
    uploadInts(cc, componentStiff, stiff, "flavorComponentStiff");
    uploadInts(cc, responseOffset, responseOffsets, "flavorResponseOffset");
    uploadMixed(cc, responseScratch, vector<double>(12 * particleList.size(), 0.0), "flavorResponseScratch");
    // The modes are measured again after parameter changes and checkpoints: the history of particles that are still
    // stiff stays, as in the CPU engine.
    if (projector)
        projector->setStiffModes(modes.get());
    hardWall.setStiffModes(modes.get(), particles);
    deviceWall->setPairs(hardWall, particles);
    // The history from where it was kept, to where it is kept now (the device where it solves the constraints).
    downloadHistory(history);
    if (projector)
        deviceCarried->setCarriers(projector->getCarriers(*modes), projector->getCarriedMembers());
    history.keepOnly(modes.get());
    uploadHistory();
    prepare();
}

void CommonFlowStepper::setFrozenCoordinates(std::shared_ptr<const StiffModes> frozenModes,
                                             std::shared_ptr<FrozenDistances> distances) {
    // The exact fast flow (HarmonicFlow) runs on the device over the same modes.
    if (frozenModes)
        setStiffModes(frozenModes);
    frozenStage.setStiffModes(std::move(frozenModes));
    deviceFrozen->setDistances(distances.get());
    frozenStage.setDistances(std::move(distances));
    if (!plan.passes.empty())
        prepare();
}

void CommonFlowStepper::setFrictionParticles(const vector<int>& particles) {
    if (frictionParticlesSet && particles == frictionParticles)
        return;
    frictionParticles = particles;
    frictionParticlesSet = true;
    vector<int> flags(numParticles, particles.empty() ? 1 : 0);
    for (int p : particles)
        flags[p] = 1;
    ContextSelector selector(cc);
    thermostated.upload(flags);
}

void CommonFlowStepper::setRandomSeed(std::uint64_t newSeed) {
    seed = newSeed;
    random = CounterRandom(seed);
    nextStream = 0;
    if (!plan.passes.empty())
        prepare();
}

void CommonFlowStepper::prepare() {
    plan = analyzeStep(schedule, hasConstraints);
    energySlots = MetropolisTest::energySlots(plan);
    slotEnergy.assign(plan.slotGroups.size(), 0.0);
    groupsWithoutEnergySlot = MetropolisTest::groupsWithoutEnergySlot(plan);
    metropolis.forgetEnergy();
    if (plan.slotGroups.size() > (size_t)MaxForceSlots)
        throw OpenMMException(owner + ": a step may kick with at most " + std::to_string(MaxForceSlots) +
                              " distinct force-group sets");
    ContextSelector selector(cc);
    auto addReal = [this](ComputeKernel& kernel, double value) { addMixedArg(cc, kernel, value); };
    ArrayInterface& correction = cc.getUseMixedPrecision() ? cc.getPosqCorrection() : cc.getPosq();
    passKernels.assign(plan.passes.size(), {});
    propagators.clear();
    propagators.resize(plan.passes.size());
    propagatorOffsets.clear();
    propagatorOffsets.resize(plan.passes.size());
    propagatorNoisy.assign(plan.passes.size(), 0);
    responses.clear();
    responses.resize(plan.passes.size());
    processings.clear();
    processings.resize(plan.passes.size());
    carrying.clear();
    carrying.resize(plan.passes.size());
    fusedPassKernels.assign(plan.passes.size(), ComputeKernel());
    fusedOps.clear();
    fusedOps.resize(plan.passes.size());
    fusedOpReals.clear();
    fusedOpReals.resize(plan.passes.size());
    bool haveBath = false, carryingStarted = false;
    Bath bath;
    deviceCarried->setNumPasses(plan.passes.size());
    for (size_t p = 0; p < plan.passes.size(); ++p) {
        const FlowPass& pass = plan.passes[p];
        for (size_t k = 0; k < pass.flows.size(); ++k) {
            const SubFlow& flow = pass.flows[k];
            ComputeKernel kernel;
            // As in the CPU engine: how constraint corrections around a stiff flow move its components.
            if (ConstraintProjector::hasCarrying(flow) && modes && projector) {
                carrying[p] = projector->carryingThrough(*modes, flow);
                if (constraintsOnDevice())
                    deviceCarried->setCarrying(p, carrying[p], !carryingStarted);
                carryingStarted = true;
            }
            switch (flow.kind) {
            case SubFlow::Kick:
                kernel = program->createKernel("kick");
                kernel->addArg(cc.getVelm());
                kernel->addArg(slotForces[pass.slots[k]]);
                kernel->addArg(cc.getAtomIndexArray());
                addReal(kernel, flow.h);
                break;
            case SubFlow::Drift:
                kernel = program->createKernel("drift");
                kernel->addArg(cc.getPosq());
                kernel->addArg(correction);
                kernel->addArg(cc.getVelm());
                addReal(kernel, flow.h);
                break;
            case SubFlow::Thermostat: {
                // The thermal speeds are per particle: one temperature for all of a step's thermostats.
                if (haveBath && flow.bath.kT != bath.kT)
                    throw OpenMMException(owner + ": the thermostats of one step must share one temperature");
                haveBath = true;
                bath = flow.bath;
                const VelocityFlow ou = computeVelocityFlow(flow.bath.friction, flow.h);
                kernel = program->createKernel("thermostat");
                kernel->addArg(cc.getVelm());
                kernel->addArg(cc.getAtomIndexArray());
                kernel->addArg(thermalSpeed);
                kernel->addArg(thermostated);
                addReal(kernel, ou.decay);
                addReal(kernel, ou.noise);
                kernel->addArg((std::uint64_t)0);
                addRandomArgs(kernel);
                break;
            }
            case SubFlow::StiffFlow:
            case SubFlow::HarmonicFlow:
                if (modes) // else prepared again when the modes are measured
                    kernel = createStiffFlowKernel(flow, p);
                break;
            case SubFlow::FilteredStiffFlow:
                // The flow, then the response to the forces where it began.
                if (modes) {
                    passKernels[p].push_back(createStiffFlowKernel(flow, p));
                    kernel = createForceResponseKernel(flow, pass.slots[k], p);
                }
                break;
            case SubFlow::FilteredKick:
                if (modes)
                    kernel = createForceResponseKernel(flow, pass.slots[k], p);
                break;
            case SubFlow::FrozenDrift:
            case SubFlow::FrozenKick:
                // The zero-mode projection moves stiff particles along the modes alone; constrained particles would
                // need the device's constraint algorithms in between (the CPU engine's ConstraintProjector).
                if (flow.frozen == SubFlow::FrozenSet::StiffModes && hasConstraints)
                    throw OpenMMException(owner + " on the " + platformName +
                                          " platform: freezing the modes of a quadratic stiff group in a System "
                                          "with constraints is not supported there yet; use the Reference or CPU "
                                          "platform");
                break; // runs on the host (HostFrozenStage)
            case SubFlow::HardWall:
            case SubFlow::HardWallSpeed:
                break; // DeviceHardWall, set up with the stiff modes
            case SubFlow::ProposalStart:
            case SubFlow::ProposalTest:
                break; // runProposal(): the state kept by saveProposalKernel, put back by rejectProposalKernel
            }
            passKernels[p].push_back(kernel);
        }
        fusedPassKernels[p] = createFusedPassKernel(pass, p);
    }
    // The step's first kernel that reads velocities, where that is a stiff flow, takes the last step's constraint
    // processing off them.
    size_t first = 0;
    while (first < plan.passes.size() && plan.passes[first].fusedIntoNext)
        ++first;
    if (constraintsOnDevice() && first < plan.passes.size() && !passKernels[first].empty() && passKernels[first][0] &&
        (plan.passes[first].flows[0].kind == SubFlow::StiffFlow ||
         plan.passes[first].flows[0].kind == SubFlow::FilteredStiffFlow))
        deviceCarried->fuseTakeOff(passKernels[first][0]);
    vector<double> speeds(numParticles, 0.0);
    for (int i = 0; i < numParticles; ++i) {
        const double mass = system.getParticleMass(i);
        speeds[i] = std::sqrt(bath.kT * (mass == 0.0 ? 0.0 : 1.0 / mass));
    }
    thermalSpeed.upload(speeds, true);
    invalidateForces();
}

ComputeKernel CommonFlowStepper::createFusedPassKernel(const FlowPass& pass, size_t p) {
    // Constrained drifts and projected kicks need the platform's constraint algorithms between the flows.
    if (hasConstraints || pass.flows.size() < 2)
        return ComputeKernel();
    vector<mm_int4> ops;
    vector<double> reals;
    for (size_t k = 0; k < pass.flows.size(); ++k) {
        const SubFlow& flow = pass.flows[k];
        if (flow.kind == SubFlow::Kick) {
            ops.push_back(mm_int4(0, pass.slots[k], 0, 0));
            reals.insert(reals.end(), {flow.h, 0.0});
        } else if (flow.kind == SubFlow::Drift) {
            ops.push_back(mm_int4(1, 0, 0, 0));
            reals.insert(reals.end(), {flow.h, 0.0});
        } else if (flow.kind == SubFlow::Thermostat) {
            const VelocityFlow ou = computeVelocityFlow(flow.bath.friction, flow.h);
            ops.push_back(mm_int4(2, 0, pass.streams[k], 0));
            reals.insert(reals.end(), {ou.decay, ou.noise});
        } else
            return ComputeKernel();
    }
    fusedOps[p].initialize<mm_int4>(cc, (int)ops.size(), "flavorFusedOps");
    fusedOps[p].upload(ops);
    uploadMixed(cc, fusedOpReals[p], reals, "flavorFusedOpReals");
    ComputeKernel kernel = program->createKernel("particlePass");
    kernel->addArg((int)ops.size());
    kernel->addArg(fusedOps[p]);
    kernel->addArg(fusedOpReals[p]);
    kernel->addArg(cc.getPosq());
    kernel->addArg(cc.getUseMixedPrecision() ? cc.getPosqCorrection() : cc.getPosq());
    kernel->addArg(cc.getVelm());
    kernel->addArg(cc.getAtomIndexArray());
    for (int s = 0; s < MaxForceSlots; ++s)
        kernel->addArg(slotForces[s]);
    kernel->addArg(thermalSpeed);
    kernel->addArg(thermostated);
    kernel->addArg(cc.getLongForceBuffer());
    kernel->addArg(-1);
    kernel->addArg((std::uint64_t)0);
    addRandomArgs(kernel);
    return kernel;
}

ComputeKernel CommonFlowStepper::createStiffFlowKernel(const SubFlow& flow, size_t p) {
    StiffModes::Propagator propagator;
    modes->computeFlowPropagator(flow, propagator);
    uploadMixed(cc, propagators[p], propagator.data, "flavorPropagator");
    vector<int> offsets(propagator.offset.begin(), propagator.offset.end());
    uploadInts(cc, propagatorOffsets[p], offsets, "flavorPropagatorOffset");
    propagatorNoisy[p] = propagator.noisy ? 1 : 0;
    ComputeKernel kernel = program->createKernel("stiffFlow");
    kernel->addArg(modes->getNumComponents());
    kernel->addArg(components);
    kernel->addArg(componentLayout);
    kernel->addArg(componentParticles);
    kernel->addArg(slotOf);
    kernel->addArg(propagators[p]);
    kernel->addArg(propagatorOffsets[p]);
    kernel->addArg(eigenvectors);
    kernel->addArg(eigenvectorOffset);
    kernel->addArg(sqrtMass);
    kernel->addArg(scratch);
    kernel->addArg(scratchOffset);
    kernel->addArg(cc.getPosq());
    kernel->addArg(cc.getUseMixedPrecision() ? cc.getPosqCorrection() : cc.getPosq());
    kernel->addArg(cc.getVelm());
    kernel->addArg(slotForces[0]);
    addMixedArg(cc, kernel, 0.0);
    kernel->addArg(propagatorNoisy[p]);
    kernel->addArg((std::uint64_t)0);
    addRandomArgs(kernel);
    // Where the constraints are solved on the device the flow leaves its displacement for their solve.
    deviceCarried->addFlowArgs(kernel, p, constraintsOnDevice(), DeviceCarriedConstraints::FlowKernel::StiffFlow);
    return kernel;
}

ComputeKernel CommonFlowStepper::createForceResponseKernel(const SubFlow& flow, int slot, size_t p) {
    const bool closing = flow.kind == SubFlow::FilteredKick;
    StiffModes::ForceResponse response, processing;
    modes->computeFlowResponses(flow, response, processing);
    uploadMixed(cc, responses[p], response.data, "flavorResponse");
    uploadMixed(cc, processings[p], processing.data, "flavorProcessing");
    ComputeKernel kernel = program->createKernel("forceResponse");
    kernel->addArg(modes->getNumComponents());
    kernel->addArg(components);
    kernel->addArg(componentStiff);
    kernel->addArg(componentParticles);
    kernel->addArg(slotOf);
    kernel->addArg(eigenvectors);
    kernel->addArg(eigenvectorOffset);
    kernel->addArg(sqrtMass);
    kernel->addArg(responses[p]);
    kernel->addArg(processings[p]);
    kernel->addArg(responseOffset);
    kernel->addArg(responseScratch);
    kernel->addArg(slotForces[slot]);
    kernel->addArg(openingForces);
    kernel->addArg(forceDifferences);
    kernel->addArg(closing ? 1 : 0);
    kernel->addArg(cc.getPosq());
    kernel->addArg(cc.getUseMixedPrecision() ? cc.getPosqCorrection() : cc.getPosq());
    kernel->addArg(cc.getVelm());
    // A FilteredStiffFlow's response joins the displacement of its flow (a FilteredKick's moves no position).
    deviceCarried->addFlowArgs(kernel, p, constraintsOnDevice(),
                               closing ? DeviceCarriedConstraints::FlowKernel::ClosingResponse
                                       : DeviceCarriedConstraints::FlowKernel::Response);
    return kernel;
}

void CommonFlowStepper::findAtoms() {
    // The atoms are reordered only between steps (where a step ends, a checkpoint is loaded, molecules are regrouped):
    // slotOf is made again only where the platform's host copy of the order changed since.
    if (atomsFound)
        return;
    const vector<int>& order = cc.getAtomIndex();
    if (order != slotOfOrder) {
        findAtomsKernel->execute(cc.getNumAtoms());
        slotOfOrder = order;
    }
    atomsFound = true;
}

void CommonFlowStepper::copyPendingForces() {
    if (slotInBuffer < 0)
        return;
    copyForcesKernel->setArg(1, slotForces[slotInBuffer]);
    copyForcesKernel->execute(cc.getNumAtoms());
    slotInBuffer = -1;
}

void CommonFlowStepper::invalidateForces() {
    // Forces at positions left behind are not needed: nothing to copy.
    slotInBuffer = -1;
    std::fill(slotValid.begin(), slotValid.end(), false);
    virtualSitesPlaced = false;
}

void CommonFlowStepper::placeVirtualSites() {
    if (hasVirtualSites && !virtualSitesPlaced)
        cc.getIntegrationUtilities().computeVirtualSites();
    virtualSitesPlaced = true;
}

void CommonFlowStepper::ensureForces(ContextImpl& context, int slot, bool clocked, double clock) {
    // A slot evaluated at these positions with another clock value holds other forces.
    if (slotValid[slot] && slotClock[slot].serves(clocked, clock))
        return;
    placeVirtualSites();
    if (clocked)
        context.setParameter(stiffClock.getParameter(), clock);
    slotClock[slot] = SlotClock{clocked, clock};
    // The buffer is about to be overwritten: forces still waiting there go into their slot first.
    copyPendingForces();
    const bool withEnergy = energySlots[slot];
    const double energy = context.calcForcesAndEnergy(true, withEnergy, plan.slotGroups[slot]);
    if (withEnergy)
        slotEnergy[slot] = energy;
    // Copied into the slot when a kernel that reads only slots needs them (copyPendingForces); kernels that read the
    // buffer too (particlePass, a device frozen pass's pre-kick) take them from there.
    slotInBuffer = slot;
    slotValid[slot] = true;
}

void CommonFlowStepper::runParticlePass(const FlowPass& pass, size_t passIndex, double constraintTolerance) {
    if (fusedPassKernels[passIndex]) {
        ComputeKernel& fused = fusedPassKernels[passIndex];
        // After the force slots: the thermal speeds, the thermostated flags, the force buffer, the slot it holds and
        // the stream.
        fused->setArg(10 + MaxForceSlots, slotInBuffer);
        fused->setArg(11 + MaxForceSlots, (std::uint64_t)nextStream);
        fused->execute(cc.getNumAtoms());
        for (const SubFlow& flow : pass.flows)
            if (flow.kind == SubFlow::Drift) {
                invalidateForces();
                break;
            }
        return;
    }
    copyPendingForces();
    bool drifts = false;
    vector<ComputeKernel>& kernels = passKernels[passIndex];
    for (size_t k = 0; k < pass.flows.size(); ++k) {
        const SubFlow& flow = pass.flows[k];
        switch (flow.kind) {
        case SubFlow::Drift:
            drifts = true;
            // The device's constraint algorithms, also with host constraints: the SIM's steps have no drifts (its
            // free flow is part of the stiff flow).
            if (hasConstraints) {
                // With constraints a pass is one sub-flow or a run of kicks and thermostats (analyzeStep).
                setMixedArg(cc, driftDisplacementKernel, 2, flow.h);
                setMixedArg(cc, applyDisplacementKernel, 4, 1.0 / flow.h);
                driftDisplacementKernel->execute(cc.getNumAtoms());
                cc.getIntegrationUtilities().applyConstraints(constraintTolerance);
                applyDisplacementKernel->execute(cc.getNumAtoms());
            } else {
                kernels[k]->execute(cc.getNumAtoms());
            }
            break;
        case SubFlow::Thermostat:
            kernels[k]->setArg(6, (std::uint64_t)(nextStream + (std::uint64_t)pass.streams[k]));
            kernels[k]->execute(cc.getNumAtoms());
            break;
        default:
            kernels[k]->execute(cc.getNumAtoms());
            break;
        }
    }
    if (drifts)
        invalidateForces();
    else if (constraintsOnDevice())
        cc.getIntegrationUtilities().applyVelocityConstraints(constraintTolerance);
    else if (projector)
        constrainVelocitiesOnHost(constraintTolerance);
    else if (hasConstraints)
        cc.getIntegrationUtilities().applyVelocityConstraints(constraintTolerance);
}

void CommonFlowStepper::rememberFlowStart() {
    if (!projector || constraintsOnDevice())
        return;
    mirror.download(true, false);
    projector->rememberPositions(mirror.positions);
}

void CommonFlowStepper::constrainAfterFlow(const FlowPass& pass, size_t passIndex, double constraintTolerance) {
    if (!projector)
        return;
    if (constraintsOnDevice()) {
        deviceCarried->constrainAfterFlow(passIndex, constraintTolerance, !pass.nextProjectsVelocities);
        return;
    }
    // As StiffFlowExecutor::runFlow: the correction of the positions is an impulse at the start of the flow, so it
    // also changes the velocities, and the projection after it removes what is left along the constraints.
    mirror.download(true, true);
    vector<Vec3>& positions = mirror.positions;
    vector<Vec3>& velocities = mirror.velocities;
    projector->constrainPositions(positions, velocities, constraintTolerance, &carrying[passIndex]);
    if (!pass.nextProjectsVelocities)
        projector->constrainVelocities(positions, velocities, constraintTolerance, &carrying[passIndex]);
    mirror.upload(true, true);
}

void CommonFlowStepper::constrainVelocitiesOnHost(double constraintTolerance,
                                                  const ConstraintProjector::StiffFlowCarrying* carrying) {
    mirror.download(true, true);
    vector<Vec3>& velocities = mirror.velocities;
    // A Filtered kick ends the step: its velocities take the constraint impulses' processing, then the projection
    // (as in the CPU engine).
    if (carrying && !carrying->processing.empty())
        projector->processVelocities(velocities, *carrying, history.constraintProcessing);
    projector->constrainVelocities(mirror.positions, velocities, constraintTolerance, carrying);
    mirror.upload(false, true);
}

void CommonFlowStepper::runStiffFlow(const FlowPass& pass, size_t passIndex) {
    if (!modes)
        throw OpenMMException(owner + ": a stiff flow needs the stiff modes");
    ComputeKernel& kernel = passKernels[passIndex][0];
    copyPendingForces();
    findAtoms();
    kernel->setArg(15, slotForces[fusedSlot >= 0 ? fusedSlot : 0]);
    setMixedArg(cc, kernel, 16, fusedSlot >= 0 ? fusedStep : 0.0);
    kernel->setArg(18, (std::uint64_t)(nextStream + (std::uint64_t)std::max(0, pass.streams[0])));
    kernel->execute(modes->getNumComponents());
    fusedSlot = -1;
    invalidateForces();
}

bool CommonFlowStepper::kickFusesIntoFrozenPass(size_t p) const {
    // A lone kick before a frozen pass on the device runs in that pass's kernel (no constraint projects it).
    if (hasConstraints || !deviceFrozen->isActive() || p + 1 >= plan.passes.size())
        return false;
    const FlowPass& pass = plan.passes[p];
    const SubFlow& next = plan.passes[p + 1].flows[0];
    return pass.flows.size() == 1 && pass.flows[0].kind == SubFlow::Kick &&
           (next.kind == SubFlow::FrozenDrift || next.kind == SubFlow::FrozenKick) &&
           next.frozen == SubFlow::FrozenSet::Distances;
}

void CommonFlowStepper::runFrozenPass(const FlowPass& pass, double constraintTolerance) {
    // Frozen passes hold one sub-flow each (analyzeStep).
    const SubFlow& flow = pass.flows[0];
    // A kick's forces were evaluated where the pass begins, as for every pass with a force slot (step()).
    const bool kick = flow.kind == SubFlow::FrozenKick;
    if (flow.frozen == SubFlow::FrozenSet::Distances && deviceFrozen->isActive()) {
        findAtoms();
        if (kick)
            copyPendingForces();
        deviceFrozen->run(flow, kick ? &slotForces[pass.slots[0]] : nullptr, constraintTolerance,
                          fusedSlot >= 0 ? &slotForces[fusedSlot] : nullptr, fusedStep,
                          fusedSlot >= 0 && fusedSlot == slotInBuffer);
        fusedSlot = -1;
    } else {
        copyPendingForces();
        frozenStage.run(flow, kick ? &slotForces[pass.slots[0]] : nullptr, constraintTolerance, !pass.othersFixedLater);
    }
    if (!kick)
        invalidateForces();
}

void CommonFlowStepper::runForceResponse(size_t passIndex, size_t kernelIndex) {
    if (!modes)
        throw OpenMMException(owner + ": a Filtered step needs the stiff modes");
    copyPendingForces();
    findAtoms();
    passKernels[passIndex][kernelIndex]->execute(modes->getNumComponents());
}

double CommonFlowStepper::proposalEnergy(ContextImpl& context) {
    double energy = 0.0;
    for (size_t s = 0; s < energySlots.size(); ++s)
        if (energySlots[s]) {
            ensureForces(context, (int)s);
            energy += slotEnergy[s];
        }
    if (groupsWithoutEnergySlot != 0) {
        placeVirtualSites();
        copyPendingForces();
        energy += context.calcForcesAndEnergy(false, true, groupsWithoutEnergySlot);
    }
    return energy;
}

void CommonFlowStepper::runProposal(ContextImpl& context, const FlowPass& pass) {
    // The energies come to the host for the test (OpenMM returns a potential energy to it); the states stay on the
    // device.
    const SubFlow& flow = pass.flows[0];
    if (flow.kind == SubFlow::ProposalStart) {
        metropolis.start(metropolis.needsStartPotential() ? proposalEnergy(context) : 0.0, kineticEnergy());
        saveProposalKernel->execute(cc.getNumAtoms());
        return;
    }
    const double potential = proposalEnergy(context);
    const double uniform = random.uniform(nextStream + (std::uint64_t)pass.streams[0]);
    if (!metropolis.test(potential, kineticEnergy(), uniform, flow.bath.kT)) {
        rejectProposalKernel->execute(cc.getNumAtoms());
        invalidateForces();
    }
}

void CommonFlowStepper::runHardWall(const SubFlow& flow) {
    findAtoms();
    if (flow.kind == SubFlow::HardWallSpeed) {
        deviceWall->setSpeeds(flow.stiffBath.kT);
        return;
    }
    deviceWall->movePositions(flow.distance, flow.h, flow.stiffBath.kT);
    invalidateForces();
}

void CommonFlowStepper::checkDeviceFailure() {
    // A failure the last step left on the device, read where this one starts (DeviceFailureFlag).
    const int code = failureFlag->take();
    if (code == DeviceFrozenStage::FailureCode)
        throw OpenMMException(deviceFrozen->failureMessage());
    if (code >= DeviceHardWall::FirstFailureCode)
        throw OpenMMException(deviceWall->failureMessage(code));
}

void CommonFlowStepper::step(ContextImpl& context, double constraintTolerance, double stepSize, bool& forcesValid) {
    ContextSelector selector(cc);
    checkDeviceFailure();
    if (!forcesValid) {
        invalidateForces();
        metropolis.forgetEnergy();
    }
    history.stepStarted();
    if (constraintsOnDevice()) {
        deviceCarried->takeOffProcessing();
    } else if (projector) {
        projector->startStep();
        // The copies only where the last step processed its velocities (the Middle placement's constraint impulses).
        if (projector->hasProcessing(history.constraintProcessing)) {
            mirror.download(false, true);
            projector->takeOffProcessing(mirror.velocities, history.constraintProcessing);
            mirror.upload(false, true);
        }
    }
    const double clockAtStart = stiffClock.startStep(cc.getTime());
    for (size_t p = 0; p < plan.passes.size(); ++p) {
        const FlowPass& pass = plan.passes[p];
        // Every kick of a pass, and a Filtered flow, reads forces at the positions where the pass begins.
        for (size_t k = 0; k < pass.flows.size(); ++k)
            if (pass.slots[k] >= 0)
                ensureForces(context, pass.slots[k], pass.flows[k].clocked, clockAtStart + pass.flows[k].clock);
        if (pass.fusedIntoNext || kickFusesIntoFrozenPass(p)) {
            fusedSlot = pass.slots[0];
            fusedStep = pass.flows[0].h;
            continue;
        }
        switch (pass.flows[0].kind) {
        case SubFlow::StiffFlow:
        case SubFlow::HarmonicFlow:
            rememberFlowStart();
            runStiffFlow(pass, p);
            constrainAfterFlow(pass, p, constraintTolerance);
            break;
        case SubFlow::FrozenDrift:
        case SubFlow::FrozenKick:
            runFrozenPass(pass, constraintTolerance);
            break;
        case SubFlow::HardWall:
        case SubFlow::HardWallSpeed:
            runHardWall(pass.flows[0]);
            break;
        case SubFlow::ProposalStart:
        case SubFlow::ProposalTest:
            runProposal(context, pass);
            break;
        case SubFlow::FilteredStiffFlow:
            // The response reads the slot's forces from where the flow began: invalidated, not overwritten.
            rememberFlowStart();
            runStiffFlow(pass, p);
            runForceResponse(p, 1);
            constrainAfterFlow(pass, p, constraintTolerance);
            break;
        case SubFlow::FilteredKick:
            // Its position response is zero: the forces stay valid for the next step's opening.
            runForceResponse(p, 0);
            if (constraintsOnDevice())
                deviceCarried->constrainVelocities(p, constraintTolerance);
            else if (projector)
                constrainVelocitiesOnHost(constraintTolerance, &carrying[p]);
            break;
        default:
            runParticlePass(pass, p, constraintTolerance);
            break;
        }
    }
    nextStream += (std::uint64_t)plan.noiseStreams;
    placeVirtualSites();
    cc.setTime(cc.getTime() + stepSize);
    cc.setStepCount(cc.getStepCount() + 1);
    stiffClock.endStep(cc.getTime());
    // Forces valid at the step's end serve the next step's opening: into their slot before the step returns (a
    // getState() may evaluate forces into the buffer in between).
    copyPendingForces();
    failureFlag->finishStep();
    cc.reorderAtoms();
    atomsFound = false;
    forcesValid = true;
}

double CommonFlowStepper::kineticEnergy() {
    ContextSelector selector(cc);
    // Summed in the System's order, as the CPU engine sums it.
    mirror.download(false, true);
    return particles.kineticEnergy(mirror.velocities);
}

void CommonFlowStepper::createCheckpoint(std::ostream& stream) const {
    ContextSelector selector(cc);
    StepHistory current = history;
    downloadHistory(current);
    writeFlowCheckpoint(stream, owner, seed, nextStream, current, stiffClock.getState(), metropolis.getCounts());
}

void CommonFlowStepper::forgetStepHistory() {
    history.forget();
    ContextSelector selector(cc);
    uploadHistory();
    // A cached factorization from where the Context was before would steer the next solves, as in FlowStepRunner.
    frozenStage.forgetFactorizations();
    deviceFrozen->forgetFactorizations();
}

void CommonFlowStepper::downloadHistory(StepHistory& target) const {
    forceDifferences.download(staging.data());
    staging.toVec3(target.forceDifferences);
    if (constraintsOnDevice())
        deviceCarried->downloadProcessing(target.constraintProcessing);
}

void CommonFlowStepper::uploadHistory() {
    staging.fromVec3(history.forceDifferences);
    forceDifferences.upload(staging.data());
    if (constraintsOnDevice())
        deviceCarried->uploadProcessing(history.constraintProcessing);
}

void CommonFlowStepper::loadCheckpoint(ContextImpl& context, std::istream& stream) {
    std::uint64_t storedSeed = 0, storedStream = 0;
    StepHistory::Stored storedHistory;
    StiffClockState storedClock;
    ProposalCounts storedCounts;
    const string problem = readFlowCheckpoint(stream, owner, history, storedSeed, storedStream, storedHistory,
                                              &storedClock, &storedCounts);
    if (!problem.empty()) {
        restoreSavedState(context);
        invalidateForces();
        throw OpenMMException(flowCheckpointError(owner, problem));
    }
    setRandomSeed(storedSeed);
    nextStream = storedStream;
    stiffClock.setState(storedClock);
    metropolis.setCounts(storedCounts);
    metropolis.forgetEnergy();
    history.load(storedHistory);
    uploadHistory();
    frozenStage.forgetFactorizations();
    deviceFrozen->forgetFactorizations();
    atomsFound = false;
    invalidateForces();
}

void CommonFlowStepper::saveContextState(ContextImpl& context, bool withParameters) {
    // The particles on the device, so that saving after every step() costs no transfer; the cell offsets, box, time
    // and parameters are host values.
    rollback.saveAllButParticles(context, withParameters);
    snapshotKernel->execute(cc.getNumAtoms());
    const vector<int>& order = cc.getAtomIndex();
    const vector<mm_int4>& offsets = cc.getPosCellOffsets();
    for (int i = 0; i < numParticles; ++i)
        savedCellOffsets[order[i]] = offsets[i];
}

void CommonFlowStepper::restoreSavedState(ContextImpl& context) {
    // The positions as ContextImpl::getPositions() gives them: the cell offsets taken off.
    vector<Vec3>& positions = rollback.savedPositions();
    vector<Vec3>& velocities = rollback.savedVelocities();
    positions.resize(numParticles);
    velocities.resize(numParticles);
    savedPositions.download(staging.data());
    staging.toVec3(positions);
    savedVelocities.download(staging.data());
    staging.toVec3(velocities);
    Vec3 box[3];
    cc.getPeriodicBoxVectors(box[0], box[1], box[2]);
    for (int i = 0; i < numParticles; ++i) {
        const mm_int4 offset = savedCellOffsets[i];
        positions[i] = positions[i] - box[0] * offset.x - box[1] * offset.y - box[2] * offset.z;
    }
    rollback.restore(context);
}

namespace {

const char* const FlavorName = "FlavorIntegrator";
const char* const ImpulseName = "StochasticImpulseIntegrator";

} // namespace

void CommonFlavorStepKernel::initialize(const System& system, const FlavorIntegrator& integrator) {
    // Both ends of every added frozen distance stay in one periodic image (HostFrozenStage), declared before the
    // platform groups the particles into molecules.
    vector<std::pair<int, int>> extraPairs;
    for (int i = 0; i < integrator.getNumFrozenDistances(); ++i) {
        int p1, p2;
        integrator.getFrozenDistance(i, p1, p2);
        extraPairs.emplace_back(p1, p2);
    }
    if (!extraPairs.empty())
        cc.addForce(new FrozenPairsInfo(extraPairs));
    // The platform sets up its buffers (forces, atom order) before the kernels use them, as OpenMM's own do.
    cc.initializeContexts();
    ContextSelector selector(cc);
    stepper = std::make_unique<CommonFlowStepper>(cc, system, FlavorName, getPlatform().getName());
    stepper->setRandomSeed(effectiveRandomSeed(integrator.getRandomNumberSeed()));
    control = std::make_unique<FlavorStepControl>(system, *stepper, getPlatform().getName());
}

void CommonFlavorStepKernel::execute(ContextImpl& context, const FlavorIntegrator& integrator, bool& forcesValid,
                                     bool& stiffModesValid) {
    ContextSelector selector(cc);
    control->step(context, integrator, forcesValid, stiffModesValid);
}

double CommonFlavorStepKernel::computeKineticEnergy(ContextImpl& /*context*/, const FlavorIntegrator& /*integrator*/) {
    ContextSelector selector(cc);
    return stepper->kineticEnergy();
}

void CommonFlavorStepKernel::createCheckpoint(ContextImpl& /*context*/, std::ostream& stream) const {
    ContextSelector selector(cc);
    stepper->createCheckpoint(stream);
}

void CommonFlavorStepKernel::loadCheckpoint(ContextImpl& context, std::istream& stream) {
    ContextSelector selector(cc);
    stepper->loadCheckpoint(context, stream);
}

void CommonFlavorStepKernel::saveContextState(ContextImpl& context, bool withParameters) {
    ContextSelector selector(cc);
    stepper->saveContextState(context, withParameters);
}

void CommonFlavorStepKernel::forgetStepHistory() {
    ContextSelector selector(cc);
    stepper->forgetStepHistory();
}

void CommonImpulseStepKernel::initialize(const System& system, const StochasticImpulseIntegrator& integrator) {
    // The platform sets up its buffers (forces, atom order) before the kernels use them, as OpenMM's own do.
    cc.initializeContexts();
    ContextSelector selector(cc);
    // The System's constraints carry stiff components (ConstraintProjector; on the device where SETTLE holds them).
    stepper = std::make_unique<CommonFlowStepper>(cc, system, ImpulseName, getPlatform().getName(), true);
    stepper->setRandomSeed(effectiveRandomSeed(integrator.getRandomNumberSeed()));
    control = std::make_unique<ImpulseStepControl>(system, *stepper, getPlatform().getName());
}

void CommonImpulseStepKernel::execute(ContextImpl& context, const StochasticImpulseIntegrator& integrator,
                                      bool& forcesValid, bool& stiffModesValid) {
    ContextSelector selector(cc);
    control->step(context, integrator, forcesValid, stiffModesValid);
}

vector<double> CommonImpulseStepKernel::getStiffModeFrequencies(ContextImpl& context,
                                                                const StochasticImpulseIntegrator& integrator,
                                                                bool& stiffModesValid) {
    ContextSelector selector(cc);
    return control->getStiffModeFrequencies(context, integrator.getStiffGroups(), stiffModesValid);
}

vector<double> CommonImpulseStepKernel::getWarpedPhaseChoice(ContextImpl& context,
                                                             const StochasticImpulseIntegrator& integrator,
                                                             bool& stiffModesValid) {
    ContextSelector selector(cc);
    const WarpedPhaseChoice* choice = control->getWarpedPhaseChoice(context, integrator, stiffModesValid);
    if (choice == nullptr)
        return {};
    return {choice->phase, choice->couplingRatio, choice->seconds};
}

double CommonImpulseStepKernel::computeKineticEnergy(ContextImpl& /*context*/,
                                                     const StochasticImpulseIntegrator& /*integrator*/) {
    ContextSelector selector(cc);
    return stepper->kineticEnergy();
}

void CommonImpulseStepKernel::createCheckpoint(ContextImpl& /*context*/, std::ostream& stream) const {
    ContextSelector selector(cc);
    stepper->createCheckpoint(stream);
}

void CommonImpulseStepKernel::loadCheckpoint(ContextImpl& context, std::istream& stream) {
    ContextSelector selector(cc);
    stepper->loadCheckpoint(context, stream);
}

void CommonImpulseStepKernel::saveContextState(ContextImpl& context, bool withParameters) {
    ContextSelector selector(cc);
    stepper->saveContextState(context, withParameters);
}

void CommonImpulseStepKernel::forgetStepHistory() {
    ContextSelector selector(cc);
    stepper->forgetStepHistory();
}
