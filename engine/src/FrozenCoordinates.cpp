#include "FrozenCoordinates.h"
#include "FlavorIntegrator.h"
#include "internal/StiffGroupChecks.h"
#include "openmm/OpenMMException.h"
#include "openmm/internal/ContextImpl.h"
#include <string>

using namespace FlavorPlugin;
using namespace OpenMM;
using std::string;
using std::vector;

FrozenCoordinates::FrozenCoordinates(const System& system)
    : measurement(system, "FlavorIntegrator",
                  "use the Nonintrusive averaging (FlavorIntegrator::setAveraging) for nonlinear stiff forces") {}

bool FrozenCoordinates::determine(ContextImpl& context, const FlavorIntegrator& integrator,
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
        const bool changed = measurement.measure(context, current.stiffGroups, checkConstraints) || distances;
        distances = nullptr;
        pairs.clear();
        return changed;
    } catch (const NotQuadraticException& notQuadratic) {
        if (current.exactFastFlow)
            throw OpenMMException(string(notQuadratic.what()) +
                                  ".  The exact fast flow (FlavorIntegrator::setExactFastFlow) needs a quadratic stiff "
                                  "group; set it to false to integrate nonlinear stiff forces with the stiff kicks");
        vector<string> unsupported;
        vector<std::pair<int, int>> newPairs = bondedFrozenPairs(context, current.stiffGroups, extra, unsupported);
        if (!unsupported.empty() && extra.empty())
            throw OpenMMException(describeUnfreezableForces(unsupported));
        if (newPairs == pairs && distances)
            return false;
        vector<Vec3> positions;
        context.getPositions(positions);
        distances = std::make_shared<FrozenDistances>(context.getSystem(), newPairs, positions);
        pairs = newPairs;
        return true;
    }
}

SubFlow::FrozenSet FrozenCoordinates::getFrozenSet() const {
    if (distances)
        return SubFlow::FrozenSet::Distances;
    return getModes() ? SubFlow::FrozenSet::StiffModes : SubFlow::FrozenSet::None;
}

int FrozenCoordinates::getNumFrozen() const {
    if (distances)
        return distances->getNumFrozen();
    return getModes() ? (int)getModes()->getStiffFrequencies().size() : 0;
}
