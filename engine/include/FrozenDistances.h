#ifndef OPENMM_FLAVORS_FROZEN_DISTANCES_H_
#define OPENMM_FLAVORS_FROZEN_DISTANCES_H_

#include "ParticleFlows.h"
#include "SparseLDLT.h"
#include "internal/windowsExportFlavors.h"
#include "openmm/System.h"
#include "openmm/Vec3.h"
#include <array>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace OpenMM {
class ContextImpl;
class ReferenceConstraints;
} // namespace OpenMM

namespace FlavorPlugin {

/**
 * The 1-3 distances that hold the angles (i, centre, j) rigid without redundancy.  A centre with k bonded neighbours
 * and its bonds are held rigid by 2k - 3 1-3 distances (3(k + 1) - 6 degrees of freedom); every further one is
 * linearly dependent on them.  With the neighbours n0, n1, ... in order of first appearance, the distances (n0, n1),
 * (n0, ni) and (n1, ni) for i >= 2 are kept; at k = 3 only (n0, n1) and (n0, n2): such centres are planar in most
 * molecules (sp2 carbons and nitrogens), where the third distance is dependent on the others too.  The distances
 * dropped change only at second order in the motions the others allow.
 */
OPENMM_EXPORT_FLAVORS std::vector<std::pair<int, int>>
nonredundantAngleDistances(const std::vector<std::array<int, 3>>& angles);

/**
 * The distances that the stiff bonded forces of groups stiffGroups act on: each bond of a HarmonicBondForce (force
 * constant nonzero) or CustomBondForce, the 1-3 distances of the angles of the HarmonicAngleForces with a nonzero
 * force constant (nonredundantAngleDistances), then the extra pairs, without repeats.  Stiff forces of other types are
 * described in unsupported (one entry per force: its index and type).
 */
OPENMM_EXPORT_FLAVORS std::vector<std::pair<int, int>> bondedFrozenPairs(const OpenMM::ContextImpl& context,
                                                                         int stiffGroups,
                                                                         const std::vector<std::pair<int, int>>& extra,
                                                                         std::vector<std::string>& unsupported);

/**
 * An off-diagonal entry of B = J M^-1 J^T: two constraints (indices into a list of pairs) sharing a particle, and the
 * sign of the product of their directions there (+1 if the particle is the same end of both).
 */
struct ConstraintCoupling {
    int first, second, particle;
    double sign;
};

/**
 * Which of the constraints pairs (the System's first, then frozen distances; most important first) to keep: row c of
 * B = J M^-1 J^T (J: the unit directions at positions) is eliminated in order, and a frozen distance whose pivot is at
 * most threshold times its diagonal entry (the squared sine of the angle between its direction and the span of those
 * kept before it, in the mass metric) is left out.  Nearly planar rings and centres make whole sets of 1-3
 * distances nearly dependent; keeping them would make B so ill conditioned that no iteration holds them.
 */
OPENMM_EXPORT_FLAVORS std::vector<char> independentConstraints(const std::vector<std::pair<int, int>>& pairs,
                                                               const std::vector<char>& frozen,
                                                               const std::vector<double>& inverseMasses,
                                                               const std::vector<OpenMM::Vec3>& positions,
                                                               double threshold);

/**
 * FrozenDistances' clusters laid out for a device that solves each cluster in one work-item (the common compute
 * platforms' frozen stage), with fixed strides: MaxParticles entries per cluster in particles, 2 MaxConstraints in ends
 * and MaxConstraints in order.
 */
struct SmallClusterTable {
    static constexpr int MaxParticles = 5, MaxConstraints = SparseLDLT::MaxDense;
    /** Per cluster: its particles (System indices, -1 past the last). */
    std::vector<int> particles;
    /** Per cluster: each constraint's two ends as indices into its particles (-1 past the last constraint). */
    std::vector<int> ends;
    /** Per cluster: the constraint eliminated k-th in factorizing B (SparseLDLT's order). */
    std::vector<int> order;
    /** Per cluster: the number of particles, of constraints, and 1 if it holds its normal momenta; then a 0. */
    std::vector<int> counts;
    /** The particles with mass in no cluster and under no constraint: their drift and kick are free. */
    std::vector<int> freeParticles;
};

/**
 * The frozen drift and kick of the artificial FLAVOR for stiff bonded forces: the frozen distances are held as
 * temporary constraints next to the System's own (which stay on throughout), each cluster of coupled constraints on
 * its own through the platform's ParallelLoop.
 *
 *     drift(h):  split each velocity into its part tangent to the constraint manifold and its normal part
 *                M^-1 J^T mu, mu = B^-1 (0, rdot) (rdot: the rates of the frozen distances, 0 for the System's
 *                constraints); keep the frozen distances' entries of mu (their normal momenta) and drift the tangent
 *                part with every constraint held, by RATTLE steps of the Hamiltonian |p_T|^2 / 2 + mu^T B(q) mu / 2 on
 *                the manifold; then give the normal part back along the new directions with the same momenta (the
 *                System's entries chosen so that their rates stay 0).  Freezing the momenta, not the rates, and the
 *                force of mu^T B(q) mu / 2 keep phase-space volume and energy where B changes (turning torsions turn
 *                the angles between constraints that share an atom): this frozen drift leaves the canonical
 *                distribution of the flexible molecule invariant.  Where B is constant (water, a rigid triangle) the
 *                force is 0 and the rates come back unchanged.
 *     kick(h):   v += h P M^-1 F, with P the same projection (the soft impulse's component along the frozen
 *                distances and the System's constraints dropped).
 *
 * Each cluster is solved as a whole, not constraint by constraint: a protein with its angles frozen is one cluster of
 * well over a thousand coupled distances, where Gauss-Seidel sweeps (SHAKE) converge far too slowly.  The matrix
 * B = J M^-1 J^T of the cluster (J: the unit constraint directions) is factorized (SparseLDLT) where a drift starts
 * and after each of its RATTLE steps; positions follow Newton's iteration with B from the start of the step (the
 * corrections along the directions there, as in SHAKE), velocities one solve with B where they are (refinement if B
 * is from elsewhere), both to the integrator's constraint tolerance.  If Newton's iteration does not converge, the
 * drift is repeated from its start in 2, 4, ... 16 RATTLE steps, each turning the directions less.  Frozen distances
 * that are nearly dependent on the System's constraints and the frozen distances before them are left out at
 * construction (independentConstraints), so B stays well conditioned; rows that become exactly dependent later are
 * recognised by their pivots and dropped.
 *
 * Rigid clusters, whose constraints fix every distance among their particles (a flexible water molecule with its
 * O-H bonds and H-H distance frozen: 3 particles, 3 independent constraints; in general 3n - 6 for n >= 3 particles,
 * 1 for 2), take a shortcut with the same drift.  Their B, whose entries w (u_c . u_d) depend only on the angles
 * between the constraint directions, is the same everywhere on their manifold: it is factorized where the drift
 * starts (the microsteps between drifts change the shape) and kept through the RATTLE steps, where only the unit
 * directions follow the positions; and the force of mu^T B(q) mu / 2, being normal to the manifold, is left out, as
 * the position and velocity projections that follow each of its kicks would take away what it adds; its kick
 * factorizes where it is (the drift's B is from the drift's start), so that the steps do not depend on where a
 * factorization was made.  The results agree with the general path to the constraint tolerance.  The shortcut is taken
 * where the last factorization found that many independent rows and the System's constraints of the cluster hold where
 * the drift starts (else the drift changes the shape).  Small clusters (up to SparseLDLT::MaxDense constraints) are
 * factorized and solved on dense arrays by SparseLDLT, with the same elimination and the same test for dependent rows.
 *
 * Clusters without a frozen distance (rigid water, molecules with only their own constraints, free particles) need
 * none of this: their drift is OpenMM's constrained drift and their kick OpenMM's projected kick, so they go through
 * the platform's constraint algorithms (SETTLE for water, CCMA otherwise), as in OpenMM's own integrators.
 *
 * All buffers are sized at construction; the steps do not allocate.
 */
class OPENMM_EXPORT_FLAVORS FrozenDistances : public RangeTask {
public:
    /**
     * @param frozenPairs  the distances to freeze, most important first
     * @param positions    where the set is checked for dependence: a frozen distance whose direction is (nearly) a
     *                     combination of the System's constraints and the frozen distances before it is left out
     *                     (it stays as it is to first order while the others hold); see independentConstraints()
     */
    FrozenDistances(const OpenMM::System& system, const std::vector<std::pair<int, int>>& frozenPairs,
                    const std::vector<OpenMM::Vec3>& positions);
    ~FrozenDistances();
    /** The frozen distances held (those of the constructor less the System's constraints and the dependent ones). */
    int getNumFrozen() const { return numFrozen; }
    /** The connected components of the constraint graph that hold a frozen distance (solved by the cluster solver). */
    int getNumClusters() const { return (int)particleStart.size() - 1; }
    /**
     * The frozen drift over h, cluster by cluster through loop; throws if the constraints cannot be held.
     * projectOthers: whether the velocities of the clusters without frozen distances end projected onto their
     * constraints; false leaves their drift's chord velocities, for a caller whose next flows project them anyway.
     */
    void drift(std::vector<OpenMM::Vec3>& positions, std::vector<OpenMM::Vec3>& velocities,
               const std::vector<double>& inverseMasses, double h, double tolerance, bool projectOthers,
               ParallelLoop& loop);
    /**
     * The frozen kick v += h P M^-1 F, cluster by cluster through loop; throws if the projection does not converge.
     * projectOthers: as for drift(); false leaves the kick of the clusters without frozen distances unprojected.
     */
    void kick(std::vector<OpenMM::Vec3>& positions, std::vector<OpenMM::Vec3>& velocities,
              const std::vector<OpenMM::Vec3>& forces, const std::vector<double>& inverseMasses, double h,
              double tolerance, bool projectOthers, ParallelLoop& loop);
    /**
     * Whether rigid clusters take their shortcut (the default): B factorized where the drift starts only, and no
     * kicks by the force of the normal momenta, which is normal to their manifold.  false treats them as any other
     * cluster; the two drifts agree to the constraint tolerance (tests compare them).
     */
    void setRigidShortcut(bool use) { rigidShortcut = use; }
    /**
     * Lays the clusters out for a device solver, if they all fit it: no System constraint in the System, at most
     * SmallClusterTable::MaxConstraints constraints (dense B) and MaxParticles particles per cluster, rigid shortcut
     * on. Returns false (table unchanged) otherwise.
     */
    bool describeSmallClusters(SmallClusterTable& table) const;
    /** The exception's message where the frozen distances could not be held to tolerance. */
    static std::string unstableMessage(double tolerance);
    /**
     * Forgets every cluster's factorization: the next drift or kick factorizes where it starts, as the first one does.
     * Called when the Context's state is set from outside (positions, velocities, a checkpoint), so that what follows
     * does not depend on where the Context was before.
     */
    void forgetFactorizations();
    /** Runs the current drift or kick on items [begin, end): the clusters, then the chunks of the other clusters. */
    void apply(int begin, int end) const override;
    int minItemsPerThread() const override { return minItems; }
    bool unevenItems() const override { return true; }

private:
    struct OtherChunk;
    static constexpr int MaxIterations = 100;
    static constexpr int ChunkParticles = 512;
    static constexpr int MaxSubsteps = 16;
    static constexpr double MaxRelativeViolation = 0.1;
    static constexpr double DependenceThreshold = 1e-2;
    // A pivot this small relative to its diagonal is a direction already spanned by the rows before it.
    static constexpr double DependentPivot = 1e-10;
    // A cluster holds its normal momenta if every pivot of its B is at least this fraction of its diagonal where the
    // set is chosen; nearly dependent sets (planar rings) have momenta B^-1 rdot so large that their force
    // -grad mu^T B(q) mu / 2 makes the drift unstable, and give back their rates instead.
    static constexpr double MomentumConditioning = 0.02;
    void run(std::vector<OpenMM::Vec3>& positions, std::vector<OpenMM::Vec3>& velocities,
             const std::vector<OpenMM::Vec3>* forces, const std::vector<double>& inverseMasses, double h,
             double tolerance, bool kicking, bool projectOthers, ParallelLoop& loop);
    /** The drift or kick of a chunk of clusters without frozen distances, by the platform's constraint algorithms. */
    void moveOtherChunk(const OtherChunk& chunk) const;
    void driftCluster(int k) const;
    /** The frozen drift of cluster k over h as substeps RATTLE steps; false if an iteration did not converge. */
    bool driftInSubsteps(int k, int substeps) const;
    /** (1/2) rdot^T mu: the kinetic energy of the stored rates, with mu as last stored. */
    double normalKineticEnergy(int k) const;
    /** The normal momenta mu = B^-1 (0, rdot) of cluster k from the stored rates, B as last factorized. */
    void storeNormalMomenta(int k) const;
    /** Whether a frozen distance of cluster k has a nonzero normal momentum. */
    bool hasNormalMomenta(int k) const;
    /** The System constraints' entries of mu at the current directions, so that their rates stay 0. */
    void updateSystemMomenta(int k) const;
    /** v += dt M^-1 F with F = -grad (1/2) mu^T B(q) mu at fixed mu, the directions as last factorized. */
    void kickByNormalMomenta(int k, double dt) const;
    void kickCluster(int k) const;
    /** x_i += w_i u_c a_c, x_j -= w_j u_c a_c for each constraint c = (i, j) of cluster k (a numbered from its first).
     */
    void addAlongConstraints(int k, OpenMM::Vec3* x, const OpenMM::Vec3* u, const double* a) const;
    /** The same for the constraints [first, last) (a numbered from first), each amount times factor. */
    void addAlongConstraints(int first, int last, OpenMM::Vec3* x, const OpenMM::Vec3* u, const double* a,
                             double factor = 1.0) const;
    /**
     * Factorizes B of cluster k at the current positions and stores the unit directions it was built from; notes
     * whether the cluster is rigid there.
     */
    void factorize(int k) const;
    /** Stores the unit directions of cluster k's constraints at the current positions, B as it was (rigid clusters). */
    void storeDirections(int k) const;
    /**
     * Whether cluster k keeps its shape through a drift from here: rigid where last factorized, with its System
     * constraints at their lengths (the frozen distances are held where the drift starts).
     */
    bool keepsShape(int k) const;
    /** Whether cluster k's last factorization was at exactly the current positions. */
    bool factorizedHere(int k) const;
    /**
     * Assembles into solver B of cluster k's constraints [constraintStart[k], last) with the first numCouplings of
     * its couplings, at positions q with inverse masses w, stores their unit directions and factorizes it; returns
     * the number of rows found dependent.
     */
    int factorizeB(SparseLDLT& solver, int k, int last, int numCouplings, const OpenMM::Vec3* q, const double* w) const;
    /** Newton's iteration with the factorized B: moves positions along the stored directions until every length
     * holds. */
    bool constrainPositions(int k) const;
    /**
     * Sets v so that every constraint's rate along its current direction is 0.  directionsHere: the stored directions
     * are those at the current positions (a factorization or storeDirections() since the positions last moved), so
     * they need not be computed again.
     */
    bool constrainVelocities(int k, OpenMM::Vec3* v, int maxIterations, bool directionsHere = false) const;
    /**
     * constrainVelocities with the factorization at hand, then, if that does not converge soon, with B from here.
     * directionsHere: the factorization at hand is at the current positions (its directions are those here).
     */
    bool constrainVelocitiesRefactorizing(int k, OpenMM::Vec3* v, bool directionsHere) const;
    void checkConvergence();
    int numFrozen;
    // Cluster k owns particles[particleStart[k] .. particleStart[k+1]) and constraints
    // [constraintStart[k], constraintStart[k+1]) of pairs, lengths and frozen (1 for a frozen distance, 0 for a
    // System constraint).
    std::vector<int> particles, particleStart, constraintStart;
    std::vector<std::pair<int, int>> pairs;
    std::vector<char> frozen;
    // The off-diagonal entries of each cluster's B, [couplingStart[k], couplingStart[k+1]) (global constraint
    // indices).
    std::vector<ConstraintCoupling> couplings;
    std::vector<int> couplingStart;
    mutable std::vector<SparseLDLT> solvers;
    // B of each cluster's System constraints (size 0 where it has none): its first systemCount[k] constraints and
    // first systemCouplingCount[k] couplings.
    mutable std::vector<SparseLDLT> systemSolvers;
    std::vector<int> systemCount, systemCouplingCount;
    std::vector<char> holdsMomenta;
    // The number of independent constraints that fix every distance among a cluster's particles (1 for 2 particles,
    // 3n - 6 for n >= 3), and whether its last factorization found that many (B then stays what it is along the
    // drift).
    std::vector<int> rigidRank;
    mutable std::vector<char> rigid;
    bool rigidShortcut = true;
    // Written per cluster while the loop runs (each cluster its own entries).  normalMomenta: mu of the drift.
    mutable std::vector<double> lengths, targetRates, residuals, normalMomenta;
    // directions: the unit constraint directions of the last factorization; currentDirections: of the last velocity
    // solve.
    mutable std::vector<OpenMM::Vec3> directions, currentDirections, previousPositions, startPositions, startVelocities,
        scratch, normalVelocities;
    mutable std::vector<char> factorized;
    // The positions of each cluster's particles where it was last factorized: a drift that starts there keeps B.
    mutable std::vector<OpenMM::Vec3> factorizedPositions;
    mutable std::vector<char> failed;
    /** Clusters without a frozen distance: their particles without constraints, those with, and their constraints. */
    struct OtherChunk {
        std::vector<int> freeParticles, constrainedParticles;
        std::unique_ptr<OpenMM::ReferenceConstraints> constraints;
    };
    std::vector<OtherChunk> otherChunks;
    // The platform's constraint algorithms take non-const inverse masses.
    mutable std::vector<double> systemInverseMasses;
    int minItems;
    // The current call's data.
    std::vector<OpenMM::Vec3>* positionVector;
    std::vector<OpenMM::Vec3>* velocityVector;
    OpenMM::Vec3* positions;
    OpenMM::Vec3* velocities;
    const OpenMM::Vec3* forces;
    const double* inverseMasses;
    double h, tolerance;
    bool kicking, projectOthers;
};

} // namespace FlavorPlugin

#endif
