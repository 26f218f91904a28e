// Spheres of fog lit by their own glowing wall, where the radiance transport equation has
// answers computed apart: the wall seen through the fog, single scattering as a one-dimensional
// integral, and a fog that does not absorb keeping the wall's radiance everywhere (a furnace).
// The fog may be split into concentric shells by pbrt-v4's "interface" material, each shell its
// own medium. Shared by the scattering media's and the interfaces' suites.
#pragma once

#include "method_checks.h"
#include "scene_files.h"

#include <fmt/format.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

namespace cbtest::fog_checks {

using Rgb = std::array<double, 3>;

// A homogeneous medium named `name`.
inline std::string namedMedium(const std::string& name, const Rgb& sigmaA, const Rgb& sigmaS,
                               double g) {
    return fmt::format("MakeNamedMedium \"{}\" \"string type\" \"homogeneous\" \"rgb sigma_a\" "
                       "[{} {} {}] \"rgb sigma_s\" [{} {} {}] \"float g\" {}\n",
                       name, sigmaA[0], sigmaA[1], sigmaA[2], sigmaS[0], sigmaS[1], sigmaS[2], g);
}

inline std::string fogMedium(const Rgb& sigmaA, const Rgb& sigmaS, double g) {
    return namedMedium("fog", sigmaA, sigmaS, g);
}

// The camera at the centre of a sphere of `radius` filled with `medium` (named "fog"), whose
// wall is black and glows with radiance `glow` on both sides. Every camera ray leaves along a
// radius, so every pixel has the same expected value. `inside`: shapes within the sphere.
inline std::string fogSphereScene(const std::string& medium, double radius, double glow,
                                  const std::string& inside = "") {
    return medium +
           "MediumInterface \"\" \"fog\"\nLookAt 0 0 0  0 0 1  0 1 0\n"
           "Camera \"perspective\" \"float fov\" 60\n"
           "Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8\n"
           "WorldBegin\nAttributeBegin\nMediumInterface \"fog\" \"\"\n"
           "Material \"diffuse\" \"rgb reflectance\" [0 0 0]\n" +
           fmt::format("AreaLightSource \"diffuse\" \"rgb L\" [{0} {0} {0}] \"bool twosided\" "
                       "true\nShape \"sphere\" \"float radius\" {1}\nAttributeEnd\n",
                       glow, radius) +
           inside;
}

// pbrt-v4's Henyey-Greenstein phase function of the cosine between the travel direction and the
// new one.
inline double henyeyGreenstein(double g, double cosTheta) {
    const double d = 1.0 + g * g - 2.0 * g * cosTheta;
    return (1.0 - g * g) / (4.0 * M_PI * d * std::sqrt(d));
}

// One channel of concentric shells of fog about the camera: shell i reaches out to radius
// outer[i] (increasing; the last is the glowing wall's) and has sigma_t, sigma_s and g.
struct Shells {
    std::vector<double> outer, sigmaT, sigmaS, g;
};

// The length of the ray p + s d, s in [0, sEnd], inside the ball of radius rho about the
// centre, for p at distance t from it and cos(d, p) = mu.
inline double lengthInBall(double t, double mu, double sEnd, double rho) {
    const double disc = rho * rho - t * t * (1.0 - mu * mu);
    if (disc <= 0.0) return 0.0;
    const double root = std::sqrt(disc);
    return std::max(0.0, std::min(-t * mu + root, sEnd) - std::max(-t * mu - root, 0.0));
}

// The optical depth from a point at distance t from the centre, in direction of cosine mu to
// the radius, to the wall.
inline double opticalDepthToWall(const Shells& f, double t, double mu) {
    const double wall = f.outer.back();
    const double sEnd = -t * mu + std::sqrt(wall * wall - t * t * (1.0 - mu * mu));
    double depth = 0.0, inner = 0.0;
    for (size_t i = 0; i < f.outer.size(); ++i) {
        const double inBall = lengthInBall(t, mu, sEnd, f.outer[i]);
        depth += f.sigmaT[i] * (inBall - inner);
        inner = inBall;
    }
    return depth;
}

// Radiance reaching the centre along a radius, paths of at most two segments: the wall seen
// through the shells, plus light scattered once, from a point at distance t, off a wall point in
// direction mu (the cosine to the radius):
//   glow exp(-tau(0, 1)) + glow int_0^R sigma_s(t) exp(-tau_radial(t)) 2 pi int_-1^1 p(mu)
//   exp(-tau(t, mu)) dmu dt.
inline double singleScatteringRadiance(const Shells& f, double glow) {
    const int n = 1500;
    const double wall = f.outer.back();
    double sum = 0.0;
    for (int i = 0; i < n; ++i) {
        const double t = (i + 0.5) * wall / n;
        size_t shell = 0;
        while (f.outer[shell] < t)
            ++shell;
        double inner = 0.0;
        for (int j = 0; j < n; ++j) {
            const double mu = -1.0 + (j + 0.5) * 2.0 / n;
            inner += henyeyGreenstein(f.g[shell], mu) * std::exp(-opticalDepthToWall(f, t, mu));
        }
        // From the camera out to t: the depth to the wall less the depth from t on.
        const double radial = opticalDepthToWall(f, 0.0, 1.0) - opticalDepthToWall(f, t, 1.0);
        sum += f.sigmaS[shell] * std::exp(-radial) * 2.0 * M_PI * inner * (2.0 / n);
    }
    return glow * (std::exp(-opticalDepthToWall(f, 0.0, 1.0)) + sum * wall / n);
}

// Per channel, the image mean over 16 runs: with 6 (channelMeans) the runs' spread misjudges the
// coherent methods' (whose pixels share samples, and CPT's and CBDPT's eye samples are the same
// for one seed) often enough to fail one of these suites' 60 checks in about 1 of 4 seeds.
inline method_checks::BinnedMeans channelMeans16(const cb::DeviceScene& scene,
                                                 cb::ClRuntime& runtime,
                                                 const cb::IntegratorSettings& settings,
                                                 int estimates, std::uint32_t seed) {
    return method_checks::binnedMeans(scene, runtime, settings, 16, estimates, seed, 3,
                                      [](int, int, int c) { return size_t(c); });
}

inline cb::IntegratorSettings pathSettings(const std::string& method, int vertices) {
    cb::IntegratorSettings s = method_checks::methodSettings(method);
    s.maxPathVertices = vertices;
    return s;
}

// Every method against the shells' answers, per channel (`shells` one per channel): paths of 2
// vertices see the wall through them, paths of 3 add single scattering
// (singleScatteringRadiance). 16 runs each, `seed` and seed + 6.
inline void checkEveryMethodAgainstSingleScattering(const cb::DeviceScene& scene,
                                                    cb::ClRuntime& runtime,
                                                    const std::array<Shells, 3>& shells,
                                                    double glow, std::uint32_t seed) {
    Rgb direct{}, single{};
    for (size_t c = 0; c < 3; ++c) {
        direct[c] = glow * std::exp(-opticalDepthToWall(shells[c], 0.0, 1.0));
        single[c] = singleScatteringRadiance(shells[c], glow);
    }
    for (const std::string method : method_checks::kMethods) {
        CAPTURE(method);
        const bool coherent = method == "cpt" || method == "cbdpt";
        method_checks::checkChannelMeans(
            channelMeans16(scene, runtime, pathSettings(method, 2), 4, seed), direct, 1e-4);
        method_checks::checkChannelMeans(
            channelMeans16(scene, runtime, pathSettings(method, 3), coherent ? 24 : 6, seed + 6u),
            single, 1e-4);
    }
}

// A furnace: every method's image per channel equals the glowing wall's radiance `glow`
// (paths of 24 vertices leave out only those that scatter more than 22 times before reaching the
// wall, at the suites' optical radii a negligible share).
inline void checkEveryMethodKeepsGlow(const cb::DeviceScene& scene, cb::ClRuntime& runtime,
                                      double glow, std::uint32_t seed) {
    for (const std::string method : method_checks::kMethods) {
        CAPTURE(method);
        const bool coherent = method == "cpt" || method == "cbdpt";
        method_checks::checkChannelMeans(
            channelMeans16(scene, runtime, pathSettings(method, 24), coherent ? 24 : 4, seed),
            {glow, glow, glow}, 1e-4);
    }
}

// checkMethodsAgreeWithPt's floor, wall, block and light inside a box of coloured fog bounded by
// `boundary` (a material directive), which the camera looks into (connections between points in
// the fog, next-event estimation from them, eye and light subpaths scattering before surfaces,
// crossing the boundary where it lets them), or in which it sits (light tracing from points in
// the fog too). `fog`: the medium "fog" (homogeneous by default).
inline void checkMethodsAgreeWithPtInFogBox(const std::string& boundary,
                                            const std::string& fog = fogMedium({0.05, 0.1, 0.2},
                                                                               {0.6, 0.4, 0.3},
                                                                               0.3)) {
    SUBCASE("the camera outside") {
        method_checks::checkMethodsAgreeWithPt(
            fog + "MediumInterface \"fog\"\n" + method_checks::kDiskLight,
            "AttributeBegin\n" + boundary + "MediumInterface \"fog\" \"\"\n" +
                scene_files::boxShape(-2.2, -0.2, -2.2, 2.2, 2.2, 1.2) + "AttributeEnd\n");
    }
    SUBCASE("the camera in the fog") {
        method_checks::checkMethodsAgreeWithPt(
            fog + "MediumInterface \"fog\"\n" + method_checks::kDiskLight,
            "AttributeBegin\n" + boundary + scene_files::boxShape(-2.2, -0.2, -3.5, 2.2, 2.2, 1.2) +
                "AttributeEnd\n",
            "", "Material \"diffuse\" \"rgb reflectance\" [0.7 0.7 0.7]\n",
            "MediumInterface \"\" \"fog\"\n");
    }
}

} // namespace cbtest::fog_checks
