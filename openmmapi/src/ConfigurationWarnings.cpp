// FlavorIntegrator::getConfigurationWarnings() and StochasticImpulseIntegrator::getConfigurationWarnings():
// configurations of a Context that run but are probably not what was meant.  Errors stay errors (ParameterChecks,
// StiffGroupChecks); these only describe, and the Python wrapper emits them as openmmflavors.FlavorsWarning at the
// first step.
#include "FlavorIntegrator.h"
#include "StochasticImpulseIntegrator.h"
#include "internal/ParameterChecks.h"
#include "internal/StiffGroupChecks.h"
#include "openmm/CMAPTorsionForce.h"
#include "openmm/CustomGBForce.h"
#include "openmm/CustomHbondForce.h"
#include "openmm/CustomManyParticleForce.h"
#include "openmm/CustomNonbondedForce.h"
#include "openmm/CustomTorsionForce.h"
#include "openmm/GBSAOBCForce.h"
#include "openmm/HarmonicAngleForce.h"
#include "openmm/NonbondedForce.h"
#include "openmm/PeriodicTorsionForce.h"
#include "openmm/RBTorsionForce.h"
#include "openmm/System.h"
#include "openmm/internal/ContextImpl.h"
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <typeinfo>
#include <vector>

using namespace FlavorPlugin;
using namespace OpenMM;
using std::string;
using std::vector;

namespace {

// The largest mesosteps measured as accurate for an artificial FLAVOR with frozen bonds and angles (README, "Which
// integrator when"), in ps.
const double AccurateProteinMesoStep = 0.0025;
const double AccurateWaterMesoStep = 0.007;

bool isNonbonded(const Force& force) {
    if (dynamic_cast<const NonbondedForce*>(&force) || dynamic_cast<const CustomNonbondedForce*>(&force) ||
        dynamic_cast<const GBSAOBCForce*>(&force) || dynamic_cast<const CustomGBForce*>(&force) ||
        dynamic_cast<const CustomHbondForce*>(&force) || dynamic_cast<const CustomManyParticleForce*>(&force))
        return true;
    // Plugin forces (AMOEBA, HIPPO) are not linked here; their class names say what they are.
    const string name = typeid(force).name();
    for (const char* part : {"Nonbonded", "Multipole", "Vdw", "Kirkwood", "WcaDispersion"})
        if (name.find(part) != string::npos)
            return true;
    return false;
}

bool isTorsion(const Force& force) {
    return dynamic_cast<const PeriodicTorsionForce*>(&force) || dynamic_cast<const RBTorsionForce*>(&force) ||
           dynamic_cast<const CMAPTorsionForce*>(&force) || dynamic_cast<const CustomTorsionForce*>(&force);
}

bool hasStiffAngles(const Force& force) {
    const HarmonicAngleForce* angles = dynamic_cast<const HarmonicAngleForce*>(&force);
    if (angles == nullptr)
        return false;
    for (int a = 0; a < angles->getNumAngles(); ++a) {
        int p1, p2, p3;
        double theta, k;
        angles->getAngleParameters(a, p1, p2, p3, theta, k);
        if (k != 0.0)
            return true;
    }
    return false;
}

} // namespace

vector<string> FlavorIntegrator::getConfigurationWarnings() const {
    vector<string> warnings;
    if (context == nullptr)
        return warnings;
    const System& system = context->getSystem();
    bool frozenAngles = false, torsions = false;
    for (int f = 0; f < system.getNumForces(); ++f) {
        const Force& force = system.getForce(f);
        const bool stiff = (stiffGroups & (1 << force.getForceGroup())) != 0;
        torsions = torsions || isTorsion(force);
        frozenAngles = frozenAngles || (stiff && averaging != Nonintrusive && hasStiffAngles(force));
        if (!stiff || averaging != Nonintrusive || !isNonbonded(force))
            continue;
        string fix = "pass the set of the stiff group numbers, e.g. {1} from Python";
        if (stiffGroups >= 1 && stiffGroups <= 31)
            fix = "if group " + std::to_string(stiffGroups) + " was meant, pass {" + std::to_string(stiffGroups) +
                  "} from Python or the bitmask 1 << " + std::to_string(stiffGroups) + " = " +
                  std::to_string(1 << stiffGroups);
        warnings.push_back("FlavorIntegrator: " + describeForce(system, f) +
                           " is stiff (stiffGroups = " + std::to_string(stiffGroups) +
                           " is the bitmask of the groups " + describeGroups(stiffGroups) +
                           "): the nonintrusive FLAVOR integrates it weakened by microStep/mesoStep = " +
                           formatNumber(microStep / getStepSize()) +
                           " and every force outside those groups as soft.  A nonbonded force is rarely meant to be "
                           "stiff; stiffGroups is a bitmask (bit g for group g), so " +
                           fix + ".");
    }
    const double limit = torsions ? AccurateProteinMesoStep : AccurateWaterMesoStep;
    if (frozenAngles && getStepSize() > limit * (1.0 + 1e-9)) {
        const string measured =
            torsions ? "2.5 fs on villin in water (examples/villin, thermostat Middle: seven paired runs within the "
                       "run-to-run error bars of LangevinMiddleIntegrator at 2 fs; at 3 fs the system ran 1.2 K warm)"
                     : "7 fs on flexible TIP3P water (examples/flexible_water, thermostat Middle, tau = 0.5 fs: three "
                       "seeds within the run-to-run error bars of LangevinMiddleIntegrator at 0.25 fs; at 10 fs the "
                       "hydrogens ran 32 K hot)";
        warnings.push_back("FlavorIntegrator: mesoStep = " + formatFemtoseconds(getStepSize()) +
                           " is longer than any mesostep measured as accurate for an artificial FLAVOR with frozen "
                           "angles" +
                           string(torsions ? " in a System with torsions" : "") + ": " + measured +
                           ".  It runs, but nothing says it is accurate: compare the observables you need with a "
                           "reference run, or use mesoStep <= " +
                           formatFemtoseconds(limit) + ".");
    }
    return warnings;
}

namespace {

// Half-width of the resonance bands, relative to k pi.  A soft force stiff along a stiff mode (r omega^2 along it)
// gives a Strang step the transfer-matrix trace 2 cos(xi) - r xi sin(xi), xi = omega H: unstable between k pi (1 - r)
// and k pi for small r > 0 (above k pi for r < 0), with growth up to 1 + r k pi / 2 per step, which the friction's
// exp(-gamma H / 2) per step closes where gamma H >= r k pi; and at xi = 2 pi k the step's response to a constant soft
// force, (xi/2) cot(xi/2), has a pole.  The bands guard against |r| <= 0.05, the width of the resonances of
// docs/resonance.png on the FPU chain (where friction 10/ps removes them at omega = 200 and 1/ps does not).
const double ResonanceBand = 0.05;

} // namespace

vector<string> StochasticImpulseIntegrator::getConfigurationWarnings() {
    vector<string> warnings;
    if (context == nullptr || splitting == Warped)
        return warnings;
    const System& system = context->getSystem();
    bool soft = false;
    for (int f = 0; f < system.getNumForces(); ++f) {
        const int bit = 1 << system.getForce(f).getForceGroup();
        soft = soft || ((bit & getIntegrationForceGroups()) != 0 && (bit & stiffGroups) == 0);
    }
    if (!soft)
        return warnings;
    const vector<double> omega = getStiffModeFrequencies();
    const double H = getStepSize(), gamma = getStiffModeFriction();
    const double w1 = 1.0 / (2.0 - std::cbrt(2.0)), w0 = 1.0 - 2.0 * w1; // Yoshida4: Strang steps w1 H, w0 H, w1 H
    const vector<double> scales = splitting == Yoshida4 ? vector<double>{w1, -w0} : vector<double>{1.0};
    double largest = 0.0;
    for (double w : omega)
        largest = std::max(largest, w);
    int stiff = 0, resonant = 0;
    double example = 0.0, exampleXi = 0.0;
    for (double w : omega) {
        if (!(w > 1e-8 * std::max(1.0, largest)))
            continue; // a zero mode
        ++stiff;
        for (double scale : scales) {
            const double h = scale * H;
            const double turn = splitting == Filtered ? std::sqrt(std::max(w * w - gamma * gamma / 4.0, 0.0)) : w;
            const double xi = turn * h, k = std::round(xi / M_PI);
            bool near = k >= 1 && std::abs(xi - k * M_PI) <= ResonanceBand * k * M_PI;
            if (splitting == Filtered)
                near = near && std::fmod(k, 2.0) == 1.0 && xi > 0.0;
            else
                near = near && gamma * h < ResonanceBand * k * M_PI;
            if (near) {
                if (resonant == 0 ||
                    std::abs(xi / (k * M_PI) - 1) < std::abs(exampleXi / (std::round(exampleXi / M_PI) * M_PI) - 1)) {
                    example = w;
                    exampleXi = xi;
                }
                ++resonant;
                break;
            }
        }
    }
    if (resonant == 0)
        return warnings;
    const char* names[] = {"LieTrotter", "Strang", "Yoshida4", "Filtered", "Warped"};
    const string band =
        splitting == Filtered
            ? "|omega H - k pi| <= 0.05 k pi for odd k, where the Filtered splitting's filter has a pole (the damped "
              "mode turns by an odd multiple of pi per step, and kicks cannot give it its mean)"
            : "|omega H - k pi| <= 0.05 k pi, where a soft force along a mode with a fraction r <= 0.05 of its "
              "stiffness makes the step unstable (for k pi (1 - r) < omega H < k pi) and, at omega H = 2 pi k, the "
              "step's response to a constant soft force, (omega H/2) cot(omega H/2), has a pole; friction closes the "
              "band at k only where gamma H >= 0.05 k pi";
    char ratio[32];
    std::snprintf(ratio, sizeof(ratio), "%.3f", exampleXi / M_PI);
    warnings.push_back(
        "StochasticImpulseIntegrator: " + std::to_string(resonant) + " of " + std::to_string(stiff) +
        " stiff modes resonate with the step size H = " + formatNumber(H) +
        " ps, e.g. omega = " + formatNumber(example) + "/ps: omega H" +
        string(splitting == Yoshida4 ? "' (a Strang substep of Yoshida4, |w_i| H)" : "") + " = " + ratio +
        " pi, with stiff-mode friction gamma = " + formatNumber(gamma) + "/ps and the " + names[splitting] +
        " splitting.  Resonance band: " + band + ".  Choose H with every omega H outside the bands (H <= " +
        formatNumber((1.0 - ResonanceBand) * M_PI / largest / (splitting == Yoshida4 ? -w0 : 1.0)) +
        " ps keeps every mode below the first), raise setStiffModeFriction, or use the Warped splitting, which has no "
        "resonances.");
    return warnings;
}
