// Constraints, virtual sites, force groups, force-evaluation counts, and agreement between platforms and thread
// counts.

#include "CountingForce.h"
#include "FlavorIntegrator.h"
#include "PlatformTest.h"
#include "TestSystems.h"
#include "openmm/Context.h"
#include "openmm/NonbondedForce.h"
#include "openmm/VirtualSite.h"
#include <memory>

using namespace FlavorPlugin;
using namespace FlavorTests;
using namespace OpenMM;
using std::vector;

class FlavorSystems : public PlatformTest {};
INSTANTIATE_ON_ALL_PLATFORMS(FlavorSystems);

TEST_P(FlavorSystems, ForceEvaluationsPerStepAreTheMinimum) {
    // SymplecticEuler needs all groups once and the soft groups once per step; Verlet all groups once (its last
    // kick is the next step's first) and the soft groups twice.
    std::unique_ptr<System> system(fpuSystem(3, 50.0));
    CountingForce* soft = new CountingForce();
    CountingForce* stiff = new CountingForce();
    stiff->setForceGroup(StiffGroup);
    system->addForce(soft);
    system->addForce(stiff);
    struct Expected {
        FlavorIntegrator::Scheme scheme;
        int soft, stiff;
    };
    for (Expected e : {Expected{FlavorIntegrator::SymplecticEuler, 2, 1}, Expected{FlavorIntegrator::Verlet, 3, 1}}) {
        FlavorIntegrator integrator(0.01, 0.001, StiffMask);
        integrator.setScheme(e.scheme);
        Context context(*system, integrator, platform(), properties());
        context.setPositions(fpuPositions({1, 0, 0}, {0.02, 0, 0}));
        integrator.step(1);
        int soft0 = soft->getCount(), stiff0 = stiff->getCount();
        integrator.step(100);
        EXPECT_EQ(100 * e.soft, soft->getCount() - soft0) << "scheme " << e.scheme;
        EXPECT_EQ(100 * e.stiff, stiff->getCount() - stiff0) << "scheme " << e.scheme;
        // Setting positions invalidates the cached forces: the next step evaluates them again.
        context.setPositions(fpuPositions({1, 0, 0}, {0.02, 0, 0}));
        soft0 = soft->getCount();
        integrator.step(1);
        EXPECT_EQ(e.scheme == FlavorIntegrator::Verlet ? 4 : 2, soft->getCount() - soft0);
    }
}

TEST_P(FlavorSystems, ArtificialFlavorEvaluatesTheSoftForcesOncePerStep) {
    // The soft kicks that end a step and begin the next act at the same positions.  The stiff kicks around the
    // microstep's drift need two stiff evaluations (Verlet) or one (SymplecticEuler, eq. (2.13)); the exact fast
    // flow needs none.
    std::unique_ptr<System> system(fpuSystem(3, 50.0));
    CountingForce* soft = new CountingForce();
    CountingForce* stiff = new CountingForce();
    stiff->setForceGroup(StiffGroup);
    system->addForce(soft);
    system->addForce(stiff);
    struct Expected {
        FlavorIntegrator::Scheme scheme;
        FlavorIntegrator::Averaging averaging;
        bool exact;
        int soft, stiff;
    };
    for (Expected e : {Expected{FlavorIntegrator::SymplecticEuler, FlavorIntegrator::Artificial, false, 1, 1},
                       Expected{FlavorIntegrator::Verlet, FlavorIntegrator::Artificial, false, 1, 2},
                       Expected{FlavorIntegrator::Verlet, FlavorIntegrator::ArtificialProjected, false, 1, 2},
                       Expected{FlavorIntegrator::Verlet, FlavorIntegrator::ArtificialProjected, true, 1, 0}}) {
        FlavorIntegrator integrator(0.01, 0.001, StiffMask);
        integrator.setScheme(e.scheme);
        integrator.setAveraging(e.averaging);
        integrator.setExactFastFlow(e.exact);
        Context context(*system, integrator, platform(), properties());
        context.setPositions(fpuPositions({1, 0, 0}, {0.02, 0, 0}));
        integrator.step(1);
        const int soft0 = soft->getCount(), stiff0 = stiff->getCount();
        integrator.step(100);
        EXPECT_EQ(100 * e.soft, soft->getCount() - soft0) << "scheme " << e.scheme << " averaging " << e.averaging;
        EXPECT_EQ(100 * e.stiff, stiff->getCount() - stiff0) << "scheme " << e.scheme << " averaging " << e.averaging;
    }
}

TEST_P(FlavorSystems, AForceOutsideTheStiffGroupsActsAsSoft) {
    // The soft walls moved to group 5 (neither group 0 nor stiff): the trajectory must be identical.
    std::unique_ptr<System> reference(fpuSystem(3, 50.0)), moved(fpuSystem(3, 50.0));
    moved->getForce(2).setForceGroup(5);
    vector<Vec3> q0 = fpuPositions({1, 0.3, 0}, {0.02, 0, 0.01});
    vector<vector<Vec3>> finals;
    for (System* system : {reference.get(), moved.get()}) {
        FlavorIntegrator integrator(0.01, 0.001, StiffMask);
        Context context(*system, integrator, platform(), properties());
        context.setPositions(q0);
        integrator.step(200);
        finals.push_back(positionsOf(context));
    }
    EXPECT_EQ(0.0, relativeDifference(finals[1], finals[0]));
    // ...and it does act: without the walls the trajectory differs.
    std::unique_ptr<System> noWalls(fpuSystem(3, 50.0));
    noWalls->removeForce(2);
    FlavorIntegrator integrator(0.01, 0.001, StiffMask);
    Context context(*noWalls, integrator, platform(), properties());
    context.setPositions(q0);
    integrator.step(200);
    EXPECT_GT(relativeDifference(positionsOf(context), finals[0]), 1e-3);
}

TEST_P(FlavorSystems, ConstraintsHoldAndVirtualSitesFollowTheirParents) {
    // A rigid diatomic (constraint 0-1) tied to particle 2 by a stiff spring and to the origin by a soft one, with a
    // virtual site at the midpoint of 0 and 1.
    System system;
    for (int i = 0; i < 3; ++i)
        system.addParticle(1.0 + i);
    system.addParticle(0.0);
    system.setVirtualSite(3, new TwoParticleAverageSite(0, 1, 0.5, 0.5));
    system.addConstraint(0, 1, 0.15);
    HarmonicBondForce* stiff = new HarmonicBondForce();
    stiff->addBond(1, 2, 0.1, 1e5);
    stiff->setForceGroup(StiffGroup);
    CustomExternalForce* soft = new CustomExternalForce("0.5*(x^2+y^2+z^2)");
    for (int i = 0; i < 3; ++i)
        soft->addParticle(i);
    system.addForce(stiff);
    system.addForce(soft);
    for (auto scheme : {FlavorIntegrator::SymplecticEuler, FlavorIntegrator::Verlet}) {
        FlavorIntegrator integrator(0.005, 0.0005, StiffMask);
        integrator.setScheme(scheme);
        integrator.setConstraintTolerance(1e-8);
        Context context(system, integrator, platform(), properties());
        context.setPositions({Vec3(0, 0, 0), Vec3(0.15, 0, 0), Vec3(0.25, 0.02, 0), Vec3()});
        context.setVelocities({Vec3(0, 0.3, 0), Vec3(0.1, 0, 0.2), Vec3(0, 0, 0), Vec3()});
        for (int block = 0; block < 20; ++block) {
            integrator.step(10);
            State state = context.getState(State::Positions | State::Velocities);
            const vector<Vec3>& q = state.getPositions();
            const vector<Vec3>& v = state.getVelocities();
            Vec3 bond = q[1] - q[0];
            EXPECT_NEAR(0.15, std::sqrt(bond.dot(bond)), 1e-7) << "scheme " << scheme;
            // A Verlet step ends with a kick, after which velocities are constrained: they satisfy the constraint's
            // time derivative.  A SymplecticEuler step ends with a constrained drift, whose velocity is the chord
            // (x' - x)/h, as for OpenMM's VerletIntegrator.
            if (scheme == FlavorIntegrator::Verlet) {
                EXPECT_NEAR(0.0, bond.dot(v[1] - v[0]), 1e-8) << "scheme " << scheme;
            }
            Vec3 site = (q[0] + q[1]) * 0.5 - q[3];
            EXPECT_NEAR(0.0, std::sqrt(site.dot(site)), 1e-12) << "scheme " << scheme;
        }
        // The system moved.
        EXPECT_GT(std::abs(positionsOf(context)[2][1] - 0.02), 1e-4);
    }
}

TEST_P(FlavorSystems, LargeSystemsAgreeWithReferenceAndAcrossThreadCounts) {
    // 2400 particles: large enough that the CPU platform splits every pass between threads.  Bonded forces are
    // double precision on both platforms; a NonbondedForce between chain ends adds the CPU platform's single
    // precision: the nonbonded force changes the positions by ~3e-5 relative, and single precision changes that by
    // ~1e-5 relative, so CPU agrees with Reference to 1e-8 (observed 3e-10).  Across thread counts only the order in
    // which the platform sums per-thread forces changes: agreement to rounding.
    const int chains = 400;
    std::unique_ptr<System> system(fpuSystem(3, 50.0, chains));
    NonbondedForce* nonbonded = new NonbondedForce();
    nonbonded->setNonbondedMethod(NonbondedForce::CutoffNonPeriodic);
    nonbonded->setCutoffDistance(0.5);
    for (int i = 0; i < system->getNumParticles(); ++i)
        nonbonded->addParticle(i % 2 == 0 ? 0.02 : -0.02, 0.05, 0.1);
    for (int i = 0; i < system->getNumParticles(); ++i)
        if (i % 6 != 5)
            nonbonded->addException(i, i + 1, 0.0, 1.0, 0.0); // bonded neighbours
    system->addForce(nonbonded);
    vector<Vec3> q0 = fpuPositions({1, 0.3, -0.2}, {0.02, 0, 0.01}, chains);
    for (int i = 0; i < (int)q0.size(); ++i)
        q0[i][1] = 0.3 * (i / 6) + 0.001 * (i % 6);
    auto run = [&](Platform& p, std::map<std::string, std::string> props) {
        FlavorIntegrator integrator(0.01, 0.001, StiffMask);
        Context context(*system, integrator, p, props);
        context.setPositions(q0);
        integrator.step(20);
        return positionsOf(context);
    };
    vector<Vec3> reference = run(Platform::getPlatformByName("Reference"), {});
    vector<Vec3> oneThread = run(platform(), properties(1));
    // CPU: single-precision nonbonded forces; OpenCL: fixed-point force sums (measured 1.5e-12).
    EXPECT_LE(relativeDifference(oneThread, reference), isCpu() ? 1e-8 : isGpu() ? 1e-10 : 0.0);
    if (isCpu()) {
        vector<Vec3> twoThreads = run(platform(), properties(2));
        EXPECT_LE(relativeDifference(twoThreads, oneThread), 1e-12);
    }
    // The nonbonded force matters: without it the trajectory is different.
    system->removeForce(system->getNumForces() - 1);
    EXPECT_GT(relativeDifference(run(Platform::getPlatformByName("Reference"), {}), reference), 1e-5);
}
