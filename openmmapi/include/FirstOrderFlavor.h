#ifndef OPENMM_FLAVORS_FIRST_ORDER_FLAVOR_H_
#define OPENMM_FLAVORS_FIRST_ORDER_FLAVOR_H_

#include "internal/CounterRandom.h"
#include "internal/ParameterChecks.h"
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>

namespace FlavorPlugin {

/**
 * The nonintrusive FLAVOR of a first-order system (FLAVORS paper, eq. 1.34 for ODEs and eq. 3.7 for SDEs)
 *
 *     du = f(u; alpha, t) dt + sigma(u; alpha, t) dW,
 *
 * whose stiffness parameter alpha (1/eps in the paper) can be switched.  Each mesostep delta runs the legacy
 * integrator, forward Euler (Euler-Maruyama when there is noise), once over the microstep tau with alpha = stiffness
 * and once over delta - tau with alpha = 0:
 *
 *     u_{k+1} = Phi^0_{delta-tau}(Phi^stiffness_tau(u_k, t_k), t_k + tau),   t_k = k delta,
 *     Phi^alpha_h(u, t) = u + h f(u; alpha, t) + sqrt(h) sigma(u; alpha, t) xi,   xi ~ N(0, I),
 *
 * with independent xi for the two stages.  Time-dependent terms see physical time.  With tau = delta the second stage
 * is empty and a step is exactly one forward Euler (Euler-Maruyama) step of length delta with the stiffness on: the
 * legacy integrator at a fine step h is this class with delta = tau = h.
 *
 * This is not an OpenMM integrator: the state is a std::array and the system a Model, a class with
 *
 *     static constexpr std::size_t Dim;        the dimension of u
 *     static constexpr std::size_t NoiseDim;   the number of independent Brownian motions (0: an ODE)
 *     void drift(const std::array<double, Dim>& u, double alpha, double t, std::array<double, Dim>& f) const;
 *     void diffusion(const std::array<double, Dim>& u, double alpha, double t,
 *                    std::array<double, Dim * NoiseDim>& sigma) const;   (row-major; only if NoiseDim > 0)
 *
 * Nothing is allocated while stepping.  The normal numbers come from CounterRandom: the stage s (0: microstep,
 * 1: the rest) of mesostep k draws its Brownian increments from the streams (2k + s) B + b, b < B = ceil(NoiseDim/3),
 * for the particle index path, so each path of an ensemble is independent and reproducible, in any order and on any
 * number of threads.  A stage whose sigma is zero draws nothing.  Header only, but the parameter checks are in
 * libOpenMMFlavors: link it (examples/van_der_pol and examples/hidden_sde show a Model and a program).
 */
template <class Model> class FirstOrderFlavor {
public:
    static constexpr std::size_t Dim = Model::Dim;
    static constexpr std::size_t NoiseDim = Model::NoiseDim;
    /** The number of streams one stage draws its NoiseDim normals from (three normals per stream). */
    static constexpr std::uint64_t StreamsPerStage = (NoiseDim + 2) / 3;
    using State = std::array<double, Dim>;
    using Diffusion = std::array<double, Dim * NoiseDim>;

    /**
     * @param system     the Model (copied)
     * @param stiffness  the value of alpha while the stiffness is on (1/eps), >= 0
     * @param mesostep   delta, > 0
     * @param microstep  tau, 0 < tau <= delta
     * @param seed       the seed of the normal numbers (used as it is: 0 is a valid seed here)
     */
    FirstOrderFlavor(const Model& system, double stiffness, double mesostep, double microstep, std::uint64_t seed = 1)
        : model(system), stiffness(stiffness), mesostep(mesostep), microstep(microstep), random(seed) {
        requireNonNegative("FirstOrderFlavor", "stiffness", stiffness, "");
        requirePositive("FirstOrderFlavor", "mesostep", mesostep, "");
        requirePositive("FirstOrderFlavor", "microstep", microstep, "");
        if (microstep > mesostep)
            throwInvalidParameter("FirstOrderFlavor", "microstep", formatNumber(microstep),
                                  "it must not exceed the mesostep " + formatNumber(mesostep));
    }

    /** Advances u by mesostep k, from t = k delta to (k + 1) delta, on the random streams of the given path. */
    void step(State& u, std::uint64_t k, std::uint32_t path = 0) const {
        const double t = k * mesostep;
        stage(u, microstep, stiffness, t, 2 * k, path);
        if (microstep < mesostep)
            stage(u, mesostep - microstep, 0.0, t + microstep, 2 * k + 1, path);
    }

    /** Runs the mesosteps first, first + 1, ..., first + count - 1. */
    void run(State& u, std::uint64_t first, std::uint64_t count, std::uint32_t path = 0) const {
        for (std::uint64_t k = first; k < first + count; ++k)
            step(u, k, path);
    }

    double getStiffness() const { return stiffness; }
    double getMesostep() const { return mesostep; }
    double getMicrostep() const { return microstep; }
    const Model& getModel() const { return model; }

private:
    /** One forward Euler (Euler-Maruyama) step of length h with stiffness parameter alpha: stage number index. */
    void stage(State& u, double h, double alpha, double t, std::uint64_t index, std::uint32_t path) const {
        State f;
        model.drift(u, alpha, t, f);
        if constexpr (NoiseDim > 0) {
            Diffusion sigma;
            model.diffusion(u, alpha, t, sigma);
            bool noisy = false;
            for (double s : sigma)
                noisy = noisy || s != 0.0;
            if (noisy) {
                std::array<double, 3 * StreamsPerStage> xi;
                for (std::uint64_t b = 0; b < StreamsPerStage; ++b) {
                    const std::array<double, 3> n = random.normals(index * StreamsPerStage + b, path);
                    for (int j = 0; j < 3; ++j)
                        xi[3 * b + j] = n[j];
                }
                const double root = std::sqrt(h);
                for (std::size_t i = 0; i < Dim; ++i) {
                    double kick = 0.0;
                    for (std::size_t j = 0; j < NoiseDim; ++j)
                        kick += sigma[i * NoiseDim + j] * xi[j];
                    u[i] = u[i] + h * f[i] + root * kick;
                }
                return;
            }
        }
        for (std::size_t i = 0; i < Dim; ++i)
            u[i] = u[i] + h * f[i];
    }

    Model model;
    double stiffness, mesostep, microstep;
    CounterRandom random;
};

} // namespace FlavorPlugin

#endif
