#include "internal/StiffModes.h"
#include "internal/ExactModeFlow.h"
#include "internal/ParameterChecks.h"
#include "openmm/OpenMMException.h"
#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numeric>
#include <utility>

using namespace FlavorPlugin;
using namespace OpenMM;
using std::vector;

namespace {

int findRoot(vector<int>& parent, int i) {
    while (parent[i] != i)
        i = parent[i] = parent[parent[i]];
    return i;
}

/** The flow of one mode over h; for h < 0 (friction 0 only) the inverse of the flow over -h. */
ModeFlow modeFlow(double omega, double gamma, double h) {
    if (h >= 0)
        return computeModeFlow(omega, gamma, h);
    // The deterministic flow has unit determinant, so its inverse is the adjugate.
    ModeFlow f = computeModeFlow(omega, 0.0, -h);
    ModeFlow inverse{f.vv, -f.xv, -f.vx, f.xx, 0, 0, 0, 0, 0};
    inverse.gx = -(inverse.xx * f.gx + inverse.xv * f.gv);
    inverse.gv = -(inverse.vx * f.gx + inverse.vv * f.gv);
    return inverse;
}

// The D x D matrices of a propagator.
enum Matrix { Axx, Axv, Avx, Avv, Nxx, Nvx, Nvv };

/**
 * Where the parts of a small component's propagator lie: the D x D particle-space matrices Axx, Axv, Avx, Avv, the
 * D x C offsets gx, gv, then Nxx, Nvx, Nvv if noisy.
 */
struct PropagatorLayout {
    size_t D, C;
    constexpr size_t matrix(Matrix m) const { return m < Nxx ? m * D * D : 4 * D * D + 2 * D * C + (m - Nxx) * D * D; }
    constexpr size_t gx() const { return 4 * D * D; }
    constexpr size_t gv() const { return 4 * D * D + D * C; }
    size_t size(bool noisy) const { return (noisy ? 7 : 4) * D * D + 2 * D * C; }
};

/**
 * A large component's propagator stays in mode space, where it is diagonal: per mode k the 2 x 2 transition
 * (xx, xv, vx, vv) and, when noisy, the noise factor sqrt(kT) (lxx, lvx, lvv); then the D x C mode offsets gx, gv.
 * Applying it costs two products with the eigenvectors, instead of four to seven with D x D particle-space matrices
 * that would not fit in cache.
 */
struct ModeLayout {
    size_t D, C;
    static constexpr size_t Transition = 4, Noise = 3;
    constexpr size_t perMode(bool noisy) const { return noisy ? Transition + Noise : Transition; }
    constexpr size_t gx(bool noisy) const { return perMode(noisy) * D; }
    constexpr size_t gv(bool noisy) const { return perMode(noisy) * D + D * C; }
    size_t size(bool noisy) const { return perMode(noisy) * D + 2 * D * C; }
};

/** out (D x C) = offset + sum over the terms of A_t in_t, with D, C and the number of terms known at compile time. */
template <int D, int C, int Terms>
[[gnu::always_inline]] inline void propagateSmall(const double* offset, const double* const (&matrices)[Terms],
                                                  const double* const (&in)[Terms], double* out) {
    double sum[D * C];
    for (int k = 0; k < D * C; ++k)
        sum[k] = offset[k];
    for (int t = 0; t < Terms; ++t) {
        const double* a = matrices[t];
        const double* x = in[t];
        for (int i = 0; i < D; ++i)
            for (int j = 0; j < D; ++j)
                for (int c = 0; c < C; ++c)
                    sum[i * C + c] += a[i * D + j] * x[j * C + c];
    }
    for (int k = 0; k < D * C; ++k)
        out[k] = sum[k];
}

/**
 * Reads one particle's position, velocity (after the fused kick, if any) and, when noisy, its two noise vectors
 * into 3-element slices.
 */
inline void readParticle(const StiffModes::Flow& flow, int particle, bool noisy, double* q, double* v, double* xi1,
                         double* xi2) {
    for (int d = 0; d < 3; ++d) {
        q[d] = flow.positions[particle][d];
        v[d] = flow.velocities[particle][d];
    }
    if (flow.kickForces != nullptr) {
        const double scale = flow.kickStep * flow.inverseMasses[particle];
        for (int d = 0; d < 3; ++d)
            v[d] += scale * flow.kickForces[particle][d];
    }
    if (noisy) {
        const std::array<double, 3> a = flow.random->normals(flow.stream, 2 * (std::uint32_t)particle);
        const std::array<double, 3> b = flow.random->normals(flow.stream, 2 * (std::uint32_t)particle + 1);
        for (int d = 0; d < 3; ++d) {
            xi1[d] = a[d];
            xi2[d] = b[d];
        }
    }
}

/**
 * The flow of one small component (D rows, C columns), its state held in local arrays: most components are a bond
 * or a single particle, where gathering into shared buffers and loops of run-time length would cost more than the
 * arithmetic.  Positions and velocities are 3 doubles per particle in the component's particle order, which is the
 * D x C row-major layout for either C.
 */
template <int D, int C, bool Noisy>
void applySmall(const int* particles, const double* m, const StiffModes::Flow& flow) {
    constexpr int Size = D * C, NumParticles = Size / 3;
    constexpr PropagatorLayout layout{D, C};
    double q[Size], v[Size], xi1[Size], xi2[Size];
    for (int p = 0; p < NumParticles; ++p)
        readParticle(flow, particles[p], Noisy, q + 3 * p, v + 3 * p, xi1 + 3 * p, xi2 + 3 * p);
    double newQ[Size], newV[Size];
    if (Noisy) {
        propagateSmall<D, C, 3>(m + layout.gx(),
                                {m + layout.matrix(Axx), m + layout.matrix(Axv), m + layout.matrix(Nxx)}, {q, v, xi1},
                                newQ);
        propagateSmall<D, C, 4>(
            m + layout.gv(),
            {m + layout.matrix(Avx), m + layout.matrix(Avv), m + layout.matrix(Nvx), m + layout.matrix(Nvv)},
            {q, v, xi1, xi2}, newV);
    } else {
        propagateSmall<D, C, 2>(m + layout.gx(), {m + layout.matrix(Axx), m + layout.matrix(Axv)}, {q, v}, newQ);
        propagateSmall<D, C, 2>(m + layout.gv(), {m + layout.matrix(Avx), m + layout.matrix(Avv)}, {q, v}, newV);
    }
    for (int p = 0; p < NumParticles; ++p) {
        const int particle = particles[p];
        flow.positions[particle] = Vec3(newQ[3 * p], newQ[3 * p + 1], newQ[3 * p + 2]);
        flow.velocities[particle] = Vec3(newV[3 * p], newV[3 * p + 1], newV[3 * p + 2]);
    }
}

/**
 * out (D x W, row-major) = U^T in (in: D x W, row-major) for the column-major D x D eigenvectors U: each column of U
 * is read once, in order.  Plain loops rather than a general matrix product, which would allocate its packing buffers
 * on the heap for large components.
 */
template <int W> void toModes(int D, const double* u, const double* in, double* out) {
    for (int k = 0; k < D; ++k) {
        const double* column = u + (size_t)k * D;
        double sum[W] = {};
        for (int i = 0; i < D; ++i)
            for (int w = 0; w < W; ++w)
                sum[w] += column[i] * in[(size_t)i * W + w];
        for (int w = 0; w < W; ++w)
            out[(size_t)k * W + w] = sum[w];
    }
}

/**
 * out (D x W, row-major) = U in, reading the columns of U in order, four at a time so that each pass over out adds
 * four modes.
 */
template <int W> void fromModes(int D, const double* u, const double* in, double* out) {
    std::fill(out, out + (size_t)D * W, 0.0);
    int k = 0;
    for (; k + 4 <= D; k += 4) {
        const double *c0 = u + (size_t)k * D, *c1 = c0 + D, *c2 = c1 + D, *c3 = c2 + D;
        const double* mode = in + (size_t)k * W;
        for (int i = 0; i < D; ++i)
            for (int w = 0; w < W; ++w)
                out[(size_t)i * W + w] +=
                    c0[i] * mode[w] + c1[i] * mode[W + w] + c2[i] * mode[2 * W + w] + c3[i] * mode[3 * W + w];
    }
    for (; k < D; ++k) {
        const double* column = u + (size_t)k * D;
        const double* mode = in + (size_t)k * W;
        for (int i = 0; i < D; ++i)
            for (int w = 0; w < W; ++w)
                out[(size_t)i * W + w] += column[i] * mode[w];
    }
}

/** toModes<W> for the one of the widths Ws that equals width, a value known only at run time. */
template <int... Ws> void toModesOfWidth(int width, int D, const double* u, const double* in, double* out) {
    const bool found = ((width == Ws && (toModes<Ws>(D, u, in, out), true)) || ...);
    if (!found)
        throw OpenMMException("StiffModes: no mode product for a component of width " + std::to_string(width));
}

typedef StiffModes::ComponentFlow SmallFlow;

/** The compiled flows of isotropic components (C = 3) of 1, 2, ... rows. */
template <bool Noisy, int... Index>
constexpr std::array<SmallFlow, sizeof...(Index)> isotropicFlows(std::integer_sequence<int, Index...>) {
    return {&applySmall<Index + 1, 3, Noisy>...};
}

/** The compiled flow for a component of D rows and C columns, or nullptr when it is too large for one. */
template <bool Noisy> SmallFlow smallFlow(int D, int C) {
    // Isotropic components of up to 6 particles; anisotropic ones (C = 1, 3 rows per particle) of 1 or 2.
    constexpr int MaxIsotropicRows = 6;
    if (C == 3 && D >= 1 && D <= MaxIsotropicRows)
        return isotropicFlows<Noisy>(std::make_integer_sequence<int, MaxIsotropicRows>())[D - 1];
    if (C == 1 && D == 3)
        return &applySmall<3, 1, Noisy>;
    if (C == 1 && D == 6)
        return &applySmall<6, 1, Noisy>;
    return nullptr;
}

} // namespace

StiffModes::StiffModes(const vector<double>& masses, const vector<StiffnessBlock>& blocks,
                       const vector<Vec3>& constantForce) {
    const int numParticles = (int)masses.size();
    stiffParticle.assign(numParticles, false);
    sqrtMass.resize(numParticles);
    for (int i = 0; i < numParticles; ++i)
        sqrtMass[i] = std::sqrt(masses[i]);

    // Connected components of the coupling graph.
    vector<int> parent(numParticles);
    std::iota(parent.begin(), parent.end(), 0);
    for (const StiffnessBlock& b : blocks) {
        stiffParticle[b.i] = stiffParticle[b.j] = true;
        parent[findRoot(parent, b.i)] = findRoot(parent, b.j);
    }
    std::map<int, vector<int>> members;
    for (int i = 0; i < numParticles; ++i)
        if (masses[i] != 0.0)
            members[findRoot(parent, i)].push_back(i);
    vector<int> componentOf(numParticles, -1), indexInComponent(numParticles, -1);
    int modes = 0;
    for (auto& entry : members) {
        Component c;
        c.firstParticle = (int)particleList.size();
        c.numParticles = (int)entry.second.size();
        c.firstMode = modes;
        c.stiff = stiffParticle[entry.second[0]];
        c.isotropic = true;
        for (size_t k = 0; k < entry.second.size(); ++k) {
            componentOf[entry.second[k]] = (int)components.size();
            indexInComponent[entry.second[k]] = (int)k;
            particleList.push_back(entry.second[k]);
        }
        modes += 3 * c.numParticles;
        components.push_back(c);
    }
    // A component whose blocks are all multiples of the identity (bonds of zero length, isotropic tethers) has the
    // same n x n modes in x, y and z: decomposing those is 27x cheaper and applying them 3x cheaper.
    double largestEntry = 0;
    for (const StiffnessBlock& b : blocks)
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c)
                largestEntry = std::max(largestEntry, std::abs(b.k[r][c]));
    // Probing rounds K to about 1e-16 |q| / (probe step 1e-3 nm) relative, 1e-11 for particles 100 nm from the
    // origin: differences far below 1e-9 are rounding, not anisotropy.
    for (const StiffnessBlock& b : blocks) {
        const double tolerance = 1e-9 * largestEntry;
        bool isotropic = std::abs(b.k[0][0] - b.k[1][1]) <= tolerance && std::abs(b.k[0][0] - b.k[2][2]) <= tolerance;
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c)
                if (r != c && std::abs(b.k[r][c]) > tolerance)
                    isotropic = false;
        if (!isotropic && masses[b.i] != 0.0)
            components[componentOf[b.i]].isotropic = false;
    }
    size_t matrixSize = 0, scratchSize = 0;
    for (Component& c : components) {
        c.flow = smallFlow<false>(c.rows(), c.columns());
        c.noisyFlow = smallFlow<true>(c.rows(), c.columns());
        c.matrixOffset = matrixSize;
        const size_t size = c.isotropic ? c.numParticles : 3 * c.numParticles;
        matrixSize += size * size;
        // Only components without a compiled flow stage their state in scratch: two D x 4C blocks (positions,
        // velocities and two noise vectors, in particle and then in mode coordinates), 24 doubles per particle.
        c.scratchOffset = scratchSize;
        if (c.flow == nullptr)
            scratchSize += 24 * (size_t)c.numParticles;
    }
    eigenvectors.assign(matrixSize, 0.0);
    omega.assign(modes, 0.0);
    modeForce.assign(modes, 0.0);
    scratch.assign(scratchSize, 0.0);

    // Assemble each component's mass-weighted stiffness and diagonalize it.
    vector<Eigen::MatrixXd> omegaSquared(components.size());
    for (size_t c = 0; c < components.size(); ++c) {
        const int size = (components[c].isotropic ? 1 : 3) * components[c].numParticles;
        omegaSquared[c] = Eigen::MatrixXd::Zero(size, size);
    }
    for (const StiffnessBlock& b : blocks) {
        if (masses[b.i] == 0.0 || masses[b.j] == 0.0)
            throw OpenMMException("StochasticImpulseIntegrator: the stiff forces act on a massless particle (" +
                                  std::to_string(masses[b.i] == 0.0 ? b.i : b.j) +
                                  "); stiff particles must have mass > 0");
        Eigen::MatrixXd& m = omegaSquared[componentOf[b.i]];
        const double scale = 1.0 / (sqrtMass[b.i] * sqrtMass[b.j]);
        if (components[componentOf[b.i]].isotropic) {
            m(indexInComponent[b.i], indexInComponent[b.j]) = b.k[0][0] * scale;
            m(indexInComponent[b.j], indexInComponent[b.i]) = b.k[0][0] * scale;
            continue;
        }
        const int ri = 3 * indexInComponent[b.i], rj = 3 * indexInComponent[b.j];
        for (int r = 0; r < 3; ++r)
            for (int s = 0; s < 3; ++s) {
                m(ri + r, rj + s) = b.k[r][s] * scale;
                m(rj + s, ri + r) = b.k[r][s] * scale;
            }
    }
    for (size_t c = 0; c < components.size(); ++c) {
        const Component& comp = components[c];
        // Isotropic components: n modes, each in x, y and z (mode 3j+d is mode j in direction d).
        const int size = (comp.isotropic ? 1 : 3) * comp.numParticles, copies = comp.isotropic ? 3 : 1;
        Eigen::Map<Eigen::MatrixXd> u(&eigenvectors[comp.matrixOffset], size, size);
        if (!comp.stiff) {
            u.setIdentity();
        } else {
            Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> solver(omegaSquared[c]);
            const Eigen::VectorXd& values = solver.eigenvalues();
            const double largest = std::max(std::abs(values.minCoeff()), std::abs(values.maxCoeff()));
            for (int k = 0; k < size; ++k) {
                // Zero modes (translations, rotations of a free molecule) come out as rounding noise.
                if (values[k] < -1e-9 * largest)
                    throw OpenMMException(
                        "StochasticImpulseIntegrator: the stiff potential has negative curvature (a mass-weighted "
                        "stiffness eigenvalue omega^2 = " +
                        formatNumber(values[k]) + " ps^-2 in the component containing particle " +
                        std::to_string(particleList[comp.firstParticle]) +
                        "); the stiff force groups must form a convex quadratic potential");
                for (int d = 0; d < copies; ++d)
                    omega[comp.firstMode + copies * k + d] = values[k] > 1e-9 * largest ? std::sqrt(values[k]) : 0.0;
            }
            u = solver.eigenvectors();
        }
        // The constant force in mode coordinates, U^T M^-1/2 b.
        Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> force(size, copies);
        for (int p = 0; p < comp.numParticles; ++p) {
            const int particle = particleList[comp.firstParticle + p];
            for (int d = 0; d < 3; ++d)
                force(comp.isotropic ? p : 3 * p + d, comp.isotropic ? d : 0) =
                    constantForce[particle][d] / sqrtMass[particle];
        }
        Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
            &modeForce[comp.firstMode], size, copies) = u.transpose() * force;
    }
}

vector<double> StiffModes::getStiffFrequencies() const {
    vector<double> result;
    for (const Component& c : components)
        if (c.stiff)
            result.insert(result.end(), omega.begin() + c.firstMode, omega.begin() + c.firstMode + 3 * c.numParticles);
    std::sort(result.begin(), result.end());
    return result;
}

void StiffModes::computePropagator(double h, double gamma, double kT, Propagator& propagator) const {
    propagator.noisy = (gamma > 0.0 && kT > 0.0);
    const bool noisy = propagator.noisy;
    propagator.offset.resize(components.size());
    size_t size = 0;
    for (size_t c = 0; c < components.size(); ++c) {
        const Component& comp = components[c];
        propagator.offset[c] = size;
        const size_t D = comp.rows(), C = comp.columns();
        size += comp.flow != nullptr ? PropagatorLayout{D, C}.size(noisy) : ModeLayout{D, C}.size(noisy);
    }
    propagator.data.assign(size, 0.0);
    const double thermalScale = noisy ? std::sqrt(kT) : 0.0;
    for (size_t c = 0; c < components.size(); ++c) {
        const Component& comp = components[c];
        const int D = comp.rows(), C = comp.columns();
        vector<ModeFlow> flows(D);
        for (int k = 0; k < D; ++k)
            flows[k] = modeFlow(omega[comp.firstMode + C * k], gamma, h);
        double* out = &propagator.data[propagator.offset[c]];
        auto modeForceOf = [&](int k, int col) { return modeForce[comp.firstMode + C * k + col]; };
        if (comp.flow == nullptr) {
            const ModeLayout layout{(size_t)D, (size_t)C};
            for (int k = 0; k < D; ++k) {
                const ModeFlow& f = flows[k];
                double* entries = out + layout.perMode(noisy) * k;
                const double values[] = {
                    f.xx, f.xv, f.vx, f.vv, thermalScale * f.lxx, thermalScale * f.lvx, thermalScale * f.lvv};
                std::copy(values, values + layout.perMode(noisy), entries);
                for (int col = 0; col < C; ++col) {
                    out[layout.gx(noisy) + k * C + col] = f.gx * modeForceOf(k, col);
                    out[layout.gv(noisy) + k * C + col] = f.gv * modeForceOf(k, col);
                }
            }
            continue;
        }
        const PropagatorLayout layout{(size_t)D, (size_t)C};
        // Row i of a component holds particle coordinates of particle particleList[firstParticle + i / (3 / C)].
        auto sqrtMassOfRow = [&](int i) { return sqrtMass[particleList[comp.firstParticle + (C == 3 ? i : i / 3)]]; };
        Eigen::Map<const Eigen::MatrixXd> u(&eigenvectors[comp.matrixOffset], D, D);
        const double ModeFlow::*entries[] = {&ModeFlow::xx,  &ModeFlow::xv,  &ModeFlow::vx, &ModeFlow::vv,
                                             &ModeFlow::lxx, &ModeFlow::lvx, &ModeFlow::lvv};
        for (int m = Axx; m <= (noisy ? Nvv : Avv); ++m) {
            Eigen::VectorXd diagonal(D);
            for (int k = 0; k < D; ++k)
                diagonal[k] = flows[k].*entries[m];
            // U f U^T acts on mass-weighted coordinates; in particle coordinates it is S^-1 U f U^T S (the noise, drawn
            // per particle coordinate, is S^-1 U L U^T xi).
            Eigen::MatrixXd product = u * diagonal.asDiagonal() * u.transpose();
            const bool noise = (m >= Nxx);
            double* matrix = out + layout.matrix((Matrix)m);
            for (int i = 0; i < D; ++i)
                for (int j = 0; j < D; ++j)
                    matrix[i * D + j] = product(i, j) / sqrtMassOfRow(i) * (noise ? thermalScale : sqrtMassOfRow(j));
        }
        // The response to the constant force, U (g_k F_k) in mass-weighted coordinates.
        double *gx = out + layout.gx(), *gv = out + layout.gv();
        for (int k = 0; k < D; ++k)
            for (int col = 0; col < C; ++col)
                for (int i = 0; i < D; ++i) {
                    gx[i * C + col] += u(i, k) * flows[k].gx * modeForceOf(k, col) / sqrtMassOfRow(i);
                    gv[i * C + col] += u(i, k) * flows[k].gv * modeForceOf(k, col) / sqrtMassOfRow(i);
                }
    }
}

void StiffModes::Flow::apply(int begin, int end) const {
    const bool noisy = propagator->noisy;
    for (int c = begin; c < end; ++c) {
        const Component& comp = modes.components[c];
        const double* m = &propagator->data[propagator->offset[c]];
        const int* particles = &modes.particleList[comp.firstParticle];
        const SmallFlow small = (noisy ? comp.noisyFlow : comp.flow);
        if (small != nullptr)
            small(particles, m, *this);
        else
            applyLarge(c, m);
    }
}

void StiffModes::Flow::applyLarge(int component, const double* m) const {
    const Component& comp = modes.components[component];
    const bool noisy = propagator->noisy;
    const int D = comp.rows(), C = comp.columns(), width = (noisy ? 4 : 2) * C;
    // Two D x width blocks in this component's slice of scratch.  Row r of the first holds, for the particle
    // coordinates of row r, S q, S v (S: square roots of the masses) and the two noise vectors, C columns each; a
    // particle's 3 coordinates are the 3 columns of one row (isotropic) or one column of 3 rows.
    double* particleSpace = &modes.scratch[comp.scratchOffset];
    double* modeSpace = particleSpace + (size_t)D * width;
    for (int p = 0; p < comp.numParticles; ++p) {
        const int particle = modes.particleList[comp.firstParticle + p];
        double q[3], v[3], xi1[3], xi2[3];
        readParticle(*this, particle, noisy, q, v, xi1, xi2);
        const double s = modes.sqrtMass[particle];
        for (int d = 0; d < 3; ++d) {
            double* row = particleSpace + (C == 3 ? p * width + d : (3 * p + d) * width);
            row[0] = s * q[d];
            row[C] = s * v[d];
            if (noisy) {
                row[2 * C] = xi1[d];
                row[3 * C] = xi2[d];
            }
        }
    }
    const double* u = &modes.eigenvectors[comp.matrixOffset];
    toModesOfWidth<2, 4, 6, 12>(width, D, u, particleSpace, modeSpace);
    // Each mode's exact 2 x 2 flow and noise; the result (q then v, C columns each) goes to the first block.
    const ModeLayout layout{(size_t)D, (size_t)C};
    const double *gx = m + layout.gx(noisy), *gv = m + layout.gv(noisy);
    for (int k = 0; k < D; ++k) {
        const double* f = m + layout.perMode(noisy) * k;
        const double* in = modeSpace + (size_t)k * width;
        double* out = particleSpace + (size_t)k * 2 * C;
        for (int col = 0; col < C; ++col) {
            const double x = in[col], v = in[C + col];
            double newX = f[0] * x + f[1] * v + gx[k * C + col];
            double newV = f[2] * x + f[3] * v + gv[k * C + col];
            if (noisy) {
                newX += f[4] * in[2 * C + col];
                newV += f[5] * in[2 * C + col] + f[6] * in[3 * C + col];
            }
            out[col] = newX;
            out[C + col] = newV;
        }
    }
    if (C == 3)
        fromModes<6>(D, u, particleSpace, modeSpace);
    else
        fromModes<2>(D, u, particleSpace, modeSpace);
    for (int p = 0; p < comp.numParticles; ++p) {
        const int particle = modes.particleList[comp.firstParticle + p];
        const double inverse = 1.0 / modes.sqrtMass[particle];
        for (int d = 0; d < 3; ++d) {
            const double* row = modeSpace + (C == 3 ? p * 2 * C + d : (3 * p + d) * 2 * C);
            positions[particle][d] = inverse * row[0];
            velocities[particle][d] = inverse * row[C];
        }
    }
}
