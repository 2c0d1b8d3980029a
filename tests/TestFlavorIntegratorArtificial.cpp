// The artificial FLAVOR (FLAVORS paper, eq. (2.11), Theorem 5.1): reductions, the transfer matrix (5.5), the
// stability boundary 2 sqrt(2), true stiff statistics, and conformance with compositions written here.

#include "Diatomics.h"
#include "FlavorIntegrator.h"
#include "FrozenStage.h"
#include "PlatformTest.h"
#include "TestSystems.h"
#include "openmm/Context.h"
#include "openmm/CustomBondForce.h"
#include "openmm/CustomExternalForce.h"
#include "openmm/HarmonicAngleForce.h"
#include "openmm/HarmonicBondForce.h"
#include "openmm/OpenMMException.h"
#include "openmm/PeriodicTorsionForce.h"
#include "openmm/VerletIntegrator.h"
#include "openmm/reference/SimTKOpenMMRealType.h"
#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <iostream>
#include <map>
#include <memory>
#include <random>
#include <sstream>

using namespace FlavorPlugin;
using namespace FlavorTests;
using namespace OpenMM;
using std::vector;

class FlavorArtificial : public PlatformTest {};
INSTANTIATE_ON_ALL_PLATFORMS(FlavorArtificial);

namespace {

typedef std::array<std::array<double, 4>, 4> Matrix4;
typedef std::array<double, 4> State4; // (y, x, p_y, p_x), the order of (5.2)

Matrix4 identity4() {
    Matrix4 m{};
    for (int i = 0; i < 4; ++i)
        m[i][i] = 1;
    return m;
}

Matrix4 operator*(const Matrix4& a, const Matrix4& b) {
    Matrix4 c{};
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j)
            for (int k = 0; k < 4; ++k)
                c[i][j] += a[i][k] * b[k][j];
    return c;
}

State4 operator*(const Matrix4& a, const State4& s) {
    State4 r{};
    for (int i = 0; i < 4; ++i)
        for (int k = 0; k < 4; ++k)
            r[i] += a[i][k] * s[k];
    return r;
}

// The factors of (5.5) for system (5.1) (unit masses), each acting on (y, x, p_y, p_x).
Matrix4 softKick(double h) { // p_x -= h x
    Matrix4 m = identity4();
    m[3][1] = -h;
    return m;
}
Matrix4 projectedSoftKick(double h) { // the soft impulse -h x (0, 1) projected on the zero mode (1, 1)/sqrt2
    Matrix4 m = identity4();
    m[2][1] = -h / 2;
    m[3][1] = -h / 2;
    return m;
}
Matrix4 drift(double h) {
    Matrix4 m = identity4();
    m[0][2] = h;
    m[1][3] = h;
    return m;
}
Matrix4 stiffKick(double h, double omega) { // p_y -= h w^2 (y - x), p_x += h w^2 (y - x)
    Matrix4 m = identity4();
    const double k = h * omega * omega;
    m[2][0] = -k;
    m[2][1] = k;
    m[3][0] = k;
    m[3][1] = -k;
    return m;
}
Matrix4 frozenDrift(double h) { // x and y drift with their mean velocity
    Matrix4 m = identity4();
    m[0][2] = m[0][3] = m[1][2] = m[1][3] = h / 2;
    return m;
}
/** The exact flow of the stiff part: the mean drifts, r = y - x oscillates at sqrt(2) omega. */
Matrix4 exactStiffFlow(double h, double omega) {
    const double w = std::sqrt(2.0) * omega, c = std::cos(w * h), s = std::sin(w * h);
    // mean m = (y+x)/2, r = y - x; momenta P = p_y + p_x, p = (p_y - p_x)/2 with r' = 2p, p' = -w^2 r / 2.
    // Written on (y, x, p_y, p_x) by composing the change of variables by hand.
    Matrix4 toModes{}, fromModes{}, flow{};
    toModes[0] = {0.5, 0.5, 0, 0};  // m
    toModes[1] = {1, -1, 0, 0};     // r
    toModes[2] = {0, 0, 1, 1};      // P
    toModes[3] = {0, 0, 0.5, -0.5}; // p
    fromModes[0] = {1, 0.5, 0, 0};  // y = m + r/2
    fromModes[1] = {1, -0.5, 0, 0}; // x = m - r/2
    fromModes[2] = {0, 0, 0.5, 1};  // p_y = P/2 + p
    fromModes[3] = {0, 0, 0.5, -1}; // p_x = P/2 - p
    flow[0] = {1, 0, h / 2, 0};     // m' = P/2
    flow[1] = {0, c, 0, 2 * s / w}; // r' = 2 p
    flow[2] = {0, 0, 1, 0};
    flow[3] = {0, -w * s / 2, 0, c}; // p' = -w^2 r / 2
    return fromModes * flow * toModes;
}

/** The one-step map of the artificial FLAVOR on (5.1), composed here from its factors (rightmost acts first). */
Matrix4 artificialMap(FlavorIntegrator::Scheme scheme, bool projected, bool exact, double delta, double tau,
                      double omega) {
    auto kickS = [&](double h) {
        return projected ? projectedSoftKick(h - h * (tau / delta)) * softKick(h * (tau / delta)) : softKick(h);
    };
    if (scheme == FlavorIntegrator::SymplecticEuler) {
        Matrix4 fast = exact ? exactStiffFlow(tau, omega) : stiffKick(tau, omega) * drift(tau);
        return frozenDrift(delta - tau) * fast * kickS(delta);
    }
    Matrix4 fast =
        exact ? exactStiffFlow(tau, omega) : stiffKick(tau / 2, omega) * drift(tau) * stiffKick(tau / 2, omega);
    return kickS(delta / 2) * frozenDrift((delta - tau) / 2) * fast * frozenDrift((delta - tau) / 2) * kickS(delta / 2);
}

/** Eq. (5.5), as printed. */
Matrix4 transferMatrix5_5(double delta, double tau, double omega) {
    return frozenDrift(delta - tau) * stiffKick(tau, omega) * drift(tau) * softKick(delta);
}

State4 stateOf(Context& context) {
    vector<Vec3> q = positionsOf(context), v = velocitiesOf(context);
    return {q[1][0], q[0][0], v[1][0], v[0][0]};
}

void setState(Context& context, const State4& s) {
    context.setPositions({Vec3(s[1], 0, 0), Vec3(s[0], 0, 0)});
    context.setVelocities({Vec3(s[3], 0, 0), Vec3(s[2], 0, 0)});
}

double maxDifference(const State4& a, const State4& b) {
    double d = 0;
    for (int i = 0; i < 4; ++i)
        d = std::max(d, std::abs(a[i] - b[i]));
    return d;
}

vector<Vec3> fpuVelocities() {
    return {Vec3(0.3, 0, 0), Vec3(-0.2, 0, 0), Vec3(0.1, 0, 0), Vec3(0.5, 0, 0), Vec3(-0.4, 0, 0), Vec3(0.2, 0, 0)};
}

} // namespace

TEST_P(FlavorArtificial, OneStepMapIsTheTransferMatrix5_5AndItsVariants) {
    const double omega = 1000, delta = 0.3, tau = 2e-4;
    std::unique_ptr<System> system(linearSystem(omega));
    const State4 s0 = {0.8 + 1.1 / omega, 0.8, 0.7, -0.4};
    // The factors above are checked against (5.5) itself.
    {
        FlavorIntegrator integrator(delta, tau, StiffMask);
        integrator.setScheme(FlavorIntegrator::SymplecticEuler);
        integrator.setAveraging(FlavorIntegrator::Artificial);
        Context context(*system, integrator, platform(), properties());
        setState(context, s0);
        integrator.step(1);
        const State4 expected = transferMatrix5_5(delta, tau, omega) * s0;
        EXPECT_LE(maxDifference(stateOf(context), expected), 1e-12 * omega);
    }
    for (auto scheme : {FlavorIntegrator::SymplecticEuler, FlavorIntegrator::Verlet})
        for (bool projected : {false, true})
            for (bool exact : {false, true}) {
                FlavorIntegrator integrator(delta, tau, StiffMask);
                integrator.setScheme(scheme);
                integrator.setAveraging(projected ? FlavorIntegrator::ArtificialProjected
                                                  : FlavorIntegrator::Artificial);
                integrator.setExactFastFlow(exact);
                Context context(*system, integrator, platform(), properties());
                setState(context, s0);
                integrator.step(3);
                const Matrix4 map = artificialMap(scheme, projected, exact, delta, tau, omega);
                const State4 expected = map * (map * (map * s0));
                EXPECT_LE(maxDifference(stateOf(context), expected), 1e-9)
                    << "scheme " << scheme << " projected " << projected << " exact " << exact;
                // Only the x components ever move.
                for (const Vec3& q : positionsOf(context))
                    EXPECT_EQ(0.0, std::abs(q[1]) + std::abs(q[2]));
            }
}

TEST_P(FlavorArtificial, StabilityBoundaryOfTheorem5_1IsTwoSqrtTwo) {
    // System (5.1), omega = 1000, tau omega = 1e-5.  With tau -> 0 the slow mean (x+y)/2 feels half the soft force
    // (-x/2): symplectic Euler at frequency 1/sqrt2, stable iff delta < 2 sqrt2 = 2.83; at delta = 2.95 an eigenvalue
    // is -1.79.  The nonintrusive FLAVOR's boundary is 2 (TestFlavorIntegratorAccuracy).
    const double omega = 1000, tau = 1e-8;
    std::unique_ptr<System> system(linearSystem(omega));
    for (auto scheme : {FlavorIntegrator::SymplecticEuler, FlavorIntegrator::Verlet})
        for (double delta : {2.7, 2.95}) {
            FlavorIntegrator integrator(delta, tau, StiffMask);
            integrator.setScheme(scheme);
            integrator.setAveraging(FlavorIntegrator::Artificial);
            Context context(*system, integrator, platform(), properties());
            context.setPositions({Vec3(0.8, 0, 0), Vec3(0.8011, 0, 0)});
            double largest = 0;
            for (int block = 0; block < 50; ++block) {
                integrator.step(10);
                for (const Vec3& q : positionsOf(context))
                    largest = std::max(largest, std::isfinite(q[0]) ? std::abs(q[0]) : INFINITY);
            }
            // Symplectic Euler on q'' = -q/2 started at rest keeps |q| <= |q0| / sqrt(1 - delta^2/8).
            if (delta < 2 * std::sqrt(2.0))
                EXPECT_LE(largest, 1.1 * 0.8011 / std::sqrt(1 - delta * delta / 8)) << "scheme " << scheme;
            else // OpenCL's fixed-point forces saturate, after which the positions grow only about linearly: to
                 // 2.5e11 on an NVIDIA H200 and 1e15 on PoCL in these 500 steps, 1e6 times the start
                EXPECT_GT(largest, isGpu() ? 1e6 : 1e50) << "scheme " << scheme;
        }
}

TEST_P(FlavorArtificial, VerletWithEqualStepsIsTheNonintrusiveSchemeBitForBit) {
    const double h = 1e-3;
    std::unique_ptr<System> system(fpuSystem(3, 50.0));
    vector<Vec3> q0 = fpuPositions({1, 0.2, -0.3}, {1 / 50.0, 0.01, 0}), v0 = fpuVelocities();
    vector<vector<Vec3>> q, v;
    for (auto averaging :
         {FlavorIntegrator::Nonintrusive, FlavorIntegrator::Artificial, FlavorIntegrator::ArtificialProjected}) {
        FlavorIntegrator integrator(h, h, StiffMask);
        integrator.setAveraging(averaging);
        Context context(*system, integrator, platform(), properties());
        context.setPositions(q0);
        context.setVelocities(v0);
        integrator.step(300);
        q.push_back(positionsOf(context));
        v.push_back(velocitiesOf(context));
    }
    for (int a = 1; a < 3; ++a)
        for (size_t i = 0; i < q0.size(); ++i)
            for (int d = 0; d < 3; ++d) {
                EXPECT_EQ(q[0][i][d], q[a][i][d]) << "averaging " << a << " particle " << i;
                EXPECT_EQ(v[0][i][d], v[a][i][d]) << "averaging " << a << " particle " << i;
            }
}

TEST_P(FlavorArtificial, FrozenStageHoldsTheStiffCoordinatesAndRestoresTheirRates) {
    // With tau << delta the fast microstep barely moves the stiff springs: over a step the spring extensions change by
    // the fast microstep alone, tau times their rates, and the rates change only by the stiff and soft kicks.  With
    // every soft force off (an empty integration group for it), a SymplecticEuler step is D(tau) K_stiff(tau) then
    // the frozen drift: the extensions move by exactly tau (rate), the pair centres by delta (mean velocity).
    const double delta = 0.01, tau = 1e-4, omega = 50;
    std::unique_ptr<System> system(fpuSystem(3, omega));
    vector<Vec3> q0 = fpuPositions({1, 0.2, -0.3}, {1 / omega, 0.01, 0}), v0 = fpuVelocities();
    // A FLAVOR System needs a soft force: a zero one, in a group of its own, stands in for the switched-off ones.
    CustomExternalForce* zeroSoftForce = new CustomExternalForce("0");
    zeroSoftForce->setForceGroup(3);
    system->addForce(zeroSoftForce);
    FlavorIntegrator integrator(delta, tau, StiffMask);
    integrator.setScheme(FlavorIntegrator::SymplecticEuler);
    integrator.setAveraging(FlavorIntegrator::Artificial);
    integrator.setIntegrationForceGroups(StiffMask | (1 << 3));
    Context context(*system, integrator, platform(), properties());
    context.setPositions(q0);
    context.setVelocities(v0);
    integrator.step(1);
    vector<Vec3> q1 = positionsOf(context), v1 = velocitiesOf(context);
    for (int pair = 0; pair < 3; ++pair) {
        const int a = 2 * pair, b = a + 1;
        const double extension0 = q0[b][0] - q0[a][0], rate0 = v0[b][0] - v0[a][0];
        const double extension1 = extension0 + tau * rate0;
        // K_stiff(tau): relative rate changes by -2 tau k x / m with k = omega^2/2.
        const double rate1 = rate0 - 2 * tau * (omega * omega / 2) * extension1;
        EXPECT_NEAR(extension1, q1[b][0] - q1[a][0], 1e-14);
        EXPECT_NEAR(rate1, v1[b][0] - v1[a][0], 1e-12);
        const double centre0 = (q0[a][0] + q0[b][0]) / 2, meanVelocity = (v0[a][0] + v0[b][0]) / 2;
        EXPECT_NEAR(centre0 + delta * meanVelocity, (q1[a][0] + q1[b][0]) / 2, 1e-14);
        EXPECT_NEAR(meanVelocity, (v1[a][0] + v1[b][0]) / 2, 1e-14);
    }
}

TEST_P(FlavorArtificial, BothCompositionsMatchAnIndependentImplementationOnTheFpuChain) {
    // The FPU chain (6.7): stiff springs omega^2/4 (q2 - q1)^2, soft (q3 - q2)^4 and walls q^4; unit masses.  The
    // frozen drift moves each stiff pair with its mean velocity; the projected soft kick gives the pair's relative
    // velocity the soft impulse over tau only.
    const int m = 3;
    const double omega = 100, delta = 0.004, tau = 2e-4;
    const int steps = 200;
    std::unique_ptr<System> system(fpuSystem(m, omega));
    const vector<Vec3> q0 = fpuPositions({1, 0.2, -0.3}, {1 / omega, 0.01, 0}), v0 = fpuVelocities();
    const int n = 2 * m;
    auto softForce = [&](const vector<double>& q) {
        vector<double> f(n, 0.0);
        f[0] -= 4 * std::pow(q[0], 3);
        f[n - 1] -= 4 * std::pow(q[n - 1], 3);
        for (int i = 1; i + 1 < n; i += 2) {
            const double r = q[i + 1] - q[i];
            f[i] += 4 * r * r * r;
            f[i + 1] -= 4 * r * r * r;
        }
        return f;
    };
    auto stiffForce = [&](const vector<double>& q) {
        vector<double> f(n, 0.0);
        for (int i = 0; i < n; i += 2) {
            const double r = q[i + 1] - q[i], k = omega * omega / 2;
            f[i] += k * r;
            f[i + 1] -= k * r;
        }
        return f;
    };
    for (auto scheme : {FlavorIntegrator::SymplecticEuler, FlavorIntegrator::Verlet})
        for (bool projected : {false, true}) {
            vector<double> q(n), v(n);
            for (int i = 0; i < n; ++i) {
                q[i] = q0[i][0];
                v[i] = v0[i][0];
            }
            auto kick = [&](const vector<double>& f, double h) {
                for (int i = 0; i < n; ++i)
                    v[i] += h * f[i];
            };
            auto softKick = [&](double h) {
                const vector<double> f = softForce(q);
                const double full = projected ? h * (tau / delta) : h;
                kick(f, full);
                for (int i = 0; i < n; i += 2) { // the rest along each pair's mean only
                    const double mean = (f[i] + f[i + 1]) / 2 * (h - full);
                    v[i] += mean;
                    v[i + 1] += mean;
                }
            };
            auto driftAll = [&](double h) {
                for (int i = 0; i < n; ++i)
                    q[i] += h * v[i];
            };
            auto frozen = [&](double h) {
                for (int i = 0; i < n; i += 2) {
                    const double mean = (v[i] + v[i + 1]) / 2;
                    q[i] += h * mean;
                    q[i + 1] += h * mean;
                }
            };
            for (int s = 0; s < steps; ++s) {
                if (scheme == FlavorIntegrator::SymplecticEuler) {
                    softKick(delta);
                    driftAll(tau);
                    kick(stiffForce(q), tau);
                    frozen(delta - tau);
                } else {
                    softKick(delta / 2);
                    frozen((delta - tau) / 2);
                    kick(stiffForce(q), tau / 2);
                    driftAll(tau);
                    kick(stiffForce(q), tau / 2);
                    frozen((delta - tau) / 2);
                    softKick(delta / 2);
                }
            }
            FlavorIntegrator integrator(delta, tau, StiffMask);
            integrator.setScheme(scheme);
            integrator.setAveraging(projected ? FlavorIntegrator::ArtificialProjected : FlavorIntegrator::Artificial);
            Context context(*system, integrator, platform(), properties());
            context.setPositions(q0);
            context.setVelocities(v0);
            integrator.step(steps);
            vector<Vec3> q1 = positionsOf(context), v1 = velocitiesOf(context);
            for (int i = 0; i < n; ++i) {
                EXPECT_NEAR(q[i], q1[i][0], 1e-10) << "scheme " << scheme << " projected " << projected;
                EXPECT_NEAR(v[i], v1[i][0], 1e-8) << "scheme " << scheme << " projected " << projected;
            }
        }
}

namespace {

/**
 * N independent pairs joined by a stiff spring of rest length 0 (k |r|^2 / 2, r = q2 - q1, group StiffGroup), the
 * first particle of each tethered by a soft harmonic potential ks |q|^2 / 2; unit masses.
 */
System* stiffPairs(int pairs, double k, double ks) {
    System* system = new System();
    HarmonicBondForce* stiff = new HarmonicBondForce();
    stiff->setForceGroup(StiffGroup);
    CustomExternalForce* soft = new CustomExternalForce("0.5*ks*(x^2+y^2+z^2)");
    soft->addGlobalParameter("ks", ks);
    soft->setForceGroup(SoftGroup);
    for (int p = 0; p < pairs; ++p) {
        system->addParticle(1.0);
        system->addParticle(1.0);
        stiff->addBond(2 * p, 2 * p + 1, 0.0, k);
        soft->addParticle(2 * p);
    }
    system->addForce(stiff);
    system->addForce(soft);
    return system;
}

} // namespace

TEST_P(FlavorArtificial, LangevinArtificialFlavorSamplesTheStiffCoordinatesWithTheirTrueVariance) {
    // k <|r|^2> = 3 kT in equilibrium.  The nonintrusive FLAVOR samples H_eff, whose spring is k tau/delta: k <|r|^2>
    // = 3 kT delta/tau.  Pairs are independent, so the standard error of the mean over pairs of each pair's time
    // average is a sound error bar; the bound is 4 standard errors.  The stiff mode (frequency sqrt(2k)) has
    // tau sqrt(2k) = 0.014, so the microstep's own bias (of order (tau omega)^2) is far below it.
    const int pairs = 200;
    const double k = 1e4, ks = 1.0, temperature = 300, kT = BOLTZ * temperature, tau = 1e-4;
    std::unique_ptr<System> system(stiffPairs(pairs, k, ks));
    struct Case {
        FlavorIntegrator::Averaging averaging;
        bool exact;
        double ratio;
    };
    const vector<Case> cases = {{FlavorIntegrator::Artificial, false, 4},
                                {FlavorIntegrator::Artificial, false, 25},
                                {FlavorIntegrator::ArtificialProjected, true, 25},
                                {FlavorIntegrator::Nonintrusive, false, 4},
                                {FlavorIntegrator::Nonintrusive, false, 25}};
    std::mt19937 generator(2024);
    std::normal_distribution<double> normal;
    for (const Case& c : cases) {
        const double delta = c.ratio * tau;
        const double expected = 3 * kT * (c.averaging == FlavorIntegrator::Nonintrusive ? c.ratio : 1.0);
        FlavorIntegrator integrator(delta, tau, StiffMask);
        integrator.setAveraging(c.averaging);
        integrator.setExactFastFlow(c.exact);
        integrator.setTemperature(temperature);
        integrator.setFriction(20.0);
        integrator.setRandomNumberSeed(11);
        Context context(*system, integrator, platform(), properties());
        // Start near the target distribution: r with variance expected/(3k) per coordinate, centres near the tether.
        vector<Vec3> q(2 * pairs), v(2 * pairs);
        const double sigmaR = std::sqrt(expected / (3 * k)), sigmaV = std::sqrt(kT);
        for (int p = 0; p < pairs; ++p) {
            Vec3 centre(0.1 * normal(generator), 0.1 * normal(generator), 0.1 * normal(generator));
            Vec3 r(sigmaR * normal(generator), sigmaR * normal(generator), sigmaR * normal(generator));
            q[2 * p] = centre - r * 0.5;
            q[2 * p + 1] = centre + r * 0.5;
            for (int i : {2 * p, 2 * p + 1})
                v[i] = Vec3(sigmaV * normal(generator), sigmaV * normal(generator), sigmaV * normal(generator));
        }
        context.setPositions(q);
        context.setVelocities(v);
        integrator.step(500);
        const int samples = 150, interval = 20;
        vector<double> average(pairs, 0.0);
        for (int s = 0; s < samples; ++s) {
            integrator.step(interval);
            vector<Vec3> x = positionsOf(context);
            for (int p = 0; p < pairs; ++p) {
                Vec3 r = x[2 * p + 1] - x[2 * p];
                average[p] += k * r.dot(r) / samples;
            }
        }
        double mean = 0, variance = 0;
        for (double a : average)
            mean += a / pairs;
        for (double a : average)
            variance += (a - mean) * (a - mean) / (pairs - 1);
        const double standardError = std::sqrt(variance / pairs);
        std::cout << "[ measured ] averaging " << c.averaging << " delta/tau " << c.ratio
                  << ": k<|r|^2>/(3 kT) = " << mean / (3 * kT) << " +- " << standardError / (3 * kT) << std::endl;
        EXPECT_LE(std::abs(mean - expected), 4 * standardError)
            << "averaging " << c.averaging << " delta/tau " << c.ratio << ": k<r^2> " << mean << " expected "
            << expected << " +- " << standardError;
        // The error bar resolves the factor delta/tau.
        EXPECT_LT(4 * standardError, 0.25 * expected);
    }
}

TEST_P(FlavorArtificial, AStiffForceThatCanNeverBeFrozenIsRejectedAtContextCreation) {
    // A torsion is neither quadratic nor a known distance: known without positions, so rejected at Context creation,
    // and by setAveraging and setStiffGroups on a Context that runs the Nonintrusive averaging, which stays usable.
    std::unique_ptr<System> system(new System());
    for (int i = 0; i < 4; ++i)
        system->addParticle(12.0);
    PeriodicTorsionForce* torsion = new PeriodicTorsionForce();
    torsion->addTorsion(0, 1, 2, 3, 3, 0.0, 5.0);
    torsion->setForceGroup(StiffGroup);
    system->addForce(torsion);
    CustomExternalForce* soft = new CustomExternalForce("x^2+y^2+z^2");
    for (int i = 0; i < 4; ++i)
        soft->addParticle(i);
    soft->setForceGroup(SoftGroup);
    system->addForce(soft);
    const vector<Vec3> positions = {Vec3(0, 0.1, 0), Vec3(0, 0, 0), Vec3(0.15, 0, 0), Vec3(0.15, 0.1, 0.05)};
    auto expectMessage = [](const OpenMMException& e) {
        const std::string message = e.what();
        for (const char* part : {"force 0 (PeriodicTorsionForce", "addFrozenDistance", "Nonintrusive"})
            EXPECT_NE(std::string::npos, message.find(part)) << message;
    };
    {
        FlavorIntegrator integrator(0.002, 0.0005, StiffMask);
        integrator.setAveraging(FlavorIntegrator::ArtificialProjected);
        try {
            Context context(*system, integrator, platform(), properties());
            FAIL() << "a stiff torsion was accepted by the artificial averaging";
        } catch (const OpenMMException& e) {
            expectMessage(e);
        }
    }
    FlavorIntegrator integrator(0.002, 0.0005, StiffMask);
    Context context(*system, integrator, platform(), properties());
    context.setPositions(positions);
    integrator.step(2);
    try {
        integrator.setAveraging(FlavorIntegrator::Artificial);
        FAIL() << "setAveraging accepted a stiff torsion";
    } catch (const OpenMMException& e) {
        expectMessage(e);
    }
    EXPECT_EQ(FlavorIntegrator::Nonintrusive, integrator.getAveraging());
    integrator.step(2);
    EXPECT_EQ(4, context.getStepCount());
    // With a frozen distance declared the user has said what freezes: accepted.
    integrator.addFrozenDistance(0, 3);
    integrator.setAveraging(FlavorIntegrator::Artificial);
    integrator.step(1);
    EXPECT_EQ(5, context.getStepCount());
}

TEST_P(FlavorArtificial, AStiffForceWithoutKnownFrozenCoordinatesIsRejectedAndTheContextStaysUsable) {
    std::unique_ptr<System> system(new System());
    system->addParticle(1.0);
    system->addParticle(1.0);
    CustomExternalForce* quartic = new CustomExternalForce("1e4*x^4");
    quartic->addParticle(1);
    quartic->setForceGroup(StiffGroup);
    system->addForce(quartic);
    CustomExternalForce* soft = new CustomExternalForce("x^2");
    soft->addParticle(0);
    soft->setForceGroup(SoftGroup);
    system->addForce(soft);
    FlavorIntegrator integrator(0.002, 0.0005, StiffMask);
    integrator.setAveraging(FlavorIntegrator::Artificial);
    Context context(*system, integrator, platform(), properties());
    context.setPositions({Vec3(0, 0, 0), Vec3(0.12, 0.01, 0)});
    try {
        integrator.step(1);
        FAIL() << "a stiff force without frozen coordinates was accepted";
    } catch (const OpenMMException& e) {
        const std::string message = e.what();
        for (const char* part :
             {"FlavorIntegrator", "force 0 (CustomExternalForce", "addFrozenDistance", "Nonintrusive"})
            EXPECT_NE(std::string::npos, message.find(part)) << message;
    }
    // The exact fast flow needs a quadratic stiff group.
    integrator.setExactFastFlow(true);
    integrator.addFrozenDistance(0, 1);
    try {
        integrator.step(1);
        FAIL() << "the exact fast flow of a nonlinear stiff group was accepted";
    } catch (const OpenMMException& e) {
        EXPECT_NE(std::string::npos, std::string(e.what()).find("setExactFastFlow")) << e.what();
    }
    // With the frozen distance the stiff group is frozen by constraints; asking for the exact flow afterwards is
    // rejected too, and the Context keeps stepping once it is switched off.
    integrator.setExactFastFlow(false);
    integrator.step(2);
    integrator.setExactFastFlow(true);
    try {
        integrator.step(1);
        FAIL() << "the exact fast flow of a nonlinear stiff group was accepted";
    } catch (const OpenMMException& e) {
        EXPECT_NE(std::string::npos, std::string(e.what()).find("setExactFastFlow(false)")) << e.what();
    }
    integrator.setExactFastFlow(false);
    integrator.step(3);
    integrator.setAveraging(FlavorIntegrator::Nonintrusive);
    integrator.step(5);
    EXPECT_EQ(10, context.getStepCount());
}

namespace {

/**
 * A flexible three-site molecule (0 = O, 1 and 2 = H: two HarmonicBondForce bonds and a HarmonicAngleForce angle,
 * all stiff) and a rigid pair (3, 4: a System constraint) tied to it by a soft CustomBondForce; a soft tether on
 * every particle.
 */
System* bondedMolecule() {
    System* system = new System();
    for (double mass : {16.0, 1.0, 1.0, 12.0, 12.0})
        system->addParticle(mass);
    addStiffBentMolecules(*system, 0);
    CustomBondForce* link = new CustomBondForce("50*(r-0.3)^2");
    link->addBond(0, 3);
    link->setForceGroup(SoftGroup);
    CustomExternalForce* tether = new CustomExternalForce("0.5*(x^2+y^2+z^2)");
    for (int i = 0; i < 5; ++i)
        tether->addParticle(i);
    tether->setForceGroup(SoftGroup);
    system->addConstraint(3, 4, 0.15);
    system->addForce(link);
    system->addForce(tether);
    return system;
}

vector<Vec3> moleculePositions() {
    vector<Vec3> q = bentMoleculePositions();
    q.push_back(Vec3(0.3, 0.01, 0));
    q.push_back(Vec3(0.45, 0.01, 0));
    return q;
}

vector<Vec3> moleculeVelocities() {
    return {Vec3(0.3, -0.2, 0.1), Vec3(2.0, 1.0, -1.5), Vec3(-1.0, 0.5, 2.0), Vec3(0.2, 0.1, 0), Vec3(0.2, 0.1, 0)};
}

} // namespace

TEST_P(FlavorArtificial, FrozenStageHoldsEveryFrozenDistanceAndRestoresTheStoredRates) {
    // Soft forces off: a SymplecticEuler step is D(tau) K_stiff(tau), computed here, then the frozen drift over
    // delta - tau, which must keep the O-H, O-H and H-H (1-3) distances at their values after the microstep, give
    // them back their rates, keep the System constraint, and move the molecule's centre of mass freely.
    const double delta = 0.01, tau = 1e-4, tolerance = 1e-10;
    std::unique_ptr<System> system(bondedMolecule());
    const FrozenStage stage = runFrozenStage(*system, moleculePositions(), moleculeVelocities(), delta, tau, tolerance,
                                             platform(), properties());
    const vector<Vec3>&q1 = stage.q1, &v1 = stage.v1, &q2 = stage.q2, &v2 = stage.v2;
    for (auto pair : {std::make_pair(0, 1), std::make_pair(0, 2), std::make_pair(1, 2)}) {
        EXPECT_NEAR(distance(q1, pair.first, pair.second), distance(q2, pair.first, pair.second), 1e-9)
            << pair.first << "-" << pair.second;
        EXPECT_NEAR(rate(q1, v1, pair.first, pair.second), rate(q2, v2, pair.first, pair.second), 1e-7)
            << pair.first << "-" << pair.second;
    }
    EXPECT_NEAR(0.15, distance(q2, 3, 4), 1e-9);
    // The molecule really moved and turned: the frozen drift is not a no-op.
    EXPECT_GT(std::abs(q2[1][0] - q1[1][0]), 1e-3);
    Vec3 momentum1, momentum2, centre1, centre2;
    double mass = 0;
    for (int i = 0; i < 3; ++i) {
        const double m = system->getParticleMass(i);
        momentum1 += v1[i] * m;
        momentum2 += v2[i] * m;
        centre1 += q1[i] * m;
        centre2 += q2[i] * m;
        mass += m;
    }
    for (int d = 0; d < 3; ++d) {
        EXPECT_NEAR(momentum1[d], momentum2[d], 1e-9);
        EXPECT_NEAR(centre1[d] / mass + (delta - tau) * momentum1[d] / mass, centre2[d] / mass, 1e-11);
    }
}

namespace {

typedef std::array<std::array<double, 3>, 3> Matrix3;

/** Solves a x = b for a 3 x 3 matrix by Cramer's rule. */
std::array<double, 3> solve3(const Matrix3& a, const std::array<double, 3>& b) {
    auto det = [](const Matrix3& m) {
        return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
               m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    };
    const double d = det(a);
    std::array<double, 3> x;
    for (int k = 0; k < 3; ++k) {
        Matrix3 m = a;
        for (int r = 0; r < 3; ++r)
            m[r][k] = b[r];
        x[k] = det(m) / d;
    }
    return x;
}

/**
 * The frozen stage for the three distances of a triangle of particles, written independently of the library: dense
 * 3 x 3 solves for the velocity constraints and Newton's method for the positions (SHAKE's equations).
 */
struct Triangle {
    const int pairs[3][2] = {{0, 1}, {0, 2}, {1, 2}};
    std::array<double, 3> w; // inverse masses
    Vec3 direction(const vector<Vec3>& q, int c) const { return q[pairs[c][0]] - q[pairs[c][1]]; }
    /** v += M^-1 J^T lambda with J v = targets afterwards (J: the unit directions of the distances at q). */
    void setRates(const vector<Vec3>& q, vector<Vec3>& v, const std::array<double, 3>& targets) const {
        Vec3 u[3];
        for (int c = 0; c < 3; ++c) {
            u[c] = direction(q, c);
            u[c] *= 1.0 / std::sqrt(u[c].dot(u[c]));
        }
        Matrix3 a{};
        std::array<double, 3> b;
        for (int c = 0; c < 3; ++c) {
            const int i = pairs[c][0], j = pairs[c][1];
            b[c] = targets[c] - u[c].dot(v[i] - v[j]);
            for (int k = 0; k < 3; ++k) {
                const int ik = pairs[k][0], jk = pairs[k][1];
                // d(u_c . (v_i - v_j)) / d lambda_k with v_p += w_p s_kp u_k.
                double coefficient = 0;
                coefficient += (ik == i ? w[i] : 0) - (jk == i ? w[i] : 0);
                coefficient -= (ik == j ? w[j] : 0) - (jk == j ? w[j] : 0);
                a[c][k] = coefficient * u[c].dot(u[k]);
            }
        }
        std::array<double, 3> lambda = solve3(a, b);
        for (int k = 0; k < 3; ++k) {
            v[pairs[k][0]] += u[k] * (w[pairs[k][0]] * lambda[k]);
            v[pairs[k][1]] -= u[k] * (w[pairs[k][1]] * lambda[k]);
        }
    }
    void drift(vector<Vec3>& q, vector<Vec3>& v, double h) const {
        std::array<double, 3> lengths, rates, zero = {0, 0, 0};
        for (int c = 0; c < 3; ++c) {
            Vec3 r = direction(q, c);
            lengths[c] = std::sqrt(r.dot(r));
            rates[c] = r.dot(v[pairs[c][0]] - v[pairs[c][1]]) / lengths[c];
        }
        setRates(q, v, zero);
        // q_new = q + h v + M^-1 sum_k mu_k s_k r_k (r_k at q); Newton on |q_new_i - q_new_j|^2 = length^2.
        const vector<Vec3> q0 = q;
        Vec3 r[3];
        for (int k = 0; k < 3; ++k)
            r[k] = direction(q0, k);
        std::array<double, 3> mu = {0, 0, 0};
        vector<Vec3> trial(3);
        for (int iteration = 0; iteration < 50; ++iteration) {
            for (int p = 0; p < 3; ++p)
                trial[p] = q0[p] + v[p] * h;
            for (int k = 0; k < 3; ++k) {
                trial[pairs[k][0]] += r[k] * (w[pairs[k][0]] * mu[k]);
                trial[pairs[k][1]] -= r[k] * (w[pairs[k][1]] * mu[k]);
            }
            Matrix3 jacobian{};
            std::array<double, 3> g;
            for (int c = 0; c < 3; ++c) {
                const int i = pairs[c][0], j = pairs[c][1];
                const Vec3 e = trial[i] - trial[j];
                g[c] = lengths[c] * lengths[c] - e.dot(e);
                for (int k = 0; k < 3; ++k) {
                    const int ik = pairs[k][0], jk = pairs[k][1];
                    double coefficient = 0;
                    coefficient += (ik == i ? w[i] : 0) - (jk == i ? w[i] : 0);
                    coefficient -= (ik == j ? w[j] : 0) - (jk == j ? w[j] : 0);
                    jacobian[c][k] = 2 * coefficient * e.dot(r[k]);
                }
            }
            std::array<double, 3> step = solve3(jacobian, g);
            for (int k = 0; k < 3; ++k)
                mu[k] += step[k];
        }
        q = trial;
        for (int p = 0; p < 3; ++p)
            v[p] = (q[p] - q0[p]) * (1.0 / h);
        setRates(q, v, rates);
    }
    /** v += h P M^-1 F: the kick with its components along the three distances removed. */
    void projectedKick(const vector<Vec3>& q, vector<Vec3>& v, const vector<Vec3>& f, double h) const {
        vector<Vec3> dv(3);
        for (int p = 0; p < 3; ++p)
            dv[p] = f[p] * (h * w[p]);
        setRates(q, dv, {0, 0, 0});
        for (int p = 0; p < 3; ++p)
            v[p] += dv[p];
    }
};

} // namespace

TEST_P(FlavorArtificial, BothCompositionsMatchAnIndependentImplementationOnABondedMolecule) {
    // A flexible three-site molecule (eqs. (6.9)-(6.12) in spirit: two stiff bonds and a stiff angle, whose frozen
    // coordinates are the three distances of the triangle) under a nonlinear soft potential.  Forces come from an
    // OpenMM Context (any correct force oracle will do); the composition and the frozen stage are written above.
    const double delta = 2e-3, tau = 2e-4;
    const int steps = 40;
    std::unique_ptr<System> system(new System());
    for (double mass : {16.0, 1.0, 1.0})
        system->addParticle(mass);
    HarmonicBondForce* bonds = new HarmonicBondForce();
    bonds->addBond(0, 1, 0.1, 4e5);
    bonds->addBond(0, 2, 0.1, 4e5);
    bonds->setForceGroup(StiffGroup);
    HarmonicAngleForce* angle = new HarmonicAngleForce();
    angle->addAngle(1, 0, 2, 1.82, 400);
    angle->setForceGroup(StiffGroup);
    CustomExternalForce* soft = new CustomExternalForce("20*x^2 + 30*y^4 + 5*z^2 + 40*x*y");
    for (int i = 0; i < 3; ++i)
        soft->addParticle(i);
    soft->setForceGroup(SoftGroup);
    system->addForce(bonds);
    system->addForce(angle);
    system->addForce(soft);
    const vector<Vec3> q0 = {Vec3(0.05, -0.02, 0.01), Vec3(0.152, -0.018, 0.012), Vec3(0.0245, 0.077, 0.013)};
    const vector<Vec3> v0 = {Vec3(0.3, -0.2, 0.1), Vec3(2.0, 1.0, -1.5), Vec3(-1.0, 0.5, 2.0)};
    VerletIntegrator oracleIntegrator(1e-3);
    Context oracle(*system, oracleIntegrator, Platform::getPlatformByName("Reference"));
    auto forces = [&](const vector<Vec3>& q, int groups) {
        oracle.setPositions(q);
        return oracle.getState(State::Forces, false, groups).getForces();
    };
    Triangle triangle;
    for (int p = 0; p < 3; ++p)
        triangle.w[p] = 1.0 / system->getParticleMass(p);
    for (auto scheme : {FlavorIntegrator::SymplecticEuler, FlavorIntegrator::Verlet})
        for (bool projected : {false, true}) {
            vector<Vec3> q = q0, v = v0;
            auto kick = [&](int groups, double h) {
                vector<Vec3> f = forces(q, groups);
                for (int p = 0; p < 3; ++p)
                    v[p] += f[p] * (h * triangle.w[p]);
            };
            auto softKick = [&](double h) {
                if (!projected) {
                    kick(1 << SoftGroup, h);
                    return;
                }
                vector<Vec3> f = forces(q, 1 << SoftGroup);
                for (int p = 0; p < 3; ++p)
                    v[p] += f[p] * (h * (tau / delta) * triangle.w[p]);
                triangle.projectedKick(q, v, f, h - h * (tau / delta));
            };
            auto drift = [&](double h) {
                for (int p = 0; p < 3; ++p)
                    q[p] += v[p] * h;
            };
            for (int s = 0; s < steps; ++s) {
                if (scheme == FlavorIntegrator::SymplecticEuler) {
                    softKick(delta);
                    drift(tau);
                    kick(StiffMask, tau);
                    triangle.drift(q, v, delta - tau);
                } else {
                    softKick(delta / 2);
                    triangle.drift(q, v, (delta - tau) / 2);
                    kick(StiffMask, tau / 2);
                    drift(tau);
                    kick(StiffMask, tau / 2);
                    triangle.drift(q, v, (delta - tau) / 2);
                    softKick(delta / 2);
                }
            }
            FlavorIntegrator integrator(delta, tau, StiffMask);
            integrator.setScheme(scheme);
            integrator.setAveraging(projected ? FlavorIntegrator::ArtificialProjected : FlavorIntegrator::Artificial);
            integrator.setConstraintTolerance(1e-13);
            Context context(*system, integrator, platform(), properties());
            context.setPositions(q0);
            context.setVelocities(v0);
            integrator.step(steps);
            const vector<Vec3> q1 = positionsOf(context), v1 = velocitiesOf(context);
            double positionError = 0, velocityError = 0, displacement = 0;
            for (int p = 0; p < 3; ++p) {
                positionError = std::max(positionError, std::sqrt((q1[p] - q[p]).dot(q1[p] - q[p])));
                velocityError = std::max(velocityError, std::sqrt((v1[p] - v[p]).dot(v1[p] - v[p])));
                displacement = std::max(displacement, std::sqrt((q[p] - q0[p]).dot(q[p] - q0[p])));
            }
            // GPU platforms: their stiff forces are 1e-6 relative off (PlatformTest::isGpu); measured 1.2e-8 nm, 1e-6
            // nm/ps.
            EXPECT_LE(positionError, isGpu() ? 1e-7 : 1e-10) << "scheme " << scheme << " projected " << projected;
            EXPECT_LE(velocityError, isGpu() ? 1e-5 : 1e-7) << "scheme " << scheme << " projected " << projected;
            EXPECT_GT(displacement, 1e-2); // the molecule really moved
        }
}

TEST_P(FlavorArtificial, BondedFreezingSamplesTheTrueBondVariance) {
    // Independent diatomics (Diatomics.h), Langevin artificial FLAVOR: the bond stretch keeps <k (r - r0)^2> = kT (up
    // to O(kT/(k r0^2)) = 6e-4) for delta/tau = 4 and 25, within 4 standard errors over the independent molecules.
    const double temperature = 300, kT = BOLTZ * temperature, tau = 1e-4;
    const Diatomics diatomics(150, 4e5, 0.1);
    std::mt19937 generator(7);
    for (auto averaging : {FlavorIntegrator::Artificial, FlavorIntegrator::ArtificialProjected})
        for (double ratio : {4.0, 25.0}) {
            FlavorIntegrator integrator(ratio * tau, tau, StiffMask);
            integrator.setAveraging(averaging);
            integrator.setTemperature(temperature);
            integrator.setFriction(20.0);
            integrator.setRandomNumberSeed(5);
            Context context(*diatomics.system, integrator, platform(), properties());
            const auto [mean, standardError] =
                diatomics.stretchEnergy(context, integrator, kT, kT / diatomics.k, generator, 500, 150, 20);
            std::cout << "[ measured ] bonded, averaging " << averaging << " delta/tau " << ratio
                      << ": k<(r-r0)^2>/kT = " << mean / kT << " +- " << standardError / kT << std::endl;
            EXPECT_LE(std::abs(mean - kT), 4 * standardError)
                << "averaging " << averaging << " delta/tau " << ratio << ": " << mean / kT << " kT";
            EXPECT_LT(4 * standardError, 0.25 * kT);
        }
}

TEST_P(FlavorArtificial, CheckpointsContinueIdentically) {
    std::unique_ptr<System> system(fpuSystem(3, 50.0));
    for (double friction : {0.0, 5.0}) {
        FlavorIntegrator integrator(0.01, 0.001, StiffMask);
        integrator.setAveraging(FlavorIntegrator::ArtificialProjected);
        integrator.setExactFastFlow(friction > 0);
        integrator.setFriction(friction);
        integrator.setTemperature(300);
        integrator.setRandomNumberSeed(42);
        Context context(*system, integrator, platform(), properties());
        context.setPositions(fpuPositions({1, 0, 0}, {0.02, 0, 0}));
        integrator.step(7);
        std::stringstream checkpoint;
        context.createCheckpoint(checkpoint);
        integrator.step(13);
        vector<Vec3> q1 = positionsOf(context), v1 = velocitiesOf(context);
        context.loadCheckpoint(checkpoint);
        integrator.step(13);
        EXPECT_EQ(0.0, relativeDifference(positionsOf(context), q1)) << "friction " << friction;
        EXPECT_EQ(0.0, relativeDifference(velocitiesOf(context), v1)) << "friction " << friction;
    }
}
