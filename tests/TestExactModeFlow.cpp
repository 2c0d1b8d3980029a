#include "internal/ExactModeFlow.h"
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <cstdio>
#include <limits>
#include <random>
#include <string>

using namespace FlavorPlugin;

namespace {

// ---------------------------------------------------------------------------------------------------------------------
// Reference: block matrix exponentials evaluated in double-double arithmetic (about 106 bits) by scaling and squaring.
//
// The mode is written in balanced dimensionless units, time in units of h and position in units of l = h/s with
// s = max(1, omega h), so that its generator is A = [[0, s], [-(omega h)^2/s, -gamma h]] and has entries of at most
// max(omega h, gamma h).  Then
//   [[Phi, g], [0, 1]] = expm([[A, e2], [0, 0]])                              (constant force, Van Loan),
//   Sigma = last column of expm(K), K the 4x4 generator of the second moments
//           d(Pxx, Pxv, Pvv, 1)/dt with P' = A P + P A^T + diag(0, 2 gamma h)    (covariance for kT = 1).
// None of this shares a formula with the implementation.  With Taylor terms up to order 22 on matrices scaled to norm
// 1/4 the truncation error is below 1e-34; the rounding error of double-double scaling and squaring grows with the
// number of squarings (at most about 21 here).  Checked against the same exponentials in 400-digit arithmetic on the
// test grid and on random parameters: every entry of Phi, gx, Sigma_xx and Sigma_vv agreed to within its final
// rounding to double (an exact zero, Phi_vv at critical damping with gamma h = 2, came out as 2e-32).  Only gv and
// Sigma_xv are accurate merely relative to the norm of their matrix (to about 1e-30): when they decay like
// e^-(gamma h/2) under heavy damping, squaring forms them as tiny differences of much larger terms.  Their
// comparisons therefore use a floor relative to that norm (BlockFloor).
// ---------------------------------------------------------------------------------------------------------------------

struct DD {
    double hi, lo;
};

DD twoSum(double a, double b) {
    const double s = a + b, bb = s - a;
    return {s, (a - (s - bb)) + (b - bb)};
}

DD quickTwoSum(double a, double b) {
    const double s = a + b;
    return {s, b - (s - a)};
}

DD twoProd(double a, double b) {
    const double p = a * b;
    return {p, std::fma(a, b, -p)};
}

DD operator+(DD a, DD b) {
    DD s = twoSum(a.hi, b.hi);
    const DD t = twoSum(a.lo, b.lo);
    s.lo += t.hi;
    s = quickTwoSum(s.hi, s.lo);
    s.lo += t.lo;
    return quickTwoSum(s.hi, s.lo);
}

DD operator-(DD a) {
    return {-a.hi, -a.lo};
}

DD operator-(DD a, DD b) {
    return a + (-b);
}

DD operator*(DD a, DD b) {
    DD p = twoProd(a.hi, b.hi);
    p.lo += a.hi * b.lo + a.lo * b.hi;
    return quickTwoSum(p.hi, p.lo);
}

DD operator/(DD a, DD b) {
    const double q1 = a.hi / b.hi;
    DD r = a - b * DD{q1, 0};
    const double q2 = r.hi / b.hi;
    r = r - b * DD{q2, 0};
    const double q3 = r.hi / b.hi;
    return quickTwoSum(q1, q2) + DD{q3, 0};
}

DD scale2(DD a, int e) {
    return {std::ldexp(a.hi, e), std::ldexp(a.lo, e)};
}

template <std::size_t N> using Matrix = std::array<std::array<DD, N>, N>;

template <std::size_t N> Matrix<N> zero() {
    Matrix<N> m;
    for (auto& row : m)
        row.fill(DD{0, 0});
    return m;
}

template <std::size_t N> Matrix<N> multiply(const Matrix<N>& a, const Matrix<N>& b) {
    Matrix<N> c = zero<N>();
    for (std::size_t i = 0; i < N; i++)
        for (std::size_t j = 0; j < N; j++)
            for (std::size_t k = 0; k < N; k++)
                c[i][j] = c[i][j] + a[i][k] * b[k][j];
    return c;
}

template <std::size_t N> Matrix<N> expm(Matrix<N> m) {
    double norm = 0;
    for (std::size_t i = 0; i < N; i++) {
        double rowSum = 0;
        for (std::size_t j = 0; j < N; j++)
            rowSum += std::abs(m[i][j].hi);
        norm = std::max(norm, rowSum);
    }
    int squarings = 0;
    while (norm > 0.25) {
        norm *= 0.5;
        squarings++;
    }
    for (auto& row : m)
        for (DD& x : row)
            x = scale2(x, -squarings);
    Matrix<N> sum = zero<N>(), term = zero<N>();
    for (std::size_t i = 0; i < N; i++)
        sum[i][i] = term[i][i] = DD{1, 0};
    for (int k = 1; k <= 22; k++) {
        term = multiply(term, m);
        for (auto& row : term)
            for (DD& x : row)
                x = x / DD{double(k), 0};
        for (std::size_t i = 0; i < N; i++)
            for (std::size_t j = 0; j < N; j++)
                sum[i][j] = sum[i][j] + term[i][j];
    }
    for (int i = 0; i < squarings; i++)
        sum = multiply(sum, sum);
    return sum;
}

/** All nine quantities in the balanced units: Phi (xx, xv, vx, vv), g (gx, gv), Sigma (xx, xv, vv). */
typedef std::array<double, 9> Quantities;
const char* const QuantityNames[9] = {"Phi_xx", "Phi_xv", "Phi_vx", "Phi_vv", "g_x",
                                      "g_v",    "Sig_xx", "Sig_xv", "Sig_vv"};

/** The balancing factor s of the units above. */
double balance(double omega, double h) {
    return std::max(1.0, omega * h);
}

Quantities reference(double omega, double gamma, double h, double s) {
    const DD w = twoProd(omega, h), gh = twoProd(gamma, h);
    const DD a12 = {s, 0}, a21 = -(w * w) / DD{s, 0}, a22 = -gh;
    Matrix<3> forced = zero<3>();
    forced[0][1] = a12;
    forced[1][0] = a21;
    forced[1][1] = a22;
    forced[1][2] = DD{1, 0};
    const Matrix<3> g = expm(forced);
    Matrix<4> k = zero<4>();
    k[0][1] = scale2(a12, 1);
    k[1][0] = a21;
    k[1][1] = a22;
    k[1][2] = a12;
    k[2][1] = scale2(a21, 1);
    k[2][2] = scale2(a22, 1);
    k[2][3] = scale2(gh, 1);
    const Matrix<4> sigma = expm(k);
    auto d = [](DD x) { return x.hi + x.lo; };
    return {d(g[0][0]), d(g[0][1]),     d(g[1][0]),     d(g[1][1]),    d(g[0][2]),
            d(g[1][2]), d(sigma[0][3]), d(sigma[1][3]), d(sigma[2][3])};
}

/** The implementation's flow and covariance, converted to the balanced units of the reference. */
Quantities implementation(double omega, double gamma, double h, double s) {
    const ModeFlowDetail::FlowAndCovariance r = ModeFlowDetail::flowAndCovariance(omega, gamma, h);
    const ModeFlow& f = r.flow;
    const double perLength = s / h; // 1/l
    return {f.xx,
            f.xv * perLength,
            f.vx / perLength,
            f.vv,
            f.gx * perLength / h,
            f.gv / h,
            r.sxx * perLength * perLength,
            r.sxv * perLength,
            r.svv};
}

// ---------------------------------------------------------------------------------------------------------------------
// Tolerances.  An entry passes if
//     |implementation - reference| <= RelTol * max(|reference|, floor) + spread,
// where spread is the sum over p in {omega, gamma} of the largest change of the reference entry when p is moved by
// PerturbationUlps units in the last place either way.  The first term is a relative tolerance near machine precision.
// The second allows for the unavoidable: omega h and gamma h are themselves rounded, so even a perfect evaluation
// cannot do better than that.  It matters only for ill-conditioned entries: where an entry crosses zero (e.g. Phi_vv =
// e^-1 (1 - 1) at critical damping with gamma h = 2) and for the phase of fast oscillations, which is uncertain by
// about omega h * eps.  floor is UnderflowFloor (in the balanced units every natural scale is of order one, so 1e-280
// is ~0 and lies above the range where doubles and the reference lose precision to underflow) and, for g and Sigma,
// BlockFloor times the largest entry of that block, well above the accuracy of the reference for gv and Sigma_xv.
// ---------------------------------------------------------------------------------------------------------------------

const double Eps = std::numeric_limits<double>::epsilon();
/** About 90 ulps; the worst relative error seen on well-conditioned entries over 300000 parameter sets was 2e-15. */
const double RelTol = 2e-14;
const double PerturbationUlps = 16;
const double UnderflowFloor = 1e-280;
const double BlockFloor = 1e-12;

/** Entries that one-ulp parameter changes move by at most this many ulps count as well-conditioned in the summary. */
const double WellConditioned = 10;

enum Regime { Free, Undamped, Under, Critical, Over, NumRegimes };
const char* const RegimeNames[NumRegimes] = {"omega=0", "gamma=0", "under", "critical", "over"};

Regime regime(double omega, double gamma) {
    if (omega == 0)
        return Free;
    if (gamma == 0)
        return Undamped;
    if (gamma == 2 * omega)
        return Critical;
    return gamma < 2 * omega ? Under : Over;
}

/** Worst errors seen, per regime and quantity, for the summary that the accuracy tests print. */
struct Statistics {
    // Worst |error|/max(|reference|, floor) over well-conditioned entries, and over the others the worst error in
    // units of spread/PerturbationUlps, the change caused by a one-ulp change of the parameters.
    double relative[NumRegimes][9] = {};
    double conditioned[NumRegimes][9] = {};
    int points = 0;
    // The largest fraction of its tolerance that any entry used, and where.
    double worstUse = 0;
    std::string worstWhere;
    void print(const std::string& title) const {
        std::printf("%s: %d parameter sets, at most %.3f of a tolerance used (%s)\n", title.c_str(), points, worstUse,
                    worstWhere.c_str());
        std::printf("  worst relative error, well-conditioned entries:\n  %-9s", "");
        for (const char* n : QuantityNames)
            std::printf(" %9s", n);
        std::printf("\n");
        for (int r = 0; r < NumRegimes; r++) {
            std::printf("  %-9s", RegimeNames[r]);
            for (int q = 0; q < 9; q++)
                std::printf(" %9.2e", relative[r][q]);
            std::printf("\n");
        }
        std::printf("  worst error of ill-conditioned entries, in units of their change under one-ulp parameter "
                    "changes:\n");
        for (int r = 0; r < NumRegimes; r++) {
            std::printf("  %-9s", RegimeNames[r]);
            for (int q = 0; q < 9; q++)
                std::printf(" %9.2e", conditioned[r][q]);
            std::printf("\n");
        }
    }
};

/** Compares all quantities at one parameter set with the reference; failures are reported through gtest. */
void compareWithReference(double omega, double gamma, double h, Statistics& stats) {
    const double s = balance(omega, h);
    const Quantities ref = reference(omega, gamma, h, s), got = implementation(omega, gamma, h, s);
    // s stays fixed so that the units do not change with the parameters.
    Quantities spread{};
    for (int p = 0; p < 2; p++) {
        const double base = p == 0 ? omega : gamma;
        if (base == 0)
            continue;
        Quantities largest{};
        for (double sign : {-1.0, 1.0}) {
            const double moved = base * (1 + sign * PerturbationUlps * Eps);
            const Quantities perturbed = p == 0 ? reference(moved, gamma, h, s) : reference(omega, moved, h, s);
            for (int q = 0; q < 9; q++)
                largest[q] = std::max(largest[q], std::abs(perturbed[q] - ref[q]));
        }
        for (int q = 0; q < 9; q++)
            spread[q] += largest[q];
    }
    const double gScale = std::max(std::abs(ref[4]), std::abs(ref[5]));
    const double sigmaScale = std::max(std::abs(ref[6]), std::abs(ref[8]));
    const Regime r = regime(omega, gamma);
    stats.points++;
    for (int q = 0; q < 9; q++) {
        double floor = UnderflowFloor;
        if (q == 4 || q == 5)
            floor = std::max(floor, BlockFloor * gScale);
        if (q >= 6)
            floor = std::max(floor, BlockFloor * sigmaScale);
        const double scale = std::max(std::abs(ref[q]), floor), error = std::abs(got[q] - ref[q]);
        const double tolerance = RelTol * scale + spread[q];
        EXPECT_LE(error, tolerance) << QuantityNames[q] << " at omega=" << omega << " gamma=" << gamma << " h=" << h
                                    << ": got " << got[q] << ", reference " << ref[q] << ", spread " << spread[q];
        if (spread[q] / PerturbationUlps <= WellConditioned * Eps * scale)
            stats.relative[r][q] = std::max(stats.relative[r][q], error / scale);
        else
            stats.conditioned[r][q] = std::max(stats.conditioned[r][q], error / (spread[q] / PerturbationUlps));
        if (error / tolerance > stats.worstUse) {
            stats.worstUse = error / tolerance;
            char where[200];
            std::snprintf(where, sizeof(where), "%s at omega=%.17g gamma=%.17g h=%.17g", QuantityNames[q], omega, gamma,
                          h);
            stats.worstWhere = where;
        }
    }
}

const double GridOmega[] = {0, 1e-8, 1e-4, 1e-2, 1, 10, 1e2, 1e4};
const double GridH[] = {1e-8, 1e-5, 1e-2, 0.37, 1, 10};

/** The friction values of the grid for one omega; -1 stands for critical damping, gamma = 2 omega. */
const double GridGamma[] = {0, 1e-8, 1e-3, 1, -1, 1e2, 1e4};

template <class F> void forEachGridPoint(F f) {
    for (double omega : GridOmega)
        for (double g : GridGamma)
            for (double h : GridH) {
                // For omega = 0 "critical" is gamma = 0 again.
                if (g < 0 && omega == 0)
                    continue;
                f(omega, g < 0 ? 2 * omega : g, h);
            }
}

} // namespace

TEST(ExactModeFlow, GridMatchesReference) {
    // Every combination is checked: with the floors above, the reference is accurate enough everywhere on the grid,
    // including where gamma h = 1e5 or omega h = 1e5 and the transition matrix underflows to zero.
    Statistics stats;
    forEachGridPoint([&](double omega, double gamma, double h) { compareWithReference(omega, gamma, h, stats); });
    stats.print("grid");
}

TEST(ExactModeFlow, RandomParametersMatchReference) {
    // Log-uniform omega h and gamma h over [1e-9, 1e5], with a share of exact, nearly critical, free and undamped
    // modes.
    std::mt19937_64 rng(20240611);
    std::uniform_real_distribution<double> uniform(0, 1);
    Statistics stats;
    for (int i = 0; i < 1500; i++) {
        const double h = std::pow(10.0, -8 + 9 * uniform(rng));
        const double w = std::pow(10.0, -9 + 14 * uniform(rng)), b = std::pow(10.0, -9 + 14 * uniform(rng)) / 2;
        double omega = w / h, gamma = 2 * b / h;
        const double kind = uniform(rng);
        if (kind < 0.1)
            omega = 0;
        else if (kind < 0.2)
            gamma = 0;
        else if (kind < 0.3)
            gamma = 2 * omega;
        else if (kind < 0.45)
            gamma = 2 * omega * (1 + (uniform(rng) < 0.5 ? -1 : 1) * std::pow(10.0, -14 * uniform(rng)));
        compareWithReference(omega, gamma, h, stats);
    }
    stats.print("random");
}

TEST(ExactModeFlow, SweepsAcrossRegimesMatchReference) {
    // Dense sweeps of omega h at fixed gamma h, through the crossovers between small and large arguments and between
    // under- and overdamping.
    Statistics stats;
    const double h = 0.5;
    for (double b : {0.0, 1e-6, 1e-3, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 4.0, 4.1, 10.0, 1e3, 3e4})
        for (int i = -120; i <= 100; i++) {
            const double w = std::pow(10.0, i / 20.0);
            compareWithReference(w / h, 2 * b / h, h, stats);
        }
    stats.print("sweeps");
}

TEST(ExactModeFlow, StationaryCovarianceIsPreserved) {
    // Phi Sigma_inf Phi^T + Sigma = Sigma_inf with Sigma_inf = diag(1/omega^2, 1), checked to a few roundings of
    // the terms involved.
    forEachGridPoint([&](double omega, double gamma, double h) {
        if (omega == 0)
            return;
        const ModeFlowDetail::FlowAndCovariance r = ModeFlowDetail::flowAndCovariance(omega, gamma, h);
        const ModeFlow& f = r.flow;
        const double px = 1 / (omega * omega);
        const double xx = f.xx * f.xx * px + f.xv * f.xv + r.sxx;
        const double xv = f.xx * f.vx * px + f.xv * f.vv + r.sxv;
        const double vv = f.vx * f.vx * px + f.vv * f.vv + r.svv;
        const double phase = 1 + omega * h;
        EXPECT_NEAR(xx, px, 64 * Eps * phase * px) << omega << " " << gamma << " " << h;
        EXPECT_NEAR(xv, 0, 64 * Eps * phase * (std::abs(f.xx * f.vx * px) + std::abs(f.xv * f.vv) + r.sxv))
            << omega << " " << gamma << " " << h;
        EXPECT_NEAR(vv, 1, 64 * Eps * phase) << omega << " " << gamma << " " << h;
    });
}

TEST(ExactModeFlow, TwoStepsEqualOneDoubleStep) {
    // Phi(2h) = Phi(h)^2, g(2h) = g + Phi g, Sigma(2h) = Sigma + Phi Sigma Phi^T.  Tolerances scale with the sum of
    // the magnitudes of the terms, and with 1 + omega h for the phase error of fast oscillations.
    forEachGridPoint([&](double omega, double gamma, double h) {
        const ModeFlowDetail::FlowAndCovariance one = ModeFlowDetail::flowAndCovariance(omega, gamma, h),
                                                two = ModeFlowDetail::flowAndCovariance(omega, gamma, 2 * h);
        const ModeFlow &f = one.flow, &f2 = two.flow;
        const double tol = 256 * Eps * (1 + 2 * (omega + gamma) * h);
        auto check = [&](const char* name, double composed, double direct, double magnitude) {
            EXPECT_LE(std::abs(composed - direct), tol * magnitude + 1e-300)
                << name << " omega=" << omega << " gamma=" << gamma << " h=" << h << ": " << composed << " vs "
                << direct;
        };
        check("xx", f.xx * f.xx + f.xv * f.vx, f2.xx, std::abs(f.xx * f.xx) + std::abs(f.xv * f.vx));
        check("xv", f.xx * f.xv + f.xv * f.vv, f2.xv, std::abs(f.xx * f.xv) + std::abs(f.xv * f.vv));
        check("vx", f.vx * f.xx + f.vv * f.vx, f2.vx, std::abs(f.vx * f.xx) + std::abs(f.vv * f.vx));
        check("vv", f.vx * f.xv + f.vv * f.vv, f2.vv, std::abs(f.vx * f.xv) + std::abs(f.vv * f.vv));
        check("gx", f.gx + f.xx * f.gx + f.xv * f.gv, f2.gx,
              std::abs(f.gx) + std::abs(f.xx * f.gx) + std::abs(f.xv * f.gv));
        check("gv", f.gv + f.vx * f.gx + f.vv * f.gv, f2.gv,
              std::abs(f.gv) + std::abs(f.vx * f.gx) + std::abs(f.vv * f.gv));
        const double sxx = one.sxx, sxv = one.sxv, svv = one.svv;
        const double pxx = f.xx * f.xx * sxx + 2 * f.xx * f.xv * sxv + f.xv * f.xv * svv;
        const double pxv = f.xx * f.vx * sxx + (f.xx * f.vv + f.xv * f.vx) * sxv + f.xv * f.vv * svv;
        const double pvv = f.vx * f.vx * sxx + 2 * f.vx * f.vv * sxv + f.vv * f.vv * svv;
        check("Sxx", sxx + pxx, two.sxx,
              sxx + std::abs(f.xx * f.xx * sxx) + std::abs(2 * f.xx * f.xv * sxv) + std::abs(f.xv * f.xv * svv));
        check("Sxv", sxv + pxv, two.sxv,
              sxv + std::abs(f.xx * f.vx * sxx) + std::abs(f.xx * f.vv * sxv) + std::abs(f.xv * f.vx * sxv) +
                  std::abs(f.xv * f.vv * svv));
        check("Svv", svv + pvv, two.svv,
              svv + std::abs(f.vx * f.vx * sxx) + std::abs(2 * f.vx * f.vv * sxv) + std::abs(f.vv * f.vv * svv));
    });
}

TEST(ExactModeFlow, UndampedModeIsSymplecticAndNoiseless) {
    for (double omega : GridOmega)
        for (double h : GridH) {
            const ModeFlowDetail::FlowAndCovariance r = ModeFlowDetail::flowAndCovariance(omega, 0, h);
            const ModeFlow& f = r.flow;
            const double det = f.xx * f.vv - f.xv * f.vx;
            EXPECT_NEAR(det, 1, 16 * Eps * (1 + omega * h) * (std::abs(f.xx * f.vv) + std::abs(f.xv * f.vx)))
                << omega << " " << h;
            EXPECT_EQ(r.sxx, 0);
            EXPECT_EQ(r.sxv, 0);
            EXPECT_EQ(r.svv, 0);
            EXPECT_EQ(f.lxx, 0);
            EXPECT_EQ(f.lvx, 0);
            EXPECT_EQ(f.lvv, 0);
        }
}

TEST(ExactModeFlow, NoNonFiniteValues) {
    auto check = [](double omega, double gamma, double h) {
        const ModeFlowDetail::FlowAndCovariance r = ModeFlowDetail::flowAndCovariance(omega, gamma, h);
        const ModeFlow& f = r.flow;
        for (double x : {f.xx, f.xv, f.vx, f.vv, f.gx, f.gv, f.lxx, f.lvx, f.lvv, r.sxx, r.sxv, r.svv})
            EXPECT_TRUE(std::isfinite(x)) << omega << " " << gamma << " " << h;
        EXPECT_GE(r.sxx, 0);
        EXPECT_GE(r.svv, 0);
        EXPECT_GE(f.lxx, 0);
        EXPECT_GE(f.lvv, 0);
    };
    forEachGridPoint(check);
    // Far outside the grid as well: extreme products, underflowing and denormal arguments.
    for (double omega : {0.0, 1e-300, 1e-150, 1e-20, 1.0, 1e6, 1e12})
        for (double gamma : {0.0, 1e-300, 1e-150, 1e-20, 1.0, 1e6, 1e12})
            for (double h : {1e-300, 1e-20, 1.0, 1e6})
                check(omega, gamma, h);
}

TEST(ExactModeFlow, CholeskyFactorReproducesCovariance) {
    forEachGridPoint([&](double omega, double gamma, double h) {
        const ModeFlowDetail::FlowAndCovariance r = ModeFlowDetail::flowAndCovariance(omega, gamma, h);
        const ModeFlow& f = r.flow;
        EXPECT_NEAR(f.lxx * f.lxx, r.sxx, 4 * Eps * r.sxx);
        EXPECT_NEAR(f.lxx * f.lvx, r.sxv, 4 * Eps * r.sxv + 1e-300);
        EXPECT_NEAR(f.lvx * f.lvx + f.lvv * f.lvv, r.svv, 8 * Eps * r.svv);
        // computeModeFlow is the same computation.
        const ModeFlow g = computeModeFlow(omega, gamma, h);
        EXPECT_EQ(g.xx, f.xx);
        EXPECT_EQ(g.vv, f.vv);
        EXPECT_EQ(g.gx, f.gx);
        EXPECT_EQ(g.lvv, f.lvv);
    });
}

TEST(ExactModeFlow, WarpedFrequencyGivesStrangTheExactStaticResponse) {
    // Without friction the warped xi~ = omega~ h solves xi~ tan(xi~/2) = xi^2/2 (checked here with tan, not with the
    // flow the function bisects on) and stays below pi for every xi; for small xi it is xi (1 - xi^2/24 + 11
    // xi^4/5760).  With friction the Strang step at omega~ has the static response 1/omega^2 exactly.
    const double h = 0.002;
    for (double xi : {1e-3, 0.01, 0.1, 0.5, 1.0, 2.07, 2.59, M_PI, 5.0, 2 * M_PI, 10.0, 50.0}) {
        const double omega = xi / h, warped = warpedFrequency(omega, 0.0, h) * h;
        EXPECT_LT(warped, M_PI) << "xi = " << xi;
        EXPECT_NEAR(1.0, warped * std::tan(0.5 * warped) / (0.5 * xi * xi), 1e-12) << "xi = " << xi;
        if (xi <= 0.1) {
            EXPECT_NEAR(xi * (1 - xi * xi / 24 + 11 * std::pow(xi, 4) / 5760), warped, std::pow(xi, 7) + 1e-14)
                << "xi = " << xi;
        }
        for (double gamma : {20.0, 0.2 * omega, 3.0 * omega}) {
            const double warpedOmega = warpedFrequency(omega, gamma, h);
            const double response = strangStaticResponse(computeModeFlow(warpedOmega, gamma, h), h);
            EXPECT_NEAR(1.0, response * omega * omega, 1e-10) << "xi = " << xi << ", gamma = " << gamma;
        }
    }
    // The mode's own flow has Strang's bias (xi/2) cot(xi/2).
    const double omega = 1036.0;
    EXPECT_NEAR(std::tan(1.036) / 1.036,
                1.0 / (strangStaticResponse(computeModeFlow(omega, 0.0, h), h) * omega * omega), 1e-12);
}

TEST(ExactModeFlow, WarpedFrictionScalingMatchesTheStepsInertia) {
    // warpedInertiaScale: a Warped step (mode flowing at omega~ without friction, half kicks a keeping the exact static
    // response, a = h/2 where the flow is the warped one) driven by f_n = cos(Omega n h) responds in its steady state
    // with the amplitude (1/omega^2)/(1 - Omega^2/omega_d^2 + O(Omega^4)), omega_d^2 = scale omega^2.  The steady state
    // is solved here from the step map: (e^(i theta) - Phi)(X) = Phi (0, a) + (0, a e^(i theta)), theta = Omega h.
    const double h = 0.002, omega = 1036.0;
    for (double flowPhase : {0.5, 1.2, 1.77, 2.05, 2.8}) {
        const double flowOmega = flowPhase / h;
        const ModeFlow f = computeModeFlow(flowOmega, 0.0, h);
        const double a = (1.0 - f.vv) * f.gx / f.xv + f.gv; // Filtered's kappa h: the exact mean at this flow
        const double aScaled = 0.5 * std::pow(flowOmega / omega, 2) * a;
        const double theta = 1e-3;
        const std::complex<double> z = std::polar(1.0, theta);
        // [[z - xx, -xv], [-vx, z - vv]] X = (xv a, vv a + a z)
        const std::complex<double> m00 = z - f.xx, m01 = -f.xv, m10 = -f.vx, m11 = z - f.vv;
        const std::complex<double> b0 = f.xv * aScaled, b1 = f.vv * aScaled + aScaled * z;
        const std::complex<double> x = (b0 * m11 - m01 * b1) / (m00 * m11 - m01 * m10);
        const double Omega = theta / h;
        const double inverseOmegaD2 = (1.0 - 1.0 / (omega * omega * x.real())) / (Omega * Omega);
        EXPECT_NEAR(1.0, inverseOmegaD2 * warpedInertiaScale(omega, flowOmega, h) * omega * omega, 1e-5)
            << "flow phase " << flowPhase;
    }
    // warpedMode: without scaling the friction is gamma and the frequencies are warpedFrequency, phase limited; with
    // it the friction is gamma times the inertia scale of the flow that friction gives (a fixed point), and nothing
    // changes without friction.
    for (double H : {0.001, 0.002, 0.0025, 0.003, 0.004}) {
        for (double maxPhase : {0.0, 1.77, 2.05}) {
            for (double gamma : {0.0, 20.0, 200.0}) {
                const std::string where = "H = " + std::to_string(H) + ", maxPhase = " + std::to_string(maxPhase) +
                                          ", gamma = " + std::to_string(gamma);
                const WarpedMode plain = warpedMode(omega, gamma, H, WarpedFlowSettings{maxPhase, false});
                EXPECT_EQ(gamma, plain.gamma) << where;
                EXPECT_EQ(warpedFrequency(omega, gamma, H), plain.warpedOmega) << where;
                EXPECT_EQ(phaseLimitedFrequency(plain.warpedOmega, H, maxPhase), plain.flowOmega) << where;
                const WarpedMode scaled = warpedMode(omega, gamma, H, WarpedFlowSettings{maxPhase, true});
                const double flowOmega = phaseLimitedFrequency(warpedFrequency(omega, scaled.gamma, H), H, maxPhase);
                EXPECT_NEAR(scaled.flowOmega, flowOmega, 1e-12 * flowOmega) << where;
                EXPECT_NEAR(scaled.gamma, gamma * warpedInertiaScale(omega, flowOmega, H), 1e-12 * (gamma + 1.0))
                    << where;
                EXPECT_LT(scaled.gamma, gamma + 1e-300) << where; // slower than omega: lighter friction
                if (gamma == 0.0) {
                    EXPECT_EQ(plain.flowOmega, scaled.flowOmega) << where;
                }
            }
        }
    }
}
