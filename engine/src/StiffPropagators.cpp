#include "StiffModes.h"
#include "internal/ExactModeFlow.h"
#include <Eigen/Dense>
#include <algorithm>

using namespace FlavorPlugin;
using std::vector;

namespace {

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

/**
 * The flow of one mode over a step h as computePropagator describes it: the exact flow, or for h > 0 the Middle free
 * flow of a zero mode or the warped flow of a stiff mode (constant force scaled so that its equilibrium stays).
 */
ModeFlow stepFlow(double omega, double gamma, double stiffGamma, double h, bool warped, bool middleZeroModes,
                  const WarpedFlowSettings& warp) {
    if (middleZeroModes && omega == 0.0 && h > 0.0)
        return computeMiddleFreeFlow(gamma, h);
    if (warped && omega > 0.0 && h > 0.0) {
        const WarpedMode mode = warpedMode(omega, stiffGamma, h, warp);
        const double scale = std::pow(mode.flowOmega / omega, 2);
        ModeFlow f = computeModeFlow(mode.flowOmega, mode.gamma, h);
        f.gx *= scale;
        f.gv *= scale;
        return f;
    }
    return modeFlow(omega, omega > 0.0 ? stiffGamma : gamma, h);
}

} // namespace

void StiffModes::computePropagator(double h, double gamma, double kT, double stiffGamma, double stiffKT,
                                   Propagator& propagator, bool warped, bool middleZeroModes,
                                   const WarpedFlowSettings& warp) const {
    bool hasStiffModes = false;
    for (const Component& comp : components)
        hasStiffModes = hasStiffModes || comp.stiff;
    propagator.noisy = (gamma > 0.0 && kT > 0.0) || (hasStiffModes && stiffGamma > 0.0 && stiffKT > 0.0);
    const bool noisy = propagator.noisy;
    propagator.offset.resize(components.size());
    size_t size = 0;
    for (size_t c = 0; c < components.size(); ++c) {
        const Component& comp = components[c];
        propagator.offset[c] = size;
        const size_t D = comp.rows(), C = comp.columns();
        size += hasParticleSpacePropagator((int)D, (int)C) ? PropagatorLayout{D, C}.size(noisy)
                                                           : ModeLayout{D, C}.size(noisy);
    }
    propagator.data.assign(size, 0.0);
    const double thermalScale = noisy ? std::sqrt(kT) : 0.0, stiffThermalScale = noisy ? std::sqrt(stiffKT) : 0.0;
    for (size_t c = 0; c < components.size(); ++c) {
        const Component& comp = components[c];
        const int D = comp.rows(), C = comp.columns();
        vector<ModeFlow> flows(D);
        // The noise factor sqrt(kT) of each mode's bath, folded into its Cholesky factor.
        vector<double> modeThermalScale(D);
        for (int k = 0; k < D; ++k) {
            const double w = omega[comp.firstMode + C * k];
            flows[k] = stepFlow(w, gamma, stiffGamma, h, warped, middleZeroModes, warp);
            modeThermalScale[k] = w > 0.0 ? stiffThermalScale : thermalScale;
        }
        double* out = &propagator.data[propagator.offset[c]];
        auto modeForceOf = [&](int k, int col) { return modeForce[comp.firstMode + C * k + col]; };
        if (!hasParticleSpacePropagator(D, C)) {
            const ModeLayout layout{(size_t)D, (size_t)C};
            for (int k = 0; k < D; ++k) {
                const ModeFlow& f = flows[k];
                double* entries = out + layout.perMode(noisy) * k;
                const double scale = modeThermalScale[k];
                const double values[] = {f.xx, f.xv, f.vx, f.vv, scale * f.lxx, scale * f.lvx, scale * f.lvv};
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
            const bool noise = (m >= Nxx);
            Eigen::VectorXd diagonal(D);
            for (int k = 0; k < D; ++k)
                diagonal[k] = flows[k].*entries[m] * (noise ? modeThermalScale[k] : 1.0);
            // U f U^T acts on mass-weighted coordinates; in particle coordinates it is S^-1 U f U^T S (the noise, drawn
            // per particle coordinate, is S^-1 U L U^T xi).
            Eigen::MatrixXd product = u * diagonal.asDiagonal() * u.transpose();
            double* matrix = out + layout.matrix((PropagatorMatrix)m);
            for (int i = 0; i < D; ++i)
                for (int j = 0; j < D; ++j)
                    matrix[i * D + j] = product(i, j) / sqrtMassOfRow(i) * (noise ? 1.0 : sqrtMassOfRow(j));
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

namespace {

// Modes whose flow turns by more than this per step keep unprocessed velocities (lambda and beta have poles at k pi).
constexpr double ProcessingLimit = 0.9 * M_PI;

/** The kicks of one stiff mode in a Filtered step of length h (see StiffModes::computeForceResponse). */
struct FilteredModeKicks {
    ModeFlow flow;
    /** kappa h/2: each half kick of the unprocessed step. */
    double halfKick;
    /** The constant-force velocity lambda f and the ramp processing beta of the step's end velocity. */
    double lambda, beta;
};

FilteredModeKicks filteredModeKicks(double w, double gamma, double h, SubFlow::KickResponse kickResponse,
                                    const WarpedFlowSettings& warp) {
    FilteredModeKicks kicks;
    // Plain kicks go with the warped flow, which has the exact static response.
    const bool warped = kickResponse == SubFlow::KickResponse::Plain;
    const WarpedMode mode = warped ? warpedMode(w, gamma, h, warp) : WarpedMode{w, w, gamma};
    const double flowW = mode.flowOmega;
    const bool plain = warped && flowW == mode.warpedOmega;
    const ModeFlow& f = kicks.flow = computeModeFlow(flowW, mode.gamma, h);
    // kappa makes the constant-force fixed point of K(kappa h/2) E(h) K(kappa h/2) the exact mean f/omega^2 (with
    // g, the flow's own constant-force response, scaled to the true potential's minimum where the flow is slowed);
    // the warped flow has it with plain kicks.
    const double scale = std::pow(flowW / w, 2);
    const double a = kicks.halfKick = plain ? 0.5 * h : 0.5 * scale * ((1.0 - f.vv) * f.gx / f.xv + f.gv);
    kicks.lambda = kicks.beta = 0.0;
    if (flowW * h >= ProcessingLimit)
        return kicks;
    // With friction the fixed point's velocity at the step's end is lambda f, not 0 (the velocity row of the fixed
    // point).
    kicks.lambda = (f.vx / (w * w) + a * (1.0 + f.vv)) / (1.0 - f.vv);
    // Under a force f_n = n h (unit slope), with lambda f removed, the step's end velocity is a constant C (the
    // particular solution y_n = A + B n); the true one is 1/omega^2.  beta removes the difference per unit change of
    // the force over the step.
    const double slope = f.xv * (kicks.lambda + a) * h / (1.0 - f.xx);
    const double rhsA = -slope, rhsC = (a - kicks.lambda) * h;
    // (1 - Phi_xx) A - Phi_xv C = -B;  -Phi_vx A + (1 - Phi_vv) C = (a - lambda) h.
    const double det = (1.0 - f.xx) * (1.0 - f.vv) - f.xv * f.vx;
    const double C = ((1.0 - f.xx) * rhsC + f.vx * rhsA) / det;
    kicks.beta = (C - 1.0 / (w * w)) / h;
    return kicks;
}

} // namespace

void StiffModes::fillModeResponses(ForceResponse& response,
                                   const std::function<void(double omega, double* out)>& modeResponse) const {
    response.offset.resize(components.size());
    size_t size = 0;
    for (size_t c = 0; c < components.size(); ++c) {
        response.offset[c] = size;
        size += 2 * (size_t)components[c].rows();
    }
    response.data.assign(size, 0.0);
    for (size_t c = 0; c < components.size(); ++c) {
        const Component& comp = components[c];
        for (int k = 0; k < comp.rows(); ++k)
            modeResponse(omega[comp.firstMode + comp.columns() * k], &response.data[response.offset[c] + 2 * k]);
    }
}

void StiffModes::computeForceResponse(double h, double gamma, double stiffGamma, bool closing,
                                      SubFlow::KickResponse kickResponse, const WarpedFlowSettings& warp,
                                      bool middleZeroModes, ForceResponse& response) const {
    fillModeResponses(response, [&](double w, double* out) {
        if (w > 0.0) {
            // Half kicks scaled by kappa; the closing one less the processing lambda f, which the opening one of the
            // next step puts back.
            const FilteredModeKicks kicks = filteredModeKicks(w, stiffGamma, h, kickResponse, warp);
            const double opening = kicks.halfKick + kicks.lambda;
            out[0] = closing ? 0.0 : opening * kicks.flow.xv;
            out[1] = closing ? kicks.halfKick - kicks.lambda : opening * kicks.flow.vv;
        } else if (middleZeroModes) {
            // Both half kicks at the opening, as the image of the Middle free flow: half-step velocities at the end.
            const ModeFlow f = computeMiddleFreeFlow(gamma, h);
            out[0] = closing ? 0.0 : h * f.xv;
            out[1] = closing ? 0.0 : h * f.vv;
        } else {
            const ModeFlow f = computeModeFlow(w, gamma, h);
            out[0] = closing ? 0.0 : 0.5 * h * f.xv;
            out[1] = closing ? 0.5 * h : 0.5 * h * f.vv;
        }
    });
}

void StiffModes::computeVelocityProcessing(double h, double stiffGamma, bool closing,
                                           SubFlow::KickResponse kickResponse, const WarpedFlowSettings& warp,
                                           ForceResponse& response) const {
    fillModeResponses(response, [&](double w, double* out) {
        if (!(w > 0.0))
            return;
        const FilteredModeKicks kicks = filteredModeKicks(w, stiffGamma, h, kickResponse, warp);
        out[0] = closing ? 0.0 : kicks.beta * kicks.flow.xv;
        out[1] = closing ? -kicks.beta : kicks.beta * kicks.flow.vv;
    });
}

void StiffModes::computeImpulseResponse(double h, double gamma, double stiffGamma, bool warped, bool middleZeroModes,
                                        const WarpedFlowSettings& warp, bool filtered,
                                        SubFlow::KickResponse kickResponse, ImpulseResponse& response) const {
    const int perMode = ImpulseResponse::NumBlocks;
    response.offset.resize(components.size());
    size_t size = 0;
    for (size_t c = 0; c < components.size(); ++c) {
        response.offset[c] = size;
        size += perMode * (size_t)components[c].rows();
    }
    response.data.assign(size, 0.0);
    for (size_t c = 0; c < components.size(); ++c) {
        const Component& comp = components[c];
        for (int k = 0; k < comp.rows(); ++k) {
            const double w = omega[comp.firstMode + comp.columns() * k];
            const ModeFlow f = stepFlow(w, gamma, stiffGamma, h, warped, middleZeroModes, warp);
            // Per unit impulse: with exact zero modes the constraint force gives h/2 times it at each end, which the
            // stiff modes take as the opening and the closing half kick (lambda moved from the closing to the
            // opening one as computeForceResponse moves it); with Middle zero modes h times it at the start.
            double opening = 1.0, closing = 1.0, processing = 0.0;
            if (filtered && w > 0.0) {
                const FilteredModeKicks kicks = filteredModeKicks(w, stiffGamma, h, kickResponse, warp);
                const double kappa = kicks.halfKick / (0.5 * h);
                opening = middleZeroModes ? kappa : (kicks.halfKick + kicks.lambda) / (0.5 * h);
                closing = middleZeroModes ? kappa : (kicks.halfKick - kicks.lambda) / (0.5 * h);
                processing = middleZeroModes ? (kicks.halfKick - kicks.lambda) / h : 0.0;
            }
            double* out = &response.data[response.offset[c] + perMode * k];
            out[ImpulseResponse::ThroughX] = opening * f.xv;
            out[ImpulseResponse::ThroughV] = opening * f.vv;
            out[ImpulseResponse::AtEnd] = closing;
            out[ImpulseResponse::Processing] = processing;
        }
    }
}

void StiffModes::getImpulseBlocks(const ImpulseResponse& response, int c, int target, int source,
                                  double blocks[ImpulseResponse::NumBlocks][3][3]) const {
    const int perMode = ImpulseResponse::NumBlocks;
    const Component& comp = components[c];
    const int D = comp.rows(), C = comp.columns();
    const double* u = getEigenvectors(c);
    const double* modeValues = &response.data[response.offset[c]];
    const int* particles = getComponentParticles(c);
    // In particle coordinates a mode-diagonal map is S^-1 U f U^T S, S the square roots of the masses; row i of an
    // isotropic component is a particle, of another one a particle coordinate.
    const double massRatio = sqrtMass[particles[source]] / sqrtMass[particles[target]];
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) {
            for (int m = 0; m < perMode; ++m)
                blocks[m][a][b] = 0.0;
            if (C == 3 && a != b)
                continue;
            const int i = C == 3 ? target : 3 * target + a, j = C == 3 ? source : 3 * source + b;
            for (int k = 0; k < D; ++k) {
                const double weight = u[k * D + i] * u[k * D + j] * massRatio;
                for (int m = 0; m < perMode; ++m)
                    blocks[m][a][b] += weight * modeValues[perMode * k + m];
            }
        }
}

void StiffModes::computeFlowPropagator(const SubFlow& flow, Propagator& propagator) const {
    if (flow.kind == SubFlow::HarmonicFlow) {
        computePropagator(flow.h, flow.bath.friction, flow.bath.kT, flow.stiffBath.friction, flow.stiffBath.kT,
                          propagator);
        return;
    }
    const bool middleFlow = flow.zeroModes == SubFlow::ZeroModeFlow::Middle && flow.h > 0;
    computePropagator(flow.h, flow.bath.friction, flow.bath.kT, flow.stiffBath.friction, flow.stiffBath.kT, propagator,
                      flow.frequency == SubFlow::StiffFrequency::Warped, middleFlow, flow.warp);
}

void StiffModes::computeFlowResponses(const SubFlow& flow, ForceResponse& response, ForceResponse& processing) const {
    const bool closing = flow.kind == SubFlow::FilteredKick;
    computeForceResponse(flow.h, flow.bath.friction, flow.stiffBath.friction, closing, flow.response, flow.warp,
                         flow.zeroModes == SubFlow::ZeroModeFlow::Middle, response);
    computeVelocityProcessing(flow.h, flow.stiffBath.friction, closing, flow.response, flow.warp, processing);
}
