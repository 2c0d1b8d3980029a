#ifndef OPENMM_STOCHASTIC_IMPULSE_INTEGRATOR_H_
#define OPENMM_STOCHASTIC_IMPULSE_INTEGRATOR_H_

#include "internal/StepKernelBinding.h"
#include "internal/windowsExportFlavors.h"
#include "openmm/Integrator.h"
#include "openmm/Kernel.h"
#include <iosfwd>
#include <string>
#include <vector>

namespace OpenMM {
class System;
}

namespace FlavorPlugin {

class IntegrateStochasticImpulseStepKernel;

/**
 * This is a stochastic impulse method (SIM) for Langevin dynamics with a quadratic stiff potential.  The forces in
 * the force groups of the bitmask stiffGroups must be linear in the positions (a quadratic potential such as
 * HarmonicBondForce with length 0); they are integrated by their exact flow together with exact friction and noise
 * (an Ornstein-Uhlenbeck process in every normal mode), and composed with kicks by all other (soft) forces.  The
 * error bound does not depend on the stiffness, so the step size is set by the soft forces.  With friction 0 it is
 * the deterministic impulse method with exact stiff flow.
 *
 * The stiffness matrix is measured from the stiff forces when the first step is taken, and again whenever a context
 * parameter changes or a force's updateParametersInContext() is called; call updateStiffModes() after any other
 * change to the stiff forces.
 *
 * Constraints may join a stiff component to particles outside it (rigid water whose oxygen is the core of a Drude
 * pair), with at most one constrained particle per stiff component; a constraint between two particles of one stiff
 * component is an error.  The constraints act as RATTLE makes them act around a drift: the constraint force is an
 * impulse on the constrained particle alone at the start of the stiff flow (the position correction) and at its end
 * (the velocity projection), and the component's exact flow carries it to the component's other particles (the
 * Drude particle's part of its core's constraint force, 2.5% in SWM4-NDP water, moves it within the step).  In the
 * stiff modes the impulses are scaled as the step's kicks are, so that under Filtered and Warped a constant constraint
 * force has the exact mean response, as a soft force has.  With the Middle placement the velocities a step returns
 * hold the closing half of the stiff modes' constraint impulse, estimated from the step's own and taken off by the
 * next step; it is part of the integrator's checkpoint.
 */
class OPENMM_EXPORT_FLAVORS StochasticImpulseIntegrator : public OpenMM::Integrator {
public:
    /**
     * How the soft kicks and the exact stiff flow are composed in each step.
     */
    enum Splitting {
        /** Stiff flow, then a soft kick: first order (Integrators 1 and 2 of the SIM paper). */
        LieTrotter = 0,
        /** Half kick, stiff flow, half kick: second order, symmetric (Integrator 3). */
        Strang = 1,
        /** The fourth-order composition of three Strang steps (Remark 2.4); only with friction 0. */
        Yoshida4 = 2,
        /**
         * Strang with each half kick scaled, in each stiff mode, by the filter kappa for which a constant soft force
         * has the exact mean displacement f/omega^2 (no impulse bias; any friction): a symmetric trigonometric
         * integrator, second order, one force evaluation per step.  Without friction kappa = tan(xi/2)/(xi/2),
         * xi = omega H, with poles at odd multiples of pi; keep omega H away from them.  Velocities are processed to
         * be exact for constant and steadily changing soft forces (modes with xi < 0.9 pi); after setPositions() or
         * setVelocities() the next step starts without the processing, as the first one does; checkpoints keep it.
         * docs/sim_drude.md section 3 derives it.
         */
        Filtered = 3,
        /**
         * Strang with plain half kicks and each stiff mode flowing at its warped frequency omega~ < omega, the one
         * for which a constant soft force has the exact mean displacement (no impulse bias; any friction).  The warped
         * mode turns by less than pi per step at any H and its kicks are not amplified, so it stays stable to longer
         * steps than Filtered and Strang where the soft forces couple the stiff modes (neighbouring Drude particles),
         * and it has no resonances; the price is stiff oscillations at omega~ (position variance kT/omega~^2).
         * Second order, symmetric; velocities processed as for Filtered.  docs/sim_drude.md section 4 derives it.
         */
        Warped = 4
    };
    /**
     * Where friction and noise act on the zero modes (a stiff component's centre of mass, free particles) in a step,
     * and which velocities a step returns for them.  The stiff modes (omega > 0) always have their exact flow.
     */
    enum ThermostatPlacement {
        /**
         * Throughout the step's flow: the exact Ornstein-Uhlenbeck flow of a free particle over H, between the two
         * half kicks (the default).  Its velocities are on-step ones.  For a soft harmonic motion of frequency Omega
         * the positions are spread as at T (1 + (Omega H)^2/12) and the step-end velocities as at
         * T (1 - (Omega H)^2/6): at H = 2.5 fs the librations of rigid water (Omega about 100-160/ps) read 1-2 % cold.
         */
        Throughout = 0,
        /**
         * As LangevinMiddleIntegrator: each zero mode drifts H/2, takes one exact Ornstein-Uhlenbeck step of H, and
         * drifts H/2, and its velocity is returned before the closing half kick (a half-step velocity), the kick
         * being applied with the next step's opening one as a full kick.  A soft harmonic motion is then sampled with
         * its exact positions and velocities at every stable H.  Velocities set on a Context are half-step
         * velocities, as for OpenMM's leapfrog integrators.  Only with the Filtered and Warped splittings, whose kicks
         * act mode by mode; other splittings are rejected when a step is taken.
         */
        Middle = 1
    };
    /**
     * Create a StochasticImpulseIntegrator.
     *
     * @param temperature    the temperature of the heat bath (in Kelvin)
     * @param frictionCoeff  the friction coefficient which couples the system to the heat bath (in inverse
     *                       picoseconds); 0 gives the deterministic impulse method
     * @param stepSize       the step size (in picoseconds)
     * @param stiffGroups    a bitmask of the force groups that are stiff (bit i set means group i is stiff)
     */
    StochasticImpulseIntegrator(double temperature, double frictionCoeff, double stepSize, int stiffGroups);
    /** Set the step size (in picoseconds).  It must be finite and positive. */
    void setStepSize(double size) override;
    /** Get the temperature of the heat bath (in Kelvin). */
    double getTemperature() const { return temperature; }
    /** Set the temperature of the heat bath (in Kelvin).  It must be finite and non-negative. */
    void setTemperature(double temp);
    /** Get the friction coefficient (in inverse picoseconds). */
    double getFriction() const { return friction; }
    /**
     * Set the friction coefficient (in inverse picoseconds).  It must be finite and non-negative, and 0 for the
     * Yoshida4 splitting.
     */
    void setFriction(double coeff);
    /**
     * Get the temperature (in Kelvin) of the exact Ornstein-Uhlenbeck flow of the stiff modes (the modes of the stiff
     * potential with angular frequency omega > 0).  Until setStiffModeTemperature() is called it is the integrator's
     * temperature, and follows it.
     */
    double getStiffModeTemperature() const { return stiffModeTemperature < 0 ? temperature : stiffModeTemperature; }
    /**
     * Set the temperature (in Kelvin) of the stiff modes, the modes of the stiff potential with angular frequency
     * omega > 0 (for a Drude pair: the motion of the Drude particle relative to its core).  The zero modes of the stiff
     * components (a pair's centre of mass) and every particle outside them keep the integrator's temperature.  A
     * friction that is diagonal in the normal-mode basis commutes with the stiffness, so each mode remains an exactly
     * integrated damped oscillator with its own bath: a cold Drude thermostat (about 1 K) is exact here.  It must be
     * finite and non-negative.
     */
    void setStiffModeTemperature(double temp);
    /**
     * Get the friction coefficient (in inverse picoseconds) of the stiff modes.  Until setStiffModeFriction() is
     * called it is the integrator's friction, and follows it.
     */
    double getStiffModeFriction() const { return stiffModeFriction < 0 ? friction : stiffModeFriction; }
    /**
     * Set the friction coefficient (in inverse picoseconds) of the stiff modes (omega > 0); the zero modes and the
     * particles outside stiff components keep the integrator's friction.  It must be finite and non-negative, and 0
     * for the Yoshida4 splitting.
     */
    void setStiffModeFriction(double coeff);
    /** Whether setStiffModeTemperature() has been called (otherwise the stiff modes follow getTemperature()). */
    bool hasStiffModeTemperature() const { return stiffModeTemperature >= 0; }
    /** Whether setStiffModeFriction() has been called (otherwise the stiff modes follow getFriction()). */
    bool hasStiffModeFriction() const { return stiffModeFriction >= 0; }
    /** Get the bitmask of stiff force groups. */
    int getStiffGroups() const { return stiffGroups; }
    /**
     * Set the bitmask of stiff force groups.  It must be nonzero.  If the integrator is bound to a Context, the
     * System must contain at least one force in these groups, and every stiff group must be an integration force
     * group.
     */
    void setStiffGroups(int groups);
    /**
     * Set the force groups the integrator integrates (a bitmask; all by default).  Forces outside them are ignored,
     * as by OpenMM's integrators, but every stiff group must be one of them: setting a mask that leaves a stiff
     * group out throws an OpenMMException while the integrator is bound to a Context, and Context creation throws
     * one for an integrator configured that way.
     */
    void setIntegrationForceGroups(int groups) override;
    /** Get the splitting. */
    Splitting getSplitting() const { return splitting; }
    /** Set the splitting (Yoshida4 requires friction 0: its middle substep runs backwards in time). */
    void setSplitting(Splitting splitting);
    /** Get where friction and noise act on the zero modes (see ThermostatPlacement). */
    ThermostatPlacement getThermostatPlacement() const { return thermostatPlacement; }
    /**
     * Set where friction and noise act on the zero modes: Throughout (the default) or Middle (with the Filtered and
     * Warped splittings only; checked when a step is taken).
     */
    void setThermostatPlacement(ThermostatPlacement placement);
    /**
     * Get the largest angle (in radians) a stiff mode of the Warped splitting turns per step: 0 (the default) for a
     * limit the integrator chooses from the System, pi for none.  See setMaxWarpedPhase().
     */
    double getMaxWarpedPhase() const { return maxWarpedPhase; }
    /**
     * Limit the angle omega~ H (in radians) that each stiff mode of the Warped splitting turns per step.  A mode whose
     * warped frequency turns farther flows at omega~ = maxWarpedPhase/H instead, and the half kicks along it are
     * scaled so that a constant soft force keeps the exact mean displacement f/omega^2.  Any such step is symmetric
     * and, with a soft stiffness r k along the mode, stable while (1 + r) sin^2(omega~ H/2) < 1: the limit keeps the
     * stability that the warp has at a shorter step (for SWM4-NDP water, whose Drude-Drude coupling reaches r = 0.5-
     * 0.66, the 2.05 that Warped has at 2.5 fs) at longer steps.  The price is a slower stiff mode: it follows a
     * soft force that changes at frequency Omega as a spring of frequency about omega~ would, so the lag grows as
     * (Omega/omega~)^2.  It must be 0, pi or between them; only the Warped splitting takes a nonzero value (checked
     * when a step is taken).  docs/sim_drude.md section 6 measures it.
     *
     * 0 (the default) lets the integrator choose the limit where the first step starts (and again after anything that
     * measures the stiff modes again): 2 asin(1/sqrt(1 + r)) for the largest soft stiffness r k along the stiff modes
     * at the Context's positions, measured by Lanczos iterations of central differences of the soft forces in a copy
     * of the System on the CPU platform (a fraction of a second for SWM4-NDP water, seconds for a protein).  It binds
     * only the modes that Warped would turn farther, so a step that Warped holds is unchanged; describeContext() says
     * what was chosen.  Minimize the energy before the first step: at unrelaxed positions r reads far too high.  pi
     * means no limit: Warped's own step.
     */
    void setMaxWarpedPhase(double phase);
    /**
     * Get whether the Warped splitting scales each stiff mode's friction to the mode's effective inertia (false by
     * default).  See setWarpedFrictionScaling().
     */
    bool getWarpedFrictionScaling() const { return warpedFrictionScaling; }
    /**
     * Set whether the Warped splitting scales each stiff mode's friction to the mode's effective inertia.  A Warped
     * step (with or without setMaxWarpedPhase()) keeps a stiff mode's exact mean, but the mode follows a soft force
     * that changes slowly as a particle (omega/omega_d)^2 times heavier would, omega_d = 2 sin(omega~ H/2)/H with
     * omega~ the frequency it flows at.  Under the stiff modes' friction gamma such a heavier particle feels a friction
     * force that much larger and draws that much more heat from the motion that drives it: with a cold Drude bath
     * (setStiffModeTemperature()) the molecules around it run cool, by about 1 % in SWM4-NDP water at H = 2.5 fs and
     * by 1-2.5 % past it.  With scaling on, each stiff mode flows with the friction gamma (omega_d/omega)^2, so that
     * the friction force on it, and the heat its bath draws, are the true mode's for a given velocity; its stationary
     * distribution at the stiff-mode temperature and its exact mean are unchanged, and it relaxes to its bath
     * (omega_d/omega)^2 times as fast.  Only the Warped splitting takes true (checked when a step is taken).
     * docs/sim_drude.md section 7 derives and measures it.
     */
    void setWarpedFrictionScaling(bool scaled) { warpedFrictionScaling = scaled; }
    /**
     * Get the hard wall of the stiff pairs (in nm), 0 (the default) for none.  See setMaxDrudeDistance().
     */
    double getMaxDrudeDistance() const { return maxDrudeDistance; }
    /**
     * Set a hard wall for the stiff pairs, as DrudeLangevinIntegrator::setMaxDrudeDistance: every stiff component of
     * two particles (a Drude particle, the lighter, and its parent, with the spring in a stiff group) that is farther
     * apart than distance at the step's final positions is put back inside the wall, by its overshoot and the distance
     * the thermal speed sqrt(kT/m) of the stiff-mode temperature covers in a step, and its relative radial velocity is
     * set to that speed, pointing inward (DrudeLangevinIntegrator reverses the radial velocity's sign instead), with
     * the pair's centre-of-mass velocity kept.  A constrained or massless parent keeps its position and velocity, and
     * the Drude particle moves inward relative to it.  The positions are set before the step's closing kick, which then
     * reads the forces at the walled positions (the next step reuses them: one force evaluation per step, as without
     * the wall); the velocities after it, where in a kick-flow-kick step they carry the pair's motion (before the kick
     * a pair held out by its field moves inward at (H/2) F/m, which the kick cancels).  The exact flow of the quadratic
     * stiff potential is untouched: the wall acts only on pairs past it, whose motion it replaces by this reset (a
     * safeguard against polarization catastrophe, not part of the dynamics).  A pair found farther than twice the wall
     * makes the step throw, with the Context as the step's flow left it.  It must be finite and non-negative; 0
     * switches it off.
     */
    void setMaxDrudeDistance(double distance);
    /**
     * Get whether each step is a Metropolis-adjusted proposal (false by default).  See setMetropolis().
     */
    bool getMetropolis() const { return metropolis; }
    /**
     * Make each step a Metropolis-adjusted proposal (FLAVORS paper, section 4.2.3), which samples the Boltzmann
     * distribution of the integrated forces exactly at any step size.  The step becomes O(H/2) [P] O(H/2)
     * (generalized hybrid Monte Carlo): the Ornstein-Uhlenbeck thermostat over half the step on every particle
     * outside, and the splitting without friction as the proposal P.  P is accepted with probability
     * min(1, exp(-dH/kT)), dH the change of the total energy H = U + K (U of every integrated force group); on
     * rejection the positions are put back and the velocities reversed.  With friction 0 each step is a plain
     * accept-or-reject of the splitting's step.  The soft energy is evaluated with the soft forces the step needs
     * anyway; the stiff energy is one evaluation of the stiff groups.
     *
     * The proposal must be reversible and volume-preserving: Strang, Yoshida4 and Filtered qualify (kicks and
     * filtered kicks are shears, the exact flow a linear map of determinant 1, composed symmetrically).  A step
     * throws an OpenMMException, and changes nothing, with LieTrotter (not symmetric), Warped (its step, as built,
     * misses its start when reversed by about 1e-3 of a stiff mode's amplitude), the
     * Middle placement (the thermostat is outside the proposal), a stiff-mode temperature or friction other than the
     * integrator's (one Boltzmann target, one thermostat on whole particles), System constraints (reversible only to
     * the constraint tolerance) or a temperature of 0.  getAcceptanceRate() reports the fraction accepted.
     */
    void setMetropolis(bool metropolis) { this->metropolis = metropolis; }
    /**
     * Get the fraction of the Metropolis-adjusted proposals accepted since the Context was created (a checkpoint
     * carries the counts), or NaN if none was made.
     *
     * @throws OpenMMException if the integrator is not bound to a Context
     */
    double getAcceptanceRate() const;
    /** Get the random number seed.  See setRandomNumberSeed() for details. */
    int getRandomNumberSeed() const { return randomNumberSeed; }
    /**
     * Set the random number seed.  The same seed on the same platform gives the same random forces.  If seed is 0
     * (the default), a unique seed is chosen when a Context is created from this Integrator.
     */
    void setRandomNumberSeed(int seed) { randomNumberSeed = seed; }
    /**
     * Get the angular frequencies (in 1/ps) of all modes of the stiff potential, in ascending order.  The
     * integrator must be bound to a Context whose positions are set.  Step sizes H with omega*H near a multiple of
     * pi resonate (SIM paper, section 3.3) when friction is small.
     */
    std::vector<double> getStiffModeFrequencies();
    /**
     * Get the step this integrator takes with its current settings as one line of text, its sub-flows applied left to
     * right (docs/ARCHITECTURE.md lists the notation), followed by the baths, e.g. for the Warped splitting with the
     * Middle placement "K_S(H/2) E^ω̃M(H) K_S(H/2)   [E: zero modes 300 K, 5/ps, stiff modes 1 K, 20/ps]".
     */
    std::string describeStep() const;
    /**
     * Describe how this integrator treats the Context it is bound to, one item a line: the step (describeStep()),
     * every force of the System with its force group and whether it is stiff, soft or not integrated, and the stiff
     * modes: how many, their angular frequencies omega and omega H as a multiple of pi (keep it away from multiples of
     * pi without friction).  It measures the stiff modes if needed.
     *
     * @throws OpenMMException if the integrator is not bound to a Context
     */
    std::string describeContext();
    /**
     * Describe what in the Context's configuration runs but is probably not what was meant (empty when nothing, when
     * the integrator is not bound to a Context, or when the System has no soft force, where every step is the exact
     * flow): stiff modes whose omega*H lies in a resonance band of the splitting, |omega H - k pi| <= 0.05 k pi
     * (Strang, LieTrotter and the substeps of Yoshida4 at every k unless the stiff-mode friction gamma has gamma H >=
     * 0.05 k pi; Filtered at odd k; Warped never).  It measures the stiff modes if needed.  Python emits the result as
     * openmmflavors.ResonanceWarning at the first step and after the step size, friction or splitting changes.
     */
    std::vector<std::string> getConfigurationWarnings();
    /**
     * Measure the stiff potential again.  Call it after changing the stiff forces in a way the Context is not told
     * about.
     */
    void updateStiffModes();
    /**
     * Split the springs of every DrudeForce of a System so that the integrator can take them as stiff: the isotropic
     * spring of each Drude particle, 0.5 k |d|^2 with d the Drude particle's displacement from its parent and
     * k = q^2/(4 pi eps0 alpha a3) (a3 = 3 - aniso12 - aniso34, each aniso taken as 1 where its axis is not given), is
     * exactly quadratic and goes into a new HarmonicBondForce of length 0 in force group stiffGroup.  Everything else
     * the DrudeForce computes stays soft in its own force group: the anisotropic terms, which depend on the parent's
     * neighbours (quadratic in d only at fixed axes), and the Thole screening between Drude pairs.  The DrudeForce
     * itself is left as it is (its charges, polarizabilities and screened pairs are needed by the screening, and tools
     * find the Drude pairs through it); a new CustomBondForce in its group, with the energy -0.5 k r^2 on the same
     * pairs, cancels its isotropic springs.  The System's energy and forces are unchanged to rounding.
     *
     * Use stiffGroup as the integrator's stiff group (or one of them) and leave the DrudeForce's group soft.  The
     * anisotropic terms stay soft: a stiff flow for springs that are quadratic only at fixed axes would be future work
     * in the engine.  Call it once, before the Context is created.
     *
     * @param system      the System to change; it must contain a DrudeForce and must not have been separated before
     * @param stiffGroup  the force group of the new isotropic springs (0 to 31), not the group of a DrudeForce
     * @throws OpenMMException naming the parameter, its value and what is allowed, leaving the System unchanged
     */
    static void separateDrudeSprings(OpenMM::System& system, int stiffGroup);
    /**
     * Advance a simulation through time by taking a series of time steps.
     *
     * @param steps   the number of time steps to take
     */
    void step(int steps) override;

protected:
    void initialize(OpenMM::ContextImpl& context) override;
    void cleanup() override;
    std::vector<std::string> getKernelNames() override;
    void stateChanged(OpenMM::State::DataType changed) override;
    double computeKineticEnergy() override;
    bool kineticEnergyRequiresForce() const override { return false; }
    /**
     * Random velocities for Context::setVelocitiesToTemperature().  Once setStiffModeTemperature() has been called,
     * drawn as OpenMM's Drude integrators draw them: the particles that the two-particle terms of the stiff groups link
     * (HarmonicBondForce and CustomBondForce bonds, DrudeForce pairs: a Drude particle and its core) move as components
     * whose centre of mass is at temperature and whose relative motion is at the stiff-mode temperature; every other
     * particle at temperature.  Otherwise every particle at temperature, as for any integrator.
     *
     * @param system       the System whose particles are given velocities
     * @param temperature  the temperature (K) of every motion but the stiff components' relative motion
     * @param randomSeed   the seed of the draw
     */
    std::vector<OpenMM::Vec3> getVelocitiesForTemperature(const OpenMM::System& system, double temperature,
                                                          int randomSeed) const override;
    void createCheckpoint(std::ostream& stream) const override;
    void loadCheckpoint(std::istream& stream) override;

private:
    double temperature, friction;
    // Negative: not set, the stiff modes use temperature and friction.
    double stiffModeTemperature, stiffModeFriction;
    int stiffGroups;
    Splitting splitting;
    ThermostatPlacement thermostatPlacement;
    int randomNumberSeed;
    bool metropolis = false;
    double maxDrudeDistance = 0.0;
    double maxWarpedPhase = 0.0;
    bool warpedFrictionScaling = false;
    // The kernel's life cycle with the Context (StepKernelBinding), and its implementation.
    StepKernelBinding binding;
    IntegrateStochasticImpulseStepKernel* stepKernel;
};

} // namespace FlavorPlugin

#endif
