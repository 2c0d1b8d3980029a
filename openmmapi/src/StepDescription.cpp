#include "internal/FlowSchedule.h"
#include "internal/ParameterChecks.h"
#include "internal/PhysicalConstants.h"
#include <cmath>
#include <sstream>

using namespace FlavorPlugin;
using std::string;

namespace {

/** c times the time scale name: "δ", "δ/2", "2δ", "1.35121H". */
string scaled(double c, const string& name) {
    if (c == 1.0)
        return name;
    const double inverse = 1.0 / c;
    if (inverse == std::round(inverse) && inverse > 1.0)
        return name + "/" + std::to_string((int)inverse);
    std::ostringstream out;
    out.precision(6);
    out << std::abs(c);
    return (c < 0 ? "−" : "") + out.str() + name;
}

string formatLength(const StepLength& length, const string& meso, const string& micro) {
    const double a = length.mesoSteps, b = length.microSteps;
    if (b == 0.0)
        return scaled(a, meso);
    if (a == 0.0)
        return scaled(b, micro);
    if (a == -b && a > 0.0) {
        const string difference = meso + "−" + micro;
        return a == 1.0 ? difference : scaled(a, "(" + difference + ")");
    }
    return scaled(a, meso) + (b > 0 ? "+" : "−") + scaled(std::abs(b), micro);
}

string kickName(int groups, int stiffGroups, int integrationGroups) {
    if (groups == (integrationGroups & ~stiffGroups))
        return "K_S";
    if (groups == (integrationGroups & stiffGroups))
        return "K_F";
    if (groups == integrationGroups)
        return "K_A";
    return "K_" + describeGroups(groups);
}

string describeBath(const Bath& bath) {
    return formatNumber(bath.kT / BoltzmannKJPerMolK) + " K, " + formatNumber(bath.friction) + "/ps";
}

} // namespace

string FlavorPlugin::describeSchedule(const Schedule& schedule, int stiffGroups, int integrationGroups,
                                      const string& meso, const string& micro, int numFrozen) {
    std::ostringstream out;
    string baths, frozen, proposal, wall;
    bool opened = false;
    for (const SubFlow& flow : schedule) {
        const string h = "(" + formatLength(flow.length, meso, micro) + ")";
        const string kick = kickName(flow.groups, stiffGroups, integrationGroups);
        string exact = "E";
        if (flow.frequency == SubFlow::StiffFrequency::Warped || flow.zeroModes == SubFlow::ZeroModeFlow::Middle)
            exact += string("^") + (flow.frequency == SubFlow::StiffFrequency::Warped ? "ω̃" : "") +
                     (flow.zeroModes == SubFlow::ZeroModeFlow::Middle ? "M" : "");
        const string halfKick = (flow.response == SubFlow::KickResponse::Scaled ? "K^κ" + kick.substr(1) : kick) + "(" +
                                formatLength({flow.length.mesoSteps / 2, flow.length.microSteps / 2}, meso, micro) +
                                ")";
        if (out.tellp() > 0 && !opened && flow.kind != SubFlow::ProposalTest)
            out << " ";
        opened = flow.kind == SubFlow::ProposalStart;
        switch (flow.kind) {
        case SubFlow::ProposalStart:
            out << "[";
            break;
        case SubFlow::HardWall:
            out << "W";
            wall = "W: hard wall of the stiff pairs at " + formatNumber(flow.distance) +
                   " nm (W_v: their radial velocity inward at the thermal speed)";
            break;
        case SubFlow::HardWallSpeed:
            out << "W_v";
            break;
        case SubFlow::ProposalTest:
            out << "]_MH";
            proposal = "[…]_MH: proposal accepted with min(1, exp(−ΔH/kT)), else reversed";
            break;
        case SubFlow::Kick:
            out << kick << h;
            break;
        case SubFlow::Drift:
            out << "D" << h;
            break;
        case SubFlow::Thermostat:
            out << "O" << h;
            baths = "O: " + describeBath(flow.bath);
            break;
        case SubFlow::StiffFlow:
        case SubFlow::FilteredStiffFlow:
            if (flow.kind == SubFlow::FilteredStiffFlow)
                out << halfKick << " ";
            out << exact << h;
            baths = "E: zero modes " + describeBath(flow.bath) + ", stiff modes " + describeBath(flow.stiffBath);
            if (flow.warp.maxPhase > 0.0)
                baths += ", ω̃H ≤ " + formatNumber(flow.warp.maxPhase) + " with kicks keeping the exact mean";
            if (flow.warp.scaledFriction)
                baths += ", stiff friction scaled by (2 sin(ω̃H/2)/ωH)²";
            break;
        case SubFlow::FilteredKick:
            out << halfKick;
            break;
        case SubFlow::HarmonicFlow:
            out << "E₀" << h;
            break;
        case SubFlow::FrozenDrift:
        case SubFlow::FrozenKick:
            out << (flow.kind == SubFlow::FrozenKick ? "θ" + kick : "θ") << h;
            if (flow.frozen == SubFlow::FrozenSet::Distances)
                frozen =
                    "θ holds the " + (numFrozen > 0 ? std::to_string(numFrozen) + " " : "") + "stiff bonded distances";
            else if (flow.frozen == SubFlow::FrozenSet::StiffModes)
                frozen = "θ holds the " + (numFrozen > 0 ? std::to_string(numFrozen) + " " : "") +
                         "stiff modes of the quadratic stiff groups";
            else
                frozen = "θ holds the stiff modes if the stiff groups are quadratic, else their bonded distances "
                         "(measured at the first step)";
            break;
        }
    }
    string notes = baths;
    if (!proposal.empty())
        notes += (notes.empty() ? "" : "; ") + proposal;
    if (!wall.empty())
        notes += (notes.empty() ? "" : "; ") + wall;
    if (!frozen.empty())
        notes += (notes.empty() ? "" : "; ") + frozen;
    if (!notes.empty())
        out << "   [" << notes << "]";
    return out.str();
}
