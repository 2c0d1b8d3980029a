#ifndef OPENMM_FLAVORS_FROZEN_DISTANCES_H_
#define OPENMM_FLAVORS_FROZEN_DISTANCES_H_

#include "ParticleFlows.h"
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
 * velocity step, solved by Gauss-Seidel sweeps to the integrator's constraint tolerance, each cluster of coupled
 * constraints on its own through the platform's ParallelLoop.
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
class OPENMM_EXPORT_FLAVORS FrozenDistances : public RangeTask {
public:
    FrozenDistances(const OpenMM::System& system, const std::vector<std::pair<int, int>>& frozenPairs);
    int getNumFrozen() const { return numFrozen; }
    /** The connected components of the constraint graph (a particle without constraints is one of its own). */
    int getNumClusters() const { return (int)particleStart.size() - 1; }
    /** The frozen drift over h, cluster by cluster through loop; throws if SHAKE does not converge. */
    void drift(std::vector<OpenMM::Vec3>& positions, std::vector<OpenMM::Vec3>& velocities,
               const std::vector<double>& inverseMasses, double h, double tolerance, ParallelLoop& loop);
    /** The frozen kick v += h P M^-1 F, cluster by cluster through loop. */
    void kick(std::vector<OpenMM::Vec3>& positions, std::vector<OpenMM::Vec3>& velocities,
              const std::vector<OpenMM::Vec3>& forces, const std::vector<double>& inverseMasses, double h,
              double tolerance, ParallelLoop& loop);
    /** Runs the current drift or kick on clusters [begin, end). */
    void apply(int begin, int end) const override;

private:
    static constexpr int MaxSweeps = 1000;
    void driftCluster(int k) const;
    void kickCluster(int k) const;
    /** SHAKE: moves positions along the constraint directions at previousPositions until every length holds. */
    bool constrainPositions(int k) const;
    /** Sets v so that every constraint's rate is its target (withTargets) or 0. */
    void constrainVelocities(int k, OpenMM::Vec3* v, bool withTargets) const;
    void checkConvergence();
    int numFrozen;
    // Cluster k owns particles[particleStart[k] .. particleStart[k+1]) and constraints
    // [constraintStart[k], constraintStart[k+1]) of pairs, lengths and frozen (1 for a frozen distance, 0 for a
    // System constraint).
    std::vector<int> particles, particleStart, constraintStart;
    std::vector<std::pair<int, int>> pairs;
    std::vector<char> frozen;
    // Written per cluster while the loop runs (each cluster its own entries).
    mutable std::vector<double> lengths, targetRates;
    mutable std::vector<OpenMM::Vec3> previousPositions, scratch;
    mutable std::vector<char> failed;
    // The current call's data.
    OpenMM::Vec3* positions;
    OpenMM::Vec3* velocities;
    const OpenMM::Vec3* forces;
    const double* inverseMasses;
    double h, tolerance;
    bool kicking;
};

} // namespace FlavorPlugin

#endif
