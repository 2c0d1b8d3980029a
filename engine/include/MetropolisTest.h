#ifndef OPENMM_FLAVORS_METROPOLIS_TEST_H_
#define OPENMM_FLAVORS_METROPOLIS_TEST_H_

#include "FlowCheckpoint.h"
#include "internal/FlowSchedule.h"
#include "internal/windowsExportFlavors.h"
#include <vector>

namespace FlavorPlugin {

/**
 * The Metropolis adjustment's accept test, the same on every platform: the energy where a proposal starts (its
 * potential known from the last accepted proposal unless the state changed from outside), the test of the energy
 * change against a uniform number of the step's stream, and the counts.  The platforms' executors evaluate the
 * energies, keep the start state and put it back, velocities reversed, where a proposal is rejected.
 */
class OPENMM_EXPORT_FLAVORS MetropolisTest {
public:
    /** Which of the plan's force slots are evaluated with their energy (none without a proposal). */
    static std::vector<bool> energySlots(const StepPlan& plan);
    /** The integrated groups of the plan's proposal that no energy slot covers (evaluated on their own). */
    static int groupsWithoutEnergySlot(const StepPlan& plan);
    /** Whether the start needs the potential energy (it does unless the last test left it). */
    bool needsStartPotential() const { return !energyKnown; }
    /** A proposal starts with these energies (potential ignored unless needsStartPotential()). */
    void start(double potential, double kinetic);
    /**
     * Tests a proposal that ends with these energies at temperature kT with a uniform number in (0, 1): returns
     * whether it is accepted.  A NaN energy (a proposal that blew up) is rejected.
     */
    bool test(double potential, double kinetic, double uniform, double kT);
    /** The state changed from outside (positions, parameters, a checkpoint): the next start evaluates its energy. */
    void forgetEnergy() { energyKnown = false; }
    const ProposalCounts& getCounts() const { return counts; }
    void setCounts(const ProposalCounts& stored) { counts = stored; }

private:
    double startPotential = 0.0, startKinetic = 0.0;
    bool energyKnown = false;
    ProposalCounts counts;
};

} // namespace FlavorPlugin

#endif
