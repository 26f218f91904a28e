// pbrt-v4's named conductor spectra ("metal-Au-eta", "metal-Au-k", ...), as measured data from
// the refractiveindex.info database (named_spectra_data.cpp, written by scripts/named-spectra;
// docs/pbrt-v4.md, "Named spectra").
#pragma once

#include <span>
#include <string>
#include <string_view>

#include "spectral/spectral.h"

namespace cb {

struct NamedSpectrum {
    std::string_view name;
    std::span<const double> pairs; // interleaved (wavelength in nm, value), increasing
};

// Every built-in named spectrum, in the generated file's order.
std::span<const NamedSpectrum> namedSpectra();

// The spectrum called `name` as (nm, value) pairs, or nullptr when cbdpt has none by that name.
const NamedSpectrum* findNamedSpectrum(std::string_view name);

// pbrt-v4's named glass spectra ("glass-BK7", ...): dispersive indices, which cbdpt's dielectrics
// do not take; kept for the refusal to suggest the glass's index at 587.6 nm.
struct NamedGlass {
    std::string_view name;
    double nd;              // index at the helium d line, 587.6 nm
    std::string_view glass; // the catalogue glass
};
std::span<const NamedGlass> namedGlasses();
const NamedGlass* findNamedGlass(std::string_view name);

// The built-in names, comma-separated, for error messages.
std::string namedSpectrumNames();

PiecewiseLinear toPiecewiseLinear(const NamedSpectrum& s);

} // namespace cb
