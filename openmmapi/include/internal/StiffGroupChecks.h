#ifndef OPENMM_FLAVORS_STIFF_GROUP_CHECKS_H_
#define OPENMM_FLAVORS_STIFF_GROUP_CHECKS_H_

#include "windowsExportFlavors.h"
#include <string>
#include <vector>

namespace OpenMM {
class ContextImpl;
class System;
} // namespace OpenMM

namespace FlavorPlugin {

/**
 * The connected components that the bonded stiff forces link particles into, known without positions (for checks at
 * Context creation): for each particle, the lowest index of its component, or -1 if no stiff force links it.
 */
OPENMM_EXPORT_FLAVORS std::vector<int> bondedStiffComponents(OpenMM::ContextImpl& context, int stiffGroups);

/**
 * Throws unless the constraints of the System can be applied beside the exact stiff flow: every particle of a stiff
 * component (componentOf[i] >= 0 names the component of particle i) may be constrained only to particles outside its
 * component, and at most one particle of each component may be constrained (the component's flow carries the
 * constraint impulses on it to the others).
 */
OPENMM_EXPORT_FLAVORS void rejectConstraintsInsideStiffComponents(const OpenMM::ContextImpl& context,
                                                                  const std::vector<int>& componentOf);

/**
 * Throws if a constraint of the System touches a particle for which stiff[i] is true; the message names the owner
 * (the integrator) and suggests the alternative.
 */
OPENMM_EXPORT_FLAVORS void rejectConstrainedStiffParticles(const OpenMM::ContextImpl& context,
                                                           const std::vector<bool>& stiff, const std::string& owner,
                                                           const std::string& alternative);

/** "force f (its name, force group g)", how the messages about stiff forces name a force of the System. */
OPENMM_EXPORT_FLAVORS std::string describeForce(const OpenMM::System& system, int f);

/**
 * Why the artificial averaging cannot freeze the stiff forces described in forces (each "force i (Type, force group
 * g)"), and what to do instead.
 */
OPENMM_EXPORT_FLAVORS std::string describeUnfreezableForces(const std::vector<std::string>& forces);

/**
 * Throws (describeUnfreezableForces) if a force of the stiff groups is of a type that is never quadratic and has no
 * known frozen distances (nonbonded, torsion and angle-function forces), unless frozen distances have been declared
 * with FlavorIntegrator::addFrozenDistance().  Forces that may be quadratic (custom bond, external and compound
 * forces, plugin forces) can only be told apart with positions, at the first step.
 */
OPENMM_EXPORT_FLAVORS void rejectUnfreezableStiffForces(const OpenMM::System& system, int stiffGroups,
                                                        bool frozenDistancesDeclared);

} // namespace FlavorPlugin

#endif
