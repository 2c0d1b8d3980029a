#ifndef OPENMM_FLAVORS_STIFF_MODES_H_
#define OPENMM_FLAVORS_STIFF_MODES_H_

#include "CounterRandom.h"
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
    /**
     * The exact flow of every component over one step, mapped back to particle coordinates.  A component has D rows
     * (its particles when isotropic, else their 3n coordinates) and C = 3 or 1 columns, so its positions q and
     * velocities v are D x C row-major blocks, and one step is
     *
     *     q' = Axx q + Axv v + gx + Nxx xi1,    v' = Avx q + Avv v + gv + Nvx xi1 + Nvv xi2
     *
     * with xi1, xi2 standard normal per particle coordinate.  Each D x D matrix is U f(Omega) U^T with the masses
     * folded in, so the noise does not depend on which eigenvectors the solver picked in a degenerate subspace.  Small
     * components (those with a compiled flow) store these matrices, so applying them needs no change of basis; large
     * ones store only the diagonal f(Omega) and apply U^T and U around it.
     */
    struct Propagator {
        /**
         * For each component, where its part of data starts: Axx, Axv, Avx, Avv, gx, gv (and Nxx, Nvx, Nvv when noisy)
         * for a small component, the per-mode flow and the mode offsets for a large one.
         */
        std::vector<size_t> offset;
        std::vector<double> data;
        bool noisy = false;
    };
    /**
     * Computes the propagator over a step h with friction gamma and thermal energy kT; h < 0 is allowed for
     * gamma = 0 (the inverse flow).
     */
    void computePropagator(double h, double gamma, double kT, Propagator& propagator) const;

    /**
     * Applies a Propagator to positions and velocities, one component per index of the range.
     */
    class Flow : public RangeTask {
    public:
        Flow(const StiffModes& modes) : modes(modes) {}
        void apply(int begin, int end) const override;
        const Propagator* propagator = nullptr;
        OpenMM::Vec3* positions = nullptr;
        OpenMM::Vec3* velocities = nullptr;
        const CounterRandom* random = nullptr;
        std::uint64_t stream = 0;
        /**
         * When not null, the kick v += kickStep F / m that precedes the flow is applied as velocities are read
         * (inverseMasses per particle), saving a pass over the particles.
         */
        const OpenMM::Vec3* kickForces = nullptr;
        const double* inverseMasses = nullptr;
        double kickStep = 0.0;

    private:
        /** The general flow of a component too large for a compiled one. */
        void applyLarge(int component, const double* propagator) const;
        const StiffModes& modes;
    };

    /**
     * The flow of one small component, compiled for its size: its particles, its part of the propagator data and
     * the Flow being applied.
     */
    typedef void (*ComponentFlow)(const int* particles, const double* propagator, const Flow& flow);

private:
    struct Component {
        int firstParticle, numParticles; // into particleList
        int firstMode;                   // its 3 * numParticles modes start here
        size_t matrixOffset;             // its column-major eigenvector matrix in eigenvectors
        size_t scratchOffset;            // its slice of scratch (components without a compiled flow only)
        bool stiff;
        bool isotropic; // every block a multiple of the identity: n x n eigenvectors shared by x, y and z
        ComponentFlow flow, noisyFlow; // nullptr when the component is too large for a compiled flow
        int rows() const { return isotropic ? numParticles : 3 * numParticles; }
        int columns() const { return isotropic ? 3 : 1; }
    };
    std::vector<Component> components;
    std::vector<int> particleList;
    std::vector<double> sqrtMass, eigenvectors, omega, modeForce;
    std::vector<bool> stiffParticle;
    // Each component's incoming and outgoing positions and velocities and its noise, one slice per component so that
    // components can run in parallel.
    mutable std::vector<double> scratch;
};

} // namespace FlavorPlugin

#endif
