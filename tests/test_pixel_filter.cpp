// Pixel filters (kernels/cb_filter.h): pbrt-v4's PixelFilter lines, each filter's sampling
// against its distribution function integrated here (with its weights for the filters with
// negative lobes), splat weights and their reach, and every method's image of a reflectance edge
// against the edge convolved with the filter.
#include <doctest/doctest.h>

#include "cb_camera.h"
#include "method_checks.h"
#include "scene/device_scene.h"
#include "scene_files.h"

#include <array>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

using namespace cbtest::method_checks;
using namespace cbtest::scene_files;

namespace {

struct FilterCase {
    const char* line; // the PixelFilter line ("" for none: pbrt-v4's default)
    int type;
    double radiusX, radiusY, sigma;
    double mitchellB = 1.0 / 3.0, mitchellC = 1.0 / 3.0, sincTau = 3.0;
};

// pbrt-v4's one-axis filters (filters.h), written out again as the oracle: the box on [-r, r],
// the triangle r - |x|, the gaussian G(x) - G(r) for the normal density G of deviation sigma,
// Mitchell and Netravali's cubic at 2 |x| / r, sinc(x) sinc(x / tau).
double oracleFilter(const FilterCase& f, double radius, double x) {
    const double a = std::fabs(x);
    if (a > radius) return 0.0;
    if (f.type == CB_FILTER_BOX) return 1.0;
    if (f.type == CB_FILTER_TRIANGLE) return radius - a;
    if (f.type == CB_FILTER_MITCHELL) {
        const double t = 2.0 * a / radius, b = f.mitchellB, c = f.mitchellC;
        return t <= 1.0 ? ((12 - 9 * b - 6 * c) * t * t * t + (-18 + 12 * b + 6 * c) * t * t +
                           (6 - 2 * b)) /
                              6.0
                        : ((-b - 6 * c) * t * t * t + (6 * b + 30 * c) * t * t +
                           (-12 * b - 48 * c) * t + (8 * b + 24 * c)) /
                              6.0;
    }
    if (f.type == CB_FILTER_SINC) {
        auto sinc = [](double y) { return y == 0.0 ? 1.0 : std::sin(M_PI * y) / (M_PI * y); };
        return sinc(a) * sinc(a / f.sincTau);
    }
    auto normal = [&](double t) {
        return std::exp(-t * t / (2.0 * f.sigma * f.sigma)) /
               std::sqrt(2.0 * M_PI * f.sigma * f.sigma);
    };
    return std::max(0.0, normal(a) - normal(radius));
}

// The integral of oracleFilter over [lo, hi] by Simpson's rule on 2 n panels.
double oracleIntegral(const FilterCase& f, double radius, double lo, double hi, int n = 500) {
    const double h = (hi - lo) / (2.0 * n);
    double sum = oracleFilter(f, radius, lo) + oracleFilter(f, radius, hi);
    for (int i = 1; i < 2 * n; ++i)
        sum += (i % 2 ? 4.0 : 2.0) * oracleFilter(f, radius, lo + i * h);
    return sum * h / 3.0;
}

// The filter's share below offset x, its integral over (-r, x) over its whole integral: the
// probability that a sample lands below x for the filters without negative lobes, the expected
// weight of the samples below x for those with them. Pieces split at 0 (the triangle's kink).
double oracleCdf(const FilterCase& f, double radius, double x) {
    if (x <= -radius) return 0.0;
    if (x >= radius) return 1.0;
    const double total = 2.0 * oracleIntegral(f, radius, 0.0, radius);
    const double part =
        x <= 0.0 ? oracleIntegral(f, radius, -radius, x)
                 : oracleIntegral(f, radius, -radius, 0.0) + oracleIntegral(f, radius, 0.0, x);
    return part / total;
}

const FilterCase kFilters[] = {
    {"", CB_FILTER_GAUSSIAN, 1.5, 1.5, 0.5},
    {"PixelFilter \"gaussian\" \"float xradius\" 2 \"float sigma\" 1", CB_FILTER_GAUSSIAN, 2.0, 1.5,
     1.0},
    {"PixelFilter \"triangle\"", CB_FILTER_TRIANGLE, 2.0, 2.0, 0.5},
    {"PixelFilter \"triangle\" \"float xradius\" 1 \"float yradius\" 0.75", CB_FILTER_TRIANGLE, 1.0,
     0.75, 0.5},
    {"PixelFilter \"box\"", CB_FILTER_BOX, 0.5, 0.5, 0.5},
    {"PixelFilter \"box\" \"float xradius\" 1.25", CB_FILTER_BOX, 1.25, 0.5, 0.5},
    {"PixelFilter \"mitchell\"", CB_FILTER_MITCHELL, 2.0, 2.0, 0.5},
    {"PixelFilter \"mitchell\" \"float B\" 0 \"float C\" 0.5 \"float yradius\" 1.5",
     CB_FILTER_MITCHELL, 2.0, 1.5, 0.5, 0.0, 0.5},
    {"PixelFilter \"sinc\"", CB_FILTER_SINC, 4.0, 4.0, 0.5},
    {"PixelFilter \"sinc\" \"float xradius\" 2.5 \"float yradius\" 3 \"float tau\" 2",
     CB_FILTER_SINC, 2.5, 3.0, 0.5, 1.0 / 3.0, 1.0 / 3.0, 2.0},
};

cb::DeviceScene filteredScene(const std::string& filterLine, int width, int height,
                              const std::string& world = "") {
    return cb::buildDeviceScene(parseInTemp(
        filterLine + "\nLookAt 0 0 3  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 40\n" +
        "Film \"rgb\" \"integer xresolution\" " + std::to_string(width) +
        " \"integer yresolution\" " + std::to_string(height) + "\nWorldBegin\n" +
        (world.empty() ? "LightSource \"infinite\" \"rgb L\" [1 1 1]\nShape \"sphere\"\n"
                       : world)));
}

} // namespace

TEST_CASE("pixel filters: PixelFilter lines, pbrt-v4's defaults, what is refused") {
    TempDirCleanup cleanup;
    for (const FilterCase& f : kFilters) {
        CAPTURE(std::string(f.line));
        const cb::SceneDesc desc = parseInTemp(std::string(f.line) + "\nWorldBegin\n");
        CHECK(desc.notes.empty());
        const cb::DeviceScene scene = filteredScene(f.line, 8, 8);
        CHECK(scene.camera.filterType == f.type);
        CHECK(scene.camera.filterRadiusX == float(f.radiusX));
        CHECK(scene.camera.filterRadiusY == float(f.radiusY));
        if (f.type == CB_FILTER_GAUSSIAN) CHECK(scene.camera.filterSigma == float(f.sigma));
        if (f.type == CB_FILTER_MITCHELL) {
            CHECK(scene.camera.filterMitchellB == float(f.mitchellB));
            CHECK(scene.camera.filterMitchellC == float(f.mitchellC));
            // pbrt-v4's MitchellFilter::Integral, r_x r_y / 4, for every B and C.
            CHECK(scene.camera.filterNormalization ==
                  doctest::Approx(4.0 / (f.radiusX * f.radiusY)).epsilon(1e-5));
        }
        if (f.type == CB_FILTER_SINC) CHECK(scene.camera.filterSincTau == float(f.sincTau));
        // Only the box of radius 0.5 compiles without the filter code.
        const bool onePixelBox = f.type == CB_FILTER_BOX && f.radiusX == 0.5 && f.radiusY == 0.5;
        CHECK(((scene.features & CB_FEATURE_PIXEL_FILTER) != 0) == !onePixelBox);
    }
    std::string e = errorOf("PixelFilter \"lanczos\"\nWorldBegin\n");
    CHECK(contains(e, "t.pbrt:1:13"));
    CHECK(contains(e, "not a filter"));
    e = errorOf("PixelFilter \"gaussian\" \"float xradius\" 0\nWorldBegin\n");
    CHECK(contains(e, "t.pbrt:1:40"));
    CHECK(contains(e, "\"float xradius\" must be in (0, 32] pixels, got 0"));
    e = errorOf("PixelFilter \"box\" \"float yradius\" 40\nWorldBegin\n");
    CHECK(contains(e, "yradius"));
    CHECK(contains(e, "got 40"));
    e = errorOf("PixelFilter \"gaussian\" \"float sigma\" -1\nWorldBegin\n");
    CHECK(contains(e, "sigma"));
    CHECK(contains(e, "got -1"));
    e = errorOf("PixelFilter \"mitchell\" \"float C\" 1e9\nWorldBegin\n");
    CHECK(contains(e, "t.pbrt:1:34"));
    CHECK(contains(e, "\"float C\" must be in [-100, 100], got 1e+09"));
    e = errorOf("PixelFilter \"sinc\"\n  \"float tau\" 0\nWorldBegin\n");
    CHECK(contains(e, "t.pbrt:2:15"));
    CHECK(contains(e, "\"float tau\" must be in [0.1, 32], got 0"));
    // Parameters another filter takes are errors, as in pbrt-v4.
    CHECK(contains(errorOf("PixelFilter \"triangle\" \"float sigma\" 1\nWorldBegin\n"), "sigma"));
    CHECK(contains(errorOf("PixelFilter \"mitchell\" \"float tau\" 1\nWorldBegin\n"), "tau"));
    CHECK(contains(errorOf("PixelFilter \"sinc\" \"float B\" 1\nWorldBegin\n"), "\"float B\""));
    CHECK(contains(errorOf("WorldBegin\nPixelFilter \"box\"\n"), "PixelFilter"));
}

TEST_CASE("pixel filters: each filter's samples invert its distribution function") {
    // A gaussian wider than its radius (sigma 2 r: g(x) - g(r) cancels, within 1e-5) beside the
    // parsed cases (within 2e-6).
    const FilterCase wide = {"", CB_FILTER_GAUSSIAN, 0.5, 0.5, 1.0};
    for (const FilterCase& f :
         {kFilters[0], kFilters[1], kFilters[2], kFilters[3], kFilters[4], kFilters[5], wide}) {
        const double tolerance = f.sigma > f.radiusX ? 1e-5 : 2e-6;
        for (const double radius : {f.radiusX, f.radiusY}) {
            CAPTURE(std::string(f.line));
            CAPTURE(radius);
            const double total = 2.0 * oracleIntegral(f, radius, 0.0, radius);
            const double normalization =
                cbk::filterNormalization(f.type, float(radius), float(radius), float(f.sigma));
            // pbrt-v4's G is the normal density, cb_filter.h's gaussian leaves out its factor
            // 1 / (sqrt(2 pi) sigma) on each axis (it cancels in the weights).
            const double unnormalized =
                f.type == CB_FILTER_GAUSSIAN ? total * std::sqrt(2.0 * M_PI) * f.sigma : total;
            CHECK(normalization ==
                  doctest::Approx(1.0 / (unnormalized * unnormalized)).epsilon(1e-5));
            double previous = -radius;
            for (int k = 0; k < 512; ++k) {
                const double u = (k + 0.5) / 512.0;
                const double x =
                    cbk::filterSample1(f.type, float(radius), float(f.sigma), float(u));
                CAPTURE(u);
                CAPTURE(x);
                CHECK(x > -radius);
                CHECK(x < radius);
                CHECK(x > previous); // monotone in u
                CHECK(std::fabs(oracleCdf(f, radius, x) - u) < tolerance);
                previous = x;
            }
        }
    }
}

// Mitchell's and the sinc's samples, drawn from a table of |f1|, weigh h / their density: over u
// (the midpoint rule on 2^18 points) the weight of the samples below x sums to the filter's own
// share below x, negative lobes included; each weight has the sign of f1 there, their sizes
// average the integral of |f1| over that of f1 and spread little about it.
TEST_CASE("pixel filters: negative lobes' samples and weights integrate to the filter") {
    TempDirCleanup cleanup;
    for (const FilterCase& f : {kFilters[6], kFilters[7], kFilters[8], kFilters[9]}) {
        CAPTURE(std::string(f.line));
        const cbk::Camera camera = filteredScene(f.line, 8, 8).camera;
        for (int axis = 0; axis < 2; ++axis) {
            CAPTURE(axis);
            const double radius = axis == 0 ? f.radiusX : f.radiusY;
            // The integral of |f1| over [0, r] (Simpson's rule on |f1|, whose kinks at f1's zeros
            // cost little with this many panels) over f1's.
            double absIntegral = 0.0;
            const int panels = 1 << 16;
            for (int i = 0; i <= 2 * panels; ++i)
                absIntegral += (i == 0 || i == 2 * panels ? 1.0
                                : i % 2                   ? 4.0
                                                          : 2.0) *
                               std::fabs(oracleFilter(f, radius, radius * i / (2.0 * panels)));
            absIntegral *= radius / (2.0 * panels) / 3.0;
            const double absRatio = absIntegral / oracleIntegral(f, radius, 0.0, radius, 20000);
            std::vector<double> thresholds;
            for (double x = -radius; x <= radius + 1e-9; x += radius / 8.0)
                thresholds.push_back(x);
            std::vector<double> below(thresholds.size(), 0.0);
            const int n = 1 << 18;
            double previous = -radius;
            int outOfOrder = 0, wrongSign = 0;
            double absSum = 0.0, squareSum = 0.0;
            for (int k = 0; k < n; ++k) {
                const float u = float((k + 0.5) / n);
                float weight = 0.0f;
                const double x = cbk::filterPixelSample(&camera, axis, 0, u, &weight) - 0.5;
                outOfOrder += !(x >= previous && x > -radius && x < radius);
                previous = x;
                const double oracle = oracleFilter(f, radius, x);
                if (std::fabs(oracle) > 1e-4) wrongSign += (weight > 0.0f) != (oracle > 0.0);
                absSum += std::fabs(weight);
                squareSum += double(weight) * weight;
                for (size_t i = 0; i < thresholds.size(); ++i)
                    if (x < thresholds[i]) below[i] += weight;
            }
            CHECK(outOfOrder == 0);
            CHECK(wrongSign == 0);
            CHECK(absSum / n == doctest::Approx(absRatio).epsilon(2e-4));
            // What the weights' spread adds to a pixel's variance, against weights of one size
            // (pbrt-v4's, drawn from its tabulated filter): 0.25-1.5% here.
            CHECK(squareSum * n / (absSum * absSum) < 1.02);
            for (size_t i = 0; i < thresholds.size(); ++i) {
                CAPTURE(thresholds[i]);
                CHECK(std::fabs(below[i] / n - oracleCdf(f, radius, thresholds[i])) < 2e-4);
            }
        }
    }
}

TEST_CASE("pixel filters: splat weights, their reach, and the one-pixel box unchanged") {
    TempDirCleanup cleanup;
    const int w = 8, h = 6;
    for (const FilterCase& f : kFilters) {
        CAPTURE(std::string(f.line));
        const cbk::Camera camera = filteredScene(f.line, w, h).camera;
        // A pixel's weights integrate to 1 over the plane (midpoint rule, 1/32 pixel, over a
        // square a little wider than the filter).
        const int n = 32, px = 3, py = 2;
        const int nx = int(std::ceil((f.radiusX + 0.25) * n)),
                  ny = int(std::ceil((f.radiusY + 0.25) * n));
        double sum = 0.0;
        for (int i = -nx; i < nx; ++i)
            for (int j = -ny; j < ny; ++j)
                sum += cbk::filterSplatWeight(&camera, px, py, float(px + 0.5 + (i + 0.5) / n),
                                              float(py + 0.5 + (j + 0.5) / n));
        CHECK(sum / (n * n) == doctest::Approx(1.0).epsilon(2e-3));
        // Every pixel a point weighs lies in its footprint, and points of weight lie where some
        // filter reaches: a grid over the image and a margin beyond the largest radius.
        // Pixel (x, y)'s weight at a point: the oracle's f over its integral.
        const double integral = 4.0 * oracleIntegral(f, f.radiusX, 0.0, f.radiusX) *
                                oracleIntegral(f, f.radiusY, 0.0, f.radiusY);
        const double peak = oracleFilter(f, f.radiusX, 0.0) * oracleFilter(f, f.radiusY, 0.0);
        for (float ry = -4.6f; ry < float(h) + 4.6f; ry += 0.23f)
            for (float rx = -4.6f; rx < float(w) + 4.6f; rx += 0.23f) {
                int x0, x1, y0, y1;
                cbk::filterFootprint(&camera, rx, ry, &x0, &x1, &y0, &y1);
                bool any = false;
                for (int y = 0; y < h; ++y)
                    for (int x = 0; x < w; ++x) {
                        const double oracle = oracleFilter(f, f.radiusX, rx - (x + 0.5)) *
                                              oracleFilter(f, f.radiusY, ry - (y + 0.5));
                        if (!(std::fabs(oracle) > 1e-6)) continue;
                        any = true;
                        CAPTURE(rx);
                        CAPTURE(ry);
                        CHECK((x0 <= x && x <= x1 && y0 <= y && y <= y1));
                        CHECK(std::fabs(cbk::filterSplatWeight(&camera, x, y, rx, ry) -
                                        oracle / integral) < 1e-5 * peak / integral);
                    }
                if (any) CHECK(cbk::filterReaches(&camera, rx, ry));
            }
    }
    // The box of radius 0.5 is what cbdpt always rendered: pixel + u, the pixel floor(p) alone,
    // weight 1, the image's own bounds.
    const cbk::Camera box = filteredScene("PixelFilter \"box\"", w, h).camera;
    for (const float u : {0.0f, 0.3f, 0.999999f}) {
        float weight = 0.0f;
        CHECK(cbk::filterPixelSample(&box, 0, 5, u, &weight) == 5.0f + u);
        CHECK(weight == 1.0f);
    }
    for (const float rx : {0.0f, 2.5f, 3.0f, 7.999f}) {
        int x0, x1, y0, y1;
        cbk::filterFootprint(&box, rx, 1.0f, &x0, &x1, &y0, &y1);
        CHECK(x0 == int(rx));
        CHECK(x1 == int(rx));
        CHECK(y0 == 1);
        CHECK(y1 == 1);
        CHECK(cbk::filterSplatWeight(&box, x0, 1, rx, 1.0f) == 1.0f);
    }
    CHECK(cbk::filterReaches(&box, 0.0f, 0.0f));
    CHECK_FALSE(cbk::filterReaches(&box, -0.01f, 3.0f));
    CHECK_FALSE(cbk::filterReaches(&box, float(w), 3.0f));
    // A point just left of the image projects for the gaussian (its pixel 0 reaches 1 pixel
    // beyond), not for the box.
    const cbk::Camera gaussian = filteredScene("", w, h).camera;
    for (const auto* camera : {&box, &gaussian}) {
        const cbk::Vec3 eye = cbk::affineTransformPoint(camera->cameraToWorld, cbk::vec3(0, 0, 0));
        // Camera space x = -(half width at depth 3) - 0.5 pixel: raster x = -0.5.
        const float pixel = 2.0f * camera->tanHalfFovX / float(w);
        const cbk::Vec3 p = cbk::affineTransformPoint(
            camera->cameraToWorld,
            cbk::vec3(3.0f * (-camera->tanHalfFovX - 0.5f * pixel), 0.0f, 3.0f));
        float rx = 0.0f, ry = 0.0f;
        const bool inside = cbk::cameraProjectPoint(camera, eye, p, &rx, &ry);
        CHECK(rx == doctest::Approx(-0.5).epsilon(1e-4));
        CHECK(inside == (camera == &gaussian));
    }
}

namespace {

// A diffuse plane facing the camera, albedo 0.8 on one side of x = 0 and black on the other, lit
// head-on by a distant light of irradiance pi: radiance 0.8 on the lit side. The plane reaches
// a little beyond every pixel's filter (and no further, so that most light subpaths are seen). The
// edge projects to the image's middle column boundary, so pixel column x's mean is 0.8 times the
// share of its filter on the lit side, from the oracle's distribution function (the same in every
// row).
constexpr int kEdgeWidth = 16, kEdgeHeight = 8;

const std::string kHeadOnLight = "LightSource \"distant\" \"point3 from\" [0 0 1] \"point3 to\" "
                                 "[0 0 0] \"rgb L\" [1 1 1] \"float scale\" 3.14159265358979\n";

cb::DeviceScene edgeScene(const std::string& filterLine, const std::string& light = kHeadOnLight) {
    return filteredScene(filterLine, kEdgeWidth, kEdgeHeight,
                         light +
                             "Material \"diffuse\" \"rgb reflectance\" [0.8 0.8 0.8]\n"
                             "Shape \"trianglemesh\" \"point3 P\" [-3 -2 0  0 -2 0  -3 2 0  0 2 0] "
                             "\"integer indices\" [0 1 3  0 3 2]\n"
                             "Material \"diffuse\" \"rgb reflectance\" [0 0 0]\n"
                             "Shape \"trianglemesh\" \"point3 P\" [0 -2 0  3 -2 0  0 2 0  3 2 0] "
                             "\"integer indices\" [0 1 3  0 3 2]\n");
}

std::array<double, kEdgeWidth> edgeColumns(const cb::DeviceScene& scene, const FilterCase& f) {
    // Which side of the image the lit half (world x < 0) lands on.
    const cbk::Camera& camera = scene.camera;
    const cbk::Vec3 eye = cbk::affineTransformPoint(camera.cameraToWorld, cbk::vec3(0, 0, 0));
    float rx = 0.0f, ry = 0.0f;
    REQUIRE(cbk::cameraProjectPoint(
        &camera, eye,
        cbk::vec3(float(-1.0 - scene.origin[0]), float(-scene.origin[1]), float(-scene.origin[2])),
        &rx, &ry));
    const bool litLeft = rx < kEdgeWidth / 2.0;
    std::array<double, kEdgeWidth> expected{};
    for (int x = 0; x < kEdgeWidth; ++x) {
        const double below = oracleCdf(f, f.radiusX, kEdgeWidth / 2.0 - (x + 0.5));
        expected[size_t(x)] = 0.8 * (litLeft ? below : 1.0 - below);
    }
    return expected;
}

} // namespace

// The eye side (each pixel's samples drawn from its filter; MLT's in the pixel its chain picks)
// and light tracing's splats (t = 1, through each pixel's filter, from points beyond the
// image's edge too): a sharp edge shows each filter's profile, and the top and bottom rows,
// part of whose filters lie outside the image, must not be darker.
TEST_CASE("pixel filters: a reflectance edge through every filter, every method" *
          doctest::test_suite("statistical")) {
    TempDirCleanup cleanup;
    cb::ClRuntime runtime;
    for (const FilterCase& f : {kFilters[0], kFilters[1], kFilters[2], kFilters[3], kFilters[5],
                                kFilters[6], kFilters[7], kFilters[9]}) {
        const cb::DeviceScene scene = edgeScene(f.line);
        const std::array<double, kEdgeWidth> expected = edgeColumns(scene, f);
        auto columns = [&](const cb::IntegratorSettings& settings, int estimates) {
            return binnedMeans(scene, runtime, settings, 6, estimates, 700u, kEdgeWidth,
                               [](int x, int, int) { return size_t(x); });
        };
        for (const std::string method : kMethods) {
            CAPTURE(std::string(f.line));
            CAPTURE(method);
            // MLT's chains are correlated: more estimates for a spread like the others'. A
            // filter with negative lobes reaches a column's far side rarely, and with few
            // estimates a run of samples that all miss it would have no spread at all.
            const int estimates =
                (method == "mlt" ? 32 : 8) * (cbk::filterHasNegativeLobes(f.type) ? 4 : 1);
            checkBinMeans(columns(methodSettings(method), estimates), expected, 1e-4);
        }
        // Light tracing alone (s = 2, t = 1), unweighted: every splat goes through the filter.
        cb::IntegratorSettings lightTracing = methodSettings("bdpt");
        lightTracing.debugS = 2;
        lightTracing.debugT = 1;
        CAPTURE(std::string(f.line));
        checkBinMeans(columns(lightTracing, 32), expected, 1e-4);
    }
}

// MLT's light-tracing splats: a point light 0.3 in front of the edge, where the t = 1 strategy
// carries nearly all of the estimate (its density over the plane is many times the eye's), so
// MLT's image is its splats through the filter; per column against BDPT's, whose splats the
// case above checks alone.
TEST_CASE("pixel filters: MLT's light-tracing splats agree with BDPT's" *
          doctest::test_suite("statistical")) {
    TempDirCleanup cleanup;
    cb::ClRuntime runtime;
    for (const FilterCase& f : {kFilters[0], kFilters[3], kFilters[9]}) {
        CAPTURE(std::string(f.line));
        const cb::DeviceScene scene = edgeScene(
            f.line, "LightSource \"point\" \"point3 from\" [0 0 0.3] \"rgb I\" [1 1 1]\n");
        auto columns = [&](const std::string& method, int estimates) {
            return binnedMeans(scene, runtime, methodSettings(method), 8, estimates, 900u,
                               kEdgeWidth, [](int x, int, int) { return size_t(x); })
                .stats;
        };
        checkRunsAgree(columns("mlt", 32), columns("bdpt", 16));
    }
}
