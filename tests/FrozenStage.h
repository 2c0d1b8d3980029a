#ifndef OPENMM_FLAVORS_TESTS_FROZEN_STAGE_H_
#define OPENMM_FLAVORS_TESTS_FROZEN_STAGE_H_

// The artificial FLAVOR's frozen drift isolated: one step without soft forces, the microstep computed here.

#include "FlavorIntegrator.h"
#include "TestSystems.h"
#include "openmm/Context.h"
#include "openmm/CustomExternalForce.h"
#include "openmm/Platform.h"
#include "openmm/VerletIntegrator.h"
#include <cmath>
#include <map>
#include <string>
#include <vector>

namespace FlavorTests {

inline double rate(const std::vector<OpenMM::Vec3>& q, const std::vector<OpenMM::Vec3>& v, int i, int j) {
    OpenMM::Vec3 r = q[i] - q[j];
    return r.dot(v[i] - v[j]) / std::sqrt(r.dot(r));
}

inline double distance(const std::vector<OpenMM::Vec3>& q, int i, int j) {
    OpenMM::Vec3 r = q[i] - q[j];
    return std::sqrt(r.dot(r));
}

/** The states around the frozen drift of one SymplecticEuler artificial step without soft forces. */
struct FrozenStage {
    // After the microstep D(tau) K_stiff(tau), computed here.
    std::vector<OpenMM::Vec3> q1, v1;
    // After the integrator's step: the microstep, then the frozen drift over delta - tau.
    std::vector<OpenMM::Vec3> q2, v2;
};

/** Runs one step of FlavorIntegrator(delta, tau) on system (its stiff forces in StiffMask; a zero soft force is added
 * in group 3) from q0, v0, and computes the microstep independently. */
inline FrozenStage runFrozenStage(OpenMM::System& system, const std::vector<OpenMM::Vec3>& q0,
                                  const std::vector<OpenMM::Vec3>& v0, double delta, double tau, double tolerance,
                                  OpenMM::Platform& platform, const std::map<std::string, std::string>& properties) {
    const int n = system.getNumParticles();
    FrozenStage stage;
    stage.q1.resize(n);
    stage.v1.resize(n);
    for (int i = 0; i < n; ++i)
        stage.q1[i] = q0[i] + v0[i] * tau;
    {
        OpenMM::VerletIntegrator probe(0.001);
        OpenMM::Context forces(system, probe, platform, properties);
        forces.setPositions(stage.q1);
        std::vector<OpenMM::Vec3> f = forces.getState(OpenMM::State::Forces, false, StiffMask).getForces();
        for (int i = 0; i < n; ++i)
            stage.v1[i] = v0[i] + f[i] * (tau / system.getParticleMass(i));
    }
    // A FLAVOR System needs a soft force: a zero one, in a group of its own.
    OpenMM::CustomExternalForce* zeroSoftForce = new OpenMM::CustomExternalForce("0");
    zeroSoftForce->setForceGroup(3);
    system.addForce(zeroSoftForce);
    FlavorPlugin::FlavorIntegrator integrator(delta, tau, StiffMask);
    integrator.setScheme(FlavorPlugin::FlavorIntegrator::SymplecticEuler);
    integrator.setAveraging(FlavorPlugin::FlavorIntegrator::Artificial);
    integrator.setIntegrationForceGroups(StiffMask | (1 << 3));
    integrator.setConstraintTolerance(tolerance);
    OpenMM::Context context(system, integrator, platform, properties);
    context.setPositions(q0);
    context.setVelocities(v0);
    integrator.step(1);
    stage.q2 = positionsOf(context);
    stage.v2 = velocitiesOf(context);
    return stage;
}

} // namespace FlavorTests

#endif
