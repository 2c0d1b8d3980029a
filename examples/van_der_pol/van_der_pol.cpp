// The heavy loop of examples/van_der_pol/van_der_pol.py: one run of the hidden Van der Pol oscillator (FLAVORS paper
// §6.1, Fig. 6.1) by FirstOrderFlavor, written as JSON on stdout.
//
//   van_der_pol --system cartesian|polar --eps 1e-3 --delta 0.01 --tau 5e-5 --T 5000 --samples 4000 --x0 1 --y0 1
//
// cartesian integrates (6.2) in (x, y), polar integrates (6.1) in (r, theta) and reports x = r sin(theta),
// y = r cos(theta).  Forward Euler at step h is --delta h --tau h.  Output: steps, wall_s (the stepping loop only),
// cpu_s (its processor time), and t, x, y at about --samples evenly spaced times (t = 0 included).
#include "FirstOrderFlavor.h"
#include "FirstOrderModels.h"
#include "FirstOrderScene.h"

#include <array>
#include <cstdio>
#include <exception>
#include <vector>

using FlavorPlugin::FirstOrderFlavor;
using namespace FirstOrderModels;

namespace {

struct Samples {
    std::vector<double> t, x, y;
    void add(double time, const std::array<double, 2>& xy) {
        t.push_back(time);
        x.push_back(xy[0]);
        y.push_back(xy[1]);
    }
};

/** Runs steps mesosteps, sampling every stride; toXY maps the state to (x, y).  Returns the loop's times. */
template <class Model, class ToXY>
std::array<double, 2> run(const FirstOrderFlavor<Model>& flavor, std::array<double, 2> u, long long steps,
                          long long stride, ToXY toXY, Samples& samples) {
    FirstOrderScene::Progress progress("mesosteps");
    FirstOrderScene::Clock clock;
    samples.add(0.0, toXY(u));
    for (long long k = 0; k < steps; ++k) {
        flavor.step(u, k);
        if ((k + 1) % stride == 0)
            samples.add((k + 1) * flavor.getMesostep(), toXY(u));
        if ((k & 0xfffff) == 0)
            progress.update((double)k, (double)steps);
    }
    return {clock.seconds(), clock.cpuSeconds()};
}

} // namespace

int main(int argc, char** argv) {
    try {
        const FirstOrderScene::Arguments args(argc, argv,
                                              {{"system", "cartesian"},
                                               {"eps", "1e-3"},
                                               {"delta", "0.01"},
                                               {"tau", "5e-5"},
                                               {"T", "5000"},
                                               {"samples", "4000"},
                                               {"x0", "1"},
                                               {"y0", "1"}});
        const double eps = args.number("eps"), delta = args.number("delta"), tau = args.number("tau");
        const long long steps = std::llround(args.number("T") / delta);
        const long long stride = std::max(1LL, steps / std::max(1LL, args.integer("samples")));
        const std::string system = args.text("system");
        Samples samples;
        samples.t.reserve(steps / stride + 2);
        samples.x.reserve(steps / stride + 2);
        samples.y.reserve(steps / stride + 2);
        std::array<double, 2> times;
        if (system == "cartesian") {
            const FirstOrderFlavor<VanDerPol> flavor(VanDerPol{eps}, 1 / eps, delta, tau);
            times = run(
                flavor, {args.number("x0"), args.number("y0")}, steps, stride,
                [](const std::array<double, 2>& u) { return u; }, samples);
        } else if (system == "polar") {
            const FirstOrderFlavor<HiddenVanDerPol> flavor(HiddenVanDerPol{eps}, 1 / eps, delta, tau);
            times = run(flavor, HiddenVanDerPol::fromCartesian(args.number("x0"), args.number("y0")), steps, stride,
                        HiddenVanDerPol::toCartesian, samples);
        } else {
            throw std::invalid_argument("--system must be cartesian or polar, not " + system);
        }
        FirstOrderScene::JsonWriter json;
        json.text("system", system);
        json.number("steps", (double)steps);
        json.number("wall_s", times[0]);
        json.number("cpu_s", times[1]);
        json.array("t", samples.t);
        json.array("x", samples.x);
        json.array("y", samples.y);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "van_der_pol: %s\n", e.what());
        return 1;
    }
    return 0;
}
