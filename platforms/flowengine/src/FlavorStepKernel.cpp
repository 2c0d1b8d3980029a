#include "FlavorStepKernel.h"
#include "internal/StiffGroupChecks.h"
#include "openmm/OpenMMException.h"
#include "openmm/internal/ContextImpl.h"

using namespace FlavorPlugin;
using namespace OpenMM;
using std::string;
using std::vector;

FlavorStepKernel::FlavorStepKernel(std::string name, const Platform& platform, std::unique_ptr<ParallelLoop> loop)
    : RunnerKernel(name, platform, "FlavorIntegrator"), loop(std::move(loop)), configured(false) {}

void FlavorStepKernel::initialize(const System& system, const FlavorIntegrator& integrator) {
    runner = std::make_unique<FlowStepRunner>(system, std::move(loop));
    runner->setRandomSeed(effectiveRandomSeed(integrator.getRandomNumberSeed()));
    measurement = std::make_unique<StiffModesMeasurement>(
        system, "FlavorIntegrator",
        "use the Nonintrusive averaging (FlavorIntegrator::setAveraging) for nonlinear stiff forces");
}

void FlavorStepKernel::execute(ContextImpl& context, const FlavorIntegrator& integrator, bool& forcesValid,
                               bool& stiffModesValid) {
    FlavorParameters current = flavorParameters(integrator);
    auto frozenSet = [this] {
        return frozenDistances ? SubFlow::FrozenSet::Distances : SubFlow::FrozenSet::StiffModes;
    };
    current.frozen = frozenSet();
    validateFlavorStep(current);
    // The artificial averagings freeze the nonzero modes of the stiff potential, measured where the first step starts
    // and again after anything that may change it.
    if (current.averaging != FlavorIntegrator::Nonintrusive &&
        (!stiffModesValid || (!measurement->getModes() && !frozenDistances))) {
        determineFrozenCoordinates(context, integrator, current);
        stiffModesValid = true;
        current.frozen = frozenSet();
        validateFlavorStep(current);
    }
    validateMetropolis(current, context.getSystem().getNumConstraints() > 0);
    if (!configured || !(current == parameters) || integrator.getStiffClockParameter() != clockParameter) {
        // Rebuilt only when a parameter changed, so the step loop does not allocate.
        parameters = current;
        clockParameter = integrator.getStiffClockParameter();
        runner->setSchedule(flavorSchedule(parameters));
        runner->setStiffClock(clockParameter, parameters.microStep, parameters.mesoStep);
        configured = true;
    }
    runner->setFrictionParticles(integrator.getFrictionParticles());
    runner->step(context, integrator.getConstraintTolerance(), integrator.getMesoStep(), forcesValid);
}

void FlavorStepKernel::determineFrozenCoordinates(ContextImpl& context, const FlavorIntegrator& integrator,
                                                  const FlavorParameters& current) {
    // A quadratic stiff group freezes its nonzero modes; otherwise the distances of the stiff bonded forces freeze.
    vector<std::pair<int, int>> extra;
    for (int i = 0; i < integrator.getNumFrozenDistances(); ++i) {
        int p1, p2;
        integrator.getFrozenDistance(i, p1, p2);
        extra.emplace_back(p1, p2);
    }
    try {
        // The zero-mode drift moves particles of stiff components along the modes alone: no constraint may touch them.
        auto checkConstraints = [&context](const StiffModes& modes) {
            std::vector<bool> stiff(context.getSystem().getNumParticles());
            for (size_t i = 0; i < stiff.size(); ++i)
                stiff[i] = modes.isStiffParticle((int)i);
            rejectConstrainedStiffParticles(
                context, stiff, "FlavorIntegrator",
                "use the Nonintrusive averaging (FlavorIntegrator::setAveraging) for nonlinear stiff forces");
        };
        if (measurement->measure(context, current.stiffGroups, checkConstraints) || frozenDistances)
            runner->setStiffModes(measurement->getModes());
        frozenDistances = nullptr;
        frozenPairs.clear();
        runner->setFrozenDistances(nullptr);
        return;
    } catch (const NotQuadraticException& notQuadratic) {
        if (current.exactFastFlow)
            throw OpenMMException(string(notQuadratic.what()) +
                                  ".  The exact fast flow (FlavorIntegrator::setExactFastFlow) needs a quadratic stiff "
                                  "group; set it to false to integrate nonlinear stiff forces with the stiff kicks");
        vector<string> unsupported;
        vector<std::pair<int, int>> pairs = bondedFrozenPairs(context, current.stiffGroups, extra, unsupported);
        if (!unsupported.empty() && extra.empty())
            throw OpenMMException(describeUnfreezableForces(unsupported));
        if (pairs == frozenPairs && frozenDistances)
            return;
        vector<Vec3> positions;
        context.getPositions(positions);
        frozenDistances = std::make_shared<FrozenDistances>(context.getSystem(), pairs, positions);
        frozenPairs = pairs;
        runner->setFrozenDistances(frozenDistances);
    }
}

double FlavorStepKernel::computeKineticEnergy(ContextImpl& context, const FlavorIntegrator& /*integrator*/) {
    return runner->kineticEnergy(context);
}

int FlavorStepKernel::getFrozenSet() const {
    if (frozenDistances)
        return (int)SubFlow::FrozenSet::Distances;
    return (int)(measurement->getModes() ? SubFlow::FrozenSet::StiffModes : SubFlow::FrozenSet::None);
}

int FlavorStepKernel::getNumFrozen() const {
    if (frozenDistances)
        return frozenDistances->getNumFrozen();
    return measurement->getModes() ? (int)measurement->getModes()->getStiffFrequencies().size() : 0;
}
