// The Middle thermostat placement of the artificial Verlet FLAVOR: with tau = delta it is LangevinMiddleIntegrator,
// it samples a harmonic stiff coordinate with its exact variance where Edges gives 1/(1 - (omega tau/2)^2) times it,
// a harmonic soft coordinate too where Edges gives 1/(1 - (omega delta/2)^2) times it, and combinations it is not
// defined for are rejected with the Context left usable.

#include "Diatomics.h"
#include "ExpectRejected.h"
#include "FlavorIntegrator.h"
#include "PlatformTest.h"
#include "TestSystems.h"
#include "openmm/Context.h"
#include "openmm/CustomExternalForce.h"
#include "openmm/HarmonicAngleForce.h"
#include "openmm/HarmonicBondForce.h"
#include "openmm/LangevinMiddleIntegrator.h"
#include "openmm/reference/SimTKOpenMMRealType.h"
#include <cmath>
#include <iostream>
#include <memory>
#include <random>
#include <vector>

using namespace FlavorPlugin;
using namespace FlavorTests;
using namespace OpenMM;
using std::vector;

class FlavorMiddle : public PlatformTest {};
INSTANTIATE_ON_ALL_PLATFORMS(FlavorMiddle);

namespace {

/**
 * Bent triatomics (masses 16, 1, 1) with stiff bonds and angle (StiffGroup) and a soft tether on every atom
 * (SoftGroup), laid out on a line 0.5 nm apart.
 */
System* triatomics(int molecules, vector<Vec3>& positions) {
    System* system = new System();
    HarmonicBondForce* bonds = new HarmonicBondForce();
    HarmonicAngleForce* angles = new HarmonicAngleForce();
    CustomExternalForce* tether = new CustomExternalForce("0.5*20*((x-x0)^2+(y-y0)^2+(z-z0)^2)");
    tether->addPerParticleParameter("x0");
    tether->addPerParticleParameter("y0");
    tether->addPerParticleParameter("z0");
    bonds->setForceGroup(StiffGroup);
    angles->setForceGroup(StiffGroup);
    tether->setForceGroup(SoftGroup);
    const double r0 = 0.1, theta0 = 1.8;
    positions.clear();
    for (int m = 0; m < molecules; ++m) {
        const int o = system->addParticle(16.0), h1 = system->addParticle(1.0), h2 = system->addParticle(1.0);
        bonds->addBond(o, h1, r0, 4e5);
        bonds->addBond(o, h2, r0, 4e5);
        angles->addAngle(h1, o, h2, theta0, 800.0);
        const Vec3 centre(0.5 * m, 0, 0);
        positions.push_back(centre);
        positions.push_back(centre + Vec3(r0 * 1.02, 0, 0));
        positions.push_back(centre + Vec3(r0 * std::cos(theta0 + 0.05), r0 * std::sin(theta0 + 0.05), 0.01));
        for (int p : {o, h1, h2})
            tether->addParticle(p, {positions[p][0], positions[p][1], positions[p][2]});
    }
    system->addForce(bonds);
    system->addForce(angles);
    system->addForce(tether);
    return system;
}

} // namespace

TEST_P(FlavorMiddle, WithEqualStepsItIsLangevinMiddleIntegrator) {
    // tau = delta: the stiff and soft kicks act at the same positions, then D(h/2) O(h) D(h/2), which is OpenMM's
    // LangevinMiddleIntegrator step.  At zero temperature the thermostat is the deterministic friction exp(-gamma h),
    // so both trajectories agree to rounding.
    const double h = 0.5e-3, friction = 5.0;
    vector<Vec3> q0;
    std::unique_ptr<System> system(triatomics(4, q0));
    vector<Vec3> v0(q0.size());
    std::mt19937 generator(3);
    std::normal_distribution<double> normal;
    for (Vec3& v : v0)
        v = Vec3(normal(generator), normal(generator), normal(generator));
    vector<vector<Vec3>> q, v;
    for (int run = 0; run < 3; ++run) {
        std::unique_ptr<Integrator> integrator;
        if (run == 0) {
            integrator.reset(new LangevinMiddleIntegrator(0.0, friction, h));
        } else {
            FlavorIntegrator* flavor = new FlavorIntegrator(h, h, StiffMask);
            flavor->setAveraging(run == 1 ? FlavorIntegrator::Artificial : FlavorIntegrator::ArtificialProjected);
            flavor->setFriction(friction);
            flavor->setThermostatPlacement(FlavorIntegrator::Middle);
            integrator.reset(flavor);
        }
        Context context(*system, *integrator, platform(), properties());
        context.setPositions(q0);
        context.setVelocities(v0);
        integrator->step(400);
        q.push_back(positionsOf(context));
        v.push_back(velocitiesOf(context));
    }
    EXPECT_GT(relativeDifference(q[0], q0), 1e-3); // the molecules really moved
    for (int run = 1; run < 3; ++run) {
        EXPECT_LT(relativeDifference(q[run], q[0]), 1e-10) << "averaging " << run;
        EXPECT_LT(relativeDifference(v[run], v[0]), 1e-10) << "averaging " << run;
    }
}

TEST_P(FlavorMiddle, AHarmonicStiffBondKeepsItsExactVarianceWhereEdgesWidenIt) {
    // Independent diatomics (Diatomics.h) at omega tau = 0.89 (omega = sqrt(2 k), unit masses): the Edges placement
    // makes the microstep an O-B-A-B-O step, whose stationary stretch variance is kT / (k (1 - (omega tau/2)^2)) =
    // 1.25 kT/k; Middle makes it B-A-O-A-B, which keeps kT/k.  Both within 4 standard errors over the independent
    // molecules (up to O(kT/(k r0^2)) = 6e-4 from the rotation), with stiff friction too (the thermostat over tau, its
    // friction scaled by delta/tau).
    const double temperature = 300, kT = BOLTZ * temperature, tau = 1e-3, delta = 4 * tau;
    const Diatomics diatomics(150, 4e5, 0.1);
    const double omegaTau = std::sqrt(2 * diatomics.k) * tau;
    struct Case {
        FlavorIntegrator::ThermostatPlacement placement;
        bool stiffFriction;
        double expected; // in units of kT
    };
    const double edgesFactor = 1 / (1 - omegaTau * omegaTau / 4);
    const vector<Case> cases = {{FlavorIntegrator::Edges, false, edgesFactor},
                                {FlavorIntegrator::Middle, false, 1.0},
                                {FlavorIntegrator::Middle, true, 1.0}};
    std::mt19937 generator(7);
    for (const Case& c : cases) {
        FlavorIntegrator integrator(delta, tau, StiffMask);
        integrator.setAveraging(FlavorIntegrator::ArtificialProjected);
        integrator.setTemperature(temperature);
        integrator.setFriction(c.stiffFriction ? 20.0 * delta / tau : 20.0);
        integrator.setStiffFriction(c.stiffFriction);
        integrator.setThermostatPlacement(c.placement);
        integrator.setRandomNumberSeed(5);
        Context context(*diatomics.system, integrator, platform(), properties());
        const auto [mean, standardError] =
            diatomics.stretchEnergy(context, integrator, kT, c.expected * kT / diatomics.k, generator, 300, 200, 10);
        std::cout << "[ measured ] placement " << c.placement << " stiff friction " << c.stiffFriction
                  << ": k<(r-r0)^2>/kT = " << mean / kT << " +- " << standardError / kT << " (expected " << c.expected
                  << ")" << std::endl;
        EXPECT_LE(std::abs(mean - c.expected * kT), 4 * standardError)
            << "placement " << c.placement << " stiff friction " << c.stiffFriction << ": " << mean / kT << " kT";
        // The error bar resolves the difference between the placements.
        EXPECT_LT(4 * standardError, 0.5 * (edgesFactor - 1) * kT);
    }
}

TEST_P(FlavorMiddle, AHarmonicSoftCoordinateKeepsItsExactVarianceWhereEdgesWidenIt) {
    // Independent diatomics (unit masses, stiff bond at omega tau = 0.89) on a soft tether k_s |x|^2 / 2 on both
    // atoms: their centres of mass X are harmonic soft coordinates, decoupled from the bond, of frequency
    // omega_s = sqrt(k_s), here omega_s delta = 0.9, with k_s <|X|^2> * 2/3 = kT exactly.  Edges integrates them by
    // an O-B-A-B-O step over delta (variance 1/(1 - (omega_s delta/2)^2) = 1.25 times too large); Middle by B-A-O-A
    // over delta with positions taken where the kicks act, which keeps it exact.  (With the step starting at the
    // stiff kicks instead, positions (delta - tau)/2 of drift away from that point, it was 1 - omega_s^2 (delta^2 -
    // tau^2)/4 = 0.81 times it.)
    const double temperature = 300, kT = BOLTZ * temperature, tau = 1e-3, delta = 4 * tau;
    const double omegaSoft = 0.9 / delta, kSoft = omegaSoft * omegaSoft;
    const int molecules = 150;
    System system;
    HarmonicBondForce* bonds = new HarmonicBondForce();
    bonds->setForceGroup(StiffGroup);
    CustomExternalForce* tether = new CustomExternalForce("0.5*ks*(x^2+y^2+z^2)");
    tether->addGlobalParameter("ks", kSoft);
    tether->setForceGroup(SoftGroup);
    for (int m = 0; m < molecules; ++m) {
        system.addParticle(1.0);
        system.addParticle(1.0);
        bonds->addBond(2 * m, 2 * m + 1, 0.1, 4e5);
        tether->addParticle(2 * m);
        tether->addParticle(2 * m + 1);
    }
    system.addForce(bonds);
    system.addForce(tether);
    const double edgesFactor = 1 / (1 - 0.9 * 0.9 / 4);
    std::mt19937 generator(11);
    std::normal_distribution<double> normal;
    for (auto [placement, expected] :
         {std::pair<FlavorIntegrator::ThermostatPlacement, double>{FlavorIntegrator::Edges, edgesFactor},
          {FlavorIntegrator::Middle, 1.0}}) {
        FlavorIntegrator integrator(delta, tau, StiffMask);
        integrator.setAveraging(FlavorIntegrator::ArtificialProjected);
        integrator.setTemperature(temperature);
        integrator.setFriction(50.0);
        integrator.setThermostatPlacement(placement);
        integrator.setRandomNumberSeed(9);
        Context context(system, integrator, platform(), properties());
        vector<Vec3> q(2 * molecules), v(2 * molecules);
        const double sigmaX = std::sqrt(kT / (2 * kSoft)), sigmaV = std::sqrt(kT);
        for (int m = 0; m < molecules; ++m) {
            const Vec3 centre(sigmaX * normal(generator), sigmaX * normal(generator), sigmaX * normal(generator));
            Vec3 axis(normal(generator), normal(generator), normal(generator));
            axis *= 0.05 / std::sqrt(axis.dot(axis));
            q[2 * m] = centre - axis;
            q[2 * m + 1] = centre + axis;
            for (int i : {2 * m, 2 * m + 1})
                v[i] = Vec3(sigmaV * normal(generator), sigmaV * normal(generator), sigmaV * normal(generator));
        }
        context.setPositions(q);
        context.setVelocities(v);
        integrator.step(300);
        const int samples = 200;
        vector<double> average(molecules, 0.0);
        for (int s = 0; s < samples; ++s) {
            integrator.step(10);
            const vector<Vec3> x = positionsOf(context);
            for (int m = 0; m < molecules; ++m) {
                const Vec3 centre = (x[2 * m] + x[2 * m + 1]) * 0.5;
                average[m] += kSoft * centre.dot(centre) * 2.0 / 3.0 / samples;
            }
        }
        const BlockMean measured = blockMean(average);
        std::cout << "[ measured ] placement " << placement << ": k_s <|X|^2> 2/3 / kT = " << measured.mean / kT
                  << " +- " << measured.standardError / kT << " (expected " << expected << ")" << std::endl;
        EXPECT_LE(std::abs(measured.mean - expected * kT), 4 * measured.standardError) << "placement " << placement;
        // The error bar resolves the differences between the placements, and the 0.81 of the shifted step.
        EXPECT_LT(4 * measured.standardError, 0.5 * (edgesFactor - 1) * kT);
    }
}

TEST_P(FlavorMiddle, CombinationsWithoutAMiddlePlacementAreRejectedAndTheContextStaysUsable) {
    vector<Vec3> q0;
    std::unique_ptr<System> system(triatomics(2, q0));
    FlavorIntegrator integrator(2e-3, 0.5e-3, StiffMask);
    expectRejected([&] { integrator.setThermostatPlacement((FlavorIntegrator::ThermostatPlacement)7); },
                   {"thermostatPlacement", "7", "Edges (0)", "Middle (1)"});
    EXPECT_EQ(FlavorIntegrator::Edges, integrator.getThermostatPlacement());
    integrator.setAveraging(FlavorIntegrator::Artificial);
    integrator.setTemperature(300);
    integrator.setFriction(1.0);
    Context context(*system, integrator, platform(), properties());
    context.setPositions(q0);
    integrator.setThermostatPlacement(FlavorIntegrator::Middle);
    EXPECT_EQ(FlavorIntegrator::Middle, integrator.getThermostatPlacement());
    integrator.step(2);
    const vector<Vec3> before = positionsOf(context);
    const double time = context.getState(State::Positions).getTime();
    integrator.setScheme(FlavorIntegrator::SymplecticEuler);
    expectRejected([&] { integrator.step(1); }, {"thermostatPlacement = Middle", "SymplecticEuler", "Verlet"});
    integrator.setScheme(FlavorIntegrator::Verlet);
    integrator.setAveraging(FlavorIntegrator::Nonintrusive);
    expectRejected([&] { integrator.step(1); }, {"thermostatPlacement = Middle", "Nonintrusive", "Artificial"});
    integrator.setAveraging(FlavorIntegrator::Artificial);
    integrator.setExactFastFlow(true);
    expectRejected([&] { integrator.step(1); }, {"thermostatPlacement = Middle", "exactFastFlow", "Edges"});
    // Nothing moved; with a supported combination the Context steps on.
    integrator.setExactFastFlow(false);
    EXPECT_EQ(0.0, relativeDifference(before, positionsOf(context)));
    EXPECT_EQ(time, context.getState(State::Positions).getTime());
    integrator.step(5);
    for (const Vec3& x : positionsOf(context))
        for (int d = 0; d < 3; ++d)
            EXPECT_TRUE(std::isfinite(x[d]));
    EXPECT_GT(relativeDifference(positionsOf(context), before), 0.0);
}
