// FrozenDistances on rigid clusters: flexible water molecules with their O-H bonds and H-H distance frozen (one with
// an O-H bond a System constraint instead).  Their drift keeps B where it starts and leaves out the force of the
// normal momenta, which is normal to the manifold of a rigid cluster; the drift and kick that refactorize and kick
// along the way (the general clusters' path) must give the same motion to the constraint tolerance.

#include "FrozenDistances.h"
#include "openmm/System.h"
#include "openmm/Vec3.h"
#include <algorithm>
#include <cmath>
#include <gtest/gtest.h>
#include <random>
#include <utility>
#include <vector>

using namespace FlavorPlugin;
using OpenMM::System;
using OpenMM::Vec3;
using std::pair;
using std::vector;

namespace {

Vec3 rotated(const Vec3& v, const Vec3& axis, double angle) {
    // Rodrigues' rotation of v about the unit axis.
    return v * std::cos(angle) + axis.cross(v) * std::sin(angle) + axis * (axis.dot(v) * (1 - std::cos(angle)));
}

struct Waters {
    System system;
    vector<pair<int, int>> frozen;
    vector<Vec3> positions, velocities;
    vector<double> inverseMasses;
};

/** numWaters water molecules 1 nm apart, randomly turned and slightly bent; the last one's first O-H bond a System
 * constraint, every other O-H and H-H distance frozen. */
Waters makeWaters(int numWaters, std::mt19937& random) {
    std::normal_distribution<double> gauss;
    std::uniform_real_distribution<double> uniform(0.0, 1.0);
    Waters w;
    for (int m = 0; m < numWaters; ++m) {
        const int o = w.system.addParticle(15.999), h1 = w.system.addParticle(1.008), h2 = w.system.addParticle(1.008);
        const double angle = 1.824 + 0.05 * gauss(random), bond1 = 0.0957 + 0.002 * gauss(random),
                     bond2 = 0.0957 + 0.002 * gauss(random);
        Vec3 axis(gauss(random), gauss(random), gauss(random));
        axis /= std::sqrt(axis.dot(axis));
        const double turn = 6.283185307179586 * uniform(random);
        const Vec3 centre(m % 2, (m / 2) % 2, m / 4);
        w.positions.push_back(centre);
        w.positions.push_back(centre + rotated(Vec3(bond1, 0, 0), axis, turn));
        w.positions.push_back(centre + rotated(Vec3(bond2 * std::cos(angle), bond2 * std::sin(angle), 0), axis, turn));
        if (m == numWaters - 1)
            w.system.addConstraint(o, h1, bond1);
        else
            w.frozen.emplace_back(o, h1);
        w.frozen.emplace_back(o, h2);
        w.frozen.emplace_back(h1, h2);
    }
    for (int i = 0; i < w.system.getNumParticles(); ++i) {
        const double mass = w.system.getParticleMass(i);
        w.inverseMasses.push_back(1.0 / mass);
        const double speed = std::sqrt(2.494 / mass);
        w.velocities.emplace_back(speed * gauss(random), speed * gauss(random), speed * gauss(random));
    }
    return w;
}

} // namespace

TEST(FrozenDistances, RigidClustersDriftAsTheGeneralPathDoes) {
    std::mt19937 random(23);
    std::normal_distribution<double> gauss;
    Waters w = makeWaters(6, random);
    const double tolerance = 1e-12, h = 0.006;
    FrozenDistances shortcut(w.system, w.frozen, w.positions), general(w.system, w.frozen, w.positions);
    general.setRigidShortcut(false);
    ASSERT_EQ(6, shortcut.getNumClusters());
    ASSERT_EQ(17, shortcut.getNumFrozen());
    SerialLoop loop;
    vector<Vec3> q1 = w.positions, v1 = w.velocities, q2 = w.positions, v2 = w.velocities;
    vector<Vec3> forces(q1.size());
    double largestVelocity = 0.0;
    for (int round = 0; round < 10; ++round) {
        // A random flexible move between the drifts: the molecules change shape, as in a microstep.
        for (size_t i = 0; i < q1.size(); ++i) {
            const Vec3 move(1e-3 * gauss(random), 1e-3 * gauss(random), 1e-3 * gauss(random));
            q1[i] += move;
            q2[i] += move;
            forces[i] = Vec3(100 * gauss(random), 100 * gauss(random), 100 * gauss(random));
        }
        // The drift, the kick and the drift again; the second drift holds the frozen distances where it starts.
        vector<double> lengths;
        for (FrozenDistances* frozen : {&shortcut, &general}) {
            vector<Vec3>& q = frozen == &shortcut ? q1 : q2;
            vector<Vec3>& v = frozen == &shortcut ? v1 : v2;
            frozen->drift(q, v, w.inverseMasses, h, tolerance, true, loop);
            frozen->kick(q, v, forces, w.inverseMasses, 0.5 * h, tolerance, true, loop);
            if (frozen == &shortcut)
                for (const pair<int, int>& p : w.frozen)
                    lengths.push_back(std::sqrt((q[p.first] - q[p.second]).dot(q[p.first] - q[p.second])));
            frozen->drift(q, v, w.inverseMasses, h, tolerance, true, loop);
        }
        for (size_t f = 0; f < w.frozen.size(); ++f) {
            const Vec3 r = q1[w.frozen[f].first] - q1[w.frozen[f].second];
            EXPECT_NEAR(lengths[f], std::sqrt(r.dot(r)), 1e-11) << "round " << round << " distance " << f;
        }
        for (size_t i = 0; i < q1.size(); ++i) {
            const Vec3 dq = q1[i] - q2[i], dv = v1[i] - v2[i];
            EXPECT_LT(std::sqrt(dq.dot(dq)), 1e-11) << "round " << round << " particle " << i;
            EXPECT_LT(std::sqrt(dv.dot(dv)), 1e-9) << "round " << round << " particle " << i;
            largestVelocity = std::max(largestVelocity, std::sqrt(v1[i].dot(v1[i])));
        }
    }
    // The molecules moved (thermal speeds of about 1.6 nm/ps for hydrogen).
    EXPECT_GT(largestVelocity, 0.5);
    // The System's O-H constraint at its length.
    int p1, p2;
    double length;
    w.system.getConstraintParameters(0, p1, p2, length);
    const Vec3 r = q1[p1] - q1[p2];
    EXPECT_NEAR(length, std::sqrt(r.dot(r)), 1e-9);
}
