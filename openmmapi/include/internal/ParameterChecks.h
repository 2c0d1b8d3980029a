#ifndef OPENMM_FLAVORS_PARAMETER_CHECKS_H_
#define OPENMM_FLAVORS_PARAMETER_CHECKS_H_

#include "windowsExportFlavors.h"
#include <string>

namespace OpenMM {
class System;
}

namespace FlavorPlugin {

/** Formats a number with the fewest digits that read back as the same double. */
OPENMM_EXPORT_FLAVORS std::string formatNumber(double value);
/** A time in ps written in fs, e.g. "2.5 fs". */
OPENMM_EXPORT_FLAVORS std::string formatFemtoseconds(double ps);

/**
 * Throws an OpenMMException that names the integrator, the parameter, the rejected value and what is allowed:
 * "<owner>: <parameter> = <value> is not allowed; <allowed>".
 */
[[noreturn]] OPENMM_EXPORT_FLAVORS void throwInvalidParameter(const std::string& owner, const std::string& parameter,
                                                              const std::string& value, const std::string& allowed);

/** Throws unless value is finite and value > 0. */
OPENMM_EXPORT_FLAVORS void requirePositive(const std::string& owner, const std::string& parameter, double value,
                                           const std::string& unit);

/** Throws unless value is finite and value >= 0. */
OPENMM_EXPORT_FLAVORS void requireNonNegative(const std::string& owner, const std::string& parameter, double value,
                                              const std::string& unit);

/** Throws unless groups is a nonzero force-group bitmask. */
OPENMM_EXPORT_FLAVORS void requireGroupMask(const std::string& owner, const std::string& parameter, int groups);

/** Throws, naming the parameter stiffGroups, unless the System has a force in one of the groups. */
OPENMM_EXPORT_FLAVORS void requireForceInGroups(const std::string& owner, const OpenMM::System& system, int groups);

/** Lists the groups of a force-group bitmask as "{0, 3}". */
OPENMM_EXPORT_FLAVORS std::string describeGroups(int groups);

/**
 * Throws, naming parameter (the setting being changed) and both masks, unless every stiff group is one of the
 * integration force groups: a stiff force the integrator does not integrate would be applied by one scheme and
 * dropped by another.
 */
OPENMM_EXPORT_FLAVORS void requireStiffGroupsIntegrated(const std::string& owner, const std::string& parameter,
                                                        int stiffGroups, int integrationGroups);

} // namespace FlavorPlugin

#endif
