// getConfigurationWarnings(): a nonbonded force in a stiff group of the nonintrusive FLAVOR (the bitmask 1 given for
// group 1), a mesostep beyond the measured ones with frozen angles, and a SIM's stiff mode in a resonance band are
// described; correct configurations give nothing.

#include "FlavorIntegrator.h"
#include "PlatformTest.h"
#include "StochasticImpulseIntegrator.h"
#include "openmm/Context.h"
#include "openmm/CustomExternalForce.h"
#include "openmm/HarmonicAngleForce.h"
#include "openmm/HarmonicBondForce.h"
#include "openmm/NonbondedForce.h"
#include "openmm/PeriodicTorsionForce.h"
#include <cmath>
#include <memory>
#include <string>
#include <vector>

using namespace FlavorPlugin;
using namespace OpenMM;
using std::string;
using std::vector;

class FlavorConfigurationWarnings : public PlatformTest {};
INSTANTIATE_ON_ALL_PLATFORMS(FlavorConfigurationWarnings);

namespace {

constexpr int StiffGroup = 1;

/** A four-atom chain: bonds and angles in StiffGroup, a soft tether in group 0, and a soft torsion if asked. */
System* chain(bool torsion) {
    System* system = new System();
    for (int i = 0; i < 4; ++i)
        system->addParticle(12.0);
    HarmonicBondForce* bonds = new HarmonicBondForce();
    HarmonicAngleForce* angles = new HarmonicAngleForce();
    for (int i = 0; i < 3; ++i)
        bonds->addBond(i, i + 1, 0.15, 2.5e5);
    for (int i = 0; i < 2; ++i)
        angles->addAngle(i, i + 1, i + 2, 1.9, 400.0);
    bonds->setForceGroup(StiffGroup);
    angles->setForceGroup(StiffGroup);
    system->addForce(bonds);
    system->addForce(angles);
    CustomExternalForce* tether = new CustomExternalForce("x^2 + y^2 + z^2");
    for (int i = 0; i < 4; ++i)
        tether->addParticle(i, {});
    system->addForce(tether);
    if (torsion) {
        PeriodicTorsionForce* torsions = new PeriodicTorsionForce();
        torsions->addTorsion(0, 1, 2, 3, 3, 0.0, 1.0);
        system->addForce(torsions);
    }
    return system;
}

vector<string> warningsOf(const System& system, FlavorIntegrator& integrator, Platform& platform) {
    Context context(const_cast<System&>(system), integrator, platform);
    return integrator.getConfigurationWarnings();
}

void expectContains(const string& text, const vector<string>& fragments) {
    for (const string& fragment : fragments)
        EXPECT_NE(string::npos, text.find(fragment)) << "'" << fragment << "' not in: " << text;
}

} // namespace

TEST_P(FlavorConfigurationWarnings, ANonbondedForceInAStiffGroupOfTheNonintrusiveFlavorIsNamedWithTheFix) {
    std::unique_ptr<System> system(new System());
    system->addParticle(16.0);
    system->addParticle(1.0);
    HarmonicBondForce* bond = new HarmonicBondForce();
    bond->addBond(0, 1, 0.1, 4e5);
    bond->setForceGroup(StiffGroup);
    system->addForce(bond);
    NonbondedForce* nonbonded = new NonbondedForce();
    nonbonded->addParticle(-0.8, 0.3, 0.6);
    nonbonded->addParticle(0.4, 0.1, 0.1);
    nonbonded->addException(0, 1, 0.0, 1.0, 0.0);
    system->addForce(nonbonded);

    FlavorIntegrator bitmaskOne(0.002, 0.0005, 1);
    const vector<string> warnings = warningsOf(*system, bitmaskOne, platform());
    ASSERT_EQ(1u, warnings.size());
    expectContains(warnings[0], {"force 1 (NonbondedForce, force group 0)", "stiffGroups = 1", "{0}", "0.25",
                                 "pass {1}", "1 << 1 = 2"});
    FlavorIntegrator groupOne(0.002, 0.0005, 1 << StiffGroup);
    EXPECT_TRUE(warningsOf(*system, groupOne, platform()).empty());
    FlavorIntegrator unbound(0.002, 0.0005, 1);
    EXPECT_TRUE(unbound.getConfigurationWarnings().empty());
}

TEST_P(FlavorConfigurationWarnings, AMesostepBeyondTheMeasuredOnesWithFrozenAnglesNamesTheMeasurement) {
    std::unique_ptr<System> protein(chain(true)), water(chain(false));
    auto artificial = [](double delta) {
        FlavorIntegrator* integrator = new FlavorIntegrator(delta, 0.0005, 1 << StiffGroup);
        integrator->setAveraging(FlavorIntegrator::ArtificialProjected);
        return std::unique_ptr<FlavorIntegrator>(integrator);
    };
    vector<string> warnings = warningsOf(*protein, *artificial(0.003), platform());
    ASSERT_EQ(1u, warnings.size());
    expectContains(warnings[0], {"mesoStep = 3 fs", "with torsions", "villin", "mesoStep <= 2.5 fs"});
    EXPECT_TRUE(warningsOf(*protein, *artificial(0.0025), platform()).empty());
    warnings = warningsOf(*water, *artificial(0.008), platform());
    ASSERT_EQ(1u, warnings.size());
    expectContains(warnings[0], {"mesoStep = 8 fs", "flexible TIP3P water", "mesoStep <= 7 fs"});
    EXPECT_TRUE(warningsOf(*water, *artificial(0.007), platform()).empty());
    FlavorIntegrator nonintrusive(0.005, 0.0005, 1 << StiffGroup); // nothing frozen: nothing measured to compare
    EXPECT_TRUE(warningsOf(*protein, nonintrusive, platform()).empty());
}

TEST_P(FlavorConfigurationWarnings,
       AStochasticImpulseModeInAResonanceBandIsNamedUnlessFrictionOrNoSoftForceRulesItOut) {
    auto pair = [](bool soft) {
        System* system = new System();
        system->addParticle(1.0);
        system->addParticle(1.0);
        HarmonicBondForce* spring = new HarmonicBondForce(); // omega = sqrt(2 k / m) = 40/ps
        spring->addBond(0, 1, 0.0, 800.0);
        spring->setForceGroup(StiffGroup);
        system->addForce(spring);
        if (soft) {
            CustomExternalForce* walls = new CustomExternalForce("x^4");
            walls->addParticle(0, {});
            system->addForce(walls);
        }
        return std::unique_ptr<System>(system);
    };
    auto warningsAt = [&](System& system, double omegaH, double friction, StochasticImpulseIntegrator::Splitting s) {
        StochasticImpulseIntegrator integrator(0.0, friction, omegaH / 40.0, 1 << StiffGroup);
        integrator.setSplitting(s);
        Context context(system, integrator, platform());
        context.setPositions({Vec3(0.1, 0.02, 0.0), Vec3(0.13, 0.0, 0.01)});
        return integrator.getConfigurationWarnings();
    };
    std::unique_ptr<System> soft = pair(true), stiffOnly = pair(false);
    const vector<string> warnings = warningsAt(*soft, 2 * M_PI, 0.0, StochasticImpulseIntegrator::Strang);
    ASSERT_EQ(1u, warnings.size());
    expectContains(warnings[0], {"3 of 3 stiff modes", "omega H = 2.000 pi", "Strang", "0.05 k pi", "Warped"});
    EXPECT_TRUE(warningsAt(*soft, 1.0, 0.0, StochasticImpulseIntegrator::Strang).empty());
    EXPECT_TRUE(warningsAt(*soft, 2 * M_PI, 5.0, StochasticImpulseIntegrator::Strang).empty()); // gamma H = 0.79
    EXPECT_TRUE(warningsAt(*soft, 2 * M_PI, 0.0, StochasticImpulseIntegrator::Warped).empty());
    EXPECT_TRUE(warningsAt(*soft, 2 * M_PI, 0.0, StochasticImpulseIntegrator::Filtered).empty());
    EXPECT_EQ(1u, warningsAt(*soft, M_PI, 5.0, StochasticImpulseIntegrator::Filtered).size());
    EXPECT_TRUE(warningsAt(*stiffOnly, 2 * M_PI, 0.0, StochasticImpulseIntegrator::Strang).empty());
}
