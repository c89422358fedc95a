// BendyLight math in double (and float where stated): the cubic solver is exact and misses no
// in-tube root (against dense sampling plus bisection), a straight chain matching the cone is the
// identity, and the light direction agrees with a finite difference of the flow line.

#include <dfb/lightmath/BendyLight.h>

#include <gtest/gtest.h>

#include <cmath>
#include <random>

using namespace dfb::lightmath;
using dvec3 = vec3<double>;

namespace {

void setFrame(Chain<double>& ch, dvec3 axis) {
    ch.axisU = glm::normalize(axis);
    const dvec3 up = std::abs(ch.axisU.y) < 0.99 ? dvec3(0, 1, 0) : dvec3(1, 0, 0);
    ch.axisW = glm::normalize(glm::cross(ch.axisU, up));
    ch.axisV = glm::cross(ch.axisW, ch.axisU);
}

// A random chain: K segments wandering from the origin along +x, bends up to ~120 degrees.
Chain<double> randomChain(std::mt19937_64& rng, int K) {
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    Chain<double> ch;
    ch.segments = K;
    ch.tanTheta = std::tan(0.5);
    setFrame(ch, dvec3(1, 0, 0));
    dvec3 dir(1, 0, 0);
    ch.p[0] = dvec3(0);
    for (int i = 1; i <= 2 * K; ++i) {
        dir = glm::normalize(dir + dvec3(u(rng), u(rng), u(rng)) * 0.9);
        if (dir.x < -0.3) dir.x = -dir.x;
        ch.p[i] = ch.p[i - 1] + dir * (1.0 + 0.5 * u(rng));
    }
    for (int i = 0; i <= 2 * K; ++i) {
        ch.r[i] = 0.2 + 0.4 * (1.0 + u(rng)) + 0.3 * i;
        ch.c[i] = dvec3(1.0);
    }
    prepareChain(ch);
    return ch;
}

double eq4(const Chain<double>& ch, int k, double t, const dvec3& Q) {
    return glm::dot(Q - chainPoint(ch, k, t), chainDerivative(ch, k, t));
}

} // namespace

TEST(BendySolver, CubicRootsAreExactOnKnownPolynomials) {
    double r[3];
    // (t - 0.2)(t - 0.5)(t - 0.9)
    int n = solveCubic(1.0, -1.6, 0.73, -0.09, r);
    ASSERT_EQ(n, 3);
    std::sort(r, r + 3);
    EXPECT_NEAR(r[0], 0.2, 1e-12);
    EXPECT_NEAR(r[1], 0.5, 1e-12);
    EXPECT_NEAR(r[2], 0.9, 1e-12);
    // Degenerate leading coefficient: 2 t - 1 (the straight segment case).
    n = solveCubic(0.0, 0.0, 2.0, -1.0, r);
    ASSERT_EQ(n, 1);
    EXPECT_NEAR(r[0], 0.5, 1e-15);
    // One real root: t^3 + t - 2 = (t - 1)(t^2 + t + 2).
    n = solveCubic(1.0, 0.0, 1.0, -2.0, r);
    ASSERT_EQ(n, 1);
    EXPECT_NEAR(r[0], 1.0, 1e-14);
    // Widely scaled coefficients.
    n = solveCubic(1e-3, -1.6e-3, 0.73e-3, -0.09e-3, r);
    EXPECT_EQ(n, 3);
}

TEST(BendySolver, AMillionRandomCasesAreExactAndMissNoInTubeRoot) {
    std::mt19937_64 rng(20101);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    const int CHAINS = 2000, POINTS = 500; // 1,000,000 (point, chain) cases
    long cases = 0, withRoot = 0, missed = 0, worseChoice = 0;
    double worstResidual = 0;
    for (int c = 0; c < CHAINS; ++c) {
        const Chain<double> ch = randomChain(rng, 1 + c % 4);
        dvec3 lo(1e30), hi(-1e30);
        for (int i = 0; i <= 2 * ch.segments; ++i) {
            lo = glm::min(lo, ch.p[i] - dvec3(ch.r[i]));
            hi = glm::max(hi, ch.p[i] + dvec3(ch.r[i]));
        }
        for (int q = 0; q < POINTS; ++q, ++cases) {
            const dvec3 Q = lo + (hi - lo) * dvec3(0.5 + 0.5 * u(rng), 0.5 + 0.5 * u(rng), 0.5 + 0.5 * u(rng));
            const TubeCoords<double> got = inverseMap(ch, Q);
            // Residual of eq. 4 at the chosen foot, relative to |Q - P| |P'|.
            if (got.valid && got.segment < ch.segments) {
                const double f = eq4(ch, got.segment, got.t, Q);
                const double scale = glm::length(Q - chainPoint(ch, got.segment, got.t)) *
                                     glm::length(chainDerivative(ch, got.segment, got.t));
                if (scale > 1e-12) worstResidual = std::max(worstResidual, std::abs(f) / scale);
            }
            // Reference: dense sampling of eq. 4 on every segment, bisection at sign changes.
            double bestR2 = 1e300;
            bool anyInside = false;
            for (int k = 0; k < ch.segments; ++k) {
                const int N = 256;
                double t0 = 0, f0 = eq4(ch, k, 0.0, Q);
                for (int i = 1; i <= N; ++i) {
                    const double t1 = double(i) / N, f1 = eq4(ch, k, t1, Q);
                    if ((f0 <= 0) != (f1 <= 0)) {
                        double a = t0, b = t1, fa = f0;
                        for (int it = 0; it < 60; ++it) {
                            const double m = 0.5 * (a + b), fm = eq4(ch, k, m, Q);
                            if ((fa <= 0) == (fm <= 0)) { a = m; fa = fm; } else b = m;
                        }
                        TubeCoords<double> ref;
                        if (tubeCoordinates(ch, Q, k, 0.5 * (a + b), ref) && ref.inside) {
                            anyInside = true;
                            bestR2 = std::min(bestR2, ref.v * ref.v + ref.w * ref.w);
                        }
                    }
                    t0 = t1;
                    f0 = f1;
                }
            }
            if (!anyInside) continue;
            ++withRoot;
            if (!got.valid || !got.inside) {
                ++missed;
                continue;
            }
            // The solver may find a foot the dense search cannot see (a tangential double root or
            // the extension), but never a less central one.
            if (got.v * got.v + got.w * got.w > bestR2 + 1e-9) ++worseChoice;
        }
    }
    std::printf("cases %ld, with an in-tube root %ld, missed %ld, less central than the reference %ld, "
                "worst relative residual of eq. 4 %.3g\n", cases, withRoot, missed, worseChoice, worstResidual);
    EXPECT_GE(cases, 1000000);
    EXPECT_GT(withRoot, 100000);
    EXPECT_EQ(missed, 0);
    EXPECT_EQ(worseChoice, 0);
    EXPECT_LT(worstResidual, 1e-9);
}

TEST(BendyMapping, StraightChainMatchingTheConeIsTheIdentity) {
    for (int K : {1, 2, 3}) {
        Chain<double> ch;
        ch.segments = K;
        ch.tanTheta = std::tan(glm::radians(30.0));
        const dvec3 axis = glm::normalize(dvec3(0.3, -1.0, 0.2));
        setFrame(ch, axis);
        ch.p[0] = dvec3(1, 5, 2);
        const double L = 6.0;
        for (int i = 0; i <= 2 * K; ++i) {
            ch.p[i] = ch.p[0] + axis * (L * i / (2 * K));
            ch.r[i] = L * i / (2 * K) * ch.tanTheta;
            ch.c[i] = dvec3(1);
        }
        prepareChain(ch);
        std::mt19937_64 rng(K);
        std::uniform_real_distribution<double> u(-1.0, 1.0);
        double worstQ = 0, worstLi = 0;
        int inside = 0;
        for (int i = 0; i < 20000; ++i) {
            // Points in front of the source, within and beyond the chain (the extension).
            const double s = 0.05 + 9.0 * (0.5 + 0.5 * u(rng));
            const dvec3 Q = ch.p[0] + axis * s + (ch.axisV * u(rng) + ch.axisW * u(rng)) * (s * 0.8);
            const TubeCoords<double> c = inverseMap(ch, Q);
            ASSERT_TRUE(c.valid);
            inside += c.inside;
            worstQ = std::max(worstQ, glm::length(deformedPoint(ch, c) - Q));
            const dvec3 Li = lightDirection(ch, c, Q, false);
            worstLi = std::max(worstLi, glm::length(Li - glm::normalize(ch.p[0] - Q)));
        }
        std::printf("K=%d: |Q' - Q| <= %.3g, |Li - L| <= %.3g (%d points inside the cone)\n", K, worstQ, worstLi, inside);
        EXPECT_LT(worstQ, 1e-9);
        EXPECT_LT(worstLi, 1e-12);
        EXPECT_GT(inside, 1000);
    }
}

namespace {
// The flow line through Q: points of constant (v, w) as u varies. Central finite difference of it
// with respect to u, at Q's own (k, t).
dvec3 flowTangent(const Chain<double>& ch, const TubeCoords<double>& c, double h) {
    auto at = [&](double t) {
        vec3<double> uHat, vHat, wHat;
        tubeFrame(ch, c.segment, t, uHat, vHat, wHat);
        return chainPoint(ch, c.segment, t) + (vHat * c.v + wHat * c.w) * chainRadius(ch, c.segment, t);
    };
    return (at(c.t + h) - at(c.t - h)) / (2 * h);
}
double angleDeg(const dvec3& a, const dvec3& b) {
    return glm::degrees(std::acos(glm::clamp(glm::dot(glm::normalize(a), glm::normalize(b)), -1.0, 1.0)));
}
} // namespace

TEST(BendyDirection, Eq9MatchesTheFlowLineWhereExactAndTheExactFormEverywhere) {
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    double worstExact = 0, worstEq9Straight = 0, worstEq9ConstR = 0, worstEq9General = 0;
    int n = 0;
    for (int c = 0; c < 300; ++c) {
        for (int variant = 0; variant < 3; ++variant) {
            Chain<double> ch = randomChain(rng, 1 + c % 3);
            if (variant == 1) { // straight chain (radius varies): eq. 9 is exact
                const dvec3 d = glm::normalize(ch.p[2 * ch.segments] - ch.p[0]);
                for (int i = 0; i <= 2 * ch.segments; ++i) ch.p[i] = ch.p[0] + d * (1.3 * i);
            }
            if (variant == 2) { // constant radius (chain bends): eq. 9 is exact
                for (int i = 0; i <= 2 * ch.segments; ++i) ch.r[i] = 0.8;
            }
            prepareChain(ch);
            for (int q = 0; q < 40; ++q) {
                const int k = int(rng() % uint64_t(ch.segments));
                const double t = 0.05 + 0.9 * (0.5 + 0.5 * u(rng));
                // Build Q from tube coordinates so that (k, t) is its foot.
                vec3<double> uHat, vHat, wHat;
                tubeFrame(ch, k, t, uHat, vHat, wHat);
                const double v = 0.7 * u(rng), w = 0.7 * u(rng);
                const dvec3 Q = chainPoint(ch, k, t) + (vHat * v + wHat * w) * chainRadius(ch, k, t);
                const TubeCoords<double> tc = inverseMap(ch, Q);
                if (!tc.inside || tc.segment != k || std::abs(tc.t - t) > 1e-7) continue; // another foot is more central
                // Skip points past the centre of curvature of a bend (R kappa > 1): there the tube
                // folds over itself (paper section 7) and flow lines reverse.
                const double fold = glm::dot(Q - chainPoint(ch, k, t), unitTangentDerivative(ch, k, t)) /
                                    glm::length(chainDerivative(ch, k, t));
                if (fold > 0.5) continue;
                const dvec3 fd = -flowTangent(ch, tc, 1e-6);
                const double exact = angleDeg(lightDirection(ch, tc, Q, true), fd);
                const double eq9 = angleDeg(lightDirection(ch, tc, Q, false), fd);
                worstExact = std::max(worstExact, exact);
                if (variant == 1) worstEq9Straight = std::max(worstEq9Straight, eq9);
                if (variant == 2) worstEq9ConstR = std::max(worstEq9ConstR, eq9);
                if (variant == 0) worstEq9General = std::max(worstEq9General, eq9);
                ++n;
            }
        }
    }
    std::printf("%d points: exact form within %.2g deg; eq. 9 within %.2g deg (straight), %.2g deg (constant radius), "
                "%.2g deg in general (bends with changing radius)\n",
                n, worstExact, worstEq9Straight, worstEq9ConstR, worstEq9General);
    EXPECT_GT(n, 10000);
    EXPECT_LT(worstExact, 0.01);
    EXPECT_LT(worstEq9Straight, 0.01);
    EXPECT_LT(worstEq9ConstR, 0.01);
    EXPECT_GT(worstEq9General, 0.01); // the difference the exact option exists for
}

TEST(BendyFrame, NoFlipsForBendsUpTo170Degrees) {
    for (double bend = 10; bend <= 170; bend += 10) {
        Chain<double> ch;
        ch.segments = 2;
        ch.tanTheta = 0.5;
        setFrame(ch, dvec3(1, 0, 0));
        const double a = glm::radians(bend);
        // Two segments turning by `bend` in total within the x-y plane.
        ch.p[0] = dvec3(0);
        ch.p[1] = dvec3(1, 0, 0);
        ch.p[2] = ch.p[1] + dvec3(std::cos(a / 2), std::sin(a / 2), 0);
        ch.p[3] = ch.p[2] + dvec3(std::cos(a / 2), std::sin(a / 2), 0);
        ch.p[4] = ch.p[3] + dvec3(std::cos(a), std::sin(a), 0);
        for (int i = 0; i < 5; ++i) ch.r[i] = 0.5;
        prepareChain(ch);
        vec3<double> uPrev, vPrev, wPrev;
        tubeFrame(ch, 0, 0.0, uPrev, vPrev, wPrev);
        double worstStep = 0;
        for (int k = 0; k < 2; ++k)
            for (int i = 0; i <= 200; ++i) {
                vec3<double> uh, vh, wh;
                tubeFrame(ch, k, i / 200.0, uh, vh, wh);
                worstStep = std::max(worstStep, glm::length(wh - wPrev));
                EXPECT_NEAR(glm::dot(uh, vh), 0.0, 1e-12);
                uPrev = uh;
                vPrev = vh;
                wPrev = wh;
            }
        // In-plane bends keep the binormal w = +z throughout (rotation-minimising frame).
        EXPECT_LT(worstStep, 0.05) << "bend " << bend;
        EXPECT_NEAR(wPrev.z, 1.0, 1e-9) << "bend " << bend;
    }
}

namespace {

// Whether some flow line of `ch` (v^2 + w^2 <= 1) reaches a point on the positive side of the
// plane n . x = d after passing below it (by more than `below`): a point the plane could shadow
// in the deformed shadow map. Walks 300 flow lines along every segment and the extension.
bool someFlowLineDipsBelow(const Chain<double>& ch, const dvec3& n, double d, double below) {
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (int line = 0; line < 300; ++line) {
        double v = u(rng), w = u(rng);
        if (v * v + w * w > 1.0) continue;
        if (line < 8) { // the rim, where flow lines spread or turn most
            v = std::cos(line * 0.785398);
            w = std::sin(line * 0.785398);
        }
        double lowest = 1e300;
        for (int k = 0; k <= ch.segments; ++k) {
            const double length = k < ch.segments ? 1.0 : 4.0;
            for (int i = 0; i <= 256; ++i) {
                const double t = length * i / 256.0;
                dvec3 uHat, vHat, wHat;
                tubeFrame(ch, k, t, uHat, vHat, wHat);
                const dvec3 X = chainPoint(ch, k, t) + chainRadius(ch, k, t) * (v * vHat + w * wHat);
                const double h = glm::dot(n, X) - d;
                if (h >= 0.0 && lowest < -below) return true;
                lowest = std::min(lowest, h);
            }
        }
    }
    return false;
}

} // namespace

// lightmath::flowLinesMissPlane lets the engine leave a floor out of a BendyLight's deformed
// shadow map: it must never say so for a chain whose light dips below the plane and comes back
// up to a receiver above it (such a plane shadows that receiver), and it must say so for chains
// that come down onto the plane.
TEST(BendyPlane, FlowLinesSaidToMissThePlaneNeverDipBelowIt) {
    // Straight down onto the floor y = 0 with a 27 degree cone: misses (descends everywhere).
    Chain<double> down;
    down.segments = 1;
    down.tanTheta = std::tan(0.47);
    setFrame(down, dvec3(0, -1, 0));
    down.p[0] = dvec3(0, 5, 0);
    down.p[1] = dvec3(0, 3, 0);
    down.p[2] = dvec3(0, 1, 0);
    for (int i = 0; i < 3; ++i) down.r[i] = 0.1 + 2.0 * i * std::tan(0.47);
    prepareChain(down);
    EXPECT_TRUE(flowLinesMissPlane(down, dvec3(0, 1, 0), 0.0, 1e-4));
    // High above the floor and then levelling out: still clear (the extension's flow lines are
    // straight and start above the floor).
    EXPECT_TRUE(flowLinesMissPlane(down, dvec3(0, 1, 0), -20.0, 1e-4));
    // A U: down below the floor and back up: a receiver above it is shadowed by the floor.
    Chain<double> u = down;
    u.segments = 2;
    u.p[1] = dvec3(0, -4, 0);
    u.p[2] = dvec3(2, -4, 0);
    u.p[3] = dvec3(4, -4, 0);
    u.p[4] = dvec3(4, 3, 0);
    for (int i = 0; i < 5; ++i) u.r[i] = 0.1 + 0.2 * i;
    prepareChain(u);
    EXPECT_TRUE(someFlowLineDipsBelow(u, dvec3(0, 1, 0), 0.0, 1e-6));
    EXPECT_FALSE(flowLinesMissPlane(u, dvec3(0, 1, 0), 0.0, 1e-4));
    // A shallow descent under a wide cone: the upper rim's flow lines rise.
    Chain<double> shallow = down;
    shallow.tanTheta = std::tan(1.2);
    setFrame(shallow, glm::normalize(dvec3(1, -0.3, 0)));
    shallow.p[1] = dvec3(4, 3.8, 0);
    shallow.p[2] = dvec3(8, 2.6, 0);
    for (int i = 0; i < 3; ++i) shallow.r[i] = 0.1 + 4.2 * i * std::tan(1.2);
    prepareChain(shallow);
    EXPECT_FALSE(flowLinesMissPlane(shallow, dvec3(0, 1, 0), 0.0, 1e-4));

    // Random chains heading for a plane across their path: none said to miss it dips below it.
    std::mt19937_64 rng(404);
    std::uniform_real_distribution<double> r01(0.0, 1.0);
    int missing = 0, notProven = 0, dipping = 0;
    for (int c = 0; c < 400; ++c) {
        const Chain<double> ch = randomChain(rng, 1 + c % 3);
        const dvec3 n = glm::normalize(dvec3(-1.0, 0.6 * (r01(rng) - 0.5), 0.6 * (r01(rng) - 0.5)));
        const dvec3 far = chainPoint(ch, ch.segments - 1, 1.0);
        const double d = glm::dot(n, far * (0.3 + 0.9 * r01(rng)));
        const bool dips = someFlowLineDipsBelow(ch, n, d, 1e-9);
        dipping += dips ? 1 : 0;
        if (flowLinesMissPlane(ch, n, d, 1e-6)) {
            ++missing;
            EXPECT_FALSE(dips) << "chain " << c;
        } else {
            ++notProven;
        }
    }
    std::printf("%d chains said to miss the plane, %d not proven; %d dip below it and come back up\n", missing, notProven, dipping);
    EXPECT_GT(missing, 40);
    EXPECT_GT(dipping, 40);
}

// tubePoint inverts eqs. 5-6: a point placed at tube coordinates inside the tube, away from
// where two feet compete (mid-segment, well inside), maps back to the same coordinates.
TEST(BendySolver, TubePointIsTheInverseOfTheTubeCoordinates) {
    std::mt19937_64 rng(20261203);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    int checked = 0;
    for (int c = 0; c < 200; ++c) {
        const Chain<double> ch = randomChain(rng, 1 + c % 4);
        for (int q = 0; q < 20; ++q) {
            const int k = int(std::abs(u(rng)) * ch.segments) % ch.segments;
            const double t = 0.5 + 0.3 * u(rng), v = 0.3 * u(rng), w = 0.3 * u(rng);
            const dvec3 Q = tubePoint(ch, k, t, v, w);
            TubeCoords<double> at;
            ASSERT_TRUE(tubeCoordinates(ch, Q, k, t, at));
            EXPECT_NEAR(at.v, v, 1e-9);
            EXPECT_NEAR(at.w, w, 1e-9);
            // The distance from the curve is the radius times |(v, w)|.
            EXPECT_NEAR(glm::length(Q - chainPoint(ch, k, t)), chainRadius(ch, k, t) * std::hypot(v, w), 1e-9);
            ++checked;
        }
    }
    EXPECT_EQ(checked, 4000);
}
