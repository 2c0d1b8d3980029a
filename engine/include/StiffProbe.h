#ifndef OPENMM_FLAVORS_STIFF_PROBE_H_
#define OPENMM_FLAVORS_STIFF_PROBE_H_

#include "StiffModes.h"
#include "internal/windowsExportFlavors.h"
#include "openmm/OpenMMException.h"
#include "openmm/System.h"
#include "openmm/Vec3.h"
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace OpenMM {
class ContextImpl;
}

namespace FlavorPlugin {

/** Thrown by probeStiffness() when the stiff forces are not quadratic in the positions. */
class OPENMM_EXPORT_FLAVORS NotQuadraticException : public OpenMM::OpenMMException {
public:
    explicit NotQuadraticException(const std::string& message) : OpenMM::OpenMMException(message) {}
};

/** The stiffness matrix K (nonzero blocks, i <= j) and constant force b of a quadratic stiff potential. */
struct ProbedStiffness {
    std::vector<StiffnessBlock> blocks;
    std::vector<OpenMM::Vec3> constantForce;
    /** The relative deviation from linearity measured at a random displacement. */
    double linearityDeviation;
};

/**
 * Measures K and b of the force groups stiffGroups.  First, with three force evaluations at multiples of one random
 * displacement of every particle with mass, it checks that the forces are linear in the positions (second and third
 * differences vanish) and throws an OpenMMException reporting the measured deviation if they are not.  Then it
 * measures K by central differences of the forces around the current positions and checks at another random
 * displacement that the forces really are -K q + b.  Particles linked by the bonded stiff forces
 * (ForceImpl::getBondedParticles) are probed together, one particle of every linked group at a time, so the cost
 * grows with the largest group, not with the number of groups; if that misses a coupling, every particle is probed
 * on its own.  Massless particles are fixed: they are never displaced and the forces on them are ignored.  Throws an
 * NotQuadraticException (an OpenMMException) if the forces are not linear in the positions or K is not
 * symmetric.  The Context's positions are left as they were.  On platforms other than Reference and CPU the forces
 * are evaluated in double precision on a copy of the stiff forces on the Reference platform (OpenCL's single and
 * mixed precision round positions too coarsely to tell a quadratic potential from another).
 */
OPENMM_EXPORT_FLAVORS ProbedStiffness
probeStiffness(OpenMM::ContextImpl& context, int stiffGroups, const std::vector<double>& masses,
               const std::string& owner = "StochasticImpulseIntegrator",
               const std::string& alternative = "use FlavorIntegrator for nonlinear stiff forces");

/**
 * The measured stiff potential of a Context, decomposed into modes, kept while new measurements describe the same
 * potential.  Errors name the owner (the integrator) and suggest the alternative.
 */
class OPENMM_EXPORT_FLAVORS StiffModesMeasurement {
public:
    StiffModesMeasurement(const OpenMM::System& system, std::string owner, std::string alternative);
    /**
     * Measures the stiff force groups at the current positions.  Returns whether the modes changed.  Throws if the
     * potential is not quadratic, or if checkConstraints, given new modes before they are kept, throws (each
     * integrator has its own rule for System constraints beside the stiff components).
     */
    bool measure(OpenMM::ContextImpl& context, int stiffGroups,
                 const std::function<void(const StiffModes&)>& checkConstraints);
    /** The current modes (null before the first measurement). */
    const std::shared_ptr<const StiffModes>& getModes() const { return modes; }

private:
    std::string owner, alternative;
    std::vector<double> masses;
    ProbedStiffness measured;
    std::shared_ptr<const StiffModes> modes;
};

} // namespace FlavorPlugin

#endif
