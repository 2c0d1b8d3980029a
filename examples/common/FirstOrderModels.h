#ifndef OPENMM_FLAVORS_FIRST_ORDER_MODELS_H_
#define OPENMM_FLAVORS_FIRST_ORDER_MODELS_H_

// The first-order systems of the FLAVORS paper's §6.1 and §6.7, as Models of FlavorPlugin::FirstOrderFlavor: alpha
// is the stiffness parameter (1/eps while the stiffness is on, 0 while it is off).  Shared by the scenes
// examples/van_der_pol and examples/hidden_sde and by the tests.

#include <array>
#include <cmath>
#include <cstddef>

namespace FirstOrderModels {

constexpr double Pi = 3.14159265358979323846;

/** The Van der Pol oscillator with separated slow x and fast y, eq. (6.2): x' = -eps y, y' = alpha (x + y - y^3/3). */
struct VanDerPol {
    static constexpr std::size_t Dim = 2, NoiseDim = 0;
    double eps;
    void drift(const std::array<double, 2>& u, double alpha, double, std::array<double, 2>& f) const {
        const double x = u[0], y = u[1];
        f[0] = -eps * y;
        f[1] = alpha * (x + y - y * y * y / 3);
    }
};

/**
 * The same oscillator in polar coordinates (r, theta), x = r sin(theta), y = r cos(theta), eq. (6.1): slow and fast
 * variables hidden.
 */
struct HiddenVanDerPol {
    static constexpr std::size_t Dim = 2, NoiseDim = 0;
    double eps;
    void drift(const std::array<double, 2>& u, double alpha, double, std::array<double, 2>& f) const {
        const double r = u[0], c = std::cos(u[1]), s = std::sin(u[1]);
        f[0] = alpha * (r * c + r * s - r * r * r * c * c * c / 3) * c - eps * r * c * s;
        f[1] = -eps * c * c - alpha * (c + s - r * r * c * c * c / 3) * s;
    }
    static std::array<double, 2> toCartesian(const std::array<double, 2>& u) {
        return {u[0] * std::sin(u[1]), u[0] * std::cos(u[1])};
    }
    static std::array<double, 2> fromCartesian(double x, double y) { return {std::hypot(x, y), std::atan2(x, y)}; }
};

/**
 * The nonautonomous SDE with hidden slow variable, eq. (6.16), in (u, v), driven by one Brownian motion:
 *   du = g dt - alpha q dt - sqrt(2 alpha) dW,   dv = g dt + alpha q dt + sqrt(2 alpha) dW,
 *   g = 4/(3 (u + v)^2) (-((v - u)/2)^2/2 + 5 sin(2 pi t)),   q = ((u + v)/2)^3 + c - (v - u)/2.
 */
struct HiddenSde {
    static constexpr std::size_t Dim = 2, NoiseDim = 1;
    double c;
    void drift(const std::array<double, 2>& w, double alpha, double t, std::array<double, 2>& f) const {
        const double u = w[0], v = w[1], half = (v - u) / 2, mean = (u + v) / 2;
        const double g = 4 / (3 * (u + v) * (u + v)) * (-half * half / 2 + 5 * std::sin(2 * Pi * t));
        const double q = mean * mean * mean + c - half;
        f[0] = g - alpha * q;
        f[1] = g + alpha * q;
    }
    void diffusion(const std::array<double, 2>&, double alpha, double, std::array<double, 2>& sigma) const {
        const double s = std::sqrt(2 * alpha);
        sigma[0] = -s;
        sigma[1] = s;
    }
    /** The slow and fast variables of the diffeomorphism (6.17): x = ((u + v)/2)^3 + c, y = (v - u)/2. */
    std::array<double, 2> slowFast(const std::array<double, 2>& w) const {
        const double mean = (w[0] + w[1]) / 2;
        return {mean * mean * mean + c, (w[1] - w[0]) / 2};
    }
    std::array<double, 2> fromSlowFast(double x, double y) const {
        const double mean = std::cbrt(x - c);
        return {mean - y, mean + y};
    }
};

/**
 * (6.16) written in the variables (6.17): dx = (-y^2/2 + 5 sin(2 pi t)) dt, dy = alpha (x - y) dt + sqrt(2 alpha) dW.
 * The paper prints (6.18) with 5 sin(2 pi t) dW in place of 5 sin(2 pi t) dt; (6.16) gives this drift (the noises
 * of u and v cancel in u + v, so x has none).
 */
struct SlowFastSde {
    static constexpr std::size_t Dim = 2, NoiseDim = 1;
    void drift(const std::array<double, 2>& u, double alpha, double t, std::array<double, 2>& f) const {
        f[0] = -u[1] * u[1] / 2 + 5 * std::sin(2 * Pi * t);
        f[1] = alpha * (u[0] - u[1]);
    }
    void diffusion(const std::array<double, 2>&, double alpha, double, std::array<double, 2>& sigma) const {
        sigma[0] = 0;
        sigma[1] = std::sqrt(2 * alpha);
    }
};

/** (6.18) as the paper prints it: dx = -y^2/2 dt + 5 sin(2 pi t) dW, dy = alpha (x - y) dt + sqrt(2 alpha) dW. */
struct PrintedSlowFastSde {
    static constexpr std::size_t Dim = 2, NoiseDim = 1;
    void drift(const std::array<double, 2>& u, double alpha, double, std::array<double, 2>& f) const {
        f[0] = -u[1] * u[1] / 2;
        f[1] = alpha * (u[0] - u[1]);
    }
    void diffusion(const std::array<double, 2>&, double alpha, double t, std::array<double, 2>& sigma) const {
        sigma[0] = 5 * std::sin(2 * Pi * t);
        sigma[1] = std::sqrt(2 * alpha);
    }
};

} // namespace FirstOrderModels

#endif
