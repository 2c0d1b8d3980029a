#ifndef OPENMM_FLAVORS_EXACT_MODE_FLOW_H_
#define OPENMM_FLAVORS_EXACT_MODE_FLOW_H_

#include <array>
#include <cmath>

namespace FlavorPlugin {

/**
 * Exact one-step propagator of one damped, forced harmonic mode.
 *
 * In mass-weighted coordinates the mode obeys dx = v dt, dv = (-omega^2 x + f - gamma v) dt + sqrt(2 gamma kT) dW.
 * Over a step h the solution is affine-Gaussian:
 *
 *     x' = xx x + xv v + gx f + sqrt(kT) lxx xi1
 *     v' = vx x + vv v + gv f + sqrt(kT) (lvx xi1 + lvv xi2)
 *
 * with xi1, xi2 independent standard normal variables.  L = [[lxx, 0], [lvx, lvv]] is a Cholesky factor of the noise
 * covariance for kT = 1.
 */
struct ModeFlow {
    /** The transition matrix Phi. */
    double xx, xv, vx, vv;
    /** The response to a unit constant force. */
    double gx, gv;
    /** The lower-triangular factor of the noise covariance for kT = 1. */
    double lxx, lvx, lvv;
};

namespace ModeFlowDetail {

/** Relative size below which a series term no longer changes the sum. */
constexpr double SeriesTolerance = 1e-17;

/** Below this omega*h and gamma*h/2 the force response and the position variance are summed as power series. */
constexpr double SmallStep = 0.1;

/** Above this gamma*h/2 the overdamped position variance uses closed forms instead of its positive series. */
constexpr double ModerateFriction = 4.0;

/**
 * e^-x sum_{j>=k} x^j/j!, the probability that a Poisson(x) variable is at least k, for k >= 1 and x >= 0.  These
 * tails are the remainders of exponential series that every closed form below is built from.
 */
inline double poissonTail(int k, double x) {
    if (!(x > 0))
        return 0.0;
    double pmf = std::exp(-x);
    if (x < k) {
        // Summing the tail itself keeps every term positive.
        for (int j = 1; j <= k; ++j)
            pmf *= x / j;
        double term = 1.0, sum = 1.0;
        for (int j = k + 1; term > SeriesTolerance * sum; ++j) {
            term *= x / j;
            sum += term;
        }
        return pmf * sum;
    }
    // Here the head is at most about one half, so subtracting it from one costs at most a bit or two.
    double head = pmf;
    for (int j = 1; j < k; ++j) {
        pmf *= x / j;
        head += pmf;
    }
    return 1.0 - head;
}

/** (1 - e^-x)/x for x >= 0. */
inline double psi1(double x) {
    return x == 0 ? 1.0 : -std::expm1(-x) / x;
}

/** 1 - psi1(x) = (x - 1 + e^-x)/x for x >= 0. */
inline double oneMinusPsi1(double x) {
    if (x >= 1)
        return 1.0 - psi1(x);
    double term = 0.5 * x, sum = term;
    for (int j = 1; std::abs(term) > SeriesTolerance * sum; ++j) {
        term *= -x / (j + 2);
        sum += term;
    }
    return sum;
}

/** cos(sqrt(z)), sin(sqrt(z))/sqrt(z) and their complements to one for z >= 0. */
struct Oscillation {
    double c, s, oneMinusC, oneMinusS;
};

inline Oscillation oscillation(double z) {
    Oscillation o;
    if (z <= 1) {
        // The complements are summed without their leading one so that they keep full relative accuracy.
        double termC = -0.5 * z, termS = -z / 6, sumC = termC, sumS = termS;
        for (int j = 2; j < 12; ++j) {
            termC *= -z / ((2 * j - 1) * (2 * j));
            termS *= -z / ((2 * j) * (2 * j + 1));
            sumC += termC;
            sumS += termS;
        }
        o.c = 1.0 + sumC;
        o.s = 1.0 + sumS;
        o.oneMinusC = -sumC;
        o.oneMinusS = -sumS;
    } else {
        const double theta = std::sqrt(z), halfSine = std::sin(0.5 * theta);
        o.c = std::cos(theta);
        o.s = std::sin(theta) / theta;
        o.oneMinusC = 2 * halfSine * halfSine;
        o.oneMinusS = 1.0 - o.s;
    }
    return o;
}

/**
 * Power series of the dimensionless force response gx/h^2 and position variance Sigma_xx/h^2 (kT = 1) for small
 * w = omega*h and b = gamma*h/2, where every closed form would divide small differences by w^2.  Returns {gx/h^2,
 * Sigma_xx/h^2}.
 */
inline std::array<double, 2> smallStepSeries(double w, double b) {
    // In units of h, the generator is M = [[0, 1], [-w^2, -2b]].  (c1, c2) runs through M^k e2 / k!, whose integral
    // over the unit step gives g; p through the Taylor coefficients of the covariance, which solves
    // P' = M P + P M^T + diag(0, 4b).  With w, b <= SmallStep the terms shrink at least like 2.5^k/k!.
    const double w2 = w * w;
    double c1 = 0.0, c2 = 1.0, gx = 0.0;
    double p11 = 0.0, p12 = 0.0, p22 = 4 * b, sxx = 0.0;
    for (int k = 1; k < 40; ++k) {
        const double n1 = c2 / k, n2 = -(w2 * c1 + 2 * b * c2) / k;
        c1 = n1;
        c2 = n2;
        gx += c1 / (k + 1);
        const double q11 = 2 * p12 / (k + 1), q12 = (p22 - w2 * p11 - 2 * b * p12) / (k + 1),
                     q22 = -2 * (w2 * p12 + 2 * b * p22) / (k + 1);
        p11 = q11;
        p12 = q12;
        p22 = q22;
        sxx += p11;
    }
    return {gx, sxx};
}

/**
 * Sum over k >= 1 of rho^(k-1) e^-x sum_{j>=2k+1} x^j/j!: the overdamped position variance times (gamma/2)^2, with
 * x = gamma h and rho = 1 - (2 omega/gamma)^2.  All terms are positive, so it is accurate where the closed forms
 * cancel.
 */
inline double overdampedPositionSeries(double x, double rho) {
    // Regrouped by j: sum_j pmf(j) (1 + rho + ... + rho^((j-3)/2)).
    double pmf = std::exp(-x), weight = 0.0, power = 1.0, sum = 0.0;
    for (int j = 1; j < 400; ++j) {
        pmf *= x / j;
        if (j >= 3 && (j & 1)) {
            weight += power;
            power *= rho;
        }
        const double term = pmf * weight;
        sum += term;
        if (j >= 3 && j > x && term <= SeriesTolerance * sum)
            break;
    }
    return sum;
}

/** A mode's flow together with the noise covariance (kT = 1) that its Cholesky factor was taken from. */
struct FlowAndCovariance {
    ModeFlow flow;
    double sxx, sxv, svv;
};

/** computeModeFlow, also returning the covariance itself. */
inline FlowAndCovariance flowAndCovariance(double omega, double gamma, double h) {
    const double w = omega * h, b = 0.5 * gamma * h;
    // z = (omega^2 - gamma^2/4) h^2, factored so that it has no cancellation near critical damping.
    const double z = (w - b) * (w + b);
    const bool small = w <= SmallStep && b <= SmallStep;
    const double omega2 = omega * omega;
    // q = xv/h.  Below, gx and Sigma are kept for kT = 1; their closed forms are rearranged into sums of non-negative
    // terms (tails of exponential series, 1 - cos, 1 - sinc, ...), since the textbook forms (I - Phi) x* and
    // Sigma_inf - Phi Sigma_inf Phi^T lose all digits for small omega*h or small h.
    double q, xx, vv, gx = 0, sxx = 0, svv;
    if (z >= 0) {
        // Underdamped or critical: Phi = e^-b [[C + b S, h S], [-omega^2 h S, C - b S]], C = cos(sqrt z),
        // S = sin(sqrt z)/sqrt z.
        const double e = std::exp(-b), e2 = std::exp(-2 * b);
        const Oscillation o = oscillation(z);
        q = e * o.s;
        xx = e * (o.c + b * o.s);
        vv = e * (o.c - b * o.s);
        // Sigma_vv = 1 - e^-2b (1 + 2 b^2 S^2 - 2 b C S) (using C^2 + z S^2 = 1), regrouped into terms that are
        // non-negative (1 + C S >= 0.78) for z >= 0.
        const double tail3 = poissonTail(3, 2 * b), decay = 2 * b * e2, oneMinusS2 = o.oneMinusS * (1 + o.s);
        svv = tail3 + decay * ((1 + o.c * o.s) + b * oneMinusS2);
        if (!small) {
            // With T_k = poissonTail(k, .) and C S = sin(2 sqrt z)/(2 sqrt z):
            //   gx       = [T_2(b) + e^-b (b (1 - S) + 1 - C)] / omega^2
            //   Sigma_xx = [T_3(2b) + 2b e^-2b ((1 - C S) + b (1 - S^2))] / omega^2
            // All terms are non-negative for z >= 0, and omega*h > SmallStep here, so the division is harmless.
            const Oscillation o4 = oscillation(4 * z);
            gx = (poissonTail(2, b) + e * (b * o.oneMinusS + o.oneMinusC)) / omega2;
            sxx = (tail3 + decay * (o4.oneMinusS + b * oneMinusS2)) / omega2;
        }
    } else {
        // Overdamped: rates (b -+ a)/h with a = sqrt(-z).  The slow exponent b - a = w^2/(a + b) is formed without
        // cancellation, and e^-b cosh a, e^-b sinh a are written with e^(a-b) and e^(-a-b) so that nothing overflows.
        const double a = std::sqrt(-z), u = w * w / (a + b);
        const double slow = std::exp(-u), ratio = std::exp(-2 * a), r = psi1(2 * a);
        q = slow * r;
        xx = slow * (0.5 * (1 + ratio) + b * r);
        // For large a the fast mode is gone and C - b S would cancel; (a + b) e^-2a - (b - a) keeps the digits.
        vv = a < 1 ? slow * (0.5 * (1 + ratio) - b * r) : slow * ((a + b) * ratio - u) / (2 * a);
        const double fullDecay = -std::expm1(-2 * b);
        svv = fullDecay + 2 * b * q * vv;
        if (!small) {
            // gx = (1 - xx)/omega^2 = h^2 [T2(u)/u + e^-u (1 - psi1(2a))]/(a + b): non-negative terms that tend to the
            // free particle's (gamma h - 1 + e^-gamma h)/gamma^2 as omega -> 0.
            const double tail2OverU = u == 0 ? 0.0 : poissonTail(2, u) / u;
            gx = h * h * (tail2OverU + slow * oneMinusPsi1(2 * a)) / (a + b);
            if (b <= ModerateFriction) {
                sxx = 4 / (gamma * gamma) * overdampedPositionSeries(2 * b, (a / b) * (a / b));
            } else {
                // Two exact forms that cancel in complementary places; use the one that cancels least.
                //   (1) Sigma_xx = (1 - e^-2b - 2 b q xx)/omega^2
                //   (2) Sigma_xx = (b h^2/a^2) [psi1(2u) - 2 psi1(2b) + psi1(2a + 2b)]
                const double t = 2 * b * q * xx;
                const double p0 = psi1(2 * u), p1 = psi1(2 * b), p2 = psi1(2 * a + 2 * b);
                const double second = p0 - 2 * p1 + p2;
                const double loss1 = fullDecay - t > 0 && w > 0 ? (fullDecay + t) / (fullDecay - t) : HUGE_VAL;
                const double loss2 = second > 0 ? (p0 + 2 * p1 + p2) / second : HUGE_VAL;
                if (loss1 <= loss2)
                    sxx = (fullDecay - t) / omega2;
                else
                    sxx = (h / a) * (h / a) * b * second;
            }
        }
    }
    if (small) {
        const std::array<double, 2> series = smallStepSeries(w, b);
        gx = h * h * series[0];
        sxx = h * h * series[1];
    }
    FlowAndCovariance result;
    ModeFlow& flow = result.flow;
    flow.xx = xx;
    flow.xv = h * q;
    flow.vx = -omega2 * flow.xv;
    flow.vv = vv;
    flow.gx = gx;
    // d(xv)/dt = vv, so the integral of vv over the step is xv itself.
    flow.gv = flow.xv;
    // d(xv^2)/dt = 2 xv vv makes Sigma_xv = 2 gamma * integral(xv vv) = gamma xv^2 exactly.
    const double sxv = gamma * flow.xv * flow.xv;
    // Sigma is positive semidefinite; the guards keep the factor finite where it is singular (gamma = 0, or a
    // variance that underflows).
    flow.lxx = std::sqrt(sxx);
    flow.lvx = flow.lxx > 0 ? sxv / flow.lxx : 0.0;
    flow.lvv = std::sqrt(std::fmax(0.0, svv - flow.lvx * flow.lvx));
    result.sxx = sxx;
    result.sxv = sxv;
    result.svv = svv;
    return result;
}

} // namespace ModeFlowDetail

/**
 * Computes the exact flow of one mode for angular frequency omega >= 0, friction gamma >= 0 and step h > 0.  Every
 * entry is accurate to a few rounding errors in all regimes: under-, critically and overdamped, undamped (gamma = 0),
 * free (omega = 0), and for omega*h and gamma*h from tiny to very large.
 */
inline ModeFlow computeModeFlow(double omega, double gamma, double h) {
    return ModeFlowDetail::flowAndCovariance(omega, gamma, h).flow;
}

/**
 * The flow of a free (omega = 0) mode over h > 0 with its friction as LangevinMiddleIntegrator places it: a drift of
 * h/2, one exact Ornstein-Uhlenbeck step of h (decay e = e^-gamma h, noise sqrt(1 - e^2) per sqrt(kT)), a drift of
 * h/2; a constant force acts during the drifts.  Phi = [[1, (1 + e) h/2], [0, e]], g = ((1 + e) h^2/4, (1 + e) h/2),
 * and the noise enters both rows through one normal draw: L = [[s h/2, 0], [s, 0]] with s = sqrt(1 - e^2).  Within a
 * kick-flow-kick step it samples a harmonic motion's positions exactly (BAOAB), and its velocity before the closing
 * kick exactly (LFMiddle).
 */
inline ModeFlow computeMiddleFreeFlow(double gamma, double h) {
    const double e = std::exp(-gamma * h), s = std::sqrt(-std::expm1(-2.0 * gamma * h));
    return ModeFlow{1.0, 0.5 * (1.0 + e) * h, 0.0, e, 0.25 * (1.0 + e) * h * h, 0.5 * (1.0 + e) * h, 0.5 * s * h, s,
                    0.0};
}

/**
 * The displacement per unit constant force at which the Strang step K(h/2) E(h) K(h/2) of a mode with flow f stands
 * still: the fixed point x* = h f.xv / det(I - Phi).  For the mode's own flow it is (1/omega^2) (xi/2) cot(xi/2)
 * without friction (xi = omega h), not the exact 1/omega^2: the impulse bias of Strang.
 */
inline double strangStaticResponse(const ModeFlow& f, double h) {
    return h * f.xv / ((1.0 - f.xx) * (1.0 - f.vv) - f.xv * f.vx);
}

/**
 * The warped angular frequency of a mode (omega > 0, friction gamma >= 0, step h > 0): the one frequency omega~ for
 * which the Strang step K(h/2) E~(h) K(h/2), with E~ the exact flow at omega~ and friction gamma, has the exact static
 * response 1/omega^2, i.e. strangStaticResponse(computeModeFlow(omega~, gamma, h), h) = 1/omega^2.  Without friction
 * xi~ = omega~ h solves xi~ tan(xi~/2) = xi^2/2, so xi~ = xi (1 - xi^2/24 + ...) and 0 < xi~ < pi for every xi:
 * the warped mode never turns by pi per step, whatever omega h is.  The response decreases monotonically from
 * 1/omega~^2 at omega~ h -> 0 to 0 where the damped mode turns by pi, which brackets the root; bisection finds it to
 * rounding.  Below omega h = 1e-4 the warp (xi^2/24 < 5e-10) is below the cancellation in det(I - Phi) and omega is
 * returned.
 */
inline double warpedFrequency(double omega, double gamma, double h) {
    if (omega * h < 1e-4)
        return omega;
    const double target = 1.0 / (omega * omega);
    double low = 0.0, high = std::sqrt(M_PI * M_PI + 0.25 * gamma * gamma * h * h) / h;
    for (int i = 0; i < 200 && high - low > 1e-15 * high; ++i) {
        const double middle = 0.5 * (low + high);
        if (strangStaticResponse(computeModeFlow(middle, gamma, h), h) > target)
            low = middle;
        else
            high = middle;
    }
    return 0.5 * (low + high);
}

/**
 * The frequency at which a stiff mode of warped frequency warpedOmega flows in a Warped step: warpedOmega, or
 * maxPhase/h where that turns farther than maxPhase per step (maxPhase > 0; 0 for no limit).  A limited mode needs
 * scaled kicks to keep the exact static response (StochasticImpulseIntegrator::setMaxWarpedPhase).
 */
inline double phaseLimitedFrequency(double warpedOmega, double h, double maxPhase) {
    return maxPhase > 0.0 ? std::fmin(warpedOmega, maxPhase / h) : warpedOmega;
}

/**
 * How the Warped splitting sets each stiff mode's flow: the limit on its phase per step
 * (StochasticImpulseIntegrator::setMaxWarpedPhase, 0 for none) and whether its friction is scaled to its effective
 * inertia (StochasticImpulseIntegrator::setWarpedFrictionScaling).
 */
struct WarpedFlowSettings {
    double maxPhase = 0.0;
    bool scaledFriction = false;
    bool operator==(const WarpedFlowSettings& o) const {
        return maxPhase == o.maxPhase && scaledFriction == o.scaledFriction;
    }
    bool operator!=(const WarpedFlowSettings& o) const { return !(*this == o); }
};

/** A stiff mode's Warped flow: its warped frequency, the frequency it flows at (phase limited) and its friction. */
struct WarpedMode {
    double warpedOmega, flowOmega, gamma;
};

/**
 * The inertia factor of a Warped step whose mode (true frequency omega) flows at flowOmega: for a soft force that
 * changes slowly, the step's two-step recurrence x_(n+1) - 2 cos(flowOmega h) x_n + x_(n-1) = ... responds as a
 * mode of frequency omega_d = 2 sin(flowOmega h/2)/h with the true stiffness, i.e. as a particle (omega/omega_d)^2
 * times heavier.  Returns (omega_d/omega)^2, the inverse of that mass factor.
 */
inline double warpedInertiaScale(double omega, double flowOmega, double h) {
    const double omegaD = 2.0 * std::sin(0.5 * flowOmega * h) / h;
    return omegaD * omegaD / (omega * omega);
}

/**
 * The Warped flow of a stiff mode of frequency omega > 0 and friction gamma >= 0 over h > 0.  Without friction
 * scaling: warpedFrequency at gamma, limited to settings.maxPhase.  With it, the friction is gamma s with
 * s = warpedInertiaScale of the flow that friction gives: the mode then responds to a slowly changing force as a
 * particle 1/s times heavier under the true friction force (mass times gamma times velocity), so its bath draws from
 * the motion that drives it the heat the true mode's does.  s depends on the friction only through the warp's weak
 * dependence on it, so the fixed point is found by iteration in a few steps (to rounding; at most 50).
 */
inline WarpedMode warpedMode(double omega, double gamma, double h, const WarpedFlowSettings& settings) {
    auto flowAt = [&](double friction) {
        const double warped = warpedFrequency(omega, friction, h);
        return WarpedMode{warped, phaseLimitedFrequency(warped, h, settings.maxPhase), friction};
    };
    WarpedMode mode = flowAt(gamma);
    if (!settings.scaledFriction || gamma == 0.0)
        return mode;
    for (int i = 0; i < 50; ++i) {
        const double scaled = gamma * warpedInertiaScale(omega, mode.flowOmega, h);
        const bool converged = std::fabs(scaled - mode.gamma) <= 1e-14 * gamma;
        mode = flowAt(scaled);
        if (converged)
            break;
    }
    return mode;
}

/** The exact Ornstein-Uhlenbeck flow of a velocity alone: v' = decay v + noise sqrt(kT/m) xi. */
struct VelocityFlow {
    double decay, noise;
};

/**
 * The velocity part of a free (omega = 0) mode's flow, for friction gamma >= 0 over h >= 0: decay = e^-gamma h and
 * noise = sqrt(1 - e^-2 gamma h), the velocity's standard deviation for kT/m = 1.
 */
inline VelocityFlow computeVelocityFlow(double gamma, double h) {
    return {std::exp(-gamma * h), std::sqrt(-std::expm1(-2.0 * gamma * h))};
}

} // namespace FlavorPlugin

#endif // OPENMM_FLAVORS_EXACT_MODE_FLOW_H_
