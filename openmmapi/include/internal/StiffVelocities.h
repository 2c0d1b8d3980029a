#ifndef OPENMM_FLAVORS_STIFF_VELOCITIES_H_
#define OPENMM_FLAVORS_STIFF_VELOCITIES_H_

#include "openmm/Vec3.h"
#include "windowsExportFlavors.h"
#include <vector>

namespace OpenMM {
class System;
} // namespace OpenMM

namespace FlavorPlugin {

/**
 * Random velocities with two temperatures, as OpenMM's Drude integrators draw them: the particles that the two-particle
 * terms of the stiff groups link (HarmonicBondForce and CustomBondForce bonds, DrudeForce pairs) form components; each
 * component's centre of mass moves at temperature, its motion relative to that centre at stiffTemperature, and every
 * other particle at temperature.  Massless particles get zero velocity.  Temperatures in K; seed fixes the draw.
 */
OPENMM_EXPORT_FLAVORS std::vector<OpenMM::Vec3> velocitiesWithStiffTemperature(const OpenMM::System& system,
                                                                               int stiffGroups, double temperature,
                                                                               double stiffTemperature, int seed);

} // namespace FlavorPlugin

#endif
