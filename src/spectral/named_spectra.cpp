#include "spectral/named_spectra.h"

#include <cmath>
#include <initializer_list>

namespace cb {

const NamedSpectrum* findNamedSpectrum(std::string_view name) {
    for (const std::span<const NamedSpectrum> table : {namedSpectra(), namedIlluminants()})
        for (const NamedSpectrum& s : table)
            if (s.name == name) return &s;
    return nullptr;
}

std::vector<double> namedSpectrumPairs(const NamedSpectrum& s) {
    std::vector<double> pairs(s.pairs.begin(), s.pairs.end());
    if (!s.unitLuminance) return pairs;
    PiecewiseLinear samples;
    for (size_t i = 0; i + 1 < pairs.size(); i += 2)
        samples.emplace_back(static_cast<float>(pairs[i]), static_cast<float>(pairs[i + 1]));
    // pbrt-v4's PiecewiseLinearSpectrum::FromInterleaved(normalize = true).
    const double scale =
        photometricIntegral({{360.0f, 1.0f}, {830.0f, 1.0f}}) / photometricIntegral(samples);
    for (size_t i = 1; i < pairs.size(); i += 2)
        pairs[i] *= scale;
    return pairs;
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
    for (const std::span<const NamedSpectrum> table : {namedSpectra(), namedIlluminants()})
        for (const NamedSpectrum& s : table)
            out += (out.empty() ? "" : ", ") + std::string(s.name);
    return out;
}

PiecewiseLinear toPiecewiseLinear(const NamedSpectrum& s) {
    const std::vector<double> pairs = namedSpectrumPairs(s);
    PiecewiseLinear out;
    for (size_t i = 0; i + 1 < pairs.size(); i += 2)
        out.emplace_back(static_cast<float>(pairs[i]), static_cast<float>(pairs[i + 1]));
    return out;
}

} // namespace cb
