#ifndef OPENMM_FLAVOR_INTEGRATOR_H_
#define OPENMM_FLAVOR_INTEGRATOR_H_

#include "internal/StepKernelBinding.h"
#include "internal/windowsExportFlavors.h"
#include "openmm/Integrator.h"
#include "openmm/Kernel.h"
#include <cstdint>
#include <iosfwd>
#include <string>
#include <utility>
#include <vector>

namespace OpenMM {
class System;
}

namespace FlavorPlugin {

class IntegrateFlavorStepKernel;

/**
 * This is a flow-averaging integrator (FLAVOR) for systems with stiff and soft forces.  Every force whose
 * force group is in the bitmask stiffGroups is stiff; every other force is soft, and no force group is ever
 * ignored.  Each step advances time by the mesostep (the step size): the stiff forces act together with the
 * soft ones for a total time equal to the microstep, and the soft forces alone act for the rest of the
 * mesostep.  With microstep << 1/(stiff frequency) << mesostep the slow variables are accurate and the fast ones
 * are correct in distribution, at a cost set by the slow time scale.
 *
 * Two schemes are available: SymplecticEuler (symplectic, first order) and Verlet (symplectic and
 * time-reversible, the default).  Setting the microstep equal to the mesostep reduces them to plain symplectic
 * Euler and velocity Verlet.  Velocities are synchronous with positions.
 *
 * With a nonzero friction the integrator is a Langevin FLAVOR: friction and noise are applied as exact
 * Ornstein-Uhlenbeck steps, either over the whole mesostep (the default) or, if stiff friction is enabled, only
 * while the stiff forces are on; at the edges of the mesostep (the default) or, for the artificial Verlet scheme, in
 * the middle of the step's drifts (setThermostatPlacement(Middle), where velocities are LangevinMiddleIntegrator's,
 * those of the middle of the step's drift).
 */
class OPENMM_EXPORT_FLAVORS FlavorIntegrator : public OpenMM::Integrator {
public:
    /**
     * The flow composition used for each mesostep.
     */
    enum Scheme {
        /** K_all(tau) D(tau) K_soft(delta-tau) D(delta-tau): symplectic, first order. */
        SymplecticEuler = 0,
        /** The symmetric (Strang) composition: symplectic and time-reversible. */
        Verlet = 1
    };
    /**
     * What the stiff degrees of freedom do while the stiff forces are off (for mesostep - microstep in each
     * mesostep).
     */
    enum Averaging {
        /**
         * The stiff forces are switched off and every coordinate keeps moving (the nonintrusive FLAVOR, the
         * default).  It integrates the stiff forces weighted by microStep/mesoStep.
         */
        Nonintrusive = 0,
        /**
         * The stiff degrees of freedom are frozen instead (the artificial FLAVOR): each mesostep is a soft kick over
         * the mesostep, a microstep of the fast Hamiltonian, and a drift for the rest of the mesostep in which the
         * frozen coordinates and their conjugate momenta are held, which leaves the canonical distribution of the
         * flexible system invariant.  What freezes: for a quadratic stiff group, the nonzero modes of its stiffness
         * matrix; otherwise the distances of the stiff bonded forces (bonds, the independent 1-3 distances of angles,
         * those added with addFrozenDistance()), held by RATTLE steps beside the System's constraints.  A stiff force
         * that can never be frozen (nonbonded forces, torsions) is an error when the Context is created.  Angles at
         * planar centres belong with the soft forces (separatePlanarAngles()).  docs/USER_GUIDE.md gives the details.
         */
        Artificial = 1,
        /**
         * As Artificial, but the soft impulse's component along the frozen coordinates is weighted by
         * microStep/mesoStep: the frozen coordinates feel the soft forces only for the time they move.
         */
        ArtificialProjected = 2
    };
    /**
     * Where friction and noise act in a Langevin mesostep of the artificial Verlet scheme.
     */
    enum ThermostatPlacement {
        /**
         * Over half the mesostep at each end of the mesostep (eqs. (4.9) and (4.10) of the FLAVORS paper; the
         * default).  The stiff microstep is then an O-B-A-B-O step, whose stationary variance of a harmonic stiff
         * coordinate of frequency omega is too large by the factor 1/(1 - (omega tau/2)^2): +3 % for O-H bonds at
         * tau = 0.5 fs.
         */
        Edges = 0,
        /**
         * Over the mesostep in the middle of the step's drifts, as LangevinMiddleIntegrator places it, for the soft
         * and the stiff time scale at once: each mesostep is K_soft(delta) frozen drift((delta-tau)/2) K_stiff(tau)
         * D(tau/2) O D(tau/2) frozen drift((delta-tau)/2).  For the stiff coordinates (which the frozen drifts and
         * the soft kick leave where they are) it is B-A-O-A over tau, for the others B-A-O-A over delta, so that
         * harmonic coordinates of either kind are sampled with their exact variance for every tau and delta (the
         * Edges step widens both), and with tau = delta the step is LangevinMiddleIntegrator's.  Velocities are
         * those after the thermostat (as LangevinMiddleIntegrator's).  It needs the Verlet scheme, an artificial
         * averaging and the symplectic fast microstep (setExactFastFlow(false)); other combinations are rejected when
         * a step is taken.
         */
        Middle = 1
    };
    /**
     * Create a FlavorIntegrator.
     *
     * @param mesoStep     the mesostep delta, which is the step size (in picoseconds)
     * @param microStep    the microstep tau for which the stiff forces act in each mesostep (in picoseconds,
     *                     0 < microStep <= mesoStep)
     * @param stiffGroups  a bitmask of the force groups that are stiff (bit i set means group i is stiff)
     */
    FlavorIntegrator(double mesoStep, double microStep, int stiffGroups);
    /**
     * Get the mesostep delta (in picoseconds).  This is the same as getStepSize().
     */
    double getMesoStep() const { return getStepSize(); }
    /**
     * Set the mesostep delta (in picoseconds).  It must be finite and at least the microstep.
     */
    void setMesoStep(double size);
    /**
     * Set the step size, which is the mesostep delta (in picoseconds).
     */
    void setStepSize(double size) override;
    /**
     * Get the microstep tau (in picoseconds).
     */
    double getMicroStep() const { return microStep; }
    /**
     * Set the microstep tau (in picoseconds).  It must be finite, positive and at most the mesostep.
     */
    void setMicroStep(double size);
    /**
     * Get the bitmask of stiff force groups.
     */
    int getStiffGroups() const { return stiffGroups; }
    /**
     * Set the bitmask of stiff force groups.  It must be nonzero.  If the integrator is bound to a Context, the
     * System must contain at least one force in these groups and one soft force (a force in an integration force
     * group that is not stiff), and every stiff group must be an integration force group.
     */
    void setStiffGroups(int groups);
    /**
     * Set the force groups the integrator integrates (a bitmask; all by default).  Forces outside them are ignored,
     * as by OpenMM's integrators, but every stiff group must be one of them: setting a mask that leaves a stiff
     * group out throws an OpenMMException while the integrator is bound to a Context, and Context creation throws
     * one for an integrator configured that way.  A soft force must remain, as for setStiffGroups().
     */
    void setIntegrationForceGroups(int groups) override;
    /**
     * Get the scheme used for each mesostep.
     */
    Scheme getScheme() const { return scheme; }
    /**
     * Set the scheme used for each mesostep.
     */
    void setScheme(Scheme scheme);
    /**
     * Get what the stiff degrees of freedom do while the stiff forces are off.
     */
    Averaging getAveraging() const { return averaging; }
    /**
     * Set what the stiff degrees of freedom do while the stiff forces are off: Nonintrusive (the default),
     * Artificial or ArtificialProjected.
     */
    void setAveraging(Averaging averaging);
    /**
     * Get whether the artificial FLAVOR's microstep of the fast Hamiltonian is the exact flow of the quadratic stiff
     * potential (true) or a symplectic step with the stiff forces (false, the default).
     */
    bool getExactFastFlow() const { return exactFastFlow; }
    /**
     * Set whether the artificial FLAVOR's microstep of the fast Hamiltonian is the exact flow of the quadratic stiff
     * potential.  It applies only to the Artificial and ArtificialProjected averagings; the stiff group must be
     * quadratic (measured when the first step is taken).
     */
    void setExactFastFlow(bool exact);
    /**
     * Get the name of the Context global parameter that carries the stiff clock, or "" if there is none (the
     * default).  See setStiffClockParameter().
     */
    const std::string& getStiffClockParameter() const { return stiffClockParameter; }
    /**
     * Synchronize a time-dependent stiff force on the tau time scale (FLAVORS paper, eq. (6.15)): before every
     * evaluation of forces that include a stiff group, the Context global parameter name is set to the stiff clock,
     * in ps: n tau for the n-th mesostep since the Context's time origin, plus the stiff time within the current
     * microstep at which the kick acts (0 for the opening kick, tau for the closing kick of the Verlet scheme).  The
     * stiff clock advances tau per mesostep while the Context's time advances delta; with tau = delta it is the
     * physical time.  Evaluations of the soft groups alone leave the parameter as it is: only stiff forces may read
     * it (a soft force that depends on time needs a parameter of its own, set to the Context's time).
     *
     * The clock starts at the Context's time times tau/delta at the first step, whenever the time is set from
     * outside and whenever tau or delta changes, and a checkpoint carries it (the continuation is identical).  It
     * needs the Nonintrusive averaging; a step with another averaging throws.  An empty name (the default) switches
     * it off.
     *
     * @throws OpenMMException if the integrator is bound to a Context that has no global parameter name; the
     *         integrator then keeps its previous setting.  Creating a Context checks the same.
     */
    void setStiffClockParameter(const std::string& name);
    /**
     * Get whether each mesostep is a Metropolis-adjusted proposal (false by default).  See setMetropolis().
     */
    bool getMetropolis() const { return metropolis; }
    /**
     * Make each mesostep a Metropolis-adjusted proposal (FLAVORS paper, section 4.2.3), which samples the Boltzmann
     * distribution of the integrated forces exactly at any step size.  The step becomes O(delta/2) [P] O(delta/2)
     * (generalized hybrid Monte Carlo): the Ornstein-Uhlenbeck thermostat over half the mesostep outside, and the
     * scheme without friction as the proposal P.  P is accepted with probability min(1, exp(-dH/kT)), dH the change
     * of the total energy H = U + K (U of every integrated force group); on rejection the positions are put back and
     * the velocities reversed.  With friction 0 each step is a plain accept-or-reject of the scheme's step.  The
     * energy is evaluated with the forces the step needs anyway, so the cost is that of an energy term, not of a
     * force evaluation.
     *
     * The proposal must be reversible and volume-preserving: the Verlet scheme with the Nonintrusive averaging, or
     * with an artificial averaging whose stiff groups are quadratic (their stiff modes freeze linearly), qualify.
     * With the Nonintrusive averaging the stiff coordinates drift over delta under only tau of stiff force, so where
     * omega delta >> 1 nearly every proposal is rejected; the artificial averagings hold the stiff modes over
     * delta - tau and keep a useful acceptance there (docs/USER_GUIDE.md gives measured rates).  A
     * step throws an OpenMMException, and changes nothing, with the SymplecticEuler scheme (not symmetric, so not
     * reversible), frozen bonded distances (held by an iterative solve, reversible only to its tolerance), System
     * constraints (the same), a stiff clock (no conserved energy), the Middle placement or stiff friction (the
     * thermostat is outside the proposal), or a temperature of 0.  getAcceptanceRate() reports the fraction accepted.
     */
    void setMetropolis(bool metropolis) { this->metropolis = metropolis; }
    /**
     * Get the fraction of the Metropolis-adjusted proposals accepted since the Context was created (a checkpoint
     * carries the counts), or NaN if none was made.
     *
     * @throws OpenMMException if the integrator is not bound to a Context
     */
    double getAcceptanceRate() const;
    /**
     * Freeze the distance between two particles during the artificial FLAVOR's frozen drift, in addition to the
     * distances the stiff bonded forces determine.  Needed when a stiff force of another type (e.g. a
     * CustomCompoundBondForce) is not quadratic.
     *
     * @param particle1  the index of the first particle
     * @param particle2  the index of the second particle (different from particle1)
     * @return the index of the frozen distance that was added
     */
    int addFrozenDistance(int particle1, int particle2);
    /**
     * Get the number of distances added with addFrozenDistance().
     */
    int getNumFrozenDistances() const { return (int)frozenDistances.size(); }
    /**
     * Get the particles of a distance added with addFrozenDistance().
     */
    void getFrozenDistance(int index, int& particle1, int& particle2) const;
    /**
     * Move the angles of every planar centre of a System's HarmonicAngleForces into a new HarmonicAngleForce in force
     * group group, so that the artificial FLAVOR integrates them with the soft forces when the other angles are
     * stiff.  A planar centre is a particle that is the centre of exactly three angles, with three distinct
     * neighbours, whose equilibrium angles add up to at least minAngleSum (sp2 carbons and nitrogens: carbonyls,
     * amides, aromatic rings).  Distances cannot hold such a centre: at planarity its motion out of its neighbours'
     * plane changes none of its distances at first order, so frozen 1-3 distances would leave that motion free while
     * its stiff angles resist it, and the frozen stage would feed energy into it.
     *
     * The moved angles keep their place in their original force with force constant 0 (so that pointers to the
     * forces and angle indices stay valid); the frozen set leaves out bonds and angles whose force constant is 0.
     * HarmonicAngleForces already in group are left as they are, so a second call moves nothing.  Call it before
     * the Context is created.
     *
     * @param system       the System to change
     * @param group        the force group of the new HarmonicAngleForce (0 to 31; a soft group of the integrator)
     * @param minAngleSum  the smallest sum of a centre's three equilibrium angles (in radians) that makes it planar;
     *                     the default, 350 degrees, separates sp2 (360 degrees) from sp3 centres (about 328 degrees)
     * @return the number of angles moved (0 if none: then no force is added)
     */
    static int separatePlanarAngles(OpenMM::System& system, int group, double minAngleSum = 6.1086523819801535);
    /**
     * Describe what in the Context's configuration runs but is probably not what was meant, one sentence each (empty
     * when nothing, or when the integrator is not bound to a Context): a nonbonded force in a stiff group of the
     * nonintrusive FLAVOR (usually a bitmask given where a group number was meant), and a mesostep longer than any
     * measured as accurate for an artificial FLAVOR with frozen angles.  Python emits them as
     * openmmflavors.FlavorsWarning at the first step.
     */
    std::vector<std::string> getConfigurationWarnings() const;
    /**
     * Get the temperature of the heat bath (in Kelvin).
     */
    double getTemperature() const { return temperature; }
    /**
     * Set the temperature of the heat bath (in Kelvin).  It must be finite and non-negative.
     */
    void setTemperature(double temp);
    /**
     * Get the friction coefficient (in inverse picoseconds).  Zero means the Hamiltonian schemes.
     */
    double getFriction() const { return friction; }
    /**
     * Set the friction coefficient (in inverse picoseconds).  It must be finite and non-negative; zero means no
     * friction and no noise.
     */
    void setFriction(double coeff);
    /**
     * Get whether friction and noise act only while the stiff forces are on (true) or over the whole mesostep
     * (false, the default).
     */
    bool getStiffFriction() const { return stiffFriction; }
    /**
     * Set whether friction and noise act only while the stiff forces are on, a total time equal to the
     * microstep in each mesostep (true), or over the whole mesostep (false).
     */
    void setStiffFriction(bool stiff);
    /**
     * Get the particles that friction and noise act on.  An empty list (the default) means every particle.
     */
    const std::vector<int>& getFrictionParticles() const { return frictionParticles; }
    /**
     * Get where friction and noise act in a Langevin mesostep.
     */
    ThermostatPlacement getThermostatPlacement() const { return thermostatPlacement; }
    /**
     * Set where friction and noise act in a Langevin mesostep: Edges (the default) or Middle.  Middle applies to the
     * Verlet scheme with an artificial averaging and the symplectic fast microstep; a step taken with another
     * combination throws an OpenMMException (the Context stays usable).
     */
    void setThermostatPlacement(ThermostatPlacement placement);
    /**
     * Restrict friction and noise to the given particles (an empty list means every particle).  The other particles
     * follow the Hamiltonian scheme.  Indices must be non-negative, distinct and, once the integrator is bound to a
     * Context, less than the number of particles.
     */
    void setFrictionParticles(const std::vector<int>& particles);
    /**
     * Get the mesostep this integrator takes with its current settings as one line of text, its sub-flows applied
     * left to right (docs/ARCHITECTURE.md lists the notation), followed by the bath and what the frozen drifts hold,
     * e.g. for the artificial FLAVOR with the Middle placement "K_S(δ) θ((δ−τ)/2) K_F(τ) D(τ/2) O(δ) D(τ/2)
     * θ((δ−τ)/2)   [O: 300 K, 1/ps; θ holds the stiff bonded distances]".  What freezes is measured when the first
     * step starts; before that the text says which of the two it will be.
     */
    std::string describeStep() const;
    /**
     * Describe how this integrator treats the Context it is bound to, one item a line: the step (describeStep()),
     * every force of the System with its force group and whether it is stiff, soft or not integrated, and what the
     * artificial averagings freeze (how many distances or stiff modes, once the first step has measured it).
     *
     * @throws OpenMMException if the integrator is not bound to a Context
     */
    std::string describeContext() const;
    /**
     * Get the random number seed.  See setRandomNumberSeed() for details.
     */
    int getRandomNumberSeed() const { return randomNumberSeed; }
    /**
     * Set the random number seed.  If two simulations use different seeds, their random forces differ.  The same
     * seed on the same platform gives the same random forces.  If seed is 0 (the default), a unique seed is
     * chosen when a Context is created from this Integrator.
     */
    void setRandomNumberSeed(int seed) { randomNumberSeed = seed; }
    /**
     * Advance a simulation through time by taking a series of mesosteps.
     *
     * @param steps   the number of mesosteps to take
     */
    void step(int steps) override;

protected:
    void initialize(OpenMM::ContextImpl& context) override;
    void cleanup() override;
    std::vector<std::string> getKernelNames() override;
    void stateChanged(OpenMM::State::DataType changed) override;
    double computeKineticEnergy() override;
    bool kineticEnergyRequiresForce() const override { return false; }
    void createCheckpoint(std::ostream& stream) const override;
    void loadCheckpoint(std::istream& stream) override;

private:
    double microStep;
    int stiffGroups;
    Scheme scheme;
    Averaging averaging;
    bool exactFastFlow;
    ThermostatPlacement thermostatPlacement;
    double temperature, friction;
    bool stiffFriction;
    std::vector<int> frictionParticles;
    std::vector<std::pair<int, int>> frozenDistances;
    int randomNumberSeed;
    std::string stiffClockParameter;
    bool metropolis = false;
    // The kernel's life cycle with the Context (StepKernelBinding), and its implementation.
    StepKernelBinding binding;
    IntegrateFlavorStepKernel* stepKernel;
};

} // namespace FlavorPlugin

#endif
