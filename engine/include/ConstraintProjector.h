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
 * A constrained particle of a stiff component (the core of a Drude pair in rigid water) is corrected around a stiff
 * flow as RATTLE corrects around a drift: the position correction is an impulse on that particle alone at the start
 * of the flow, the velocity projection one at its end, and the component's flow carries the impulse to each of its
 * particles (StiffModes::ImpulseResponse: in its stiff modes scaled as a Filtered step scales its kicks, so that a
 * constraint force acts on them as a soft force does).  Through the flow an impulse J moves the constrained particle
 * by X J / m, X its block of the response (h for a free particle), the other particles of its component by their own
 * blocks, and changes their velocities likewise; each solve takes the constrained particle with the inverse mass that
 * its block gives (StiffFlowCarrying).  After a drift or a plain kick an impulse moves no other particle.
 *
 * The solves work on position and velocity vectors in the System's order: the Reference and CPU platforms' own (the
 * ContextImpl overloads, which solve with the platform's solver where no stiff flow is carried), or host copies of a
 * device's state (the common compute platforms; built with ownSolver, the projector holds a solver of the same
 * System).
 */
class OPENMM_EXPORT_FLAVORS ConstraintProjector {
public:
    /** ownSolver: build a solver for the vector overloads (else only the ContextImpl overloads may be called). */
    ConstraintProjector(const OpenMM::System& system, const ParticleTable& particles, bool ownSolver = false);
    ~ConstraintProjector();
    /**
     * How the corrections around one stiff flow move the particles: built for each pass of a stiff flow or a
     * Filtered kick by carryingThrough() from the pass's impulse response.
     */
    struct StiffFlowCarrying {
        /**
         * A particle of a constrained stiff component (carried: the component's index among them; carrier: its
         * constrained particle), moved per unit correction of the carrier (per unit impulse in processing).
         */
        struct Motion {
            int particle, carrier, carried;
            double position[3][3], velocity[3][3];
        };
        /** The impulse on a carrier per unit of its correction. */
        struct Impulse {
            int carrier, carried;
            double perCorrection[3][3];
        };
        /**
         * A solver whose constrained particles of stiff components have their own inverse masses, and the motions of
         * their components; no solver where these are the particles' own (the plain solve).
         */
        struct Solve {
            std::shared_ptr<OpenMM::ReferenceConstraints> solver;
            // OpenMM's solvers take the inverse masses by non-const reference.
            mutable std::vector<double> inverseMasses;
            std::vector<Motion> motions;
            std::vector<Impulse> impulses;
        };
        /** The position correction at the start of the flow and the velocity projection at its end. */
        Solve positions, velocities;
        /** The velocity processing at the end of a step (StiffModes::ImpulseResponse; a Filtered kick's only). */
        std::vector<Motion> processing;
        /** The velocity per unit position correction of every particle outside constrained stiff components. */
        double velocityPerCorrection = 0.0;
    };
    /**
     * Throws unless the projector can correct the stiff components of modes through the System's constraints (a
     * constraint may join a stiff component to particles outside it, at most one particle of each component;
     * rejectConstraintsInsideStiffComponents).
     */
    static void rejectUncarriedConstraints(const OpenMM::ContextImpl& context, const StiffModes& modes);
    /** Finds the constrained particle of each stiff component of modes (none without modes). */
    void setStiffModes(const StiffModes* modes);
    /** The constrained particle of each constrained stiff component of modes (the last set), in carrying order. */
    std::vector<int> getCarriers(const StiffModes& modes) const;
    /** Every particle of the constrained stiff components. */
    const std::vector<int>& getCarriedMembers() const { return carriedMembers; }
    /** Whether a pass of this sub-flow has a carrying: a StiffFlow, HarmonicFlow, FilteredStiffFlow or FilteredKick. */
    static bool hasCarrying(const SubFlow& flow);
    /**
     * The carrying of a sub-flow that has one (hasCarrying) over the modes last set (its flow as StiffFlowExecutor
     * computes it).  Throws if the step would move a constrained particle against an impulse on it.
     */
    StiffFlowCarrying carryingThrough(const StiffModes& modes, const SubFlow& flow);
    /** Remembers the positions a move starts from, the reference of the next constrainPositions(). */
    void rememberPositions(const std::vector<OpenMM::Vec3>& positions) { reference = positions; }
    const std::vector<OpenMM::Vec3>& getReferencePositions() const { return reference; }
    /**
     * Constrains the Context's positions against the remembered ones.  After a stiff flow (carrying not null) the
     * correction also moves the other particles of constrained stiff components and changes all velocities.
     */
    void constrainPositions(OpenMM::ContextImpl& context, double tolerance,
                            const StiffFlowCarrying* carrying = nullptr);
    /**
     * The same on positions and velocities in the System's order, with the projector's own solver (ownSolver) where
     * carrying is null; velocities are changed only with carrying.
     */
    void constrainPositions(std::vector<OpenMM::Vec3>& positions, std::vector<OpenMM::Vec3>& velocities,
                            double tolerance, const StiffFlowCarrying* carrying = nullptr);
    /** A step starts: forgets the constraint impulses so far. */
    void startStep();
    /** Whether the last step's velocity processing (applied) is still on the velocities. */
    bool hasProcessing(const std::vector<OpenMM::Vec3>& applied) const;
    /** Takes the last step's velocity processing (applied, which is zeroed) off the velocities. */
    void takeOffProcessing(std::vector<OpenMM::Vec3>& velocities, std::vector<OpenMM::Vec3>& applied) const;
    /**
     * The step ends with the carrying's Filtered kick: adds its velocity processing of the step's constraint impulses
     * to velocities and to applied.
     */
    void processVelocities(std::vector<OpenMM::Vec3>& velocities, const StiffFlowCarrying& carrying,
                           std::vector<OpenMM::Vec3>& applied) const;
    /** Projects the Context's velocities onto the constraints; at the end of a stiff flow with its carrying. */
    void constrainVelocities(OpenMM::ContextImpl& context, double tolerance,
                             const StiffFlowCarrying* carrying = nullptr);
    /** The same on velocities at positions in the System's order, with the projector's own solver (ownSolver). */
    void constrainVelocities(std::vector<OpenMM::Vec3>& positions, std::vector<OpenMM::Vec3>& velocities,
                             double tolerance, const StiffFlowCarrying* carrying = nullptr);

private:
    /**
     * How a constraint correction after a stiff flow, an impulse at the start of the flow in a zero mode, changes the
     * velocities (velocity: per unit correction) and how much impulse it is (impulse: per unit correction and mass).
     */
    struct CorrectionScales {
        double velocity = 0.0, impulse = 0.0;
    };
    static CorrectionScales stiffFlowScales(const SubFlow& flow);
    /** The solver of a solve (plain, with the particles' own masses, where it has none) and its inverse masses. */
    std::pair<OpenMM::ReferenceConstraints*, std::vector<double>*> solverOf(const StiffFlowCarrying::Solve* solve,
                                                                            OpenMM::ReferenceConstraints& plain);
    /** The solves; plain: the solver with the particles' own masses. */
    void solvePositions(OpenMM::ReferenceConstraints& plain, std::vector<OpenMM::Vec3>& positions,
                        std::vector<OpenMM::Vec3>& velocities, double tolerance, const StiffFlowCarrying* carrying);
    void solveVelocities(OpenMM::ReferenceConstraints& plain, std::vector<OpenMM::Vec3>& positions,
                         std::vector<OpenMM::Vec3>& velocities, double tolerance, const StiffFlowCarrying* carrying);
    /**
     * Adds the carriers' impulses of a solve to the step's, then moves the other particles of constrained stiff
     * components by their motions per correction (now - before).
     */
    void moveCarried(const StiffFlowCarrying::Solve& solve, const std::vector<OpenMM::Vec3>& now,
                     const std::vector<OpenMM::Vec3>& before, std::vector<OpenMM::Vec3>* positions,
                     std::vector<OpenMM::Vec3>& velocities);
    /** A solve of constraintSystem with the given inverse masses (its masses restored after). */
    std::shared_ptr<OpenMM::ReferenceConstraints> solverWith(const std::vector<double>& inverseMasses);
    OpenMM::ReferenceConstraints& ownConstraints();
    const ParticleTable& particles;
    // OpenMM's solvers take the inverse masses by non-const reference.
    std::vector<double> inverseMasses;
    std::vector<OpenMM::Vec3> reference;
    // The System's particles and constraints (and angles, which CCMA uses), from which the solver of each stiff flow
    // is built with its constrained particles' masses.
    std::unique_ptr<OpenMM::System> constraintSystem;
    // With ownSolver: the solver of constraintSystem with the particles' own masses.
    std::unique_ptr<OpenMM::ReferenceConstraints> solver;
    // Per constrained stiff component: the component and its constrained particle's index in it, and the impulse on
    // that particle so far in this step; the particles of these components; room for all positions or velocities
    // before a solve.
    std::vector<std::pair<int, int>> carriedComponents;
    std::vector<OpenMM::Vec3> stepImpulses;
    std::vector<int> carriedMembers;
    std::vector<OpenMM::Vec3> uncorrected;
};

} // namespace FlavorPlugin

#endif
