#ifndef OPENMM_FLAVORS_FROZEN_DISTANCES_H_
#define OPENMM_FLAVORS_FROZEN_DISTANCES_H_

#include "internal/windowsExportFlavors.h"
#include "openmm/System.h"
#include "openmm/Vec3.h"
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace OpenMM {
class ContextImpl;
}

namespace FlavorPlugin {

/**
 * The distances that the stiff bonded forces of groups stiffGroups act on: each bond of a HarmonicBondForce or
 * CustomBondForce, the 1-3 distance of each angle of a HarmonicAngleForce, then the extra pairs, without repeats.
 * Stiff forces of other types are described in unsupported (one entry per force: its index and type).
 */
OPENMM_EXPORT_FLAVORS std::vector<std::pair<int, int>> bondedFrozenPairs(const OpenMM::ContextImpl& context,
                                                                         int stiffGroups,
                                                                         const std::vector<std::pair<int, int>>& extra,
                                                                         std::vector<std::string>& unsupported);

/**
 * The frozen drift and kick of the artificial FLAVOR for stiff bonded forces: the frozen distances are held with
 * OpenMM's CCMA constraint solver as temporary constraints next to the System's own (which stay on throughout).
 *
 *     drift(h):  store the rates of the frozen distances; remove the velocity components along every constraint
 *                (mass-orthogonal projection onto the constraint manifold's tangent space); drift with the frozen
 *                distances held at their current lengths and the System's at theirs; project the velocities again
 *                (RATTLE); restore the stored rates along the new constraint directions.
 *     kick(h):   v += h P M^-1 F, with P the same projection (the soft impulse's component along the frozen
 *                distances dropped).
 *
 * All buffers are sized at construction; the steps do not allocate.
 */
class OPENMM_EXPORT_FLAVORS FrozenDistances {
public:
    FrozenDistances(const OpenMM::System& system, const std::vector<std::pair<int, int>>& frozenPairs);
    ~FrozenDistances();
    int getNumFrozen() const { return numFrozen; }
    void drift(std::vector<OpenMM::Vec3>& positions, std::vector<OpenMM::Vec3>& velocities,
               std::vector<double>& inverseMasses, double h, double tolerance);
    void kick(std::vector<OpenMM::Vec3>& positions, std::vector<OpenMM::Vec3>& velocities,
              const std::vector<OpenMM::Vec3>& forces, std::vector<double>& inverseMasses, double h, double tolerance);

private:
    class Solver;
    /** Sets v so that every constraint's rate is its target (0 for the System's), to the tolerance. */
    void restoreRates(const std::vector<OpenMM::Vec3>& positions, std::vector<OpenMM::Vec3>& velocities,
                      const std::vector<double>& inverseMasses, double tolerance);
    int numSystem, numFrozen;
    std::vector<std::pair<int, int>> pairs;
    std::unique_ptr<Solver> solver;
    std::vector<double> targetRates;
    std::vector<OpenMM::Vec3> previousPositions, scratch;
};

} // namespace FlavorPlugin

#endif
