#include "internal/CounterRandom.h"
#include <algorithm>
#include <cmath>
#include <gtest/gtest.h>
#include <vector>

using namespace FlavorPlugin;

// Moments of 3e5 normals: each estimate must lie within 5 standard errors (fixed seed: never flakes).
TEST(CounterRandom, NormalsHaveUnitVarianceAndAreUncorrelated) {
    CounterRandom random(12345);
    const int n = 100000;
    double sum = 0, sumSq = 0, sum4 = 0, cross = 0, lag = 0;
    double previous = 0;
    for (int i = 0; i < n; ++i) {
        std::array<double, 3> x = random.normals(7, (std::uint32_t)i);
        for (double v : x) {
            sum += v;
            sumSq += v * v;
            sum4 += v * v * v * v;
            lag += v * previous;
            previous = v;
        }
        cross += x[0] * x[2];
    }
    const double count = 3.0 * n;
    EXPECT_NEAR(0.0, sum / count, 5 / std::sqrt(count));
    EXPECT_NEAR(1.0, sumSq / count, 5 * std::sqrt(2.0 / count));
    EXPECT_NEAR(3.0, sum4 / count, 5 * std::sqrt(96.0 / count));
    EXPECT_NEAR(0.0, cross / n, 5 / std::sqrt((double)n));
    EXPECT_NEAR(0.0, lag / count, 5 / std::sqrt(count));
}

TEST(CounterRandom, StreamsAndSeedsDifferAndRepeat) {
    CounterRandom a(1), b(1), c(2);
    EXPECT_EQ(a.normals(3, 4), b.normals(3, 4));
    EXPECT_NE(a.normals(3, 4), c.normals(3, 4));
    EXPECT_NE(a.normals(3, 4), a.normals(4, 4));
    EXPECT_NE(a.normals(3, 4), a.normals(3, 5));
}

namespace {

double normalCdf(double x) {
    return 0.5 * std::erfc(-x / std::sqrt(2.0));
}

} // namespace

// The whole distribution: Kolmogorov-Smirnov distance of 6e5 normals from Phi, and the probabilities of the regions
// the ziggurat treats separately (the tail beyond its last layer, the far tail, the centre), each within 5 standard
// errors of the exact value.
TEST(CounterRandom, NormalsFollowTheNormalDistribution) {
    CounterRandom random(2024);
    const int draws = 200000;
    std::vector<double> x;
    x.reserve(3 * draws);
    for (int i = 0; i < draws; ++i)
        for (double v : random.normals(11, (std::uint32_t)i))
            x.push_back(v);
    std::sort(x.begin(), x.end());
    const double n = (double)x.size();
    double distance = 0;
    for (size_t i = 0; i < x.size(); ++i) {
        const double cdf = normalCdf(x[i]);
        distance = std::max({distance, std::abs((i + 1) / n - cdf), std::abs(i / n - cdf)});
    }
    // P(sqrt(n) D > 2.2) is about 2 exp(-2 * 2.2^2) = 1.2e-4 for a correct generator.
    EXPECT_LT(std::sqrt(n) * distance, 2.2);
    auto fraction = [&](double low, double high) {
        return (std::upper_bound(x.begin(), x.end(), high) - std::lower_bound(x.begin(), x.end(), low)) / n;
    };
    const double tail = ZigguratTables::TailStart;
    const struct {
        double low, high;
    } regions[] = {{tail, 1e300}, {-1e300, -tail}, {4.0, 1e300}, {-0.1, 0.1}, {1.0, 2.0}};
    for (const auto& r : regions) {
        const double p = normalCdf(std::min(r.high, 40.0)) - normalCdf(std::max(r.low, -40.0));
        EXPECT_NEAR(p, fraction(r.low, r.high), 5 * std::sqrt(p * (1 - p) / n)) << r.low << " .. " << r.high;
    }
}
