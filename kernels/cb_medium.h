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
 * (mediumSampleDistance) and the path may scatter before the surface. Under
 * CB_FEATURE_GRID_MEDIUM a medium's coefficients may vary over a grid (pbrt-v4's "uniformgrid":
 * mediumGrid below), where the same formulas hold with the segment's length replaced by the
 * integral of the density along it. */
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

#if CB_HAS(CB_FEATURE_GRID_MEDIUM)
/* pbrt-v4's "uniformgrid" medium (GridMedium): its sigma_a and sigma_s times a density that is
 * trilinear between nx x ny x nz samples over a box of the medium's space and 0 outside it. In a
 * scene with one, every medium's three entries are followed by CB_GRID_HEADER floats: nx, ny, nz
 * (0: the medium is homogeneous), the 3 x 4 affine map from the kernels' coordinates to the
 * samples' (pbrt-v4's SampledGrid::Lookup: the point's offset in the box times n, minus 0.5, so
 * that sample (i, j, k) sits at (i, j, k)) and the clip (CB_GRID_CLIP); then the nx ny nz
 * densities, x fastest; the whole padded to entries (addMediumGrid, src/scene/device_scene.cpp).
 * Along a ray the density is a cubic in t within each cell of the samples' lattice, so a segment's
 * integral of it is exact (two-point Gauss-Legendre per cell), and so is the distance at which it
 * reaches a given value (Newton's method within the cell): distances are sampled by inverting the
 * exact transmittance, from the one number a homogeneous medium uses, where pbrt-v4 draws null
 * collisions against a majorant (delta tracking). */
#define CB_GRID_HEADER 16
#define CB_GRID_MAP 3
/* The header's last float: how far inside the box of the samples' cells the density ends, in
 * samples (0 for pbrt-v4's uniformgrid; 0.5 for its nanovdb media, which it clips to the grid's
 * world bounds: the first and last samples). */
#define CB_GRID_CLIP 15

/* The offset in `spectra` of medium's grid header, -1 where the medium is homogeneous. */
CB_FN int mediumGrid(const SceneView* scene, int medium) {
    if (!CB_SCENE_HAS(scene, CB_FEATURE_GRID_MEDIUM) || medium < 0) return -1;
    int header = (medium + CB_MEDIUM_ENTRIES) * CB_CHANNELS;
    return scene->spectra[header] > 0.0f ? header : -1;
}

/* A cell of the samples' lattice that a ray crosses: its eight samples (x fastest), its lowest
 * corner, and the ray in sample coordinates, origin a and direction v. */
typedef struct GridCell {
    real sample[8];
    real corner[3];
    real a[3];
    real v[3];
} GridCell;

/* The density at t along the ray in `cell`, trilinear in pbrt-v4's order of lerps. */
CB_FN real gridCellDensity(const GridCell* cell, real t) {
    real f[3];
    for (int i = 0; i < 3; ++i)
        f[i] = cbClamp(cell->a[i] + cell->v[i] * t - cell->corner[i], 0.0f, 1.0f);
    const real* s = cell->sample;
    real d00 = cbLerp(f[0], s[0], s[1]), d10 = cbLerp(f[0], s[2], s[3]);
    real d01 = cbLerp(f[0], s[4], s[5]), d11 = cbLerp(f[0], s[6], s[7]);
    return cbLerp(f[2], cbLerp(f[1], d00, d10), cbLerp(f[1], d01, d11));
}

/* The density's integral over [ta, tb] in `cell`: a cubic's, exact by two-point Gauss-Legendre. */
CB_FN real gridCellIntegral(const GridCell* cell, real ta, real tb) {
    real halfWidth = 0.5f * (tb - ta), mid = 0.5f * (ta + tb);
    real offset = halfWidth * 0.57735026918962576f; /* 1 / sqrt(3) */
    return halfWidth * (gridCellDensity(cell, mid - offset) + gridCellDensity(cell, mid + offset));
}

/* Where in [ta, tb] the density's integral from ta reaches `remaining` (at most the cell's
 * integral): Newton's method on the monotone integral, kept within a shrinking bracket. */
CB_FN real gridCellInvert(const GridCell* cell, real ta, real tb, real remaining, real whole) {
    real lo = ta, hi = tb;
    real x = whole > 0.0f ? ta + (tb - ta) * (remaining / whole) : ta;
    for (int iteration = 0; iteration < 32; ++iteration) {
        real g = gridCellIntegral(cell, ta, x) - remaining;
        if (g > 0.0f)
            hi = x;
        else
            lo = x;
        if (fabs(g) <= 1e-6f * whole) break;
        real density = gridCellDensity(cell, x);
        real next = density > 0.0f ? x - g / density : 0.5f * (lo + hi);
        if (!(next > lo && next < hi)) next = 0.5f * (lo + hi);
        if (!(hi - lo > 1e-7f * (tb - ta))) break;
        x = next;
    }
    return x;
}

/* The integral of the density of the grid at `grid` (mediumGrid) along o + t dir (dir of unit
 * length), t from 0 to tMax (CB_INFINITY: to the grid's end), into *length; where it reaches
 * `target` (CB_INFINITY: nowhere) first, *length is target, *t where it does, and the result
 * true. Cells are walked in order (Amanatides and Woo's traversal), within the box of the
 * samples' cells. */
CB_FN bool gridDensityWalk(const SceneView* scene, int grid, Vec3 o, Vec3 dir, real tMax,
                           real target, real* length, real* t) {
    CB_GLOBAL const real* header = &scene->spectra[grid];
    CB_GLOBAL const real* densities = header + CB_GRID_HEADER;
    CB_GLOBAL const real* m = header + CB_GRID_MAP;
    int n[3] = {(int)header[0], (int)header[1], (int)header[2]};
    real clip = header[CB_GRID_CLIP];
    GridCell cell;
    real t0 = 0.0f, t1 = tMax;
    for (int i = 0; i < 3; ++i) {
        cell.a[i] = m[4 * i] * o.x + m[4 * i + 1] * o.y + m[4 * i + 2] * o.z + m[4 * i + 3];
        cell.v[i] = m[4 * i] * dir.x + m[4 * i + 1] * dir.y + m[4 * i + 2] * dir.z;
        real lo = -0.5f + clip, hi = (real)n[i] - 0.5f - clip;
        if (cell.v[i] == 0.0f) {
            if (cell.a[i] < lo || cell.a[i] > hi) t1 = -1.0f;
        } else {
            real ta = (lo - cell.a[i]) / cell.v[i], tb = (hi - cell.a[i]) / cell.v[i];
            t0 = fmax(t0, fmin(ta, tb));
            t1 = fmin(t1, fmax(ta, tb));
        }
    }
    *length = 0.0f;
    *t = tMax;
    if (!(t0 < t1)) return false;
    int index[3], step[3];
    real next[3], delta[3];
    for (int i = 0; i < 3; ++i) {
        index[i] = (int)cbClamp(floor(cell.a[i] + cell.v[i] * t0), -1.0f, (real)(n[i] - 1));
        step[i] = cell.v[i] > 0.0f ? 1 : -1;
        delta[i] = cell.v[i] != 0.0f ? fabs(1.0f / cell.v[i]) : CB_INFINITY;
        next[i] = cell.v[i] > 0.0f   ? ((real)(index[i] + 1) - cell.a[i]) / cell.v[i]
                  : cell.v[i] < 0.0f ? ((real)index[i] - cell.a[i]) / cell.v[i]
                                     : CB_INFINITY;
    }
    real enter = t0;
    for (int cells = n[0] + n[1] + n[2] + 3; cells > 0; --cells) {
        int axis = next[0] < next[1] ? (next[0] < next[2] ? 0 : 2) : (next[1] < next[2] ? 1 : 2);
        real exit = fmin(next[axis], t1);
        if (exit > enter) {
            for (int corner = 0; corner < 8; ++corner) {
                int x = index[0] + (corner & 1), y = index[1] + ((corner >> 1) & 1),
                    z = index[2] + (corner >> 2);
                cell.sample[corner] = x >= 0 && y >= 0 && z >= 0 && x < n[0] && y < n[1] && z < n[2]
                                          ? densities[(z * n[1] + y) * n[0] + x]
                                          : 0.0f;
            }
            for (int i = 0; i < 3; ++i)
                cell.corner[i] = (real)index[i];
            real integral = gridCellIntegral(&cell, enter, exit);
            if (*length + integral >= target) {
                *t = gridCellInvert(&cell, enter, exit, target - *length, integral);
                *length = target;
                return true;
            }
            *length += integral;
        }
        if (!(next[axis] < t1)) break;
        enter = exit;
        index[axis] += step[axis];
        if (index[axis] < -1 || index[axis] > n[axis] - 1) break;
        next[axis] += delta[axis];
    }
    return false;
}
#endif

/* The fraction of each channel that crosses `distance` (CB_INFINITY: to a light at infinity)
 * of `medium` from o in unit direction dir: exp(-sigma_t distance), 1 in vacuum and where sigma_t
 * is 0; in a grid medium the distance is the density's integral along the way. */
CB_FN Spectrum mediumTransmittance(const SceneView* scene, int medium, Vec3 o, Vec3 dir,
                                   real distance) {
    Spectrum t = specConst(1.0f);
#if CB_HAS(CB_FEATURE_MEDIUM)
    if (medium < 0) return t;
#if CB_HAS(CB_FEATURE_GRID_MEDIUM)
    int grid = mediumGrid(scene, medium);
    if (grid >= 0) {
        real length, unused;
        gridDensityWalk(scene, grid, o, dir, distance, CB_INFINITY, &length, &unused);
        for (int i = 0; i < CB_CHANNELS; ++i)
            t.c[i] = exp(-scene->spectra[medium * CB_CHANNELS + i] * length);
        return t;
    }
#endif
    (void)o;
    (void)dir;
    for (int i = 0; i < CB_CHANNELS; ++i) {
        real sigma = scene->spectra[medium * CB_CHANNELS + i];
        if (sigma > 0.0f) t.c[i] = distance < CB_INFINITY ? exp(-sigma * distance) : 0.0f;
    }
#else
    (void)scene;
    (void)medium;
    (void)o;
    (void)dir;
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
 * In a grid medium (mediumGrid) the segment, from o in unit direction dir, is as long as the
 * density's integral along it, and the density at the scattering point cancels. Returns whether
 * the ray scattered, at *t; a throughput of 0 gets the factor 0. */
CB_FN bool mediumTrackSegment(const SceneView* scene, int medium, Spectrum throughput, int channel,
                              real* depth, Vec3 o, Vec3 dir, real tMax, real* t, Spectrum* weight) {
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
    bool scattered;
    real d; /* the segment's length, in a grid medium its density's integral */
#if CB_HAS(CB_FEATURE_GRID_MEDIUM)
    int grid = mediumGrid(scene, medium);
    if (grid >= 0) {
        scattered = gridDensityWalk(scene, grid, o, dir, tMax, distance, &d, t);
    } else
#endif
    {
        (void)o;
        (void)dir;
        scattered = distance < tMax;
        d = scattered ? distance : tMax;
        *t = d;
    }
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
    *weight = pdf > 0.0f ? specScale(w, total / pdf) : specZero();
    return scattered;
}

/* Where a ray of unit direction in a scattering `medium`, carrying `throughput`, first
 * interacts before the surface at tMax (CB_INFINITY: none), and the factor its throughput takes
 * (mediumTrackSegment): the channel drawn by uChannel (mediumTrackChannel), the distance by
 * uDistance, an optical depth -log(1 - u), finite since 1 - u is in (0, 1]. The ray leaves o in
 * direction dir. Returns whether the ray scattered, at *t. */
CB_FN bool mediumSampleDistance(const SceneView* scene, int medium, Spectrum throughput, Vec3 o,
                                Vec3 dir, real tMax, real uChannel, real uDistance, real* t,
                                Spectrum* weight) {
    int channel = mediumTrackChannel(throughput, uChannel);
    if (channel < 0) {
        *t = tMax;
        *weight = specZero();
        return false;
    }
    real depth = -log(1.0f - uDistance);
    return mediumTrackSegment(scene, medium, throughput, channel, &depth, o, dir, tMax, t, weight);
}
#endif

#if CB_HAS(CB_FEATURE_MEDIUM)
/* The segment of a ray of unit direction dir from its origin o to the surface it found at tMax
 * (CB_INFINITY: none) through track->medium: Beer-Lambert's transmittance where the medium only
 * absorbs, unless the ray already samples a distance; where it scatters (and in any medium
 * after that) the distance sampled (mediumTrackSegment), the ray's channel and optical depth
 * drawn from the pair of dimensions `dimension` of `stream` where its first such segment
 * starts. *throughput takes the factor. Returns 1 where the ray scattered, at *t, -1 where the
 * sampling left the throughput black, 0 where the ray reached tMax. */
CB_FN int mediumRaySegment(const SceneView* scene, MediumTrack* track, Spectrum* throughput,
                           SampleStream stream, uint dimension, Vec3 o, Vec3 dir, real tMax,
                           real* t) {
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
                                            &track->depth, o, dir, tMax, t, &weight);
        *throughput = specMul(*throughput, weight);
        if (specIsBlack(*throughput)) return -1;
        return scattered ? 1 : 0;
    }
#else
    (void)stream;
    (void)dimension;
#endif
    *throughput = specMul(*throughput, mediumTransmittance(scene, track->medium, o, dir, tMax));
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
            return specMul(tr, mediumTransmittance(scene, medium, ray.o, ray.d,
                                                   toInfinity ? CB_INFINITY : fmax(tMax, 0.0f)));
        /* Blocked before any shading work: an interface is never a mix's part, so the
         * primitive's own material tells. */
        if (!materialIsInterface(scene, scene->primitives[hit.primitive].material))
            return specZero();
        SurfacePoint sp = surfacePointFromHit(scene, ray, hit);
        tr = specMul(tr, mediumTransmittance(scene, medium, ray.o, ray.d, hit.t));
        medium = mediumLeaving(scene, sp.material, sp.ng, ray.d, medium);
        ray = spawnRay(sp, ray.d);
        tMax = vdot(vsub(end, ray.o), ray.d);
    }
    return specZero();
}
#endif

CB_END_NAMESPACE

#endif /* CB_MEDIUM_H */
