/* cb_medium.h - pbrt-v4's "homogeneous" media behind the boundaries its MediumInterface names
 * (CB_FEATURE_MEDIUM, docs/pbrt-v4.md "Media"): media that absorb, and under
 * CB_FEATURE_SCATTERING media that scatter too, by the Henyey-Greenstein phase function
 * (phaseHenyeyGreenstein, cb_sampling.h).
 *
 * A medium is the index in `spectra` of three consecutive entries (per unit of world length,
 * pbrt-v4's "scale" folded in): sigma_t = sigma_a + sigma_s, sigma_s, and the phase function's
 * asymmetry g in every channel; -1 is vacuum. A material carries the medium on each side of its
 * surface (Material.mediumInside, mediumOutside: pbrt-v4's interface of the shape, the outside
 * the one its geometric normal points into). A ray travels in one medium from vertex to vertex:
 * through an absorbing one it arrives with Beer-Lambert's transmittance exp(-sigma_t d) per
 * channel, the expectation of pbrt-v4's ratio tracking; in a scattering one a distance is sampled
 * (mediumSampleDistance) and the path may scatter before the surface. */
#ifndef CB_MEDIUM_H
#define CB_MEDIUM_H

#include "cb_sampling.h"
#include "cb_spectrum.h"
#include "cb_types.h"

CB_BEGIN_NAMESPACE

/* The entries of a medium after its sigma_t (cb_medium.h's layout). */
#define CB_MEDIUM_SIGMA_S 1
#define CB_MEDIUM_ASYMMETRY 2
#define CB_MEDIUM_ENTRIES 3

/* The medium a ray in unit direction w enters leaving a surface of `material` whose geometric
 * normal is ng, `current` being the one the surface sits in: a surface with the same medium on
 * both sides (pbrt-v4's IsMediumTransition false, every surface outside MediumInterface) keeps
 * it; a boundary gives the side w points to (pbrt-v4's Interaction::GetMedium). */
CB_FN int mediumLeaving(const SceneView* scene, int material, Vec3 ng, Vec3 w, int current) {
#if CB_HAS(CB_FEATURE_MEDIUM)
    if (material < 0) return current;
    CB_GLOBAL const Material* m = &scene->materials[material];
    if (m->mediumInside == m->mediumOutside) return current;
    return vdot(w, ng) > 0.0f ? m->mediumOutside : m->mediumInside;
#else
    (void)scene;
    (void)material;
    (void)ng;
    (void)w;
    return current;
#endif
}

/* The fraction of each channel that crosses `distance` (CB_INFINITY: to a light at infinity)
 * of `medium`: exp(-sigma_t distance), 1 in vacuum and where sigma_t is 0. */
CB_FN Spectrum mediumTransmittance(const SceneView* scene, int medium, real distance) {
    Spectrum t = specConst(1.0f);
#if CB_HAS(CB_FEATURE_MEDIUM)
    if (medium < 0) return t;
    for (int i = 0; i < CB_CHANNELS; ++i) {
        real sigma = scene->spectra[medium * CB_CHANNELS + i];
        if (sigma > 0.0f) t.c[i] = distance < CB_INFINITY ? exp(-sigma * distance) : 0.0f;
    }
#else
    (void)scene;
    (void)medium;
    (void)distance;
#endif
    return t;
}

#if CB_HAS(CB_FEATURE_SCATTERING)
/* Whether a ray in `medium` may scatter: some channel's sigma_s above 0. */
CB_FN bool mediumScatters(const SceneView* scene, int medium) {
    if (medium < 0) return false;
    CB_GLOBAL const real* sigmaS = &scene->spectra[(medium + CB_MEDIUM_SIGMA_S) * CB_CHANNELS];
    real largest = 0.0f;
    for (int i = 0; i < CB_CHANNELS; ++i)
        largest = fmax(largest, sigmaS[i]);
    return largest > 0.0f;
}

CB_FN real mediumAsymmetry(const SceneView* scene, int medium) {
    return scene->spectra[(medium + CB_MEDIUM_ASYMMETRY) * CB_CHANNELS];
}

/* Where a ray of unit direction in a scattering `medium`, carrying `throughput`, first
 * interacts before the surface at tMax (CB_INFINITY: none), and the factor its throughput takes.
 * The distance follows one channel's exp(-sigma_t t), the channel drawn by uChannel with
 * probability proportional to its throughput, the distance by uDistance; the factor divides by
 * the mixture's pdf (one-sample MIS with the balance heuristic, Veach 1997 9.2.4; spectral
 * tracking's channel choice as Wrenninge et al. 2017 and Cycles weigh it). Scattering at t:
 * sigma_s T(t) / sum_k p_k sigma_t,k T_k(t); passing to tMax: T(tMax) / sum_k p_k T_k(tMax).
 * Weighed by the throughput, the factor never raises the throughput's sum (each channel's new
 * throughput is at most the old sum times its albedo), so that long paths in a coloured medium
 * do not grow heavy-tailed weights, as uniform choices do (a factor up to the channel count at
 * every vertex). Both are computed relative to the smallest sigma_t's transmittance, which
 * cancels, so that a long distance underflows no ratio to 0 / 0. Returns whether the ray
 * scattered, at *t; a throughput of 0 gets the factor 0. */
CB_FN bool mediumSampleDistance(const SceneView* scene, int medium, Spectrum throughput, real tMax,
                                real uChannel, real uDistance, real* t, Spectrum* weight) {
    CB_GLOBAL const real* sigmaT = &scene->spectra[medium * CB_CHANNELS];
    CB_GLOBAL const real* sigmaS = &scene->spectra[(medium + CB_MEDIUM_SIGMA_S) * CB_CHANNELS];
    real total = 0.0f;
    for (int i = 0; i < CB_CHANNELS; ++i)
        total += fmax(throughput.c[i], 0.0f);
    if (!(total > 0.0f) || !isfinite(total)) {
        *t = tMax;
        *weight = specZero();
        return false;
    }
    /* The channel whose share of the throughput holds uChannel; where rounding leaves it past
     * every share, the last channel with one. */
    int channel = -1, lastWithShare = 0;
    real below = 0.0f, target = uChannel * total;
    for (int i = 0; i < CB_CHANNELS; ++i) {
        real share = fmax(throughput.c[i], 0.0f);
        if (share > 0.0f) lastWithShare = i;
        if (channel < 0 && share > 0.0f && below + share > target) channel = i;
        below += share;
    }
    if (channel < 0) channel = lastWithShare;
    real sigma = sigmaT[channel];
    /* -log(1 - u) / sigma: 1 - u is in (0, 1], so the distance is finite where sigma > 0. */
    real distance = sigma > 0.0f ? -log(1.0f - uDistance) / sigma : CB_INFINITY;
    bool scattered = distance < tMax;
    real d = scattered ? distance : tMax;
    real smallest = sigmaT[0];
    for (int i = 1; i < CB_CHANNELS; ++i)
        smallest = fmin(smallest, sigmaT[i]);
    Spectrum w;
    real pdf = 0.0f;
    for (int i = 0; i < CB_CHANNELS; ++i) {
        real excess = sigmaT[i] - smallest;
        real relative = d < CB_INFINITY ? exp(-excess * d) : (excess > 0.0f ? 0.0f : 1.0f);
        w.c[i] = scattered ? sigmaS[i] * relative : relative;
        pdf += fmax(throughput.c[i], 0.0f) * (scattered ? sigmaT[i] * relative : relative);
    }
    *t = d;
    *weight = pdf > 0.0f ? specScale(w, total / pdf) : specZero();
    return scattered;
}
#endif

CB_END_NAMESPACE

#endif /* CB_MEDIUM_H */
