#ifndef OPENMM_FLAVORS_TESTS_DRUDE_WATER_H_
#define OPENMM_FLAVORS_TESTS_DRUDE_WATER_H_

#include "TestSystems.h"
#include "openmm/CustomExternalForce.h"
#include "openmm/HarmonicBondForce.h"
#include "openmm/System.h"
#include "openmm/Vec3.h"
#include <cmath>
#include <vector>

namespace FlavorTests {

// SWM4-NDP: the oxygen keeps 15.59943 - 0.4 of its mass, the Drude spring has k = 418400 kJ/mol/nm^2 (a relative
// frequency of 1036/ps), rigid O-H 0.09572 nm and H-H 0.15139 nm.
constexpr double OxygenMass = 15.59943, HydrogenMass = 1.008, DrudeMass = 0.4, DrudeK = 418400.0;
constexpr double OH = 0.09572, HH = 0.15139;

/**
 * Rigid Drude waters (O, H, H, D per molecule) on a lattice.  The soft forces are a tether on the hydrogens only
 * (hydrogensOnly) or, otherwise, a tether on every particle and a field pulling on the Drude particles.
 */
struct DrudeWater {
    OpenMM::System system;
    std::vector<OpenMM::Vec3> positions;
    int molecules;
    DrudeWater(int molecules, bool hydrogensOnly) : molecules(molecules) {
        OpenMM::HarmonicBondForce* drude = new OpenMM::HarmonicBondForce();
        drude->setForceGroup(StiffGroup);
        OpenMM::CustomExternalForce* tether = new OpenMM::CustomExternalForce("0.5*a*((x-x0)^2+2*(y-y0)^2+3*(z-z0)^2)");
        tether->addGlobalParameter("a", 2e3);
        for (const char* p : {"x0", "y0", "z0"})
            tether->addPerParticleParameter(p);
        OpenMM::CustomExternalForce* field = new OpenMM::CustomExternalForce("-e*(x+0.5*y)");
        field->addGlobalParameter("e", 300.0);
        const double angle = 2 * std::asin(0.5 * HH / OH);
        for (int m = 0; m < molecules; ++m) {
            const int o = 4 * m;
            for (double mass : {OxygenMass - DrudeMass, HydrogenMass, HydrogenMass, DrudeMass})
                system.addParticle(mass);
            system.addConstraint(o, o + 1, OH);
            system.addConstraint(o, o + 2, OH);
            system.addConstraint(o + 1, o + 2, HH);
            drude->addBond(o, o + 3, 0.0, DrudeK);
            const OpenMM::Vec3 origin(0.4 * (m % 4), 0.4 * ((m / 4) % 4), 0.4 * (m / 16));
            positions.push_back(origin);
            positions.push_back(origin + OpenMM::Vec3(OH, 0, 0));
            positions.push_back(origin + OpenMM::Vec3(OH * std::cos(angle), OH * std::sin(angle), 0));
            positions.push_back(origin + OpenMM::Vec3(0.002, -0.001, 0.0015));
            for (int i = 0; i < 4; ++i) {
                if (hydrogensOnly && (i == 0 || i == 3))
                    continue;
                const OpenMM::Vec3 rest = positions[o + i] + OpenMM::Vec3(0.01 * ((m + i) % 3), -0.01, 0.005 * i);
                tether->addParticle(o + i, {rest[0], rest[1], rest[2]});
            }
            if (!hydrogensOnly)
                field->addParticle(o + 3);
        }
        system.addForce(drude);
        system.addForce(tether);
        if (!hydrogensOnly)
            system.addForce(field);
        else
            delete field;
    }
};

} // namespace FlavorTests

#endif
