// Furnace tests: integrators against the analytic radiance of a closed emitting diffuse box.
#include "scene_builders.h"
#include "test_render_util.h"

#include "spectral/spectral.h"

#include <cmath>
#include <doctest/doctest.h>

TEST_CASE("PT furnace: truncated Neumann series Le (1 - a^(n-1)) / (1 - a)") {
    cb::ClRuntime runtime;
    struct Case {
        float albedo;
        int eyeVertices;
        bool roulette;
    };
    const Case cases[] = {{0.5f, 2, true},  {0.5f, 3, true},   {0.5f, 5, true},  {0.8f, 8, true},
                          {0.8f, 8, false}, {0.99f, 12, true}, {0.99f, 64, true}};
    for (const Case& c : cases) {
        CAPTURE(c.albedo);
        CAPTURE(c.eyeVertices);
        CAPTURE(c.roulette);
        const float emission = 0.25f;
        cb::DeviceScene scene = cb::buildDeviceScene(cbtest::furnaceScene(c.albedo, emission));
        cb::IntegratorSettings settings;
        settings.name = "pt";
        settings.eyeVertices = c.eyeVertices;
        settings.rouletteVertex = c.roulette ? 3 : 0;
        settings.seed = 7;
        auto stats = cbtest::renderPooled(scene, runtime, settings, 16);
        double expected = emission * (1.0 - std::pow(double(c.albedo), c.eyeVertices - 1)) /
                          (1.0 - double(c.albedo));
        CAPTURE(expected);
        CAPTURE(stats.mean);
        CAPTURE(stats.standardError);
        // PT pixels are independent, so the pooled mean's standard error is the spread over
        // all pixel samples / sqrt(count). 3.5 standard errors, plus float rounding.
        CHECK(std::fabs(stats.mean - expected) <= 3.5 * stats.standardError + 1e-5 * expected);
        CHECK(stats.nonFinite == 0);
    }
}

TEST_CASE("PT furnace in 16-bin spectral mode: RGB white emission renders as white") {
    cb::ClRuntime runtime;
    const float albedo = 0.7f, emission = 0.5f;
    const int eyeVertices = 6;
    cb::DeviceScene scene =
        cb::buildDeviceScene(cbtest::furnaceScene(albedo, emission), cb::ChannelMode::Spectral);
    REQUIRE(scene.channels == 16);
    cb::IntegratorSettings settings;
    settings.eyeVertices = eyeVertices;
    settings.seed = 3;
    auto stats = cbtest::renderPooled(scene, runtime, settings, 16);
    // RGB emission is RGB times the white illuminant (pbrt-v4's meaning), which the film maps to
    // linear sRGB (1, 1, 1); the grey albedo becomes a flat reflectance. The pooled value is the
    // mean of the three channels of the film's white times the scalar furnace radiance.
    const auto film = cb::filmMatrix(16, {});
    double whiteMean = 0.0;
    for (int i = 0; i < 16; ++i)
        for (int c = 0; c < 3; ++c)
            whiteMean += film[c * 16 + i] * cb::whiteIlluminantBins()[i] / 3.0;
    CHECK(whiteMean == doctest::Approx(1.0).epsilon(1e-5));
    double expected = whiteMean * emission * (1.0 - std::pow(double(albedo), eyeVertices - 1)) /
                      (1.0 - double(albedo));
    CAPTURE(expected);
    CAPTURE(stats.mean);
    CHECK(std::fabs(stats.mean - expected) <= 3.5 * stats.standardError + 1e-5 * expected);
}
