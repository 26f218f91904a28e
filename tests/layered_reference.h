// Closed forms of smooth interfaces in double, apart from the kernels' float code: dielectric
// and conductor Fresnel, and pbrt-v4's coated diffuse (a Lambertian base under a smooth coat
// with an absorbing layer) and coated conductor (both layers smooth) as their random walks of a
// given depth estimate them.
#pragma once

#include <cmath>
#include <complex>

namespace cbtest {

// Unpolarised dielectric Fresnel (Hecht, eqs. 4.42/4.43); 1 under total internal reflection.
inline double dielectricFresnel(double cosI, double eta) {
    const double sinT = std::sqrt(1.0 - cosI * cosI) / eta;
    if (sinT >= 1.0) return 1.0;
    const double cosT = std::sqrt(1.0 - sinT * sinT);
    const double rs = (cosI - eta * cosT) / (cosI + eta * cosT);
    const double rp = (eta * cosI - cosT) / (eta * cosI + cosT);
    return 0.5 * (rs * rs + rp * rp);
}

// A thin sheet's reflectance as the sum over internal bounces: R, then T R T, T R^3 T, ...
inline double thinSheetReflectance(double cosI, double eta) {
    const double r = dielectricFresnel(cosI, eta), t = 1.0 - r;
    double sum = r, bounce = t * r * t;
    for (int k = 0; k < 200 && bounce > 1e-17; ++k, bounce *= r * r)
        sum += bounce;
    return sum;
}

// Conductor Fresnel from the complex amplitudes (Born & Wolf sec. 13.2), written apart from the
// kernels' real a, b form: eta + i k the conductor's index relative to the medium of incidence.
inline double conductorFresnel(double cosI, double eta, double k) {
    using C = std::complex<double>;
    const C n(eta, k);
    const C cosT = std::sqrt(C(1.0) - C(1.0 - cosI * cosI) / (n * n));
    const C rs = (C(cosI) - n * cosT) / (C(cosI) + n * cosT);
    const C rp = (n * C(cosI) - cosT) / (n * C(cosI) + cosT);
    return 0.5 * (std::norm(rs) + std::norm(rp));
}

// A smooth conductor of index eta + i k (in vacuum) under a smooth coat of index coatEta: every
// way out is the mirror direction. The coat reflects R(mu); T = 1 - R refracts in to mu', the
// layer passes tau = exp(-thickness / mu') each way, the conductor reflects F(mu') at its index
// relative to the coat's, and back at the coat the walk leaves with T (Stokes: the inside
// reflectance at mu' is R(mu)) or goes down again with R; the radiance's coatEta^2 in and out
// cancel. A walk of an even maxdepth d leaves at most d / 2 times. For a conductor given by its
// normal-incidence reflectance r instead, pbrt-v4 takes eta 1, k 2 sqrt(r) / sqrt(1 - r).
inline double smoothCoatedConductorAlbedo(double cosO, double coatEta, double eta, double k,
                                          double thickness, int maxDepth) {
    const double r = dielectricFresnel(cosO, coatEta);
    const double cos2Inside = 1.0 - (1.0 - cosO * cosO) / (coatEta * coatEta);
    if (cos2Inside <= 0.0) return r;
    const double muInside = std::sqrt(cos2Inside);
    const double tau2 = std::exp(-2.0 * thickness / muInside);
    const double base = conductorFresnel(muInside, eta / coatEta, k / coatEta);
    double sum = 0.0, term = 1.0;
    for (int exit = 0; exit < maxDepth / 2; ++exit, term *= r * base * tau2)
        sum += term;
    return r + (1.0 - r) * (1.0 - r) * tau2 * base * sum;
}

inline double conductorKFromReflectance(double reflectance) {
    return 2.0 * std::sqrt(reflectance) / std::sqrt(1.0 - reflectance);
}

// The coated diffuse of base reflectance rho, coat index eta and layer `thickness`: the coat
// reflects R(mu); T(mu) refracts in, crosses the layer (tau = exp(-thickness / mu') at the
// refracted cosine mu') and the base reflects rho, cosine-distributed. An upward trip leaves with
// a = int (1 - F_in) tau 2 mu' dmu' and comes back down with b = int F_in tau^2 2 mu' dmu' (F_in
// the coat's reflectance from inside, total beyond the critical angle). pbrt-v4's walk of an even
// maxdepth d reaches the base d / 2 times, hence the truncated series. (For an odd d its f visits
// the base once more than its sampling can leave: pbrt-v4's, and cbdpt's, f and sampling then
// describe different BSDFs; the tests use even depths.)
struct CoatedDiffuseReference {
    double rho, eta, thickness;
    int maxDepth;
    double a = 0.0, b = 0.0;

    CoatedDiffuseReference(double rho_, double eta_, double thickness_, int maxDepth_)
        : rho(rho_), eta(eta_), thickness(thickness_), maxDepth(maxDepth_) {
        const int n = 20000;
        for (int i = 0; i < n; ++i) {
            const double mu = (i + 0.5) / n;
            const double fin = dielectricFresnel(mu, 1.0 / eta), tau = std::exp(-thickness / mu);
            a += (1.0 - fin) * tau * 2.0 * mu / n;
            b += fin * tau * tau * 2.0 * mu / n;
        }
    }
    // sum over the base visits of what survives the round trips between them
    double visits() const {
        double sum = 0.0, term = 1.0;
        for (int k = 0; k < maxDepth / 2; ++k, term *= rho * b)
            sum += term;
        return sum;
    }
    // T(mu) tau(mu') on the way in (or out) at outside cosine mu; 0 where a coat of eta < 1
    // reflects totally.
    double crossing(double cosOutside) const {
        const double cos2Inside = 1.0 - (1.0 - cosOutside * cosOutside) / (eta * eta);
        if (cos2Inside <= 0.0) return 0.0;
        return (1.0 - dielectricFresnel(cosOutside, eta)) *
               std::exp(-thickness / std::sqrt(cos2Inside));
    }
    // The directional albedo seen from an outside cosine: R + T tau rho a visits. The outside
    // solid angle of the exit maps to mu' with eta^2 mu' dmu' = mu dmu, cancelling radiance's
    // eta^2.
    double albedo(double cosO) const {
        return dielectricFresnel(cosO, eta) + crossing(cosO) * rho * a * visits();
    }
    // E[f(wo, wi)] for radiance, both above: in at wo (divided by eta^2), the base's rho / pi,
    // out at wi, each visit of the base looking toward wi's refracted direction.
    double meanF(double cosO, double cosI) const {
        return crossing(cosO) / (eta * eta) * rho / M_PI * crossing(cosI) * visits();
    }
};

} // namespace cbtest
