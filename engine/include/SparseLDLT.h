#ifndef OPENMM_FLAVORS_SPARSE_LDLT_H_
#define OPENMM_FLAVORS_SPARSE_LDLT_H_

#include "internal/windowsExportFlavors.h"
#include <array>
#include <utility>
#include <vector>

namespace FlavorPlugin {

/**
 * A = L D L^T for a sparse symmetric positive semidefinite matrix whose pattern is fixed at construction: the
 * fill-reducing ordering (approximate minimum degree), the elimination tree and the pattern of L are computed once,
 * so factorize() and solve() do not allocate.  The factorization is up-looking (row k of L from a sparse triangular
 * solve along the elimination tree).
 *
 * A pivot d_k <= dropTolerance * A_kk marks row k as linearly dependent on the rows eliminated before it: its
 * column of L is set to zero and solve() returns x_k = 0.  For a consistent singular system (redundant constraints
 * whose targets agree) that is a solution of A x = b; the other unknowns solve the system without the dependent rows.
 *
 * Small matrices (n <= MaxDense: a frozen water molecule's 3 x 3) are factorized by the same elimination in the same
 * order and with the same test for dependent rows, on a dense array (values then holds the permuted lower triangle):
 * the walks along the elimination tree cost more than the arithmetic there.  factorize() then also forms the matrix G =
 * P^T L^-T D^+ L^-1 P that solve() applies (D^+: the inverse pivots, 0 for the dependent rows), so a solve is one n x n
 * product, the same x as the substitutions up to rounding.
 */
class OPENMM_EXPORT_FLAVORS SparseLDLT {
public:
    /**
     * @param n            the order of A
     * @param offDiagonal  the positions (i, j), i != j, of A's nonzeros off the diagonal, each symmetric pair once
     * @param reorder      eliminate in a fill-reducing order; otherwise in the given one (row k is then tested for
     *                     dependence on rows 0 .. k-1)
     * @param allowDense   take the dense path where n <= MaxDense (false: the sparse one at every size, for tests)
     */
    SparseLDLT(int n, const std::vector<std::pair<int, int>>& offDiagonal, bool reorder = true, bool allowDense = true);
    /** The largest order factorized and solved on a dense array. */
    static constexpr int MaxDense = 4;
    int size() const { return n; }
    /** Sets A_ii. */
    void setDiagonal(int i, double value) { values[diagonalSlot[i]] = value; }
    /** Sets A_ij = A_ji for the k-th pair given to the constructor. */
    void setOffDiagonal(int k, double value) { values[offDiagonalSlot[k]] = value; }
    /** Factorizes the values set; returns how many rows were found dependent. */
    int factorize(double dropTolerance);
    /** Overwrites b (in the constructor's numbering) with the solution of A x = b. */
    void solve(double* b) const {
        switch (dense ? n : 0) {
        case 1:
            b[0] *= inverse[0];
            return;
        case 2:
            applyDense<2>(b);
            return;
        case 3:
            applyDense<3>(b);
            return;
        case 4:
            applyDense<4>(b);
            return;
        default:
            solveSparse(b);
        }
    }
    /**
     * The smallest ratio of a pivot to its row's diagonal entry among the rows not found dependent by the last
     * factorize() (1 for an empty matrix): how close the rows come to being dependent, in the elimination order.
     */
    double smallestPivotRatio() const { return smallestRatio; }
    /** Whether row i (the constructor's numbering) was found dependent by the last factorize(). */
    bool isDependent(int i) const { return dependent[position[i]] != 0; }
    /** Whether factorize() and solve() take the dense path. */
    bool isDense() const { return dense; }
    /** The row (constructor's numbering) eliminated k-th. */
    int eliminatedAt(int k) const { return order[k]; }

private:
    void solveSparse(double* b) const;
    /** b = G b on the dense path. */
    template <int N> void applyDense(double* b) const {
        double x[N];
        for (int i = 0; i < N; ++i) {
            double sum = 0.0;
            for (int j = 0; j < N; ++j)
                sum += inverse[i * N + j] * b[j];
            x[i] = sum;
        }
        for (int i = 0; i < N; ++i)
            b[i] = x[i];
    }
    int factorizeDense(double dropTolerance);
    template <int N> int eliminateDense(double dropTolerance);
    int n;
    bool dense;
    // original index of row k of the permuted matrix, and its inverse
    std::vector<int> order, position;
    // The upper triangle of the permuted matrix by columns (rows <= column, the diagonal last), and where each
    // entry set by the caller lives in it.
    std::vector<int> columnStart, rowIndex, diagonalSlot, offDiagonalSlot;
    std::vector<double> values;
    // L strictly below the diagonal by columns, D, the elimination tree and the rows found dependent.
    std::vector<int> factorStart, factorRow, parent;
    std::vector<double> factorValue, pivot;
    std::vector<char> dependent;
    double smallestRatio = 1.0;
    // Workspaces of factorize() and solve().
    std::vector<int> count, pattern, flag;
    std::vector<double> accumulator;
    mutable std::vector<double> permuted;
    // The dense path: G in the constructor's numbering, row by row.
    std::array<double, MaxDense * MaxDense> inverse{};
};

} // namespace FlavorPlugin

#endif
