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
 * The frozen drift and kick of the artificial FLAVOR for stiff bonded forces: the frozen distances are held as
 * temporary constraints next to the System's own (which stay on throughout), with SHAKE for positions and RATTLE's
 * velocity step, solved by Gauss-Seidel sweeps to the integrator's constraint tolerance.
 *
 *     drift(h):  store the rates of the frozen distances; remove the velocity components along every constraint
 *                (mass-orthogonal projection onto the constraint manifold's tangent space); drift with the frozen
 *                distances held at their current lengths and the System's at theirs; then give every constraint its
 *                rate along the new directions: the stored one for the frozen distances, 0 for the System's.
 *     kick(h):   v += h P M^-1 F, with P the same projection (the soft impulse's component along the frozen
 *                distances and the System's constraints dropped).
 *
 * All buffers are sized at construction; the steps do not allocate.
 */
class OPENMM_EXPORT_FLAVORS FrozenDistances {
public:
    FrozenDistances(const OpenMM::System& system, const std::vector<std::pair<int, int>>& frozenPairs);
    int getNumFrozen() const { return numFrozen; }
    void drift(std::vector<OpenMM::Vec3>& positions, std::vector<OpenMM::Vec3>& velocities,
               const std::vector<double>& inverseMasses, double h, double tolerance);
    void kick(const std::vector<OpenMM::Vec3>& positions, std::vector<OpenMM::Vec3>& velocities,
              const std::vector<OpenMM::Vec3>& forces, const std::vector<double>& inverseMasses, double h,
              double tolerance);

private:
    static constexpr int MaxSweeps = 1000;
    /** SHAKE: moves positions along the constraint directions at previousPositions until every length holds. */
    void constrainPositions(std::vector<OpenMM::Vec3>& positions, const std::vector<double>& inverseMasses,
                            double tolerance);
    /** Sets the velocities so that every constraint's rate is its target. */
    void constrainVelocities(const std::vector<OpenMM::Vec3>& positions, std::vector<OpenMM::Vec3>& velocities,
                             const std::vector<double>& inverseMasses, const std::vector<double>& targets,
                             double tolerance);
    // The System's constraints, then the frozen distances.
    int numSystem, numFrozen;
    std::vector<std::pair<int, int>> pairs;
    std::vector<double> lengths, targetRates, zeroRates;
    std::vector<OpenMM::Vec3> previousPositions, scratch;
};

} // namespace FlavorPlugin

#endif
