#ifndef OPENMM_FLAVORS_PHYSICAL_CONSTANTS_H_
#define OPENMM_FLAVORS_PHYSICAL_CONSTANTS_H_

namespace FlavorPlugin {

/**
 * Boltzmann's constant in kJ/(mol K), the product of OpenMM's: k_B N_A / 1000 with CODATA 2018's exact k_B and N_A,
 * evaluated as OpenMM's reference headers evaluate BOLTZ, so that kT is the same double as in OpenMM's integrators
 * (tests/TestFlowSchedule.cpp compares them).
 */
constexpr double BoltzmannKJPerMolK = (1.380649e-23 * 6.02214076e23) / 1e3;

} // namespace FlavorPlugin

#endif
