#ifndef OPENMM_FLAVORS_FROZEN_FLOW_TASK_H_
#define OPENMM_FLAVORS_FROZEN_FLOW_TASK_H_

#include "ParticleFlows.h"
#include "StiffModes.h"
#include "internal/windowsExportFlavors.h"
#include "openmm/Vec3.h"
#include <cstddef>
#include <vector>

namespace FlavorPlugin {

/**
 * The flows of the artificial FLAVOR that hold the stiff degrees of freedom of a quadratic stiff potential frozen,
 * one component per index of the range.  Both add h P0 u to a target, where P0 is the mass-orthogonal projection onto
 * the zero modes of the stiff potential (the directions along which it is flat):
 *
 *     FrozenDrift:  q += h P0 v          (the rates of the frozen coordinates, K's nonzero modes, stay as they were)
 *     FrozenKick:   v += h P0 M^-1 F
 *
 * In mass-weighted coordinates P0 = sum over zero modes k of U_k U_k^T.  Components without stiffness are all zero
 * modes (P0 = 1); massless particles belong to no component and never move.  The step engine sets the fields before
 * each run.
 */
class OPENMM_EXPORT_FLAVORS FrozenFlowTask : public RangeTask {
public:
    /** Lists each component's zero modes and sizes the scratch; nothing is allocated later. */
    explicit FrozenFlowTask(const StiffModes& modes);
    void apply(int begin, int end) const override;

    /** The vector projected: velocities (FrozenDrift) or forces (FrozenKick). */
    const OpenMM::Vec3* source = nullptr;
    /** Where h P0 u is added: positions (FrozenDrift) or velocities (FrozenKick). */
    OpenMM::Vec3* target = nullptr;
    /** Whether source holds forces (u = M^-1 F) rather than velocities (u = v). */
    bool sourceIsForce = false;
    double h = 0.0;

private:
    void applyStiff(int component) const;
    const StiffModes& modes;
    // Per component: where its zero modes start in zeroModes, how many, and its slice of scratch.
    std::vector<int> firstZeroMode, numZeroModes;
    std::vector<int> zeroModes;
    std::vector<std::size_t> scratchOffset;
    // The zero-mode coefficients of each stiff component, one slice per component so that components run in parallel.
    mutable std::vector<double> scratch;
};

} // namespace FlavorPlugin

#endif
