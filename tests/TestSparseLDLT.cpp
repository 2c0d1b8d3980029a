// SparseLDLT, the factorization of the frozen-distance clusters, against Eigen's dense LDL^T: full-rank systems,
// and consistent singular ones (redundant constraints) where dependent rows must be found and dropped.

#include "SparseLDLT.h"
#include <Eigen/Dense>
#include <cmath>
#include <gtest/gtest.h>
#include <random>
#include <utility>
#include <vector>

using namespace FlavorPlugin;
using std::pair;
using std::vector;

namespace {

/** A = G G^T with G n x m random sparse (each row a few entries), so A is positive semidefinite with G's pattern. */
Eigen::MatrixXd gramOfRandomRows(int n, int m, int perRow, std::mt19937& random) {
    std::uniform_int_distribution<int> column(0, m - 1);
    std::normal_distribution<double> value;
    Eigen::MatrixXd g = Eigen::MatrixXd::Zero(n, m);
    for (int i = 0; i < n; ++i)
        for (int e = 0; e < perRow; ++e)
            g(i, column(random)) = value(random);
    return g * g.transpose();
}

SparseLDLT factorOf(const Eigen::MatrixXd& a, bool reorder, double dropTolerance, int& numDependent,
                    bool allowDense = true) {
    const int n = (int)a.rows();
    vector<pair<int, int>> offDiagonal;
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < j; ++i)
            if (a(i, j) != 0.0)
                offDiagonal.emplace_back(j, i);
    SparseLDLT solver(n, offDiagonal, reorder, allowDense);
    for (int i = 0; i < n; ++i)
        solver.setDiagonal(i, a(i, i));
    for (size_t k = 0; k < offDiagonal.size(); ++k)
        solver.setOffDiagonal((int)k, a(offDiagonal[k].first, offDiagonal[k].second));
    numDependent = solver.factorize(dropTolerance);
    return solver;
}

} // namespace

TEST(SparseLDLT, SolvesSparsePositiveDefiniteSystemsLikeADenseFactorization) {
    std::mt19937 random(11);
    for (bool reorder : {true, false}) {
        const Eigen::MatrixXd a = gramOfRandomRows(80, 120, 3, random) + Eigen::MatrixXd::Identity(80, 80);
        int numDependent = -1;
        SparseLDLT solver = factorOf(a, reorder, 1e-10, numDependent);
        EXPECT_EQ(0, numDependent);
        Eigen::VectorXd b = Eigen::VectorXd::Random(80);
        const Eigen::VectorXd expected = a.ldlt().solve(b);
        solver.solve(b.data());
        EXPECT_LT((b - expected).norm(), 1e-11 * expected.norm()) << "reorder " << reorder;
        // Refactorizing new values with the same pattern gives the new solution.
        const Eigen::MatrixXd scaled = 3.0 * a;
        SparseLDLT again = factorOf(scaled, reorder, 1e-10, numDependent);
        Eigen::VectorXd c = Eigen::VectorXd::Ones(80);
        again.solve(c.data());
        EXPECT_LT((scaled * c - Eigen::VectorXd::Ones(80)).norm(), 1e-11 * std::sqrt(80.0));
    }
}

TEST(SparseLDLT, DropsDependentRowsAndSolvesConsistentSingularSystems) {
    // Rows 5 and 9 of G are combinations of earlier rows: A has rank n - 2, and b in its range has solutions.
    std::mt19937 random(5);
    const int n = 30, m = 40;
    std::normal_distribution<double> value;
    Eigen::MatrixXd g = Eigen::MatrixXd::Zero(n, m);
    for (int i = 0; i < n; ++i)
        for (int j = i; j < std::min(m, i + 4); ++j)
            g(i, j) = value(random);
    g.row(5) = 0.5 * g.row(3) - 2.0 * g.row(4);
    g.row(9) = g.row(8) + g.row(7) - g.row(6);
    const Eigen::MatrixXd a = g * g.transpose();
    const Eigen::VectorXd b = a * Eigen::VectorXd::Random(n);
    for (bool reorder : {true, false}) {
        int numDependent = -1;
        SparseLDLT solver = factorOf(a, reorder, 1e-10, numDependent);
        EXPECT_EQ(2, numDependent) << "reorder " << reorder;
        Eigen::VectorXd x = b;
        solver.solve(x.data());
        EXPECT_LT((a * x - b).norm(), 1e-10 * b.norm()) << "reorder " << reorder;
        if (!reorder) {
            // In the given order the later row of each dependent set is the one dropped, and its unknown is 0.
            EXPECT_TRUE(solver.isDependent(5));
            EXPECT_TRUE(solver.isDependent(9));
            EXPECT_EQ(0.0, x[5]);
            EXPECT_EQ(0.0, x[9]);
        }
    }
}

TEST(SparseLDLT, NearlyDependentRowsAreDroppedByTheThreshold) {
    // Row 2 of G makes the angle theta with row 1 and is orthogonal to row 0: its pivot relative to its diagonal entry
    // is sin^2(theta).
    const double theta = 0.05;
    Eigen::MatrixXd g = Eigen::MatrixXd::Zero(3, 3);
    g(0, 0) = 1.0;
    g(1, 1) = 1.0;
    g(2, 1) = std::cos(theta);
    g(2, 2) = std::sin(theta);
    const Eigen::MatrixXd a = g * g.transpose();
    int numDependent = -1;
    SparseLDLT strict = factorOf(a, false, 0.5 * theta * theta, numDependent);
    EXPECT_EQ(0, numDependent);
    SparseLDLT loose = factorOf(a, false, 2.0 * theta * theta, numDependent);
    EXPECT_EQ(1, numDependent);
    EXPECT_TRUE(loose.isDependent(2));
    // The smallest pivot ratio among the rows kept: sin^2(theta) when row 2 is kept, 1 when it is dropped.
    EXPECT_NEAR(std::sin(theta) * std::sin(theta), strict.smallestPivotRatio(), 1e-12);
    EXPECT_NEAR(1.0, loose.smallestPivotRatio(), 1e-12);
}

TEST(SparseLDLT, TheDensePathOfSmallMatricesAgreesWithTheSparseOne) {
    // Orders 1 to MaxDense, full and sparse patterns, in both orders: positive definite matrices, matrices with a row
    // that is a combination of others (exactly, and within or beyond the drop tolerance), each solved for a right-hand
    // side in its range.  The dense path must find the same dependent rows and pivots and give the same solution.
    std::mt19937 random(17);
    std::normal_distribution<double> value;
    std::uniform_real_distribution<double> uniform(0.0, 1.0);
    const double dropTolerance = 1e-10;
    int numCompared = 0, numWithDependent = 0;
    for (int n = 1; n <= SparseLDLT::MaxDense; ++n)
        for (int trial = 0; trial < 200; ++trial) {
            Eigen::MatrixXd g = Eigen::MatrixXd::Zero(n, 3 * n);
            for (int i = 0; i < n; ++i)
                for (int j = 0; j < 3 * n; ++j)
                    if (trial % 2 == 0 || uniform(random) < 0.4 || j == i)
                        g(i, j) = value(random);
            const int kind = trial % 4;
            if (n >= 2 && kind >= 1) {
                // Row r a combination of the others: exactly (kind 1), or off by a relative 1e-3 (kind 2, pivot ratio
                // about 1e-6, kept) or 1e-7 (kind 3, about 1e-14, dropped) in a new direction.
                const int r = std::uniform_int_distribution<int>(1, n - 1)(random);
                Eigen::RowVectorXd combination = Eigen::RowVectorXd::Zero(3 * n);
                for (int i = 0; i < n; ++i)
                    if (i != r)
                        combination += value(random) * g.row(i);
                Eigen::RowVectorXd offset = Eigen::RowVectorXd::Zero(3 * n);
                offset(3 * n - 1 - r) = combination.norm();
                g.row(r) = combination + (kind == 1 ? 0.0 : kind == 2 ? 1e-3 : 1e-7) * offset;
            }
            const Eigen::MatrixXd a = g * g.transpose();
            const Eigen::VectorXd b = a * Eigen::VectorXd::Random(n);
            for (bool reorder : {true, false}) {
                int sparseDependent = -1, denseDependent = -1;
                SparseLDLT sparse = factorOf(a, reorder, dropTolerance, sparseDependent, false);
                SparseLDLT dense = factorOf(a, reorder, dropTolerance, denseDependent, true);
                ASSERT_FALSE(sparse.isDense());
                ASSERT_TRUE(dense.isDense());
                ASSERT_EQ(sparseDependent, denseDependent) << "n " << n << " trial " << trial;
                for (int i = 0; i < n; ++i)
                    EXPECT_EQ(sparse.isDependent(i), dense.isDependent(i)) << "n " << n << " trial " << trial;
                EXPECT_NEAR(sparse.smallestPivotRatio(), dense.smallestPivotRatio(),
                            1e-12 * sparse.smallestPivotRatio());
                Eigen::VectorXd x = b, y = b;
                sparse.solve(x.data());
                dense.solve(y.data());
                EXPECT_LT((x - y).norm(), 1e-8 * x.norm()) << "n " << n << " trial " << trial;
                if (sparseDependent == 0) {
                    EXPECT_LT((a * y - b).norm(), 1e-8 * b.norm()) << "n " << n << " trial " << trial;
                }
                ++numCompared;
                numWithDependent += sparseDependent > 0 ? 1 : 0;
            }
        }
    EXPECT_EQ(2 * 200 * SparseLDLT::MaxDense, numCompared);
    EXPECT_GT(numWithDependent, 100);
}
