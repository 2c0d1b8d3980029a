#include "SparseLDLT.h"
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCore>
#include <algorithm>

using namespace FlavorPlugin;
using std::pair;
using std::vector;

SparseLDLT::SparseLDLT(int n, const vector<pair<int, int>>& offDiagonal, bool reorder, bool allowDense)
    : n(n), dense(allowDense && n <= MaxDense), diagonalSlot(n), offDiagonalSlot(offDiagonal.size()) {
    // Fill-reducing order from the symmetric pattern.
    order.resize(n);
    position.resize(n);
    if (reorder && n > 2) {
        vector<Eigen::Triplet<double>> entries;
        for (int i = 0; i < n; ++i)
            entries.emplace_back(i, i, 1.0);
        for (const pair<int, int>& e : offDiagonal) {
            entries.emplace_back(e.first, e.second, 1.0);
            entries.emplace_back(e.second, e.first, 1.0);
        }
        Eigen::SparseMatrix<double> pattern(n, n);
        pattern.setFromTriplets(entries.begin(), entries.end());
        Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> permutation;
        Eigen::AMDOrdering<int>()(pattern, permutation);
        for (int k = 0; k < n; ++k)
            order[k] = permutation.indices()[k];
    } else {
        for (int k = 0; k < n; ++k)
            order[k] = k;
    }
    for (int k = 0; k < n; ++k)
        position[order[k]] = k;
    // The permuted upper triangle by columns: each off-diagonal pair goes to the column of its later row.
    vector<vector<pair<int, int>>> columns(n); // (row, caller's slot: -1 - i for diagonal i, k for pair k)
    for (size_t k = 0; k < offDiagonal.size(); ++k) {
        const int a = position[offDiagonal[k].first], b = position[offDiagonal[k].second];
        columns[std::max(a, b)].emplace_back(std::min(a, b), (int)k);
    }
    for (int i = 0; i < n; ++i)
        columns[position[i]].emplace_back(position[i], -1 - i);
    columnStart.push_back(0);
    for (int j = 0; j < n; ++j) {
        for (const pair<int, int>& entry : columns[j]) {
            const int slot = (int)rowIndex.size();
            rowIndex.push_back(entry.first);
            if (entry.second < 0)
                diagonalSlot[-1 - entry.second] = slot;
            else
                offDiagonalSlot[entry.second] = slot;
        }
        columnStart.push_back((int)rowIndex.size());
    }
    values.assign(rowIndex.size(), 0.0);
    // Elimination tree and the number of nonzeros in each column of L.
    parent.assign(n, -1);
    count.assign(n, 0);
    flag.assign(n, -1);
    for (int k = 0; k < n; ++k) {
        flag[k] = k;
        for (int p = columnStart[k]; p < columnStart[k + 1]; ++p)
            for (int i = rowIndex[p]; i < k && flag[i] != k; i = parent[i]) {
                if (parent[i] == -1)
                    parent[i] = k;
                ++count[i];
                flag[i] = k;
            }
    }
    factorStart.assign(n + 1, 0);
    for (int k = 0; k < n; ++k)
        factorStart[k + 1] = factorStart[k] + count[k];
    factorRow.resize(factorStart[n]);
    factorValue.resize(factorStart[n]);
    pivot.resize(n);
    dependent.assign(n, 0);
    pattern.resize(n);
    accumulator.assign(n, 0.0);
    permuted.resize(n);
    if (dense) {
        // The dense path keeps the permuted matrix's lower triangle in values, row by row (entry (j, i), i <= j, at
        // j n + i; those outside the pattern stay 0).  An entry given twice (summed by the sparse path) keeps the
        // sparse path.
        vector<int> denseSlot(rowIndex.size());
        vector<char> taken(n * n, 0);
        for (int j = 0; j < n; ++j)
            for (int p = columnStart[j]; p < columnStart[j + 1]; ++p) {
                denseSlot[p] = j * n + rowIndex[p];
                dense = dense && !taken[denseSlot[p]];
                taken[denseSlot[p]] = 1;
            }
        if (dense) {
            for (int& slot : diagonalSlot)
                slot = denseSlot[slot];
            for (int& slot : offDiagonalSlot)
                slot = denseSlot[slot];
            values.assign(n * n, 0.0);
        }
    }
}

int SparseLDLT::factorize(double dropTolerance) {
    if (dense)
        return factorizeDense(dropTolerance);
    int numDependent = 0;
    smallestRatio = 1.0;
    for (int k = 0; k < n; ++k) {
        // Scatter column k of the upper triangle and find the rows of L's row k by walking the elimination tree.
        accumulator[k] = 0.0;
        flag[k] = k;
        count[k] = 0;
        int top = n;
        double diagonal = 0.0;
        for (int p = columnStart[k]; p < columnStart[k + 1]; ++p) {
            int i = rowIndex[p];
            accumulator[i] += values[p];
            if (i == k)
                diagonal = values[p];
            int length = 0;
            for (; flag[i] != k; i = parent[i]) {
                pattern[length++] = i;
                flag[i] = k;
            }
            while (length > 0)
                pattern[--top] = pattern[--length];
        }
        double d = accumulator[k];
        accumulator[k] = 0.0;
        // Sparse triangular solve in topological order: L_ki = y_i / d_i, d_k = A_kk - sum L_ki y_i.
        for (; top < n; ++top) {
            const int i = pattern[top];
            const double y = accumulator[i];
            accumulator[i] = 0.0;
            const int end = factorStart[i] + count[i];
            for (int p = factorStart[i]; p < end; ++p)
                accumulator[factorRow[p]] -= factorValue[p] * y;
            const double l = dependent[i] ? 0.0 : y / pivot[i];
            d -= l * y;
            factorRow[end] = k;
            factorValue[end] = l;
            ++count[i];
        }
        pivot[k] = d;
        dependent[k] = d <= dropTolerance * diagonal ? 1 : 0;
        numDependent += dependent[k];
        if (!dependent[k])
            smallestRatio = std::min(smallestRatio, d / diagonal);
    }
    return numDependent;
}

int SparseLDLT::factorizeDense(double dropTolerance) {
    switch (n) {
    case 1:
        return eliminateDense<1>(dropTolerance);
    case 2:
        return eliminateDense<2>(dropTolerance);
    case 3:
        return eliminateDense<3>(dropTolerance);
    case 4:
        return eliminateDense<4>(dropTolerance);
    default:
        smallestRatio = 1.0;
        return 0;
    }
}

template <int N> int SparseLDLT::eliminateDense(double dropTolerance) {
    // The elimination of factorize() on dense arrays, in the same order: a is the permuted matrix's lower triangle
    // (values), l the strict lower triangle of L, d the pivots, keep 1 for the rows not found dependent.
    const double* a = values.data();
    double l[N][N], d[N], keep[N];
    int numDependent = 0;
    double ratio = 1.0;
#pragma GCC unroll 4
    for (int k = 0; k < N; ++k) {
        // Row k of L from L D y = a_k (the triangular solve of factorize(), every entry present).
        double y[N];
#pragma GCC unroll 4
        for (int i = 0; i < k; ++i)
            y[i] = a[k * N + i];
        d[k] = a[k * N + k];
#pragma GCC unroll 4
        for (int i = 0; i < k; ++i) {
#pragma GCC unroll 4
            for (int r = i + 1; r < k; ++r)
                y[r] -= l[r][i] * y[i];
            const double entry = keep[i] != 0.0 ? y[i] / d[i] : 0.0;
            d[k] -= entry * y[i];
            l[k][i] = entry;
        }
        const bool dropped = d[k] <= dropTolerance * a[k * N + k];
        keep[k] = dropped ? 0.0 : 1.0;
        numDependent += dropped ? 1 : 0;
        if (!dropped)
            ratio = std::min(ratio, d[k] / a[k * N + k]);
    }
    // G = L^-T D^+ L^-1 with m = L^-1 (unit lower triangular), stored in the caller's numbering.
    double m[N][N], inversePivot[N];
#pragma GCC unroll 4
    for (int i = 0; i < N; ++i) {
        m[i][i] = 1.0;
#pragma GCC unroll 4
        for (int j = 0; j < i; ++j) {
            double sum = 0.0;
#pragma GCC unroll 4
            for (int q = j; q < i; ++q)
                sum -= l[i][q] * m[q][j];
            m[i][j] = sum;
        }
        inversePivot[i] = keep[i] != 0.0 ? 1.0 / d[i] : 0.0;
    }
    int original[N];
#pragma GCC unroll 4
    for (int i = 0; i < N; ++i) {
        original[i] = order[i];
        pivot[i] = d[i];
        dependent[i] = keep[i] == 0.0 ? 1 : 0;
    }
#pragma GCC unroll 4
    for (int i = 0; i < N; ++i)
#pragma GCC unroll 4
        for (int j = 0; j <= i; ++j) {
            double sum = 0.0;
#pragma GCC unroll 4
            for (int k = i; k < N; ++k)
                sum += m[k][i] * inversePivot[k] * m[k][j];
            inverse[original[i] * N + original[j]] = sum;
            inverse[original[j] * N + original[i]] = sum;
        }
    smallestRatio = ratio;
    return numDependent;
}

void SparseLDLT::solveSparse(double* b) const {
    for (int k = 0; k < n; ++k)
        permuted[k] = b[order[k]];
    for (int j = 0; j < n; ++j)
        for (int p = factorStart[j]; p < factorStart[j + 1]; ++p)
            permuted[factorRow[p]] -= factorValue[p] * permuted[j];
    for (int j = 0; j < n; ++j)
        permuted[j] = dependent[j] ? 0.0 : permuted[j] / pivot[j];
    for (int j = n - 1; j >= 0; --j)
        for (int p = factorStart[j]; p < factorStart[j + 1]; ++p)
            permuted[j] -= factorValue[p] * permuted[factorRow[p]];
    for (int k = 0; k < n; ++k)
        b[order[k]] = permuted[k];
}
