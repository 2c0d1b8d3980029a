#ifndef OPENMM_FLAVORS_STIFF_MODES_H_
#define OPENMM_FLAVORS_STIFF_MODES_H_

#include "CounterRandom.h"
#include "ExactModeFlow.h"
#include "ParticleFlows.h"
#include "openmm/Vec3.h"
#include "windowsExportFlavors.h"
#include <cstdint>
#include <vector>

namespace FlavorPlugin {

/** The 3x3 block K_ij of a stiffness matrix, for particles i and j (K_ji is its transpose). */
struct StiffnessBlock {
    int i, j;
    double k[3][3];
};

/**
 * A quadratic stiff potential U(q) = q^T K q / 2 - b^T q, decomposed into independent normal modes (DESIGN.md
 * section 3).  Particles coupled by nonzero blocks of K form connected components; each component is diagonalized
 * in mass-weighted coordinates, Omega = M^-1/2 K M^-1/2 = U diag(omega^2) U^T.  Every other movable particle is a
 * component of its own with three zero modes, so the free flow is the same code.
 */
class OPENMM_EXPORT_FLAVORS StiffModes {
public:
    /**
     * @param masses          the particle masses; massless particles do not move and belong to no component
     * @param blocks          the nonzero blocks K_ij with i <= j
     * @param constantForce   b, the stiff force at q = 0
     */
    StiffModes(const std::vector<double>& masses, const std::vector<StiffnessBlock>& blocks,
               const std::vector<OpenMM::Vec3>& constantForce);
    int getNumComponents() const { return (int)components.size(); }
    int getNumModes() const { return (int)omega.size(); }
    /** The angular frequencies of the modes of components with nonzero stiffness, ascending. */
    std::vector<double> getStiffFrequencies() const;
    /** Whether particle i belongs to a component with nonzero stiffness. */
    bool isStiffParticle(int i) const { return stiffParticle[i]; }
    /** The per-mode flows over a step h with friction gamma; h < 0 is allowed for gamma = 0 (the inverse flow). */
    void computeFlows(double h, double gamma, std::vector<ModeFlow>& flows) const;

    /**
     * Applies the exact flow to positions and velocities, one component per index of the range.
     */
    class Flow : public RangeTask {
    public:
        Flow(const StiffModes& modes) : modes(modes) {}
        void apply(int begin, int end) const override;
        const ModeFlow* flows = nullptr;
        OpenMM::Vec3* positions = nullptr;
        OpenMM::Vec3* velocities = nullptr;
        /** sqrt(kT); zero means no noise. */
        double thermalScale = 0.0;
        const CounterRandom* random = nullptr;
        std::uint64_t stream = 0;

    private:
        const StiffModes& modes;
    };

private:
    struct Component {
        int firstParticle, numParticles; // into particleList
        int firstMode;                   // its 3 * numParticles modes start here
        size_t matrixOffset;             // its column-major eigenvector matrix in eigenvectors
        bool stiff;
        bool isotropic; // every block a multiple of the identity: n x n eigenvectors shared by x, y and z
    };
    std::vector<Component> components;
    std::vector<int> particleList;
    std::vector<double> sqrtMass, eigenvectors, omega, modeForce;
    std::vector<bool> stiffParticle;
    // Mode coordinates and velocities, one slice per component, so components can run in parallel.
    mutable std::vector<double> scratch;
};

} // namespace FlavorPlugin

#endif
