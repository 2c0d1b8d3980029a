// The heavy loop of examples/hidden_sde/hidden_sde.py: an ensemble of the nonautonomous SDE with a hidden slow
// variable (FLAVORS paper §6.7, Fig. 6.13) by FirstOrderFlavor, its moments written as JSON on stdout.
//
//   hidden_sde --system hidden|slowfast|printed --eps 1e-4 --c 10 --delta 0.01 --tau 1e-4 --T 2 --paths 100
//              --samples 200 --seed 1 --repeat 1
//
// hidden integrates (6.16) in (u, v) and reports x = ((u + v)/2)^3 + c, y = (v - u)/2; slowfast integrates (6.16)
// written in (x, y); printed integrates (6.18) as the paper prints it (5 sin(2 pi t) dW on x).  All start at
// x = 1 + eps, y = 1.  Euler-Maruyama at step h is --delta h --tau h.  Path p uses the random streams of particle p.
// Output: steps (per path), wall_s and cpu_s (the fastest of --repeat runs of the whole ensemble), and at about
// --samples evenly spaced times t: the mean and standard error of x over the paths still finite, the mean of y, the
// number of finite paths; blowup_t: the first time a path's x left |x| < 1e6 (null if none did).
#include "FirstOrderFlavor.h"
#include "FirstOrderModels.h"
#include "FirstOrderScene.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <exception>
#include <limits>
#include <vector>

using FlavorPlugin::FirstOrderFlavor;
using namespace FirstOrderModels;

namespace {

struct Moments {
    std::vector<double> t, sumX, sumX2, sumY, finite;
    double blowup = std::numeric_limits<double>::infinity();
};

constexpr double Escaped = 1e6;

/** Runs every path of the ensemble; toXY maps a state to (x, y).  Returns the wall and processor seconds. */
template <class Model, class ToXY>
std::array<double, 2> runEnsemble(const FirstOrderFlavor<Model>& flavor, const std::array<double, 2>& start,
                                  long long steps, long long stride, int paths, ToXY toXY, Moments& m) {
    const std::size_t count = steps / stride + 1;
    m.t.assign(count, 0.0);
    m.sumX.assign(count, 0.0);
    m.sumX2.assign(count, 0.0);
    m.sumY.assign(count, 0.0);
    m.finite.assign(count, 0.0);
    for (std::size_t i = 0; i < count; ++i)
        m.t[i] = i * stride * flavor.getMesostep();
    FirstOrderScene::Progress progress("paths");
    FirstOrderScene::Clock clock;
    for (int p = 0; p < paths; ++p) {
        std::array<double, 2> u = start;
        bool alive = true;
        for (long long k = 0; k <= steps && alive; ++k) {
            if (k > 0)
                flavor.step(u, k - 1, (std::uint32_t)p);
            const std::array<double, 2> xy = toXY(u);
            if (!(std::fabs(xy[0]) < Escaped)) {
                m.blowup = std::min(m.blowup, k * flavor.getMesostep());
                alive = false;
            } else if (k % stride == 0) {
                const std::size_t i = k / stride;
                m.sumX[i] += xy[0];
                m.sumX2[i] += xy[0] * xy[0];
                m.sumY[i] += xy[1];
                m.finite[i] += 1;
            }
        }
        progress.update(p + 1, paths);
    }
    return {clock.seconds(), clock.cpuSeconds()};
}

} // namespace

int main(int argc, char** argv) {
    try {
        const FirstOrderScene::Arguments args(argc, argv,
                                              {{"system", "hidden"},
                                               {"eps", "1e-4"},
                                               {"c", "10"},
                                               {"delta", "0.01"},
                                               {"tau", "1e-4"},
                                               {"T", "2"},
                                               {"paths", "100"},
                                               {"samples", "200"},
                                               {"seed", "1"},
                                               {"repeat", "1"}});
        const double eps = args.number("eps"), delta = args.number("delta"), tau = args.number("tau");
        const long long steps = std::llround(args.number("T") / delta);
        const long long stride = std::max(1LL, steps / std::max(1LL, args.integer("samples")));
        const int paths = (int)args.integer("paths");
        const std::uint64_t seed = (std::uint64_t)args.integer("seed");
        const std::string system = args.text("system");
        const double x0 = 1 + eps, y0 = 1;
        Moments m;
        std::array<double, 2> best = {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
        for (long long r = 0; r < std::max(1LL, args.integer("repeat")); ++r) {
            std::array<double, 2> times;
            if (system == "hidden") {
                const HiddenSde model{args.number("c")};
                const FirstOrderFlavor<HiddenSde> flavor(model, 1 / eps, delta, tau, seed);
                times = runEnsemble(
                    flavor, model.fromSlowFast(x0, y0), steps, stride, paths,
                    [&model](const std::array<double, 2>& u) { return model.slowFast(u); }, m);
            } else if (system == "slowfast" || system == "printed") {
                auto identity = [](const std::array<double, 2>& u) { return u; };
                if (system == "slowfast")
                    times = runEnsemble(FirstOrderFlavor<SlowFastSde>(SlowFastSde(), 1 / eps, delta, tau, seed),
                                        {x0, y0}, steps, stride, paths, identity, m);
                else
                    times = runEnsemble(
                        FirstOrderFlavor<PrintedSlowFastSde>(PrintedSlowFastSde(), 1 / eps, delta, tau, seed), {x0, y0},
                        steps, stride, paths, identity, m);
            } else {
                throw std::invalid_argument("--system must be hidden, slowfast or printed, not " + system);
            }
            best = {std::min(best[0], times[0]), std::min(best[1], times[1])};
        }
        std::vector<double> meanX(m.t.size()), seX(m.t.size()), meanY(m.t.size());
        for (std::size_t i = 0; i < m.t.size(); ++i) {
            const double n = m.finite[i];
            meanX[i] = n > 0 ? m.sumX[i] / n : std::nan("");
            meanY[i] = n > 0 ? m.sumY[i] / n : std::nan("");
            seX[i] =
                n > 1 ? std::sqrt(std::max(0.0, (m.sumX2[i] - n * meanX[i] * meanX[i]) / (n - 1)) / n) : std::nan("");
        }
        FirstOrderScene::JsonWriter json;
        json.text("system", system);
        json.number("steps", (double)steps);
        json.number("paths", paths);
        json.number("wall_s", best[0]);
        json.number("cpu_s", best[1]);
        json.number("blowup_t", m.blowup);
        json.array("t", m.t);
        json.array("mean_x", meanX);
        json.array("se_x", seX);
        json.array("mean_y", meanY);
        json.array("finite", m.finite);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "hidden_sde: %s\n", e.what());
        return 1;
    }
    return 0;
}
