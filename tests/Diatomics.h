#ifndef OPENMM_FLAVORS_TESTS_DIATOMICS_H_
#define OPENMM_FLAVORS_TESTS_DIATOMICS_H_

// Independent diatomics for the stretch-variance tests of the Langevin artificial FLAVOR: unit masses, a stiff bond
// k (r - r0)^2 / 2 (StiffGroup) and a soft tether |x|^2 / 2 on the first atom (SoftGroup).

#include "TestSystems.h"
#include "openmm/Context.h"
#include "openmm/CustomExternalForce.h"
#include "openmm/HarmonicBondForce.h"
#include "openmm/Integrator.h"
#include "openmm/System.h"
#include <cmath>
#include <memory>
#include <random>
#include <vector>

namespace FlavorTests {

struct Diatomics {
    int molecules;
    double k, r0;
    std::unique_ptr<OpenMM::System> system;

    Diatomics(int molecules, double k, double r0) : molecules(molecules), k(k), r0(r0), system(new OpenMM::System()) {
        OpenMM::HarmonicBondForce* bonds = new OpenMM::HarmonicBondForce();
        bonds->setForceGroup(StiffGroup);
        OpenMM::CustomExternalForce* tether = new OpenMM::CustomExternalForce("0.5*(x^2+y^2+z^2)");
        tether->setForceGroup(SoftGroup);
        for (int m = 0; m < molecules; ++m) {
            system->addParticle(1.0);
            system->addParticle(1.0);
            bonds->addBond(2 * m, 2 * m + 1, r0, k);
            tether->addParticle(2 * m);
        }
        system->addForce(bonds);
        system->addForce(tether);
    }

    /**
     * Starts near equilibrium (centres near the tether, random axes, stretches with variance stretchVariance,
     * Maxwell velocities at kT), runs `warmup` steps, then returns the mean over the molecules of each one's average
     * of k (r - r0)^2 over `samples` samples `interval` steps apart, and its standard error.  The molecules are
     * independent, so the standard error over them is a sound error bar.
     */
    std::pair<double, double> stretchEnergy(OpenMM::Context& context, OpenMM::Integrator& integrator, double kT,
                                            double stretchVariance, std::mt19937& generator, int warmup, int samples,
                                            int interval) const {
        std::normal_distribution<double> normal;
        std::vector<OpenMM::Vec3> q(2 * molecules), v(2 * molecules);
        const double sigmaR = std::sqrt(stretchVariance), sigmaV = std::sqrt(kT);
        for (int m = 0; m < molecules; ++m) {
            OpenMM::Vec3 centre(0.1 * normal(generator), 0.1 * normal(generator), 0.1 * normal(generator));
            OpenMM::Vec3 axis(normal(generator), normal(generator), normal(generator));
            axis *= 1.0 / std::sqrt(axis.dot(axis));
            const double length = r0 + sigmaR * normal(generator);
            q[2 * m] = centre - axis * (length / 2);
            q[2 * m + 1] = centre + axis * (length / 2);
            for (int i : {2 * m, 2 * m + 1})
                v[i] = OpenMM::Vec3(sigmaV * normal(generator), sigmaV * normal(generator), sigmaV * normal(generator));
        }
        context.setPositions(q);
        context.setVelocities(v);
        integrator.step(warmup);
        std::vector<double> average(molecules, 0.0);
        for (int s = 0; s < samples; ++s) {
            integrator.step(interval);
            std::vector<OpenMM::Vec3> x = positionsOf(context);
            for (int m = 0; m < molecules; ++m) {
                const OpenMM::Vec3 d = x[2 * m + 1] - x[2 * m];
                const double stretch = std::sqrt(d.dot(d)) - r0;
                average[m] += k * stretch * stretch / samples;
            }
        }
        const BlockMean overMolecules = blockMean(average);
        return {overMolecules.mean, overMolecules.standardError};
    }
};

} // namespace FlavorTests

#endif
