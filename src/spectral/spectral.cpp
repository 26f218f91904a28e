#include "spectral/spectral.h"

#include "cb_spectrum.h"
#include "spectral/camera_sensors.h"
#include "spectral/named_spectra.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace cb {

namespace {

using Mat3 = std::array<std::array<double, 3>, 3>;
using Vec3d = std::array<double, 3>;

void validate(const PiecewiseLinear& s) {
    for (std::size_t i = 0; i < s.size(); ++i) {
        if (!std::isfinite(s[i].first) || !std::isfinite(s[i].second))
            throw std::invalid_argument("spectrum sample " + std::to_string(i) + " is not finite");
        if (i > 0 && !(s[i].first > s[i - 1].first))
            throw std::invalid_argument(
                "spectrum wavelengths must be strictly increasing (sample " + std::to_string(i) +
                ")");
    }
}

// One lobe of the Wyman et al. fit: a Gaussian whose inverse width differs on each side of the
// peak (their eq. 2 with 1/sigma written as in their listing 1).
double lobe(double nm, double mu, double invSigmaBelow, double invSigmaAbove) {
    const double t = (nm - mu) * (nm < mu ? invSigmaBelow : invSigmaAbove);
    return std::exp(-0.5 * t * t);
}

// Integrates f over [a, b] with two-point Gauss-Legendre on 0.25 nm panels: the fit is smooth
// except for a jump in the second derivative at each lobe peak, so the error is far below the
// fit's own error against the CIE tables. A trailing partial panel is handled exactly.
template <class F> double integrateFine(F&& f, double a, double b) {
    constexpr double kPanel = 0.25;
    const double g = 0.5 / std::sqrt(3.0);
    double sum = 0.0;
    for (double lo = a; lo < b; lo += kPanel) {
        const double hi = std::min(b, lo + kPanel);
        const double mid = 0.5 * (lo + hi), h = hi - lo;
        sum += 0.5 * h * (f(mid - g * h) + f(mid + g * h));
    }
    return sum;
}

Vec3d mul(const Mat3& m, const Vec3d& v) {
    Vec3d r{};
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            r[i] += m[i][j] * v[j];
    return r;
}

Mat3 mul(const Mat3& a, const Mat3& b) {
    Mat3 r{};
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            for (int k = 0; k < 3; ++k)
                r[i][j] += a[i][k] * b[k][j];
    return r;
}

Mat3 inverse(const Mat3& m) {
    const double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                       m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                       m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    Mat3 r{};
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            // Cofactor of m[j][i] (transposed) via cyclic indices.
            const int r0 = (j + 1) % 3, r1 = (j + 2) % 3, c0 = (i + 1) % 3, c1 = (i + 2) % 3;
            r[i][j] = (m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0]) / det;
        }
    return r;
}

Vec3d xyzFromChromaticity(double x, double y) {
    return {x / y, 1.0, (1.0 - x - y) / y};
}

// XYZ -> linear sRGB derived from the Rec. 709 primaries and the D65 chromaticity (0.3127,
// 0.3290) of IEC 61966-2-1, rather than the rounded published matrix, so that D65 maps to
// (1,1,1) to double precision.
Mat3 xyzToLinearSrgb() {
    const Vec3d r = xyzFromChromaticity(0.64, 0.33), g = xyzFromChromaticity(0.30, 0.60),
                b = xyzFromChromaticity(0.15, 0.06), w = xyzFromChromaticity(0.3127, 0.3290);
    const Mat3 primaries{{{r[0], g[0], b[0]}, {r[1], g[1], b[1]}, {r[2], g[2], b[2]}}};
    const Vec3d scale = mul(inverse(primaries), w);
    Mat3 rgbToXyz{};
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            rgbToXyz[i][j] = primaries[i][j] * scale[j];
    return inverse(rgbToXyz);
}

// Bradford chromatic adaptation (Lam 1985; the von Kries scaling in the sharpened cone space)
// from the equal-energy white E (X=Y=Z=1) to D65.
Mat3 bradfordEToD65() {
    const Mat3 bradford{
        {{0.8951, 0.2664, -0.1614}, {-0.7502, 1.7135, 0.0367}, {0.0389, -0.0685, 1.0296}}};
    const Vec3d src = mul(bradford, Vec3d{1.0, 1.0, 1.0});
    const Vec3d dst = mul(bradford, xyzFromChromaticity(0.3127, 0.3290));
    Mat3 scale{};
    for (int i = 0; i < 3; ++i)
        scale[i][i] = dst[i] / src[i];
    return mul(inverse(bradford), mul(scale, bradford));
}

double ybarIntegral400to700() {
    return integrateFine([](double nm) { return cieXyz1931Fit(nm)[1]; }, kLambdaMin, kLambdaMax);
}

// 3 x 16 bins -> linear sRGB, in double.
const std::array<double, 3 * kSpectralBins>& spectralMatrix() {
    static const std::array<double, 3 * kSpectralBins> m = [] {
        const double norm = 1.0 / ybarIntegral400to700();
        const Mat3 toRgb = mul(xyzToLinearSrgb(), bradfordEToD65());
        std::array<double, 3 * kSpectralBins> out{};
        for (int i = 0; i < kSpectralBins; ++i) {
            // A bin value is the mean of the spectrum over the bin, so its weight is the integral
            // of the CMF over the bin.
            Vec3d xyz{};
            for (int c = 0; c < 3; ++c)
                xyz[c] = norm * integrateFine([c](double nm) { return cieXyz1931Fit(nm)[c]; },
                                              binLambdaLow(i), binLambdaHigh(i));
            const Vec3d rgb = mul(toRgb, xyz);
            for (int c = 0; c < 3; ++c)
                out[c * kSpectralBins + i] = rgb[c];
        }
        return out;
    }();
    return m;
}

// Dense Gaussian elimination with partial pivoting; false if (numerically) singular.
bool solveDense(std::vector<double> a, std::vector<double>& x, int n) {
    for (int col = 0; col < n; ++col) {
        int piv = col;
        for (int r = col + 1; r < n; ++r)
            if (std::abs(a[r * (n + 1) + col]) > std::abs(a[piv * (n + 1) + col])) piv = r;
        if (std::abs(a[piv * (n + 1) + col]) < 1e-13) return false;
        if (piv != col)
            for (int c = 0; c <= n; ++c)
                std::swap(a[piv * (n + 1) + c], a[col * (n + 1) + c]);
        for (int r = col + 1; r < n; ++r) {
            const double f = a[r * (n + 1) + col] / a[col * (n + 1) + col];
            for (int c = col; c <= n; ++c)
                a[r * (n + 1) + c] -= f * a[col * (n + 1) + c];
        }
    }
    x.assign(n, 0.0);
    for (int r = n - 1; r >= 0; --r) {
        double v = a[r * (n + 1) + n];
        for (int c = r + 1; c < n; ++c)
            v -= a[r * (n + 1) + c] * x[c];
        x[r] = v / a[r * (n + 1) + r];
    }
    return true;
}

// Minimises 0.5 s'Hs - g's subject to A s = b (m rows) and 0 <= s <= 1 with the primal-dual
// active-set method (Hintermueller, Ito & Kunisch 2003, SIAM J. Optim. 13(3)): each step solves
// the KKT system with the current bound set fixed, then re-guesses the set from the sign of
// the bound multipliers. False if it does not settle or the reduced system is singular (e.g. the
// equalities are infeasible inside the box).
bool solveBoxQp(const std::vector<double>& h, const std::vector<double>& g,
                const std::vector<double>& aEq, const std::vector<double>& bEq, int n, int m,
                std::vector<double>& s) {
    std::vector<int> state(n, 0), next(n, 0); // -1 at 0, +1 at 1, 0 free
    s.assign(n, 0.0);
    for (int iter = 0; iter < 100; ++iter) {
        std::vector<int> free;
        for (int i = 0; i < n; ++i) {
            if (state[i] == 0)
                free.push_back(i);
            else
                s[i] = state[i] < 0 ? 0.0 : 1.0;
        }
        const int k = static_cast<int>(free.size()), dim = k + m;
        if (k < m) return false;
        std::vector<double> kkt(static_cast<std::size_t>(dim) * (dim + 1), 0.0), sol;
        auto at = [&](int r, int c) -> double& { return kkt[r * (dim + 1) + c]; };
        for (int r = 0; r < k; ++r) {
            const int i = free[r];
            double rhs = g[i];
            for (int j = 0; j < n; ++j)
                if (state[j] != 0) rhs -= h[i * n + j] * s[j];
            for (int c = 0; c < k; ++c)
                at(r, c) = h[i * n + free[c]];
            for (int e = 0; e < m; ++e)
                at(r, k + e) = aEq[e * n + i];
            at(r, dim) = rhs;
        }
        for (int e = 0; e < m; ++e) {
            double rhs = bEq[e];
            for (int j = 0; j < n; ++j)
                if (state[j] != 0) rhs -= aEq[e * n + j] * s[j];
            for (int c = 0; c < k; ++c)
                at(k + e, c) = aEq[e * n + free[c]];
            at(k + e, dim) = rhs;
        }
        if (!solveDense(kkt, sol, dim)) return false;
        for (int r = 0; r < k; ++r)
            s[free[r]] = sol[r];
        bool changed = false;
        for (int i = 0; i < n; ++i) {
            // Bound multiplier from stationarity: H s - g + A' nu = lambda.
            double lambda = -g[i];
            for (int j = 0; j < n; ++j)
                lambda += h[i * n + j] * s[j];
            for (int e = 0; e < m; ++e)
                lambda += aEq[e * n + i] * sol[k + e];
            constexpr double tol = 1e-12;
            next[i] = lambda - s[i] > tol ? -1 : (lambda + (1.0 - s[i]) < -tol ? 1 : 0);
            changed |= next[i] != state[i];
        }
        if (!changed) {
            for (int e = 0; e < m; ++e) {
                double r = -bEq[e];
                for (int j = 0; j < n; ++j)
                    r += aEq[e * n + j] * s[j];
                if (std::abs(r) > 1e-9) return false;
            }
            for (double& v : s)
                v = std::clamp(v, 0.0, 1.0);
            return true;
        }
        state = next;
    }
    return false;
}

// The smoothest 16-bin reflectance in [0,1] whose film colour, lit by the white of RGB lights, is
// exactly `target` (Smits 1999 asks for the same: smooth, bounded, matching; pbrt-v4 fits its
// RGB albedo spectra under D65 likewise, so that such a reflectance renders as its RGB). Smoothness
// is the squared first difference between adjacent bins; a tiny ridge makes the objective strictly
// convex. If no bounded spectrum matches exactly, the match becomes a stiff penalty instead.
std::array<float, kSpectralBins> smoothestReflectance(const Vec3d& target) {
    constexpr int n = kSpectralBins;
    std::vector<double> h(n * n, 0.0), g(n, 0.0);
    for (int i = 0; i + 1 < n; ++i) {
        h[i * n + i] += 1.0;
        h[(i + 1) * n + i + 1] += 1.0;
        h[i * n + i + 1] -= 1.0;
        h[(i + 1) * n + i] -= 1.0;
    }
    for (int i = 0; i < n; ++i)
        h[i * n + i] += 1e-6;
    // The film's matrix times the white (whiteIlluminantBins, whose film colour is (1,1,1)).
    const std::vector<float> film = filmMatrix(kSpectralBins, FilmColour{});
    std::vector<double> a(3 * n), b(target.begin(), target.end()), s;
    for (int c = 0; c < 3; ++c)
        for (int i = 0; i < n; ++i)
            a[c * n + i] = double(film[c * n + i]) * whiteIlluminantBins()[i];
    if (!solveBoxQp(h, g, a, b, n, 3, s)) {
        constexpr double w = 1e6;
        for (int i = 0; i < n; ++i) {
            for (int j = 0; j < n; ++j)
                for (int e = 0; e < 3; ++e)
                    h[i * n + j] += w * a[e * n + i] * a[e * n + j];
            for (int e = 0; e < 3; ++e)
                g[i] += w * a[e * n + i] * b[e];
        }
        if (!solveBoxQp(h, g, {}, {}, n, 0, s))
            throw std::logic_error("rgbToSpectrum: basis optimisation failed");
    }
    std::array<float, kSpectralBins> out{};
    for (int i = 0; i < n; ++i)
        out[i] = static_cast<float>(s[i]);
    return out;
}

} // namespace

double evalPiecewiseLinear(const PiecewiseLinear& s, double nm) {
    if (s.empty() || nm < s.front().first || nm > s.back().first) return 0.0;
    if (nm == s.back().first) return s.back().second;
    const auto it = std::upper_bound(s.begin(), s.end(), nm,
                                     [](double v, const auto& p) { return v < p.first; });
    const auto& p1 = *it;
    const auto& p0 = *(it - 1);
    const double t = (nm - p0.first) / (static_cast<double>(p1.first) - p0.first);
    return p0.second + t * (static_cast<double>(p1.second) - p0.second);
}

double integratePiecewiseLinear(const PiecewiseLinear& s, double a, double b) {
    if (s.empty() || !(b > a)) return 0.0;
    double sum = 0.0;
    // Zero outside [first, last] (pbrt-v4). The trapezoid rule is exact on each linear piece
    // clipped to [a, b].
    for (std::size_t k = 0; k + 1 < s.size(); ++k) {
        const double lo = std::max<double>(a, s[k].first), hi = std::min<double>(b, s[k + 1].first);
        if (hi > lo)
            sum += 0.5 * (hi - lo) * (evalPiecewiseLinear(s, lo) + evalPiecewiseLinear(s, hi));
    }
    return sum;
}

std::array<float, kSpectralBins> binSpectrum(const PiecewiseLinear& s) {
    validate(s);
    std::array<float, kSpectralBins> out{};
    for (int i = 0; i < kSpectralBins; ++i)
        out[i] = static_cast<float>(integratePiecewiseLinear(s, binLambdaLow(i), binLambdaHigh(i)) /
                                    kBinWidth);
    return out;
}

std::array<double, 3> cieXyz1931Fit(double nm) {
    // Wyman, Sloan & Shirley 2013, listing 1 (multi-lobe fit, CIE 1931 2-degree observer).
    const double x = 0.362 * lobe(nm, 442.0, 0.0624, 0.0374) +
                     1.056 * lobe(nm, 599.8, 0.0264, 0.0323) -
                     0.065 * lobe(nm, 501.1, 0.0490, 0.0382);
    const double y =
        0.821 * lobe(nm, 568.8, 0.0213, 0.0247) + 0.286 * lobe(nm, 530.9, 0.0613, 0.0322);
    const double z =
        1.217 * lobe(nm, 437.0, 0.0845, 0.0278) + 0.681 * lobe(nm, 459.0, 0.0385, 0.0725);
    return {x, y, z};
}

std::array<double, 3> spectrumToXyz(const PiecewiseLinear& s) {
    validate(s);
    static const double norm = 1.0 / ybarIntegral400to700();
    std::array<double, 3> xyz{};
    for (int c = 0; c < 3; ++c)
        xyz[c] =
            norm * integrateFine(
                       [&](double nm) { return evalPiecewiseLinear(s, nm) * cieXyz1931Fit(nm)[c]; },
                       kLambdaMin, kLambdaMax);
    return xyz;
}

std::vector<float> channelsToRgbMatrix(int channels) {
    if (channels == 3) return {1.f, 0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f};
    if (channels != kSpectralBins)
        throw std::invalid_argument("channelsToRgbMatrix: unsupported channel count " +
                                    std::to_string(channels));
    const auto& m = spectralMatrix();
    return std::vector<float>(m.begin(), m.end());
}

std::array<float, 3> binsToRgb(const std::array<float, kSpectralBins>& bins) {
    const auto& m = spectralMatrix();
    std::array<float, 3> rgb{};
    for (int c = 0; c < 3; ++c) {
        double v = 0.0;
        for (int i = 0; i < kSpectralBins; ++i)
            v += m[c * kSpectralBins + i] * bins[i];
        rgb[c] = static_cast<float>(v);
    }
    return rgb;
}

std::array<float, 3> spectrumToRgb(const PiecewiseLinear& s) {
    return binsToRgb(binSpectrum(s));
}

const std::array<std::array<float, kSpectralBins>, 7>& smitsBasis() {
    static const std::array<std::array<float, kSpectralBins>, 7> basis = [] {
        std::array<std::array<float, kSpectralBins>, 7> b{};
        b[0].fill(1.f); // white is exactly flat, so rgb (1,1,1) gives reflectance 1 everywhere
        const Vec3d targets[6] = {{0, 1, 1}, {1, 0, 1}, {1, 1, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
        for (int k = 0; k < 6; ++k)
            b[k + 1] = smoothestReflectance(targets[k]);
        return b;
    }();
    return basis;
}

std::array<float, kSpectralBins> rgbToSpectrum(std::array<float, 3> rgb) {
    // Smits's weights (cb_spectrum.h, shared with the image lights' pixels); negative components
    // have no reflectance meaning and are clamped to zero.
    const auto& basis = smitsBasis();
    const cbk::SmitsSplit k = cbk::smitsSplit(rgb[0], rgb[1], rgb[2]);
    std::array<float, kSpectralBins> out{};
    for (int i = 0; i < kSpectralBins; ++i)
        out[i] = k.white * basis[0][i] + k.secondaryWeight * basis[size_t(k.secondary)][i] +
                 k.primaryWeight * basis[size_t(k.primary)][i];
    return out;
}

double photometricIntegral(const PiecewiseLinear& s) {
    validate(s);
    if (s.empty()) return 0.0;
    // pbrt-v4 sums 1 nm samples over [Lambda_min, Lambda_max] = [360, 830]; the integral of the
    // same piecewise-linear product differs from that sum by far less than the fit's error.
    const double lo = std::max(360.0, double(s.front().first));
    const double hi = std::min(830.0, double(s.back().first));
    if (!(hi > lo)) return 0.0;
    return integrateFine(
        [&](double nm) { return evalPiecewiseLinear(s, nm) * cieXyz1931Fit(nm)[1]; }, lo, hi);
}

namespace {

// Absolute CMF integral over each bin (nm units): the XYZ weight of a bin's mean value.
const std::array<Vec3d, kSpectralBins>& binCmfIntegrals() {
    static const std::array<Vec3d, kSpectralBins> w = [] {
        std::array<Vec3d, kSpectralBins> out{};
        for (int i = 0; i < kSpectralBins; ++i)
            for (int c = 0; c < 3; ++c)
                out[i][c] = integrateFine([c](double nm) { return cieXyz1931Fit(nm)[c]; },
                                          binLambdaLow(i), binLambdaHigh(i));
        return out;
    }();
    return w;
}

// Planck's law (relative spectral radiance; the scale cancels in a chromaticity).
double planck(double nm, double kelvin) {
    const double c = 299792458.0, h = 6.62606957e-34, kb = 1.3806488e-23;
    const double l = nm * 1e-9;
    return 2.0 * h * c * c / (std::pow(l, 5) * (std::exp(h * c / (l * kb * kelvin)) - 1.0));
}

// pbrt-v4's WhiteBalance (util/color.h): von Kries scaling in Bradford's cone space from the
// source white's chromaticity to the target's.
Mat3 whiteBalance(const std::array<double, 2>& src, const std::array<double, 2>& dst) {
    const Mat3 bradford{
        {{0.8951, 0.2664, -0.1614}, {-0.7502, 1.7135, 0.0367}, {0.0389, -0.0685, 1.0296}}};
    const Vec3d s = mul(bradford, xyzFromChromaticity(src[0], src[1]));
    const Vec3d d = mul(bradford, xyzFromChromaticity(dst[0], dst[1]));
    Mat3 scale{};
    for (int i = 0; i < 3; ++i)
        scale[i][i] = d[i] / s[i];
    return mul(inverse(bradford), mul(scale, bradford));
}

Mat3 filmXyzToRgb(const FilmColour& film) {
    Mat3 m = xyzToLinearSrgb();
    if (film.whiteBalanceKelvin > 0.0)
        m = mul(m,
                whiteBalance(whiteBalanceChromaticity(film.whiteBalanceKelvin), {0.3127, 0.3290}));
    for (auto& row : m)
        for (double& v : row)
            v *= film.imagingRatio;
    return m;
}

} // namespace

PiecewiseLinear blackbody(double kelvin) {
    const double peak = planck(2.8977721e6 / kelvin, kelvin); // Wien: lambda_max T in nm K
    PiecewiseLinear out;
    for (int nm = 360; nm <= 830; ++nm)
        out.emplace_back(static_cast<float>(nm), static_cast<float>(planck(nm, kelvin) / peak));
    return out;
}

std::array<double, 2> whiteBalanceChromaticity(double kelvin) {
    const double cct = kelvin * 1.4388 / 1.4380;
    if (cct < 4000.0) {
        Vec3d xyz{};
        for (int c = 0; c < 3; ++c)
            xyz[c] = integrateFine(
                [&](double nm) { return planck(nm, cct) * cieXyz1931Fit(nm)[c]; }, 360.0, 830.0);
        const double sum = xyz[0] + xyz[1] + xyz[2];
        return {xyz[0] / sum, xyz[1] / sum};
    }
    // CIE 15 daylight locus, as in pbrt-v4's Spectra::D.
    const double x =
        cct <= 7000.0
            ? -4.607e9 / (cct * cct * cct) + 2.9678e6 / (cct * cct) + 0.09911e3 / cct + 0.244063
            : -2.0064e9 / (cct * cct * cct) + 1.9018e6 / (cct * cct) + 0.24748e3 / cct + 0.23704;
    return {x, -3.0 * x * x + 2.870 * x - 0.275};
}

namespace {

// Column `column` of a table of rows of `stride` numbers (nm first) as a spectrum.
PiecewiseLinear tableColumn(std::span<const double> table, std::size_t stride, std::size_t column) {
    PiecewiseLinear out;
    for (std::size_t row = 0; row + stride <= table.size(); row += stride)
        out.emplace_back(static_cast<float>(table[row]), static_cast<float>(table[row + column]));
    return out;
}

// A camera's R, G, B sensitivities as spectra.
std::array<PiecewiseLinear, 3> cameraResponse(const CameraSensorCurves& camera) {
    return {tableColumn(camera.table, 4, 1), tableColumn(camera.table, 4, 2),
            tableColumn(camera.table, 4, 3)};
}

const CameraSensorCurves& cameraCurves(const std::string& name) {
    const CameraSensorCurves* camera = findCameraSensor(name);
    if (!camera)
        throw std::invalid_argument("unknown camera sensor \"" + name + "\" (cbdpt knows " +
                                    cameraSensorNames() + ")");
    return *camera;
}

// pbrt-v4's Spectra::D: the CIE daylight of correlated temperature kelvin * 1.4388 / 1.4380
// (CIE 15 components), or Planck's law below 4000 K; unnormalised (only ratios are used).
std::vector<double> daylightEveryNm(double kelvin) {
    const double cct = kelvin * 1.4388 / 1.4380;
    std::vector<double> out;
    if (cct < 4000.0) {
        for (int nm = 360; nm <= 830; ++nm)
            out.push_back(planck(nm, cct));
        return out;
    }
    const auto [x, y] = whiteBalanceChromaticity(kelvin);
    const double m = 0.0241 + 0.2562 * x - 0.7341 * y;
    const double m1 = (-1.3515 - 1.7703 * x + 5.9114 * y) / m;
    const double m2 = (0.0300 - 31.4424 * x + 30.0717 * y) / m;
    const auto table = daylightComponents();
    const PiecewiseLinear s0 = tableColumn(table, 4, 1), s1 = tableColumn(table, 4, 2),
                          s2 = tableColumn(table, 4, 3);
    for (int nm = 360; nm <= 830; ++nm)
        out.push_back(evalPiecewiseLinear(s0, nm) + m1 * evalPiecewiseLinear(s1, nm) +
                      m2 * evalPiecewiseLinear(s2, nm));
    return out;
}

} // namespace

std::array<double, 9> xyzFromCameraRgb(const std::string& name, double kelvin) {
    const CameraSensorCurves& camera = cameraCurves(name);
    const std::vector<double> sensorIllum = daylightEveryNm(kelvin);
    const NamedSpectrum* d65Named = findNamedSpectrum("stdillum-D65");
    if (!d65Named) throw std::logic_error("the built-in stdillum-D65 table is missing");
    const PiecewiseLinear d65 = tableColumn(d65Named->pairs, 2, 1);
    const std::array<PiecewiseLinear, 3> response = cameraResponse(camera);
    // The patches every 10 nm from 380 nm.
    constexpr int kPatches = 24, kPatchSamples = 36;
    const auto table = colorCheckerReflectances();
    std::array<PiecewiseLinear, kPatches> patches;
    for (int p = 0; p < kPatches; ++p)
        for (int i = 0; i < kPatchSamples; ++i)
            patches[size_t(p)].emplace_back(380.f + 10.f * float(i),
                                            float(table[size_t(p * kPatchSamples + i)]));
    // Sums over pbrt-v4's 1 nm steps (ProjectReflectance, InnerProduct).
    std::array<Vec3d, kPatches> rgb{}, xyz{};
    double illumG = 0.0, illumY = 0.0, d65Y = 0.0;
    for (int nm = 360; nm <= 830; ++nm) {
        const double li = sensorIllum[size_t(nm - 360)];
        const double ld = evalPiecewiseLinear(d65, nm);
        const Vec3d cam{evalPiecewiseLinear(response[0], nm), evalPiecewiseLinear(response[1], nm),
                        evalPiecewiseLinear(response[2], nm)};
        const auto cmf = cieXyz1931Fit(nm);
        illumG += cam[1] * li;
        illumY += cmf[1] * li;
        d65Y += cmf[1] * ld;
        for (int p = 0; p < kPatches; ++p) {
            const double r = evalPiecewiseLinear(patches[size_t(p)], nm);
            for (int c = 0; c < 3; ++c) {
                rgb[size_t(p)][size_t(c)] += cam[size_t(c)] * r * li;
                xyz[size_t(p)][size_t(c)] += cmf[size_t(c)] * r * ld;
            }
        }
    }
    for (int p = 0; p < kPatches; ++p)
        for (int c = 0; c < 3; ++c) {
            rgb[size_t(p)][size_t(c)] /= illumG;
            xyz[size_t(p)][size_t(c)] *= (illumY / illumG) / d65Y;
        }
    // Least squares (pbrt-v4's LinearLeastSquares): M = ((A^T A)^-1 A^T B)^T, A the patches'
    // camera RGB, B their XYZ, so that XYZ = M * RGB.
    Mat3 ata{}, atb{};
    for (int p = 0; p < kPatches; ++p)
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) {
                ata[i][j] += rgb[size_t(p)][size_t(i)] * rgb[size_t(p)][size_t(j)];
                atb[i][j] += rgb[size_t(p)][size_t(i)] * xyz[size_t(p)][size_t(j)];
            }
    const Mat3 solved = mul(inverse(ata), atb);
    std::array<double, 9> out{};
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            out[size_t(3 * i + j)] = solved[j][i];
    return out;
}

namespace {

// pbrt-v4's outputRGBFromSensorRGB times the imaging ratio: linear sRGB from camera RGB.
Mat3 filmFromCameraRgb(const FilmColour& film) {
    const auto m = xyzFromCameraRgb(
        film.sensor, film.whiteBalanceKelvin > 0.0 ? film.whiteBalanceKelvin : 6500.0);
    Mat3 xyzFromCamera{};
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            xyzFromCamera[i][j] = m[size_t(3 * i + j)] * film.imagingRatio;
    return mul(xyzToLinearSrgb(), xyzFromCamera);
}

} // namespace

std::vector<float> filmMatrix(int channels, const FilmColour& film) {
    if (!film.sensor.empty()) {
        if (channels != kSpectralBins)
            throw std::invalid_argument("the camera sensor \"" + film.sensor +
                                        "\" needs spectral rendering (16 channels)");
        const std::array<PiecewiseLinear, 3> curves = cameraResponse(cameraCurves(film.sensor));
        const Mat3 toRgb = filmFromCameraRgb(film);
        std::vector<float> out(3 * kSpectralBins);
        for (int i = 0; i < kSpectralBins; ++i) {
            Vec3d response{};
            for (int c = 0; c < 3; ++c)
                response[size_t(c)] =
                    integratePiecewiseLinear(curves[size_t(c)], binLambdaLow(i), binLambdaHigh(i));
            const Vec3d rgb = mul(toRgb, response);
            for (int c = 0; c < 3; ++c)
                out[size_t(c * kSpectralBins + i)] = static_cast<float>(rgb[size_t(c)]);
        }
        return out;
    }
    const Mat3 toRgb = filmXyzToRgb(film);
    if (channels == 3) {
        const Mat3 m = mul(toRgb, inverse(xyzToLinearSrgb()));
        std::vector<float> out;
        for (const auto& row : m)
            for (double v : row)
                out.push_back(static_cast<float>(v));
        return out;
    }
    if (channels != kSpectralBins)
        throw std::invalid_argument("filmMatrix: unsupported channel count " +
                                    std::to_string(channels));
    std::vector<float> out(3 * kSpectralBins);
    for (int i = 0; i < kSpectralBins; ++i) {
        const Vec3d rgb = mul(toRgb, binCmfIntegrals()[i]);
        for (int c = 0; c < 3; ++c)
            out[c * kSpectralBins + i] = static_cast<float>(rgb[c]);
    }
    return out;
}

std::array<float, 9> sensorFromFilmRgb(const FilmColour& film) {
    // Film RGB = filmXyzToRgb * XYZ and sensor RGB = imagingRatio * XYZ (pbrt-v4's
    // PixelSensor::ToSensorRGB for the XYZ matching functions); for a camera, film RGB =
    // filmFromCameraRgb * camera RGB and sensor RGB = imagingRatio * camera RGB.
    const Mat3 m = inverse(film.sensor.empty() ? filmXyzToRgb(film) : filmFromCameraRgb(film));
    std::array<float, 9> out{};
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
            out[size_t(3 * r + c)] = static_cast<float>(film.imagingRatio * m[r][c]);
    return out;
}

std::array<float, 3> emissionToRgb(const PiecewiseLinear& s) {
    const auto bins = binSpectrum(s);
    Vec3d xyz{};
    for (int i = 0; i < kSpectralBins; ++i)
        for (int c = 0; c < 3; ++c)
            xyz[c] += binCmfIntegrals()[i][c] * bins[i];
    const Vec3d rgb = mul(xyzToLinearSrgb(), xyz);
    return {static_cast<float>(rgb[0]), static_cast<float>(rgb[1]), static_cast<float>(rgb[2])};
}

const std::array<float, kSpectralBins>& whiteIlluminantBins() {
    static const std::array<float, kSpectralBins> w = [] {
        // Bin means of a + b t + c t^2, t = (nm - 550) / 150, chosen so that the film's XYZ is
        // D65's white with Y = 1. Its values are positive (tested).
        auto power = [](int i, int k) {
            // Exact mean of t^k over bin i.
            const double t0 = (binLambdaLow(i) - 550.0) / 150.0,
                         t1 = (binLambdaHigh(i) - 550.0) / 150.0;
            return (std::pow(t1, k + 1) - std::pow(t0, k + 1)) / ((k + 1) * (t1 - t0));
        };
        const Vec3d d65 = xyzFromChromaticity(0.3127, 0.3290);
        std::vector<double> a(3 * 4, 0.0), coef;
        for (int c = 0; c < 3; ++c) {
            for (int k = 0; k < 3; ++k)
                for (int i = 0; i < kSpectralBins; ++i)
                    a[c * 4 + k] += binCmfIntegrals()[i][c] * power(i, k);
            a[c * 4 + 3] = d65[c];
        }
        if (!solveDense(a, coef, 3)) throw std::logic_error("whiteIlluminantBins: singular");
        std::array<float, kSpectralBins> out{};
        for (int i = 0; i < kSpectralBins; ++i)
            out[i] = static_cast<float>(coef[0] + coef[1] * power(i, 1) + coef[2] * power(i, 2));
        return out;
    }();
    return w;
}

std::array<float, kSpectralBins> rgbIlluminantSpectrum(std::array<float, 3> rgb) {
    std::array<float, kSpectralBins> s = rgbToSpectrum(rgb);
    for (int i = 0; i < kSpectralBins; ++i)
        s[i] *= whiteIlluminantBins()[i];
    return s;
}

} // namespace cb
