// Warps and GGX of kernels/cb_sampling.h: each density integrates to one, each sampler matches its
// density (chi-square), the maps are continuous (coherence), and GGX, isotropic and anisotropic,
// stays finite at alpha = 1e-4 and grazing angles.
#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "cb_sampling.h"
#include "chi2.h"

using namespace cbk;
using cbtest::kPi;

namespace {

// Chi-square tests in this file share one family-wise level of 1% (Sidak).
constexpr int kChi2Tests = 27;
const double kLevel = cbtest::sidak(0.01, kChi2Tests);

struct Uniform {
    std::mt19937 rng;
    explicit Uniform(unsigned seed) : rng(seed) {}
    // 24 random mantissa bits: uniform on [0, 1), never 1.
    float operator()() { return static_cast<float>(rng() >> 8) * (1.0f / 16777216.0f); }
};

double angleBetween(Vec3 a, Vec3 b) {
    double d = std::clamp(static_cast<double>(vdot(a, b)) /
                              std::sqrt(static_cast<double>(vlength2(a)) * vlength2(b)),
                          -1.0, 1.0);
    return std::acos(d);
}

// Chi-square of a direction sampler (local frame) against its claimed density.
cbtest::Chi2Result sphereChi2(const std::function<Vec3(float, float)>& sample,
                              const std::function<double(Vec3)>& pdf, int samples, unsigned seed,
                              double* integral = nullptr) {
    cbtest::SphereHistogram hist(20, 40);
    std::vector<double> observed(hist.cells(), 0.0);
    Uniform u(seed);
    for (int i = 0; i < samples; ++i) {
        float u0 = u(), u1 = u();
        observed[hist.cell(sample(u0, u1))] += 1.0;
    }
    std::vector<double> expected = hist.integrate(pdf);
    double total = 0.0;
    for (double& e : expected) {
        total += e;
        e *= samples;
    }
    if (integral) *integral = total;
    return cbtest::chi2Test(observed, expected, kLevel);
}

} // namespace

TEST_CASE("concentric disk: inside the unit disk, uniform, continuous") {
    Uniform u(1);
    const int n = 200000, nr = 10, nphi = 20;
    std::vector<double> observed(nr * nphi, 0.0);
    for (int i = 0; i < n; ++i) {
        float x, y;
        sampleConcentricDisk(u(), u(), &x, &y);
        double r2 = static_cast<double>(x) * x + static_cast<double>(y) * y;
        REQUIRE(r2 <= 1.0 + 1e-6);
        double phi = std::atan2(static_cast<double>(y), static_cast<double>(x));
        if (phi < 0.0) phi += 2.0 * kPi;
        // Cells of equal area: r^2 and phi uniform for a uniform disk.
        int ir = std::min(nr - 1, static_cast<int>(r2 * nr));
        int ip = std::min(nphi - 1, static_cast<int>(phi / (2.0 * kPi) * nphi));
        observed[ir * nphi + ip] += 1.0;
    }
    std::vector<double> expected(nr * nphi, static_cast<double>(n) / (nr * nphi));
    auto r = cbtest::chi2Test(observed, expected, kLevel);
    INFO(r.message);
    CHECK(r.passed);

    // Corners and centre: the map sends the square's boundary to the circle.
    float x, y;
    sampleConcentricDisk(0.5f, 0.5f, &x, &y);
    CHECK(x == 0.0f);
    CHECK(y == 0.0f);
    sampleConcentricDisk(1.0f, 1.0f, &x, &y);
    CHECK(std::hypot(x, y) == doctest::Approx(1.0).epsilon(1e-6));
    CHECK(std::atan2(y, x) == doctest::Approx(kPi / 4).epsilon(1e-6));

    // Lipschitz: the concentric map stretches distances by at most pi/2 * 2 (Shirley-Chiu).
    double worst = 0.0;
    const float h = 1e-3f;
    for (int i = 0; i <= 100; ++i)
        for (int j = 0; j <= 100; ++j) {
            float a = 0.98f * i / 100.0f + 0.01f, b = 0.98f * j / 100.0f + 0.01f;
            float x0, y0, x1, y1, x2, y2;
            sampleConcentricDisk(a, b, &x0, &y0);
            sampleConcentricDisk(a + h, b, &x1, &y1);
            sampleConcentricDisk(a, b + h, &x2, &y2);
            worst = std::max(worst, static_cast<double>(std::hypot(x1 - x0, y1 - y0) / h));
            worst = std::max(worst, static_cast<double>(std::hypot(x2 - x0, y2 - y0) / h));
        }
    CHECK(worst < kPi + 0.01);
}

TEST_CASE("cosine hemisphere: density integrates to 1 and matches the samples") {
    double integral = 0.0;
    auto r = sphereChi2(
        sampleCosineHemisphere, [](Vec3 w) { return cosineHemispherePdf(w.z); }, 300000, 2,
        &integral);
    INFO(r.message);
    CHECK(r.passed);
    CHECK(integral == doctest::Approx(1.0).epsilon(1e-6));
    CHECK(cosineHemispherePdf(-0.5f) == 0.0f);
    CHECK(cosineHemispherePdf(1.0f) == doctest::Approx(1.0 / kPi));
    Uniform u(3);
    for (int i = 0; i < 10000; ++i) {
        Vec3 w = sampleCosineHemisphere(u(), u());
        REQUIRE(w.z >= 0.0f);
        REQUIRE(vlength(w) == doctest::Approx(1.0).epsilon(1e-5));
    }
}

TEST_CASE("cosine hemisphere is continuous in u (coherent sample vectors)") {
    // z = sqrt(1 - r^2) has a square-root edge at the horizon, so nearby u give directions within
    // O(sqrt(du)) there and O(du) elsewhere: bound the angle for du = 1e-4 by 2 sqrt(2 du) * 2.
    const float h = 1e-4f;
    double worst = 0.0;
    for (int i = 0; i < 200; ++i)
        for (int j = 0; j < 200; ++j) {
            float a = (i + 0.5f) / 200.0f, b = (j + 0.5f) / 200.0f;
            Vec3 w = sampleCosineHemisphere(a, b);
            worst = std::max(worst, angleBetween(w, sampleCosineHemisphere(a + h, b)));
            worst = std::max(worst, angleBetween(w, sampleCosineHemisphere(a, b + h)));
        }
    CHECK(worst < 4.0 * std::sqrt(2.0 * h));
}

TEST_CASE("uniform sphere and hemisphere: densities integrate to 1 and match the samples") {
    double integral = 0.0;
    auto r = sphereChi2(
        sampleUniformSphere, [](Vec3) { return uniformSpherePdf(); }, 300000, 4, &integral);
    INFO(r.message);
    CHECK(r.passed);
    CHECK(integral == doctest::Approx(1.0).epsilon(1e-6));

    auto r2 = sphereChi2(
        sampleUniformHemisphere, [](Vec3 w) { return w.z > 0.0f ? uniformHemispherePdf() : 0.0f; },
        300000, 5, &integral);
    INFO(r2.message);
    CHECK(r2.passed);
    CHECK(integral == doctest::Approx(1.0).epsilon(1e-6));
}

TEST_CASE("equal-area map: uniform square points are uniform directions, and it inverts") {
    // Equal area: the square's uniform points must land uniformly on the sphere.
    auto r = sphereChi2([](float u0, float u1) { return equalAreaSquareToSphere(u0, u1); },
                        [](Vec3) { return uniformSpherePdf(); }, 300000, 21);
    INFO(r.message);
    CHECK(r.passed);
    // pbrt-v4's layout (Clarberg): the centre is +z, the corners -z, the edges' midpoints the
    // horizon's axes, u toward +x and v toward +y; a mirrored or rotated map fails here.
    struct Pin {
        float s, t, x, y, z;
    };
    for (const Pin& p : {Pin{0.5f, 0.5f, 0, 0, 1}, Pin{0.f, 0.f, 0, 0, -1}, Pin{1.f, 1.f, 0, 0, -1},
                         Pin{1.f, 0.5f, 1, 0, 0}, Pin{0.f, 0.5f, -1, 0, 0}, Pin{0.5f, 1.f, 0, 1, 0},
                         Pin{0.5f, 0.f, 0, -1, 0}, Pin{0.75f, 0.75f, 0.7071068f, 0.7071068f, 0}}) {
        CAPTURE(p.s);
        CAPTURE(p.t);
        const Vec3 w = equalAreaSquareToSphere(p.s, p.t);
        CHECK(w.x == doctest::Approx(p.x).epsilon(1e-6));
        CHECK(w.y == doctest::Approx(p.y).epsilon(1e-6));
        CHECK(w.z == doctest::Approx(p.z).epsilon(1e-6));
    }
    // z = 1 - r^2 north of the equator, r = |u| + |v| in [-1,1]^2.
    CHECK(equalAreaSquareToSphere(0.6f, 0.55f).z == doctest::Approx(1.0 - 0.3 * 0.3).epsilon(1e-6));
    // Round trip over a grid that avoids the seams, every direction of unit length.
    double worst = 0.0;
    for (int i = 0; i < 101; ++i)
        for (int j = 0; j < 101; ++j) {
            const float s = (float(i) + 0.37f) / 101.f, t = (float(j) + 0.61f) / 101.f;
            const Vec3 w = equalAreaSquareToSphere(s, t);
            CHECK(std::fabs(vlength2(w) - 1.f) < 1e-5f);
            float s2, t2;
            equalAreaSphereToSquare(w, &s2, &t2);
            worst = std::max({worst, double(std::fabs(s2 - s)), double(std::fabs(t2 - t))});
        }
    CHECK(worst < 2e-6);
}

TEST_CASE("tabulated CDF: each interval with its probability, empty ones never") {
    // Weights 0, 2, 0, 0, 1, 5, 0 (the last and the first empty).
    const std::vector<float> cdf{0.f, 0.f, 0.25f, 0.25f, 0.25f, 0.375f, 1.f, 1.f};
    const int count = int(cdf.size()) - 1;
    std::vector<double> observed(size_t(count), 0.0), expected(size_t(count), 0.0);
    Uniform u(22);
    constexpr int kSamples = 200000;
    double withinSum = 0.0;
    for (int i = 0; i < kSamples; ++i) {
        float within = -1.f;
        const int k = sampleCdf(cdf.data(), count, u(), &within);
        REQUIRE(k >= 0);
        REQUIRE(k < count);
        CHECK(cdf[size_t(k) + 1] > cdf[size_t(k)]);
        CHECK(within >= 0.f);
        CHECK(within < 1.f);
        observed[size_t(k)] += 1.0;
        withinSum += within;
    }
    for (int k = 0; k < count; ++k)
        expected[size_t(k)] = double(cdf[size_t(k) + 1] - cdf[size_t(k)]) * kSamples;
    // chi2Test needs expected counts > 0: compare the non-empty intervals.
    std::vector<double> o, e;
    for (int k = 0; k < count; ++k)
        if (expected[size_t(k)] > 0.0) {
            o.push_back(observed[size_t(k)]);
            e.push_back(expected[size_t(k)]);
        } else {
            CHECK(observed[size_t(k)] == 0.0);
        }
    auto r = cbtest::chi2Test(o, e, kLevel);
    INFO(r.message);
    CHECK(r.passed);
    // The position within the interval is uniform: mean 1/2 (standard error 0.29 / sqrt(n)).
    CHECK(withinSum / kSamples == doctest::Approx(0.5).epsilon(0.01));
    // The edges: u = 0 skips the empty first interval, u just below 1 the empty last one, and a
    // value on a boundary belongs to the interval it starts.
    float within = 0.f;
    CHECK(sampleCdf(cdf.data(), count, 0.f, &within) == 1);
    CHECK(within == 0.f);
    CHECK(sampleCdf(cdf.data(), count, 0.99999994f, &within) == 5);
    CHECK(sampleCdf(cdf.data(), count, 0.25f, &within) == 4);
    CHECK(sampleCdf(cdf.data(), count, 0.375f, &within) == 5);
}

TEST_CASE("uniform triangle: barycentrics uniform by area, continuous across the diagonal") {
    const int n = 20, samples = 300000;
    std::vector<double> observed(n * n, 0.0), expected(n * n, 0.0);
    Uniform u(6);
    for (int i = 0; i < samples; ++i) {
        float b0, b1, b2;
        sampleUniformTriangle(u(), u(), &b0, &b1, &b2);
        REQUIRE(b0 >= 0.0f);
        REQUIRE(b1 >= 0.0f);
        REQUIRE(b2 >= 0.0f);
        REQUIRE(b0 + b1 + b2 == doctest::Approx(1.0).epsilon(1e-6));
        int i1 = std::min(n - 1, static_cast<int>(b1 * n));
        int i2 = std::min(n - 1, static_cast<int>(b2 * n));
        observed[i1 * n + i2] += 1.0;
    }
    // Grid cells in (b1, b2) cut by the hypotenuse b1 + b2 = 1: whole, half or empty; the pdf
    // (1 / area = 2) over them sums to exactly 1.
    double total = 0.0;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            double area = i + j + 2 <= n ? 1.0 : (i + j + 1 == n ? 0.5 : 0.0);
            double p = 2.0 * area / (n * n);
            total += p;
            expected[i * n + j] = p * samples;
        }
    CHECK(total == doctest::Approx(1.0).epsilon(1e-12));
    auto r = cbtest::chi2Test(observed, expected, kLevel);
    INFO(r.message);
    CHECK(r.passed);

    // Both branches agree on the diagonal u0 == u1 and the map is Lipschitz.
    float a0, a1, a2, c0, c1, c2;
    sampleUniformTriangle(0.4f, 0.4f, &a0, &a1, &a2);
    sampleUniformTriangle(0.4f, std::nextafter(0.4f, 1.0f), &c0, &c1, &c2);
    CHECK(std::fabs(a0 - c0) < 1e-6f);
    CHECK(std::fabs(a1 - c1) < 1e-6f);
    // The corners of the square go to the triangle's vertices.
    sampleUniformTriangle(0.0f, 0.0f, &a0, &a1, &a2);
    CHECK(a2 == 1.0f);
    sampleUniformTriangle(1.0f, 0.0f, &a0, &a1, &a2);
    CHECK(a0 == 1.0f);
    sampleUniformTriangle(1.0f, 1.0f, &a0, &a1, &a2);
    CHECK(a0 + a1 == doctest::Approx(1.0));
}

// Isotropic and anisotropic GGX alphas (along x, along y) the tests below go through.
const GgxAlpha kGgxAlphas[] = {{0.05f, 0.05f}, {0.3f, 0.3f}, {1.0f, 1.0f},
                               {0.05f, 0.4f},  {0.6f, 0.1f}, {1.0f, 0.3f}};

std::ostream& operator<<(std::ostream& out, GgxAlpha a) {
    return out << "(" << a.x << ", " << a.y << ")";
}

TEST_CASE("GGX: D is normalised (projected area 1) and the visible-normal pdf integrates to 1") {
    for (GgxAlpha alpha : kGgxAlphas) {
        // Fine panels in phi for the anisotropic lobes, which vary with it.
        cbtest::SphereHistogram hist(40, alpha.x == alpha.y ? 8 : 32);
        // Fine theta panels resolve the narrow peak at alpha = 0.05.
        std::vector<double> proj =
            hist.integrate([&](Vec3 wm) { return ggxD(wm, alpha) * fmax(wm.z, 0.0f); }, 4);
        double sum = 0.0;
        for (double v : proj)
            sum += v;
        INFO("alpha = " << alpha);
        CHECK(sum == doctest::Approx(1.0).epsilon(1e-4));
        for (float cosO : {1.0f, 0.7f, 0.2f, 0.05f}) {
            const float sinO = std::sqrt(1.0f - cosO * cosO);
            Vec3 wo = vec3(0.6f * sinO, 0.8f * sinO, cosO);
            std::vector<double> v =
                hist.integrate([&](Vec3 wm) { return ggxVisibleNormalPdf(wo, wm, alpha); }, 4);
            double s = 0.0;
            for (double x : v)
                s += x;
            INFO("cos wo = " << cosO);
            CHECK(s == doctest::Approx(1.0).epsilon(1e-3));
        }
    }
}

TEST_CASE("GGX: Smith G1 and Lambda against closed forms") {
    // alpha = 1, theta = 60 deg: Lambda = (sqrt(1 + 3) - 1) / 2 = 0.5, G1 = 2/3.
    Vec3 w = vec3(std::sqrt(3.0f) / 2.0f, 0.0f, 0.5f);
    CHECK(ggxLambda(w, ggxIsotropic(1.0f)) == doctest::Approx(0.5).epsilon(1e-6));
    CHECK(ggxG1(w, ggxIsotropic(1.0f)) == doctest::Approx(2.0 / 3.0).epsilon(1e-6));
    CHECK(ggxG(w, w, ggxIsotropic(1.0f)) == doctest::Approx(0.5).epsilon(1e-6));
    CHECK(ggxG1(vec3(0.0f, 0.0f, 1.0f), ggxIsotropic(0.5f)) == 1.0f);
    CHECK(ggxD(vec3(0.0f, 0.0f, 1.0f), ggxIsotropic(0.5f)) == doctest::Approx(1.0 / (kPi * 0.25)));
    CHECK(ggxD(vec3(0.0f, 0.0f, -1.0f), ggxIsotropic(0.5f)) == 0.0f);
    // Tangent plane: no visibility.
    CHECK(ggxG1(vec3(1.0f, 0.0f, 0.0f), ggxIsotropic(0.3f)) < 1e-30f);
    // Small-slope regime where the naive (sqrt(1+s)-1)/2 would cancel to zero.
    Vec3 near = vnormalize(vec3(1e-3f, 0.0f, 1.0f));
    double tan2 = 1e-6 * 1e-8; // alpha = 1e-4
    CHECK(ggxLambda(near, ggxIsotropic(1e-4f)) == doctest::Approx(tan2 / 4.0).epsilon(1e-3));
}

TEST_CASE("anisotropic GGX: D, Lambda and sampling against the polar forms and the axes") {
    // Heitz 2014, eq. 85: D = 1 / (pi ax ay cos^4 (1 + tan^2 (cos^2 phi / ax^2 + sin^2 phi /
    // ay^2))^2); eq. 86: Lambda with alpha^2 = ax^2 cos^2 phi + ay^2 sin^2 phi.
    const GgxAlpha a = {0.6f, 0.2f};
    double worstD = 0.0, worstLambda = 0.0;
    for (double theta : {0.0, 0.1, 0.5, 1.0, 1.4})
        for (double phi : {0.0, 0.3, 0.785398, 1.2, 1.5707963, 2.5, 4.0}) {
            const Vec3 w = vec3(float(std::sin(theta) * std::cos(phi)),
                                float(std::sin(theta) * std::sin(phi)), float(std::cos(theta)));
            const double c = std::cos(theta), t2 = std::tan(theta) * std::tan(theta);
            const double e =
                t2 * (std::pow(std::cos(phi) / a.x, 2) + std::pow(std::sin(phi) / a.y, 2));
            const double d = 1.0 / (kPi * a.x * a.y * std::pow(c, 4) * (1.0 + e) * (1.0 + e));
            const double alpha2 =
                std::pow(a.x * std::cos(phi), 2) + std::pow(a.y * std::sin(phi), 2);
            const double lambda = (std::sqrt(1.0 + alpha2 * t2) - 1.0) / 2.0;
            worstD = std::max(worstD, std::fabs(ggxD(w, a) / d - 1.0));
            if (lambda > 0.0)
                worstLambda = std::max(worstLambda, std::fabs(ggxLambda(w, a) / lambda - 1.0));
            else
                CHECK(ggxLambda(w, a) == 0.0f);
        }
    CHECK(worstD < 1e-5);
    CHECK(worstLambda < 1e-5);
    // Along each axis the lobe is the isotropic one of that axis's alpha; swapping the axes
    // swaps the alphas.
    const Vec3 alongX = vnormalize(vec3(0.8f, 0.0f, 0.6f)), alongY = vec3(0.0f, 0.8f, 0.6f);
    CHECK(ggxLambda(alongX, a) == doctest::Approx(ggxLambda(alongX, ggxIsotropic(a.x))));
    CHECK(ggxLambda(alongY, a) == doctest::Approx(ggxLambda(alongY, ggxIsotropic(a.y))));
    const GgxAlpha swapped = {a.y, a.x};
    Uniform u(21);
    for (int i = 0; i < 200; ++i) {
        const Vec3 wm = ggxSampleVisibleNormal(alongX, a, u(), u());
        const Vec3 turned = vec3(-wm.y, wm.x, wm.z), woTurned = vec3(0.0f, 0.8f, 0.6f);
        CHECK(ggxD(turned, swapped) == doctest::Approx(ggxD(wm, a)).epsilon(1e-5));
        CHECK(ggxVisibleNormalPdf(woTurned, turned, swapped) ==
              doctest::Approx(ggxVisibleNormalPdf(alongX, wm, a)).epsilon(1e-4));
    }
    // The sampled normals spread by each axis's alpha: at normal incidence the slopes x/z and
    // y/z have spreads in the ratio ax : ay.
    double sx = 0.0, sy = 0.0;
    for (int i = 0; i < 20000; ++i) {
        const Vec3 wm = ggxSampleVisibleNormal(vec3(0.0f, 0.0f, 1.0f), a, u(), u());
        sx += std::fabs(wm.x / wm.z);
        sy += std::fabs(wm.y / wm.z);
    }
    CHECK(sx / sy == doctest::Approx(a.x / a.y).epsilon(0.03));
}

TEST_CASE("GGX visible normals: sampled histogram matches ggxVisibleNormalPdf") {
    int k = 0;
    for (GgxAlpha alpha : {GgxAlpha{0.1f, 0.1f}, GgxAlpha{0.5f, 0.5f}, GgxAlpha{1.0f, 1.0f},
                           GgxAlpha{0.1f, 0.5f}, GgxAlpha{0.8f, 0.2f}, GgxAlpha{0.05f, 1.0f}})
        for (float cosO : {0.9f, 0.3f, 0.05f}) {
            Vec3 wo = vnormalize(vec3(std::sqrt(1.0f - cosO * cosO) * 0.6f,
                                      std::sqrt(1.0f - cosO * cosO) * -0.8f, cosO));
            double integral = 0.0;
            auto r = sphereChi2(
                [&](float a, float b) { return ggxSampleVisibleNormal(wo, alpha, a, b); },
                [&](Vec3 wm) { return ggxVisibleNormalPdf(wo, wm, alpha); }, 100000, 100 + k++,
                &integral);
            INFO("alpha = " << alpha << ", cos wo = " << cosO << ": " << r.message);
            CHECK(r.passed);
            CHECK(integral == doctest::Approx(1.0).epsilon(2e-3));
        }
}

TEST_CASE("GGX at alpha = 1e-4 and grazing angles stays finite") {
    for (const GgxAlpha alpha : {ggxIsotropic(1e-4f), GgxAlpha{1e-4f, 1.0f}}) {
        Uniform u(7);
        for (float cosO : {1.0f, 0.5f, 0.05f, 1e-4f, 1e-8f, 1e-30f, 0.0f}) {
            Vec3 wo = vec3(std::sqrt(1.0f - cosO * cosO), 0.0f, cosO);
            CHECK(std::isfinite(ggxLambda(wo, alpha)));
            CHECK(std::isfinite(ggxG1(wo, alpha)));
            int near = 0;
            for (int i = 0; i < 2000; ++i) {
                float a = i == 0 ? 0.0f : (i == 1 ? 0.99999994f : u()), b = u();
                Vec3 wm = ggxSampleVisibleNormal(wo, alpha, a, b);
                REQUIRE(std::isfinite(wm.x));
                REQUIRE(std::isfinite(wm.y));
                REQUIRE(std::isfinite(wm.z));
                REQUIRE(wm.z >= 0.0f);
                REQUIRE(vlength(wm) == doctest::Approx(1.0).epsilon(1e-5));
                float d = ggxD(wm, alpha), p = ggxVisibleNormalPdf(wo, wm, alpha);
                REQUIRE(std::isfinite(d));
                REQUIRE(std::isfinite(p));
                REQUIRE(p >= 0.0f);
                if (std::acos(std::min(wm.z, 1.0f)) < 5e-3) ++near;
            }
            // The normals concentrate at the macro normal: at normal incidence P(tan > T) =
            // alpha^2 / (alpha^2 + T^2), 4e-4 for T = 5e-3 (the edge u = 0 maps to the horizon).
            if (cosO > 0.01f && alpha.x == alpha.y) CHECK(near > 2000 * 99 / 100);
        }
    }
}

TEST_CASE("power heuristic: values and robustness to zero, infinity and overflow") {
    const float inf = std::numeric_limits<float>::infinity();
    CHECK(powerHeuristic(1.0f, 1.0f) == doctest::Approx(0.5));
    CHECK(powerHeuristic(2.0f, 1.0f) == doctest::Approx(0.8));
    CHECK(powerHeuristic(1.0f, 3.0f) == doctest::Approx(0.1));
    CHECK(powerHeuristic(0.0f, 1.0f) == 0.0f);
    CHECK(powerHeuristic(1.0f, 0.0f) == 1.0f);
    CHECK(powerHeuristic(0.0f, 0.0f) == 0.0f);
    CHECK(powerHeuristic(inf, 1.0f) == 1.0f);
    CHECK(powerHeuristic(1.0f, inf) == 0.0f);
    CHECK(powerHeuristic(inf, inf) == 0.5f);
    CHECK(powerHeuristic(1e30f, 1e-30f) == 1.0f);
    CHECK(powerHeuristic(1e-30f, 1e30f) == 0.0f);
    CHECK(powerHeuristic(3e20f, 4e20f) == doctest::Approx(9.0 / 25.0));
    CHECK(powerHeuristic(std::nanf(""), 1.0f) == 0.0f);
}
