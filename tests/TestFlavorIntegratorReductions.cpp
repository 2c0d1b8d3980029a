// Exact reductions and scheme conformance: with tau = delta the schemes are the legacy integrators, and on a
// nonlinear stiff/soft system each scheme matches the flow composition written out independently here.

#include "FlavorIntegrator.h"
#include "PlatformTest.h"
#include "TestSystems.h"
#include "openmm/Context.h"
#include "openmm/VerletIntegrator.h"
#include <array>
#include <functional>
#include <memory>

using namespace FlavorPlugin;
using namespace FlavorTests;
using namespace OpenMM;
using std::vector;

class FlavorReductions : public PlatformTest {};
INSTANTIATE_ON_ALL_PLATFORMS(FlavorReductions);

namespace {

vector<Vec3> fpuVelocities() {
    return {Vec3(0.3, 0, 0), Vec3(-0.2, 0, 0), Vec3(0.1, 0, 0), Vec3(0.5, 0, 0), Vec3(-0.4, 0, 0), Vec3(0.2, 0, 0)};
}

} // namespace

TEST_P(FlavorReductions, VerletWithEqualStepsReproducesVerletIntegratorPositions) {
    const double h = 1e-3;
    const int steps = 500;
    std::unique_ptr<System> system(fpuSystem(3, 50.0));
    vector<Vec3> q0 = fpuPositions({1, 0.2, -0.3}, {1 / 50.0, 0.01, 0}), v0 = fpuVelocities();

    FlavorIntegrator flavor(h, h, StiffMask);
    Context flavorContext(*system, flavor, platform(), properties());
    flavorContext.setPositions(q0);
    flavorContext.setVelocities(v0);
    flavor.step(steps);

    // OpenMM's VerletIntegrator is leapfrog: start it half a step back in velocity.
    VerletIntegrator verlet(h);
    Context verletContext(*system, verlet, platform(), properties());
    verletContext.setPositions(q0);
    vector<Vec3> f0 = verletContext.getState(State::Forces).getForces();
    vector<Vec3> vHalf(v0.size());
    for (size_t i = 0; i < v0.size(); ++i)
        vHalf[i] = v0[i] - f0[i] * (h / 2 / system->getParticleMass(i));
    verletContext.setVelocities(vHalf);
    verlet.step(steps);

    EXPECT_LE(relativeDifference(positionsOf(flavorContext), positionsOf(verletContext)), 1e-10);
    EXPECT_NEAR(steps * h, flavorContext.getState(0).getTime(), 1e-12);
    EXPECT_EQ(steps, flavorContext.getStepCount());
}

TEST_P(FlavorReductions, SymplecticEulerWithEqualStepsIsSymplecticEuler) {
    const double h = 1e-3;
    const int steps = 500;
    std::unique_ptr<System> system(fpuSystem(3, 50.0));
    vector<Vec3> q = fpuPositions({1, 0.2, -0.3}, {1 / 50.0, 0.01, 0}), v = fpuVelocities();

    FlavorIntegrator flavor(h, h, StiffMask);
    flavor.setScheme(FlavorIntegrator::SymplecticEuler);
    Context flavorContext(*system, flavor, platform(), properties());
    flavorContext.setPositions(q);
    flavorContext.setVelocities(v);
    flavor.step(steps);

    // v += h F(q)/m; q += h v, with forces from a separate Context.
    VerletIntegrator unused(h);
    Context forces(*system, unused, platform(), properties());
    for (int n = 0; n < steps; ++n) {
        forces.setPositions(q);
        vector<Vec3> f = forces.getState(State::Forces).getForces();
        for (size_t i = 0; i < q.size(); ++i) {
            v[i] += f[i] * h;
            q[i] += v[i] * h;
        }
    }
    EXPECT_LE(relativeDifference(positionsOf(flavorContext), q), 1e-10);
    EXPECT_LE(relativeDifference(velocitiesOf(flavorContext), v), 1e-10);
}

namespace {

/**
 * Eq. (6.6): H = py^2/2 + px^2/2 + y^6/eps + (x-y)^4, with particle 0 = y and particle 1 = x on the x axis.
 */
System* nonlinearSystem(double epsilon) {
    System* system = new System();
    system->addParticle(1.0);
    system->addParticle(1.0);
    CustomExternalForce* stiff = new CustomExternalForce("x^6/" + std::to_string(epsilon));
    stiff->addParticle(0);
    stiff->setForceGroup(StiffGroup);
    CustomBondForce* soft = new CustomBondForce("r^4");
    soft->addBond(0, 1);
    soft->setForceGroup(SoftGroup);
    system->addForce(stiff);
    system->addForce(soft);
    return system;
}

/** State (y, x, py, px) and the two force fields of (6.6), written independently of the library. */
typedef std::array<double, 4> State4;

void kick(State4& s, double h, double epsilon, bool withStiff) {
    double soft = 4 * std::pow(s[1] - s[0], 3); // -dV/dy; -dV/dx is its negative
    s[2] += h * soft;
    s[3] -= h * soft;
    if (withStiff)
        s[2] -= h * 6 * std::pow(s[0], 5) / epsilon;
}

void drift(State4& s, double h) {
    s[0] += h * s[2];
    s[1] += h * s[3];
}

} // namespace

TEST_P(FlavorReductions, BothSchemesMatchTheirFlowCompositionsOnNonlinearStiffAndSoftPotentials) {
    // Fig. 6.2: eps = 1e-6, y(0) = 1.1, x(0) = 2.2, delta = 1e-3, tau = 1e-5.
    const double epsilon = 1e-6, delta = 1e-3, tau = 1e-5;
    const int steps = 300;
    std::unique_ptr<System> system(nonlinearSystem(epsilon));
    for (auto scheme : {FlavorIntegrator::SymplecticEuler, FlavorIntegrator::Verlet}) {
        FlavorIntegrator flavor(delta, tau, StiffMask);
        flavor.setScheme(scheme);
        Context context(*system, flavor, platform(), properties());
        context.setPositions({Vec3(1.1, 0, 0), Vec3(2.2, 0, 0)});
        flavor.step(steps);

        State4 s = {1.1, 2.2, 0, 0};
        for (int n = 0; n < steps; ++n) {
            if (scheme == FlavorIntegrator::SymplecticEuler) {
                // (2.17): stiff+soft for tau, then soft alone for delta - tau.
                kick(s, tau, epsilon, true);
                drift(s, tau);
                kick(s, delta - tau, epsilon, false);
                drift(s, delta - tau);
            } else {
                // (2.7): the symmetric composition.
                kick(s, tau / 2, epsilon, true);
                drift(s, tau / 2);
                kick(s, (delta - tau) / 2, epsilon, false);
                drift(s, delta - tau);
                kick(s, (delta - tau) / 2, epsilon, false);
                drift(s, tau / 2);
                kick(s, tau / 2, epsilon, true);
            }
        }
        vector<Vec3> q = positionsOf(context), v = velocitiesOf(context);
        EXPECT_LE(relativeDifference(q, {Vec3(s[0], 0, 0), Vec3(s[1], 0, 0)}), 1e-10) << "scheme " << scheme;
        EXPECT_LE(relativeDifference(v, {Vec3(s[2], 0, 0), Vec3(s[3], 0, 0)}), 1e-10) << "scheme " << scheme;
    }
}
