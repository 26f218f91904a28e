// Chi-square goodness-of-fit machinery for warps and BSDFs, in the manner of Nori's chi2test and
// Mitsuba 3's chi2.py: histogram the samples over (theta, phi) cells, integrate the claimed pdf
// over the same cells by Gauss-Legendre quadrature, pool cells with small expected counts, and
// reject when the p-value falls below a Sidak-corrected significance level.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include "cb_common.h"

namespace cbtest {

inline constexpr double kPi = 3.14159265358979323846;

// Regularised lower incomplete gamma P(a, x): series for x < a + 1, Lentz's continued fraction
// for Q = 1 - P otherwise (Abramowitz & Stegun 6.5.29 and 6.5.31).
inline double regularizedGammaP(double a, double x) {
    if (x <= 0.0) return 0.0;
    const double logPrefix = a * std::log(x) - x - std::lgamma(a);
    if (x < a + 1.0) {
        double term = 1.0 / a, sum = term;
        for (int n = 1; n < 100000; ++n) {
            term *= x / (a + n);
            sum += term;
            if (std::fabs(term) < std::fabs(sum) * 1e-15) break;
        }
        return sum * std::exp(logPrefix);
    }
    const double tiny = 1e-300;
    double b = x + 1.0 - a, c = 1.0 / tiny, d = 1.0 / b, h = d;
    for (int n = 1; n < 100000; ++n) {
        double an = -n * (n - a);
        b += 2.0;
        d = an * d + b;
        if (std::fabs(d) < tiny) d = tiny;
        c = b + an / c;
        if (std::fabs(c) < tiny) c = tiny;
        d = 1.0 / d;
        double delta = d * c;
        h *= delta;
        if (std::fabs(delta - 1.0) < 1e-15) break;
    }
    return 1.0 - std::exp(logPrefix) * h;
}

// Upper tail of the chi-square distribution with `dof` degrees of freedom.
inline double chi2PValue(double statistic, int dof) {
    return 1.0 - regularizedGammaP(0.5 * dof, 0.5 * statistic);
}

// Per-test level so that `tests` independent tests together reject a correct sampler with
// probability `alpha` (Sidak).
inline double sidak(double alpha, int tests) {
    return 1.0 - std::pow(1.0 - alpha, 1.0 / tests);
}

struct Chi2Result {
    bool passed = false;
    double statistic = 0.0;
    int dof = 0;
    double pValue = 0.0;
    std::string message;
};

// observed / expected are counts per cell (same total sample count). Cells with expected count
// below minExpected are pooled (smallest first) until the pool reaches minExpected. A cell with
// zero expected count but observed samples fails outright, allowing `zeroSlack` samples there
// for quadrature that misses a sliver of the support.
inline Chi2Result chi2Test(const std::vector<double>& observed, const std::vector<double>& expected,
                           double significance, double minExpected = 5.0, double zeroSlack = 0.0) {
    Chi2Result r;
    std::vector<std::size_t> order(observed.size());
    for (std::size_t i = 0; i < order.size(); ++i)
        order[i] = i;
    std::sort(order.begin(), order.end(),
              [&](std::size_t a, std::size_t b) { return expected[a] < expected[b]; });
    double zeroObserved = 0.0;
    double poolObs = 0.0, poolExp = 0.0;
    std::vector<std::pair<double, double>> cells;
    for (std::size_t i : order) {
        if (expected[i] <= 0.0) {
            zeroObserved += observed[i];
            continue;
        }
        if (expected[i] < minExpected || (poolExp > 0.0 && poolExp < minExpected)) {
            poolObs += observed[i];
            poolExp += expected[i];
            if (poolExp >= minExpected) {
                cells.emplace_back(poolObs, poolExp);
                poolObs = poolExp = 0.0;
            }
            continue;
        }
        cells.emplace_back(observed[i], expected[i]);
    }
    if (poolExp > 0.0) {
        if (cells.empty())
            cells.emplace_back(poolObs, poolExp);
        else {
            cells.back().first += poolObs;
            cells.back().second += poolExp;
        }
    }
    std::ostringstream msg;
    if (zeroObserved > zeroSlack) {
        msg << zeroObserved << " samples in cells with zero expected count";
        r.message = msg.str();
        return r;
    }
    for (auto& [o, e] : cells)
        r.statistic += (o - e) * (o - e) / e;
    r.dof = static_cast<int>(cells.size()) - 1;
    if (r.dof < 1) {
        r.message = "fewer than two cells";
        return r;
    }
    r.pValue = chi2PValue(r.statistic, r.dof);
    r.passed = r.pValue > significance;
    msg << "chi2 = " << r.statistic << ", dof = " << r.dof << ", p = " << r.pValue
        << ", level = " << significance;
    r.message = msg.str();
    return r;
}

// Gauss-Legendre nodes/weights on [-1, 1], order 8.
inline const double* gaussLegendre8Nodes() {
    static const double x[8] = {-0.9602898564975363, -0.7966664774136267, -0.5255324099163290,
                                -0.1834346424956498, 0.1834346424956498,  0.5255324099163290,
                                0.7966664774136267,  0.9602898564975363};
    return x;
}
inline const double* gaussLegendre8Weights() {
    static const double w[8] = {0.1012285362903763, 0.2223810344533745, 0.3137066458778873,
                                0.3626837833783620, 0.3626837833783620, 0.3137066458778873,
                                0.2223810344533745, 0.1012285362903763};
    return w;
}

// Integral of f over [x0,x1] x [y0,y1] with sub x sub panels of 8x8-point Gauss-Legendre.
inline double integrate2D(const std::function<double(double, double)>& f, double x0, double x1,
                          double y0, double y1, int sub = 1) {
    const double* gx = gaussLegendre8Nodes();
    const double* gw = gaussLegendre8Weights();
    double sum = 0.0;
    double hx = (x1 - x0) / sub, hy = (y1 - y0) / sub;
    for (int a = 0; a < sub; ++a)
        for (int b = 0; b < sub; ++b) {
            double cx = x0 + (a + 0.5) * hx, cy = y0 + (b + 0.5) * hy;
            for (int i = 0; i < 8; ++i)
                for (int j = 0; j < 8; ++j)
                    sum += gw[i] * gw[j] * f(cx + 0.5 * hx * gx[i], cy + 0.5 * hy * gx[j]);
        }
    return sum * 0.25 * hx * hy;
}

// Cells over the sphere in the local frame: theta in [0, pi] (nTheta cells, even so that the
// horizon is a cell boundary and a hemisphere cutoff is not integrated across) times phi in
// [0, 2 pi).
struct SphereHistogram {
    int nTheta, nPhi;
    SphereHistogram(int nt, int np) : nTheta(nt), nPhi(np) {}
    int cells() const { return nTheta * nPhi; }
    static cbk::Vec3 direction(double theta, double phi) {
        return cbk::vec3(static_cast<float>(std::sin(theta) * std::cos(phi)),
                         static_cast<float>(std::sin(theta) * std::sin(phi)),
                         static_cast<float>(std::cos(theta)));
    }
    int cell(cbk::Vec3 w) const {
        double theta = std::acos(std::clamp(static_cast<double>(w.z), -1.0, 1.0));
        double phi = std::atan2(static_cast<double>(w.y), static_cast<double>(w.x));
        if (phi < 0.0) phi += 2.0 * kPi;
        int it = std::min(nTheta - 1, static_cast<int>(theta / kPi * nTheta));
        int ip = std::min(nPhi - 1, static_cast<int>(phi / (2.0 * kPi) * nPhi));
        return it * nPhi + ip;
    }
    // Per-cell integral of a solid-angle density given on local directions, with sub x sub
    // panels. Beyond 2, only cells where 1 and 2 panels disagree get sub: a density that drops
    // to 0 along a curve (a rough dielectric's) needs many panels in the few cells the curve
    // crosses, while Gauss-Legendre on smooth cells agrees to ~1e-12 already.
    std::vector<double> integrate(const std::function<double(cbk::Vec3)>& pdf, int sub = 1) const {
        std::vector<double> out(cells());
        for (int it = 0; it < nTheta; ++it)
            for (int ip = 0; ip < nPhi; ++ip) {
                double t0 = kPi * it / nTheta, t1 = kPi * (it + 1) / nTheta;
                double p0 = 2.0 * kPi * ip / nPhi, p1 = 2.0 * kPi * (ip + 1) / nPhi;
                auto cell = [&](int panels) {
                    return integrate2D(
                        [&](double t, double p) { return pdf(direction(t, p)) * std::sin(t); }, t0,
                        t1, p0, p1, panels);
                };
                double value = cell(std::min(sub, 2));
                if (sub > 2) {
                    const double coarse = cell(1);
                    if (std::fabs(value - coarse) > 1e-6 * std::max(std::fabs(value), 1e-12))
                        value = cell(sub);
                }
                out[it * nPhi + ip] = value;
            }
        return out;
    }
};

} // namespace cbtest
