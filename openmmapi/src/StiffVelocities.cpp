#include "internal/StiffVelocities.h"
#include "internal/PhysicalConstants.h"
#include "internal/UnionFind.h"
#include "openmm/CustomBondForce.h"
#include "openmm/DrudeForce.h"
#include "openmm/HarmonicBondForce.h"
#include "openmm/System.h"
#include <cmath>
#include <random>

using namespace FlavorPlugin;
using namespace OpenMM;
using std::vector;

namespace {

/** The particle pairs that the two-particle terms of the stiff-group forces link. */
vector<std::pair<int, int>> stiffPairs(const System& system, int stiffGroups) {
    vector<std::pair<int, int>> pairs;
    for (int f = 0; f < system.getNumForces(); ++f) {
        const Force& force = system.getForce(f);
        if ((stiffGroups & (1 << force.getForceGroup())) == 0)
            continue;
        if (auto* bonds = dynamic_cast<const HarmonicBondForce*>(&force)) {
            for (int b = 0; b < bonds->getNumBonds(); ++b) {
                int p1, p2;
                double length, k;
                bonds->getBondParameters(b, p1, p2, length, k);
                pairs.emplace_back(p1, p2);
            }
        } else if (auto* custom = dynamic_cast<const CustomBondForce*>(&force)) {
            for (int b = 0; b < custom->getNumBonds(); ++b) {
                int p1, p2;
                vector<double> parameters;
                custom->getBondParameters(b, p1, p2, parameters);
                pairs.emplace_back(p1, p2);
            }
        } else if (auto* drude = dynamic_cast<const DrudeForce*>(&force)) {
            for (int d = 0; d < drude->getNumParticles(); ++d) {
                int particle, parent, p2, p3, p4;
                double charge, polarizability, aniso12, aniso34;
                drude->getParticleParameters(d, particle, parent, p2, p3, p4, charge, polarizability, aniso12, aniso34);
                pairs.emplace_back(particle, parent);
            }
        }
    }
    return pairs;
}

} // namespace

vector<Vec3> FlavorPlugin::velocitiesWithStiffTemperature(const System& system, int stiffGroups, double temperature,
                                                          double stiffTemperature, int seed) {
    const int n = system.getNumParticles();
    vector<double> mass(n);
    vector<int> parent(n);
    for (int i = 0; i < n; ++i) {
        mass[i] = system.getParticleMass(i);
        parent[i] = i;
    }
    for (const auto& pair : stiffPairs(system, stiffGroups))
        if (mass[pair.first] > 0 && mass[pair.second] > 0)
            parent[findRoot(parent, pair.first)] = findRoot(parent, pair.second);

    std::mt19937 generator(static_cast<unsigned>(seed));
    std::normal_distribution<double> normal(0.0, 1.0);
    const auto draw = [&](double kT, double m) {
        return Vec3(normal(generator), normal(generator), normal(generator)) * std::sqrt(kT / m);
    };
    const double kT = BoltzmannKJPerMolK * temperature, kTStiff = BoltzmannKJPerMolK * stiffTemperature;
    // Each particle at the stiff temperature first (particles alone in their component keep it at temperature below).
    vector<Vec3> velocity(n, Vec3());
    vector<Vec3> momentum(n, Vec3());
    vector<double> componentMass(n, 0.0);
    vector<int> size(n, 0);
    for (int i = 0; i < n; ++i) {
        if (mass[i] <= 0)
            continue;
        const int root = findRoot(parent, i);
        velocity[i] = draw(kTStiff, mass[i]);
        momentum[root] += velocity[i] * mass[i];
        componentMass[root] += mass[i];
        ++size[root];
    }
    // Then each component's centre of mass replaced by one drawn at temperature.
    vector<Vec3> centre(n, Vec3());
    for (int root = 0; root < n; ++root)
        if (size[root] > 0)
            centre[root] = draw(kT, componentMass[root]) - momentum[root] / componentMass[root];
    for (int i = 0; i < n; ++i)
        if (mass[i] > 0)
            velocity[i] += centre[findRoot(parent, i)];
    return velocity;
}
