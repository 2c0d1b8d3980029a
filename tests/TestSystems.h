#ifndef OPENMM_FLAVORS_TESTS_TEST_SYSTEMS_H_
#define OPENMM_FLAVORS_TESTS_TEST_SYSTEMS_H_

// Small systems from the FLAVORS paper, in OpenMM's units with unit masses.  Particles move along x only.

#include "FpuChain.h"
#include "openmm/Context.h"
#include "openmm/CustomBondForce.h"
#include "openmm/CustomExternalForce.h"
#include "openmm/HarmonicAngleForce.h"
#include "openmm/HarmonicBondForce.h"
#include "openmm/State.h"
#include "openmm/System.h"
#include "openmm/Vec3.h"
#include <cmath>
#include <vector>

namespace FlavorTests {

constexpr int SoftGroup = FlavorExamples::FpuSoftGroup;
constexpr int StiffGroup = FlavorExamples::FpuStiffGroup;
constexpr int StiffMask = 1 << StiffGroup;

using FlavorExamples::fpuSystem;

/**
 * Positions from the slow and fast coordinates x0_i = (q_2i + q_2i-1)/sqrt2, x1_i = (q_2i - q_2i-1)/sqrt2,
 * repeated for each chain.
 */
inline std::vector<OpenMM::Vec3> fpuPositions(const std::vector<double>& x0, const std::vector<double>& x1,
                                              int chains = 1) {
    std::vector<OpenMM::Vec3> positions;
    for (int c = 0; c < chains; ++c)
        for (size_t i = 0; i < x0.size(); ++i) {
            positions.push_back(OpenMM::Vec3((x0[i] - x1[i]) / std::sqrt(2.0), 0, 0));
            positions.push_back(OpenMM::Vec3((x0[i] + x1[i]) / std::sqrt(2.0), 0, 0));
        }
    return positions;
}

/**
 * Makes particles first + 3m, first + 3m + 1, first + 3m + 2 (m = 0 .. count - 1) of system flexible bent molecules
 * with stiff forces only: bonds from the first particle to the two others of 0.1 nm, 4e5 kJ/mol/nm^2, and the angle
 * at the first of 1.82 rad, 400 kJ/mol/rad^2, all in StiffGroup.
 */
/** A start of one bent molecule of addStiffBentMolecules, its first particle at centre (bonds and angle near rest). */
inline std::vector<OpenMM::Vec3> bentMoleculePositions(OpenMM::Vec3 centre = OpenMM::Vec3()) {
    return {centre, centre + OpenMM::Vec3(0.101, 0.002, 0), centre + OpenMM::Vec3(-0.0245, 0.0968, 0.003)};
}

inline void addStiffBentMolecules(OpenMM::System& system, int first, int count = 1) {
    OpenMM::HarmonicBondForce* bonds = new OpenMM::HarmonicBondForce();
    OpenMM::HarmonicAngleForce* angles = new OpenMM::HarmonicAngleForce();
    for (int m = 0; m < count; ++m) {
        const int o = first + 3 * m;
        bonds->addBond(o, o + 1, 0.1, 4e5);
        bonds->addBond(o, o + 2, 0.1, 4e5);
        angles->addAngle(o + 1, o, o + 2, 1.82, 400);
    }
    bonds->setForceGroup(StiffGroup);
    angles->setForceGroup(StiffGroup);
    system.addForce(bonds);
    system.addForce(angles);
}

/** The linear system (5.1): particle 0 is x (soft potential x^2/2), particle 1 is y (stiff omega^2/2 (y-x)^2). */
inline OpenMM::System* linearSystem(double omega) {
    OpenMM::System* system = new OpenMM::System();
    system->addParticle(1.0);
    system->addParticle(1.0);
    OpenMM::CustomExternalForce* soft = new OpenMM::CustomExternalForce("0.5*x^2");
    soft->addParticle(0);
    soft->setForceGroup(SoftGroup);
    OpenMM::HarmonicBondForce* stiff = new OpenMM::HarmonicBondForce();
    stiff->addBond(0, 1, 0.0, omega * omega);
    stiff->setForceGroup(StiffGroup);
    system->addForce(soft);
    system->addForce(stiff);
    return system;
}

inline std::vector<OpenMM::Vec3> positionsOf(OpenMM::Context& context) {
    return context.getState(OpenMM::State::Positions).getPositions();
}

inline std::vector<OpenMM::Vec3> velocitiesOf(OpenMM::Context& context) {
    return context.getState(OpenMM::State::Velocities).getVelocities();
}

/** |a - b| / |b| over all coordinates. */
inline double relativeDifference(const std::vector<OpenMM::Vec3>& a, const std::vector<OpenMM::Vec3>& b) {
    double diff = 0, norm = 0;
    for (size_t i = 0; i < a.size(); ++i) {
        OpenMM::Vec3 d = a[i] - b[i];
        diff += d.dot(d);
        norm += b[i].dot(b[i]);
    }
    return std::sqrt(diff / norm);
}

/** The mean of block means and its standard error (the blocks taken as independent). */
struct BlockMean {
    double mean, standardError;
};

inline BlockMean blockMean(const std::vector<double>& blocks) {
    const double n = (double)blocks.size();
    double mean = 0, variance = 0;
    for (double x : blocks)
        mean += x / n;
    for (double x : blocks)
        variance += (x - mean) * (x - mean) / (n - 1);
    return {mean, std::sqrt(variance / n)};
}

} // namespace FlavorTests

#endif
