// FlavorIntegrator::separatePlanarAngles: which angles it moves, that the System's energy and forces stay the same,
// and that the artificial FLAVOR freezes none of the moved angles (their terms left behind with force constant 0).

#include "ExpectRejected.h"
#include "FlavorIntegrator.h"
#include "PlatformTest.h"
#include "TestSystems.h"
#include "openmm/Context.h"
#include "openmm/CustomExternalForce.h"
#include "openmm/HarmonicAngleForce.h"
#include "openmm/HarmonicBondForce.h"
#include "openmm/PeriodicTorsionForce.h"
#include "openmm/VerletIntegrator.h"
#include <cmath>
#include <memory>

using namespace FlavorPlugin;
using namespace FlavorTests;
using namespace OpenMM;
using std::vector;

class FlavorPlanarAngles : public PlatformTest {};
INSTANTIATE_ON_ALL_PLATFORMS(FlavorPlanarAngles);

namespace {

constexpr int PlanarGroup = 5;
const double Degree = M_PI / 180.0;

/**
 * Three molecules, bonds and angles in StiffGroup: a planar carbonyl centre C(=O)H2 (angles 121.9 + 121.9 + 116.2 =
 * 360 degrees), a pyramidal NH3 (3 x 107 = 321 degrees, three neighbours but not planar) and a tetrahedral CH4 (six
 * angles), slightly off their equilibrium geometries; a soft improper torsion on the carbonyl and a soft anharmonic
 * tether on every atom.  The carbonyl's angles are the three first of the angle force.
 */
System* threeCentres(vector<Vec3>& positions, bool planarAnglesInOwnForce) {
    System* system = new System();
    HarmonicBondForce* bonds = new HarmonicBondForce();
    HarmonicAngleForce* angles = new HarmonicAngleForce();
    HarmonicAngleForce* planarAngles = new HarmonicAngleForce();
    auto atom = [&](double mass, Vec3 position) {
        positions.push_back(position);
        return system->addParticle(mass);
    };
    // Carbonyl in the xy plane around (0, 0, 0), the centre 0.004 nm out of it.
    const int c = atom(12.0, Vec3(0.0, 0.0, 0.004));
    const int o = atom(16.0, Vec3(0.123, 0.002, 0.0));
    const int h1 = atom(1.0, Vec3(-0.058, 0.094, 0.0));
    const int h2 = atom(1.0, Vec3(-0.056, -0.096, 0.001));
    bonds->addBond(c, o, 0.1229, 4.8e5);
    bonds->addBond(c, h1, 0.109, 2.8e5);
    bonds->addBond(c, h2, 0.109, 2.8e5);
    HarmonicAngleForce* carbonyl = planarAnglesInOwnForce ? planarAngles : angles;
    carbonyl->addAngle(o, c, h1, 121.9 * Degree, 400.0);
    carbonyl->addAngle(o, c, h2, 121.9 * Degree, 400.0);
    carbonyl->addAngle(h1, c, h2, 116.2 * Degree, 300.0);
    // NH3 around (1, 0, 0).
    const Vec3 n0(1.0, 0.0, 0.0);
    const int n = atom(14.0, n0);
    int hn[3];
    for (int i = 0; i < 3; ++i) {
        const double phi = 2 * M_PI * i / 3 + 0.05 * i;
        hn[i] = atom(1.0, n0 + Vec3(0.095 * std::cos(phi), 0.095 * std::sin(phi), -0.038));
        bonds->addBond(n, hn[i], 0.101, 3.6e5);
    }
    for (int i = 0; i < 3; ++i)
        angles->addAngle(hn[i], n, hn[(i + 1) % 3], 107.0 * Degree, 350.0);
    // CH4 around (0, 1, 0).
    const Vec3 m0(0.0, 1.0, 0.0);
    const int m = atom(12.0, m0);
    const double s = 0.109 / std::sqrt(3.0);
    const Vec3 tetrahedron[4] = {Vec3(s, s, s), Vec3(s, -s, -s), Vec3(-s, s, -s), Vec3(-s, -s, s * 1.05)};
    int hm[4];
    for (int i = 0; i < 4; ++i) {
        hm[i] = atom(1.0, m0 + tetrahedron[i]);
        bonds->addBond(m, hm[i], 0.109, 2.8e5);
    }
    for (int i = 0; i < 4; ++i)
        for (int j = i + 1; j < 4; ++j)
            angles->addAngle(hm[i], m, hm[j], 109.47 * Degree, 330.0);
    bonds->setForceGroup(StiffGroup);
    angles->setForceGroup(StiffGroup);
    system->addForce(bonds);
    system->addForce(angles);
    PeriodicTorsionForce* improper = new PeriodicTorsionForce();
    improper->addTorsion(o, h1, c, h2, 2, M_PI, 4.6);
    improper->setForceGroup(SoftGroup);
    system->addForce(improper);
    CustomExternalForce* tether = new CustomExternalForce("0.5*(x^2+y^2+z^2) + 2*(x^4+y^4+z^4)");
    tether->setForceGroup(SoftGroup);
    for (int i = 0; i < system->getNumParticles(); ++i)
        tether->addParticle(i);
    system->addForce(tether);
    if (planarAnglesInOwnForce) {
        planarAngles->setForceGroup(PlanarGroup);
        system->addForce(planarAngles);
    } else {
        delete planarAngles;
    }
    return system;
}

State stateOf(const System& system, const vector<Vec3>& positions, Platform& platform) {
    VerletIntegrator integrator(0.001);
    Context context(system, integrator, platform);
    context.setPositions(positions);
    return context.getState(State::Energy | State::Forces);
}

} // namespace

TEST_P(FlavorPlanarAngles, MovesTheAnglesOfPlanarCentresOnlyAndKeepsEnergyAndForces) {
    vector<Vec3> positions;
    std::unique_ptr<System> system(threeCentres(positions, false));
    const State before = stateOf(*system, positions, platform());
    const int forcesBefore = system->getNumForces();
    ASSERT_EQ(3, FlavorIntegrator::separatePlanarAngles(*system, PlanarGroup));
    ASSERT_EQ(forcesBefore + 1, system->getNumForces());
    const HarmonicAngleForce& planar = dynamic_cast<const HarmonicAngleForce&>(system->getForce(forcesBefore));
    EXPECT_EQ(PlanarGroup, planar.getForceGroup());
    ASSERT_EQ(3, planar.getNumAngles());
    const HarmonicAngleForce& original = dynamic_cast<const HarmonicAngleForce&>(system->getForce(1));
    ASSERT_EQ(3 + 3 + 6, original.getNumAngles());
    for (int a = 0; a < original.getNumAngles(); ++a) {
        int p1, p2, p3;
        double theta, k;
        original.getAngleParameters(a, p1, p2, p3, theta, k);
        EXPECT_EQ(a < 3, k == 0.0) << "angle " << a; // the carbonyl's, and only those
        if (a < 3) {
            int q1, q2, q3;
            double theta2, k2;
            planar.getAngleParameters(a, q1, q2, q3, theta2, k2);
            EXPECT_EQ(p1, q1);
            EXPECT_EQ(p2, q2);
            EXPECT_EQ(p3, q3);
            EXPECT_EQ(theta, theta2);
            EXPECT_GT(k2, 0.0);
        }
    }
    const State after = stateOf(*system, positions, platform());
    EXPECT_NEAR(before.getPotentialEnergy(), after.getPotentialEnergy(), 1e-9 * std::abs(before.getPotentialEnergy()));
    EXPECT_LT(relativeDifference(after.getForces(), before.getForces()), 1e-9);
    // Moved angles are not moved again; a lower threshold takes the pyramidal NH3 too.
    EXPECT_EQ(0, FlavorIntegrator::separatePlanarAngles(*system, PlanarGroup));
    EXPECT_EQ(3, FlavorIntegrator::separatePlanarAngles(*system, PlanarGroup, 320.0 * Degree));
    EXPECT_EQ(forcesBefore + 2, system->getNumForces());
}

TEST_P(FlavorPlanarAngles, BadArgumentsAreRejectedAndLeaveTheSystemUnchanged) {
    vector<Vec3> positions;
    std::unique_ptr<System> system(threeCentres(positions, false));
    const int forces = system->getNumForces();
    expectRejected([&] { FlavorIntegrator::separatePlanarAngles(*system, 32); },
                   {"separatePlanarAngles", "group = 32", "0 to 31"});
    expectRejected([&] { FlavorIntegrator::separatePlanarAngles(*system, -1); }, {"group = -1", "0 to 31"});
    expectRejected([&] { FlavorIntegrator::separatePlanarAngles(*system, 3, 7.0); },
                   {"minAngleSum = 7", "at most 2 pi"});
    expectRejected([&] { FlavorIntegrator::separatePlanarAngles(*system, 3, NAN); }, {"minAngleSum = nan"});
    EXPECT_EQ(forces, system->getNumForces());
    double theta, k;
    int p1, p2, p3;
    dynamic_cast<const HarmonicAngleForce&>(system->getForce(1)).getAngleParameters(0, p1, p2, p3, theta, k);
    EXPECT_EQ(400.0, k);
}

// The artificial FLAVOR on the System whose planar angles were separated (their terms left in the stiff angle force
// with force constant 0) takes the same steps as on the System built with those angles in the soft group from the
// start: a term with force constant 0 adds no frozen distance.  If it did, the carbonyl's 1-3 distances would be held
// through the frozen stage in one run and not in the other.
TEST_P(FlavorPlanarAngles, TheArtificialFlavorFreezesNoneOfTheSeparatedAngles) {
    vector<Vec3> positions, positionsBuilt;
    std::unique_ptr<System> separated(threeCentres(positions, false));
    std::unique_ptr<System> built(threeCentres(positionsBuilt, true));
    ASSERT_EQ(3, FlavorIntegrator::separatePlanarAngles(*separated, PlanarGroup));
    vector<vector<Vec3>> trajectories;
    for (System* system : {separated.get(), built.get()}) {
        FlavorIntegrator integrator(0.004, 0.001, StiffMask);
        integrator.setAveraging(FlavorIntegrator::ArtificialProjected);
        integrator.setConstraintTolerance(1e-10);
        Context context(*system, integrator, platform(), properties(1));
        context.setPositions(positions);
        vector<Vec3> velocities(positions.size());
        for (size_t i = 0; i < velocities.size(); ++i)
            velocities[i] = Vec3(std::sin(1.0 + i), std::cos(2.0 * i), std::sin(0.5 * i + 0.3)) * 2.0;
        context.setVelocities(velocities);
        integrator.step(50);
        trajectories.push_back(positionsOf(context));
        const State state = context.getState(State::Positions);
        const vector<Vec3>& q = state.getPositions();
        // The carbonyl's H-H distance (its third 1-3 distance) moved: it was not frozen.
        EXPECT_GT(std::abs(std::sqrt((q[2] - q[3]).dot(q[2] - q[3])) -
                           std::sqrt((positions[2] - positions[3]).dot(positions[2] - positions[3]))),
                  1e-4);
    }
    EXPECT_LT(relativeDifference(trajectories[0], trajectories[1]), 1e-12);
}
