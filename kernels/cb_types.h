/* cb_types.h - the scene as the kernels see it: plain structs copied to the device as bytes.
 *
 * Layout rules: only real/int/uint fields and arrays of them, every struct a multiple of
 * 16 bytes, asserted on the host (src/scene/device_scene.cpp). */
#ifndef CB_TYPES_H
#define CB_TYPES_H

#include "cb_common.h"

CB_BEGIN_NAMESPACE

/* ---- Geometry ----------------------------------------------------------------------------- */

#define CB_PRIM_TRIANGLE 0
#define CB_PRIM_SPHERE 1
/* A triangle whose hits count only where its material's alpha test keeps them (pbrt-v4's shape
 * "alpha", CB_FEATURE_ALPHA): in packs of their own (`alphaTested`). */
#define CB_PRIM_ALPHA_TRIANGLE 2
/* A piece of one of pbrt-v4's curves (CB_FEATURE_CURVES): p0 and p1 its bounding box's corners,
 * p2[0] its index in the scene's `curves` (CurveSegment, cb_curve.h). */
#define CB_PRIM_CURVE 3

/* One primitive of the BVH. Triangle: world-space vertices p0, p1, p2 (counter-clockwise seen
 * from the side the geometric normal cross(p1-p0, p2-p0) points to). Sphere: centre p0, radius
 * p1[0]; p1[1] is +1 for outward normals and -1 when the orientation is reversed. */
typedef struct Primitive {
    real p0[3];
    int kind; /* CB_PRIM_* */
    real p1[3];
    int material; /* index into materials */
    real p2[3];
    int light; /* index into lights if this primitive is an area emitter, else -1 */
} Primitive;

/* Up to four primitives of one BVH leaf, in lanes [0, count): prim[lane]. A pack holds either
 * triangles only, their vertices copied in structure-of-arrays form (v[0], v[1], v[2] = p0,
 * p1, p2) so that one test covers all of them with the same instructions on every lane
 * (Embree's triangle4), or, with `scalar` set, other primitives (spheres), tested one by one.
 * Lanes from `count` on repeat lane 0, so that every lane can be tested without a mask. */
#define CB_PACK_LANES 4
typedef struct TrianglePack {
    real v[3][3][CB_PACK_LANES]; /* [vertex][axis][lane] */
    int prim[CB_PACK_LANES];
    int count;
    int scalar;
    int alphaTested; /* its triangles are CB_PRIM_ALPHA_TRIANGLE: each hit asks alphaKeepsHit */
    int pad;
} TrianglePack;

CB_STATIC_ASSERT(sizeof(TrianglePack) == 176, "TrianglePack must be 176 bytes");

/* pbrt-v4's curve types: a flat ribbon that faces each ray, a ribbon oriented by normals given at
 * its ends, and a flat one whose normal turns across its width as a cylinder's would. */
#define CB_CURVE_FLAT 0
#define CB_CURVE_RIBBON 1
#define CB_CURVE_CYLINDER 2

/* One piece of a cubic Bezier curve of pbrt-v4 (its Curve: a CurveCommon's [uMin, uMax]),
 * in world space. cp: the piece's own control points (the curve's blossomed over [uMin, uMax]);
 * width: the whole curve's at u = 0 and 1; n: a ribbon's unit normals at u = 0 and 1, turned
 * between them by spherical interpolation over normalAngle; mirrored: the CTM mirrors (the
 * kernels then find v and dp/dv as pbrt-v4 finds them in object space); reverse: pbrt-v4's
 * ReverseOrientation (the normal negated). */
typedef struct CurveSegment {
    real cp[4][3];
    real n[2][3];
    real width[2];
    real uMin, uMax;
    real normalAngle, invSinNormalAngle;
    int type; /* CB_CURVE_* */
    int mirrored;
    int reverse;
    int pad;
} CurveSegment;

CB_STATIC_ASSERT(sizeof(CurveSegment) == 112, "CurveSegment must be 112 bytes");

typedef struct Ray {
    Vec3 o;
    Vec3 d;
} Ray;

/* A closest hit: ray parameter, primitive, and the barycentrics (b1, b2) of p1 and p2 for a
 * triangle (unused for spheres). */
typedef struct Hit {
    real t;
    int primitive;
    real b1, b2;
} Hit;

/* ---- Materials ---------------------------------------------------------------------------- */

#define CB_MAT_DIFFUSE 0
#define CB_MAT_CONDUCTOR 1            /* perfect mirror (alpha == 0) or GGX rough mirror */
#define CB_MAT_DIELECTRIC 2           /* glass: smooth (alpha == 0) or GGX rough */
#define CB_MAT_MIX 3                  /* mixture of two materials: second with probability amount */
#define CB_MAT_DIFFUSE_TRANSMISSION 4 /* Lambertian reflection and transmission (pbrt-v4's) */
#define CB_MAT_THIN_DIELECTRIC 5      /* a thin glass sheet (pbrt-v4's "thindielectric") */
#define CB_MAT_COATED_DIFFUSE 6       /* Lambertian under a dielectric coat (pbrt-v4's) */
#define CB_MAT_COATED_CONDUCTOR 7     /* a conductor under a dielectric coat (pbrt-v4's) */
/* pbrt-v4's mix as one part per surface point, the second with probability amount (for parts
 * that cannot join a mixture: mixPartAtPoint, cb_intersect.h); hits find the part, never this. */
#define CB_MAT_MIX_AT_POINT 8
/* pbrt-v4's "interface": a boundary between media that scatters nothing; rays cross it without a
 * vertex (cb_medium.h, mediumCrossInterface). */
#define CB_MAT_INTERFACE 9
/* pbrt-v4's "hair": Chiang, Bitterli, Tappan and Burley 2016's hair BSDF (pbrt-v4's HairBxDF),
 * the surface's dp/du along the fibre and its v across it (cb_bsdf.h, hairEval). */
#define CB_MAT_HAIR 10

/* Feature bits: the scene's material kinds and light kinds, passed to the kernel build as
 * -DCB_FEATURES=... so that unused code is compiled out (each scene compiles only what it uses). */
#define CB_FEATURE_DIFFUSE (1u << 0)
#define CB_FEATURE_CONDUCTOR (1u << 1)
#define CB_FEATURE_DIELECTRIC (1u << 2)
#define CB_FEATURE_MIX (1u << 3)
#define CB_FEATURE_CONDUCTOR_FRESNEL (1u << 4) /* conductors given eta and k (pbrt-v4's) */
#define CB_FEATURE_ROUGH_DIELECTRIC (1u << 5)  /* dielectrics with a GGX roughness */
#define CB_FEATURE_DIFFUSE_TRANSMISSION (1u << 6)
#define CB_FEATURE_THIN_DIELECTRIC (1u << 7)
#define CB_FEATURE_AREA_LIGHT (1u << 8)
#define CB_FEATURE_POINT_LIGHT (1u << 9)
#define CB_FEATURE_SPHERES (1u << 10)
#define CB_FEATURE_SPOT_LIGHT (1u << 11)       /* point lights with a cone (pbrt-v4's "spot") */
#define CB_FEATURE_DISTANT_LIGHT (1u << 12)    /* pbrt-v4's "distant": a delta in direction */
#define CB_FEATURE_INFINITE_LIGHT (1u << 13)   /* pbrt-v4's "infinite" with a constant L */
#define CB_FEATURE_THIN_LENS (1u << 14)        /* a camera with a lens radius (depth of field) */
#define CB_FEATURE_COATED_DIFFUSE (1u << 15)   /* pbrt-v4's layered "coateddiffuse" */
#define CB_FEATURE_COATED_CONDUCTOR (1u << 16) /* pbrt-v4's layered "coatedconductor" */
#define CB_FEATURE_IMAGE_LIGHT (1u << 17) /* an "infinite" light given by an equal-area image */
#define CB_FEATURE_TEXTURE (1u << 18) /* a reflectance given by an image (pbrt-v4's "imagemap") */
#define CB_FEATURE_SHADING_NORMALS (1u << 19)   /* meshes with vertex normals (pbrt-v4's "N") */
#define CB_FEATURE_NORMAL_MAP (1u << 20)        /* materials with pbrt-v4's "normalmap" */
#define CB_FEATURE_ROUGHNESS_TEXTURE (1u << 21) /* a GGX roughness given by a float texture */
#define CB_FEATURE_PIXEL_FILTER (1u << 22)      /* any pixel filter but the box of radius 0.5 */
#define CB_FEATURE_ALPHA (1u << 23)             /* shapes with pbrt-v4's "alpha" (cut-outs) */
#define CB_FEATURE_BUMP_MAP (1u << 24)          /* materials with pbrt-v4's "displacement" */
#define CB_FEATURE_DISPERSION (1u << 25)        /* dielectrics with pbrt-v4's "spectrum eta" */
/* Textures mapped by the hit point: pbrt-v4's "spherical", "cylindrical" and "planar". */
#define CB_FEATURE_TEXTURE_MAPPING (1u << 26)
/* Area lights whose shape has alpha 0: sampled as lights, never found by a ray (pbrt-v4). */
#define CB_FEATURE_INVISIBLE_LIGHT (1u << 27)
/* Coats whose layer thickness is a float texture (pbrt-v4's "texture thickness"). */
#define CB_FEATURE_THICKNESS_TEXTURE (1u << 28)
/* Textures mixed by the normal's direction (pbrt-v4's "directionmix"). */
#define CB_FEATURE_DIRECTION_MIX (1u << 29)
/* Conductors or rough dielectrics of two roughnesses (pbrt-v4's "uroughness" != "vroughness"),
 * shaded in frames whose first axis is the surface's dp/du. */
#define CB_FEATURE_ANISOTROPIC (1u << 30)
/* Media behind surfaces (pbrt-v4's "homogeneous" media, cb_medium.h). */
#define CB_FEATURE_MEDIUM (1u << 31)
/* A film that clamps each sample (pbrt-v4's "maxcomponentvalue", filmClampSample). The bits from
 * 32 on are unsigned long: 64 bits in OpenCL C and on the host (LP64). */
#define CB_FEATURE_SAMPLE_CLAMP (1ul << 32)
/* pbrt-v4's procedural float textures "fbm", "wrinkled" and "windy" (cb_noise.h). */
#define CB_FEATURE_NOISE_TEXTURE (1ul << 33)
/* Mixes that pick one part per surface point (CB_MAT_MIX_AT_POINT). */
#define CB_FEATURE_MIX_AT_POINT (1ul << 34)
/* Media that scatter (pbrt-v4's "homogeneous" media of sigma_s above 0, cb_medium.h). */
#define CB_FEATURE_SCATTERING (1ul << 35)
/* Surfaces of pbrt-v4's "interface" material (CB_MAT_INTERFACE). */
#define CB_FEATURE_INTERFACE (1ul << 36)
/* Media whose coefficients vary over a grid (pbrt-v4's "uniformgrid", cb_medium.h). */
#define CB_FEATURE_GRID_MEDIUM (1ul << 37)
/* pbrt-v4's "hair" material (CB_MAT_HAIR), shaded in frames along dp/du (CB_FEATURE_ANISOTROPIC)
 * at the hit's (u, v) (CB_FEATURE_TEXTURE). */
#define CB_FEATURE_HAIR (1ul << 38)
/* pbrt-v4's "curve" shapes (CB_PRIM_CURVE, cb_curve.h). */
#define CB_FEATURE_CURVES (1ul << 39)

#ifndef CB_FEATURES
#define CB_FEATURES 0xfffffffffffffffful
#endif
#define CB_HAS(feature) ((CB_FEATURES & (feature)) != 0u)
/* Code shared by several kinds: the layered materials' random walk, the GGX reflection lobe and
 * the conductor Fresnel equations (a coated conductor's base uses both). */
#define CB_HAS_LAYERED (CB_HAS(CB_FEATURE_COATED_DIFFUSE) || CB_HAS(CB_FEATURE_COATED_CONDUCTOR))
#define CB_HAS_GGX_REFLECTION (CB_HAS(CB_FEATURE_CONDUCTOR) || CB_HAS(CB_FEATURE_COATED_CONDUCTOR))
#define CB_HAS_CONDUCTOR_FRESNEL                                                                   \
    (CB_HAS(CB_FEATURE_CONDUCTOR_FRESNEL) || CB_HAS(CB_FEATURE_COATED_CONDUCTOR))
/* Shading normals that can differ from the geometric ones: vertex normals, normal or bump maps. */
#define CB_HAS_SHADING                                                                             \
    (CB_HAS(CB_FEATURE_SHADING_NORMALS) || CB_HAS(CB_FEATURE_NORMAL_MAP) ||                        \
     CB_HAS(CB_FEATURE_BUMP_MAP))

/* Where a surface point's material is looked up: its texture coordinates (pbrt-v4's uv) and,
 * on paths that have met a dispersive dielectric (CB_FEATURE_DISPERSION), the one wavelength
 * they follow from there on, as a position over the bins: bin + fraction in [0, CB_CHANNELS)
 * (dispersionFollowOne, cb_bsdf.h); -1 where the path carries every bin. */
typedef struct TexCoord {
    real u, v;
    real hero;
#if CB_HAS(CB_FEATURE_TEXTURE_MAPPING)
    Vec3 p; /* the point itself (device space), for textures mapped by it (textureST) */
#endif
#if CB_HAS(CB_FEATURE_DIRECTION_MIX)
    Vec3 n; /* the unit geometric normal, for textures mixed by it (textureReflectance) */
#endif
} TexCoord;

/* Where a ray hit, with the error bound needed to spawn new rays without self-intersection
 * (pbrt-v4's conservative floating-point error bounds: no scene-scale epsilon). */
typedef struct SurfacePoint {
    Vec3 p;      /* the hit point */
    Vec3 pError; /* per-axis absolute bound on the error of p */
    Vec3 ng;     /* unit geometric normal (outward / front side) */
    /* Unit shading normal: CB_FEATURE_SHADING_NORMALS, the triangle's vertex normals interpolated
     * (ng faces its side, as pbrt-v4's FaceForward), then CB_FEATURE_NORMAL_MAP, bent by the
     * material's normal map (normalMapNormal); else ng. */
    Vec3 ns;
    int primitive;
    int material;
    int light;
    TexCoord uv; /* CB_FEATURE_TEXTURE: interpolated from the triangle's vertices; else 0 (hero
                  * -1: the caller sets it, dispersionFollowOne) */
#if CB_HAS(CB_FEATURE_ANISOTROPIC)
    /* The shape's dp/du, which surfaceFrame makes perpendicular to ns as the frame's first axis
     * (pbrt-v4's shading dpdu); 0 where the shape gives none or the material is isotropic
     * (materialTurnsWithTangent), and surfaceFrame then picks any. */
    Vec3 tangent;
#endif
} SurfacePoint;

typedef struct Material {
    int kind;        /* CB_MAT_* */
    int reflectance; /* index into the spectra table (CB_CHANNELS floats per entry) */
    real alpha;      /* GGX roughness alpha for conductors and dielectrics (0: smooth) */
    real eta;        /* relative index of refraction for (thin) dielectrics */
    /* CB_MAT_MIX and CB_MAT_MIX_AT_POINT: the two parts; only the second may be a mix of the
     * same kind (cbMixEval, mixPartAtPoint) */
    int mixFirst;
    int mixSecond;
    real mixAmount; /* probability of mixSecond */
    /* A second spectrum's index, -1 where there is none. CB_MAT_CONDUCTOR given eta and k: k's,
     * `reflectance` then holding eta's (CB_FEATURE_CONDUCTOR_FRESNEL; -1: `reflectance` is a
     * constant Fresnel tint). CB_MAT_DIFFUSE_TRANSMISSION: the transmittance. */
    int secondSpectrum;
    /* CB_MAT_COATED_DIFFUSE and CB_MAT_COATED_CONDUCTOR (`eta` and `alpha` the coat's;
     * `reflectance` the diffuse base's, or the conductor's eta with `secondSpectrum` its k, or,
     * where that is -1, its normal-incidence reflectance): the layer's thickness in mean free
     * paths, the random walk's longest path and its walks per estimate (pbrt-v4's "thickness",
     * "maxdepth", "nsamples"), the conductor base's GGX alpha (0: smooth), and the layer's
     * single-scattering albedo (a spectrum's index, -1 where it does not scatter) and its
     * Henyey-Greenstein asymmetry g ("albedo", "g"). */
    real thickness;
    int layerDepth;
    int layerSamples;
    real baseAlpha;
    int layerAlbedo;
    real layerG;
    /* CB_FEATURE_TEXTURE: the offset in `textures` of the image texture that gives the diffuse,
     * coated diffuse, diffuse transmission or coated conductor reflectance in place of
     * `reflectance` (a coated conductor's: its normal-incidence reflectance), and of the
     * one that gives the diffuse transmission's transmittance in place of `secondSpectrum`; -1:
     * none. A diffuse transmission's textures are times `textureScale` (pbrt-v4's "scale", which
     * its constant spectra hold already), the products clamped to [0, 1]; 1 elsewhere. */
    int reflectanceTexture;
    int transmittanceTexture;
    real textureScale;
    /* CB_FEATURE_NORMAL_MAP: the offset in `textures` of pbrt-v4's "normalmap", an image whose
     * texels 2 rgb - 1 are the shading normal in the tangent frame (cb_texture.h); -1: none. */
    int normalMap;
    /* CB_FEATURE_ROUGHNESS_TEXTURE: the offset in `textures` of the float texture (the mean of
     * its channels) that gives a conductor's, dielectric's or coat's roughness in place of the
     * one `alpha` was made from, -1: none; and whether alpha = sqrt(roughness) (pbrt-v4's
     * "remaproughness"). `alpha` then only says that the lobe is rough. */
    int roughnessTexture;
    int remapRoughness;
    /* CB_FEATURE_THICKNESS_TEXTURE: the offset in `textures` of the float texture that gives a
     * coat's layer thickness in place of `thickness`, -1: none. */
    int thicknessTexture;
    /* CB_FEATURE_ALPHA: the offset in `textures` of the float texture (1 x 1 for a constant) that
     * gives the shape's alpha, for the primitives of kind CB_PRIM_ALPHA_TRIANGLE; -1: none. */
    int alphaTexture;
    /* CB_FEATURE_BUMP_MAP: the offset in `textures` of the float texture (1 x 1 for a constant)
     * of pbrt-v4's "displacement", whose slopes tilt the shading normal (bumpMapNormal); -1: none
     * (also where the material has a normal map, which pbrt-v4 uses instead). */
    int displacement;
    /* CB_FEATURE_DISPERSION: a (thin) dielectric whose index varies with wavelength (pbrt-v4's
     * "spectrum eta"): the entry in `spectra` from which CB_DISPERSION_KNOTS values hold its
     * index at 400 nm and then every 1 / CB_DISPERSION_KNOTS_PER_BIN of a bin to 700 nm (linear
     * between them), `eta` their mean; -1: none. */
    int dispersion;
    /* CB_FEATURE_ANISOTROPIC: a conductor's or rough dielectric's GGX alpha along dp/dv (pbrt-v4's
     * "vroughness"), `alpha` then being the one along dp/du ("uroughness"); `alpha` elsewhere. */
    real alphaV;
    /* CB_FEATURE_MEDIUM: the medium on each side of the surface (cb_medium.h: its entries'
     * index in `spectra`, -1 vacuum), the outside the one ng points into (pbrt-v4's
     * MediumInterface of the shape; equal sides: the surface is no boundary). */
    int mediumInside;
    int mediumOutside;
    /* CB_MAT_HAIR (pbrt-v4's HairBxDF; `reflectance` its sigma_a, `eta` its index): the variance
     * v of the R lobe's longitudinal scattering (from beta_m; TT's is v / 4, TRT's and the rest's
     * 4 v), the logistic scale s of the azimuthal scattering (from beta_n), and the sine and
     * cosine of the scales' tilt alpha (Chiang et al. 2016, sec. 4). */
    real hairV;
    real hairS;
    real hairSinAlpha;
    real hairCosAlpha;
    int pad;
} Material;

/* One link of a mix chain (CB_MAT_MIX, CB_MAT_MIX_AT_POINT) chosen by a uniform u: the second part
 * where u < amount. Returns that part's index and rescales u to [0,1) within the choice, so the
 * next link (or the part's own lobe) can use it; the choice stays monotone in u. */
CB_FN int mixLinkChoose(Material link, real* u) {
    bool second = *u < link.mixAmount;
    *u = cbClamp(second ? *u / link.mixAmount : (*u - link.mixAmount) / (1.0f - link.mixAmount),
                 0.0f, 0.99999994f);
    return second ? link.mixSecond : link.mixFirst;
}

#define CB_DISPERSION_KNOTS_PER_BIN 4
#define CB_DISPERSION_KNOTS (CB_DISPERSION_KNOTS_PER_BIN * CB_CHANNELS + 1)

/* ---- Lights ------------------------------------------------------------------------------- */

#define CB_LIGHT_AREA 0
#define CB_LIGHT_POINT 1
#define CB_LIGHT_DISTANT 2
#define CB_LIGHT_INFINITE 3

/* Area lights are one entry per emitting primitive (a triangle or a sphere), so that lights
 * can be chosen by power and points sampled uniformly by area (docs/method.md, BDPT). Point lights
 * emit intensity `emission` uniformly in all directions; a spot light is a point light whose
 * intensity falls off with the angle to `axis` (pbrt-v4's SpotLight::I). A distant light sends
 * radiance `emission` from the single direction `axis`: irradiance `emission` on a surface
 * facing it. Its light subpaths start on the disk of the scene's bounding sphere (position,
 * sceneRadius) perpendicular to `axis`, outside the sphere (pbrt-v4's DistantLight::SampleLe).
 * An infinite light sends radiance `emission` from every direction; a scene has at most one,
 * and it is the last light, so that escaped rays find it at once. Its light subpaths start on
 * the disk perpendicular to their direction (pbrt-v4's UniformInfiniteLight::SampleLe). An
 * infinite light given by an image (imageSize > 0, pbrt-v4's ImageInfiniteLight) sends pixel
 * p's radiance from the directions that pbrt-v4's equal-area octahedral map takes to that pixel
 * in the light's frame (worldFromLight); a goniometric light (a point light with an image)
 * weights its intensity so. The image's sampling tables and pixel values start at
 * lightTables[imageTable] (cb_lights.h, imageLightPixelPdf and imageLightPixelEmission). An
 * invisible area light (pbrt-v4's area light on a shape of alpha 0) has its primitive outside
 * the BVH: light sampling reaches it, no ray finds it, so no strategy that finds it by a ray
 * counts in MIS (pbrt-v4 marks it DeltaPosition for the same reason). */
typedef struct Light {
    int kind;         /* CB_LIGHT_* */
    int primitive;    /* CB_LIGHT_AREA: the emitting primitive */
    int emission;     /* index into the spectra table: radiance L (area, distant) or intensity I */
    int twoSided;     /* area lights: emit on both sides */
    real position[3]; /* CB_LIGHT_POINT; distant, infinite: the scene's bounding sphere's centre */
    real area;        /* CB_LIGHT_AREA: surface area of the primitive */
    real pickProbability; /* probability of choosing this light (proportional to power) */
    real cdf;             /* sum of pickProbability over lights 0..this one (for binary search) */
    real spotCosStart;    /* full intensity inside this cosine of the angle to the axis */
    real spotCosEnd;      /* zero outside it; below -1: not a spot (uniform point light) */
    real axis[3]; /* unit: a spot's cone axis; CB_LIGHT_DISTANT: the direction toward the light */
    real sceneRadius;       /* distant, infinite: the radius of the scene's bounding sphere */
    real worldFromLight[9]; /* image light: row-major rotation from the light's frame to world */
    int imageSize;          /* image light: the square image's side in pixels; 0 otherwise */
    int imageTable;         /* image light: offset of its sampling tables in lightTables */
    int invisible;          /* area light: its primitive is in no BVH leaf (no ray finds it) */
    /* Infinite light: offset in lightTables of its portal (lightSeenThroughPortal), -1 none. */
    int portal;
} Light;

/* ---- Camera ------------------------------------------------------------------------------- */

/* pbrt-v4's perspective camera: camera space is left-handed, +z forward, +y up, +x right in
 * the image; raster y grows downwards. cameraToWorld is a 3x4 row-major affine matrix. */
#define CB_FILTER_BOX 0
#define CB_FILTER_TRIANGLE 1
#define CB_FILTER_GAUSSIAN 2
#define CB_FILTER_MITCHELL 3
#define CB_FILTER_SINC 4
#define CB_FILTER_TABLE_BINS 32

typedef struct Camera {
    real cameraToWorld[12];
    real worldToCamera[12];
    real tanHalfFovX; /* screen window half-extents at z = 1 */
    real tanHalfFovY;
    int width;
    int height;
    /* The screen window's centre at z = 1: zero, except for a crop window (pbrt's
     * --cropwindow), whose image is that part of the full film's screen window. */
    real screenCenterX;
    real screenCenterY;
    /* pbrt-v4's thin lens: a lens of this radius at the camera's origin, in focus at z =
     * focalDistance (camera space); radius 0 is the pinhole (CB_FEATURE_THIN_LENS). */
    real lensRadius;
    real focalDistance;
    /* pbrt-v4's PixelFilter (cb_filter.h): CB_FILTER_*, its radii in pixels, the gaussian's
     * standard deviation, Mitchell and Netravali's B and C, the Lanczos window's tau, and 1 /
     * the filter's integral. The box of radius 0.5 (one pixel) needs no
     * CB_FEATURE_PIXEL_FILTER. */
    int filterType;
    real filterRadiusX;
    real filterRadiusY;
    real filterSigma;
    real filterMitchellB;
    real filterMitchellC;
    real filterSincTau;
    real filterNormalization;
    /* Filters with negative lobes (mitchell, sinc), per axis (x, y): the share of the integral
     * of |f1| over [0, r] below each of CB_FILTER_TABLE_BINS + 1 evenly spaced offsets, by
     * which pixel samples are drawn (filterTableSample1), and (r / CB_FILTER_TABLE_BINS) / the
     * integral of f1 over [0, r], which turns a sample's density into its weight. */
    real filterAbsCdf[2][CB_FILTER_TABLE_BINS + 1];
    real filterSampleScale[2];
    /* CB_FEATURE_MEDIUM: the medium the camera sits in (pbrt-v4's CameraMedium, the
     * outside of its MediumInterface: cb_medium.h), -1 vacuum. */
    int medium;
    /* CB_FEATURE_SAMPLE_CLAMP: pbrt-v4's "maxcomponentvalue", the largest component a sample's
     * sensor RGB may have (0: no clamp), and the 3 x 3 row-major matrix from the film's output
     * RGB (specToRgb's) to the sensor's: XYZ times the imaging ratio for the cie1931 sensor. */
    real sampleClamp;
    real sensorFromRgb[9];
    int pad[1];
} Camera;

CB_FN Vec3 affineTransformPoint(const real* m, Vec3 p) {
    return vec3(m[0] * p.x + m[1] * p.y + m[2] * p.z + m[3],
                m[4] * p.x + m[5] * p.y + m[6] * p.z + m[7],
                m[8] * p.x + m[9] * p.y + m[10] * p.z + m[11]);
}
CB_FN Vec3 affineTransformVector(const real* m, Vec3 v) {
    return vec3(m[0] * v.x + m[1] * v.y + m[2] * v.z, m[4] * v.x + m[5] * v.y + m[6] * v.z,
                m[8] * v.x + m[9] * v.y + m[10] * v.z);
}

/* ---- The scene as one bundle of buffers ------------------------------------------------- */

struct BvhNodeWide; /* defined in cb_bvh_wide.h */

/* Built inside each kernel from its arguments (OpenCL 1.2 allows structs of pointers in
 * private memory, not as kernel arguments) and passed by pointer to the shared code; on the
 * host it points at the host-side copies of the same arrays. */
typedef struct SceneView {
    CB_GLOBAL const struct BvhNodeWide* nodes;
    CB_GLOBAL const TrianglePack* packs; /* the BVH leaves' triangles */
    CB_GLOBAL const Primitive* primitives;
    CB_GLOBAL const Material* materials;
    CB_GLOBAL const Light* lights;
    CB_GLOBAL const real* spectra;     /* CB_CHANNELS floats per entry */
    CB_GLOBAL const real* lightTables; /* image lights' sampling tables (Light.imageTable) */
    /* CB_FEATURE_TEXTURE: per primitive 6 values, a triangle's vertices' texture coordinates
     * (u0 v0 u1 v1 u2 v2) or a sphere's object frame, then the image textures (cb_texture.h) */
    CB_GLOBAL const real* textures;
    /* CB_FEATURE_SHADING_NORMALS: per primitive 9 values, a triangle's vertex normals */
    CB_GLOBAL const real* shadingNormals;
    /* CB_FEATURE_CURVES: the curve pieces that primitives of kind CB_PRIM_CURVE index */
    CB_GLOBAL const CurveSegment* curves;
    int lightCount;
#ifndef CB_KERNEL_SIDE
    /* The host compiles every feature; code that a scene without one must not pay for asks the
     * scene's own bits (CB_SCENE_HAS). */
    unsigned long features;
#endif
} SceneView;

/* Whether `scene` may use `feature`: the kernels compile only their scene's features, so there
 * the compile-time bit; on the host the scene's bits. */
#ifdef CB_KERNEL_SIDE
#define CB_SCENE_HAS(scene, feature) CB_HAS(feature)
#else
#define CB_SCENE_HAS(scene, feature) (((scene)->features & (feature)) != 0u)
#endif

#ifdef CB_KERNEL_SIDE
/* Every kernel takes the scene as these parameters (in this order; the host sets them with
 * SceneBuffers::setKernelArgs) and builds its SceneView with CB_SCENE_VIEW. */
#define CB_SCENE_KERNEL_PARAMS                                                                     \
    __global const struct BvhNodeWide *nodes, __global const TrianglePack *packs,                  \
        __global const Primitive *primitives, __global const Material *materials,                  \
        __global const Light *lights, __global const real *spectra,                                \
        __global const real *lightTables, __global const real *textures,                           \
        __global const real *shadingNormals, __global const CurveSegment *curves, int lightCount
#define CB_SCENE_VIEW(view)                                                                        \
    SceneView view;                                                                                \
    view.nodes = nodes;                                                                            \
    view.packs = packs;                                                                            \
    view.primitives = primitives;                                                                  \
    view.materials = materials;                                                                    \
    view.lights = lights;                                                                          \
    view.spectra = spectra;                                                                        \
    view.lightTables = lightTables;                                                                \
    view.textures = textures;                                                                      \
    view.shadingNormals = shadingNormals;                                                          \
    view.curves = curves;                                                                          \
    view.lightCount = lightCount
#endif

CB_END_NAMESPACE

#endif /* CB_TYPES_H */
