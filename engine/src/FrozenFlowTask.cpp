#include "FrozenFlowTask.h"

using namespace FlavorPlugin;
using namespace OpenMM;

FrozenFlowTask::FrozenFlowTask(const StiffModes& modes) : modes(modes) {
    const int numComponents = modes.getNumComponents();
    firstZeroMode.resize(numComponents);
    numZeroModes.resize(numComponents);
    scratchOffset.resize(numComponents);
    std::size_t scratchSize = 0;
    for (int c = 0; c < numComponents; ++c) {
        const StiffModes::Component& comp = modes.getComponent(c);
        firstZeroMode[c] = (int)zeroModes.size();
        scratchOffset[c] = scratchSize;
        if (!comp.stiff)
            continue;
        // A mode's frequency is the same in every column, so column 0 decides.
        for (int k = 0; k < comp.rows(); ++k)
            if (modes.getModeFrequency(comp.firstMode + comp.columns() * k) == 0.0)
                zeroModes.push_back(k);
        numZeroModes[c] = (int)zeroModes.size() - firstZeroMode[c];
        scratchSize += (std::size_t)numZeroModes[c] * comp.columns();
    }
    scratch.resize(scratchSize);
}

void FrozenFlowTask::apply(int begin, int end) const {
    for (int c = begin; c < end; ++c) {
        const StiffModes::Component& comp = modes.getComponent(c);
        if (comp.stiff) {
            applyStiff(c);
            continue;
        }
        // Every direction is a zero mode.
        const int* particles = modes.getComponentParticles(c);
        for (int n = 0; n < comp.numParticles; ++n) {
            const int i = particles[n];
            const double scale = sourceIsForce ? h / (modes.getSqrtMass(i) * modes.getSqrtMass(i)) : h;
            target[i] += source[i] * scale;
        }
    }
}

void FrozenFlowTask::applyStiff(int c) const {
    const StiffModes::Component& comp = modes.getComponent(c);
    const int* particles = modes.getComponentParticles(c);
    const double* U = modes.getEigenvectors(c);
    const int D = comp.rows(), C = comp.columns();
    const int* zero = &zeroModes[firstZeroMode[c]];
    const int numZero = numZeroModes[c];
    double* coefficient = &scratch[scratchOffset[c]];
    // Row r of the D x C component state is particle r, coordinate col (isotropic), or particle r/3, coordinate r%3.
    auto element = [&](int r, int col, int& particle, int& coordinate) {
        particle = particles[C == 3 ? r : r / 3];
        coordinate = C == 3 ? col : r % 3;
    };
    // The mass-weighted source s = M^1/2 v or M^-1/2 F; coefficient (k, col) = U_k^T s.
    for (int z = 0; z < numZero; ++z) {
        const double* u = U + (std::size_t)zero[z] * D;
        for (int col = 0; col < C; ++col) {
            double sum = 0.0;
            for (int r = 0; r < D; ++r) {
                int i, d;
                element(r, col, i, d);
                const double sqrtMass = modes.getSqrtMass(i);
                sum += u[r] * (sourceIsForce ? source[i][d] / sqrtMass : source[i][d] * sqrtMass);
            }
            coefficient[z * C + col] = sum;
        }
    }
    // target += h M^-1/2 sum_k U_k coefficient_k.
    for (int r = 0; r < D; ++r)
        for (int col = 0; col < C; ++col) {
            double sum = 0.0;
            for (int z = 0; z < numZero; ++z)
                sum += U[(std::size_t)zero[z] * D + r] * coefficient[z * C + col];
            int i, d;
            element(r, col, i, d);
            target[i][d] += h * sum / modes.getSqrtMass(i);
        }
}
