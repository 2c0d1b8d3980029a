#ifndef OPENMM_FLAVORS_STIFF_GROUP_CHECKS_H_
#define OPENMM_FLAVORS_STIFF_GROUP_CHECKS_H_

#include "windowsExportFlavors.h"
#include <string>
#include <vector>

namespace OpenMM {
class ContextImpl;
}

namespace FlavorPlugin {

/**
 * The particles that the bonded stiff forces link to others, known without positions (for checks at Context
 * creation).
 */
OPENMM_EXPORT_FLAVORS std::vector<bool> bondedStiffParticles(OpenMM::ContextImpl& context, int stiffGroups);

/**
 * Throws if a constraint of the System touches a particle for which stiff[i] is true; the message names the owner
 * (the integrator) and suggests the alternative.
 */
OPENMM_EXPORT_FLAVORS void rejectConstrainedStiffParticles(const OpenMM::ContextImpl& context,
                                                           const std::vector<bool>& stiff,
                                                           const std::string& owner = "StochasticImpulseIntegrator",
                                                           const std::string& alternative = "use FlavorIntegrator");

} // namespace FlavorPlugin

#endif
