#include "StiffFlowTask.h"
#include <algorithm>
#include <array>

using namespace FlavorPlugin;
using namespace OpenMM;

namespace {

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
inline void readParticle(const StiffFlowTask& flow, int particle, bool noisy, double* q, double* v, double* xi1,
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
template <int D, int C, bool Noisy> void applySmall(const int* particles, const double* m, const StiffFlowTask& flow) {
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

typedef StiffFlowTask::ComponentFlow ComponentFlow;

/** The compiled flow for a component of D rows and C columns, or nullptr when it is too large for one. */
template <bool Noisy> ComponentFlow compiledFlow(int D, int C) {
    if (!StiffModes::hasParticleSpacePropagator(D, C))
        return nullptr;
    if (C == 1)
        return D == 3 ? &applySmall<3, 1, Noisy> : &applySmall<6, 1, Noisy>;
    static_assert(StiffModes::MaxIsotropicRows == 6, "one compiled flow per isotropic size");
    switch (D) {
    case 1:
        return &applySmall<1, 3, Noisy>;
    case 2:
        return &applySmall<2, 3, Noisy>;
    case 3:
        return &applySmall<3, 3, Noisy>;
    case 4:
        return &applySmall<4, 3, Noisy>;
    case 5:
        return &applySmall<5, 3, Noisy>;
    default:
        return &applySmall<6, 3, Noisy>;
    }
}

} // namespace

StiffFlowTask::StiffFlowTask(const StiffModes& modes) : modes(modes) {
    const int numComponents = modes.getNumComponents();
    flows.resize(numComponents);
    noisyFlows.resize(numComponents);
    scratchOffset.resize(numComponents);
    size_t scratchSize = 0;
    for (int c = 0; c < numComponents; ++c) {
        const StiffModes::Component& comp = modes.getComponent(c);
        flows[c] = compiledFlow<false>(comp.rows(), comp.columns());
        noisyFlows[c] = compiledFlow<true>(comp.rows(), comp.columns());
        // Large components stage their state in scratch: two D x 4C blocks (positions, velocities and two noise
        // vectors, in particle and then in mode coordinates), 24 doubles per particle.
        scratchOffset[c] = scratchSize;
        if (flows[c] == nullptr)
            scratchSize += 24 * (size_t)comp.numParticles;
    }
    scratch.assign(scratchSize, 0.0);
}

void StiffFlowTask::apply(int begin, int end) const {
    const bool noisy = propagator->noisy;
    for (int c = begin; c < end; ++c) {
        const double* m = &propagator->data[propagator->offset[c]];
        const ComponentFlow small = (noisy ? noisyFlows[c] : flows[c]);
        if (small != nullptr)
            small(modes.getComponentParticles(c), m, *this);
        else
            applyLarge(c, m);
    }
}

void StiffFlowTask::applyLarge(int component, const double* m) const {
    const StiffModes::Component& comp = modes.getComponent(component);
    const int* particles = modes.getComponentParticles(component);
    const bool noisy = propagator->noisy;
    const int D = comp.rows(), C = comp.columns(), width = (noisy ? 4 : 2) * C;
    // Two D x width blocks in this component's slice of scratch.  Row r of the first holds, for the particle
    // coordinates of row r, S q, S v (S: square roots of the masses) and the two noise vectors, C columns each; a
    // particle's 3 coordinates are the 3 columns of one row (isotropic) or one column of 3 rows.
    double* particleSpace = &scratch[scratchOffset[component]];
    double* modeSpace = particleSpace + (size_t)D * width;
    for (int p = 0; p < comp.numParticles; ++p) {
        const int particle = particles[p];
        double q[3], v[3], xi1[3], xi2[3];
        readParticle(*this, particle, noisy, q, v, xi1, xi2);
        const double s = modes.getSqrtMass(particle);
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
    const double* u = modes.getEigenvectors(component);
    switch (width) {
    case 2:
        toModes<2>(D, u, particleSpace, modeSpace);
        break;
    case 4:
        toModes<4>(D, u, particleSpace, modeSpace);
        break;
    case 6:
        toModes<6>(D, u, particleSpace, modeSpace);
        break;
    default:
        toModes<12>(D, u, particleSpace, modeSpace);
        break;
    }
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
        const int particle = particles[p];
        const double inverse = 1.0 / modes.getSqrtMass(particle);
        for (int d = 0; d < 3; ++d) {
            const double* row = modeSpace + (C == 3 ? p * 2 * C + d : (3 * p + d) * 2 * C);
            positions[particle][d] = inverse * row[0];
            velocities[particle][d] = inverse * row[C];
        }
    }
}

ForceResponseTask::ForceResponseTask(const StiffModes& modes) : modes(modes) {
    scratchOffset.resize(modes.getNumComponents());
    size_t size = 0;
    for (int c = 0; c < modes.getNumComponents(); ++c) {
        scratchOffset[c] = size;
        size += 6 * 3 * (size_t)modes.getComponent(c).numParticles;
    }
    scratch.assign(size, 0.0);
}

void ForceResponseTask::apply(int begin, int end) const {
    for (int c = begin; c < end; ++c) {
        const StiffModes::Component& comp = modes.getComponent(c);
        const int D = comp.rows(), C = comp.columns();
        const double* r = &response->data[response->offset[c]];
        const bool processed = processing != nullptr && comp.stiff;
        const double* q = processed ? &processing->data[processing->offset[c]] : nullptr;
        // Single particles and pairs (Drude pairs), isotropic, through the same code with their sizes known to the
        // compiler.
        if (D == 1 && C == 3)
            applyComponent<1, 3>(c, r, q);
        else if (D == 2 && C == 3)
            applyComponent<2, 3>(c, r, q);
        else
            applyComponent<0, 0>(c, r, q);
    }
}

template <int FixedRows, int FixedColumns>
void ForceResponseTask::applyComponent(int c, const double* r, const double* q) const {
    const StiffModes::Component& comp = modes.getComponent(c);
    const int* particles = modes.getComponentParticles(c);
    const int D = FixedRows > 0 ? FixedRows : comp.rows(), C = FixedColumns > 0 ? FixedColumns : comp.columns();
    const int size = D * C;
    const int numParticles = FixedRows > 0 && FixedColumns == 3 ? FixedRows : comp.numParticles;
    const bool processed = q != nullptr;
    const double* u = modes.getEigenvectors(c);
    // Fixed sizes work on the stack, where the compiler can keep the blocks in registers.
    double local[FixedRows > 0 ? 6 * FixedRows * FixedColumns : 1];
    double* particleForce = FixedRows > 0 ? local : &scratch[scratchOffset[c]];
    double* modeForce = particleForce + size;
    double* dx = modeForce + size;
    double* dv = dx + size;
    double* particleChange = dv + size;
    double* modeChange = particleChange + size;
    // Row i, column col of a row-major D x C block holds coordinate d of particle p (isotropic: row p, column d;
    // else row 3 p + d, one column), as in StiffFlowTask: in both layouts element 3 p + d.
    for (int p = 0; p < numParticles; ++p) {
        const int particle = particles[p];
        const double scale = 1.0 / modes.getSqrtMass(particle);
        const OpenMM::Vec3& force = forces[particle];
        OpenMM::Vec3 change;
        if (processed && closing) {
            change = forceChanges[particle] = forces[particle] - openingForces[particle];
        } else if (processed) {
            change = forceChanges[particle];
            openingForces[particle] = forces[particle];
        }
        for (int d = 0; d < 3; ++d) {
            particleForce[3 * p + d] = scale * force[d];
            particleChange[3 * p + d] = scale * change[d];
        }
    }
    for (int k = 0; k < D; ++k)
        for (int col = 0; col < C; ++col) {
            double sum = 0, sumChange = 0;
            for (int i = 0; i < D; ++i) {
                sum += u[(size_t)k * D + i] * particleForce[i * C + col];
                sumChange += u[(size_t)k * D + i] * particleChange[i * C + col];
            }
            modeForce[k * C + col] = sum;
            modeChange[k * C + col] = sumChange;
        }
    for (int i = 0; i < D; ++i)
        for (int col = 0; col < C; ++col) {
            double sx = 0, sv = 0;
            for (int k = 0; k < D; ++k) {
                const double projected = u[(size_t)k * D + i] * modeForce[k * C + col];
                sx += r[2 * k] * projected;
                sv += r[2 * k + 1] * projected;
                if (processed) {
                    const double projectedChange = u[(size_t)k * D + i] * modeChange[k * C + col];
                    sx += q[2 * k] * projectedChange;
                    sv += q[2 * k + 1] * projectedChange;
                }
            }
            dx[i * C + col] = sx;
            dv[i * C + col] = sv;
        }
    for (int p = 0; p < numParticles; ++p) {
        const double scale = 1.0 / modes.getSqrtMass(particles[p]);
        for (int d = 0; d < 3; ++d) {
            positions[particles[p]][d] += scale * dx[3 * p + d];
            velocities[particles[p]][d] += scale * dv[3 * p + d];
        }
    }
}
