/* cb_medium.h - absorbing media: pbrt-v4's "homogeneous" media of sigma_s = 0 behind the
 * boundaries its MediumInterface names (CB_FEATURE_MEDIUM, docs/pbrt-v4.md "Absorbing media").
 *
 * A medium is the index in `spectra` of its absorption coefficient sigma_a (per unit of world
 * length, pbrt-v4's "scale" folded in); -1 is vacuum. A material carries the medium on each
 * side of its surface (Material.mediumInside, mediumOutside: pbrt-v4's interface of the shape,
 * the outside the one its geometric normal points into). A ray travels in one medium from vertex
 * to vertex and arrives with Beer-Lambert's transmittance exp(-sigma_a d) per channel, the
 * expectation of pbrt-v4's ratio tracking in a medium that does not scatter. */
#ifndef CB_MEDIUM_H
#define CB_MEDIUM_H

#include "cb_spectrum.h"
#include "cb_types.h"

CB_BEGIN_NAMESPACE

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
 * of `medium`: exp(-sigma_a distance), 1 in vacuum and where sigma_a is 0. */
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

CB_END_NAMESPACE

#endif /* CB_MEDIUM_H */
