#include "WarpedPhaseChoice.h"
#include "openmm/Context.h"
#include "openmm/Force.h"
#include "openmm/OpenMMException.h"
#include "openmm/Platform.h"
#include "openmm/State.h"
#include "openmm/VerletIntegrator.h"
#include "openmm/internal/ContextImpl.h"
#include "openmm/serialization/XmlSerializer.h"
#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <vector>

using namespace FlavorPlugin;
using namespace OpenMM;
using std::vector;

namespace {

/** The stiff modes (ω > 0): each one's particle-space direction M^-1/2 u, and its frequency. */
struct StiffDirections {
    vector<vector<std::pair<int, Vec3>>> directions;
    vector<double> omega;
};

StiffDirections stiffDirections(const StiffModes& modes) {
    StiffDirections result;
    for (int c = 0; c < modes.getNumComponents(); ++c) {
        const StiffModes::Component& comp = modes.getComponent(c);
        if (!comp.stiff)
            continue;
        const int D = comp.rows(), C = comp.columns();
        const int* particles = modes.getComponentParticles(c);
        const double* u = modes.getEigenvectors(c);
        for (int k = 0; k < D; ++k)
            for (int col = 0; col < C; ++col) {
                const double omega = modes.getModeFrequency(comp.firstMode + C * k + col);
                if (omega <= 0.0)
                    continue;
                vector<std::pair<int, Vec3>> direction;
                for (int i = 0; i < D; ++i) {
                    // Row i is particle i (isotropic: coordinate col) or coordinate i % 3 of particle i / 3.
                    const int particle = particles[C == 3 ? i : i / 3];
                    Vec3 d;
                    d[C == 3 ? col : i % 3] = u[(size_t)k * D + i] / modes.getSqrtMass(particle);
                    direction.emplace_back(particle, d);
                }
                result.directions.push_back(std::move(direction));
                result.omega.push_back(omega);
            }
    }
    return result;
}

/** A copy of the System's soft forces in a Context of its own, at the given state. */
class SoftForces {
public:
    SoftForces(ContextImpl& context, int softGroups) : groups(softGroups) {
        system.reset(XmlSerializer::clone<System>(context.getSystem()));
        for (int f = system->getNumForces() - 1; f >= 0; --f)
            if ((softGroups & (1 << system->getForce(f).getForceGroup())) == 0)
                system->removeForce(f);
        integrator = std::make_unique<VerletIntegrator>(0.001);
        Platform* platform = nullptr;
        for (const char* name : {"CPU", "Reference"})
            try {
                platform = &Platform::getPlatformByName(name);
                break;
            } catch (const OpenMMException&) {
            }
        copy = std::make_unique<Context>(*system, *integrator, *platform);
        Vec3 box[3];
        context.getPeriodicBoxVectors(box[0], box[1], box[2]);
        copy->setPeriodicBoxVectors(box[0], box[1], box[2]);
        // The parameters of the soft forces (the copy has no others).
        const std::map<std::string, double> own = copy->getParameters();
        for (const auto& parameter : context.getParameters())
            if (own.count(parameter.first) != 0)
                copy->setParameter(parameter.first, parameter.second);
        context.getPositions(positions);
        displaced = positions;
    }
    /** The soft forces with the particles displaced by delta (the virtual sites placed after them). */
    vector<Vec3> forcesAt(const vector<Vec3>& delta) {
        for (size_t i = 0; i < positions.size(); ++i)
            displaced[i] = positions[i] + delta[i];
        copy->setPositions(displaced);
        copy->computeVirtualSites();
        ++evaluations;
        return copy->getState(State::Forces, false, groups).getForces();
    }
    int evaluations = 0;

private:
    int groups;
    std::unique_ptr<System> system;
    std::unique_ptr<VerletIntegrator> integrator;
    std::unique_ptr<Context> copy;
    vector<Vec3> positions, displaced;
};

} // namespace

WarpedPhaseChoice FlavorPlugin::chooseWarpedPhase(ContextImpl& context, const StiffModes& modes, int softGroups) {
    const auto started = std::chrono::steady_clock::now();
    WarpedPhaseChoice choice;
    choice.phase = M_PI;
    const StiffDirections stiff = stiffDirections(modes);
    const int n = (int)stiff.omega.size();
    if (n == 0 || softGroups == 0)
        return choice;
    SoftForces soft(context, softGroups);
    const int numParticles = context.getSystem().getNumParticles();
    // R v = Ω⁻¹ Uᵀ M^-1/2 H M^-1/2 U Ω⁻¹ v, H x from the soft forces at ±h x scaled so that no particle moves more
    // than 1e-4 nm (small against the Drude displacements the couplings act on, large against force rounding).
    vector<Vec3> x(numParticles), minus(numParticles);
    auto applyR = [&](const Eigen::VectorXd& v) {
        std::fill(x.begin(), x.end(), Vec3());
        for (int m = 0; m < n; ++m)
            for (const auto& entry : stiff.directions[m])
                x[entry.first] += entry.second * (v[m] / stiff.omega[m]);
        double largest = 0.0;
        for (const Vec3& d : x)
            largest = std::max(largest, std::sqrt(d.dot(d)));
        Eigen::VectorXd result = Eigen::VectorXd::Zero(n);
        if (largest == 0.0)
            return result;
        const double h = 1e-4 / largest;
        for (int i = 0; i < numParticles; ++i) {
            minus[i] = -x[i] * h;
            x[i] *= h;
        }
        const vector<Vec3> plus = soft.forcesAt(x);
        const vector<Vec3> back = soft.forcesAt(minus);
        for (int m = 0; m < n; ++m) {
            double sum = 0.0;
            for (const auto& entry : stiff.directions[m])
                sum -= entry.second.dot(plus[entry.first] - back[entry.first]);
            result[m] = sum / (2 * h) / stiff.omega[m];
        }
        return result;
    };
    // Lanczos with full reorthogonalization from a fixed start: its largest Ritz value converges to the largest
    // eigenvalue in a few tens of iterations.
    const int iterations = std::min(n, 30);
    Eigen::MatrixXd basis(n, iterations);
    vector<double> alpha, beta;
    Eigen::VectorXd v = Eigen::VectorXd::Ones(n);
    for (int m = 0; m < n; ++m)
        v[m] += 0.5 * std::sin(1.0 + m);
    v.normalize();
    for (int j = 0; j < iterations; ++j) {
        basis.col(j) = v;
        Eigen::VectorXd w = applyR(v);
        alpha.push_back(v.dot(w));
        for (int repeat = 0; repeat < 2; ++repeat)
            w -= basis.leftCols(j + 1) * (basis.leftCols(j + 1).transpose() * w);
        const double norm = w.norm();
        if (j + 1 == iterations || norm < 1e-12 * std::max(1.0, std::abs(alpha.back())))
            break;
        beta.push_back(norm);
        v = w / norm;
    }
    const int k = (int)alpha.size();
    Eigen::MatrixXd tridiagonal = Eigen::MatrixXd::Zero(k, k);
    for (int j = 0; j < k; ++j) {
        tridiagonal(j, j) = alpha[j];
        if (j + 1 < k)
            tridiagonal(j, j + 1) = tridiagonal(j + 1, j) = beta[j];
    }
    const double largest = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(tridiagonal).eigenvalues().maxCoeff();
    choice.couplingRatio = std::max(0.0, largest);
    // 5 % of margin on r: the condition's edge is neutral (a mode there grows linearly), and r changes as the System
    // moves.
    choice.phase = 2 * std::asin(1 / std::sqrt(1 + WarpedPhaseChoice::PhaseMargin * choice.couplingRatio));
    choice.forceEvaluations = soft.evaluations;
    choice.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    return choice;
}
