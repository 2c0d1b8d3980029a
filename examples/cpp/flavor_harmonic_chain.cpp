// A FLAVOR simulation through the C++ API: one Fermi-Pasta-Ulam chain (stiff harmonic springs in force group 1,
// soft quartic springs and walls in group 0), integrated with a mesostep 20x the microstep.
//
// Usage: flavor_harmonic_chain [plugin directory]

#include "FlavorIntegrator.h"
#include "OpenMM.h"
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

using namespace OpenMM;

int main(int argc, char** argv) {
    // OpenMM's plugins first (the CPU platform), then this library's kernel plugins.
    Platform::loadPluginsFromDirectory(Platform::getDefaultPluginsDirectory());
    Platform::loadPluginsFromDirectory(argc > 1 ? argv[1] : FLAVORS_PLUGIN_DIR);

    const int m = 3;
    const double omega = 200.0;
    System system;
    HarmonicBondForce* stiff = new HarmonicBondForce();
    CustomBondForce* soft = new CustomBondForce("r^4");
    CustomExternalForce* walls = new CustomExternalForce("x^4");
    stiff->setForceGroup(1);
    for (int i = 0; i < 2 * m; ++i)
        system.addParticle(1.0);
    for (int i = 0; i < m; ++i)
        stiff->addBond(2 * i, 2 * i + 1, 0.0, omega * omega / 2);
    for (int i = 0; i + 1 < m; ++i)
        soft->addBond(2 * i + 1, 2 * i + 2);
    walls->addParticle(0);
    walls->addParticle(2 * m - 1);
    system.addForce(stiff);
    system.addForce(soft);
    system.addForce(walls);

    // Fig. 6.5 of the FLAVORS paper: energy starts in the leftmost soft and stiff springs.
    const double s = std::sqrt(2.0);
    std::vector<Vec3> positions = {
        Vec3((1 - 1 / omega) / s, 0, 0), Vec3((1 + 1 / omega) / s, 0, 0), Vec3(), Vec3(), Vec3(), Vec3()};

    FlavorPlugin::FlavorIntegrator integrator(2e-3, 1e-4, 1 << 1);
    Context context(system, integrator, Platform::getPlatformByName("Reference"));
    context.setPositions(positions);
    std::printf("%8s %12s %12s %12s %12s %14s\n", "time", "x0,1", "I1", "I2", "I3", "total energy");
    for (int report = 0; report <= 10; ++report) {
        State state = context.getState(State::Positions | State::Velocities | State::Energy);
        const std::vector<Vec3>& q = state.getPositions();
        const std::vector<Vec3>& v = state.getVelocities();
        double I[3];
        for (int j = 0; j < m; ++j) {
            double x1 = (q[2 * j + 1][0] - q[2 * j][0]) / s, y1 = (v[2 * j + 1][0] - v[2 * j][0]) / s;
            I[j] = 0.5 * (y1 * y1 + omega * omega * x1 * x1);
        }
        double x01 = (q[0][0] + q[1][0]) / s;
        std::printf("%8.2f %12.6f %12.6f %12.6f %12.6f %14.8f\n", state.getTime(), x01, I[0], I[1], I[2],
                    state.getKineticEnergy() + state.getPotentialEnergy());
        integrator.step(5000);
    }
    return 0;
}
