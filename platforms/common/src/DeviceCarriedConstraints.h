#ifndef OPENMM_FLAVORS_DEVICE_CARRIED_CONSTRAINTS_H_
#define OPENMM_FLAVORS_DEVICE_CARRIED_CONSTRAINTS_H_

#include "ConstraintProjector.h"
#include "StepHistory.h"
#include "openmm/System.h"
#include "openmm/common/ComputeArray.h"
#include "openmm/common/ComputeContext.h"
#include "openmm/common/ComputeKernel.h"
#include "openmm/common/ComputeProgram.h"
#include <vector>

namespace FlavorPlugin {

/**
 * The SIM's constraint solves around its stiff flows on the device (kernels/carriedConstraints.cc), with the
 * arithmetic of the host's ConstraintProjector, which computes each pass's carrying (StiffFlowCarrying) and stays the
 * oracle of the tests.  The solves themselves are OpenMM's (IntegrationUtilities) with each carrier's inverse mass
 * set to its solve's for the duration of the solve: this is exact where SETTLE, which reads the masses from the
 * velocities' fourth component, holds every carrier (rigid Drude water: the oxygen core in its water's triangle).
 * Where a carrier is held by SHAKE or CCMA, whose masses are fixed when the Context is made, the host solves them
 * (isActive() false).  Nothing is copied between host and device per step.
 */
class DeviceCarriedConstraints {
public:
    /** program: compiled with kernels/carriedConstraints.cc; slotOf: each particle's atom, current when a pass runs. */
    DeviceCarriedConstraints(OpenMM::ComputeContext& cc, OpenMM::ComputeProgram& program, OpenMM::ComputeArray& slotOf,
                             const OpenMM::System& system);
    /**
     * The constrained particles of stiff components (carriers) and every particle of their components (members):
     * returns whether the device solves them (every carrier a SETTLE atom).
     */
    bool setCarriers(const std::vector<int>& carriers, const std::vector<int>& members);
    bool isActive() const { return active; }
    /** Starts a plan of numPasses passes; carryings come with setCarrying(). */
    void setNumPasses(size_t numPasses);
    /**
     * The carrying of pass p (ConstraintProjector::carryingThrough), uploaded with its kernels; firstOfStep: the first
     * pass of the step that adds to the carriers' impulses.
     */
    void setCarrying(size_t p, const ConstraintProjector::StiffFlowCarrying& carrying, bool firstOfStep);
    /** The kernels of flowPasses.cc that take arguments from here. */
    enum class FlowKernel { StiffFlow, Response, ClosingResponse };
    /**
     * Adds the arguments of a stiff flow, a force response after it, or the closing response of a step's Filtered
     * kick (which readies the carriers for the velocity solve after it) to a kernel of flowPasses.cc: displaced where
     * pass p's constraints are solved here.
     */
    void addFlowArgs(OpenMM::ComputeKernel& kernel, size_t p, bool displaced, FlowKernel kind);
    /** The stiffFlow kernel's argument that takes the last step's processing off (set by fuseTakeOff()). */
    static const int StiffFlowTakeOffArg = 30;
    /**
     * The step's first flow is this stiff flow: it takes the last step's processing off the velocities it reads,
     * where the plan processes any (then takeOffProcessing() launches nothing).  Called after every setCarrying().
     */
    void fuseTakeOff(OpenMM::ComputeKernel& firstStiffFlow);
    /** After pass p's displaced stiff flow: the position solve, and the velocity solve unless projectVelocities is
     * false. */
    void constrainAfterFlow(size_t p, double tolerance, bool projectVelocities);
    /** The velocity solve at the end of pass p (a Filtered kick), after its closing response readied the carriers. */
    void constrainVelocities(size_t p, double tolerance);
    /** Where a step starts: takes the last step's velocity processing off the velocities. */
    void takeOffProcessing();
    /** The velocity processing still on the velocities, in the host's history and back (System order). */
    void downloadProcessing(std::vector<OpenMM::Vec3>& applied) const;
    void uploadProcessing(const std::vector<OpenMM::Vec3>& applied);

private:
    struct PassArrays {
        OpenMM::ComputeArray carriers, motionStart, motionParticle, carrierReals, motionReals;
        OpenMM::ComputeKernel finishPositions, finishVelocities;
        int numPositionMotions = 0;
        bool set = false, process = false, velocitiesFirstOfStep = false;
    };
    OpenMM::ComputeContext& cc;
    OpenMM::ComputeProgram& program;
    OpenMM::ComputeArray& slotOf;
    std::vector<bool> settled;
    std::vector<int> carriers;
    std::vector<double> ownInverseMass;
    std::vector<PassArrays> passes;
    // Per particle: its carried component (carriers) or -1, whether it is a member; per carrier: the step's impulse
    // and its velocity before a velocity solve; per atom: the uncorrected displacement; per particle: the processing.
    OpenMM::ComputeArray carrierOf, carriedMember, stepImpulses, carrierVelocity, uncorrected, applied;
    OpenMM::ComputeKernel takeOffKernel;
    bool active = false, processing = false, takeOffFused = false;
};

} // namespace FlavorPlugin

#endif
