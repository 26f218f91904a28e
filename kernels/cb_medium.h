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

#include "cb_bvh_wide.h"
#include "cb_rng.h"
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

/* Whether a ray's way through media carries more than its medium: a distance sampled in a
 * scattering medium, interfaces crossed. Without either a MediumTrack is its medium alone, so that
 * CPT's packets copy no more per path than before (PtPath, CB_PT_PATH_BYTES). */
#define CB_HAS_MEDIUM_TRACK (CB_HAS(CB_FEATURE_SCATTERING) || CB_HAS(CB_FEATURE_INTERFACE))

/* A ray's way through media from the vertex it leaves to the next one (pbrt-v4's Ray::medium): the
 * medium it travels in now, and the distance sampling it carries across the interfaces it crosses
 * (mediumRaySegment): its channel (-1: none drawn yet) and the optical depth left in it; how many
 * interfaces it crossed (mediumCrossInterface). Four-byte members only (PtPath keeps one). */
typedef struct MediumTrack {
    int medium;
#if CB_HAS_MEDIUM_TRACK
    int channel;
    real depth;
    int crossings;
#endif
} MediumTrack;
/* MediumTrack's size in 4-byte words where `tracked` (CB_HAS_MEDIUM_TRACK). */
#define CB_MEDIUM_TRACK_WORDS(tracked) ((tracked) ? 4 : 1)

/* A ray leaving a vertex in `medium`, no distance drawn. */
CB_FN MediumTrack mediumTrackStart(int medium) {
    MediumTrack track;
    track.medium = medium;
#if CB_HAS_MEDIUM_TRACK
    track.channel = -1;
    track.depth = 0.0f;
    track.crossings = 0;
#endif
    return track;
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

/* The channel whose share of `throughput` holds u, each channel's share its throughput (clamped
 * at 0): where rounding leaves u past every share, the last channel with one; -1 where no channel
 * has one or the sum is not finite. */
CB_FN int mediumTrackChannel(Spectrum throughput, real u) {
    real total = 0.0f;
    for (int i = 0; i < CB_CHANNELS; ++i)
        total += fmax(throughput.c[i], 0.0f);
    if (!(total > 0.0f) || !isfinite(total)) return -1;
    int channel = -1, lastWithShare = 0;
    real below = 0.0f, target = u * total;
    for (int i = 0; i < CB_CHANNELS; ++i) {
        real share = fmax(throughput.c[i], 0.0f);
        if (share > 0.0f) lastWithShare = i;
        if (channel < 0 && share > 0.0f && below + share > target) channel = i;
        below += share;
    }
    return channel < 0 ? lastWithShare : channel;
}

/* One homogeneous segment, up to tMax (CB_INFINITY: none), of a ray of unit direction in
 * `medium`, carrying `throughput`, whose distance follows channel `channel`'s exp(-sigma_t t):
 * *depth is the optical depth in that channel left to travel before the ray interacts, and on
 * passing to tMax it loses the segment's. Scattering at t: sigma_s T(t) / sum_k p_k sigma_t,k
 * T_k(t); passing: T(tMax) / sum_k p_k T_k(tMax), p_k the channels' shares of the throughput
 * (mediumTrackChannel; one-sample MIS with the balance heuristic, Veach 1997 9.2.4; spectral
 * tracking's channel choice as Wrenninge et al. 2017 and Cycles weigh it). Weighed by the
 * throughput, the factor never raises the throughput's sum (each channel's new throughput is at
 * most the old sum times its albedo), so that long paths in a coloured medium do not grow
 * heavy-tailed weights, as uniform choices do (a factor up to the channel count at every vertex).
 * Both are computed relative to the smallest sigma_t's transmittance, which cancels, so that a
 * long distance underflows no ratio to 0 / 0. A ray that crosses interfaces keeps its channel
 * and depth from segment to segment: after passing, the throughput's shares are the channel's
 * probabilities given that it passed, and the depth left is again exponential (memoryless), so
 * the segments' factors multiply to the whole ray's (its mixture over the media it crosses).
 * Returns whether the ray scattered, at *t; a throughput of 0 gets the factor 0. */
CB_FN bool mediumTrackSegment(const SceneView* scene, int medium, Spectrum throughput, int channel,
                              real* depth, real tMax, real* t, Spectrum* weight) {
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
    real sigma = sigmaT[channel];
    real distance = sigma > 0.0f ? *depth / sigma : CB_INFINITY;
    bool scattered = distance < tMax;
    real d = scattered ? distance : tMax;
    if (!scattered && d < CB_INFINITY) *depth = fmax(*depth - sigma * d, 0.0f);
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

/* Where a ray of unit direction in a scattering `medium`, carrying `throughput`, first
 * interacts before the surface at tMax (CB_INFINITY: none), and the factor its throughput takes
 * (mediumTrackSegment): the channel drawn by uChannel (mediumTrackChannel), the distance by
 * uDistance, an optical depth -log(1 - u), finite since 1 - u is in (0, 1]. Returns whether the
 * ray scattered, at *t. */
CB_FN bool mediumSampleDistance(const SceneView* scene, int medium, Spectrum throughput, real tMax,
                                real uChannel, real uDistance, real* t, Spectrum* weight) {
    int channel = mediumTrackChannel(throughput, uChannel);
    if (channel < 0) {
        *t = tMax;
        *weight = specZero();
        return false;
    }
    real depth = -log(1.0f - uDistance);
    return mediumTrackSegment(scene, medium, throughput, channel, &depth, tMax, t, weight);
}
#endif

#if CB_HAS(CB_FEATURE_MEDIUM)
/* The segment of a ray of unit direction from its origin to the surface it found at tMax
 * (CB_INFINITY: none) through track->medium: Beer-Lambert's transmittance where the medium only
 * absorbs, unless the ray already samples a distance; where it scatters (and in any medium
 * after that) the distance sampled (mediumTrackSegment), the ray's channel and optical depth
 * drawn from the pair of dimensions `dimension` of `stream` where its first such segment
 * starts. *throughput takes the factor. Returns 1 where the ray scattered, at *t, -1 where the
 * sampling left the throughput black, 0 where the ray reached tMax. */
CB_FN int mediumRaySegment(const SceneView* scene, MediumTrack* track, Spectrum* throughput,
                           SampleStream stream, uint dimension, real tMax, real* t) {
    *t = tMax;
#if CB_HAS(CB_FEATURE_SCATTERING)
    if (track->channel >= 0 || mediumScatters(scene, track->medium)) {
        /* Vacuum between two media: nothing to sample, the depth left kept for the next. */
        if (track->medium < 0) return 0;
        if (track->channel < 0) {
            real uChannel, uDistance;
            sampleAt2(stream, dimension, &uChannel, &uDistance);
            track->channel = mediumTrackChannel(*throughput, uChannel);
            if (track->channel < 0) {
                *throughput = specZero();
                return -1;
            }
            track->depth = -log(1.0f - uDistance);
        }
        Spectrum weight;
        bool scattered = mediumTrackSegment(scene, track->medium, *throughput, track->channel,
                                            &track->depth, tMax, t, &weight);
        *throughput = specMul(*throughput, weight);
        if (specIsBlack(*throughput)) return -1;
        return scattered ? 1 : 0;
    }
#else
    (void)stream;
    (void)dimension;
#endif
    *throughput = specMul(*throughput, mediumTransmittance(scene, track->medium, tMax));
    return 0;
}
#endif

#if CB_HAS(CB_FEATURE_INTERFACE)
/* The most interfaces a ray crosses between two vertices: a guard against a ray caught between
 * surfaces by rounding (the path, or the shadow ray, ends there; no test scene comes near it). */
#define CB_MAX_INTERFACE_CROSSINGS 64

CB_FN bool materialIsInterface(const SceneView* scene, int material) {
    return material >= 0 && scene->materials[material].kind == CB_MAT_INTERFACE;
}

/* *ray found sp on an interface: it goes on from there in its direction, in the medium on the
 * side it leaves to, its distance sampling carried over (pbrt-v4's SkipIntersection). False
 * after CB_MAX_INTERFACE_CROSSINGS. */
CB_FN bool mediumCrossInterface(const SceneView* scene, SurfacePoint sp, Ray* ray,
                                MediumTrack* track) {
    if (++track->crossings > CB_MAX_INTERFACE_CROSSINGS) return false;
    track->medium = mediumLeaving(scene, sp.material, sp.ng, ray->d, track->medium);
    *ray = spawnRay(sp, ray->d);
    return true;
}

/* The fraction of each channel that arrives along a shadow ray (unit direction, free up to
 * tMax; toInfinity: it ends at a light at infinity) that leaves in `medium`: the product of its
 * segments' Beer-Lambert factors between the interfaces it crosses, 0 where any other surface
 * blocks it (pbrt-v4's Integrator::Tr, whose ratio tracking has this expectation in homogeneous
 * media). */
CB_FN Spectrum sceneTransmittance(const SceneView* scene, Ray ray, real tMax, bool toInfinity,
                                  int medium) {
    Spectrum tr = specConst(1.0f);
    Vec3 end = vmadd(ray.o, ray.d, tMax);
    for (int crossings = 0; crossings <= CB_MAX_INTERFACE_CROSSINGS; ++crossings) {
        Hit hit;
        if (!(tMax > 0.0f) || !sceneIntersect(scene, ray, tMax, &hit))
            return specMul(tr, mediumTransmittance(scene, medium,
                                                   toInfinity ? CB_INFINITY : fmax(tMax, 0.0f)));
        /* Blocked before any shading work: an interface is never a mix's part, so the
         * primitive's own material tells. */
        if (!materialIsInterface(scene, scene->primitives[hit.primitive].material))
            return specZero();
        SurfacePoint sp = surfacePointFromHit(scene, ray, hit);
        tr = specMul(tr, mediumTransmittance(scene, medium, hit.t));
        medium = mediumLeaving(scene, sp.material, sp.ng, ray.d, medium);
        ray = spawnRay(sp, ray.d);
        tMax = vdot(vsub(end, ray.o), ray.d);
    }
    return specZero();
}
#endif

CB_END_NAMESPACE

#endif /* CB_MEDIUM_H */
