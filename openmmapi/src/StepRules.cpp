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
    if (p.maxWarpedPhase != 0.0 && p.splitting != StochasticImpulseIntegrator::Warped)
        throw OpenMM::OpenMMException(
            "StochasticImpulseIntegrator: maxWarpedPhase = " + formatNumber(p.maxWarpedPhase) +
            " is not allowed with splitting = " + std::to_string((int)p.splitting) +
            " (it limits the warped frequency); allowed: 0 with every splitting, a phase "
            "between 0 and pi with Warped (4)");
    if (p.warpedFrictionScaling && p.splitting != StochasticImpulseIntegrator::Warped)
        throw OpenMM::OpenMMException("StochasticImpulseIntegrator: warpedFrictionScaling = true is not allowed with "
                                      "splitting = " +
                                      std::to_string((int)p.splitting) +
                                      " (it scales the friction of warped modes); allowed: false with every "
                                      "splitting, true with Warped (4)");
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

namespace {

/** The rejection of a Metropolis-adjusted step: what stops it (setting) and why (reason). */
[[noreturn]] void rejectMetropolis(const string& owner, const string& setting, const string& reason) {
    throw OpenMM::OpenMMException(owner + ": the Metropolis adjustment (setMetropolis(true)) is not allowed with " +
                                  setting + ": " + reason +
                                  ".  The adjustment needs a reversible, volume-preserving proposal and a Boltzmann "
                                  "target; call setMetropolis(false) to step without it");
}

void requireMetropolisTarget(const string& owner, double kT, bool constrained) {
    if (!(kT > 0.0))
        rejectMetropolis(owner, "temperature = 0 K", "the acceptance exp(-ΔH/kT) needs a temperature > 0");
    if (constrained)
        rejectMetropolis(owner, "a System with constraints",
                         "the constraint solves are reversible only to the constraint tolerance, which biases the "
                         "acceptance; make the constrained bonds flexible (a stiff force group)");
}

} // namespace

void FlavorPlugin::validateMetropolis(const FlavorParameters& p, bool constrained) {
    if (!p.metropolis)
        return;
    const string owner = "FlavorIntegrator";
    if (p.scheme != FlavorIntegrator::Verlet)
        rejectMetropolis(owner, "scheme = SymplecticEuler (0)",
                         "its step is not symmetric, so it is not reversible (the step with reversed velocities is "
                         "not its inverse); allowed: Verlet (1)");
    if (p.stiffClock)
        rejectMetropolis(owner, "a stiff clock (setStiffClockParameter)",
                         "the stiff forces change with the clock, so there is no conserved energy to test");
    if (p.thermostatPlacement == FlavorIntegrator::Middle)
        rejectMetropolis(owner, "thermostatPlacement = Middle (1)",
                         "the adjusted step puts the thermostat outside the proposal, O(δ/2) [P] O(δ/2); allowed: "
                         "Edges (0)");
    if (p.stiffFriction)
        rejectMetropolis(owner, "stiffFriction = true",
                         "the adjusted step puts the thermostat outside the proposal, over the whole mesostep, "
                         "O(δ/2) [P] O(δ/2); allowed: false");
    if (p.averaging != FlavorIntegrator::Nonintrusive && p.frozen == SubFlow::FrozenSet::Distances)
        rejectMetropolis(owner, "frozen bonded distances (the artificial averaging of nonlinear stiff forces)",
                         "the frozen drift holds the distances by an iterative solve, reversible only to its "
                         "tolerance; allowed: the Nonintrusive averaging, or an artificial one with quadratic stiff "
                         "groups (their stiff modes freeze exactly)");
    requireMetropolisTarget(owner, p.kT, constrained);
}

void FlavorPlugin::validateMetropolis(const ImpulseParameters& p, bool constrained) {
    if (!p.metropolis)
        return;
    const string owner = "StochasticImpulseIntegrator";
    if (p.splitting == StochasticImpulseIntegrator::LieTrotter)
        rejectMetropolis(owner, "splitting = LieTrotter (0)",
                         "its step E(H) K(H) is not symmetric, so it is not reversible; allowed: Strang (1), "
                         "Yoshida4 (2) and Filtered (3)");
    if (p.splitting == StochasticImpulseIntegrator::Warped)
        rejectMetropolis(owner, "splitting = Warped (4)",
                         "its step is not reversible: from the reversed end state it misses its start by about 1e-3 "
                         "of a stiff mode's amplitude (the reversibility test); allowed: Strang (1), Yoshida4 (2) "
                         "and Filtered (3)");
    if (p.maxDrudeDistance > 0.0)
        rejectMetropolis(owner, "a hard wall (setMaxDrudeDistance)",
                         "the wall resets velocities, which no Hamiltonian proposal does");
    if (p.thermostatPlacement == StochasticImpulseIntegrator::Middle)
        rejectMetropolis(owner, "thermostatPlacement = Middle (1)",
                         "the adjusted step puts the thermostat outside the proposal, O(H/2) [P] O(H/2); allowed: "
                         "Throughout (0)");
    if (p.stiffBath.kT != p.bath.kT)
        rejectMetropolis(
            owner, "a stiff-mode temperature (" + formatNumber(p.stiffBath.kT / p.bath.kT) + " times the temperature)",
            "the Boltzmann target has one temperature; set the stiff-mode temperature equal to the temperature");
    if (p.stiffBath.friction != p.bath.friction)
        rejectMetropolis(owner, "stiffModeFriction = " + formatNumber(p.stiffBath.friction) + " 1/ps",
                         "the adjusted step's thermostat acts on whole particles outside the proposal with the "
                         "friction (" +
                             formatNumber(p.bath.friction) + " 1/ps); set the stiff-mode friction equal to it");
    requireMetropolisTarget(owner, p.bath.kT, constrained);
}
