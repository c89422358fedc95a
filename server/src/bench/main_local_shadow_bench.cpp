// dfb-local-shadow-bench: Kasai et al. section 4.2.1's local shadow move (E1, eq. 11) and local
// shadow scale (E2, eq. 13) on a synthetic bent BendyLight (no GPU, no scene): N drag updates per
// mode, the pointer a little further each update, each solved from the light as it was when the
// drag began, by (a) Eigen's Levenberg-Marquardt with the regulariser (LocalShadowEdit.h), (b) the
// same with 16 occluder samples around S whose tube coordinates are kept too (issue 17 point 8),
// and (c) the paper's finite-difference steepest descent (eqs. 12, 14; paper::localShadowEdit).
// Prints per mode and solver: median / p90 iterations, ms per update, final E (C't and S), the
// occluder samples' rms (u, v, w) change (measured for every solver, kept only by (b)), refused
// updates. A benchmark prints numbers; nothing here passes or fails.
//
//   dfb-local-shadow-bench [--updates N] [--drag METRES] [--paper-iterations N] [--paper-alpha A]
//                          [--paper-step D]

#include <dfb/core/Version.h>
#include <dfb/core/Stats.h>
#include <dfb/server/LocalShadowEdit.h>

#include "support/BentDownLight.h"

#include <dfb/core/CommandLine.h>
#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

using namespace dfb;
using namespace dfb::indirect;
using glm::dvec3;
using Clock = std::chrono::steady_clock;

namespace {

// (u, v, w) of X; zero without a foot (the bench only prints).
dvec3 coordsOf(const Light& l, const dvec3& X) {
    const auto c = lightmath::inverseMap(chainFromLight<double>(l), X);
    return c.valid ? dvec3(c.segment + c.t, c.v, c.w) : dvec3(0.0);
}

double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

} // namespace

int main(int argc, char** argv) {
    int updates = 40, paperIterations = paper::Options{}.maxIterations;
    double drag = 0.3, alpha = paper::Options{}.alphaL2, step = paper::Options{}.stepD;
    CLI::App app{"dfb-local-shadow-bench: local shadow move / scale, Levenberg-Marquardt against the paper's descent"};
    app.set_version_flag("--version", dfb::versionText("dfb-local-shadow-bench"));
    app.add_option("--updates", updates, "drag updates per mode")->check(CLI::Range(1, 100000));
    app.add_option("--drag", drag, "the last update's pointer offset, metres on the ground (scale: relative)")
        ->check(CLI::Range(1e-6, 10.0));
    app.add_option("--paper-iterations", paperIterations, "the paper's iteration cap")->check(CLI::Range(1, 1000000));
    app.add_option("--paper-alpha", alpha, "the paper's coefficient alpha, in units of L^2")->check(CLI::Range(1e-9, 10.0));
    app.add_option("--paper-step", step, "the paper's step D, in units of L")->check(CLI::Range(1e-12, 1.0));
    if (const int rc = dfb::parseCommandLine(app, argc, argv, "dfb-local-shadow-bench"); rc >= 0) return rc;

    const Light light = test::bentDownLight();
    const auto ch = chainFromLight<double>(light);
    const dvec3 S = lightmath::tubePoint(ch, 0, 0.7, 0.3, -0.2);  // occluder in the straight first segment
    const dvec3 Ct = lightmath::tubePoint(ch, 2, 1.0, 0.3, -0.2); // its shadow on the ground y = -1
    const dvec3 centre = lightmath::chainPoint(ch, 2, 1.0);
    // The occluder around S: u 0.55 to 1.15 (the straight part into the bend), four (v, w) each.
    std::vector<dvec3> occluder;
    const double vw[4][2] = {{0.3, -0.2}, {0.1, 0.1}, {-0.2, 0.3}, {0.4, 0.2}};
    for (double u : {0.55, 0.75, 0.95, 1.15})
        for (const auto& c : vw) occluder.push_back(lightmath::tubePoint(ch, int(u), u - double(int(u)), c[0], c[1]));
    auto occluderChange = [&](const Light& after) {
        double sum = 0.0;
        for (const dvec3& X : occluder) {
            const dvec3 d = coordsOf(after, X) - coordsOf(light, X);
            sum += glm::dot(d, d);
        }
        return std::sqrt(sum / double(occluder.size()));
    };
    paper::Options opt;
    opt.maxIterations = paperIterations;
    opt.alphaL2 = alpha;
    opt.stepD = step;

    std::printf("light:    K = 2, a 90-degree bend onto the ground (chain %.2f m); S at u = 0.7, Ct at u = 3 "
                "(v, w) = (0.3, -0.2)\n", ch.arcStart[2]);
    std::printf("updates:  %d per mode, each from the begin light; move: C't = Ct + i/N %.2f m (0.8, 0, 0.6); "
                "scale: C't = centre + (Ct - centre)(1 + i/N %.2f)\n", updates, drag, drag);
    std::printf("paper:    forward-difference steepest descent, D = %.0e L, alpha = %.3g L^2, at most %d iterations\n",
                opt.stepD, opt.alphaL2, opt.maxIterations);
    std::printf("bound:    sqrt(E) (reachable part) <= %.0e; E = sum of the six squared tube-coordinate differences\n",
                LOCAL_ACCEPTED);
    std::printf("occluder: %zu points around S (u 0.55 to 1.15), weight %.0e in all; 'occl' = their rms (u, v, w) "
                "change (median)\n\n", occluder.size(), OCCLUDER_WEIGHT);
    std::printf("%-20s %-26s %6s %6s | %8s %8s | %10s %10s | %9s | %s\n", "mode", "solver", "iter", "p90", "ms", "p90",
                "E median", "E p90", "occl", "refused");

    struct Run {
        const char* mode;
        local::Mode m;
        std::function<dvec3(int)> target;
    };
    const Run runs[] = {
        {"local shadow move", local::Mode::Move,
         [&](int i) { return Ct + dvec3(0.8, 0.0, 0.6) * (drag * double(i) / updates); }},
        {"local shadow scale", local::Mode::Scale,
         [&](int i) { return centre + (Ct - centre) * (1.0 + drag * double(i) / updates); }},
    };
    for (const Run& run : runs) {
        for (int solver = 0; solver < 3; ++solver) {
            std::vector<double> iterations, ms, energy, occl;
            int refused = 0;
            std::string firstRefusal;
            for (int i = 1; i <= updates; ++i) {
                const dvec3 target = run.target(i);
                const auto t0 = Clock::now();
                auto o = solver == 0   ? localShadowSolve(light, S, Ct, target, {}, run.m)
                         : solver == 1 ? localShadowSolve(light, S, Ct, target, {}, run.m, occluder)
                                       : paper::localShadowEdit(light, S, Ct, target, {}, run.m, opt);
                ms.push_back(msSince(t0));
                if (!o) {
                    ++refused;
                    if (firstRefusal.empty()) firstRefusal = o.error().message;
                    continue;
                }
                iterations.push_back(o->iterations);
                energy.push_back(o->residual * o->residual);
                occl.push_back(occluderChange(o->light));
                if (!o->refused.empty()) {
                    ++refused;
                    if (firstRefusal.empty()) firstRefusal = o->refused;
                }
            }
            const char* names[] = {"Eigen LM + regulariser", "LM + 16 occluder samples", "paper descent"};
            std::printf("%-20s %-26s %6.0f %6.0f | %8.3f %8.3f | %10.2e %10.2e | %9.2e | %d of %d\n", run.mode,
                        names[solver], percentile(iterations, 50), percentile(iterations, 90), percentile(ms, 50),
                        percentile(ms, 90), percentile(energy, 50), percentile(energy, 90), percentile(occl, 50), refused,
                        updates);
            if (!firstRefusal.empty()) std::printf("%-20s   first refusal: %s\n", "", firstRefusal.c_str());
        }
    }
    return 0;
}
