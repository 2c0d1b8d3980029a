#ifndef OPENMM_FLAVORS_STIFF_MODES_H_
#define OPENMM_FLAVORS_STIFF_MODES_H_

#include "internal/FlowSchedule.h"
#include "internal/windowsExportFlavors.h"
#include "openmm/Vec3.h"
#include <cstddef>
#include <functional>
#include <vector>

namespace FlavorPlugin {

/** The 3x3 block K_ij of a stiffness matrix, for particles i and j (K_ji is its transpose). */
struct StiffnessBlock {
    int i, j;
    double k[3][3];
};

/**
 * A quadratic stiff potential U(q) = q^T K q / 2 - b^T q, decomposed into independent normal modes (see
 * docs/ARCHITECTURE.md, "The exact stiff flow").  Particles coupled by nonzero blocks of K form connected components;
 * each component is diagonalized in mass-weighted coordinates, Omega = M^-1/2 K M^-1/2 = U diag(omega^2) U^T.  Every
 * other movable particle is a component of its own with three zero modes, so the free flow is the same code.
 *
 * This class describes the modes and computes their exact flow over a step (a Propagator); StiffFlowTask applies a
 * Propagator to particle data.
 */
class OPENMM_EXPORT_FLAVORS StiffModes {
public:
    /** One connected component of the coupling graph. */
    struct Component {
        /** Its particles are getComponentParticles(c)[0 .. numParticles). */
        int firstParticle, numParticles;
        /** Its 3 * numParticles modes start here (mode C k + col is mode k in column col). */
        int firstMode;
        /** Where its column-major rows() x rows() eigenvector matrix starts. */
        std::size_t matrixOffset;
        bool stiff;
        /** Every block a multiple of the identity: the rows() x rows() eigenvectors are shared by x, y and z. */
        bool isotropic;
        /** D: its particles when isotropic, else their 3n coordinates. */
        int rows() const { return isotropic ? numParticles : 3 * numParticles; }
        /** C: 3 when isotropic (x, y, z side by side), else 1. */
        int columns() const { return isotropic ? 3 : 1; }
    };

    /**
     * @param masses          the particle masses; massless particles do not move and belong to no component
     * @param blocks          the nonzero blocks K_ij with i <= j, between particles with mass
     * @param constantForce   b, the stiff force at q = 0
     * @throws OpenMMException if a block involves a massless particle or K has a negative eigenvalue
     */
    StiffModes(const std::vector<double>& masses, const std::vector<StiffnessBlock>& blocks,
               const std::vector<OpenMM::Vec3>& constantForce);
    int getNumComponents() const { return (int)components.size(); }
    const Component& getComponent(int c) const { return components[c]; }
    /** The particles of component c, in the order of its rows. */
    const int* getComponentParticles(int c) const { return &particleList[components[c].firstParticle]; }
    /** The column-major eigenvectors U of component c. */
    const double* getEigenvectors(int c) const { return &eigenvectors[components[c].matrixOffset]; }
    double getSqrtMass(int particle) const { return sqrtMass[particle]; }
    /**
     * The angular frequency of mode m (component c's mode k in column col is m = firstMode + columns() k + col);
     * exactly 0 for the zero modes, along which the stiff potential is flat.
     */
    double getModeFrequency(int mode) const { return omega[mode]; }
    /** The angular frequencies of the modes of components with nonzero stiffness, ascending. */
    std::vector<double> getStiffFrequencies() const;
    /** Whether particle i belongs to a component with nonzero stiffness. */
    bool isStiffParticle(int i) const { return stiffParticle[i]; }
    /**
     * Whether a component of D rows and C columns stores its propagator as particle-space matrices (small components,
     * applied by code compiled for their size) rather than per mode (large ones, applied through U^T and U).
     */
    static bool hasParticleSpacePropagator(int rows, int columns) {
        return (columns == 3 && rows >= 1 && rows <= MaxIsotropicRows) || (columns == 1 && (rows == 3 || rows == 6));
    }
    /** The largest isotropic component stored in particle space. */
    static constexpr int MaxIsotropicRows = 6;

    /**
     * The exact flow of every component over one step, mapped back to particle coordinates.  A component has D rows
     * and C columns, so its positions q and velocities v are D x C row-major blocks, and one step is
     *
     *     q' = Axx q + Axv v + gx + Nxx xi1,    v' = Avx q + Avv v + gv + Nvx xi1 + Nvv xi2
     *
     * with xi1, xi2 standard normal per particle coordinate.  Each D x D matrix is U f(Omega) U^T with the masses
     * folded in, so the noise does not depend on which eigenvectors the solver picked in a degenerate subspace.  Small
     * components store these matrices (PropagatorLayout); large ones store only the diagonal f(Omega) (ModeLayout).
     */
    struct Propagator {
        /** For each component, where its part of data starts. */
        std::vector<std::size_t> offset;
        std::vector<double> data;
        bool noisy = false;
    };
    /**
     * Computes the propagator over a step h.  The zero modes (omega = 0: free particles, a component's translations)
     * have friction gamma and thermal energy kT, the stiff modes (omega > 0) stiffGamma and stiffKT: friction that is
     * diagonal in the mode basis commutes with Omega, so every mode stays an independent, exactly integrated damped
     * oscillator.  h < 0 is allowed when both frictions are 0 (the inverse flow).  warped (h > 0): each stiff mode
     * flows at its warped frequency omega~ = warpedFrequency(omega, stiffGamma, h) instead of omega, with its constant
     * force scaled by (omega~/omega)^2 so that its equilibrium stays where the true potential has it (the Warped
     * splitting).  middleZeroModes (h > 0): the zero modes flow as computeMiddleFreeFlow (the Middle thermostat
     * placement) instead of the exact free flow.  warp (warped only): a mode whose warped frequency turns farther per
     * step than warp.maxPhase > 0 flows at maxPhase/h (phaseLimitedFrequency), its constant force scaled likewise;
     * with warp.scaledFriction its friction is stiffGamma scaled to its inertia (warpedMode).
     */
    void computePropagator(double h, double gamma, double kT, double stiffGamma, double stiffKT, Propagator& propagator,
                           bool warped = false, bool middleZeroModes = false,
                           const WarpedFlowSettings& warp = WarpedFlowSettings()) const;
    /**
     * How an impulse on a particle moves its component over a step: per mode, the position and velocity at the end of
     * the step per unit velocity change at its start (the flow's Phi_xv and Phi_vv) and the velocity per unit velocity
     * change at its end, each scaled by the mode's kick scale (the half kick of a Filtered step over h/2, see
     * computeForceResponse; 1 in zero modes and without Filtered kicks), so that a constraint force, given as impulses
     * at the ends of the step, acts on the stiff modes as the step's kicks make a soft force act.  With Middle zero
     * modes the impulse at the start is h times the force and holds both half kicks of the stiff modes at that
     * instant (the closing one of the last step and the opening one of this); the velocities at the step's end, which
     * the next impulse completes, are processed by the closing half kick of an impulse (per unit impulse, its last
     * value standing in for the next), added at the step's end and taken off at the next step's start.
     */
    struct ImpulseResponse {
        /** The blocks of getImpulseBlocks, in this order. */
        enum Block { ThroughX, ThroughV, AtEnd, Processing, NumBlocks };
        std::vector<std::size_t> offset;
        std::vector<double> data;
    };
    /**
     * Computes the impulse response of a step h whose flow is computePropagator's with the same arguments; filtered:
     * the step has Filtered kicks of kind kickResponse.
     */
    void computeImpulseResponse(double h, double gamma, double stiffGamma, bool warped, bool middleZeroModes,
                                const WarpedFlowSettings& warp, bool filtered, SubFlow::KickResponse kickResponse,
                                ImpulseResponse& response) const;
    /**
     * The 3 x 3 blocks of an impulse response that take a velocity change of particle source of component c (an index
     * into getComponentParticles(c)) to particle target: its position (ThroughX) and velocity (ThroughV) at the end of
     * the step for a change at the start, its velocity for a change at the end (AtEnd) and its velocity processing
     * (Processing).
     */
    void getImpulseBlocks(const ImpulseResponse& response, int c, int target, int source,
                          double blocks[ImpulseResponse::NumBlocks][3][3]) const;
    /**
     * The response of positions and velocities to a force F held by each mode: per component, for each of its D modes
     * k the pair (rx_k, rv_k), so that in mass-weighted mode coordinates x_k += rx_k f_k and v_k += rv_k f_k with
     * f = U^T M^-1/2 F (the C columns of an isotropic component share the pair).
     */
    struct ForceResponse {
        std::vector<std::size_t> offset;
        std::vector<double> data;
    };
    /**
     * Computes the force responses of the Filtered and Warped splittings over a step h > 0 (see
     * SubFlow::FilteredStiffFlow and FilteredKick): a half kick h/2 in each stiff mode (friction stiffGamma), scaled
     * by kappa with kappa h = (1 - Phi_vv) g_x/Phi_xv + g_v (response Scaled) or plain (Plain, where Phi is the flow
     * at the warped frequency), and plain in the zero modes (friction gamma).  The opening response (closing = false)
     * is the flow's image of the half kick, (Phi_xv, Phi_vv) (kappa h/2 + lambda), added after the flow with the
     * forces where it began; the closing one is (0, kappa h/2 - lambda).  lambda f is the velocity that the
     * constant-force fixed point has at the step's end with friction (0 without): moving it from the closing to the
     * next opening kick processes the velocities to the exact 0 and leaves positions unchanged (modes whose flow
     * turns by less than 0.9 pi per step only; lambda has poles at k pi).  middleZeroModes: the zero modes take a
     * full kick h in the opening response, as the image of the Middle free flow, and none in the closing one, so that
     * their velocities at the step's end are half-step velocities.  warp (Plain only): a mode whose warped flow is
     * slowed to warp.maxPhase per step (computePropagator) takes the half kicks kappa h/2 that keep its exact mean
     * with the slowed flow, instead of plain ones; with warp.scaledFriction, kicks and processing are those of the
     * flow with the scaled friction.
     */
    void computeForceResponse(double h, double gamma, double stiffGamma, bool closing,
                              SubFlow::KickResponse kickResponse, const WarpedFlowSettings& warp, bool middleZeroModes,
                              ForceResponse& response) const;
    /**
     * Computes the velocity processing of the Filtered splitting over a step h > 0.  Under a soft force that grows
     * steadily, f_n = f_0 + n s h, the Filtered step's positions are exact (x_n = f_n/omega^2) but its velocities at
     * the step ends are c s/omega^2 with c = kappa / sinc^2(omega h/2), not s/omega^2 (2.36 times it at omega h =
     * 2.07).  The closing response (0, -beta) with beta = (c - 1)/(omega^2 h), applied to the force change over the
     * step, makes them exact; the opening one, (Phi_xv, Phi_vv) beta, puts it back in the flow's image before the next
     * step, so positions are unchanged.  c is computed with the friction stiffGamma (the step's particular solution
     * for a linearly growing force, lambda f removed).  Zero modes and modes whose flow turns by 0.9 pi or more per
     * step: none.  With Plain kicks the same with the warped flow (c = xi~/sin xi~ without friction), limited by
     * warp as in computeForceResponse.
     */
    void computeVelocityProcessing(double h, double stiffGamma, bool closing, SubFlow::KickResponse kickResponse,
                                   const WarpedFlowSettings& warp, ForceResponse& response) const;
    /**
     * The propagator of a sub-flow over these modes, as every backend applies it: a StiffFlow or FilteredStiffFlow
     * with its frequencies (Warped or exact) and zero-mode flow (Middle's with friction where h > 0), a HarmonicFlow
     * (the exact fast flow) with exact frequencies and the exact zero-mode flow.
     */
    void computeFlowPropagator(const SubFlow& flow, Propagator& propagator) const;
    /** The force response and velocity processing of a FilteredStiffFlow or FilteredKick (closing). */
    void computeFlowResponses(const SubFlow& flow, ForceResponse& response, ForceResponse& processing) const;

private:
    /** Lays out response per mode (two values each) and fills each mode's pair with modeResponse(omega, pair). */
    void fillModeResponses(ForceResponse& response,
                           const std::function<void(double omega, double* out)>& modeResponse) const;
    std::vector<Component> components;
    std::vector<int> particleList;
    std::vector<double> sqrtMass, eigenvectors, omega, modeForce;
    std::vector<bool> stiffParticle;
};

/** The D x D matrices of a particle-space propagator. */
enum PropagatorMatrix { Axx, Axv, Avx, Avv, Nxx, Nvx, Nvv };

/**
 * Where the parts of a small component's propagator lie: the D x D particle-space matrices Axx, Axv, Avx, Avv, the
 * D x C offsets gx, gv, then Nxx, Nvx, Nvv if noisy.
 */
struct PropagatorLayout {
    std::size_t D, C;
    constexpr std::size_t matrix(PropagatorMatrix m) const {
        return m < Nxx ? m * D * D : 4 * D * D + 2 * D * C + (m - Nxx) * D * D;
    }
    constexpr std::size_t gx() const { return 4 * D * D; }
    constexpr std::size_t gv() const { return 4 * D * D + D * C; }
    constexpr std::size_t size(bool noisy) const { return (noisy ? 7 : 4) * D * D + 2 * D * C; }
};

/**
 * A large component's propagator stays in mode space, where it is diagonal: per mode k the 2 x 2 transition
 * (xx, xv, vx, vv) and, when noisy, the noise factor sqrt(kT) (lxx, lvx, lvv); then the D x C mode offsets gx, gv.
 * Applying it costs two products with the eigenvectors, instead of four to seven with D x D particle-space matrices
 * that would not fit in cache.
 */
struct ModeLayout {
    std::size_t D, C;
    static constexpr std::size_t Transition = 4, Noise = 3;
    constexpr std::size_t perMode(bool noisy) const { return noisy ? Transition + Noise : Transition; }
    constexpr std::size_t gx(bool noisy) const { return perMode(noisy) * D; }
    constexpr std::size_t gv(bool noisy) const { return perMode(noisy) * D + D * C; }
    constexpr std::size_t size(bool noisy) const { return perMode(noisy) * D + 2 * D * C; }
};

} // namespace FlavorPlugin

#endif
