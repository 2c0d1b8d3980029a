#include "FlavorStepKernel.h"
#include "internal/StiffGroupChecks.h"
#include "openmm/OpenMMException.h"
#include "openmm/internal/ContextImpl.h"
#include "openmm/reference/SimTKOpenMMRealType.h"

using namespace FlavorPlugin;
using namespace OpenMM;
using std::string;
using std::vector;

FlavorStepKernel::FlavorStepKernel(std::string name, const Platform& platform, std::unique_ptr<ParallelLoop> loop)
    : IntegrateFlavorStepKernel(name, platform), loop(std::move(loop)), configured(false), kT(0.0) {}

void FlavorStepKernel::initialize(const System& system, const FlavorIntegrator& integrator) {
    runner = std::make_unique<FlowStepRunner>(system, std::move(loop));
    runner->setRandomSeed(effectiveRandomSeed(integrator.getRandomNumberSeed()));
    measurement = std::make_unique<StiffModesMeasurement>(
        system, "FlavorIntegrator",
        "use the Nonintrusive averaging (FlavorIntegrator::setAveraging) for nonlinear stiff forces");
}

namespace {

/** The Middle placement is defined for the artificial Verlet scheme with its symplectic microstep. */
void requireMiddlePlacementSupported(const FlavorParameters& p) {
    string conflict;
    if (p.scheme != FlavorIntegrator::Verlet)
        conflict = "scheme = SymplecticEuler (it needs Verlet)";
    else if (p.averaging == FlavorIntegrator::Nonintrusive)
        conflict = "averaging = Nonintrusive (it needs Artificial or ArtificialProjected)";
    else if (p.exactFastFlow)
        conflict = "exactFastFlow = true (it needs the symplectic microstep; the exact fast flow samples harmonic "
                   "stiff coordinates exactly with Edges)";
    if (!conflict.empty())
        throw OpenMMException("FlavorIntegrator: thermostatPlacement = Middle (1) is not allowed with " + conflict +
                              "; allowed: FlavorIntegrator::Edges (0) with every scheme and averaging, Middle with the "
                              "Verlet scheme, an artificial averaging and setExactFastFlow(false)");
}

} // namespace

void FlavorStepKernel::execute(ContextImpl& context, const FlavorIntegrator& integrator, bool& forcesValid,
                               bool& stiffModesValid) {
    FlavorParameters current{integrator.getScheme(),
                             integrator.getAveraging(),
                             integrator.getExactFastFlow(),
                             integrator.getMesoStep(),
                             integrator.getMicroStep(),
                             integrator.getStiffGroups(),
                             integrator.getIntegrationForceGroups(),
                             integrator.getFriction(),
                             integrator.getStiffFriction(),
                             integrator.getThermostatPlacement()};
    if (current.thermostatPlacement == FlavorIntegrator::Middle)
        requireMiddlePlacementSupported(current);
    const double currentKT = BOLTZ * integrator.getTemperature();
    if (!configured || !(current == parameters) || currentKT != kT) {
        // Rebuilt only when a parameter changed, so the step loop does not allocate.
        parameters = current;
        kT = currentKT;
        runner->setSchedule(flavorSchedule(parameters), kT, parameters.friction);
        configured = true;
    }
    // The artificial averagings freeze the nonzero modes of the stiff potential, measured where the first step starts
    // and again after anything that may change it.
    if (parameters.averaging != FlavorIntegrator::Nonintrusive &&
        (!stiffModesValid || (!measurement->getModes() && !frozenDistances))) {
        determineFrozenCoordinates(context, integrator);
        stiffModesValid = true;
    }
    if (parameters.averaging != FlavorIntegrator::Nonintrusive && parameters.exactFastFlow && frozenDistances)
        throw OpenMMException("FlavorIntegrator: the stiff force groups are not quadratic (their distances are frozen "
                              "with constraints), so they have no exact fast flow; call setExactFastFlow(false)");
    runner->setFrictionParticles(integrator.getFrictionParticles());
    runner->step(context, integrator.getConstraintTolerance(), integrator.getMesoStep(), forcesValid);
}

void FlavorStepKernel::determineFrozenCoordinates(ContextImpl& context, const FlavorIntegrator& integrator) {
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
        if (measurement->measure(context, parameters.stiffGroups, checkConstraints) || frozenDistances)
            runner->setStiffModes(measurement->getModes());
        frozenDistances = nullptr;
        frozenPairs.clear();
        runner->setFrozenDistances(nullptr);
        return;
    } catch (const NotQuadraticException& notQuadratic) {
        if (parameters.exactFastFlow)
            throw OpenMMException(string(notQuadratic.what()) +
                                  ".  The exact fast flow (FlavorIntegrator::setExactFastFlow) needs a quadratic stiff "
                                  "group; set it to false to integrate nonlinear stiff forces with the stiff kicks");
        vector<string> unsupported;
        vector<std::pair<int, int>> pairs = bondedFrozenPairs(context, parameters.stiffGroups, extra, unsupported);
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

void FlavorStepKernel::createCheckpoint(ContextImpl& /*context*/, std::ostream& stream) const {
    runner->createCheckpoint(stream, "FlavorIntegrator");
}

void FlavorStepKernel::loadCheckpoint(ContextImpl& context, std::istream& stream) {
    runner->loadCheckpoint(context, stream, "FlavorIntegrator");
}

void FlavorStepKernel::saveContextState(ContextImpl& context, bool withParameters) {
    runner->saveContextState(context, withParameters);
}
