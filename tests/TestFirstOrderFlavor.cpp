#include "FirstOrderFlavor.h"
#include "FirstOrderModels.h"
#include "openmm/OpenMMException.h"
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>

using namespace FlavorPlugin;

namespace {

// ---------------------------------------------------------------------------------------------------------------------
// A linear two-scale system with a known solution: x' = -y (soft), y' = alpha (x - y) (stiff).  As alpha -> infinity y
// follows x and x decays as e^-t.
// ---------------------------------------------------------------------------------------------------------------------

struct LinearTwoScale {
    static constexpr std::size_t Dim = 2, NoiseDim = 0;
    void drift(const std::array<double, 2>& u, double alpha, double, std::array<double, 2>& f) const {
        f[0] = -u[1];
        f[1] = alpha * (u[0] - u[1]);
    }
};

using Mat = std::array<long double, 4>; // row-major 2x2

Mat multiply(const Mat& a, const Mat& b) {
    return {a[0] * b[0] + a[1] * b[2], a[0] * b[1] + a[1] * b[3], a[2] * b[0] + a[3] * b[2], a[2] * b[1] + a[3] * b[3]};
}

/**
 * g(A) for a 2x2 matrix A with distinct real eigenvalues l1, l2 (Sylvester's formula):
 * g(A) = (g(l1) (A - l2 I) - g(l2) (A - l1 I)) / (l1 - l2).
 */
template <class G> Mat matrixFunction(const Mat& a, G g) {
    const long double trace = a[0] + a[3], det = a[0] * a[3] - a[1] * a[2];
    const long double root = std::sqrt(trace * trace / 4 - det);
    const long double l1 = trace / 2 + root, l2 = trace / 2 - root;
    const long double g1 = g(l1), g2 = g(l2);
    Mat result;
    for (int i = 0; i < 4; ++i) {
        const long double identity = (i == 0 || i == 3) ? 1 : 0;
        result[i] = (g1 * (a[i] - l2 * identity) - g2 * (a[i] - l1 * identity)) / (l1 - l2);
    }
    return result;
}

std::array<long double, 2> apply(const Mat& a, long double x, long double y) {
    return {a[0] * x + a[1] * y, a[2] * x + a[3] * y};
}

/** The FLAVOR of LinearTwoScale after n mesosteps, as the n-th power of its one-step matrix, in closed form. */
std::array<long double, 2> linearFlavorClosedForm(double alpha, double delta, double tau, int n, double x0, double y0) {
    const long double t = tau, rest = (long double)delta - tau;
    const Mat on = {1, -t, alpha * t, 1 - alpha * t}; // I + tau (alpha A + B)
    const Mat off = {1, -rest, 0, 1};                 // I + (delta - tau) B
    const Mat power = matrixFunction(multiply(off, on), [n](long double l) { return std::pow(l, (long double)n); });
    return apply(power, x0, y0);
}

/** The exact solution of LinearTwoScale at time T: exp(T (alpha A + B)) (x0, y0). */
std::array<long double, 2> linearExact(double alpha, double T, double x0, double y0) {
    const Mat generator = {0, -1, alpha, -alpha};
    return apply(matrixFunction(generator, [T](long double l) { return std::exp(l * T); }), x0, y0);
}

std::array<double, 2> runLinear(double alpha, double delta, double tau, int n, double x0, double y0) {
    FirstOrderFlavor<LinearTwoScale> flavor(LinearTwoScale(), alpha, delta, tau);
    std::array<double, 2> u = {x0, y0};
    flavor.run(u, 0, n);
    return u;
}

} // namespace

TEST(FirstOrderFlavor, LinearSystemIsItsOneStepMatrixToThePowerN) {
    // eps = 1e-6, tau = eps/10, delta = 1000 tau: the stiffness must be on for tau and off for delta - tau, or the
    // run differs from the closed form by orders of magnitude (it blows up with the stiffness on for delta).
    const double alpha = 1e6, delta = 1e-3, tau = 1e-7, x0 = 1.0, y0 = 0.3;
    const int n = 1000;
    const std::array<double, 2> u = runLinear(alpha, delta, tau, n, x0, y0);
    const std::array<long double, 2> expected = linearFlavorClosedForm(alpha, delta, tau, n, x0, y0);
    for (int i = 0; i < 2; ++i)
        EXPECT_NEAR(u[i], (double)expected[i], 1e-12 * std::fabs((double)expected[i])) << "component " << i;
}

TEST(FirstOrderFlavor, LinearSystemConvergesToTheExactSolution) {
    // To leading order the FLAVOR integrates the system with its stiffness slowed by tau/delta, alpha' = alpha tau /
    // delta, whose slow eigenvalue is -1 - 1/alpha' + O(1/alpha'^2) instead of -1 - 1/alpha + ...; at T = 1 the
    // relative error in x is therefore (1/alpha' - 1/alpha) T to first order (plus forward Euler's O(delta) and the
    // microstep's O(alpha tau) corrections).  Halving delta at fixed tau halves 1/alpha'.
    const double alpha = 1e6, tau = 1e-7, T = 1.0, x0 = 1.0, y0 = 1.0;
    const long double exact = linearExact(alpha, T, x0, y0)[0];
    double previous = 0;
    for (double delta : {2e-3, 1e-3, 5e-4}) {
        const int n = (int)std::lround(T / delta);
        const double x = runLinear(alpha, delta, tau, n, x0, y0)[0];
        const double error = (double)((x - exact) / exact);
        const double predicted = -(delta / (alpha * tau) - 1 / alpha) * T;
        EXPECT_NEAR(error, predicted, 0.15 * std::fabs(predicted)) << "delta = " << delta;
        if (previous != 0) {
            EXPECT_NEAR(previous / error, 2.0, 0.2) << "delta = " << delta;
        }
        previous = error;
    }
}

TEST(FirstOrderFlavor, ErrorDoesNotDependOnTheStiffnessAtFixedGamma) {
    // FLAVORS Remark 1.6: with tau = gamma eps and delta = gamma tau / eps the error is a function of gamma alone, so
    // the speedup delta/tau = gamma/eps over a method resolving tau grows like 1/eps at fixed accuracy.  Here the
    // slowed stiffness is alpha' = alpha tau/delta = 1/gamma for every eps, and the relative error in x(T) stays at
    // -(1/alpha' - 1/alpha) T = -(gamma - eps) T (see above) while eps falls a thousandfold.
    const double gamma = 0.01, T = 1.0, x0 = 1.0, y0 = 1.0;
    for (double eps : {1e-4, 1e-5, 1e-6, 1e-7}) {
        const double alpha = 1 / eps, tau = gamma * eps, delta = gamma * tau / eps;
        const int n = (int)std::lround(T / delta);
        const long double exact = linearExact(alpha, T, x0, y0)[0];
        const double error = (double)((runLinear(alpha, delta, tau, n, x0, y0)[0] - exact) / exact);
        EXPECT_NEAR(error, -(gamma - eps) * T, 0.15 * gamma * T) << "eps = " << eps;
    }
}

TEST(FirstOrderFlavor, TauEqualToDeltaIsForwardEulerBitForBit) {
    // The Van der Pol oscillator (6.2), Fig. 6.1's parameters: tau = delta = h must be forward Euler at step h with
    // the stiffness on, nothing else.
    const FirstOrderModels::VanDerPol model{1e-3};
    const double alpha = 1e3, h = 5e-5;
    FirstOrderFlavor<FirstOrderModels::VanDerPol> flavor(model, alpha, h, h);
    std::array<double, 2> u = {1.0, 1.0}, v = u;
    for (int k = 0; k < 20000; ++k) {
        flavor.step(u, k);
        const double fx = -model.eps * v[1], fy = alpha * (v[0] + v[1] - v[1] * v[1] * v[1] / 3);
        v = {v[0] + h * fx, v[1] + h * fy};
    }
    EXPECT_EQ(0, std::memcmp(u.data(), v.data(), sizeof(u)));
    EXPECT_NE(1.0, u[0]);
}

TEST(FirstOrderFlavor, TauEqualToDeltaIsEulerMaruyamaBitForBit) {
    // The nonautonomous SDE (6.16): Euler-Maruyama at step h, time t = k h, with the documented stream of each step's
    // normal (stream 2k, particle = path).
    const FirstOrderModels::HiddenSde model{10.0};
    const double alpha = 1e4, h = 1e-4;
    const std::uint64_t seed = 12345;
    const std::uint32_t path = 7;
    FirstOrderFlavor<FirstOrderModels::HiddenSde> flavor(model, alpha, h, h, seed);
    const CounterRandom random(seed);
    std::array<double, 2> u = model.fromSlowFast(1 + 1e-4, 1.0), v = u;
    for (std::uint64_t k = 0; k < 5000; ++k) {
        flavor.step(u, k, path);
        const double t = k * h, x = v[0], y = v[1], half = (y - x) / 2, mean = (x + y) / 2;
        const double g = 4 / (3 * (x + y) * (x + y)) * (-half * half / 2 + 5 * std::sin(2 * FirstOrderModels::Pi * t));
        const double q = mean * mean * mean + model.c - half;
        const double xi = random.normals(2 * k, path)[0], s = std::sqrt(2 * alpha);
        v = {x + h * (g - alpha * q) + std::sqrt(h) * (-s * xi), y + h * (g + alpha * q) + std::sqrt(h) * (s * xi)};
    }
    EXPECT_EQ(0, std::memcmp(u.data(), v.data(), sizeof(u)));
}

namespace {

/** u' = cos(3 t) + alpha sin(t): only time, so that each stage's clock shows. */
struct Clock {
    static constexpr std::size_t Dim = 1, NoiseDim = 0;
    void drift(const std::array<double, 1>&, double alpha, double t, std::array<double, 1>& f) const {
        f[0] = std::cos(3 * t) + alpha * std::sin(t);
    }
};

} // namespace

TEST(FirstOrderFlavor, StagesSeePhysicalTime) {
    // Mesostep k: the microstep at t = k delta with the stiffness on, the rest at k delta + tau with it off.
    const double alpha = 2.0, delta = 0.1, tau = 0.03;
    FirstOrderFlavor<Clock> flavor(Clock(), alpha, delta, tau);
    std::array<double, 1> u = {0.5};
    double v = 0.5;
    for (int k = 0; k < 50; ++k) {
        flavor.step(u, k);
        const double t = k * delta;
        v = v + tau * (std::cos(3 * t) + alpha * std::sin(t));
        v = v + (delta - tau) * (std::cos(3 * (t + tau)) + 0.0 * std::sin(t + tau));
    }
    EXPECT_EQ(v, u[0]);
}

TEST(FirstOrderFlavor, PolarVanDerPolIsTheCartesianOneInHiddenVariables) {
    // Eq. (6.1) is (6.2) after x = r sin(theta), y = r cos(theta): the chain rule maps one drift onto the other, with
    // the stiffness on and off.
    const FirstOrderModels::VanDerPol cartesian{1e-3};
    const FirstOrderModels::HiddenVanDerPol polar{1e-3};
    for (double alpha : {0.0, 1e3})
        for (double theta : {0.3, 1.9, -2.4})
            for (double r : {0.5, 1.4, 2.2}) {
                std::array<double, 2> fp, fc;
                polar.drift({r, theta}, alpha, 0, fp);
                const std::array<double, 2> xy = FirstOrderModels::HiddenVanDerPol::toCartesian({r, theta});
                cartesian.drift(xy, alpha, 0, fc);
                const double dx = fp[0] * std::sin(theta) + r * std::cos(theta) * fp[1];
                const double dy = fp[0] * std::cos(theta) - r * std::sin(theta) * fp[1];
                const double scale = 1e-12 * (1 + alpha);
                EXPECT_NEAR(dx, fc[0], scale) << "r " << r << " theta " << theta << " alpha " << alpha;
                EXPECT_NEAR(dy, fc[1], scale) << "r " << r << " theta " << theta << " alpha " << alpha;
            }
}

TEST(FirstOrderFlavor, HiddenSdeIsTheSlowFastSdeInHiddenVariables) {
    // (6.16) after (6.17): x = ((u + v)/2)^3 + c has no noise (the two noises cancel in u + v), so its drift is
    // 3 ((u + v)/2)^2 times that of (u + v)/2; y = (v - u)/2 is linear.
    const FirstOrderModels::HiddenSde hidden{10.0};
    const FirstOrderModels::SlowFastSde slowFast;
    for (double alpha : {0.0, 1e4})
        for (double t : {0.1, 0.7})
            for (double x : {-3.0, 1.0, 4.0})
                for (double y : {-1.5, 0.5}) {
                    const std::array<double, 2> w = hidden.fromSlowFast(x, y);
                    std::array<double, 2> fh, fs, sh, ss;
                    hidden.drift(w, alpha, t, fh);
                    slowFast.drift(hidden.slowFast(w), alpha, t, fs); // (x, y) up to the rounding of w
                    // The stiff terms +-alpha q cancel in fh[0] + fh[1]: allow a few roundings of them.
                    const double mean = (w[0] + w[1]) / 2, cancelled = std::fabs(fh[0]) + std::fabs(fh[1]);
                    EXPECT_NEAR(3 * mean * mean * (fh[0] + fh[1]) / 2, fs[0], 1e-15 * 3 * mean * mean * cancelled);
                    EXPECT_NEAR((fh[1] - fh[0]) / 2, fs[1], 1e-15 * cancelled);
                    hidden.diffusion(w, alpha, t, sh);
                    slowFast.diffusion(hidden.slowFast(w), alpha, t, ss);
                    EXPECT_EQ(0.0, sh[0] + sh[1]);
                    EXPECT_EQ((sh[1] - sh[0]) / 2, ss[1]);
                }
}

namespace {

/** Ornstein-Uhlenbeck: dx = -lambda x dt + s dW (no stiff part). */
struct OrnsteinUhlenbeck {
    static constexpr std::size_t Dim = 1, NoiseDim = 1;
    double lambda, s;
    void drift(const std::array<double, 1>& u, double, double, std::array<double, 1>& f) const {
        f[0] = -lambda * u[0];
    }
    void diffusion(const std::array<double, 1>&, double, double, std::array<double, 1>& sigma) const { sigma[0] = s; }
};

struct Moments {
    double mean, variance, meanError, varianceError; // estimates and their standard errors
};

template <class Model>
Moments sampleMoments(const FirstOrderFlavor<Model>& flavor, const std::array<double, Model::Dim>& start, int steps,
                      int paths) {
    double sum = 0, sumSquares = 0;
    for (int p = 0; p < paths; ++p) {
        std::array<double, Model::Dim> u = start;
        flavor.run(u, 0, steps, p);
        sum += u[0];
        sumSquares += u[0] * u[0];
    }
    const double mean = sum / paths, variance = (sumSquares - paths * mean * mean) / (paths - 1);
    // For the (Gaussian) laws here the variance of the sample variance is 2 variance^2/(paths - 1).
    return {mean, variance, std::sqrt(variance / paths), variance * std::sqrt(2.0 / (paths - 1))};
}

} // namespace

TEST(FirstOrderFlavor, EulerMaruyamaHasWeakOrderOne) {
    // OU from x0 = 1 to T = 1 (lambda = s = 1): E x_T = e^-1, Var x_T = (1 - e^-2)/2.  Euler-Maruyama at step h has
    // the Gaussian law of the recursion x <- (1 - h) x + sqrt(h) xi: mean (1 - h)^N, variance
    // h (1 - (1 - h)^2N) / (1 - (1 - h)^2).  The sampled moments must match that law within 4 standard errors at
    // every h, and their errors against the SDE must fall as h^p with p within 4 standard errors of the law's p
    // (1.06 for the mean and 1.08 for the variance between h = 1/4 and 1/16; 1 as h -> 0).
    const OrnsteinUhlenbeck ou{1.0, 1.0};
    const double T = 1.0, exactMean = std::exp(-T), exactVariance = (1 - std::exp(-2 * T)) / 2;
    const int paths = 400000;
    std::array<Moments, 2> sampled;
    std::array<double, 2> lawMean, lawVariance;
    const std::array<double, 2> steps = {0.25, 0.0625};
    for (int i = 0; i < 2; ++i) {
        const double h = steps[i];
        const int n = (int)std::lround(T / h);
        sampled[i] = sampleMoments(FirstOrderFlavor<OrnsteinUhlenbeck>(ou, 0.0, h, h, 2024 + i), {1.0}, n, paths);
        const double decay = 1 - h;
        lawMean[i] = std::pow(decay, n);
        lawVariance[i] = h * (1 - std::pow(decay, 2 * n)) / (1 - decay * decay);
        EXPECT_NEAR(sampled[i].mean, lawMean[i], 4 * sampled[i].meanError) << "h = " << h;
        EXPECT_NEAR(sampled[i].variance, lawVariance[i], 4 * sampled[i].varianceError) << "h = " << h;
    }
    const double ratio = std::log(steps[0] / steps[1]);
    auto order = [ratio](double coarse, double fine) { return std::log(coarse / fine) / ratio; };
    auto orderError = [ratio](double coarse, double fine, double seCoarse, double seFine) {
        return std::hypot(seCoarse / coarse, seFine / fine) / ratio;
    };
    const double meanOrder = order(sampled[0].mean - exactMean, sampled[1].mean - exactMean);
    const double lawMeanOrder = order(lawMean[0] - exactMean, lawMean[1] - exactMean);
    EXPECT_NEAR(meanOrder, lawMeanOrder,
                4 * orderError(sampled[0].mean - exactMean, sampled[1].mean - exactMean, sampled[0].meanError,
                               sampled[1].meanError));
    const double varianceOrder = order(sampled[0].variance - exactVariance, sampled[1].variance - exactVariance);
    const double lawVarianceOrder = order(lawVariance[0] - exactVariance, lawVariance[1] - exactVariance);
    EXPECT_NEAR(varianceOrder, lawVarianceOrder,
                4 * orderError(sampled[0].variance - exactVariance, sampled[1].variance - exactVariance,
                               sampled[0].varianceError, sampled[1].varianceError));
    EXPECT_NEAR(lawMeanOrder, 1.0, 0.1);
    EXPECT_NEAR(lawVarianceOrder, 1.0, 0.1);
}

namespace {

/**
 * A stiff linear SDE: dx = -y dt + s dW1 (soft), dy = alpha (x - y) dt + sqrt(2 alpha) dW2 (stiff drift and
 * noise): the soft noise acts in both stages, the stiff one in the microstep only.
 */
struct StiffLinearSde {
    static constexpr std::size_t Dim = 2, NoiseDim = 2;
    double s;
    void drift(const std::array<double, 2>& u, double alpha, double, std::array<double, 2>& f) const {
        f[0] = -u[1];
        f[1] = alpha * (u[0] - u[1]);
    }
    void diffusion(const std::array<double, 2>&, double alpha, double, std::array<double, 4>& sigma) const {
        sigma = {s, 0, 0, std::sqrt(2 * alpha)};
    }
};

} // namespace

TEST(FirstOrderFlavor, StiffLinearSdeHasTheLawOfItsFlavorMap) {
    // One mesostep is u <- M2 (M1 u + sqrt(tau) G1 xi) + sqrt(delta - tau) G0 xi', M1 = I + tau (alpha A + B),
    // M2 = I + (delta - tau) B, G1 = diag(s, sqrt(2 alpha)), G0 = diag(s, 0), with xi and xi' independent (Remark
    // 3.3: the Brownian increments over the two stages).  Mean and covariance follow m <- M2 M1 m and
    // P <- M2 (M1 P M1^T + tau G1 G1^T) M2^T + (delta - tau) G0 G0^T.  The sampled mean and variance of x must match
    // within 4 standard errors.  Stiff noise scaled by sqrt(delta) makes the variance (0.0136 here, about 120 standard
    // errors) 25 times larger; the same normals in both stages change it by 0.0021 (19 standard errors).
    const double alpha = 1e4, delta = 1e-3, tau = 1e-5, x0 = 1.0, y0 = 0.5, s = 0.25;
    const int n = 200, paths = 40000;
    const Moments sampled =
        sampleMoments(FirstOrderFlavor<StiffLinearSde>(StiffLinearSde{s}, alpha, delta, tau, 99), {x0, y0}, n, paths);
    const Mat m1 = {1, -tau, alpha * tau, 1 - alpha * tau}, m2 = {1, -(delta - tau), 0, 1};
    auto transpose = [](const Mat& a) { return Mat{a[0], a[2], a[1], a[3]}; };
    std::array<long double, 2> mean = {x0, y0};
    Mat covariance = {0, 0, 0, 0};
    for (int k = 0; k < n; ++k) {
        mean = apply(m2, apply(m1, mean[0], mean[1])[0], apply(m1, mean[0], mean[1])[1]);
        Mat inner = multiply(multiply(m1, covariance), transpose(m1));
        inner[0] += (long double)tau * s * s;
        inner[3] += (long double)tau * 2 * alpha;
        covariance = multiply(multiply(m2, inner), transpose(m2));
        covariance[0] += ((long double)delta - tau) * s * s;
    }
    EXPECT_NEAR(sampled.mean, (double)mean[0], 4 * sampled.meanError);
    EXPECT_NEAR(sampled.variance, (double)covariance[0], 4 * sampled.varianceError);
    EXPECT_GT(covariance[0], 100 * sampled.varianceError);
}

TEST(FirstOrderFlavor, RejectsBadSteps) {
    const LinearTwoScale model;
    EXPECT_THROW(FirstOrderFlavor<LinearTwoScale>(model, 1.0, 1e-3, 2e-3), OpenMM::OpenMMException);
    EXPECT_THROW(FirstOrderFlavor<LinearTwoScale>(model, 1.0, 0.0, 0.0), OpenMM::OpenMMException);
    EXPECT_THROW(FirstOrderFlavor<LinearTwoScale>(model, -1.0, 1e-3, 1e-4), OpenMM::OpenMMException);
    EXPECT_THROW(FirstOrderFlavor<LinearTwoScale>(model, 1.0, 1e-3, std::nan("")), OpenMM::OpenMMException);
}
