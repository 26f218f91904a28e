#include "spectral/named_spectra.h"

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
