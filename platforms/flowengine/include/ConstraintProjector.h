#ifndef OPENMM_FLAVORS_CONSTRAINT_PROJECTOR_H_
#define OPENMM_FLAVORS_CONSTRAINT_PROJECTOR_H_

#include "ParticleTable.h"
#include "StiffModes.h"
#include "internal/FlowSchedule.h"
#include "internal/windowsExportFlavors.h"
#include "openmm/System.h"
#include "openmm/Vec3.h"
#include <memory>
#include <utility>
#include <vector>

namespace OpenMM {
class ContextImpl;
class ReferenceConstraints;
} // namespace OpenMM

namespace FlavorPlugin {

/**
 * The System's constraints, applied as OpenMM's VerletIntegrator applies them: positions against the positions a
 * move started from (with the velocity set to the constrained displacement by the caller), velocities by projection.
 *
 * A constrained particle of a stiff component (the core of a Drude pair in rigid water) carries its component through
 * the constraint solve: it enters the solve with the inverse of its component's total mass, and every other particle
 * of the component moves by the correction of its carrier, so the component's internal (stiff) coordinates are left
 * exactly as the stiff flow made them.  The true constraint force acts on the carrier alone, and a share of it (its
 * carried particles' mass over the component's) moves the internal coordinates; takeShares() turns the constraint
 * impulses of a step into that share, as a soft force pair (on each carried particle and, opposite, on its carrier)
 * for the next step's kicks.
 *
 * The solves work on position and velocity vectors in the System's order: the Reference and CPU platforms' own (the
 * ContextImpl overloads, which solve constraints outside carried components with the platform's solver), or host
 * copies of a device's state (the common compute platforms; built with ownSolver, the projector holds a solver of
 * the same System).
 */
class OPENMM_EXPORT_FLAVORS ConstraintProjector {
public:
    /** ownSolver: build a solver for the vector overloads (else only the ContextImpl overloads may be called). */
    ConstraintProjector(const OpenMM::System& system, const ParticleTable& particles, bool ownSolver = false);
    ~ConstraintProjector();
    /**
     * How a stiff flow's constraint correction, an impulse at the start of the flow in a zero mode, changes the
     * velocities (velocity: per unit correction) and how much impulse it is (impulse: per unit correction and mass).
     */
    struct CorrectionScales {
        double velocity = 0.0, impulse = 0.0;
    };
    static CorrectionScales stiffFlowScales(const SubFlow& flow);
    /**
     * Throws unless the projector can carry the stiff components of modes through the System's constraints (a
     * constraint may join a stiff component to particles outside it, at most one particle of each component;
     * rejectConstraintsInsideStiffComponents).
     */
    static void rejectUncarriedConstraints(const OpenMM::ContextImpl& context, const StiffModes& modes);
    /** Finds the carriers of the stiff components of modes (none without modes). */
    void setStiffModes(const StiffModes* modes);
    /** The carried particles and their carriers, each once (whose share forces the next step's kicks add). */
    const std::vector<int>& getShareParticles() const { return shareParticles; }
    /** Remembers the positions a move starts from, the reference of the next constrainPositions(). */
    void rememberPositions(const std::vector<OpenMM::Vec3>& positions) { reference = positions; }
    const std::vector<OpenMM::Vec3>& getReferencePositions() const { return reference; }
    /**
     * Constrains the Context's positions against the remembered ones, carrying stiff components.  A carrier's
     * correction, times its component's mass and impulsePerCorrection (the impulse per unit correction), adds to its
     * constraint impulse of this step.
     */
    void constrainPositions(OpenMM::ContextImpl& context, double tolerance, double impulsePerCorrection);
    /** The same on positions in the System's order, with the projector's own solver (ownSolver). */
    void constrainPositions(std::vector<OpenMM::Vec3>& positions, double tolerance, double impulsePerCorrection);
    /** Projects the Context's velocities onto the constraints, carrying stiff components. */
    void constrainVelocities(OpenMM::ContextImpl& context, double tolerance);
    /** The same on velocities at positions in the System's order, with the projector's own solver (ownSolver). */
    void constrainVelocities(std::vector<OpenMM::Vec3>& positions, std::vector<OpenMM::Vec3>& velocities,
                             double tolerance);
    /**
     * Turns the constraint impulses of a step of length stepSize into the share forces of the next step (written for
     * the share particles) and resets them.
     */
    void takeShares(double stepSize, std::vector<OpenMM::Vec3>& shareForces);

private:
    /** The solves; solver: the one for a System without carried components. */
    void solvePositions(OpenMM::ReferenceConstraints& solver, std::vector<OpenMM::Vec3>& positions, double tolerance,
                        double impulsePerCorrection);
    void solveVelocities(OpenMM::ReferenceConstraints& solver, std::vector<OpenMM::Vec3>& positions,
                         std::vector<OpenMM::Vec3>& velocities, double tolerance);
    OpenMM::ReferenceConstraints& ownConstraints();
    /** Adds each carrier's correction (now minus carrierBefore) times its mass and scale to its step's impulse. */
    void addCarrierImpulses(const std::vector<OpenMM::Vec3>& corrected, double impulsePerCorrection);
    const ParticleTable& particles;
    // OpenMM's solvers take the inverse masses by non-const reference.
    std::vector<double> inverseMasses;
    std::vector<OpenMM::Vec3> reference;
    // The System's particles and constraints (and angles, which CCMA uses), from which the solver of carried
    // constraints is built with each carrier's mass replaced by its component's.
    std::unique_ptr<OpenMM::System> constraintSystem;
    // With ownSolver: the solver of constraintSystem with the particles' own masses.
    std::unique_ptr<OpenMM::ReferenceConstraints> solver;
    // When stiff components are constrained: the solver with carrier masses, its inverse masses, the (carried,
    // carrier) particle pairs and room for each carrier's coordinates before the solve.
    std::unique_ptr<OpenMM::ReferenceConstraints> carriedConstraints;
    std::vector<double> carriedInverseMasses;
    std::vector<std::pair<int, int>> carriedParticles;
    std::vector<OpenMM::Vec3> carrierBefore;
    // Per carried pair: its carrier's constraint impulse so far in this step.
    std::vector<OpenMM::Vec3> carrierImpulses;
    std::vector<int> shareParticles;
};

} // namespace FlavorPlugin

#endif
