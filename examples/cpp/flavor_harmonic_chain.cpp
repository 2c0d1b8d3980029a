// A FLAVOR simulation through the C++ API: one Fermi-Pasta-Ulam chain (stiff harmonic springs in force group 1,
// soft quartic springs and walls in group 0), integrated with a mesostep 20x the microstep.
//
// Usage: flavor_harmonic_chain [plugin directory]
// The plugin directory is the kernel plugins' (PREFIX/lib/plugins after make install); built with the project, the
// build tree's is the default.  Compiled against an installation (docs/USER_GUIDE.md):
//   g++ -std=c++17 flavor_harmonic_chain.cpp -I PREFIX/include/openmmflavors -L PREFIX/lib -Wl,-rpath,PREFIX/lib
//       -lOpenMMFlavors -lOpenMM -o flavor_harmonic_chain
//   ./flavor_harmonic_chain PREFIX/lib/plugins

#include "FlavorIntegrator.h"
#include "OpenMM.h"
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#ifndef FLAVORS_PLUGIN_DIR
#define FLAVORS_PLUGIN_DIR ""
#endif

using namespace OpenMM;

int main(int argc, char** argv) {
    const std::string pluginDir = argc > 1 ? argv[1] : FLAVORS_PLUGIN_DIR;
    if (pluginDir.empty()) {
        std::fprintf(stderr, "usage: %s PLUGIN_DIR (the kernel plugins, PREFIX/lib/plugins after make install)\n",
                     argv[0]);
        return 2;
    }
    // OpenMM's plugins first (the CPU platform), then this library's kernel plugins.
    Platform::loadPluginsFromDirectory(Platform::getDefaultPluginsDirectory());
    Platform::loadPluginsFromDirectory(pluginDir);

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

    const double delta = 2e-3, tau = 1e-4;
    FlavorPlugin::FlavorIntegrator integrator(delta, tau, 1 << 1);
    Context context(system, integrator, Platform::getPlatformByName("Reference"));
    context.setPositions(positions);
    // A FLAVOR conserves the averaged energy H_eff = K + V_soft + (tau/delta) V_stiff, not H itself: its fast motion
    // is slowed down by sqrt(tau/delta).  x0,1 is the slow variable.
    std::printf("%8s %12s %14s %14s\n", "time", "x0,1", "H", "H_eff");
    for (int report = 0; report <= 10; ++report) {
        State soft = context.getState(State::Positions | State::Energy, false, 1 << 0);
        State stiffState = context.getState(State::Energy, false, 1 << 1);
        const std::vector<Vec3>& q = soft.getPositions();
        const double kinetic = soft.getKineticEnergy(), vSoft = soft.getPotentialEnergy();
        const double vStiff = stiffState.getPotentialEnergy();
        std::printf("%8.2f %12.6f %14.8f %14.8f\n", soft.getTime(), (q[0][0] + q[1][0]) / s, kinetic + vSoft + vStiff,
                    kinetic + vSoft + tau / delta * vStiff);
        integrator.step(5000);
    }
    return 0;
}
