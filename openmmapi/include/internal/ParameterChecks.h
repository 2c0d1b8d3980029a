#ifndef OPENMM_FLAVORS_PARAMETER_CHECKS_H_
#define OPENMM_FLAVORS_PARAMETER_CHECKS_H_

#include "windowsExportFlavors.h"
#include <string>

namespace FlavorPlugin {

/** Formats a number with the fewest digits that read back as the same double. */
OPENMM_EXPORT_FLAVORS std::string formatNumber(double value);

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

} // namespace FlavorPlugin

#endif
