// Accuracy, convergence, stability and long-time energy, against analytic results and an independent
// fine-step integration.

#include "FlavorIntegrator.h"
#include "PlatformTest.h"
#include "TestSystems.h"
#include "openmm/Context.h"
#include "openmm/VerletIntegrator.h"
#include <algorithm>
#include <cmath>
#include <map>
#include <memory>

using namespace FlavorPlugin;
using namespace FlavorTests;
using namespace OpenMM;
using std::vector;

class FlavorAccuracy : public PlatformTest {};
INSTANTIATE_ON_ALL_PLATFORMS(FlavorAccuracy);

namespace {

/**
 * The slow variable (x+y)/2 at time t of the exact solution of x'' = -x + k(y-x), y'' = -k(y-x) started at rest
 * from (x0, y0): the modes of [[1+k, -k], [-k, k]] in closed form.
 */
double exactLinearSlowVariable(double k, double x0, double y0, double t) {
    double mean = 0.5 + k, root = std::sqrt(0.25 + k * k);
    double lambda[2] = {mean - root, mean + root};
    double result = 0;
    for (double l : lambda) {
        // Eigenvector (k, 1 + k - l) of [[1+k, -k], [-k, k]], normalized.
        double u0 = k, u1 = 1 + k - l, norm = std::sqrt(u0 * u0 + u1 * u1);
        u0 /= norm;
        u1 /= norm;
        double amplitude = u0 * x0 + u1 * y0;
        result += amplitude * std::cos(std::sqrt(l) * t) * 0.5 * (u0 + u1);
    }
    return result;
}

} // namespace

TEST_P(FlavorAccuracy, SlowVariableOfTheLinearSystemMatchesTheAveragedDynamics) {
    // System (5.1), Fig. 5.2 data: omega = 1000, x(0) = 0.8, y(0) = x(0) + 1.1/omega, T = 10.
    //
    // The bound: with tau*omega << 1 the stiff impulse tau*omega^2*(y-x) per mesostep acts, to leading order, like
    // a spring of constant kappa = omega^2 tau/delta over the whole mesostep (flow averaging).  The Verlet FLAVOR is
    // then velocity Verlet on the averaged system, whose own O(delta^2) error is below 1e-5 here.  So the slow
    // variable's error is e = |s_kappa(T) - s_omega^2(T)| (both exact solutions) up to relative corrections of
    // O(tau*omega) + O(delta^2) + O(1/kappa): we require the measured error to be within 10% of e.  Doubling the
    // stiff time, or dropping a soft kick, moves it far outside.
    const double omega = 1000, x0 = 0.8, y0 = x0 + 1.1 / omega, T = 10;
    std::unique_ptr<System> system(linearSystem(omega));
    const double exact = exactLinearSlowVariable(omega * omega, x0, y0, T);
    for (auto steps : {std::pair<double, double>{0.01, 1e-5}, {0.005, 1e-6}, {0.01, 1e-7}}) {
        const double delta = steps.first, tau = steps.second;
        FlavorIntegrator integrator(delta, tau, StiffMask);
        Context context(*system, integrator, platform(), properties());
        context.setPositions({Vec3(x0, 0, 0), Vec3(y0, 0, 0)});
        integrator.step((int)std::round(T / delta));
        vector<Vec3> q = positionsOf(context);
        double error = std::abs(0.5 * (q[0][0] + q[1][0]) - exact);
        double predicted = std::abs(exactLinearSlowVariable(omega * omega * tau / delta, x0, y0, T) - exact);
        EXPECT_NEAR(1.0, error / predicted, 0.1) << "delta " << delta << " tau " << tau << ": error " << error
                                                 << ", averaged-dynamics prediction " << predicted;
    }
}

TEST_P(FlavorAccuracy, TimeAveragedSlowVariableConvergesAtFirstOrderInTheMesostep) {
    // System (5.8) with Fig. 5.3's data (eps = 1e-6, omega1 = 1.1, omega2 = 0.97, x,y,z(0) = 0.8, 0.811, 0.721)
    // and tau = 2e-5 (the caption's tau = 5e-4 gives tau*delta*omega_max^2 > 4, outside the stability region).
    // As in Fig. 5.4(a): H = 1, delta = H/M, the slow variable (x+y+z)/3 averaged over the M mesosteps that end at
    // T, against OpenMM's VerletIntegrator with h = 2e-6 (omega_max h = 0.0035) sampled at the same times.
    const double epsilon = 1e-6, T = 5, H = 1, tau = 2e-5, h = 2e-6;
    System system;
    for (int i = 0; i < 3; ++i)
        system.addParticle(1.0);
    CustomExternalForce* soft = new CustomExternalForce("x^4");
    soft->addParticle(0);
    HarmonicBondForce* stiff = new HarmonicBondForce();
    stiff->addBond(0, 1, 0, 1.1 / epsilon);
    stiff->addBond(1, 2, 0, 0.97 / epsilon);
    stiff->setForceGroup(StiffGroup);
    system.addForce(soft);
    system.addForce(stiff);
    const vector<Vec3> q0 = {Vec3(0.8, 0, 0), Vec3(0.811, 0, 0), Vec3(0.721, 0, 0)};
    auto slow = [](const vector<Vec3>& q) { return (q[0][0] + q[1][0] + q[2][0]) / 3; };

    const vector<int> Ms = {20, 40, 80};
    // The reference on the Reference platform: it is independent of the platform under test.
    std::map<long long, double> reference; // keyed by step count of the fine integrator
    {
        VerletIntegrator verlet(h);
        Context context(system, verlet, Platform::getPlatformByName("Reference"));
        context.setPositions(q0);
        std::map<long long, bool> wanted;
        for (int M : Ms)
            for (int j = 0; j < M; ++j)
                wanted[std::llround((T - j * H / M) / h)] = true;
        long long at = 0;
        for (auto& w : wanted) {
            verlet.step((int)(w.first - at));
            at = w.first;
            reference[w.first] = slow(positionsOf(context));
        }
    }
    vector<double> errors;
    for (int M : Ms) {
        const double delta = H / M;
        FlavorIntegrator integrator(delta, tau, StiffMask);
        integrator.setScheme(FlavorIntegrator::SymplecticEuler);
        Context context(system, integrator, platform(), properties());
        context.setPositions(q0);
        integrator.step((int)std::lround((T - H) / delta));
        double flavorAverage = 0, referenceAverage = 0;
        for (int j = M - 1; j >= 0; --j) {
            integrator.step(1);
            flavorAverage += slow(positionsOf(context)) / M;
            referenceAverage += reference.at(std::llround((T - j * delta) / h)) / M;
        }
        errors.push_back(std::abs(flavorAverage - referenceAverage));
    }
    // First order: each halving of delta divides the error by about 2 (observed order between 0.7 and 1.6), and
    // the finest run is accurate to 2e-3.
    for (size_t i = 0; i + 1 < errors.size(); ++i) {
        double order = std::log2(errors[i] / errors[i + 1]);
        EXPECT_GE(order, 0.7) << "errors " << errors[i] << " -> " << errors[i + 1];
        EXPECT_LE(order, 1.6) << "errors " << errors[i] << " -> " << errors[i + 1];
    }
    EXPECT_LT(errors.back(), 2e-3);
}

TEST_P(FlavorAccuracy, StabilityBoundaryOfTheorem5_1) {
    // System (5.1) with omega = 1000 and tau = 1e-8 << 1/omega^2: the FLAVOR is stable iff delta < 2.  Symplectic
    // Euler with step delta on the unit-frequency slow oscillator keeps |x| <= |x0| / sqrt(1 - delta^2/4); past
    // delta = 2 it has a real eigenvalue below -1 (-1.88 at delta = 2.1) and grows without bound.
    const double omega = 1000, tau = 1e-8;
    std::unique_ptr<System> system(linearSystem(omega));
    for (auto scheme : {FlavorIntegrator::SymplecticEuler, FlavorIntegrator::Verlet}) {
        for (double delta : {1.9, 2.1}) {
            FlavorIntegrator integrator(delta, tau, StiffMask);
            integrator.setScheme(scheme);
            Context context(*system, integrator, platform(), properties());
            context.setPositions({Vec3(0.8, 0, 0), Vec3(0.8011, 0, 0)});
            double largest = 0;
            for (int block = 0; block < 50; ++block) {
                integrator.step(10);
                for (const Vec3& q : positionsOf(context))
                    largest = std::max(largest, std::isfinite(q[0]) ? std::abs(q[0]) : INFINITY);
            }
            if (delta < 2)
                EXPECT_LE(largest, 1.1 * 0.8011 / std::sqrt(1 - delta * delta / 4)) << "scheme " << scheme;
            else
                EXPECT_GT(largest, 1e50) << "scheme " << scheme;
        }
    }
}

TEST_P(FlavorAccuracy, NoEnergyDriftOverALongFermiPastaUlamRun) {
    // A FLAVOR is the legacy integrator applied to the averaged Hamiltonian H_eff = K + V_soft + (tau/delta) V_stiff
    // (the fast variables are slowed down, so H itself is not conserved along the FLAVOR trajectory).  Being
    // symplectic, it keeps H_eff within a bounded oscillation: O(delta) for SymplecticEuler, O(delta^2) for Verlet
    // (backward error analysis).  FPU chain (m = 3, omega = 50, Fig. 6.5 data), delta = 2e-3, tau = 2e-4, 1e5 steps
    // (5e3 on CPU, whose per-step overhead on 6 particles is ~100x Reference's): the mean |H_eff error| over the
    // last fifth of the run must not exceed 1.5x that over the second fifth (a linear drift gives ~4x), and stays
    // below 5 delta |H_eff| (SymplecticEuler) or 5 delta^2 |H_eff| / delta_ref with delta_ref = 0.1 (Verlet).
    const double omega = 50, delta = 2e-3, tau = 2e-4;
    std::unique_ptr<System> system(fpuSystem(3, omega));
    for (auto scheme : {FlavorIntegrator::SymplecticEuler, FlavorIntegrator::Verlet}) {
        FlavorIntegrator integrator(delta, tau, StiffMask);
        integrator.setScheme(scheme);
        Context context(*system, integrator, platform(), properties());
        context.setPositions(fpuPositions({1, 0, 0}, {1 / omega, 0, 0}));
        auto averagedEnergy = [&]() {
            State soft = context.getState(State::Energy, false, 1 << SoftGroup);
            State stiff = context.getState(State::Energy, false, StiffMask);
            return soft.getKineticEnergy() + soft.getPotentialEnergy() + tau / delta * stiff.getPotentialEnergy();
        };
        const double e0 = averagedEnergy();
        const int blocks = 100, stepsPerBlock = isCpu() ? 50 : 1000;
        vector<double> deviation;
        for (int b = 0; b < blocks; ++b) {
            integrator.step(stepsPerBlock);
            deviation.push_back(std::abs(averagedEnergy() - e0));
        }
        auto meanOver = [&](int first, int last) {
            double sum = 0;
            for (int b = first; b < last; ++b)
                sum += deviation[b];
            return sum / (last - first);
        };
        double early = meanOver(20, 40), late = meanOver(80, 100);
        double bound = (scheme == FlavorIntegrator::SymplecticEuler ? 5 * delta : 5 * delta * delta / 0.1) * e0;
        EXPECT_LE(late, 1.5 * early) << "scheme " << scheme << ": H_eff error grows from " << early << " to " << late;
        EXPECT_LE(*std::max_element(deviation.begin(), deviation.end()), bound) << "scheme " << scheme;
    }
}
