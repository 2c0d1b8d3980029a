// Langevin FLAVORs: exact Ornstein-Uhlenbeck friction, equipartition, seeds.

#include "ExpectRejected.h"
#include "FlavorIntegrator.h"
#include "PlatformTest.h"
#include "TestSystems.h"
#include "openmm/Context.h"
#include "openmm/reference/SimTKOpenMMRealType.h"
#include <cmath>
#include <memory>

using namespace FlavorPlugin;
using namespace FlavorTests;
using namespace OpenMM;
using std::vector;

class FlavorLangevin : public PlatformTest {};
INSTANTIATE_ON_ALL_PLATFORMS(FlavorLangevin);

namespace {

/** n free particles of mass 2 (a stiff force that is identically zero keeps the integrator's contract). */
System* freeParticles(int n) {
    System* system = new System();
    for (int i = 0; i < n; ++i)
        system->addParticle(2.0);
    CustomExternalForce* nothing = new CustomExternalForce("0");
    nothing->addParticle(0);
    nothing->setForceGroup(StiffGroup);
    system->addForce(nothing);
    // A FLAVOR needs a soft force; this one is zero too.
    CustomExternalForce* softNothing = new CustomExternalForce("0");
    softNothing->addParticle(0);
    softNothing->setForceGroup(SoftGroup);
    system->addForce(softNothing);
    return system;
}

/**
 * n independent particles in 3-D, each with the soft potential a r^2/2 + b (x^4 + y^4 + z^4) and the stiff
 * potential k r^2/2 (omega = sqrt(k) = 100).
 */
const double SoftA = 1.0, SoftB = 20.0, StiffK = 1e4;

System* anharmonicParticles(int n) {
    System* system = new System();
    CustomExternalForce* soft = new CustomExternalForce("0.5*a*(x^2+y^2+z^2) + b*(x^4+y^4+z^4)");
    soft->addGlobalParameter("a", SoftA);
    soft->addGlobalParameter("b", SoftB);
    CustomExternalForce* stiff = new CustomExternalForce("0.5*k*(x^2+y^2+z^2)");
    stiff->addGlobalParameter("k", StiffK);
    stiff->setForceGroup(StiffGroup);
    for (int i = 0; i < n; ++i) {
        system->addParticle(1.0);
        soft->addParticle(i);
        stiff->addParticle(i);
    }
    system->addForce(soft);
    system->addForce(stiff);
    return system;
}

struct Mode {
    FlavorIntegrator::Scheme scheme;
    bool stiffFriction;
};
const Mode AllModes[] = {{FlavorIntegrator::SymplecticEuler, false},
                         {FlavorIntegrator::SymplecticEuler, true},
                         {FlavorIntegrator::Verlet, false},
                         {FlavorIntegrator::Verlet, true}};

} // namespace

TEST_P(FlavorLangevin, FrictionDecaysVelocityExactly) {
    // At T = 0 the thermostat is v -> exp(-gamma h) v: after n steps a free particle's velocity is
    // exp(-gamma n delta) v0, or exp(-gamma n tau) v0 with stiff friction.  At T > 0 the mean over many particles
    // decays the same way; its fluctuation has standard error sqrt(kT/m (1 - exp(-2 gamma t)) / N).
    const int n = 2000, steps = 40;
    const double delta = 0.01, tau = 0.002, gamma = 3.0, mass = 2.0;
    std::unique_ptr<System> system(freeParticles(n));
    vector<Vec3> v0(n);
    for (int i = 0; i < n; ++i)
        v0[i] = Vec3(1.0, -0.5, 0.25 * (i % 3));
    for (const Mode& mode : AllModes) {
        for (double temperature : {0.0, 300.0}) {
            FlavorIntegrator integrator(delta, tau, StiffMask);
            integrator.setScheme(mode.scheme);
            integrator.setStiffFriction(mode.stiffFriction);
            integrator.setFriction(gamma);
            integrator.setTemperature(temperature);
            integrator.setRandomNumberSeed(11);
            Context context(*system, integrator, platform(), properties());
            context.setPositions(vector<Vec3>(n));
            context.setVelocities(v0);
            integrator.step(steps);
            const double frictionTime = steps * (mode.stiffFriction ? tau : delta);
            const double decay = std::exp(-gamma * frictionTime);
            vector<Vec3> v = velocitiesOf(context);
            if (temperature == 0.0) {
                for (int i = 0; i < n; ++i)
                    ASSERT_LE(std::sqrt((v[i] - v0[i] * decay).dot(v[i] - v0[i] * decay)), 1e-13)
                        << "scheme " << mode.scheme << " stiff " << mode.stiffFriction;
            } else {
                Vec3 mean, expected;
                for (int i = 0; i < n; ++i) {
                    mean += v[i] / n;
                    expected += v0[i] * (decay / n);
                }
                double standardError =
                    std::sqrt(BOLTZ * temperature / mass * -std::expm1(-2 * gamma * frictionTime) / n);
                for (int k = 0; k < 3; ++k)
                    EXPECT_NEAR(expected[k], mean[k], 5 * standardError)
                        << "scheme " << mode.scheme << " stiff " << mode.stiffFriction;
            }
        }
    }
}

TEST_P(FlavorLangevin, EquipartitionAndConfigurationalTemperature) {
    // FLAVOR kicks and drifts preserve (to O(delta^p)) the averaged Hamiltonian H_eff = K + V_soft +
    // (tau/delta) V_stiff and the thermostat preserves the Maxwell distribution, so the stationary measure is
    // exp(-H_eff/kT): <K> = (3N/2) kT and the configurational temperature of V_eff,
    // <|grad V_eff|^2> / <lap V_eff>, equals kT.  Both are checked to 5 standard errors estimated from 20 block
    // means (each block 1 ps, ten relaxation times 1/gamma), plus 0.005 for the O(delta^2) bias of the scheme.
    // The configurational temperature is checked for the symmetric Verlet schemes only: SymplecticEuler is first
    // order and its stationary positions carry an O(delta) bias (measured here: +2.2% with friction over the
    // mesostep, -2.3% with stiff friction), which the kinetic temperature does not see.
    const int n = 300, blocks = 20, samplesPerBlock = 20, stride = 10;
    const double delta = 0.005, tau = 0.0002, temperature = 300, kT = BOLTZ * temperature, gamma = 10;
    const double stiffWeight = tau / delta;
    std::unique_ptr<System> system(anharmonicParticles(n));
    for (const Mode& mode : AllModes) {
        FlavorIntegrator integrator(delta, tau, StiffMask);
        integrator.setScheme(mode.scheme);
        integrator.setStiffFriction(mode.stiffFriction);
        integrator.setFriction(mode.stiffFriction ? 100.0
                                                  : gamma); // stiff: relaxation time 1/(100 tau/delta) = 0.25 ps
        integrator.setTemperature(temperature);
        integrator.setRandomNumberSeed(2024);
        Context context(*system, integrator, platform(), properties());
        context.setPositions(vector<Vec3>(n, Vec3(0.05, -0.05, 0.02)));
        integrator.step(400);
        vector<double> kineticRatio, configurationalRatio;
        for (int b = 0; b < blocks; ++b) {
            double kinetic = 0, gradSquared = 0, laplacian = 0;
            for (int s = 0; s < samplesPerBlock; ++s) {
                integrator.step(stride);
                State state = context.getState(State::Positions | State::Energy);
                kinetic += state.getKineticEnergy() / (1.5 * n * kT);
                for (const Vec3& q : state.getPositions())
                    for (int k = 0; k < 3; ++k) {
                        double x = q[k];
                        double grad = SoftA * x + 4 * SoftB * x * x * x + stiffWeight * StiffK * x;
                        gradSquared += grad * grad;
                        laplacian += SoftA + 12 * SoftB * x * x + stiffWeight * StiffK;
                    }
            }
            kineticRatio.push_back(kinetic / samplesPerBlock);
            configurationalRatio.push_back(gradSquared / (laplacian * kT));
        }
        vector<vector<double>*> checked = {&kineticRatio};
        if (mode.scheme == FlavorIntegrator::Verlet)
            checked.push_back(&configurationalRatio);
        for (auto* series : checked) {
            const BlockMean m = blockMean(*series);
            EXPECT_NEAR(1.0, m.mean, 5 * m.standardError + 0.005)
                << (series == &kineticRatio ? "kinetic" : "configurational") << " temperature, scheme " << mode.scheme
                << " stiff friction " << mode.stiffFriction << " (standard error " << m.standardError << ")";
        }
    }
}

TEST_P(FlavorLangevin, SeedsDetermineTheNoiseAndFrictionZeroIsHamiltonian) {
    std::unique_ptr<System> system(fpuSystem(3, 50.0));
    auto run = [&](double friction, double temperature, int seed) {
        FlavorIntegrator integrator(0.01, 0.001, StiffMask);
        integrator.setFriction(friction);
        integrator.setTemperature(temperature);
        integrator.setRandomNumberSeed(seed);
        Context context(*system, integrator, platform(), properties());
        context.setPositions(fpuPositions({1, 0, 0}, {0.02, 0, 0}));
        integrator.step(30);
        return positionsOf(context);
    };
    EXPECT_EQ(0.0, relativeDifference(run(2.0, 300, 5), run(2.0, 300, 5)));
    EXPECT_GT(relativeDifference(run(2.0, 300, 5), run(2.0, 300, 6)), 1e-6);
    EXPECT_EQ(0.0, relativeDifference(run(0.0, 300, 5), run(0.0, 0, 0)));
}

TEST_P(FlavorLangevin, FrictionParticlesRestrictFrictionAndNoise) {
    // Friction and noise on the odd particles only: at T = 0 their velocities decay exactly, the even ones keep
    // theirs; at T > 0 the even particles are untouched by noise (free particles: constant velocity).
    const int n = 6, steps = 20;
    const double delta = 0.01, tau = 0.002, gamma = 4.0;
    std::unique_ptr<System> system(freeParticles(n));
    vector<Vec3> v0(n, Vec3(1.0, -2.0, 0.5));
    for (double temperature : {0.0, 300.0}) {
        FlavorIntegrator integrator(delta, tau, StiffMask);
        integrator.setFriction(gamma);
        integrator.setTemperature(temperature);
        integrator.setFrictionParticles({1, 3, 5});
        Context context(*system, integrator, platform(), properties());
        context.setPositions(vector<Vec3>(n));
        context.setVelocities(v0);
        integrator.step(steps);
        vector<Vec3> v = velocitiesOf(context);
        for (int i = 0; i < n; i += 2)
            EXPECT_EQ(v0[i], v[i]) << "particle " << i << " at " << temperature << " K";
        if (temperature == 0.0)
            for (int i = 1; i < n; i += 2)
                EXPECT_NEAR(0.0,
                            std::sqrt((v[i] - v0[i] * std::exp(-gamma * steps * delta))
                                          .dot(v[i] - v0[i] * std::exp(-gamma * steps * delta))),
                            1e-13);
        else
            EXPECT_GT(std::sqrt((v[1] - v0[1]).dot(v[1] - v0[1])), 0.1);
    }
    FlavorIntegrator integrator(delta, tau, StiffMask);
    integrator.setFrictionParticles({2, 9});
    expectRejected([&] { Context context(*system, integrator, platform(), properties()); },
                   {"frictionParticles", "9", "< 6"});
}
