// The stiff modes' own bath (setStiffModeTemperature, setStiffModeFriction): one noisy step against the exact linear
// SDE with a friction and a noise that differ between a Drude pair's centre of mass and its relative motion, long runs
// against equipartition at two temperatures, defaults, bad input and serialization.

#include "ExpectRejected.h"
#include "LinearSdeReference.h"
#include "PlatformTest.h"
#include "StochasticImpulseIntegrator.h"
#include "TestSystems.h"
#include "openmm/Context.h"
#include "openmm/VerletIntegrator.h"
#include "openmm/reference/SimTKOpenMMRealType.h"
#include "openmm/serialization/XmlSerializer.h"
#include <cmath>
#include <memory>
#include <sstream>

using namespace FlavorPlugin;
using namespace FlavorTests;
using namespace OpenMM;
using std::vector;

class ImpulseModeBath : public PlatformTest {};
INSTANTIATE_ON_ALL_PLATFORMS(ImpulseModeBath);

namespace {

/** Drude-like pairs: a core of mass 15.6 and a particle of mass 0.4 on a zero-length spring of constant k. */
struct DrudePairs {
    static constexpr double CoreMass = 15.6, DrudeMass = 0.4;
    System system;
    DrudePairs(int copies, double k, double softTether) {
        HarmonicBondForce* springs = new HarmonicBondForce();
        springs->setForceGroup(StiffGroup);
        // U = a m |q|^2 / 2 per particle: the identity times a in mass-weighted coordinates, so it leaves the centre
        // of mass and the relative motion uncoupled.
        CustomExternalForce* soft = new CustomExternalForce("0.5*a*m*(x^2+y^2+z^2)");
        soft->addGlobalParameter("a", softTether);
        soft->addPerParticleParameter("m");
        for (int c = 0; c < copies; ++c) {
            system.addParticle(CoreMass);
            system.addParticle(DrudeMass);
            springs->addBond(2 * c, 2 * c + 1, 0.0, k);
            soft->addParticle(2 * c, {CoreMass});
            soft->addParticle(2 * c + 1, {DrudeMass});
        }
        system.addForce(springs);
        if (softTether > 0)
            system.addForce(soft);
        else
            delete soft;
    }
};

/**
 * The exact mean and covariance of one pair (per direction the same, so 2 particles x 3 directions) with friction
 * gamma and kT on the centre-of-mass mode and stiffGamma, stiffKT on the relative mode, written in particle coordinates
 * from the two projectors onto those modes (not from an eigensolver).  Mass-weighted, the modes are
 * u0 = (sqrt m1, sqrt m2)/sqrt(M) and u1 = (sqrt m2, -sqrt m1)/sqrt(M); the friction is G = gamma u0 u0^T +
 * stiffGamma u1 u1^T, the noise intensity 2 (gamma kT u0 u0^T + stiffGamma stiffKT u1 u1^T).
 */
struct TwoBathPair {
    MatrixL drift, diffusion;
    TwoBathPair(double k, double gamma, double kT, double stiffGamma, double stiffKT) {
        const long double m1 = DrudePairs::CoreMass, m2 = DrudePairs::DrudeMass, M = m1 + m2;
        const long double s[2] = {std::sqrt(m1), std::sqrt(m2)};
        const long double u0[2] = {s[0] / std::sqrt(M), s[1] / std::sqrt(M)};
        const long double u1[2] = {s[1] / std::sqrt(M), -s[0] / std::sqrt(M)};
        const int n = 6;
        drift = MatrixL::Zero(2 * n, 2 * n);
        diffusion = MatrixL::Zero(2 * n, 2 * n);
        for (int d = 0; d < 3; ++d)
            for (int i = 0; i < 2; ++i) {
                const int ri = 3 * i + d;
                drift(ri, n + ri) = 1;
                for (int j = 0; j < 2; ++j) {
                    const int rj = 3 * j + d;
                    const long double sign = (i == j ? 1 : -1);
                    drift(n + ri, rj) = -sign * k / (i == 0 ? m1 : m2);
                    // Particle-space friction M^-1/2 G M^1/2 and noise M^-1/2 (2 G kT) M^-1/2.
                    const long double g = gamma * u0[i] * u0[j] + stiffGamma * u1[i] * u1[j];
                    const long double q = 2 * (gamma * kT * u0[i] * u0[j] + stiffGamma * stiffKT * u1[i] * u1[j]);
                    drift(n + ri, n + rj) = -g * s[j] / s[i];
                    diffusion(n + ri, n + rj) = q / (s[i] * s[j]);
                }
            }
    }
    VectorL mean(const VectorL& state, double t) const { return exponential(drift * (long double)t) * state; }
    /** Van Loan's block exponential. */
    MatrixL covariance(double t) const {
        const int m = (int)drift.rows();
        MatrixL block = MatrixL::Zero(2 * m, 2 * m);
        block.topLeftCorner(m, m) = -drift;
        block.topRightCorner(m, m) = diffusion;
        block.bottomRightCorner(m, m) = drift.transpose();
        MatrixL e = exponential(block * (long double)t);
        return e.bottomRightCorner(m, m).transpose() * e.topRightCorner(m, m);
    }
};

/**
 * The warped frequency of a mode (omega, friction gamma, step h) found here from the mode's exact 2x2 flow by
 * bisection: the frequency at which the Strang step's static response h Phi_xv / det(I - Phi) is 1/omega^2.
 */
double warpedOmega(double omega, double gamma, double h) {
    auto response = [&](double w) {
        MatrixL a(2, 2);
        a << 0, 1, -w * w, -gamma;
        const MatrixL p = exponential(a * (long double)h);
        return (double)(h * p(0, 1) / ((1 - p(0, 0)) * (1 - p(1, 1)) - p(0, 1) * p(1, 0)));
    };
    double low = 0, high = std::sqrt(M_PI * M_PI + 0.25 * gamma * gamma * h * h) / h;
    for (int i = 0; i < 100; ++i)
        (response(0.5 * (low + high)) > 1 / (omega * omega) ? low : high) = 0.5 * (low + high);
    return 0.5 * (low + high);
}

VectorL pairState(const vector<Vec3>& q, const vector<Vec3>& v, int pair) {
    VectorL s(12);
    for (int i = 0; i < 2; ++i)
        for (int d = 0; d < 3; ++d) {
            s[3 * i + d] = q[2 * pair + i][d];
            s[6 + 3 * i + d] = v[2 * pair + i][d];
        }
    return s;
}

} // namespace

namespace {

/** The one-step experiment: 4000 pairs (omega_rel = 300/ps) from one state, one step H = 0.01 ps with two baths. */
struct OneStepOfManyPairs {
    static constexpr int Copies = 4000;
    static constexpr double Omega = 300, H = 0.01, Temperature = 300, Gamma = 5, StiffTemperature = 20, StiffGamma = 40;
    const double mu = DrudePairs::CoreMass * DrudePairs::DrudeMass / (DrudePairs::CoreMass + DrudePairs::DrudeMass);
    const double k = Omega * Omega * mu;
    DrudePairs pairs{Copies, k, 0.0};
    vector<Vec3> q, v, q1, v1;
    /** Takes the step with splitting; withZeroSoftForce adds a soft force that is 0 (so that soft kicks exist). */
    void run(Platform& platform, const std::map<std::string, std::string>& properties,
             StochasticImpulseIntegrator::Splitting splitting, bool withZeroSoftForce, int seed) {
        if (withZeroSoftForce) {
            CustomExternalForce* nothing = new CustomExternalForce("0*x");
            for (int i = 0; i < 2 * Copies; ++i)
                nothing->addParticle(i);
            pairs.system.addForce(nothing);
        }
        StochasticImpulseIntegrator integrator(Temperature, Gamma, H, StiffMask);
        integrator.setSplitting(splitting);
        integrator.setStiffModeTemperature(StiffTemperature);
        integrator.setStiffModeFriction(StiffGamma);
        integrator.setRandomNumberSeed(seed);
        Context context(pairs.system, integrator, platform, properties);
        const Vec3 q0[2] = {Vec3(0.1, -0.2, 0.05), Vec3(0.104, -0.197, 0.049)};
        const Vec3 v0[2] = {Vec3(0.5, -0.3, 0.2), Vec3(-4.0, 6.0, 2.5)};
        for (int c = 0; c < Copies; ++c)
            for (int i = 0; i < 2; ++i) {
                q.push_back(q0[i]);
                v.push_back(v0[i]);
            }
        context.setPositions(q);
        context.setVelocities(v);
        integrator.step(1);
        q1 = positionsOf(context);
        v1 = velocitiesOf(context);
    }
};

/** The sample mean and covariance of the pairs' 12 coordinates against the exact ones, within 5 standard errors. */
void expectPairStatistics(const vector<Vec3>& q1, const vector<Vec3>& v1, int copies, const VectorL& mean,
                          const MatrixL& covariance) {
    const int dims = 12;
    VectorL sampleMean = VectorL::Zero(dims);
    for (int c = 0; c < copies; ++c)
        sampleMean += pairState(q1, v1, c) / (long double)copies;
    MatrixL sampleCovariance = MatrixL::Zero(dims, dims);
    for (int c = 0; c < copies; ++c) {
        const VectorL d = pairState(q1, v1, c) - sampleMean;
        sampleCovariance += d * d.transpose() / (long double)(copies - 1);
    }
    for (int i = 0; i < dims; ++i) {
        EXPECT_NEAR((double)mean[i], (double)sampleMean[i], 5 * std::sqrt((double)covariance(i, i) / copies))
            << "mean of coordinate " << i;
        for (int j = 0; j <= i; ++j) {
            const double se =
                std::sqrt((double)(covariance(i, i) * covariance(j, j) + covariance(i, j) * covariance(i, j)) / copies);
            EXPECT_NEAR((double)covariance(i, j), (double)sampleCovariance(i, j), 5 * se)
                << "covariance " << i << "," << j;
        }
    }
}

} // namespace

TEST_P(ImpulseModeBath, OneStepHasTheExactMeanAndCovarianceWithTwoBaths) {
    // 4000 pairs with omega_rel = sqrt(k/mu) = 300/ps take one step H = 0.01 ps (omega H = 3) from the same state:
    // the centre of mass at 300 K with 5/ps, the relative motion at 20 K with 40/ps.  The sample mean and covariance of
    // a pair's 12 coordinates must match the exact ones within 5 standard errors.
    OneStepOfManyPairs e;
    e.run(platform(), properties(), StochasticImpulseIntegrator::Strang, false, 11);
    const TwoBathPair exact(e.k, e.Gamma, BOLTZ * e.Temperature, e.StiffGamma, BOLTZ * e.StiffTemperature);
    const MatrixL covariance = exact.covariance(e.H);
    expectPairStatistics(e.q1, e.v1, e.Copies, exact.mean(pairState(e.q, e.v, 0), e.H), covariance);
    // The relative velocity's variance is set by the cold bath: a check that the two baths are not swapped, far
    // outside the statistical bound above (kT_rel/mu and kT/M differ by a factor 2.6 here).
    const double relativeVariance = (double)(covariance(6, 6) + covariance(9, 9) - 2 * covariance(6, 9));
    EXPECT_LT(relativeVariance, 1.2 * BOLTZ * e.StiffTemperature / e.mu);
}

TEST_P(ImpulseModeBath, AWarpedStepIsTheExactStepOfTheWarpedSpring) {
    // The same one step, Warped: with a soft force that is zero, the step is the exact flow of the pair with its
    // relative mode at the warped frequency omega~ (omega H = 3: omega~ H = 2.2, found in the test from the damped
    // 2x2 flow) and the same two baths.  The sample statistics of 4000 pairs match it within 5 standard errors; the
    // unwarped flow's mean is hundreds of standard errors away.
    OneStepOfManyPairs e;
    e.run(platform(), properties(), StochasticImpulseIntegrator::Warped, true, 12);
    const double warped = warpedOmega(e.Omega, e.StiffGamma, e.H);
    EXPECT_NEAR(2.2, warped * e.H, 0.1);
    const TwoBathPair exact(warped * warped * e.mu, e.Gamma, BOLTZ * e.Temperature, e.StiffGamma,
                            BOLTZ * e.StiffTemperature);
    const MatrixL covariance = exact.covariance(e.H);
    expectPairStatistics(e.q1, e.v1, e.Copies, exact.mean(pairState(e.q, e.v, 0), e.H), covariance);
    // Against the unwarped flow: the relative velocity's mean differs by far more than its standard error.
    const TwoBathPair unwarped(e.k, e.Gamma, BOLTZ * e.Temperature, e.StiffGamma, BOLTZ * e.StiffTemperature);
    const VectorL a = exact.mean(pairState(e.q, e.v, 0), e.H), b = unwarped.mean(pairState(e.q, e.v, 0), e.H);
    EXPECT_GT(std::abs((double)(a[9] - b[9])), 100 * std::sqrt((double)covariance(9, 9) / e.Copies));
}

TEST_P(ImpulseModeBath, LongRunsHoldTheCentreOfMassAtTAndTheRelativeMotionAtTheStiffTemperature) {
    // 300 pairs (omega_rel = 1000/ps) in a soft tether a = 1/ps^2 that acts alike on both modes (see DrudePairs).
    // Strang with H = 0.02 ps (omega H = 20: no stiff-mode resolution at all), and Filtered with H = 0.002 ps
    // (omega H = 2, where its velocities are processed): the centre-of-mass kinetic temperature must be 300 K and the
    // relative one 5 K, within 5 standard errors of 20 block means plus 0.002 relative for the splitting bias
    // (a H^2 <= 4e-4).
    const int copies = 300;
    const double mu = DrudePairs::CoreMass * DrudePairs::DrudeMass / (DrudePairs::CoreMass + DrudePairs::DrudeMass);
    const double k = 1e6 * mu, temperature = 300, stiffTemperature = 5;
    DrudePairs pairs(copies, k, 1.0);
    const std::pair<StochasticImpulseIntegrator::Splitting, double> runs[] = {
        {StochasticImpulseIntegrator::Strang, 0.02}, {StochasticImpulseIntegrator::Filtered, 0.002}};
    for (const auto& run : runs) {
        SCOPED_TRACE(run.second);
        StochasticImpulseIntegrator integrator(temperature, 2.0, run.second, StiffMask);
        integrator.setSplitting(run.first);
        integrator.setStiffModeTemperature(stiffTemperature);
        integrator.setStiffModeFriction(20.0);
        integrator.setRandomNumberSeed(23);
        Context context(pairs.system, integrator, platform(), properties());
        context.setPositions(vector<Vec3>(2 * copies));
        // 5 ps before sampling, then a sample every 0.25 ps (blocks of 2.5 ps; the centre of mass decorrelates in
        // 0.5 ps).
        const int stride = (int)std::lround(0.25 / run.second);
        integrator.step(20 * stride);
        const int blocks = 20, samples = 10;
        const double M = DrudePairs::CoreMass + DrudePairs::DrudeMass;
        vector<double> centre, relative;
        for (int b = 0; b < blocks; ++b) {
            double tc = 0, tr = 0;
            for (int s = 0; s < samples; ++s) {
                integrator.step(stride);
                const vector<Vec3> v = velocitiesOf(context);
                for (int c = 0; c < copies; ++c) {
                    const Vec3 vc = (v[2 * c] * DrudePairs::CoreMass + v[2 * c + 1] * DrudePairs::DrudeMass) / M;
                    const Vec3 vr = v[2 * c + 1] - v[2 * c];
                    tc += M * vc.dot(vc) / (3 * BOLTZ * temperature) / (copies * samples);
                    tr += mu * vr.dot(vr) / (3 * BOLTZ * stiffTemperature) / (copies * samples);
                }
            }
            centre.push_back(tc);
            relative.push_back(tr);
        }
        for (auto* series : {&centre, &relative}) {
            const BlockMean m = blockMean(*series);
            EXPECT_NEAR(1.0, m.mean, 5 * m.standardError + 0.002)
                << (series == &centre ? "centre-of-mass" : "relative") << " temperature ratio";
        }
    }
}

TEST_P(ImpulseModeBath, UnsetOrEqualBathsGiveTodaysTrajectoryBitForBit) {
    // Setting the stiff modes' bath to the integrator's own values changes nothing, and unset it follows changes of the
    // integrator's temperature and friction.
    DrudePairs pairs(20, 5e4, 1.0);
    auto run = [&](bool setBath) {
        StochasticImpulseIntegrator integrator(250, 3.0, 0.004, StiffMask);
        integrator.setRandomNumberSeed(4);
        if (setBath) {
            integrator.setStiffModeTemperature(320);
            integrator.setStiffModeFriction(7.0);
        }
        Context context(pairs.system, integrator, platform(), properties());
        vector<Vec3> q;
        for (int i = 0; i < 40; ++i)
            q.push_back(Vec3(0.01 * i, 0.002 * (i % 3), -0.003 * (i % 5)));
        context.setPositions(q);
        integrator.step(10);
        integrator.setTemperature(320);
        integrator.setFriction(7.0);
        integrator.step(10);
        return std::make_pair(positionsOf(context), velocitiesOf(context));
    };
    // Bath set to (320 K, 7/ps) throughout differs from following (250 K, 3/ps) then (320 K, 7/ps)...
    const auto followed = run(false), fixed = run(true);
    EXPECT_GT(relativeDifference(followed.first, fixed.first), 0.0);
    // ...and explicitly equal values reproduce following exactly.
    StochasticImpulseIntegrator a(300, 2.0, 0.004, StiffMask), b(300, 2.0, 0.004, StiffMask);
    b.setStiffModeTemperature(300);
    b.setStiffModeFriction(2.0);
    a.setRandomNumberSeed(9);
    b.setRandomNumberSeed(9);
    Context ca(pairs.system, a, platform(), properties()), cb(pairs.system, b, platform(), properties());
    vector<Vec3> q(40, Vec3(0.01, 0.02, 0.03));
    q[1] = Vec3(0.02, 0.01, 0.0);
    ca.setPositions(q);
    cb.setPositions(q);
    a.step(20);
    b.step(20);
    EXPECT_EQ(0.0, relativeDifference(positionsOf(ca), positionsOf(cb)));
    EXPECT_EQ(0.0, relativeDifference(velocitiesOf(ca), velocitiesOf(cb)));
}

TEST(ImpulseModeBathInput, DefaultsFollowTheIntegratorAndBadValuesAreRejected) {
    StochasticImpulseIntegrator integrator(300, 2.0, 0.002, StiffMask);
    EXPECT_FALSE(integrator.hasStiffModeTemperature());
    EXPECT_FALSE(integrator.hasStiffModeFriction());
    EXPECT_EQ(300.0, integrator.getStiffModeTemperature());
    EXPECT_EQ(2.0, integrator.getStiffModeFriction());
    integrator.setTemperature(310);
    integrator.setFriction(1.0);
    EXPECT_EQ(310.0, integrator.getStiffModeTemperature());
    EXPECT_EQ(1.0, integrator.getStiffModeFriction());
    integrator.setStiffModeTemperature(1.0);
    integrator.setStiffModeFriction(20.0);
    integrator.setTemperature(300);
    EXPECT_EQ(1.0, integrator.getStiffModeTemperature());
    EXPECT_EQ(20.0, integrator.getStiffModeFriction());
    expectRejected([&] { integrator.setStiffModeTemperature(-1); }, {"stiffModeTemperature", "-1", ">= 0", "K"});
    expectRejected([&] { integrator.setStiffModeTemperature(NAN); }, {"stiffModeTemperature", "nan", "finite"});
    expectRejected([&] { integrator.setStiffModeFriction(-0.5); }, {"stiffModeFriction", "-0.5", ">= 0", "1/ps"});
    expectRejected([&] { integrator.setStiffModeFriction(INFINITY); }, {"stiffModeFriction", "inf", "finite"});
    EXPECT_EQ(1.0, integrator.getStiffModeTemperature());
    EXPECT_EQ(20.0, integrator.getStiffModeFriction());
    // Yoshida4 runs a substep backwards in time: no friction anywhere.
    integrator.setFriction(0);
    expectRejected([&] { integrator.setSplitting(StochasticImpulseIntegrator::Yoshida4); },
                   {"splitting", "Yoshida4", "friction 0", "20"});
    integrator.setStiffModeFriction(0);
    integrator.setSplitting(StochasticImpulseIntegrator::Yoshida4);
    expectRejected([&] { integrator.setStiffModeFriction(3); }, {"stiffModeFriction", "3", "Yoshida4"});
}

TEST(ImpulseModeBathInput, SerializationKeepsTheBathAndReadsVersion1) {
    // Written as version 3 (version 2 added the bath, version 3 the thermostat placement).
    StochasticImpulseIntegrator integrator(300, 5.0, 0.002, StiffMask);
    integrator.setStiffModeTemperature(1.0);
    integrator.setStiffModeFriction(20.0);
    std::stringstream buffer;
    XmlSerializer::serialize<Integrator>(&integrator, "Integrator", buffer);
    EXPECT_NE(std::string::npos, buffer.str().find("version=\"3\""));
    std::unique_ptr<Integrator> copy(XmlSerializer::deserialize<Integrator>(buffer));
    auto* sim = dynamic_cast<StochasticImpulseIntegrator*>(copy.get());
    ASSERT_NE(nullptr, sim);
    EXPECT_EQ(1.0, sim->getStiffModeTemperature());
    EXPECT_EQ(20.0, sim->getStiffModeFriction());
    // Unset stays unset (following the integrator).
    StochasticImpulseIntegrator plain(300, 5.0, 0.002, StiffMask);
    std::stringstream plainBuffer;
    XmlSerializer::serialize<Integrator>(&plain, "Integrator", plainBuffer);
    std::unique_ptr<Integrator> plainCopy(XmlSerializer::deserialize<Integrator>(plainBuffer));
    EXPECT_FALSE(dynamic_cast<StochasticImpulseIntegrator&>(*plainCopy).hasStiffModeTemperature());
    // A version 1 document, as written before the stiff-mode bath existed.
    std::stringstream version1("<?xml version=\"1.0\" ?>\n<Integrator constraintTolerance=\"1e-05\" friction=\"5\" "
                               "integrationForceGroups=\"-1\" randomSeed=\"0\" splitting=\"1\" stepSize=\".002\" "
                               "stiffGroups=\"2\" temperature=\"300\" type=\"StochasticImpulseIntegrator\" "
                               "version=\"1\"/>\n");
    std::unique_ptr<Integrator> old(XmlSerializer::deserialize<Integrator>(version1));
    auto& oldSim = dynamic_cast<StochasticImpulseIntegrator&>(*old);
    EXPECT_FALSE(oldSim.hasStiffModeTemperature());
    EXPECT_FALSE(oldSim.hasStiffModeFriction());
    EXPECT_EQ(300.0, oldSim.getStiffModeTemperature());
    EXPECT_EQ(5.0, oldSim.getStiffModeFriction());
    EXPECT_EQ(0.002, oldSim.getStepSize());
}

namespace {

/** The temperatures (K) of the pairs' centre-of-mass motion and of their relative motion, from the velocities. */
std::pair<double, double> pairTemperatures(const vector<Vec3>& v, int pairs) {
    const double M = DrudePairs::CoreMass + DrudePairs::DrudeMass;
    const double mu = DrudePairs::CoreMass * DrudePairs::DrudeMass / M;
    double centre = 0, relative = 0;
    for (int c = 0; c < pairs; ++c) {
        const Vec3 com = (v[2 * c] * DrudePairs::CoreMass + v[2 * c + 1] * DrudePairs::DrudeMass) / M;
        const Vec3 rel = v[2 * c + 1] - v[2 * c];
        centre += M * com.dot(com);
        relative += mu * rel.dot(rel);
    }
    return {centre / (3 * pairs * BOLTZ), relative / (3 * pairs * BOLTZ)};
}

} // namespace

TEST_P(ImpulseModeBath, SetVelocitiesToTemperatureGivesThePairsRelativeMotionTheStiffModeTemperature) {
    // 2,000 pairs: each temperature is a mean of 6,000 squared normals, relative standard error sqrt(2/6000) = 1.8 %;
    // the bounds are 5 of those.
    const int pairs = 2000;
    DrudePairs drudes(pairs, 4e5, 1.0);
    StochasticImpulseIntegrator sim(300.0, 5.0, 0.002, StiffMask);
    sim.setStiffModeTemperature(1.0);
    Context context(drudes.system, sim, platform(), properties());
    context.setPositions(vector<Vec3>(2 * pairs, Vec3()));
    context.setVelocitiesToTemperature(300.0, 17);
    const std::pair<double, double> t = pairTemperatures(context.getState(State::Velocities).getVelocities(), pairs);
    const double bound = 5 * std::sqrt(2.0 / (3 * pairs));
    EXPECT_NEAR(t.first, 300.0, 300.0 * bound);
    EXPECT_NEAR(t.second, 1.0, 1.0 * bound);
}

TEST(ImpulseModeBathInput, WithoutAStiffModeTemperatureVelocitiesAreOpenMMsOwn) {
    // Until setStiffModeTemperature() the stiff modes follow the integrator's temperature: the draw is Integrator's,
    // the one a VerletIntegrator's Context makes from the same seed.
    DrudePairs drudes(50, 4e5, 1.0);
    StochasticImpulseIntegrator sim(300.0, 5.0, 0.002, StiffMask);
    VerletIntegrator verlet(0.002);
    vector<vector<Vec3>> velocities;
    for (Integrator* integrator : {static_cast<Integrator*>(&sim), static_cast<Integrator*>(&verlet)}) {
        Context context(drudes.system, *integrator, Platform::getPlatformByName("Reference"));
        context.setPositions(vector<Vec3>(100, Vec3()));
        context.setVelocitiesToTemperature(300.0, 5);
        velocities.push_back(context.getState(State::Velocities).getVelocities());
    }
    for (size_t i = 0; i < velocities[0].size(); ++i)
        EXPECT_EQ(0.0, (velocities[0][i] - velocities[1][i]).dot(velocities[0][i] - velocities[1][i]))
            << "particle " << i;
}
