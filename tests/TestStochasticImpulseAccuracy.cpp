// Accuracy of the SIMs against a fine-step VerletIntegrator: uniformity in the stiffness (Theorem 3.2) and the
// orders of the three splittings.

#include "PlatformTest.h"
#include "StochasticImpulseIntegrator.h"
#include "TestSystems.h"
#include "openmm/Context.h"
#include "openmm/VerletIntegrator.h"
#include <algorithm>
#include <cmath>
#include <memory>

using namespace FlavorPlugin;
using namespace FlavorTests;
using namespace OpenMM;
using std::vector;

class ImpulseAccuracy : public PlatformTest {};
INSTANTIATE_ON_ALL_PLATFORMS(ImpulseAccuracy);

namespace {

/**
 * The 2-spring system of the SIM paper (section 4.1) without noise: a wall, a stiff spring omega^2 x^2/2, a mass,
 * a soft spring (y-x)^4/4, a mass.  Started at x = 0.8/omega, y = 1.1 + x, at rest.
 */
System* twoSpringSystem(double omega) {
    System* system = new System();
    system->addParticle(1.0);
    system->addParticle(1.0);
    CustomExternalForce* stiff = new CustomExternalForce("0.5*w2*x^2");
    stiff->addGlobalParameter("w2", omega * omega);
    stiff->addParticle(0);
    stiff->setForceGroup(StiffGroup);
    CustomBondForce* soft = new CustomBondForce("0.25*r^4");
    soft->addBond(0, 1);
    system->addForce(stiff);
    system->addForce(soft);
    return system;
}

vector<Vec3> twoSpringStart(double omega) {
    return {Vec3(0.8 / omega, 0, 0), Vec3(1.1 + 0.8 / omega, 0, 0)};
}

/** OpenMM's VerletIntegrator with step h (leapfrog started half a step back), on Reference: the exact solution. */
vector<Vec3> fineReference(double omega, double T, double h) {
    std::unique_ptr<System> system(twoSpringSystem(omega));
    VerletIntegrator verlet(h);
    Context context(*system, verlet, Platform::getPlatformByName("Reference"));
    context.setPositions(twoSpringStart(omega));
    vector<Vec3> f = context.getState(State::Forces).getForces();
    context.setVelocities({f[0] * (-h / 2), f[1] * (-h / 2)});
    verlet.step((int)std::lround(T / h));
    return positionsOf(context);
}

double positionError(Platform& platform, const std::map<std::string, std::string>& properties, double omega, double T,
                     double H, StochasticImpulseIntegrator::Splitting splitting, const vector<Vec3>& reference) {
    std::unique_ptr<System> system(twoSpringSystem(omega));
    StochasticImpulseIntegrator integrator(0.0, 0.0, H, StiffMask);
    integrator.setSplitting(splitting);
    Context context(*system, integrator, platform, properties);
    context.setPositions(twoSpringStart(omega));
    integrator.step((int)std::lround(T / H));
    vector<Vec3> q = positionsOf(context);
    Vec3 d0 = q[0] - reference[0], d1 = q[1] - reference[1];
    return std::sqrt(d0.dot(d0) + d1.dot(d1));
}

} // namespace

TEST_P(ImpulseAccuracy, PositionErrorDoesNotGrowWithTheStiffness) {
    // Theorem 3.2: at fixed T and H the position error of Integrator 1 (LieTrotter) is bounded independently of
    // omega.  H = 0.037 keeps omega*H = 3.7, 37, 370 away from multiples of pi (resonances, section 3.3).  The
    // reference resolves the fast scale (omega h = 0.02; its own error is below 1e-6 here).  Measured: LieTrotter
    // 1.50e-2, 1.53e-2, 1.54e-2; Strang 4.3e-4, 1.6e-4, 3.2e-5.
    const double T = 1.85, H = 0.037;
    vector<double> lieTrotter, strang;
    for (double omega : {1e2, 1e3, 1e4}) {
        vector<Vec3> reference = fineReference(omega, T, 0.02 / omega);
        lieTrotter.push_back(
            positionError(platform(), properties(), omega, T, H, StochasticImpulseIntegrator::LieTrotter, reference));
        strang.push_back(
            positionError(platform(), properties(), omega, T, H, StochasticImpulseIntegrator::Strang, reference));
    }
    auto [lo, hi] = std::minmax_element(lieTrotter.begin(), lieTrotter.end());
    EXPECT_LT(*hi / *lo, 2.0) << "LieTrotter errors " << lieTrotter[0] << ", " << lieTrotter[1] << ", "
                              << lieTrotter[2];
    EXPECT_LT(*hi, 0.05);
    EXPECT_LE(*std::max_element(strang.begin(), strang.end()), 2 * strang[0])
        << "Strang errors " << strang[0] << ", " << strang[1] << ", " << strang[2];
}

TEST_P(ImpulseAccuracy, SplittingsHaveOrdersOneTwoAndFour) {
    // omega = 10, T = 1; reference VerletIntegrator with h = 1e-5 (error 4e-10 by step doubling).  Observed orders
    // from successive halvings of H: LieTrotter 0.94-0.97, Strang 2.00, Yoshida4 3.94-3.98.
    const double omega = 10, T = 1;
    vector<Vec3> reference = fineReference(omega, T, 1e-5);
    struct Case {
        StochasticImpulseIntegrator::Splitting splitting;
        double firstStep, order;
    };
    for (Case c :
         {Case{StochasticImpulseIntegrator::LieTrotter, 0.1, 1}, Case{StochasticImpulseIntegrator::Strang, 0.1, 2},
          Case{StochasticImpulseIntegrator::Yoshida4, 0.05, 4}}) {
        double previous = 0;
        for (int halvings = 0; halvings < 3; ++halvings) {
            double H = c.firstStep / (1 << halvings);
            double error = positionError(platform(), properties(), omega, T, H, c.splitting, reference);
            if (halvings > 0) {
                double observed = std::log2(previous / error);
                EXPECT_NEAR(c.order, observed, 0.15 * c.order) << "splitting " << c.splitting << ", H " << H;
            }
            previous = error;
        }
    }
}
