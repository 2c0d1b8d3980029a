// FlavorIntegrator::describeContext() and StochasticImpulseIntegrator::describeContext(): how an integrator treats the
// Context it is bound to, in words, for a user checking a set-up before a long run.
#include "FlavorIntegrator.h"
#include "FlavorKernels.h"
#include "StochasticImpulseIntegrator.h"
#include "internal/FlowSchedule.h"
#include "internal/ParameterChecks.h"
#include "internal/StiffGroupChecks.h"
#include "openmm/Force.h"
#include "openmm/OpenMMException.h"
#include "openmm/System.h"
#include "openmm/internal/ContextImpl.h"
#include <algorithm>
#include <cmath>
#include <sstream>

using namespace FlavorPlugin;
using namespace OpenMM;
using std::string;

namespace {

/** One line per force: its index, class, group and whether it is stiff, soft or not integrated. */
string describeForces(const System& system, int stiffGroups, int integrationGroups) {
    string text = "forces:\n";
    for (int f = 0; f < system.getNumForces(); ++f) {
        const int group = 1 << system.getForce(f).getForceGroup();
        const char* role = (group & integrationGroups) == 0 ? "not integrated"
                           : (group & stiffGroups) != 0     ? "stiff"
                                                            : "soft";
        text += "  " + describeForce(system, f) + ": " + role + "\n";
    }
    return text;
}

void requireBound(const ContextImpl* context, const string& owner) {
    if (context == nullptr)
        throw OpenMMException(owner + ": describeContext() needs the integrator to be bound to a Context");
}

} // namespace

string FlavorIntegrator::describeContext() const {
    requireBound(context, "FlavorIntegrator");
    string text = "FlavorIntegrator, mesostep δ = " + formatFemtoseconds(getMesoStep()) +
                  ", microstep τ = " + formatFemtoseconds(microStep) + "\nstep: " + describeStep() + "\n" +
                  describeForces(context->getSystem(), stiffGroups, getIntegrationForceGroups());
    if (averaging == Nonintrusive)
        return text + "frozen: nothing (the nonintrusive averaging weakens the stiff forces by τ/δ instead)\n";
    const int numFrozen = stepKernel->getNumFrozen();
    switch ((SubFlow::FrozenSet)stepKernel->getFrozenSet()) {
    case SubFlow::FrozenSet::Distances:
        return text + "frozen: " + std::to_string(numFrozen) + " distances of the stiff bonded forces\n";
    case SubFlow::FrozenSet::StiffModes:
        return text + "frozen: the " + std::to_string(numFrozen) + " stiff modes of the quadratic stiff groups\n";
    default:
        return text + "frozen: measured when the first step starts\n";
    }
}

string StochasticImpulseIntegrator::describeContext() {
    requireBound(context, "StochasticImpulseIntegrator");
    string text = "StochasticImpulseIntegrator, step H = " + formatFemtoseconds(getStepSize()) +
                  "\nstep: " + describeStep() + "\n" +
                  describeForces(context->getSystem(), stiffGroups, getIntegrationForceGroups());
    const std::vector<double> omega = getStiffModeFrequencies();
    std::vector<double> stiff;
    std::copy_if(omega.begin(), omega.end(), std::back_inserter(stiff), [](double w) { return w > 0.0; });
    if (stiff.empty())
        return text + "stiff modes: none\n";
    const double H = getStepSize();
    std::ostringstream modes;
    modes.precision(4);
    modes << "stiff modes: " << stiff.size() << ", ω from " << stiff.front() << " to " << stiff.back()
          << " /ps, ωH from " << stiff.front() * H / M_PI << "π to " << stiff.back() * H / M_PI << "π\n";
    const std::vector<double> choice = stepKernel->getWarpedPhaseChoice(*context, *this, binding.stiffModesValid);
    if (!choice.empty()) {
        modes << "Warped phase limit chosen here (setMaxWarpedPhase(0)): ";
        if (choice[0] < M_PI)
            modes << choice[0] << " rad";
        else
            modes << "none";
        modes << ", for a soft stiffness along the stiff modes of up to " << choice[1]
              << " times their own (measured in " << choice[2] << " s; stable while (1 + r) sin²(ω̃H/2) < 1)\n";
    }
    return text + modes.str();
}
