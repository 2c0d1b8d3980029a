#include "internal/FlowSchedule.h"
#include "internal/ParameterChecks.h"
#include "openmm/OpenMMException.h"
#include <iterator>
#include <utility>

using namespace FlavorPlugin;
using std::string;

namespace {

/** Every splitting and its name: the one list setSplitting() accepts and its messages give. */
const std::pair<StochasticImpulseIntegrator::Splitting, const char*> Splittings[] = {
    {StochasticImpulseIntegrator::LieTrotter, "LieTrotter"},
    {StochasticImpulseIntegrator::Strang, "Strang"},
    {StochasticImpulseIntegrator::Yoshida4, "Yoshida4"},
    {StochasticImpulseIntegrator::Filtered, "Filtered"},
    {StochasticImpulseIntegrator::Warped, "Warped"}};

string splittingList() {
    string list;
    const size_t n = std::size(Splittings);
    for (size_t i = 0; i < n; ++i)
        list += string(i == 0       ? ""
                       : i + 1 == n ? " or "
                                    : ", ") +
                Splittings[i].second + " (" + std::to_string((int)Splittings[i].first) + ")";
    return list;
}

} // namespace

void FlavorPlugin::validateSplitting(StochasticImpulseIntegrator::Splitting splitting, double friction,
                                     const char* parameter) {
    // Checked before every step: no string is built unless the check fails.
    const char* owner = "StochasticImpulseIntegrator";
    bool known = false;
    for (const auto& entry : Splittings)
        known = known || entry.first == splitting;
    if (!known)
        throwInvalidParameter(owner, "splitting", std::to_string((int)splitting),
                              "splitting must be " + splittingList());
    // Yoshida4's middle Strang substep runs backwards in time, where friction would amplify.
    if (splitting == StochasticImpulseIntegrator::Yoshida4 && friction != 0.0)
        throwInvalidParameter(owner, parameter, string(parameter) == "splitting" ? "Yoshida4" : formatNumber(friction),
                              "the Yoshida4 splitting has a substep backwards in time and is defined only for friction "
                              "0 (friction is " +
                                  formatNumber(friction) + " 1/ps); use Strang or LieTrotter with friction");
}

void FlavorPlugin::validateImpulseStep(const ImpulseParameters& p) {
    validateSplitting(p.splitting, p.bath.friction, "friction");
    validateSplitting(p.splitting, p.stiffBath.friction, "stiffModeFriction");
    if (p.thermostatPlacement == StochasticImpulseIntegrator::Middle &&
        p.splitting != StochasticImpulseIntegrator::Filtered && p.splitting != StochasticImpulseIntegrator::Warped)
        throw OpenMM::OpenMMException("StochasticImpulseIntegrator: thermostatPlacement = Middle (1) is not allowed "
                                      "with splitting = " +
                                      std::to_string((int)p.splitting) +
                                      " (its kicks act on whole particles, not mode by mode); allowed: Throughout (0) "
                                      "with every splitting, Middle with Filtered (3) and Warped (4)");
}

void FlavorPlugin::validateFlavorStep(const FlavorParameters& p) {
    if (p.thermostatPlacement == FlavorIntegrator::Middle) {
        // The Middle placement is defined for the artificial Verlet scheme with its symplectic microstep.
        string conflict;
        if (p.scheme != FlavorIntegrator::Verlet)
            conflict = "scheme = SymplecticEuler (it needs Verlet)";
        else if (p.averaging == FlavorIntegrator::Nonintrusive)
            conflict = "averaging = Nonintrusive (it needs Artificial or ArtificialProjected)";
        else if (p.exactFastFlow)
            conflict = "exactFastFlow = true (it needs the symplectic microstep; the exact fast flow samples harmonic "
                       "stiff coordinates exactly with Edges)";
        if (!conflict.empty())
            throw OpenMM::OpenMMException(
                "FlavorIntegrator: thermostatPlacement = Middle (1) is not allowed with " + conflict +
                "; allowed: FlavorIntegrator::Edges (0) with every scheme and averaging, Middle with the Verlet "
                "scheme, an artificial averaging and setExactFastFlow(false)");
    }
    if (p.stiffClock && p.averaging != FlavorIntegrator::Nonintrusive)
        throw OpenMM::OpenMMException(
            "FlavorIntegrator: a stiff clock (setStiffClockParameter) is not allowed with averaging = " +
            string(p.averaging == FlavorIntegrator::Artificial ? "Artificial (1)" : "ArtificialProjected (2)") +
            ": the artificial averagings measure the stiff potential once, and a stiff force that depends on the "
            "clock changes with it; allowed: the Nonintrusive averaging (0)");
    if (p.averaging != FlavorIntegrator::Nonintrusive && p.exactFastFlow && p.frozen == SubFlow::FrozenSet::Distances)
        throw OpenMM::OpenMMException("FlavorIntegrator: the stiff force groups are not quadratic (their distances are "
                                      "frozen with constraints), so they have no exact fast flow; call "
                                      "setExactFastFlow(false)");
}
