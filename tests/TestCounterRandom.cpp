#include "internal/CounterRandom.h"
#include <cmath>
#include <gtest/gtest.h>

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
