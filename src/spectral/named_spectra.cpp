#include "spectral/named_spectra.h"

#include <cmath>

namespace cb {

const NamedSpectrum* findNamedSpectrum(std::string_view name) {
    for (const NamedSpectrum& s : namedSpectra())
        if (s.name == name) return &s;
    return nullptr;
}

const NamedGlass* findNamedGlass(std::string_view name) {
    for (const NamedGlass& g : namedGlasses())
        if (g.name == name) return &g;
    return nullptr;
}

double glassIndex(const NamedGlass& glass, double nm) {
    const auto& c = glass.sellmeier;
    const double um2 = (nm / 1000.0) * (nm / 1000.0);
    return std::sqrt(1.0 + c[0] + c[1] * um2 / (um2 - c[2]) + c[3] * um2 / (um2 - c[4]) +
                     c[5] * um2 / (um2 - c[6]));
}

PiecewiseLinear glassIndexSpectrum(const NamedGlass& glass) {
    PiecewiseLinear out;
    for (int nm = 360; nm <= 830; nm += 5)
        out.emplace_back(float(nm), float(glassIndex(glass, double(nm))));
    return out;
}

std::string namedSpectrumNames() {
    std::string out;
    for (const NamedSpectrum& s : namedSpectra())
        out += (out.empty() ? "" : ", ") + std::string(s.name);
    return out;
}

PiecewiseLinear toPiecewiseLinear(const NamedSpectrum& s) {
    PiecewiseLinear out;
    for (size_t i = 0; i + 1 < s.pairs.size(); i += 2)
        out.emplace_back(static_cast<float>(s.pairs[i]), static_cast<float>(s.pairs[i + 1]));
    return out;
}

} // namespace cb
