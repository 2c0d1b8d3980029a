#include "StiffModes.h"
#include "internal/ParameterChecks.h"
#include "internal/UnionFind.h"
#include "openmm/OpenMMException.h"
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>

using namespace FlavorPlugin;
using namespace OpenMM;
using std::vector;

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
    size_t matrixSize = 0;
    for (Component& c : components) {
        c.matrixOffset = matrixSize;
        matrixSize += (size_t)c.rows() * c.rows();
    }
    eigenvectors.assign(matrixSize, 0.0);
    omega.assign(modes, 0.0);
    modeForce.assign(modes, 0.0);

    // Assemble each component's mass-weighted stiffness and diagonalize it.
    vector<Eigen::MatrixXd> omegaSquared(components.size());
    for (size_t c = 0; c < components.size(); ++c) {
        const int size = (components[c].isotropic ? 1 : 3) * components[c].numParticles;
        omegaSquared[c] = Eigen::MatrixXd::Zero(size, size);
    }
    for (const StiffnessBlock& b : blocks) {
        if (masses[b.i] == 0.0 || masses[b.j] == 0.0)
            throw OpenMMException("the stiff forces act on a massless particle (" +
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
                    throw OpenMMException("the stiff potential has negative curvature (a mass-weighted "
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
