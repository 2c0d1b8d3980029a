#ifndef OPENMM_FLAVORS_EXAMPLES_FPU_CHAIN_H_
#define OPENMM_FLAVORS_EXAMPLES_FPU_CHAIN_H_

// The Fermi-Pasta-Ulam chain of the FLAVORS paper (eq. 6.7), shared by the C++ tests and benchmarks.

#include "openmm/CustomBondForce.h"
#include "openmm/CustomExternalForce.h"
#include "openmm/HarmonicBondForce.h"
#include "openmm/System.h"

namespace FlavorExamples {

constexpr int FpuSoftGroup = 0;
constexpr int FpuStiffGroup = 1;

/**
 * The Fermi-Pasta-Ulam chain (6.7): `chains` independent copies of m stiff harmonic springs (omega^2/4 (q2-q1)^2,
 * force group FpuStiffGroup) joined by soft quartic springs (q3-q2)^4 and to walls at 0 ((q1)^4 and (q_2m)^4), in
 * FpuSoftGroup.  Particle 2m*c + k is q_{k+1} of chain c.
 */
inline OpenMM::System* fpuSystem(int m, double omega, int chains = 1) {
    OpenMM::System* system = new OpenMM::System();
    OpenMM::HarmonicBondForce* stiff = new OpenMM::HarmonicBondForce();
    OpenMM::CustomBondForce* soft = new OpenMM::CustomBondForce("r^4");
    OpenMM::CustomExternalForce* walls = new OpenMM::CustomExternalForce("x^4");
    stiff->setForceGroup(FpuStiffGroup);
    soft->setForceGroup(FpuSoftGroup);
    walls->setForceGroup(FpuSoftGroup);
    for (int c = 0; c < chains; ++c) {
        int first = system->getNumParticles();
        for (int k = 0; k < 2 * m; ++k)
            system->addParticle(1.0);
        for (int i = 0; i < m; ++i)
            stiff->addBond(first + 2 * i, first + 2 * i + 1, 0.0, omega * omega / 2);
        for (int i = 0; i + 1 < m; ++i)
            soft->addBond(first + 2 * i + 1, first + 2 * i + 2);
        walls->addParticle(first);
        walls->addParticle(first + 2 * m - 1);
    }
    system->addForce(stiff);
    system->addForce(soft);
    system->addForce(walls);
    return system;
}

} // namespace FlavorExamples

#endif
