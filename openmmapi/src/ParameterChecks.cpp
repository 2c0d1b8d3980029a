#include "internal/ParameterChecks.h"
#include "openmm/Force.h"
#include "openmm/OpenMMException.h"
#include "openmm/System.h"
#include <cmath>
#include <cstdlib>
#include <sstream>

using namespace FlavorPlugin;

std::string FlavorPlugin::formatNumber(double value) {
    for (int digits = 6; digits <= 17; ++digits) {
        std::ostringstream out;
        out.precision(digits);
        out << value;
        if (std::isnan(value) || std::strtod(out.str().c_str(), nullptr) == value)
            return out.str();
    }
    std::ostringstream out;
    out.precision(17);
    out << value;
    return out.str();
}

std::string FlavorPlugin::formatFemtoseconds(double ps) {
    return formatNumber(ps * 1000.0) + " fs";
}

void FlavorPlugin::throwInvalidParameter(const std::string& owner, const std::string& parameter,
                                         const std::string& value, const std::string& allowed) {
    throw OpenMM::OpenMMException(owner + ": " + parameter + " = " + value + " is not allowed; " + allowed);
}

void FlavorPlugin::requirePositive(const std::string& owner, const std::string& parameter, double value,
                                   const std::string& unit) {
    if (!(std::isfinite(value) && value > 0.0))
        throwInvalidParameter(owner, parameter, formatNumber(value),
                              parameter + " must be a finite number > 0 (in " + unit + ")");
}

void FlavorPlugin::requireNonNegative(const std::string& owner, const std::string& parameter, double value,
                                      const std::string& unit) {
    if (!(std::isfinite(value) && value >= 0.0))
        throwInvalidParameter(owner, parameter, formatNumber(value),
                              parameter + " must be a finite number >= 0 (in " + unit + ")");
}

void FlavorPlugin::requireGroupMask(const std::string& owner, const std::string& parameter, int groups) {
    if (groups == 0)
        throwInvalidParameter(owner, parameter, "0",
                              parameter + " must be a nonzero bitmask of force groups 0..31 (bit i set = group i)");
}

void FlavorPlugin::requireForceInGroups(const std::string& owner, const OpenMM::System& system, int groups) {
    for (int i = 0; i < system.getNumForces(); ++i)
        if ((groups & (1 << system.getForce(i).getForceGroup())) != 0)
            return;
    throwInvalidParameter(owner, "stiffGroups", std::to_string(groups),
                          "the System has no force in these groups; stiffGroups must select the force group(s) of at "
                          "least one force (Force.setForceGroup)");
}

std::string FlavorPlugin::describeGroups(int groups) {
    if (groups == -1)
        return "{0, ..., 31} (all)";
    std::string result;
    for (int group = 0; group < 32; ++group)
        if ((groups & (1 << group)) != 0)
            result += (result.empty() ? "{" : ", ") + std::to_string(group);
    return result.empty() ? "{}" : result + "}";
}

void FlavorPlugin::requireStiffGroupsIntegrated(const std::string& owner, const std::string& parameter, int stiffGroups,
                                                int integrationGroups) {
    const int missing = stiffGroups & ~integrationGroups;
    if (missing == 0)
        return;
    const std::string value = std::to_string(parameter == "stiffGroups" ? stiffGroups : integrationGroups);
    throwInvalidParameter(owner, parameter, value,
                          "every stiff group must be one of the integration force groups, but stiffGroups = " +
                              std::to_string(stiffGroups) + " (groups " + describeGroups(stiffGroups) +
                              ") and integrationForceGroups = " + std::to_string(integrationGroups) + " (groups " +
                              describeGroups(integrationGroups) + ") leave stiff group(s) " + describeGroups(missing) +
                              " out of the integration; add them to setIntegrationForceGroups() or remove them from "
                              "stiffGroups");
}
