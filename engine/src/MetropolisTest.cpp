#include "MetropolisTest.h"
#include <cmath>

using namespace FlavorPlugin;
using std::vector;

namespace {

/** The integrated groups of the plan's proposal, or 0 without one. */
int proposalGroups(const StepPlan& plan) {
    for (const FlowPass& pass : plan.passes)
        if (pass.flows[0].kind == SubFlow::ProposalTest)
            return pass.flows[0].groups;
    return 0;
}

} // namespace

vector<bool> MetropolisTest::energySlots(const StepPlan& plan) {
    // Slots whose groups lie inside what is still uncovered, first come first taken: for a FLAVOR the slot of all
    // groups (its closing kick), for a SIM the soft one.
    int uncovered = proposalGroups(plan);
    vector<bool> withEnergy(plan.slotGroups.size(), false);
    for (size_t s = 0; s < plan.slotGroups.size(); ++s)
        if (uncovered != 0 && (plan.slotGroups[s] & ~uncovered) == 0) {
            withEnergy[s] = true;
            uncovered &= ~plan.slotGroups[s];
        }
    return withEnergy;
}

int MetropolisTest::groupsWithoutEnergySlot(const StepPlan& plan) {
    int groups = proposalGroups(plan);
    const vector<bool> withEnergy = energySlots(plan);
    for (size_t s = 0; s < withEnergy.size(); ++s)
        if (withEnergy[s])
            groups &= ~plan.slotGroups[s];
    return groups;
}

void MetropolisTest::start(double potential, double kinetic) {
    if (!energyKnown)
        startPotential = potential;
    startKinetic = kinetic;
}

bool MetropolisTest::test(double potential, double kinetic, double uniform, double kT) {
    const double change = (potential + kinetic) - (startPotential + startKinetic);
    const bool accepted = change <= 0.0 || uniform < std::exp(-change / kT);
    counts.proposed++;
    if (accepted) {
        counts.accepted++;
        startPotential = potential;
    }
    energyKnown = true;
    return accepted;
}
