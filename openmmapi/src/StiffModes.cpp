#include "internal/StiffModes.h"
#include "internal/ParameterChecks.h"
#include "openmm/OpenMMException.h"
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>

using namespace FlavorPlugin;
using namespace OpenMM;
using std::vector;

namespace {

int findRoot(vector<int>& parent, int i) {
    while (parent[i] != i)
        i = parent[i] = parent[parent[i]];
    return i;
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
    for (const StiffnessBlock& b : blocks) {
        const double tolerance = 1e-12 * largestEntry;
        bool isotropic = std::abs(b.k[0][0] - b.k[1][1]) <= tolerance && std::abs(b.k[0][0] - b.k[2][2]) <= tolerance;
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c)
                if (r != c && std::abs(b.k[r][c]) > tolerance)
                    isotropic = false;
        if (!isotropic && masses[b.i] != 0.0)
            components[componentOf[b.i]].isotropic = false;
    }
    size_t matrixSize = 0;
    for (Component& c : components) {
        c.matrixOffset = matrixSize;
        const size_t size = c.isotropic ? c.numParticles : 3 * c.numParticles;
        matrixSize += size * size;
    }
    eigenvectors.assign(matrixSize, 0.0);
    omega.assign(modes, 0.0);
    modeForce.assign(modes, 0.0);
    scratch.assign(6 * (size_t)modes, 0.0);

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

namespace {

/**
 * out = U^T in (transpose) or U in, for n x 3 row-major coordinate blocks and a column-major n x n U.  Plain loops
 * for the small components that dominate in practice (Eigen's dynamic-size products cost more than the arithmetic
 * there), Eigen for large ones.
 */
void rotateRows(const double* u, int n, const double* in, double* out, bool transpose) {
    typedef Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>> Rows;
    typedef Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> const> ConstRows;
    typedef Eigen::Map<const Eigen::MatrixXd> Matrix;
    if (n > 8) {
        if (transpose)
            Rows(out, n, 3).noalias() = Matrix(u, n, n).transpose() * ConstRows(in, n, 3);
        else
            Rows(out, n, 3).noalias() = Matrix(u, n, n) * ConstRows(in, n, 3);
        return;
    }
    for (int j = 0; j < n; ++j) {
        double sum0 = 0, sum1 = 0, sum2 = 0;
        for (int p = 0; p < n; ++p) {
            const double coefficient = transpose ? u[j * n + p] : u[p * n + j]; // U(p, j) or U(j, p)
            sum0 += coefficient * in[3 * p];
            sum1 += coefficient * in[3 * p + 1];
            sum2 += coefficient * in[3 * p + 2];
        }
        out[3 * j] = sum0;
        out[3 * j + 1] = sum1;
        out[3 * j + 2] = sum2;
    }
}

} // namespace

vector<double> StiffModes::getStiffFrequencies() const {
    vector<double> result;
    for (const Component& c : components)
        if (c.stiff)
            result.insert(result.end(), omega.begin() + c.firstMode, omega.begin() + c.firstMode + 3 * c.numParticles);
    std::sort(result.begin(), result.end());
    return result;
}

void StiffModes::computeFlows(double h, double gamma, vector<ModeFlow>& flows) const {
    flows.resize(omega.size());
    for (size_t k = 0; k < omega.size(); ++k) {
        if (h >= 0) {
            flows[k] = computeModeFlow(omega[k], gamma, h);
            continue;
        }
        // Deterministic flow backwards in time: the inverse of the (unit-determinant) forward flow.
        ModeFlow f = computeModeFlow(omega[k], 0.0, -h);
        ModeFlow inverse{f.vv, -f.xv, -f.vx, f.xx, 0, 0, 0, 0, 0};
        inverse.gx = -(inverse.xx * f.gx + inverse.xv * f.gv);
        inverse.gv = -(inverse.vx * f.gx + inverse.vv * f.gv);
        flows[k] = inverse;
    }
}

void StiffModes::Flow::apply(int begin, int end) const {
    typedef Eigen::Map<Eigen::VectorXd> Vector;
    typedef Eigen::Map<const Eigen::MatrixXd> Matrix;
    for (int c = begin; c < end; ++c) {
        const Component& comp = modes.components[c];
        const int dim = 3 * comp.numParticles;
        // Mass-weighted coordinates x, w, mode coordinates a, alpha and the two noise vectors, in this component's
        // slice of scratch.
        double* x = &modes.scratch[6 * (size_t)comp.firstMode];
        double* w = x + dim;
        double* a = comp.stiff ? w + dim : x;
        double* alpha = comp.stiff ? a + dim : w;
        double* noise1 = x + 4 * dim;
        double* noise2 = noise1 + dim;
        const bool noisy = (thermalScale != 0.0);
        for (int p = 0; p < comp.numParticles; ++p) {
            const int particle = modes.particleList[comp.firstParticle + p];
            const double s = modes.sqrtMass[particle];
            for (int d = 0; d < 3; ++d) {
                x[3 * p + d] = s * positions[particle][d];
                w[3 * p + d] = s * velocities[particle][d];
            }
            if (noisy) {
                // Drawn per particle and rotated into the modes, so the noise does not depend on which basis the
                // eigensolver picked inside a degenerate subspace.
                std::array<double, 3> xi1 = random->normals(stream, 2 * (std::uint32_t)particle);
                std::array<double, 3> xi2 = random->normals(stream, 2 * (std::uint32_t)particle + 1);
                for (int d = 0; d < 3; ++d) {
                    noise1[3 * p + d] = xi1[d];
                    noise2[3 * p + d] = xi2[d];
                }
            }
        }
        const int n = comp.numParticles;
        if (comp.stiff && comp.isotropic) {
            const double* u = &modes.eigenvectors[comp.matrixOffset];
            rotateRows(u, n, x, a, true);
            rotateRows(u, n, w, alpha, true);
            if (noisy) {
                // x and w are free until the modes are mapped back.
                rotateRows(u, n, noise1, x, true);
                rotateRows(u, n, noise2, w, true);
                std::copy(x, x + 2 * dim, noise1);
            }
        } else if (comp.stiff) {
            Matrix u(&modes.eigenvectors[comp.matrixOffset], dim, dim);
            Vector(a, dim).noalias() = u.transpose() * Vector(x, dim);
            Vector(alpha, dim).noalias() = u.transpose() * Vector(w, dim);
            if (noisy) {
                Vector(x, dim).noalias() = u.transpose() * Vector(noise1, dim);
                Vector(w, dim).noalias() = u.transpose() * Vector(noise2, dim);
                std::copy(x, x + 2 * dim, noise1);
            }
        }
        for (int k = 0; k < dim; ++k) {
            const int mode = comp.firstMode + k;
            const ModeFlow& f = flows[mode];
            const double force = modes.modeForce[mode];
            double na = f.xx * a[k] + f.xv * alpha[k] + f.gx * force;
            double nalpha = f.vx * a[k] + f.vv * alpha[k] + f.gv * force;
            if (noisy) {
                na += thermalScale * f.lxx * noise1[k];
                nalpha += thermalScale * (f.lvx * noise1[k] + f.lvv * noise2[k]);
            }
            a[k] = na;
            alpha[k] = nalpha;
        }
        if (comp.stiff && comp.isotropic) {
            const double* u = &modes.eigenvectors[comp.matrixOffset];
            rotateRows(u, n, a, x, false);
            rotateRows(u, n, alpha, w, false);
        } else if (comp.stiff) {
            Matrix u(&modes.eigenvectors[comp.matrixOffset], dim, dim);
            Vector(x, dim).noalias() = u * Vector(a, dim);
            Vector(w, dim).noalias() = u * Vector(alpha, dim);
        }
        for (int p = 0; p < comp.numParticles; ++p) {
            const int particle = modes.particleList[comp.firstParticle + p];
            const double s = 1.0 / modes.sqrtMass[particle];
            for (int d = 0; d < 3; ++d) {
                positions[particle][d] = s * x[3 * p + d];
                velocities[particle][d] = s * w[3 * p + d];
            }
        }
    }
}
