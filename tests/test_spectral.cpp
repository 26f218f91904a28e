// Spectral module (src/spectral) and the data of scenes/cornell-box.pbrt.
#include <doctest/doctest.h>

#include "source_tree.h"
#include "spectral/named_spectra.h"
#include "spectral/spectral.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
// g++ 12 reports a false -Wmaybe-uninitialized inside <regex>'s std::function moves in the
// sanitized -O1 build (scripts/run-sanitized-tests); the warning is libstdc++'s, not ours.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <regex>
#pragma GCC diagnostic pop
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

using namespace cb;

namespace {

// The white of the 16-bin pipeline: M * (1,...,1). Documented in docs/spectral.md.
constexpr std::array<double, 3> kDocumentedWhite{0.994300, 1.002399, 0.993726};

std::array<double, 3> matrixTimesOnes(const std::vector<float>& m, int channels) {
    std::array<double, 3> r{};
    for (int c = 0; c < 3; ++c)
        for (int i = 0; i < channels; ++i)
            r[c] += m[c * channels + i];
    return r;
}

} // namespace

TEST_CASE("spectral: flat spectrum gives the documented white, within 1% of (1,1,1)") {
    const auto m = channelsToRgbMatrix(kSpectralBins);
    REQUIRE(m.size() == 3 * kSpectralBins);
    const auto white = matrixTimesOnes(m, kSpectralBins);
    const auto viaSpectrum = spectrumToRgb({{400.f, 1.f}, {700.f, 1.f}});
    for (int c = 0; c < 3; ++c) {
        CHECK(std::abs(white[c] - kDocumentedWhite[c]) < 1e-3);
        CHECK(std::abs(white[c] - 1.0) < 0.01);
        // M * ones and the full spectrum path agree (binning a constant is exact).
        CHECK(viaSpectrum[c] == doctest::Approx(white[c]).epsilon(1e-6));
    }
    // Y of a flat spectrum is 1 by construction; X and Z fall short only by the CMF mass outside
    // 400-700 nm and the fit's error (docs/spectral.md).
    const auto xyz = spectrumToXyz({{400.f, 1.f}, {700.f, 1.f}});
    CHECK(xyz[1] == doctest::Approx(1.0).epsilon(1e-9));
    CHECK(xyz[0] == doctest::Approx(0.99738).epsilon(1e-4));
    CHECK(xyz[2] == doctest::Approx(0.99469).epsilon(1e-4));
}

TEST_CASE("spectral: CMF fit close to the CIE 1931 table") {
    // CIE 1931 2-degree tabulated values (x, y, z) at 450, 500, 550, 600, 650 nm.
    const double table[5][4] = {{450, 0.33620, 0.03800, 1.77211},
                                {500, 0.00490, 0.32300, 0.27200},
                                {550, 0.43345, 0.99495, 0.00875},
                                {600, 1.06220, 0.63100, 0.00080},
                                {650, 0.28350, 0.10700, 0.00000}};
    for (const auto& row : table) {
        const auto f = cieXyz1931Fit(row[0]);
        for (int c = 0; c < 3; ++c)
            CHECK(std::abs(f[c] - row[c + 1]) < 0.012);
    }
}

TEST_CASE("spectral: binSpectrum is the exact mean over each bin") {
    SUBCASE("constant") {
        const auto b = binSpectrum({{400.f, 0.37f}, {700.f, 0.37f}});
        for (float v : b)
            CHECK(v == doctest::Approx(0.37f).epsilon(1e-6));
        for (float v : binSpectrum({}))
            CHECK(v == 0.f);
        // One sample is a spectrum that is zero except at that wavelength (pbrt-v4).
        for (float v : binSpectrum({{550.f, 0.37f}}))
            CHECK(v == 0.f);
    }
    SUBCASE("linear: mean is the value at the bin centre") {
        // f = 2 + 0.01 (nm - 400), sampled only at the ends: no bin contains a sample.
        const auto b = binSpectrum({{400.f, 2.f}, {700.f, 5.f}});
        for (int i = 0; i < kSpectralBins; ++i) {
            const double centre = 0.5 * (binLambdaLow(i) + binLambdaHigh(i));
            CHECK(b[i] == doctest::Approx(2.0 + 0.01 * (centre - 400.0)).epsilon(1e-6));
        }
    }
    SUBCASE("triangle straddling a bin edge") {
        // Peak 1 at 460 nm, zero at 450 and 470; the edge between bins 2 and 3 is 456.25 nm.
        // Bin 2 holds the ramp 450..456.25: 6.25^2 / 20 = 1.953125 nm; bin 3 the rest of the
        // area 10: 8.046875 nm. Divided by 18.75 nm.
        const auto b = binSpectrum({{450.f, 0.f}, {460.f, 1.f}, {470.f, 0.f}});
        for (int i = 0; i < kSpectralBins; ++i) {
            const double expect = i == 2 ? 1.953125 / 18.75 : i == 3 ? 8.046875 / 18.75 : 0.0;
            CHECK(b[i] == doctest::Approx(expect).epsilon(1e-6));
        }
    }
    SUBCASE("zero outside the samples, and the Cornell emission") {
        // Table A.1 read as piecewise linear; bin 0 is [400, 418.75]: mean 0.08 * 9.375 = 0.75.
        // Bin 5 = [493.75, 512.5] straddles the 500 nm sample; by hand, piece by piece:
        // 6.25 * (7.5 + 8) / 2 + 12.5 * (8 + 8.95) / 2 = 154.375.
        const auto b = binSpectrum({{400.f, 0.f}, {500.f, 8.f}, {600.f, 15.6f}, {700.f, 18.4f}});
        CHECK(b[0] == doctest::Approx(0.75).epsilon(1e-6));
        CHECK(b[5] == doctest::Approx(154.375 / 18.75).epsilon(1e-6));
        const auto e = binSpectrum({{450.f, 3.f}, {650.f, 7.f}});
        CHECK(e[0] == 0.f);  // wholly below the first sample
        CHECK(e[15] == 0.f); // wholly above the last
        // Bin 2 = [437.5, 456.25]: 12.5 nm of 0, then a ramp from 3 to 3.125 over 6.25 nm.
        CHECK(e[2] == doctest::Approx(6.25 * 3.0625 / 18.75).epsilon(1e-6));
    }
    SUBCASE("malformed input throws") {
        CHECK_THROWS_AS(binSpectrum({{500.f, 1.f}, {500.f, 2.f}}), std::invalid_argument);
        CHECK_THROWS_AS(binSpectrum({{600.f, 1.f}, {500.f, 2.f}}), std::invalid_argument);
        CHECK_THROWS_AS(binSpectrum({{500.f, NAN}}), std::invalid_argument);
    }
}

TEST_CASE("spectral: narrow spectra have the expected dominant channel") {
    // Triangles 20 nm wide at the base.
    const float centres[3] = {450.f, 550.f, 650.f};
    const int dominant[3] = {2, 1, 0};
    for (int k = 0; k < 3; ++k) {
        const float c = centres[k];
        const auto rgb = spectrumToRgb({{c - 10.f, 0.f}, {c, 1.f}, {c + 10.f, 0.f}});
        const int d = dominant[k];
        INFO("centre " << c << " nm");
        CHECK(rgb[d] > 0.05f);
        for (int o = 0; o < 3; ++o)
            if (o != d) CHECK(rgb[d] > 3.f * std::abs(rgb[o]));
    }
}

TEST_CASE("spectral: channelsToRgbMatrix") {
    const auto id = channelsToRgbMatrix(3);
    REQUIRE(id.size() == 9);
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
            CHECK(id[r * 3 + c] == (r == c ? 1.f : 0.f));
    CHECK_THROWS_AS(channelsToRgbMatrix(4), std::invalid_argument);
    // M applied to a binned spectrum equals spectrumToRgb (one matrix for both paths).
    const PiecewiseLinear s{{420.f, 0.2f}, {530.f, 0.9f}, {690.f, 0.1f}};
    const auto bins = binSpectrum(s);
    const auto m = channelsToRgbMatrix(kSpectralBins);
    const auto rgb = spectrumToRgb(s);
    for (int c = 0; c < 3; ++c) {
        double v = 0.0;
        for (int i = 0; i < kSpectralBins; ++i)
            v += m[c * kSpectralBins + i] * bins[i];
        CHECK(rgb[c] == doctest::Approx(v).epsilon(1e-5));
    }
}

TEST_CASE("spectral: rgbToSpectrum") {
    for (float v : rgbToSpectrum({1.f, 1.f, 1.f}))
        CHECK(v == 1.f);
    for (float v : rgbToSpectrum({0.f, 0.f, 0.f}))
        CHECK(v == 0.f);
    // Each basis spectrum gives back its target colour exactly through the film, lit by the
    // white of RGB lights (the constraint of its optimisation), as pbrt-v4's sigmoid spectra are
    // fit under D65: so every rgb in [0,1]^3 does (the weights sum the targets), within [0,1].
    const std::vector<float> film = filmMatrix(kSpectralBins, FilmColour{});
    auto litByWhite = [&](const std::array<float, kSpectralBins>& s) {
        std::array<double, 3> rgb{};
        for (int c = 0; c < 3; ++c)
            for (int i = 0; i < kSpectralBins; ++i)
                rgb[size_t(c)] += film[size_t(c * kSpectralBins + i)] * s[size_t(i)] *
                                  whiteIlluminantBins()[size_t(i)];
        return rgb;
    };
    const std::array<float, 3> targets[6] = {{0, 1, 1}, {1, 0, 1}, {1, 1, 0},
                                             {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    for (int k = 0; k < 6; ++k) {
        const auto rgb = litByWhite(smitsBasis()[k + 1]);
        for (int c = 0; c < 3; ++c)
            CHECK(rgb[c] == doctest::Approx(targets[k][c]).epsilon(1e-5).scale(1));
    }
    const float levels[5] = {0.f, 0.1f, 0.35f, 0.7f, 1.f};
    for (float r : levels)
        for (float g : levels)
            for (float b : levels) {
                const auto s = rgbToSpectrum({r, g, b});
                for (float v : s) {
                    CHECK(v >= -1e-6f);
                    CHECK(v <= 1.f + 1e-6f);
                }
                const auto back = litByWhite(s);
                INFO("rgb " << r << " " << g << " " << b);
                CHECK(std::abs(back[0] - r) < 1e-4);
                CHECK(std::abs(back[1] - g) < 1e-4);
                CHECK(std::abs(back[2] - b) < 1e-4);
            }
    // RGB emission (times that white) renders as its RGB, as pbrt-v4's RGBIlluminantSpectrum.
    for (const std::array<float, 3>& rgb :
         {std::array<float, 3>{12.f, 11.5f, 10.5f}, std::array<float, 3>{4.f, 0.5f, 0.2f},
          std::array<float, 3>{0.1f, 0.3f, 2.f}}) {
        const auto bins = rgbIlluminantSpectrum(rgb);
        for (int c = 0; c < 3; ++c) {
            double v = 0.0;
            for (int i = 0; i < kSpectralBins; ++i)
                v += film[size_t(c * kSpectralBins + i)] * bins[size_t(i)];
            CHECK(v == doctest::Approx(rgb[size_t(c)]).epsilon(1e-4));
        }
    }
    // Positive homogeneity: emission values above 1 scale linearly.
    const auto a = rgbToSpectrum({0.2f, 0.5f, 0.9f}), b5 = rgbToSpectrum({1.f, 2.5f, 4.5f});
    for (int i = 0; i < kSpectralBins; ++i)
        CHECK(b5[i] == doctest::Approx(5.f * a[i]).epsilon(1e-5));
}

// ---- Data of scenes/cornell-box.pbrt (no parser needed) ----

namespace {

std::string readCornell() {
    const std::string path = cbtest::sourcePath("scenes/cornell-box.pbrt");
    std::ifstream in(path);
    REQUIRE_MESSAGE(in.good(), "cannot open " << path);
    std::stringstream ss;
    ss << in.rdbuf();
    // Comments would confuse the regexes below.
    return std::regex_replace(ss.str(), std::regex("#[^\n]*"), "");
}

std::vector<double> numbers(const std::string& s) {
    std::vector<double> v;
    std::istringstream in(s);
    double x;
    while (in >> x)
        v.push_back(x);
    return v;
}

using P3 = std::array<double, 3>;
P3 sub(P3 a, P3 b) {
    return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}
P3 cross(P3 a, P3 b) {
    return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double dot(P3 a, P3 b) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

} // namespace

TEST_CASE("cornell-box.pbrt: measured reflectance spectra") {
    const std::string text = readCornell();
    const std::regex re(
        R"re(MakeNamedMaterial\s+"(\w+)"[^\[]*"spectrum reflectance"\s*\[([^\]]*)\])re");
    std::vector<std::string> names;
    for (auto it = std::sregex_iterator(text.begin(), text.end(), re); it != std::sregex_iterator();
         ++it) {
        const std::string name = (*it)[1];
        names.push_back(name);
        const auto v = numbers((*it)[2]);
        if (name == "light") continue; // the emitters' black base material
        INFO("material " << name);
        REQUIRE(v.size() == 2 * 76);
        for (int k = 0; k < 76; ++k) {
            CHECK(v[2 * k] == 400 + 4 * k);
            CHECK(v[2 * k + 1] >= 0.0);
            CHECK(v[2 * k + 1] <= 1.0);
        }
        PiecewiseLinear s;
        for (int k = 0; k < 76; ++k)
            s.emplace_back(static_cast<float>(v[2 * k]), static_cast<float>(v[2 * k + 1]));
        const auto rgb = spectrumToRgb(s);
        // Spot values from tables A.18, A.21, A.23 and the colour each spectrum must have.
        if (name == "white") {
            CHECK(v[1] == 0.343);
            CHECK(*std::min_element(rgb.begin(), rgb.end()) >
                  0.85f * *std::max_element(rgb.begin(), rgb.end()));
        } else if (name == "green") {
            CHECK(v[2 * 75 + 1] == 0.159);
            CHECK(rgb[1] > 1.5f * rgb[0]);
            CHECK(rgb[1] > 1.5f * rgb[2]);
        } else if (name == "red") {
            CHECK(v[2 * 58 + 1] == doctest::Approx(0.620)); // 632 nm
            CHECK(rgb[0] > 3.f * rgb[1]);
            CHECK(rgb[0] > 3.f * rgb[2]);
        }
    }
    std::sort(names.begin(), names.end());
    CHECK(names == std::vector<std::string>{"green", "light", "red", "white"});
}

TEST_CASE("cornell-box.pbrt: emitters and orientation") {
    const std::string text = readCornell();
    const std::regex emission(R"re("spectrum L"\s*\[([^\]]*)\])re");
    int emitters = 0;
    for (auto it = std::sregex_iterator(text.begin(), text.end(), emission);
         it != std::sregex_iterator(); ++it, ++emitters)
        CHECK(numbers((*it)[1]) == std::vector<double>{400, 0.0, 500, 8.0, 600, 15.6, 700, 18.4});
    CHECK(emitters == 2);
    CHECK(text.find("Translate 0.200 0.100 0.400") != std::string::npos);
    CHECK(std::regex_search(text, std::regex(R"re(Shape\s+"sphere"\s+"float radius"\s+0\.025)re")));

    // Every mesh: triangles wound so cross(p1-p0, p2-p0) faces into the room; the 20-vertex
    // block meshes face away from their own centre; the light faces -y.
    const std::regex meshRe(
        R"re((AreaLightSource[^\n]*\n(?:[^\n]*\n)*?)?\s*Shape\s+"trianglemesh"\s+"point3 P"\s*\[([^\]]*)\]\s*"integer indices"\s*\[([^\]]*)\])re");
    const P3 roomCentre{0.278, 0.2744, 0.2796};
    int meshes = 0, lights = 0;
    for (auto it = std::sregex_iterator(text.begin(), text.end(), meshRe);
         it != std::sregex_iterator(); ++it, ++meshes) {
        const bool isLight = (*it)[1].matched;
        lights += isLight;
        const auto p = numbers((*it)[2]);
        const auto idx = numbers((*it)[3]);
        REQUIRE(p.size() % 3 == 0);
        REQUIRE(idx.size() % 3 == 0);
        const std::size_t nv = p.size() / 3;
        P3 centre{};
        for (std::size_t v = 0; v < nv; ++v)
            for (int c = 0; c < 3; ++c)
                centre[c] += p[3 * v + c] / static_cast<double>(nv);
        for (std::size_t v = 0; v < nv; ++v) {
            CHECK(p[3 * v] >= 0.0);
            CHECK(p[3 * v] <= 0.556);
            CHECK(p[3 * v + 1] >= 0.0);
            CHECK(p[3 * v + 1] <= 0.5488);
            CHECK(p[3 * v + 2] >= 0.0);
            CHECK(p[3 * v + 2] <= 0.5592);
        }
        for (std::size_t t = 0; t < idx.size(); t += 3) {
            P3 q[3];
            for (int k = 0; k < 3; ++k) {
                const auto i = static_cast<std::size_t>(idx[t + k]);
                REQUIRE(i < nv);
                q[k] = {p[3 * i], p[3 * i + 1], p[3 * i + 2]};
            }
            const P3 n = cross(sub(q[1], q[0]), sub(q[2], q[0]));
            const P3 tc{(q[0][0] + q[1][0] + q[2][0]) / 3, (q[0][1] + q[1][1] + q[2][1]) / 3,
                        (q[0][2] + q[1][2] + q[2][2]) / 3};
            INFO("mesh " << meshes << " triangle " << t / 3);
            CHECK(dot(n, n) > 1e-6); // not degenerate
            if (nv == 20)
                CHECK(dot(n, sub(tc, centre)) > 0.0);
            else
                CHECK(dot(n, sub(roomCentre, tc)) > 0.0);
            if (isLight) {
                CHECK(n[1] < 0.0);
                CHECK(std::abs(n[0]) < 1e-12);
                CHECK(std::abs(n[2]) < 1e-12);
            }
        }
    }
    CHECK(meshes == 8); // 5 walls, 2 blocks, 1 light
    CHECK(lights == 1);
}

TEST_CASE("spectral: white-balance chromaticities of CIE illuminants A, D50 and D75") {
    // pbrt-v4 takes a temperature in its own scale, CCT = T * 1.4388 / 1.4380, so the CIE's
    // daylight illuminants D50 (5003 K) and D75 (7504 K) are asked for at their CCT / that ratio.
    // The CIE 15 daylight locus reproduces the tabulated chromaticities to about 1e-4.
    const double ratio = 1.4380 / 1.4388;
    const auto d50 = whiteBalanceChromaticity(5003.0 * ratio);
    CHECK(std::abs(d50[0] - 0.34567) < 1.5e-4);
    CHECK(std::abs(d50[1] - 0.35850) < 1.5e-4);
    const auto d75 = whiteBalanceChromaticity(7504.0 * ratio);
    CHECK(std::abs(d75[0] - 0.29902) < 1.5e-4);
    CHECK(std::abs(d75[1] - 0.31485) < 1.5e-4);
    // Below 4000 K: Planck's law. Illuminant A is a black body of 2856 K with the old radiation
    // constant c2 = 1.435e-2 m K; with today's 1.438777e-2 the same spectrum is at 2863.5 K.
    // The CMF fit's error leaves its chromaticity (0.44757, 0.40745) within 3e-3.
    const double c2 = 6.62606957e-34 * 299792458.0 / 1.3806488e-23;
    const auto a = whiteBalanceChromaticity(2856.0 * c2 / 1.435e-2 * ratio);
    CHECK(std::abs(a[0] - 0.44757) < 3e-3);
    CHECK(std::abs(a[1] - 0.40745) < 3e-3);
}

TEST_CASE("spectral: an emission converted to RGB is what the spectral film records of it") {
    // emissionToRgb gives an RGB render the light a spectral render sees through its film (no
    // white balance, imaging ratio 1), for a narrow blue line and a broad ramp alike.
    const auto film = filmMatrix(kSpectralBins, {});
    for (const PiecewiseLinear& s : {PiecewiseLinear{{440.f, 0.f}, {450.f, 3.f}, {460.f, 0.f}},
                                     PiecewiseLinear{{400.f, 0.5f}, {700.f, 2.f}}}) {
        const auto bins = binSpectrum(s);
        const auto rgb = emissionToRgb(s);
        for (int c = 0; c < 3; ++c) {
            double v = 0.0;
            for (int i = 0; i < kSpectralBins; ++i)
                v += double(film[size_t(c * kSpectralBins + i)]) * bins[size_t(i)];
            CHECK(rgb[size_t(c)] == doctest::Approx(v).epsilon(1e-5));
        }
    }
}

TEST_CASE("named spectra: pbrt-v4's metal-* names, measured data over 360-830 nm") {
    std::vector<std::string> names;
    for (const NamedSpectrum& s : namedSpectra()) {
        CAPTURE(s.name);
        names.emplace_back(s.name);
        CHECK(findNamedSpectrum(s.name) == &s);
        REQUIRE(s.pairs.size() % 2 == 0);
        REQUIRE(s.pairs.size() >= 8);
        for (size_t i = 0; i < s.pairs.size(); i += 2) {
            CHECK(std::isfinite(s.pairs[i + 1]));
            CHECK(s.pairs[i + 1] >= 0.0);
            if (i > 0) CHECK(s.pairs[i] > s.pairs[i - 2]);
        }
        // pbrt-v4's film samples 360-830 nm; the data run to the first sample past each end.
        CHECK(s.pairs.front() <= 360.0);
        CHECK(s.pairs[s.pairs.size() - 2] >= 830.0);
        CHECK(s.pairs[s.pairs.size() - 2] < 1500.0); // nanometres, not micrometres
        const std::string_view stem = s.name.substr(0, s.name.rfind('-'));
        const std::string_view part = s.name.substr(stem.size());
        CHECK((part == "-eta" || part == "-k"));
        CHECK(findNamedSpectrum(std::string(stem) + (part == "-eta" ? "-k" : "-eta")) != nullptr);
    }
    CHECK(names.size() == 12);
    // pbrt-v4's glasses, by their index at 587.6 nm (SCHOTT's catalogue): crown to dense flint.
    CHECK(namedGlasses().size() == 7);
    for (const NamedGlass& g : namedGlasses()) {
        CAPTURE(g.name);
        CHECK(findNamedGlass(g.name) == &g);
        CHECK(g.nd > 1.45);
        CHECK(g.nd < 1.9);
    }
    CHECK(findNamedGlass("glass-BK7")->nd == 1.5168);
    CHECK(findNamedGlass("glass-F11")->nd > findNamedGlass("glass-F5")->nd);
    CHECK(findNamedSpectrum("metal-Xx-eta") == nullptr);
    CHECK(findNamedSpectrum("glass-BK7") == nullptr);
    CHECK(namedSpectrumNames().find("metal-CuZn-k") != std::string::npos);

    // Normal-incidence reflectance ((n - 1)^2 + k^2) / ((n + 1)^2 + k^2) against handbook values
    // (Palik; Johnson & Christy 1972): gold and copper dark in the blue and bright in the red,
    // silver and aluminium bright throughout. Catches swapped columns, metals or units.
    auto reflectance = [](const char* metal, double nm) {
        const auto eta = toPiecewiseLinear(*findNamedSpectrum(std::string(metal) + "-eta"));
        const auto k = toPiecewiseLinear(*findNamedSpectrum(std::string(metal) + "-k"));
        const double n = evalPiecewiseLinear(eta, nm), kk = evalPiecewiseLinear(k, nm);
        return ((n - 1) * (n - 1) + kk * kk) / ((n + 1) * (n + 1) + kk * kk);
    };
    CHECK(reflectance("metal-Au", 450) > 0.3);
    CHECK(reflectance("metal-Au", 450) < 0.45);
    CHECK(reflectance("metal-Au", 650) > 0.9);
    CHECK(reflectance("metal-Cu", 450) > 0.5);
    CHECK(reflectance("metal-Cu", 450) < 0.65);
    CHECK(reflectance("metal-Cu", 650) > 0.9);
    CHECK(reflectance("metal-CuZn", 450) < reflectance("metal-CuZn", 650));
    CHECK(reflectance("metal-CuZn", 650) > 0.8);
    for (double nm = 400; nm <= 700; nm += 25) {
        CAPTURE(nm);
        CHECK(reflectance("metal-Ag", nm) > 0.85);
        CHECK(reflectance("metal-Al", nm) > 0.88);
        CHECK(reflectance("metal-Al", nm) < 0.94);
    }
    CHECK(reflectance("metal-Ag", 650) > 0.95);
    // Magnesium oxide is a transparent dielectric: k near 0, n_D = 1.7355 at 589.3 nm.
    const auto mgoK = toPiecewiseLinear(*findNamedSpectrum("metal-MgO-k"));
    CHECK(std::all_of(mgoK.begin(), mgoK.end(), [](auto p) { return p.second < 1e-4f; }));
    CHECK(evalPiecewiseLinear(toPiecewiseLinear(*findNamedSpectrum("metal-MgO-eta")), 589.3) ==
          doctest::Approx(1.7355).epsilon(0.003));
}

TEST_CASE("named spectra: pbrt-v4's standard illuminants, at luminance 1") {
    // CIE 15:2004's chromaticities of the illuminants (CIE 1931 observer); ACES's white point
    // from SMPTE ST 2065-1.
    const std::vector<std::tuple<std::string, double, double>> published = {
        {"stdillum-A", 0.44758, 0.40745}, {"stdillum-D50", 0.3457, 0.3585},
        {"stdillum-D65", 0.3127, 0.3290}, {"stdillum-F1", 0.3131, 0.3371},
        {"stdillum-F2", 0.3721, 0.3751},  {"stdillum-F3", 0.4091, 0.3941},
        {"stdillum-F4", 0.4402, 0.4031},  {"stdillum-F5", 0.3138, 0.3452},
        {"stdillum-F6", 0.3779, 0.3882},  {"stdillum-F7", 0.3129, 0.3292},
        {"stdillum-F8", 0.3458, 0.3586},  {"stdillum-F9", 0.3741, 0.3727},
        {"stdillum-F10", 0.3458, 0.3588}, {"stdillum-F11", 0.3805, 0.3769},
        {"stdillum-F12", 0.4370, 0.4042}, {"illum-acesD60", 0.32168, 0.33767}};
    REQUIRE(namedIlluminants().size() == published.size());
    const double flatLuminance = photometricIntegral({{360.0f, 1.0f}, {830.0f, 1.0f}});
    for (const auto& [name, x, y] : published) {
        CAPTURE(name);
        const NamedSpectrum* s = findNamedSpectrum(name);
        REQUIRE(s != nullptr);
        CHECK(s->unitLuminance);
        CHECK(namedSpectrumNames().find(name) != std::string::npos);
        // A's and the daylight series' tables are relative to 100 at 560 nm.
        const PiecewiseLinear raw = [&] {
            PiecewiseLinear out;
            for (size_t i = 0; i + 1 < s->pairs.size(); i += 2)
                out.emplace_back(float(s->pairs[i]), float(s->pairs[i + 1]));
            return out;
        }();
        if (name.find("-F") == std::string::npos)
            CHECK(evalPiecewiseLinear(raw, 560.0) == doctest::Approx(100.0).epsilon(2e-4));
        // A scene gets it at luminance 1: its y-bar integral is a flat 1's.
        const PiecewiseLinear samples = toPiecewiseLinear(*s);
        CHECK(photometricIntegral(samples) == doctest::Approx(flatLuminance).epsilon(1e-5));
        // Its chromaticity through cbdpt's CMF fit (Wyman et al.), against the CIE's, within the
        // fit's error (at most 0.0014 here, illuminant A's x).
        std::array<double, 3> xyz{};
        for (double nm = 360.0; nm < 830.0; nm += 0.25)
            for (int c = 0; c < 3; ++c)
                xyz[size_t(c)] += evalPiecewiseLinear(samples, nm + 0.125) *
                                  cieXyz1931Fit(nm + 0.125)[size_t(c)] * 0.25;
        const double sum = xyz[0] + xyz[1] + xyz[2];
        CHECK(std::abs(xyz[0] / sum - x) < 0.002);
        CHECK(std::abs(xyz[1] / sum - y) < 0.002);
    }
    // Illuminant A is Planck's law at 2848 K with the CIE's c2 = 1.435e7 nm K (CIE 15:2004),
    // relative to 560 nm: the table to its 6 significant digits.
    const NamedSpectrum& a = *findNamedSpectrum("stdillum-A");
    for (size_t i = 0; i + 1 < a.pairs.size(); i += 2) {
        const double nm = a.pairs[i], c2 = 1.435e7, t = 2848.0;
        CAPTURE(nm);
        CHECK(a.pairs[i + 1] ==
              doctest::Approx(100.0 * std::pow(560.0 / nm, 5) * std::expm1(c2 / (t * 560.0)) /
                              std::expm1(c2 / (t * nm)))
                  .epsilon(1e-5));
    }
    // Materials' measured spectra keep their values.
    CHECK(!findNamedSpectrum("metal-Cu-eta")->unitLuminance);
    CHECK(namedSpectrumPairs(*findNamedSpectrum("metal-Cu-eta")).front() ==
          findNamedSpectrum("metal-Cu-eta")->pairs.front());
}

TEST_CASE("spectral: blackbody is Planck's law normalised to its peak, 360-830 nm") {
    // Planck's law in ratios needs only c2 = h c / k (pbrt-v4's constants: 1.4387773e-2 m K).
    const double c2 = 6.62606957e-34 * 299792458.0 / 1.3806488e-23 * 1e9; // nm K
    auto planckRatio = [c2](double a, double b, double kelvin) {          // B(a) / B(b)
        return std::pow(b / a, 5) * std::expm1(c2 / (b * kelvin)) / std::expm1(c2 / (a * kelvin));
    };
    for (double kelvin : {1000.0, 2856.0, 5000.0, 6504.0, 20000.0}) {
        CAPTURE(kelvin);
        const PiecewiseLinear s = blackbody(kelvin);
        REQUIRE(s.size() == 471);
        CHECK(s.front().first == 360.0f);
        CHECK(s.back().first == 830.0f);
        const double peakNm = 2.8977721e6 / kelvin; // Wien's displacement law
        for (const auto& [nm, v] : s) {
            CHECK(v <= 1.0f + 1e-6f);
            CHECK(v == doctest::Approx(planckRatio(nm, peakNm, kelvin)).epsilon(1e-5));
        }
    }
    // 5000 K peaks at 579.6 nm, inside the range: the samples there are the peak's 1.
    const PiecewiseLinear s5000 = blackbody(5000.0);
    CHECK(evalPiecewiseLinear(s5000, 579.6) == doctest::Approx(1.0).epsilon(1e-5));
}
