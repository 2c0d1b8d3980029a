#ifndef OPENMM_FLAVORS_FROZEN_COORDINATES_H_
#define OPENMM_FLAVORS_FROZEN_COORDINATES_H_

#include "FrozenDistances.h"
#include "StiffModes.h"
#include "StiffProbe.h"
#include "internal/FlowSchedule.h"
#include "internal/windowsExportFlavors.h"
#include "openmm/System.h"
#include <memory>
#include <utility>
#include <vector>

namespace OpenMM {
class ContextImpl;
}

namespace FlavorPlugin {

class FlavorIntegrator;

/**
 * What the artificial averagings freeze, decided where the first step starts and again after anything that may
 * change it: the nonzero modes of a quadratic stiff group (measured by a StiffModesMeasurement), or else the distances
 * of the stiff bonded forces and those added with FlavorIntegrator::addFrozenDistance().  The FlavorIntegrator kernels
 * of every platform decide it here and hand the result to their step engine.
 */
class OPENMM_EXPORT_FLAVORS FrozenCoordinates {
public:
    explicit FrozenCoordinates(const OpenMM::System& system);
    /**
     * Decides what freezes at the Context's current positions.  Returns true if the stiff modes or the frozen distances
     * changed, so that the step engine must be given them again (getModes(), getDistances()).
     */
    bool determine(OpenMM::ContextImpl& context, const FlavorIntegrator& integrator, const FlavorParameters& current);
    /** The measured stiff modes (null before the first measurement; kept, but not frozen, while distances freeze). */
    const std::shared_ptr<const StiffModes>& getModes() const { return measurement.getModes(); }
    /** The frozen distances, or null where the stiff modes freeze. */
    const std::shared_ptr<FrozenDistances>& getDistances() const { return distances; }
    /** What freezes: the distances, the stiff modes, or nothing yet (None before the first decision). */
    SubFlow::FrozenSet getFrozenSet() const;
    /** The set a step is built for: the distances if they freeze, else the stiff modes (until decided). */
    SubFlow::FrozenSet getScheduledSet() const {
        return distances ? SubFlow::FrozenSet::Distances : SubFlow::FrozenSet::StiffModes;
    }
    /** How many coordinates freeze: distances held, or nonzero stiff modes. */
    int getNumFrozen() const;

private:
    StiffModesMeasurement measurement;
    std::shared_ptr<FrozenDistances> distances;
    std::vector<std::pair<int, int>> pairs;
};

} // namespace FlavorPlugin

#endif
