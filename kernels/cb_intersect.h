/* cb_intersect.h - ray/primitive intersection and robust spawning of secondary rays.
 *
 * Nothing here uses a scene-scale epsilon. Intersections are watertight and conservative
 * (Woop, Benthin, Wald 2013; pbrt-v4), every hit point carries a floating-point error bound
 * (pbrt 3rd ed. sec. 3.9), and new rays start just outside that bound, so the same code
 * works for a scene scaled by 1e-4 or 1e4 or translated far from the origin. */
#ifndef CB_INTERSECT_H
#define CB_INTERSECT_H

#include "cb_curve.h"
#include "cb_texture.h"
#include "cb_types.h"

/* No fused multiply-adds in this file: OpenCL C lets the compiler contract a * b - c * d into
 * fma(a, b, -c * d), which rounds the two products differently, so the edge function of an
 * edge would no longer be the exact negation of the same edge seen from the neighbouring
 * triangle, and rays through shared edges leak (2 of 37k rays through the Buddha's vertices and
 * edges did, in PoCL's AVX-512 code: test_bvh.cpp). The host compiles with -ffp-contract=off
 * (CMakeLists.txt) for the same reason. Restored at the end of the file. */
#ifdef CB_KERNEL_SIDE
#pragma OPENCL FP_CONTRACT OFF
#endif
#if defined(CB_KERNEL_SIDE) && defined(cl_khr_fp64)
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#define CB_HAS_DOUBLE 1
#elif !defined(CB_KERNEL_SIDE)
#define CB_HAS_DOUBLE 1
#endif

CB_BEGIN_NAMESPACE

/* Relative shortening of shadow rays (pbrt-v4's ShadowEpsilon): the intersection t of the
 * target surface itself carries a relative error of a few ulps of the distance, which the
 * endpoint offsets alone do not cover when the target is far from the ray origin. Being
 * relative, it is independent of the scene scale. */
#define CB_SHADOW_EPSILON 1.0e-4f

CB_FN Vec3 cbPermute(Vec3 v, int x, int y, int z) {
    return vec3(vcomponent(v, x), vcomponent(v, y), vcomponent(v, z));
}

CB_FN int cbMaxAxis(Vec3 v) {
    return (v.x > v.y) ? (v.x > v.z ? 0 : 2) : (v.y > v.z ? 1 : 2);
}

/* The parts of the watertight test that one triangle (real) and four at once (float4, the
 * kernels' intersectPackSimd) must compute with the same arithmetic, written once.
 * cbEdgeFunction: the edge function of the sheared, translated edge a -> b; with nothing fused
 * (FP_CONTRACT OFF above) it is exactly antisymmetric, so neighbouring triangles see a shared
 * edge with opposite signs. cbTriangleTError: pbrt's bound on the rounding error of the hit's
 * t (3rd ed. sec. 3.9.6), from the sheared vertices (z already scaled), the edge functions and
 * 1 / det. */
#define CB_DEFINE_TRIANGLE_ARITHMETIC(T, SUFFIX)                                                   \
    CB_FN T cbEdgeFunction##SUFFIX(T ax, T ay, T bx, T by) {                                       \
        return ax * by - ay * bx;                                                                  \
    }                                                                                              \
    CB_FN T cbTriangleTError##SUFFIX(T x0, T x1, T x2, T y0, T y1, T y2, T z0, T z1, T z2, T e0,   \
                                     T e1, T e2, T invDet) {                                       \
        T maxZt = fmax(fabs(z0), fmax(fabs(z1), fabs(z2)));                                        \
        T deltaZ = cbGamma(3) * maxZt;                                                             \
        T maxXt = fmax(fabs(x0), fmax(fabs(x1), fabs(x2)));                                        \
        T maxYt = fmax(fabs(y0), fmax(fabs(y1), fabs(y2)));                                        \
        T deltaX = cbGamma(5) * (maxXt + maxZt);                                                   \
        T deltaY = cbGamma(5) * (maxYt + maxZt);                                                   \
        T deltaE = 2.0f * (cbGamma(2) * maxXt * maxYt + deltaY * maxXt + deltaX * maxYt);          \
        T maxE = fmax(fabs(e0), fmax(fabs(e1), fabs(e2)));                                         \
        return 3.0f * (cbGamma(3) * maxE * maxZt + deltaE * maxZt + deltaZ * maxE) * fabs(invDet); \
    }
CB_DEFINE_TRIANGLE_ARITHMETIC(real, )
#ifdef CB_KERNEL_SIDE
CB_DEFINE_TRIANGLE_ARITHMETIC(float4, 4)
#endif

/* What the watertight test needs of the ray alone (Woop, Benthin, Wald 2013, sec. 3): the axis
 * permutation that makes the largest direction component z, the shear that makes the ray run
 * along +z, and the origin in the permuted axes. The traversal computes it once per ray. */
typedef struct TriangleRay {
    int kx, ky, kz;
    real sx, sy, sz;
    real ox, oy, oz;
} TriangleRay;

CB_FN TriangleRay triangleRayOf(Ray ray) {
    TriangleRay r;
    r.kz = cbMaxAxis(vabs(ray.d));
    r.kx = r.kz + 1;
    if (r.kx == 3) r.kx = 0;
    r.ky = r.kx + 1;
    if (r.ky == 3) r.ky = 0;
    Vec3 d = cbPermute(ray.d, r.kx, r.ky, r.kz);
    /* One division per ray: the shear need not be -d.x / d.z rounded once, only the same for
     * every triangle the ray is tested against. */
    r.sz = 1.0f / d.z;
    r.sx = -d.x * r.sz;
    r.sy = -d.y * r.sz;
    r.ox = vcomponent(ray.o, r.kx);
    r.oy = vcomponent(ray.o, r.ky);
    r.oz = vcomponent(ray.o, r.kz);
    return r;
}

#ifdef CB_HAS_DOUBLE
/* Double-precision ray parameter of the hit of `ray` with the triangle's plane (the edge tests
 * already passed in real), and whether it clears its own rounding-error bound (pbrt 3rd ed.
 * sec. 3.9.6 with double's unit roundoff). The axes are the sheared ray's; the shear is
 * recomputed in double. */
CB_FN bool cbTriangleHitBeyondErrorDouble(Ray ray, TriangleRay sheared, Vec3 p0, Vec3 p1, Vec3 p2,
                                          real* t) {
    /* Scalars, not arrays: PoCL gives every private array that survives to its work-group
     * pass a copy per work-item, set up in every ray's prologue though this path is rare. */
    int kx = sheared.kx, ky = sheared.ky, kz = sheared.kz;
    double ox = vcomponent(ray.o, kx), oy = vcomponent(ray.o, ky), oz = vcomponent(ray.o, kz);
    double dx = vcomponent(ray.d, kx), dy = vcomponent(ray.d, ky), dz = vcomponent(ray.d, kz);
    double sx = -dx / dz;
    double sy = -dy / dz;
    double sz = 1.0 / dz;
    double z0 = (double)vcomponent(p0, kz) - oz, z1 = (double)vcomponent(p1, kz) - oz,
           z2 = (double)vcomponent(p2, kz) - oz;
    double x0 = ((double)vcomponent(p0, kx) - ox) + sx * z0;
    double x1 = ((double)vcomponent(p1, kx) - ox) + sx * z1;
    double x2 = ((double)vcomponent(p2, kx) - ox) + sx * z2;
    double y0 = ((double)vcomponent(p0, ky) - oy) + sy * z0;
    double y1 = ((double)vcomponent(p1, ky) - oy) + sy * z1;
    double y2 = ((double)vcomponent(p2, ky) - oy) + sy * z2;
    z0 *= sz;
    z1 *= sz;
    z2 *= sz;
    double e0 = x1 * y2 - y1 * x2;
    double e1 = x2 * y0 - y2 * x0;
    double e2 = x0 * y1 - y0 * x1;
    double det = e0 + e1 + e2;
    if (det == 0.0) return false;
    double tD = (e0 * z0 + e1 * z1 + e2 * z2) / det;
    const double u = 1.1102230246251565e-16; /* double unit roundoff */
    double maxX = fmax(fabs(x0), fmax(fabs(x1), fabs(x2)));
    double maxY = fmax(fabs(y0), fmax(fabs(y1), fabs(y2)));
    double maxZ = fmax(fabs(z0), fmax(fabs(z1), fabs(z2)));
    double maxE = fmax(fabs(e0), fmax(fabs(e1), fabs(e2)));
    double g2 = 2.0 * u / (1.0 - 2.0 * u), g3 = 3.0 * u / (1.0 - 3.0 * u),
           g5 = 5.0 * u / (1.0 - 5.0 * u);
    double deltaX = g5 * (maxX + maxZ), deltaY = g5 * (maxY + maxZ), deltaZ = g3 * maxZ;
    double deltaE = 2.0 * (g2 * maxX * maxY + deltaY * maxX + deltaX * maxY);
    double deltaT = 3.0 * (g3 * maxE * maxZ + deltaE * maxZ + deltaZ * maxE) / fabs(det);
    if (!(tD > deltaT)) return false;
    *t = (real)tD;
    return true;
}
#endif

/* Watertight ray/triangle intersection (Woop, Benthin, Wald 2013, JCGT 2(1)), with the
 * conservative t > 0 test of pbrt-v4 (3rd ed. sec. 3.9.6). Rays through a shared edge or
 * vertex hit at least one of the triangles sharing it: the edge functions are evaluated in a
 * ray-aligned sheared frame where they are exact up to one rounding, and a zero edge function
 * is re-evaluated in double precision so that ties are broken consistently. Returns the hit
 * only for t in (0, tMax); b1, b2 are the barycentric weights of p1 and p2. `sheared` is
 * triangleRayOf(ray). intersectPackSimd (below) is the same test on four triangles at once:
 * the edge functions and the error bound are the shared CB_DEFINE_TRIANGLE_ARITHMETIC. */
CB_FN bool intersectTriangleSheared(Ray ray, TriangleRay sheared, real tMax, Vec3 p0, Vec3 p1,
                                    Vec3 p2, real* t, real* b1, real* b2) {
    int kx = sheared.kx, ky = sheared.ky, kz = sheared.kz;
    Vec3 p0t = cbPermute(vsub(p0, ray.o), kx, ky, kz);
    Vec3 p1t = cbPermute(vsub(p1, ray.o), kx, ky, kz);
    Vec3 p2t = cbPermute(vsub(p2, ray.o), kx, ky, kz);
    real sx = sheared.sx, sy = sheared.sy, sz = sheared.sz;

    /* Shear so that the ray runs along +z; z is scaled later, only if needed. */
    p0t.x += sx * p0t.z;
    p0t.y += sy * p0t.z;
    p1t.x += sx * p1t.z;
    p1t.y += sy * p1t.z;
    p2t.x += sx * p2t.z;
    p2t.y += sy * p2t.z;

    real e0 = cbEdgeFunction(p1t.x, p1t.y, p2t.x, p2t.y);
    real e1 = cbEdgeFunction(p2t.x, p2t.y, p0t.x, p0t.y);
    real e2 = cbEdgeFunction(p0t.x, p0t.y, p1t.x, p1t.y);
#ifdef CB_HAS_DOUBLE
    if (e0 == 0.0f || e1 == 0.0f || e2 == 0.0f) {
        e0 = (real)((double)p1t.x * (double)p2t.y - (double)p1t.y * (double)p2t.x);
        e1 = (real)((double)p2t.x * (double)p0t.y - (double)p2t.y * (double)p0t.x);
        e2 = (real)((double)p0t.x * (double)p1t.y - (double)p0t.y * (double)p1t.x);
    }
#endif
    /* Edge functions of mixed sign: the ray passes outside. Zero counts as inside. */
    if ((e0 < 0.0f || e1 < 0.0f || e2 < 0.0f) && (e0 > 0.0f || e1 > 0.0f || e2 > 0.0f))
        return false;
    real det = e0 + e1 + e2;
    if (det == 0.0f) return false;

    p0t.z *= sz;
    p1t.z *= sz;
    p2t.z *= sz;
    real tScaled = e0 * p0t.z + e1 * p1t.z + e2 * p2t.z;
    /* Range test on the unnormalised t, avoiding the division for most misses. */
    if (det < 0.0f && (tScaled >= 0.0f || tScaled <= tMax * det)) return false;
    if (det > 0.0f && (tScaled <= 0.0f || tScaled >= tMax * det)) return false;

    real invDet = 1.0f / det;
    real tHit = tScaled * invDet;
    if (!(tHit < tMax)) return false;

    /* Conservative t > 0 (pbrt 3rd ed. sec. 3.9.6): reject hits whose t is within its own
     * rounding-error bound of zero, which is what keeps spawned rays from re-hitting their
     * origin triangle. */
    real deltaT = cbTriangleTError(p0t.x, p1t.x, p2t.x, p0t.y, p1t.y, p2t.y, p0t.z, p1t.z, p2t.z,
                                   e0, e1, e2, invDet);
    if (tHit <= deltaT) {
#ifdef CB_HAS_DOUBLE
        /* The real bound grows with the triangle's size relative to the ray origin, so a hit a
         * few 1e-5 away on a metres-wide triangle (a camera just above a floor) falls inside
         * it and would leak through. Decide such cases with the same computation in double,
         * whose bound is 2^29 times tighter; a spawned ray's own surface (origin offset past
         * its error box) still comes out at t <= 0 there. */
        if (!cbTriangleHitBeyondErrorDouble(ray, sheared, p0, p1, p2, &tHit)) return false;
#else
        return false;
#endif
    }

    *t = tHit;
    *b1 = e1 * invDet;
    *b2 = e2 * invDet;
    return true;
}

/* intersectTriangleSheared for a single triangle. */
CB_FN bool intersectTriangle(Ray ray, real tMax, Vec3 p0, Vec3 p1, Vec3 p2, real* t, real* b1,
                             real* b2) {
    return intersectTriangleSheared(ray, triangleRayOf(ray), tMax, p0, p1, p2, t, b1, b2);
}

/* Ray/sphere intersection in the form of Haines et al., "Precision Improvements for Ray/Sphere
 * Intersection" (Ray Tracing Gems, ch. 7): the discriminant is computed from the distance of
 * the centre to the ray line (b^2 - 4ac = 4a (r^2 - |f - (f.d/a) d|^2)), which avoids
 * the cancellation of b^2 - 4ac for small or distant spheres, and the two roots come from
 * q = b' + sign(b') sqrt(disc) (Press et al.) so that neither root subtracts nearly equal
 * numbers. Returns the nearest root in (0, tMax): the near one from outside, the far one from
 * inside. ray.d need not be unit. */
CB_FN bool intersectSphere(Ray ray, real tMax, Vec3 center, real radius, real* t) {
    Vec3 f = vsub(ray.o, center);
    real a = vdot(ray.d, ray.d);
    real bp = -vdot(f, ray.d); /* -b/2 */
    Vec3 l = vmadd(f, ray.d, bp / a);
    real r2 = radius * radius;
    real disc = a * (r2 - vlength2(l)); /* (b^2 - 4ac) / 4 */
    if (disc < 0.0f) return false;
    real c = vlength2(f) - r2;
    real sq = sqrt(disc);
    real q = bp >= 0.0f ? bp + sq : bp - sq;
    if (q == 0.0f) return false; /* both roots at t = 0 */
    real t0 = c / q;
    real t1 = q / a;
    if (t0 > t1) {
        real tmp = t0;
        t0 = t1;
        t1 = tmp;
    }
    if (t0 > 0.0f && t0 < tMax) {
        *t = t0;
        return true;
    }
    if (t1 > 0.0f && t1 < tMax) {
        *t = t1;
        return true;
    }
    return false;
}

/* Fills hit->t, b1, b2 (b1 = b2 = 0 for spheres, a curve's (u, v)); the caller sets
 * hit->primitive. `sheared` is triangleRayOf(ray); `scene` holds the curve pieces (null where
 * there are none). With !closestHit a curve returns at its first hit, *hit then unset. */
CB_FN bool intersectPrimitiveSheared(CB_GLOBAL const Primitive* prim, Ray ray, TriangleRay sheared,
                                     real tMax, Hit* hit, const SceneView* scene, bool closestHit) {
    (void)scene;
    (void)closestHit;
#if CB_HAS(CB_FEATURE_CURVES)
    if (prim->kind == CB_PRIM_CURVE)
        return intersectCurve(scene->curves + (int)prim->p2[0], ray, tMax, closestHit, hit);
#endif
#if CB_HAS(CB_FEATURE_SPHERES)
    if (prim->kind == CB_PRIM_SPHERE) {
        real t;
        if (!intersectSphere(ray, tMax, vec3FromGlobalArray(prim->p0), prim->p1[0], &t))
            return false;
        hit->t = t;
        hit->b1 = 0.0f;
        hit->b2 = 0.0f;
        return true;
    }
#endif
    real t, b1, b2;
    if (!intersectTriangleSheared(ray, sheared, tMax, vec3FromGlobalArray(prim->p0),
                                  vec3FromGlobalArray(prim->p1), vec3FromGlobalArray(prim->p2), &t,
                                  &b1, &b2))
        return false;
    hit->t = t;
    hit->b1 = b1;
    hit->b2 = b2;
    return true;
}

/* Triangles and spheres (curves need their scene: intersectPrimitiveSheared). */
CB_FN bool intersectPrimitive(CB_GLOBAL const Primitive* prim, Ray ray, real tMax, Hit* hit) {
    return intersectPrimitiveSheared(prim, ray, triangleRayOf(ray), tMax, hit, 0, true);
}

/* The lanes of a TrianglePack against `ray` for t in (0, tMax), each lane decided as
 * intersectPrimitive decides its primitive alone, all against the same tMax. Returns whether
 * any lane is hit; *hit: the nearest, the lowest lane among equal t, primitive set. With
 * !closestHit it may return at the first hit found, *hit then unset. `sheared` is
 * triangleRayOf(ray). hitScene: the scene whose materials and textures decide the hits on
 * alpha-tested triangles (alphaKeepsHit) and whose curve pieces the curves index; null where
 * the primitives have neither. */
#ifdef CB_KERNEL_SIDE
/* Whether any lane of a mask (lanes 0 or -1) is set. PoCL's any() tests the sign bits one
 * by one; an OR across the lanes is a few instructions fewer. */
CB_FN bool cbAnyLane(int4 mask) {
    int2 a = mask.lo | mask.hi;
    return (a.x | a.y) != 0;
}

#define CB_PACK_MISS 0
#define CB_PACK_HIT 1
#define CB_PACK_PICK 2

/* intersectTriangleSheared's float arithmetic on vector lanes T (masks M), written once for
 * intersectPackSimd (four triangles of a pack against one ray: shear and tMax S = real) and for
 * cbdpt-bench's packets (one triangle against several rays: S = T). p*: the vertices translated
 * to the ray origin in the ray's permuted axes, not yet sheared; live: the lanes that take part.
 * The two cases where the test turns to double precision, a zero edge function and a hit within
 * its own error bound of t = 0, are rare: such lanes come back in *slow, to be decided one by
 * one. CB_PACK_MISS: no lane can be hit; CB_PACK_HIT: !closestHit and a lane is hit; CB_PACK_PICK:
 * *t (+inf where no hit), *b1, *b2 per lane, and *slow, to choose from.
 *
 * The sign of a nonzero float edge function is exact (the two products round monotonically), so
 * intersectTriangleSheared's double-precision re-evaluation of a zero one can decide that lane,
 * never flip the others: a lane with edge functions of both strict signs is outside either way.
 * The cheap test goes first, as most lanes are misses. */
#define CB_DEFINE_TRIANGLE_LANES(T, M, S, SUFFIX, ANY)                                             \
    CB_FN int cbTriangleLanes##SUFFIX(T p0x, T p0y, T p0z, T p1x, T p1y, T p1z, T p2x, T p2y,      \
                                      T p2z, S sx, S sy, S sz, S tMax, M live, bool closestHit,    \
                                      T* t, T* b1, T* b2, M* slow) {                               \
        p0x += sx * p0z;                                                                           \
        p0y += sy * p0z;                                                                           \
        p1x += sx * p1z;                                                                           \
        p1y += sy * p1z;                                                                           \
        p2x += sx * p2z;                                                                           \
        p2y += sy * p2z;                                                                           \
        T e0 = cbEdgeFunction##SUFFIX(p1x, p1y, p2x, p2y);                                         \
        T e1 = cbEdgeFunction##SUFFIX(p2x, p2y, p0x, p0y);                                         \
        T e2 = cbEdgeFunction##SUFFIX(p0x, p0y, p1x, p1y);                                         \
        T eMin = min(e0, min(e1, e2)), eMax = max(e0, max(e1, e2));                                \
        M candidate = ((eMin >= 0.0f) | (eMax <= 0.0f)) & live;                                    \
        if (!ANY(candidate)) return CB_PACK_MISS;                                                  \
        *slow = candidate & ((e0 == 0.0f) | (e1 == 0.0f) | (e2 == 0.0f));                          \
        candidate &= ~*slow;                                                                       \
        T det = e0 + e1 + e2;                                                                      \
        p0z *= sz;                                                                                 \
        p1z *= sz;                                                                                 \
        p2z *= sz;                                                                                 \
        T tScaled = e0 * p0z + e1 * p1z + e2 * p2z;                                                \
        T tMaxDet = tMax * det;                                                                    \
        candidate &= ((det < 0.0f) & (tScaled < 0.0f) & (tScaled > tMaxDet)) |                     \
                     ((det > 0.0f) & (tScaled > 0.0f) & (tScaled < tMaxDet));                      \
        T invDet = 1.0f / det;                                                                     \
        T tHit = tScaled * invDet;                                                                 \
        candidate &= tHit < tMax;                                                                  \
        if (!ANY(candidate | *slow)) return CB_PACK_MISS;                                          \
        T deltaT = cbTriangleTError##SUFFIX(p0x, p1x, p2x, p0y, p1y, p2y, p0z, p1z, p2z, e0, e1,   \
                                            e2, invDet);                                           \
        M nearZero = tHit <= deltaT;                                                               \
        *slow |= candidate & nearZero;                                                             \
        M exact = candidate & ~nearZero;                                                           \
        if (!closestHit && ANY(exact)) return CB_PACK_HIT;                                         \
        *t = select((T)(INFINITY), tHit, exact);                                                   \
        *b1 = e1 * invDet;                                                                         \
        *b2 = e2 * invDet;                                                                         \
        return CB_PACK_PICK;                                                                       \
    }
CB_DEFINE_TRIANGLE_LANES(float4, int4, real, 4, cbAnyLane)

/* The SIMD part of intersectPack on a triangle pack: cbTriangleLanes4 on its four triangles
 * (one SSE instruction per step under PoCL), see there. */
CB_FN int intersectPackSimd(CB_GLOBAL const TrianglePack* pack, TriangleRay sheared, real tMax,
                            bool closestHit, float4* t, float4* b1, float4* b2, int4* slow) {
    int kx = sheared.kx, ky = sheared.ky, kz = sheared.kz;
    return cbTriangleLanes4(
        vload4(0, pack->v[0][kx]) - sheared.ox, vload4(0, pack->v[0][ky]) - sheared.oy,
        vload4(0, pack->v[0][kz]) - sheared.oz, vload4(0, pack->v[1][kx]) - sheared.ox,
        vload4(0, pack->v[1][ky]) - sheared.oy, vload4(0, pack->v[1][kz]) - sheared.oz,
        vload4(0, pack->v[2][kx]) - sheared.ox, vload4(0, pack->v[2][ky]) - sheared.oy,
        vload4(0, pack->v[2][kz]) - sheared.oz, sheared.sx, sheared.sy, sheared.sz, tMax,
        (int4)(-1), closestHit, t, b1, b2, slow);
}

/* The value of the one lane of v that `lane` (lanes 0 or -1) selects, exactly (bits ORed with
 * zeros). */
CB_FN float cbPackLaneValue(float4 v, int4 lane) {
    int4 bits = as_int4(v) & lane;
    int2 a = bits.lo | bits.hi;
    return as_float(a.x | a.y);
}

/* Triangle packs through intersectPackSimd, scalar packs (and slow lanes) lane by lane with
 * intersectPrimitiveSheared: one inlined copy of the scalar test, not two. The nearest lane
 * is picked with vector minimums and selects rather than through private arrays: PoCL gives
 * each private array one copy per work-item of the work-group, and LLVM set up their
 * addresses once per ray, though most primary rays never reach a pack (docs/performance.md). */
CB_FN bool intersectPack(CB_GLOBAL const TrianglePack* pack, CB_GLOBAL const Primitive* prims,
                         Ray ray, TriangleRay sheared, real tMax, bool closestHit, Hit* hit,
                         const SceneView* hitScene) {
    const int4 lanes = (int4)(0, 1, 2, 3);
    float4 tLane = (float4)(INFINITY), b1Lane = (float4)(0.0f), b2Lane = (float4)(0.0f);
    int4 slow;
#if CB_HAS(CB_FEATURE_ALPHA)
    /* Alpha-tested lanes: every lane's distance, for the alpha test to pick among below. */
    const bool alphaTested = pack->alphaTested != 0;
#else
    const bool alphaTested = false;
#endif
    if (pack->scalar) {
        slow = lanes < (int4)(pack->count);
    } else {
        int outcome = intersectPackSimd(pack, sheared, tMax, closestHit || alphaTested, &tLane,
                                        &b1Lane, &b2Lane, &slow);
        if (outcome != CB_PACK_PICK) return outcome == CB_PACK_HIT;
    }
    if (cbAnyLane(slow)) {
        for (int k = 0; k < CB_PACK_LANES; ++k) {
            int4 at = lanes == (int4)(k);
            if (!cbAnyLane(slow & at)) continue;
            Hit h = {tMax, -1, 0.0f, 0.0f};
            if (!intersectPrimitiveSheared(prims + pack->prim[k], ray, sheared, tMax, &h, hitScene,
                                           closestHit))
                continue;
#if CB_HAS(CB_FEATURE_ALPHA)
            if (alphaTested && !alphaKeepsHit(hitScene, pack->prim[k], ray, h.b1, h.b2)) continue;
#endif
            if (!closestHit) return true;
            tLane = select(tLane, (float4)(h.t), at);
            b1Lane = select(b1Lane, (float4)(h.b1), at);
            b2Lane = select(b2Lane, (float4)(h.b2), at);
        }
    }
    /* The nearest lane, the lowest among equal t (no lane is NaN: misses are +inf). An
     * alpha-tested pack's nearest lane the alpha test skips is dropped, and the next one tried
     * (a slow lane's hit asks again: the same answer). */
    real bestT;
    int best;
    int4 at;
    for (;;) {
        float2 m2 = min(tLane.lo, tLane.hi);
        bestT = min(m2.x, m2.y);
        if (!(bestT < tMax)) return false;
        int4 first = select((int4)(CB_PACK_LANES), lanes, tLane == (float4)(bestT));
        int2 f2 = min(first.lo, first.hi);
        best = min(f2.x, f2.y);
        at = lanes == (int4)(best);
#if CB_HAS(CB_FEATURE_ALPHA)
        if (alphaTested &&
            !alphaKeepsHit(hitScene, pack->prim[best], ray, cbPackLaneValue(b1Lane, at),
                           cbPackLaneValue(b2Lane, at))) {
            tLane = select(tLane, (float4)(INFINITY), at);
            continue;
        }
#endif
        break;
    }
    if (!closestHit) return true;
    hit->t = bestT;
    hit->b1 = cbPackLaneValue(b1Lane, at);
    hit->b2 = cbPackLaneValue(b2Lane, at);
    hit->primitive = pack->prim[best];
    return true;
}
#else
/* The host: the lanes one by one, from the primitives. */
CB_FN bool intersectPack(CB_GLOBAL const TrianglePack* pack, CB_GLOBAL const Primitive* prims,
                         Ray ray, TriangleRay sheared, real tMax, bool closestHit, Hit* hit,
                         const SceneView* hitScene) {
    bool found = false;
    real bestT = tMax;
    for (int k = 0; k < pack->count; ++k) {
        Hit h;
        h.t = tMax;
        if (!intersectPrimitiveSheared(prims + pack->prim[k], ray, sheared, tMax, &h, hitScene,
                                       closestHit))
            continue;
        if (pack->alphaTested && !alphaKeepsHit(hitScene, pack->prim[k], ray, h.b1, h.b2)) continue;
        if (!closestHit) return true;
        if (h.t < bestT) {
            bestT = h.t;
            h.primitive = pack->prim[k];
            *hit = h;
            found = true;
        }
    }
    return found;
}
#endif

#if CB_HAS(CB_FEATURE_ANISOTROPIC)
/* Whether a material's lobe (or a lobe of its mix) is anisotropic or hair: only those turn with
 * dp/du. The others keep frameFromNormal's frame, so that a scene's isotropic materials (and the
 * host, which compiles every feature) shade as where no material is anisotropic. */
CB_FN bool materialTurnsWithTangent(const SceneView* scene, int material) {
    if (material < 0) return false;
    Material m = scene->materials[material];
    while (m.kind == CB_MAT_MIX) { /* a chain of links (cbMixEval) */
        Material first = scene->materials[m.mixFirst];
        if (first.alphaV != first.alpha || first.kind == CB_MAT_HAIR) return true;
        m = scene->materials[m.mixSecond];
    }
    /* Hair's frame runs along the fibre (pbrt-v4: Frame::FromXZ(dpdu, ns)). */
    return m.alphaV != m.alpha || m.kind == CB_MAT_HAIR;
}

/* sp's shading tangent (SurfacePoint.tangent): its shape's dp/du, as surfacePointMapped takes it,
 * a sphere's (p0 = the hit point minus the centre) or a triangle's (its corners); 0 (any frame)
 * for isotropic materials. The frame makes it perpendicular to ns (frameFromNormalTangent). */
CB_FN SurfacePoint surfacePointTangent(const SceneView* scene, SurfacePoint sp, Hit hit, Vec3 p0,
                                       Vec3 p1, Vec3 p2) {
    sp.tangent = vec3(0.0f, 0.0f, 0.0f);
    /* (Host views of scenes without (u, v) have no texture buffer.) */
    if (!scene->textures || !materialTurnsWithTangent(scene, sp.material)) return sp;
    const bool sphere = scene->primitives[hit.primitive].kind == CB_PRIM_SPHERE;
    sp.tangent = sphere ? sphereShadingPartials(scene, hit.primitive, p0).dpdu
                        : triangleUvFrame(scene, hit.primitive, p0, p1, p2).dpdu;
    return sp;
}
#endif

#if CB_HAS(CB_FEATURE_NORMAL_MAP) || CB_HAS(CB_FEATURE_BUMP_MAP)
/* sp's shading normal bent by its material's normal map or bump map, from its shape's partials:
 * a sphere's (p0 = p1 = p2 = the hit point minus the centre) or a triangle's (its corners). One
 * call site per map for both shapes: with the maps called again in the sphere's branch, PoCL
 * 3.1's work-item loop vectoriser ("loopvec", LLVM 15) computed a bump-mapped sphere's normal
 * wrongly wherever a normal-mapped material was compiled too ("loops" and -cl-opt-disable did
 * not); found by comparing with pbrt-v4 (docs/pbrt-v4.md, sphere-maps.pbrt). */
CB_FN SurfacePoint surfacePointMapped(const SceneView* scene, SurfacePoint sp, Hit hit, Vec3 p0,
                                      Vec3 p1, Vec3 p2) {
    if (!scene->textures) return sp;
    const bool sphere = scene->primitives[hit.primitive].kind == CB_PRIM_SPHERE;
#if CB_HAS(CB_FEATURE_NORMAL_MAP)
    int normalMap = scene->materials[sp.material].normalMap;
    if (normalMap >= 0)
        sp.ns = normalMapNormal(scene, normalMap,
                                sphere ? sphereShadingPartials(scene, hit.primitive, p0).dpdu
                                       : triangleUvFrame(scene, hit.primitive, p0, p1, p2).dpdu,
                                sp);
#endif
#if CB_HAS(CB_FEATURE_BUMP_MAP)
    int displacement = scene->materials[sp.material].displacement;
    if (displacement >= 0)
        sp.ns =
            bumpMapNormal(scene, displacement,
                          sphere ? sphereShadingPartials(scene, hit.primitive, p0)
                                 : triangleShadingPartials(scene, hit.primitive, p0, p1, p2, sp.ns),
                          sp);
#endif
    return sp;
}
#endif

#if CB_HAS(CB_FEATURE_MIX_AT_POINT)
/* pbrt-v4's MixMaterial::ChooseMaterial for mixes whose parts cannot join a mixture of f and pdfs
 * (a coat's estimated density, a normal or bump map's own shading normal, a dispersive
 * dielectric's one wavelength): one part per surface point, the second with probability amount,
 * by a hash of the point (pbrt-v4 hashes wo too). A vertex then has one material for every
 * strategy that connects to it, and a pixel's points take each part in its share. */
CB_FN int mixPartAtPoint(const SceneView* scene, int material, Vec3 p) {
    /* (Host views that only trace, such as the BVH choice's, have no materials.) */
    if (material < 0 || !scene->materials) return material;
    Material m = scene->materials[material];
    if (m.kind != CB_MAT_MIX_AT_POINT) return material;
    uint h = cbHashCombine(cbHash32((uint)material), cbFloatBits(p.x));
    h = cbHashCombine(cbHashCombine(h, cbFloatBits(p.y)), cbFloatBits(p.z));
    real u = (real)(h >> 8) * (1.0f / 16777216.0f);
    while (m.kind == CB_MAT_MIX_AT_POINT) { /* a chain of links, as cbMixEval's */
        material = mixLinkChoose(m, &u);
        m = scene->materials[material];
    }
    return material;
}
#endif

/* The point and the geometric normal that textures mapped by the hit point and mixed by the
 * normal's direction read (|n . dir|: the side ng ends up facing does not matter). */
CB_FN void surfacePointForTextures(SurfacePoint* sp) {
#if CB_HAS(CB_FEATURE_TEXTURE_MAPPING)
    sp->uv.p = sp->p;
#endif
#if CB_HAS(CB_FEATURE_DIRECTION_MIX)
    sp->uv.n = sp->ng;
#endif
    (void)sp;
}

/* The hit point with a conservative per-axis error bound (pbrt 3rd ed. sec. 3.9.4-3.9.5).
 * The point is not o + t d, whose error grows with t, but recomputed from the primitive. */
CB_FN SurfacePoint surfacePointFromHit(const SceneView* scene, Ray ray, Hit hit) {
    CB_GLOBAL const Primitive* prim = scene->primitives + hit.primitive;
    SurfacePoint sp;
    sp.primitive = hit.primitive;
    sp.material = prim->material;
    sp.light = prim->light;
    sp.uv.u = 0.0f;
    sp.uv.v = 0.0f;
    sp.uv.hero = -1.0f;
    (void)ray; /* only spheres need the ray */
#if CB_HAS(CB_FEATURE_SPHERES)
    if (prim->kind == CB_PRIM_SPHERE) {
        Vec3 c = vec3FromGlobalArray(prim->p0);
        real r = prim->p1[0];
        /* Reproject onto the sphere: the local point then has error <= gamma(5)|p_local|
         * (pbrt 3rd ed. sec. 3.9.4, spheres), and adding the centre rounds once more. */
        Vec3 pLocal = vsub(vmadd(ray.o, ray.d, hit.t), c);
        pLocal = vscale(pLocal, r / vlength(pLocal));
        sp.p = vadd(c, pLocal);
        sp.pError = vadd(vscale(vabs(pLocal), cbGamma(5)), vscale(vabs(sp.p), cbGamma(2)));
        sp.ng = vscale(vnormalize(pLocal), prim->p1[1] < 0.0f ? -1.0f : 1.0f);
        sp.ns = sp.ng;
#if CB_HAS(CB_FEATURE_MIX_AT_POINT)
        sp.material = mixPartAtPoint(scene, sp.material, sp.p);
#endif
#if CB_HAS(CB_FEATURE_TEXTURE)
        if (scene->textures) sp.uv = sphereTexCoord(scene, hit.primitive, pLocal);
#endif
        surfacePointForTextures(&sp);
#if CB_HAS(CB_FEATURE_NORMAL_MAP) || CB_HAS(CB_FEATURE_BUMP_MAP)
        sp = surfacePointMapped(scene, sp, hit, pLocal, pLocal, pLocal);
#endif
#if CB_HAS(CB_FEATURE_ANISOTROPIC)
        sp = surfacePointTangent(scene, sp, hit, pLocal, pLocal, pLocal);
#endif
        return sp;
    }
#endif
#if CB_HAS(CB_FEATURE_CURVES)
    if (prim->kind == CB_PRIM_CURVE) {
        Vec3 dpdu;
        real width;
        curveSurface(scene->curves + (int)prim->p2[0], ray, hit, &sp.p, &sp.ng, &dpdu, &width);
        /* pbrt-v4's bound: the width, which lifts rays that leave the curve off its surface
         * that faces every ray. */
        sp.pError = vec3(width, width, width);
        sp.ns = sp.ng;
#if CB_HAS(CB_FEATURE_MIX_AT_POINT)
        sp.material = mixPartAtPoint(scene, sp.material, sp.p);
#endif
        sp.uv.u = hit.b1; /* pbrt-v4's (u, v): along the curve and across its width */
        sp.uv.v = hit.b2;
        surfacePointForTextures(&sp);
#if CB_HAS(CB_FEATURE_ANISOTROPIC)
        sp.tangent = dpdu;
#endif
        (void)dpdu;
        return sp;
    }
#endif
    Vec3 p0 = vec3FromGlobalArray(prim->p0);
    Vec3 p1 = vec3FromGlobalArray(prim->p1);
    Vec3 p2 = vec3FromGlobalArray(prim->p2);
    real b0 = 1.0f - hit.b1 - hit.b2;
    Vec3 w0 = vscale(p0, b0);
    Vec3 w1 = vscale(p1, hit.b1);
    Vec3 w2 = vscale(p2, hit.b2);
    sp.p = vadd(vadd(w0, w1), w2);
    /* pbrt 3rd ed. sec. 3.9.4 (triangles, barycentric interpolation): gamma(7) sum |b_i p_i|. */
    sp.pError = vscale(vadd(vadd(vabs(w0), vabs(w1)), vabs(w2)), cbGamma(7));
    sp.ng = triangleNormal(p0, p1, p2);
#if CB_HAS(CB_FEATURE_MIX_AT_POINT)
    sp.material = mixPartAtPoint(scene, sp.material, sp.p);
#endif
#if CB_HAS(CB_FEATURE_TEXTURE)
    /* (Host views of untextured scenes, such as the BVH choice's, have no texture buffer.) */
    if (scene->textures) sp.uv = triangleTexCoord(scene, hit.primitive, hit.b1, hit.b2);
#endif
    surfacePointForTextures(&sp);
    sp.ns = sp.ng;
#if CB_HAS(CB_FEATURE_SHADING_NORMALS)
    if (scene->shadingNormals) {
        /* pbrt-v4's Triangle::InteractionFromIntersection: the vertex normals interpolated by
         * the barycentrics, ng turned to the side of ns; a triangle without (zeros) keeps ng. */
        CB_GLOBAL const real* vn = scene->shadingNormals + 9 * hit.primitive;
        Vec3 ns = vadd(
            vadd(vscale(vec3FromGlobalArray(vn), b0), vscale(vec3FromGlobalArray(vn + 3), hit.b1)),
            vscale(vec3FromGlobalArray(vn + 6), hit.b2));
        real length2 = vlength2(ns);
        if (length2 > 0.0f && isfinite(length2)) {
            sp.ns = vscale(ns, 1.0f / sqrt(length2));
            if (vdot(sp.ns, sp.ng) < 0.0f) sp.ng = vneg(sp.ng);
        }
    }
#endif
#if CB_HAS(CB_FEATURE_NORMAL_MAP) || CB_HAS(CB_FEATURE_BUMP_MAP)
    sp = surfacePointMapped(scene, sp, hit, p0, p1, p2);
#endif
#if CB_HAS(CB_FEATURE_ANISOTROPIC)
    sp = surfacePointTangent(scene, sp, hit, p0, p1, p2);
#endif
    return sp;
}

/* pbrt-v4 OffsetRayOrigin: move p along n out of its error box, to the side w leaves
 * through, then round away from p so the rounding of the addition cannot undo the offset. */
CB_FN Vec3 offsetRayOrigin(Vec3 p, Vec3 pError, Vec3 n, Vec3 w) {
    real d = vdot(vabs(n), pError);
    Vec3 offset = vscale(n, d);
    if (vdot(w, n) < 0.0f) offset = vneg(offset);
    Vec3 po = vadd(p, offset);
    if (offset.x > 0.0f)
        po.x = cbNextFloatUp(po.x);
    else if (offset.x < 0.0f)
        po.x = cbNextFloatDown(po.x);
    if (offset.y > 0.0f)
        po.y = cbNextFloatUp(po.y);
    else if (offset.y < 0.0f)
        po.y = cbNextFloatDown(po.y);
    if (offset.z > 0.0f)
        po.z = cbNextFloatUp(po.z);
    else if (offset.z < 0.0f)
        po.z = cbNextFloatDown(po.z);
    return po;
}

CB_FN Ray spawnRay(SurfacePoint sp, Vec3 dir) {
    Ray r;
    r.o = offsetRayOrigin(sp.p, sp.pError, sp.ng, dir);
    r.d = dir;
    return r;
}

/* A ray from `origin` (already off its surface, or a point in a medium) to `target`, offset off
 * its surface towards the origin; the direction normalised, tMax just short of the offset
 * target; `fallback` the direction where the two meet. For a point light pass targetError =
 * targetNormal = 0. */
CB_FN Ray spawnRayFromTo(Vec3 origin, Vec3 fallback, Vec3 target, Vec3 targetError,
                         Vec3 targetNormal, real* tMax) {
    Ray r;
    r.o = origin;
    Vec3 pt = offsetRayOrigin(target, targetError, targetNormal, vsub(r.o, target));
    Vec3 d = vsub(pt, r.o);
    real len = vlength(d);
    if (len > 0.0f) {
        r.d = vscale(d, 1.0f / len);
        *tMax = len * (1.0f - CB_SHADOW_EPSILON);
    } else {
        r.d = fallback;
        *tMax = 0.0f;
    }
    return r;
}

/* pbrt-v4 SpawnRayTo between two interactions: both ends are offset off their surfaces
 * (spawnRayFromTo). */
CB_FN Ray spawnRayTo(SurfacePoint from, Vec3 target, Vec3 targetError, Vec3 targetNormal,
                     real* tMax) {
    return spawnRayFromTo(offsetRayOrigin(from.p, from.pError, from.ng, vsub(target, from.p)),
                          from.ng, target, targetError, targetNormal, tMax);
}

CB_END_NAMESPACE

#ifdef CB_KERNEL_SIDE
#pragma OPENCL FP_CONTRACT ON
#endif

#endif /* CB_INTERSECT_H */
