// pbrt-v4's named conductor spectra ("metal-Au-eta", "metal-Au-k", ...), as measured data from
// the refractiveindex.info database (named_spectra_data.cpp, written by scripts/named-spectra),
// and its standard illuminants ("stdillum-D65", ...), the CIE's tables
// (named_illuminants_data.cpp, written by scripts/named-illuminants; docs/pbrt-v4.md, "Named
// spectra").
#pragma once

#include <array>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "spectral/spectral.h"

namespace cb {

struct NamedSpectrum {
    std::string_view name;
    std::span<const double> pairs; // interleaved (wavelength in nm, value), increasing
    // Scaled to luminance 1 where a scene names it (the integral of the spectrum times y-bar
    // over 360-830 nm equal to y-bar's), as pbrt-v4 normalises its illuminants.
    bool unitLuminance = false;
};

// The built-in measured spectra of materials, in the generated file's order.
std::span<const NamedSpectrum> namedSpectra();

// The built-in illuminants, in the generated file's order.
std::span<const NamedSpectrum> namedIlluminants();

// The spectrum called `name` (a material's or an illuminant), or nullptr when cbdpt has none
// by that name.
const NamedSpectrum* findNamedSpectrum(std::string_view name);

// Its (nm, value) pairs as a scene gets them: scaled to luminance 1 where unitLuminance.
std::vector<double> namedSpectrumPairs(const NamedSpectrum& s);

// pbrt-v4's named glass spectra ("glass-BK7", ...): dispersive indices, by the catalogue's
// Sellmeier formula.
struct NamedGlass {
    std::string_view name;
    double nd;              // index at the helium d line, 587.6 nm
    std::string_view glass; // the catalogue glass
    // n^2 = 1 + c0 + sum of B lambda^2 / (lambda^2 - C), lambda in micrometres: {c0, B1, C1,
    // B2, C2, B3, C3}, valid from lowNm to highNm.
    std::array<double, 7> sellmeier;
    double lowNm, highNm;
};
std::span<const NamedGlass> namedGlasses();
const NamedGlass* findNamedGlass(std::string_view name);

// The glass's index at `nm` nanometres (within its range).
double glassIndex(const NamedGlass& glass, double nm);

// The glass's index every 5 nm over pbrt-v4's 360-830 nm, as a spectrum.
PiecewiseLinear glassIndexSpectrum(const NamedGlass& glass);

// The built-in names, comma-separated, for error messages.
std::string namedSpectrumNames();

PiecewiseLinear toPiecewiseLinear(const NamedSpectrum& s);

} // namespace cb
