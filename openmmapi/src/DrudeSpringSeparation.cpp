#include "StochasticImpulseIntegrator.h"
#include "internal/ParameterChecks.h"
#include "openmm/CustomBondForce.h"
#include "openmm/DrudeForce.h"
#include "openmm/HarmonicBondForce.h"
#include "openmm/System.h"
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

using namespace FlavorPlugin;
using namespace OpenMM;

namespace {

// 1/(4 pi eps0) in kJ nm/(mol e^2), written as OpenMM 7.7's reference kernels write it (CODATA 2018), so that the
// springs moved out of a DrudeForce have the force constants its kernel computes, to the last bit.
const double OneOver4PiEps0 =
    1.0 / (4.0 * M_PI * (1e-6 * 8.8541878128e-12 / (1.602176634e-19 * 1.602176634e-19 * 6.02214076e23)));

// The energy of the force that cancels a DrudeForce's isotropic springs in the DrudeForce's group; a System holding a
// CustomBondForce with this expression has been separated already.
const char* const CancelExpression = "-0.5*kIsotropic*r^2";

struct Spring {
    int drude, parent;
    double k;
    int group;
};

} // namespace

void StochasticImpulseIntegrator::separateDrudeSprings(System& system, int stiffGroup) {
    const std::string owner = "StochasticImpulseIntegrator::separateDrudeSprings";
    if (stiffGroup < 0 || stiffGroup > 31)
        throwInvalidParameter(owner, "stiffGroup", std::to_string(stiffGroup), "force groups are 0 to 31");
    // Every check comes before the System is changed.
    std::vector<Spring> springs;
    std::vector<int> drudeGroups;
    int drudeForces = 0;
    for (int f = 0; f < system.getNumForces(); ++f) {
        const Force& force = system.getForce(f);
        const CustomBondForce* custom = dynamic_cast<const CustomBondForce*>(&force);
        if (custom != nullptr && custom->getEnergyFunction() == CancelExpression)
            throwInvalidParameter(owner, "system",
                                  "a System whose Drude springs are already separated (force " + std::to_string(f) +
                                      " cancels them)",
                                  "call it once per System");
        const DrudeForce* drude = dynamic_cast<const DrudeForce*>(&force);
        if (drude == nullptr)
            continue;
        ++drudeForces;
        if (drude->getForceGroup() == stiffGroup)
            throwInvalidParameter(owner, "stiffGroup", std::to_string(stiffGroup),
                                  "it is the group of the DrudeForce (force " + std::to_string(f) +
                                      "), which keeps the soft remainder (anisotropic terms, Thole screening): give "
                                      "the isotropic springs a group of their own");
        for (int i = 0; i < drude->getNumParticles(); ++i) {
            int p, p1, p2, p3, p4;
            double charge, polarizability, aniso12, aniso34;
            drude->getParticleParameters(i, p, p1, p2, p3, p4, charge, polarizability, aniso12, aniso34);
            // As OpenMM's DrudeForce kernels: an axis that is not given has a factor of 1.
            const double a1 = (p2 == -1 ? 1.0 : aniso12);
            const double a2 = (p3 == -1 || p4 == -1 ? 1.0 : aniso34);
            const double a3 = 3.0 - a1 - a2;
            if (!(a3 > 0.0) || !(polarizability > 0.0))
                throwInvalidParameter(owner, "system",
                                      "a DrudeForce (force " + std::to_string(f) + ") whose particle " +
                                          std::to_string(i) + " has polarizability " + formatNumber(polarizability) +
                                          " and a3 = 3 - aniso12 - aniso34 = " + formatNumber(a3) +
                                          " (an aniso taken as 1 where its axis is not given)",
                                      "both must be above 0 for its isotropic spring to be a spring");
            springs.push_back(
                {p, p1, OneOver4PiEps0 * charge * charge / (polarizability * a3), drude->getForceGroup()});
        }
        if (std::find(drudeGroups.begin(), drudeGroups.end(), drude->getForceGroup()) == drudeGroups.end())
            drudeGroups.push_back(drude->getForceGroup());
    }
    if (drudeForces == 0)
        throwInvalidParameter(owner, "system",
                              "a System without a DrudeForce (" + std::to_string(system.getNumForces()) + " forces)",
                              "it needs a DrudeForce whose springs to separate");

    HarmonicBondForce* stiff = new HarmonicBondForce();
    stiff->setForceGroup(stiffGroup);
    for (const Spring& s : springs)
        stiff->addBond(s.parent, s.drude, 0.0, s.k);
    system.addForce(stiff);
    for (int group : drudeGroups) {
        CustomBondForce* cancel = new CustomBondForce(CancelExpression);
        cancel->addPerBondParameter("kIsotropic");
        cancel->setForceGroup(group);
        for (const Spring& s : springs)
            if (s.group == group)
                cancel->addBond(s.parent, s.drude, {s.k});
        system.addForce(cancel);
    }
}
