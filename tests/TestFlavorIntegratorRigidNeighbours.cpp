// Molecules beside the frozen ones that hold only their own constraints (rigid water, a constrained pair): the
// artificial FLAVOR moves them by OpenMM's constrained drift and projected kicks, written here as a CustomIntegrator.

#include "FlavorIntegrator.h"
#include "PlatformTest.h"
#include "TestSystems.h"
#include "openmm/Context.h"
#include "openmm/CustomExternalForce.h"
#include "openmm/CustomIntegrator.h"
#include <cmath>
#include <memory>

using namespace FlavorPlugin;
using namespace FlavorTests;
using namespace OpenMM;
using std::vector;

class FlavorRigidNeighbours : public PlatformTest {};
INSTANTIATE_ON_ALL_PLATFORMS(FlavorRigidNeighbours);

namespace {

// Particles 0-2 of the full System: a flexible bent molecule (stiff bonds and angle); then a rigid water (SETTLE)
// and a constrained pair of unequal masses (CCMA), none of them interacting with the molecule.
const vector<double> NeighbourMasses = {15.999, 1.008, 1.008, 12.0, 14.0};
const int FirstNeighbour = 3;

/** The neighbours' constraints and a soft anisotropic tether on every particle (not a rigid-body force). */
void addNeighbours(System& system, int first) {
    for (double mass : NeighbourMasses)
        system.addParticle(mass);
    system.addConstraint(first, first + 1, 0.09572);
    system.addConstraint(first, first + 2, 0.09572);
    system.addConstraint(first + 1, first + 2, 0.15139);
    system.addConstraint(first + 3, first + 4, 0.13);
    CustomExternalForce* tether = new CustomExternalForce("200*x^2+300*y^2+500*z^2");
    for (int i = 0; i < system.getNumParticles(); ++i)
        tether->addParticle(i);
    tether->setForceGroup(SoftGroup);
    system.addForce(tether);
}

vector<Vec3> neighbourPositions() {
    return {Vec3(0.3, 0.1, 0.05), Vec3(0.3957, 0.1, 0.05), Vec3(0.276, 0.1927, 0.05), Vec3(-0.2, 0.3, 0.1),
            Vec3(-0.2, 0.43, 0.1)};
}

vector<Vec3> neighbourVelocities() {
    return {Vec3(0.4, -0.3, 0.2), Vec3(-1.5, 2.0, 0.7), Vec3(1.1, -0.4, -2.2), Vec3(0.5, 0.2, -0.3),
            Vec3(-0.6, 0.1, 0.9)};
}

/** The frozen bent molecule (particles 0-2) with the neighbours after it. */
void addMoleculeAndNeighbours(System& system) {
    for (double mass : {15.999, 1.008, 1.008})
        system.addParticle(mass);
    addStiffBentMolecules(system, 0);
    addNeighbours(system, FirstNeighbour);
}

/** The molecule's and the neighbours' start, the neighbours' velocities times neighbourSpeed. */
void moleculeAndNeighboursStart(vector<Vec3>& q, vector<Vec3>& v, double neighbourSpeed) {
    q = bentMoleculePositions();
    v = {Vec3(0.3, -0.2, 0.1), Vec3(2.0, 1.0, -1.5), Vec3(-1.0, 0.5, 2.0)};
    for (const Vec3& x : neighbourPositions())
        q.push_back(x);
    for (const Vec3& x : neighbourVelocities())
        v.push_back(x * neighbourSpeed);
}

/** v += h F / m, projected; x moved by RATTLE drifts over (delta - tau)/2, tau, (delta - tau)/2; v += h F / m. */
CustomIntegrator* constrainedVerletWithThreeDrifts(double delta, double tau, double tolerance) {
    CustomIntegrator* integrator = new CustomIntegrator(delta);
    integrator->setConstraintTolerance(tolerance);
    integrator->addPerDofVariable("x1", 0);
    integrator->addUpdateContextState();
    integrator->addComputePerDof("v", "v + 0.5*dt*f/m");
    integrator->addConstrainVelocities();
    for (double h : {0.5 * (delta - tau), tau, 0.5 * (delta - tau)}) {
        const std::string length = std::to_string(h);
        integrator->addComputePerDof("x1", "x");
        integrator->addComputePerDof("x", "x + " + length + "*v");
        integrator->addConstrainPositions();
        integrator->addComputePerDof("v", "(x - x1)/" + length);
        integrator->addConstrainVelocities();
    }
    integrator->addComputePerDof("v", "v + 0.5*dt*f/m");
    integrator->addConstrainVelocities();
    return integrator;
}

} // namespace

TEST_P(FlavorRigidNeighbours, MoleculesWithOnlyTheirOwnConstraintsMoveAsInOpenMMsConstrainedVerlet) {
    const double delta = 0.004, tau = 0.001, tolerance = 1e-10;
    const int steps = 25;
    System full;
    addMoleculeAndNeighbours(full);
    System alone;
    addNeighbours(alone, 0);

    vector<Vec3> q, v;
    moleculeAndNeighboursStart(q, v, 1.0);
    FlavorIntegrator flavor(delta, tau, StiffMask);
    flavor.setAveraging(FlavorIntegrator::ArtificialProjected);
    flavor.setConstraintTolerance(tolerance);
    Context flavorContext(full, flavor, platform(), properties());
    flavorContext.setPositions(q);
    flavorContext.setVelocities(v);
    flavorContext.applyConstraints(tolerance);
    flavorContext.applyVelocityConstraints(tolerance);

    std::unique_ptr<CustomIntegrator> reference(constrainedVerletWithThreeDrifts(delta, tau, tolerance));
    Context referenceContext(alone, *reference, platform(), properties());
    State start = flavorContext.getState(State::Positions | State::Velocities);
    vector<Vec3> q0(start.getPositions().begin() + FirstNeighbour, start.getPositions().end());
    vector<Vec3> v0(start.getVelocities().begin() + FirstNeighbour, start.getVelocities().end());
    referenceContext.setPositions(q0);
    referenceContext.setVelocities(v0);

    flavor.step(steps);
    reference->step(steps);
    State a = flavorContext.getState(State::Positions | State::Velocities);
    State b = referenceContext.getState(State::Positions | State::Velocities);
    double moved = 0.0;
    for (int i = 0; i < (int)NeighbourMasses.size(); ++i) {
        const Vec3 dq = a.getPositions()[FirstNeighbour + i] - b.getPositions()[i];
        const Vec3 dv = a.getVelocities()[FirstNeighbour + i] - b.getVelocities()[i];
        // OpenCL: its SETTLE and CCMA hold to about 1e-9 nm (measured deviations up to 2.9e-9 nm).
        EXPECT_LT(std::sqrt(dq.dot(dq)), isGpu() ? 1e-8 : 1e-9) << "particle " << FirstNeighbour + i;
        EXPECT_LT(std::sqrt(dv.dot(dv)), 1e-6) << "particle " << FirstNeighbour + i;
        const Vec3 d = b.getPositions()[i] - q0[i];
        moved = std::max(moved, std::sqrt(d.dot(d)));
    }
    // The neighbours really moved and their constraints hold: to the tolerance (CCMA), or to the about 1e-8 relative
    // that SETTLE's analytic solution keeps rigid water at (the reference's lengths are the same).
    EXPECT_GT(moved, 0.01);
    for (int c = 0; c < full.getNumConstraints(); ++c) {
        int i, j;
        double length;
        full.getConstraintParameters(c, i, j, length);
        const Vec3 r = a.getPositions()[i] - a.getPositions()[j];
        const Vec3 s = b.getPositions()[i - FirstNeighbour] - b.getPositions()[j - FirstNeighbour];
        EXPECT_NEAR(length, std::sqrt(r.dot(r)), 1e-8 * length) << "constraint " << c;
        EXPECT_NEAR(std::sqrt(s.dot(s)), std::sqrt(r.dot(r)), isGpu() ? 1e-8 : 1e-12) << "constraint " << c;
    }
}

TEST_P(FlavorRigidNeighbours, AStepThatEndsWithAFrozenStageEndsWithTheNeighboursVelocitiesOnTheirConstraints) {
    // Inside a step the frozen stage leaves the neighbours' chord velocities to the next kick's projection; where the
    // step ends with the frozen stage (the symplectic Euler scheme) it projects them itself, as where a kick ends it.
    const double delta = 0.004, tau = 0.001, tolerance = 1e-10;
    for (FlavorIntegrator::Scheme scheme : {FlavorIntegrator::SymplecticEuler, FlavorIntegrator::Verlet})
        for (FlavorIntegrator::Averaging averaging :
             {FlavorIntegrator::Artificial, FlavorIntegrator::ArtificialProjected}) {
            System system;
            addMoleculeAndNeighbours(system);
            vector<Vec3> q, v;
            moleculeAndNeighboursStart(q, v, 10.0);
            FlavorIntegrator flavor(delta, tau, StiffMask);
            flavor.setScheme(scheme);
            flavor.setAveraging(averaging);
            flavor.setConstraintTolerance(tolerance);
            Context context(system, flavor, platform(), properties());
            context.setPositions(q);
            context.setVelocities(v);
            context.applyConstraints(tolerance);
            context.applyVelocityConstraints(tolerance);
            for (int step = 0; step < 5; ++step) {
                flavor.step(1);
                State state = context.getState(State::Positions | State::Velocities);
                for (int c = 0; c < system.getNumConstraints(); ++c) {
                    int i, j;
                    double length;
                    system.getConstraintParameters(c, i, j, length);
                    const Vec3 r = state.getPositions()[i] - state.getPositions()[j];
                    const Vec3 vi = state.getVelocities()[i], vj = state.getVelocities()[j];
                    const double rate = r.dot(vi - vj) / std::sqrt(r.dot(r));
                    EXPECT_LT(std::abs(rate), 1e-8 * (std::sqrt(vi.dot(vi)) + std::sqrt(vj.dot(vj))))
                        << "scheme " << scheme << ", averaging " << averaging << ", constraint " << c;
                }
            }
        }
}
