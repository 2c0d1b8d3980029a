#ifndef OPENMM_FLAVORS_TESTS_LINEAR_SDE_REFERENCE_H_
#define OPENMM_FLAVORS_TESTS_LINEAR_SDE_REFERENCE_H_

// The exact solution of the linear SDE  dq = v dt,  M dv = (-K q + b) dt - gamma M v dt + sqrt(2 gamma kT M) dW
// by matrix exponentials in long double, independent of the library's per-mode formulas.

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <vector>

namespace FlavorTests {

typedef Eigen::Matrix<long double, Eigen::Dynamic, Eigen::Dynamic> MatrixL;
typedef Eigen::Matrix<long double, Eigen::Dynamic, 1> VectorL;

/**
 * exp(A) by scaling to norm 1e-3, a Taylor series summed to long double precision, and repeated squaring (interval
 * doubling).  Each squaring at most doubles the relative error, so for norms up to ~1e4 the result is good to
 * ~1e-13 relative (Eigen's Pade exp in long double was measured to lose 1e-9 at omega*t = 3700).
 */
inline MatrixL exponential(const MatrixL& a) {
    const long double norm = a.cwiseAbs().rowwise().sum().maxCoeff();
    const int squarings = norm > 1e-3L ? (int)std::ceil(std::log2(norm / 1e-3L)) : 0;
    const MatrixL scaled = a / std::pow(2.0L, (long double)squarings);
    MatrixL result = MatrixL::Identity(a.rows(), a.cols()), term = result;
    for (int k = 1; k < 40; ++k) {
        term = term * scaled / (long double)k;
        result += term;
        if (term.cwiseAbs().maxCoeff() < 1e-24L * result.cwiseAbs().maxCoeff())
            break;
    }
    for (int i = 0; i < squarings; ++i)
        result = result * result;
    return result;
}

struct LinearSde {
    MatrixL K;                // n x n stiffness (n = 3 * particles)
    VectorL b;                // constant force
    std::vector<double> mass; // per coordinate
    double gamma = 0, kT = 0;

    /** The drift matrix of (q, v, 1). */
    MatrixL drift() const {
        const int n = (int)b.size();
        MatrixL a = MatrixL::Zero(2 * n + 1, 2 * n + 1);
        for (int i = 0; i < n; ++i) {
            a(i, n + i) = 1;
            a(n + i, n + i) = -gamma;
            a(n + i, 2 * n) = b[i] / mass[i];
            for (int j = 0; j < n; ++j)
                a(n + i, j) = -K(i, j) / mass[i];
        }
        return a;
    }

    /**
     * The mean of (q, v) after time t from the state (q, v).  Velocities are scaled by the largest frequency so that
     * the exponentiated matrix has norm ~omega rather than omega^2.
     */
    VectorL mean(const VectorL& state, double t) const {
        const int n = (int)b.size();
        long double omega = 1;
        for (int i = 0; i < n; ++i)
            omega = std::max(omega, std::sqrt(K.row(i).cwiseAbs().sum() / (long double)mass[i]));
        VectorL scale = VectorL::Ones(2 * n + 1);
        scale.segment(n, n).setConstant(1 / omega);
        MatrixL balanced = scale.asDiagonal() * drift() * scale.cwiseInverse().asDiagonal();
        VectorL x(2 * n + 1);
        x << state, 1.0L;
        VectorL result =
            scale.cwiseInverse().asDiagonal() * (exponential(balanced * (long double)t) * (scale.asDiagonal() * x));
        return result.head(2 * n);
    }

    /** The covariance of (q, v) after time t (Van Loan's block exponential). */
    MatrixL covariance(double t) const {
        const int n = (int)b.size();
        MatrixL a = drift().topLeftCorner(2 * n, 2 * n);
        MatrixL q = MatrixL::Zero(2 * n, 2 * n);
        for (int i = 0; i < n; ++i)
            q(n + i, n + i) = 2 * gamma * kT / mass[i];
        MatrixL block = MatrixL::Zero(4 * n, 4 * n);
        block.topLeftCorner(2 * n, 2 * n) = -a;
        block.topRightCorner(2 * n, 2 * n) = q;
        block.bottomRightCorner(2 * n, 2 * n) = a.transpose();
        MatrixL e = exponential(block * (long double)t);
        MatrixL phiT = e.bottomRightCorner(2 * n, 2 * n);
        return phiT.transpose() * e.topRightCorner(2 * n, 2 * n);
    }
};

} // namespace FlavorTests

#endif
