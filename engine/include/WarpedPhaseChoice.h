#ifndef OPENMM_FLAVORS_WARPED_PHASE_CHOICE_H_
#define OPENMM_FLAVORS_WARPED_PHASE_CHOICE_H_

#include "StiffModes.h"
#include "internal/windowsExportFlavors.h"

namespace OpenMM {
class ContextImpl;
} // namespace OpenMM

namespace FlavorPlugin {

/**
 * The Warped splitting's phase limit as the integrator chooses it from the System (StochasticImpulseIntegrator::
 * setMaxWarpedPhase(0), the default).  A soft stiffness r k along a stiff mode of stiffness k keeps the Warped step
 * stable while the mode's phase per step ξ satisfies (1 + r) sin²(ξ/2) < 1, so the limit is 2 asin(1/√(1 + 1.05 r)) for
 * the largest r over the stiff modes' space: the largest eigenvalue of Ω⁻¹ Uᵀ M^-1/2 H_soft M^-1/2 U Ω⁻¹ over the
 * modes with ω > 0, H_soft the soft forces' Hessian where the Context is.  Measured by Lanczos iterations whose
 * products with H_soft are central differences of the soft forces, evaluated in a copy of the System on the CPU
 * platform (Reference where there is none), so that the Context itself is not touched.
 */
struct OPENMM_EXPORT_FLAVORS WarpedPhaseChoice {
    /** The largest soft stiffness along the stiff modes, in units of each mode's own (0 if none is positive). */
    double couplingRatio = 0.0;
    /** 2 asin(1/√(1 + PhaseMargin couplingRatio)): π where nothing couples. */
    double phase = 0.0;
    /** The margin on the measured coupling. */
    static constexpr double PhaseMargin = 1.05;
    /** How long the choice took (s) and how many soft-force evaluations it made. */
    double seconds = 0.0;
    int forceEvaluations = 0;
};

/** Chooses the phase limit for the stiff modes of the Context's System at its positions; softGroups: the soft forces.
 */
OPENMM_EXPORT_FLAVORS WarpedPhaseChoice chooseWarpedPhase(OpenMM::ContextImpl& context, const StiffModes& modes,
                                                          int softGroups);

} // namespace FlavorPlugin

#endif
