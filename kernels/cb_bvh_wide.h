/* cb_bvh_wide.h - a 4- or 8-wide BVH and its stackless traversal: sceneIntersect,
 * sceneIntersectCoherent (camera rays) and sceneOccluded, what every renderer (PT, BDPT,
 * CBDPT, MLT, their host builds) traces with.
 * The binary BVH of cb_bvh.h is what it is collapsed from; its traversals stay as the comparison
 * for cbdpt-bench and the tests (src/bench/kernels/bench_bvh_binary.h).
 *
 * One node holds the boxes of up to CB_BVH_WIDE_LANES children in structure-of-arrays form,
 * so one node visit tests all of them with the same instructions on all lanes (what Embree's
 * BVH4/BVH8 do with SSE/AVX). src/bvh/bvh_wide.cpp builds it by collapsing the binary BVH
 * (Wald, Benthin, Boulos 2008, "Getting rid of packets": repeatedly open the largest child).
 *
 * The traversal stays stackless and near-child-first: each node stores its parent, and the
 * order in which a node's children are visited is recomputed from the node whenever the
 * traversal returns to it. Children are ordered by the key (entry distance, lane), a strict
 * total order that depends only on the ray and the boxes; coming back up from child c, the
 * next child is the hit child with the smallest key above c's key. The set of hit children
 * only shrinks as the closest hit gets closer, so every child is visited at most once and in
 * the same order as with a stack. A leaf child's packs are tested without leaving the node,
 * which is then entered again as when coming back up from that child. */
#ifndef CB_BVH_WIDE_H
#define CB_BVH_WIDE_H

#include "cb_intersect.h"

CB_BEGIN_NAMESPACE

#define CB_BVHW_NONE 0xffffffffu

/* The interval of a box from its per-axis near and far distances: entry = the largest near
 * distance and 0, exit = the smallest far distance and tMax. fmax/fmin spelled as selects
 * with the running value second: `a > acc ? a : acc` is false for a NaN `a` and keeps acc,
 * which is fmax's NaN rule (acc is never NaN), and compiles to one maxss/minss instead of a
 * libm call on the host (g++ without -ffast-math) and a NaN-checking sequence in PoCL
 * (docs/performance.md). Shared with the binary BVH's box test
 * (src/bench/kernels/bench_bvh_binary.h). */
CB_FN void bvhSlabCombine(real nx, real ny, real nz, real fx, real fy, real fz, real tMax,
                          real* tNearOut, real* tFarOut) {
    real tNear = nx > 0.0f ? nx : 0.0f;
    tNear = ny > tNear ? ny : tNear;
    tNear = nz > tNear ? nz : tNear;
    real tFar = fx < tMax ? fx : tMax;
    tFar = fy < tFar ? fy : tFar;
    tFar = fz < tFar ? fz : tFar;
    *tNearOut = tNear;
    *tFarOut = tFar;
}

/* Children per node: 4 (SSE) or 8 (AVX). */
#ifndef CB_BVH_WIDE_LANES
#define CB_BVH_WIDE_LANES 8
#endif

/* 128 bytes (4 lanes) or 256 (8 lanes). lo/hi[axis][lane] are the children's boxes.
 * child[lane]: the child node for an interior child, the first TrianglePack for a leaf,
 * CB_BVHW_NONE for an empty lane (its box is empty as well). Interior children take the first
 * lanes and consecutive nodes, so the one at lane k is child[0] + k (bvhWideInteriorChild). counts:
 * byte `lane` is the leaf's number of packs (up to four primitives each), 0 for an interior child
 * or an empty lane. parent: the parent node, CB_BVHW_NONE for the root (node 0); lane: this node's
 * lane in its parent, so that coming back up needs no search. */
typedef struct BvhNodeWide {
    real lo[3][CB_BVH_WIDE_LANES];
    real hi[3][CB_BVH_WIDE_LANES];
    uint child[CB_BVH_WIDE_LANES];
    uint counts[CB_BVH_WIDE_LANES / 4];
    uint parent;
    uint lane;
    uint pad[CB_BVH_WIDE_LANES == 4 ? 1 : 4];
} BvhNodeWide;

CB_STATIC_ASSERT(sizeof(BvhNodeWide) == 32 * CB_BVH_WIDE_LANES,
                 "BvhNodeWide must be 32 bytes per lane");

CB_FN uint bvhWideCount(CB_GLOBAL const BvhNodeWide* node, int k) {
    return (node->counts[k >> 2] >> (8 * (k & 3))) & 0xffu;
}

/* Leading zero bits of a non-zero 64-bit value. */
#ifdef CB_KERNEL_SIDE
CB_FN int cbClz64(ulong v) {
    return (int)clz(v);
}
#else
CB_FN int cbClz64(ulong v) {
    return __builtin_clzll(v);
}
#endif

/* The interior child at lane k: child[0] is read with the rest of the node, so the next node's
 * address does not wait for a load that depends on the lane. */
CB_FN uint bvhWideInteriorChild(CB_GLOBAL const BvhNodeWide* node, int k) {
    return node->child[0] + (uint)k;
}

/* The slab test as one fused multiply-add per plane, t = fma(plane, inv, add), with inv and
 * add set up once per ray per axis so that the test stays conservative: it keeps every box
 * that pbrt's test keeps (3rd ed. sec. 3.9.2: entry <= exit * (1 + 2 gamma(3)), with the
 * distances computed as (plane - o) * inv). Per axis, with u = 2^-24:
 * - Entry planes: inv = (1/d)(1 - 4 gamma(3)) and add = -o * inv rounded down by two ulps. The
 *   FMA forms plane * inv + add exactly and rounds once, so the entry distance is at most
 *   (1 - 4 gamma(3) + 4 u) times the true one (the roundings of 1/d, the scale, inv and the
 *   result), below 1 / ((1 + 2 gamma(3))(1 + u)) because gamma(3) > 3 u.
 * - Exit planes: inv = 1/d and add = -o * inv rounded up by two ulps: at least (1 - 2 u)
 *   times the true distance. The test is then entry <= min(exit, closest), no multiplication.
 * - Flat axes, |1/d| >= 2^32 (a zero or subnormal direction component): inv = +-2^32, whose
 *   products are exact, so the entry distance has the exact sign of (plane - o) and the slab
 *   keeps or drops the box exactly as its side of the plane says; the exit addend also gets
 *   2^100, an exit never reached. Such an axis keeps at least the boxes of the exact test
 *   (scene coordinates below 2^60).
 * Nothing is ever NaN (no 0 * inf: empty lanes' infinite planes meet finite factors), so the
 * minimum and maximum are plain trees, two deep. Against the subtract-and-multiply form this
 * takes a dependent operation and a level of selects off every node visit. */
typedef struct BvhWideSlabs {
    Vec3 invNear, addNear; /* entry planes */
    Vec3 invFar, addFar;   /* exit planes */
} BvhWideSlabs;

#define CB_BVHW_FLAT 4294967296.0f        /* 2^32 */
#define CB_BVHW_NEVER 1.2676506e30f       /* 2^100 */
#define CB_BVHW_TWO_ULPS 2.384185791e-07f /* 2^-22 */
/* Also added outwards to both addends, so that they stay outward where two ulps underflow
 * (-o * inv near zero). The smallest normal float, not the smallest subnormal: camera rays
 * start at the device origin, where the addends are exactly this, and an Intel core takes a
 * microcode assist on every FMA with a subnormal operand (renders 40-90% slower). */
#define CB_BVHW_TINY 1.175494351e-38f /* 2^-126 */

/* One axis per lane of T (real on the host, float4 in the kernels: the three axes at once, a
 * quarter of the scalar set-up's instructions, which rays with few node visits notice), the
 * same arithmetic written once. The conditional operator selects lane by lane on vectors. */
#define CB_DEFINE_WIDE_SLAB_LANES(T, SUFFIX)                                                       \
    CB_FN void bvhWideSlabLanes##SUFFIX(T d, T o, T* invNear, T* addNear, T* invFar, T* addFar) {  \
        T inv = 1.0f / (d + 0.0f);                                                                 \
        T h = inv > 0.0f ? (T)(CB_BVHW_FLAT) : (T)(-CB_BVHW_FLAT);                                 \
        T n = inv * (1.0f - 4.0f * cbGamma(3));                                                    \
        T a = -o * n;                                                                              \
        T b = -o * inv;                                                                            \
        T oh = -o * h;                                                                             \
        T nearAdd = a - fabs(a) * CB_BVHW_TWO_ULPS - CB_BVHW_TINY;                                 \
        T farAdd = b + fabs(b) * CB_BVHW_TWO_ULPS + CB_BVHW_TINY;                                  \
        *invNear = fabs(inv) < CB_BVHW_FLAT ? n : h;                                               \
        *addNear = fabs(inv) < CB_BVHW_FLAT ? nearAdd : oh;                                        \
        *invFar = fabs(inv) < CB_BVHW_FLAT ? inv : h;                                              \
        *addFar = fabs(inv) < CB_BVHW_FLAT ? farAdd : oh + CB_BVHW_NEVER;                          \
    }
CB_DEFINE_WIDE_SLAB_LANES(real, )

#ifdef CB_KERNEL_SIDE
CB_DEFINE_WIDE_SLAB_LANES(float4, 4)

CB_FN BvhWideSlabs bvhWideSlabsOf(Vec3 o, Vec3 d) {
    float4 invNear, addNear, invFar, addFar;
    bvhWideSlabLanes4((float4)(d.x, d.y, d.z, 1.0f), (float4)(o.x, o.y, o.z, 0.0f), &invNear,
                      &addNear, &invFar, &addFar);
    BvhWideSlabs s;
    s.invNear = vec3(invNear.x, invNear.y, invNear.z);
    s.addNear = vec3(addNear.x, addNear.y, addNear.z);
    s.invFar = vec3(invFar.x, invFar.y, invFar.z);
    s.addFar = vec3(addFar.x, addFar.y, addFar.z);
    return s;
}
#else
CB_FN BvhWideSlabs bvhWideSlabsOf(Vec3 o, Vec3 d) {
    BvhWideSlabs s;
    bvhWideSlabLanes(d.x, o.x, &s.invNear.x, &s.addNear.x, &s.invFar.x, &s.addFar.x);
    bvhWideSlabLanes(d.y, o.y, &s.invNear.y, &s.addNear.y, &s.invFar.y, &s.addFar.y);
    bvhWideSlabLanes(d.z, o.z, &s.invNear.z, &s.addNear.z, &s.invFar.z, &s.addFar.z);
    return s;
}
#endif

/* The visiting order. A child's key is its entry distance with the 3 lowest mantissa bits
 * replaced by its lane: entry distances are never negative or NaN (bvhWideBoxes starts them at
 * +0), so the keys of one node are distinct, and compared as integers they order the children
 * by distance, ties (within 8 ulps) broken by lane. That is still a strict total order that
 * depends only on the ray and the boxes, which is all the traversal needs, and it lets the
 * kernels pick the next child with one integer minimum across the lanes. Any-hit queries use
 * the same near-first order: they stop at the first hit, and the near children hold it more
 * often (docs/performance.md: fewer instructions than lane order, shadow rays 0-10% faster). */
#ifdef CB_KERNEL_SIDE
/* The kernels test the lanes with OpenCL vectors (one SSE/AVX instruction per step under
 * PoCL). The selects are bvhSlabCombine's, lane by lane (see there for NaNs). */
#if CB_BVH_WIDE_LANES == 4
typedef float4 BvhWideReal;
typedef int4 BvhWideInt;
#define CB_BVHW_LOAD(p) vload4(0, p)
#define CB_BVHW_AS_INT(v) as_int4(v)
#define CB_BVHW_LANE_INDICES ((int4)(0, 1, 2, 3))
#define CB_BVHW_AS_REAL(v) as_float4(v)
CB_FN int bvhWideOrAll(int4 v) {
    int2 a = v.lo | v.hi;
    return a.x | a.y;
}
CB_FN int bvhWideMinAll(int4 v) {
    int2 a = min(v.lo, v.hi);
    return min(a.x, a.y);
}
#else
typedef float8 BvhWideReal;
typedef int8 BvhWideInt;
#define CB_BVHW_LOAD(p) vload8(0, p)
#define CB_BVHW_AS_INT(v) as_int8(v)
#define CB_BVHW_LANE_INDICES ((int8)(0, 1, 2, 3, 4, 5, 6, 7))
#define CB_BVHW_AS_REAL(v) as_float8(v)
CB_FN int bvhWideOrAll(int8 v) {
    int4 a = v.lo | v.hi;
    int2 b = a.lo | a.hi;
    return b.x | b.y;
}
CB_FN int bvhWideMinAll(int8 v) {
    /* Shuffles within one vector to the end: LLVM otherwise finishes the last step with a lane
     * extract and a scalar compare, a longer chain on the path that picks every next child. */
    int4 a = min(v.lo, v.hi);
    int4 b = min(a, a.zwxy);
    return min(b, b.yxwz).x;
}
#endif
typedef int BvhWideKey;

/* A lane mask (lanes 0 or -1) as bits, lane k in bit k: one movmskps where the target has it
 * (clang defines __SSE__/__AVX__ for PoCL's CPU targets), otherwise the sign bit of each lane's
 * byte gathered with a multiply (also forced by -DCB_PORTABLE_LANE_BITS, which the tests use to
 * check it). The bits replace the mask's bytes on the path from a node's boxes to its child:
 * two dependent instructions instead of four. */
CB_FN uint bvhWideBits(BvhWideInt mask) {
#if defined(__AVX__) && CB_BVH_WIDE_LANES == 8 && !defined(CB_PORTABLE_LANE_BITS)
    return (uint)__builtin_ia32_movmskps256(CB_BVHW_AS_REAL(mask));
#elif defined(__SSE__) && CB_BVH_WIDE_LANES == 4 && !defined(CB_PORTABLE_LANE_BITS)
    return (uint)__builtin_ia32_movmskps(CB_BVHW_AS_REAL(mask));
#elif CB_BVH_WIDE_LANES == 8
    ulong signs = as_ulong(convert_char8(mask)) & 0x8080808080808080UL;
    return (uint)((signs * 0x0002040810204081UL) >> 56);
#else
    uint signs = as_uint(convert_char4(mask)) & 0x80808080u;
    return (signs * 0x00204081u) >> 28;
#endif
}

/* Each lane's entry distance *tn and exit distance *far, the latter already clamped to
 * closest: the box is hit when tn <= far (see BvhWideSlabs). */
CB_FN BvhWideReal bvhWideMax(BvhWideReal a, BvhWideReal b) {
    return select(a, b, b > a);
}
CB_FN BvhWideReal bvhWideMin(BvhWideReal a, BvhWideReal b) {
    return select(a, b, b < a);
}

CB_FN void bvhWideBoxes(CB_GLOBAL const BvhNodeWide* node, Vec3 invNear, Vec3 addNear, Vec3 invFar,
                        Vec3 addFar, real closest, BvhWideReal* tn, BvhWideReal* far) {
    /* The near plane of each axis is lo where the direction is positive, hi where it is
     * negative (Williams et al. 2005), picked once per ray. */
    CB_GLOBAL const real* planes = &node->lo[0][0];
    bool px = invFar.x >= 0.0f, py = invFar.y >= 0.0f, pz = invFar.z >= 0.0f;
    BvhWideReal nx = fma(CB_BVHW_LOAD(planes + (px ? 0 : 3 * CB_BVH_WIDE_LANES)),
                         (BvhWideReal)(invNear.x), (BvhWideReal)(addNear.x));
    BvhWideReal fx = fma(CB_BVHW_LOAD(planes + (px ? 3 * CB_BVH_WIDE_LANES : 0)),
                         (BvhWideReal)(invFar.x), (BvhWideReal)(addFar.x));
    BvhWideReal ny = fma(CB_BVHW_LOAD(planes + (py ? CB_BVH_WIDE_LANES : 4 * CB_BVH_WIDE_LANES)),
                         (BvhWideReal)(invNear.y), (BvhWideReal)(addNear.y));
    BvhWideReal fy = fma(CB_BVHW_LOAD(planes + (py ? 4 * CB_BVH_WIDE_LANES : CB_BVH_WIDE_LANES)),
                         (BvhWideReal)(invFar.y), (BvhWideReal)(addFar.y));
    BvhWideReal nz =
        fma(CB_BVHW_LOAD(planes + (pz ? 2 * CB_BVH_WIDE_LANES : 5 * CB_BVH_WIDE_LANES)),
            (BvhWideReal)(invNear.z), (BvhWideReal)(addNear.z));
    BvhWideReal fz =
        fma(CB_BVHW_LOAD(planes + (pz ? 5 * CB_BVH_WIDE_LANES : 2 * CB_BVH_WIDE_LANES)),
            (BvhWideReal)(invFar.z), (BvhWideReal)(addFar.z));
    *tn = bvhWideMax(bvhWideMax(nx, (BvhWideReal)(0.0f)), bvhWideMax(ny, nz));
    *far = bvhWideMin(bvhWideMin(fx, (BvhWideReal)(closest)), bvhWideMin(fy, fz));
}

/* A cached node's far (bvhWideTraverse), clamped to the closest hit found since. */
CB_FN BvhWideReal bvhWideClamp(BvhWideReal far, real closest) {
    return select(far, (BvhWideReal)(closest), closest < far);
}

/* The keys of a node's lanes (see above). */
CB_FN BvhWideInt bvhWideKeys(BvhWideReal tn) {
    return (CB_BVHW_AS_INT(tn) & (BvhWideInt)(~7)) | CB_BVHW_LANE_INDICES;
}

/* Below every key: where a node is entered from its parent. */
CB_FN BvhWideKey bvhWideKeyNone(void) {
    return -1;
}

/* Defined starting values (PoCL keeps a copy per work-item of a value that may be undefined). */
CB_FN BvhWideReal bvhWideZeroReal(void) {
    return (BvhWideReal)(0.0f);
}
CB_FN BvhWideInt bvhWideZeroInt(void) {
    return (BvhWideInt)(0);
}

/* The key of lane k, coming back up from it. A select and a minimum, not a private array:
 * PoCL gives every private array a copy per work-item, stored to on every node visit. */
CB_FN BvhWideKey bvhWideKeyOf(BvhWideInt keys, int k) {
    return bvhWideMinAll(
        select((BvhWideInt)(INT_MAX), keys, CB_BVHW_LANE_INDICES == (BvhWideInt)(k)));
}

/* The candidates of bvhWideNext: the hit lanes above `after` as a mask, and for coherent
 * queries also as bits (bvhWideBits). */
typedef struct BvhWideCand {
    BvhWideInt mask;
    uint bits;
} BvhWideCand;

/* The hit lane with the smallest key above `after`, its key in *key; -1 if none. *cand: the
 * candidates, for bvhWideMore.
 *
 * `coherent` (a constant: a separate copy of the traversal) is for rays whose neighbours in
 * the work-group take the same path, camera rays above all. A lone candidate, their most
 * common case, is then found from the candidate bits with a leading-zero count, behind a
 * branch that predicts well for such rays; *key is then just the lane: nothing is left to
 * order after it. Incoherent closest-hit queries mispredict that branch, and are 0-10% slower
 * with it (docs/performance.md), so they always take the minimum across the lanes. Any-hit
 * queries, which stop at their first hit, are faster with it, incoherent or not. */
CB_FN int bvhWideNext(CB_GLOBAL const BvhNodeWide* node, BvhWideReal tn, BvhWideReal far,
                      BvhWideInt keys, BvhWideKey after, bool coherent, BvhWideKey* key,
                      BvhWideCand* cand) {
    BvhWideInt c = (CB_BVHW_LOAD(node->child) != CB_BVHW_NONE) & (tn <= far);
    /* Coming down every key is above `after`, so camera rays, for which the branch predicts
     * well, keep the compare off the descent's path; incoherent rays were 1-3% slower with it. */
    if (!coherent || after != bvhWideKeyNone()) c &= keys > after;
    cand->mask = c;
    if (coherent) {
        uint bits = bvhWideBits(c);
        cand->bits = bits;
        if (bits == 0u) return -1;
        if ((bits & (bits - 1u)) == 0u) {
            int lane = 31 - (int)clz(bits);
            *key = lane;
            return lane;
        }
    }
    int m = bvhWideMinAll(select((BvhWideInt)(INT_MAX), keys, c));
    if (m == INT_MAX) return -1;
    *key = m;
    return m & (CB_BVH_WIDE_LANES - 1);
}

/* Whether a candidate other than the lane bvhWideNext returned (with `key`) remains. */
CB_FN bool bvhWideMore(BvhWideCand cand, BvhWideInt keys, BvhWideKey key, bool coherent) {
    if (coherent) return (cand.bits & (cand.bits - 1u)) != 0u;
    return bvhWideOrAll(cand.mask & (keys != key)) != 0;
}
#else
/* The host: the same per-lane arithmetic as plain loops, and the same order: (entry distance
 * with its 3 lowest mantissa bits cleared, lane), lexicographically. */
typedef struct BvhWideReal {
    real v[CB_BVH_WIDE_LANES];
} BvhWideReal;
typedef struct BvhWideInt {
    real t[CB_BVH_WIDE_LANES];
} BvhWideInt;
typedef struct BvhWideKey {
    real t;
    int lane;
} BvhWideKey;
typedef int BvhWideCand;

CB_FN void bvhWideBoxes(CB_GLOBAL const BvhNodeWide* node, Vec3 invNear, Vec3 addNear, Vec3 invFar,
                        Vec3 addFar, real closest, BvhWideReal* tn, BvhWideReal* far) {
    bool px = invFar.x >= 0.0f, py = invFar.y >= 0.0f, pz = invFar.z >= 0.0f;
    for (int k = 0; k < CB_BVH_WIDE_LANES; ++k) {
        real nx = fma(px ? node->lo[0][k] : node->hi[0][k], invNear.x, addNear.x);
        real fx = fma(px ? node->hi[0][k] : node->lo[0][k], invFar.x, addFar.x);
        real ny = fma(py ? node->lo[1][k] : node->hi[1][k], invNear.y, addNear.y);
        real fy = fma(py ? node->hi[1][k] : node->lo[1][k], invFar.y, addFar.y);
        real nz = fma(pz ? node->lo[2][k] : node->hi[2][k], invNear.z, addNear.z);
        real fz = fma(pz ? node->hi[2][k] : node->lo[2][k], invFar.z, addFar.z);
        bvhSlabCombine(nx, ny, nz, fx, fy, fz, closest, &tn->v[k], &far->v[k]);
    }
}

CB_FN BvhWideReal bvhWideClamp(BvhWideReal far, real closest) {
    for (int k = 0; k < CB_BVH_WIDE_LANES; ++k)
        far.v[k] = closest < far.v[k] ? closest : far.v[k];
    return far;
}

/* Whether lane k holds a child whose box the ray enters (the kernels' mask, one lane). */
CB_FN bool bvhWideLaneHit(CB_GLOBAL const BvhNodeWide* node, BvhWideReal tn, BvhWideReal far,
                          int k) {
    return node->child[k] != CB_BVHW_NONE && tn.v[k] <= far.v[k];
}

CB_FN real bvhWideTruncate(real t) {
    if constexpr (sizeof(real) == sizeof(uint)) {
        uint bits;
        std::memcpy(&bits, &t, sizeof bits);
        bits &= ~7u;
        std::memcpy(&t, &bits, sizeof bits);
    } else {
        ulong bits;
        std::memcpy(&bits, &t, sizeof bits);
        bits &= ~(ulong)7u;
        std::memcpy(&t, &bits, sizeof bits);
    }
    return t;
}

CB_FN BvhWideInt bvhWideKeys(BvhWideReal tn) {
    BvhWideInt keys;
    for (int k = 0; k < CB_BVH_WIDE_LANES; ++k)
        keys.t[k] = bvhWideTruncate(tn.v[k]);
    return keys;
}

CB_FN BvhWideKey bvhWideKeyNone(void) {
    BvhWideKey key = {-CB_INFINITY, -1};
    return key;
}

CB_FN BvhWideReal bvhWideZeroReal(void) {
    return BvhWideReal{};
}
CB_FN BvhWideInt bvhWideZeroInt(void) {
    return BvhWideInt{};
}

CB_FN BvhWideKey bvhWideKeyOf(BvhWideInt keys, int k) {
    BvhWideKey key = {keys.t[k], k};
    return key;
}

CB_FN bool bvhWideKeyLess(BvhWideKey a, BvhWideKey b) {
    return a.t < b.t || (a.t == b.t && a.lane < b.lane);
}

/* *cand: how many hit lanes are above `after`. */
CB_FN int bvhWideNext(CB_GLOBAL const BvhNodeWide* node, BvhWideReal tn, BvhWideReal far,
                      BvhWideInt keys, BvhWideKey after, bool coherent, BvhWideKey* key,
                      int* cand) {
    (void)coherent;
    int best = -1;
    *cand = 0;
    *key = after; /* read only when a lane is returned; set so g++ can see that */
    for (int k = 0; k < CB_BVH_WIDE_LANES; ++k) {
        bool hit = bvhWideLaneHit(node, tn, far, k);
        BvhWideKey kk = bvhWideKeyOf(keys, k);
        if (!hit || !bvhWideKeyLess(after, kk)) continue;
        ++*cand;
        if (best < 0 || bvhWideKeyLess(kk, *key)) {
            best = k;
            *key = kk;
        }
    }
    return best;
}

CB_FN bool bvhWideMore(int cand, BvhWideInt keys, BvhWideKey key, bool coherent) {
    (void)keys;
    (void)key;
    (void)coherent;
    return cand > 1;
}
#endif

/* The kernels get one copy of the traversal for closest hits and one for any hits, each with
 * `closestHit` a constant: left to itself, LLVM kept a single out-of-line copy that tested the
 * flag at run time, for the many call sites of the path code. */
#ifdef CB_KERNEL_SIDE
#define CB_BVHW_SPECIALISE __attribute__((always_inline))
#define CB_BVHW_ONE_COPY __attribute__((noinline))
#else
#define CB_BVHW_SPECIALISE
#define CB_BVHW_ONE_COPY
#endif

/* CB_TREE_PREFETCH 1 (the host's choice for CPU devices, treePrefetchPays of
 * src/bvh/bvh_wide.h): for a tree larger than the device's cache, a traversal coming down to a
 * node asks for the children it will enter after the next one (a packet: all it will enter,
 * cb_bvh_ray_packet.h), whose loads then overlap its work on the nearer ones. A tree that fits
 * gains nothing and pays the requests (docs/performance.md, "What was tried"). */
#ifndef CB_TREE_PREFETCH
#define CB_TREE_PREFETCH 0
#endif
#if defined(CB_KERNEL_SIDE) && CB_TREE_PREFETCH
/* Prefetches the children of `node` in `lanes` (bits): an interior child's node (four cache
 * lines), a leaf's first pack (176 bytes). */
CB_FN __attribute__((always_inline)) void bvhWidePrefetch(CB_GLOBAL const BvhNodeWide* nodes,
                                                          CB_GLOBAL const TrianglePack* packs,
                                                          CB_GLOBAL const BvhNodeWide* node,
                                                          uint lanes) {
    while (lanes != 0u) {
        const int c = 31 - (int)clz(lanes & (0u - lanes));
        lanes &= lanes - 1u;
        if (bvhWideCount(node, c) == 0u) {
            CB_GLOBAL const char* p =
                (CB_GLOBAL const char*)(nodes + bvhWideInteriorChild(node, c));
            __builtin_prefetch(p);
            __builtin_prefetch(p + 64);
            __builtin_prefetch(p + 128);
            __builtin_prefetch(p + 192);
        } else {
            CB_GLOBAL const char* p = (CB_GLOBAL const char*)(packs + node->child[c]);
            __builtin_prefetch(p);
            __builtin_prefetch(p + 64);
            __builtin_prefetch(p + 128);
        }
    }
}
#endif

/* Closest hit (closestHit) or any hit (!closestHit: returns at the first one found, in the
 * same near-first order) with t in (0, tMax). `coherent`: see bvhWideNext; it changes how
 * the next child is found, never which, so the answer is the same either way. hitScene: as
 * intersectPack's. */
CB_FN CB_BVHW_SPECIALISE bool bvhWideTraverse(CB_GLOBAL const BvhNodeWide* nodes,
                                              CB_GLOBAL const TrianglePack* packs,
                                              CB_GLOBAL const Primitive* prims, Ray ray, real tMax,
                                              bool closestHit, bool coherent, Hit* hit,
                                              const SceneView* hitScene) {
    hit->t = tMax;
    hit->primitive = -1;
    hit->b1 = 0.0f;
    hit->b2 = 0.0f;
    BvhWideSlabs slabs = bvhWideSlabsOf(ray.o, ray.d);
    TriangleRay sheared = triangleRayOf(ray);
    real closest = tMax;
    bool found = false;
    uint cur = 0u;
    int fromLane = -1; /* the lane just finished when coming back up, -1 coming down */
    /* Trail: bit d says the node at depth d (root 0) may still have children to visit after
     * the one being traversed. Coming back up to a node whose bit is clear skips its box tests
     * and goes on up. A clear bit is exact when it is written (no hit child after the chosen
     * one) and stays exact, because the closest hit only shrinks; depths >= 64 are not
     * recorded and always tested. One register, not a stack. */
    ulong trail = 0;
    int depth = 0;
    /* The last node left with children still to visit, with its lanes' distances and keys:
     * coming back up to it reuses them instead of testing its boxes again (far clamped to the
     * closest hit found since). They depend only on the node and the ray, so the order and the
     * hits are the same; this saves the box tests of most returns (a stack would hold a child
     * per level, this holds one node's lanes, in registers). Coherent queries only (see
     * bvhWideNext): incoherent closest-hit queries were 3-5% slower with it. */
    uint cachedNode = CB_BVHW_NONE;
    int cachedDepth = -1, cachedLane = -1;     /* its depth and the lane it was left through */
    BvhWideKey cachedAfter = bvhWideKeyNone(); /* that lane's key */
    BvhWideReal cachedTn = bvhWideZeroReal(), cachedFar = bvhWideZeroReal();
    BvhWideInt cachedKeys = bvhWideZeroInt();
    for (;;) {
        CB_GLOBAL const BvhNodeWide* node = nodes + cur;
        BvhWideReal tn, far;
        BvhWideInt keys;
        BvhWideKey after;
        if (coherent && cur == cachedNode && fromLane == cachedLane) {
            tn = cachedTn;
            far = bvhWideClamp(cachedFar, closest);
            keys = cachedKeys;
            after = cachedAfter;
        } else {
            bvhWideBoxes(node, slabs.invNear, slabs.addNear, slabs.invFar, slabs.addFar, closest,
                         &tn, &far);
            keys = bvhWideKeys(tn);
            after = fromLane >= 0 ? bvhWideKeyOf(keys, fromLane) : bvhWideKeyNone();
        }
        BvhWideKey key = after;
        BvhWideCand cand;
        int k = bvhWideNext(node, tn, far, keys, after, coherent, &key, &cand);
#if defined(CB_KERNEL_SIDE) && CB_TREE_PREFETCH
        /* Coming down: the candidates after the one entered next. Not for camera rays (the
         * coherent closest-hit copy), where it measured 0-2% slower. */
        if (!(coherent && closestHit) && fromLane < 0 && k >= 0)
            bvhWidePrefetch(nodes, packs, node, bvhWideBits(cand.mask) & ~(1u << k));
#endif
        if (k >= 0) {
            bool more = bvhWideMore(cand, keys, key, coherent);
            uint count = bvhWideCount(node, k);
            if (count == 0u) {
                if (depth < 64) {
                    ulong bit = (ulong)1 << depth;
                    trail = more ? (trail | bit) : (trail & ~bit);
                }
                if (coherent && more) {
                    cachedNode = cur;
                    cachedDepth = depth;
                    cachedLane = k;
                    cachedAfter = key;
                    cachedTn = tn;
                    cachedFar = far;
                    cachedKeys = keys;
                } else if (coherent && cur == cachedNode) {
                    cachedNode = CB_BVHW_NONE; /* left for the last time */
                    cachedDepth = -1;
                }
                fromLane = -1;
                cur = bvhWideInteriorChild(node, k);
                ++depth;
                continue;
            }
            uint first = node->child[k];
            for (uint p = first; p < first + count; ++p) {
                Hit h;
                if (intersectPack(packs + p, prims, ray, sheared, closest, closestHit, &h,
                                  hitScene)) {
                    if (!closestHit) return true;
                    *hit = h;
                    closest = h.t;
                    found = true;
                }
            }
            /* The node's other candidates: enter it again as if back from a child, which tests
             * its boxes once more (the closest hit may be nearer now). Keeping the lanes'
             * distances and keys instead made them live across the pack tests, whose registers
             * they need: LLVM then kept them in stack slots, and every pick, on every node
             * visit, read them back on the path from the boxes to the next child. Primary rays
             * are 4-8% faster this way (docs/performance.md). */
            if (more) {
                fromLane = k;
                continue;
            }
        }
        /* Up to the nearest ancestor that may have children left. While every ancestor's trail
         * bit is recorded (depth <= 64), the highest set bit below the current depth is its
         * depth: none means the traversal is over, without climbing to the root through a
         * chain of dependent parent loads; and when it is the cached node's depth, the
         * cached node is that ancestor (its bit was last written when the cache was), and
         * the traversal goes there at once. Otherwise it climbs. */
        if (depth <= 64) {
            ulong below = depth == 64 ? trail : (trail & (((ulong)1 << depth) - (ulong)1));
            if (below == 0) return found;
            if (coherent && 63 - (int)cbClz64(below) == cachedDepth) {
                cur = cachedNode;
                fromLane = cachedLane;
                depth = cachedDepth;
                continue;
            }
        }
        for (;;) {
            if (cur == 0u) return found;
            fromLane = (int)nodes[cur].lane;
            cur = nodes[cur].parent;
            --depth;
            if (depth >= 64 || ((trail >> depth) & 1u) != 0u) break;
        }
    }
    return found;
}

/* The out-of-line entry points take the ray's origin and direction apart: a 24-byte Ray passed by
 * value goes through the stack, and copying its narrow stores as wide loads stalled store
 * forwarding (about 4% of BDPT's samples); two Vec3 travel in registers. */
CB_FN CB_BVHW_ONE_COPY bool sceneIntersectFrom(const SceneView* scene, Vec3 o, Vec3 d, real tMax,
                                               Hit* hit) {
    Ray ray = {o, d};
    return bvhWideTraverse(scene->nodes, scene->packs, scene->primitives, ray, tMax, true, false,
                           hit, scene);
}
CB_FN CB_BVHW_ONE_COPY bool sceneIntersectCoherentFrom(const SceneView* scene, Vec3 o, Vec3 d,
                                                       real tMax, Hit* hit) {
    Ray ray = {o, d};
    return bvhWideTraverse(scene->nodes, scene->packs, scene->primitives, ray, tMax, true, true,
                           hit, scene);
}
CB_FN CB_BVHW_ONE_COPY bool sceneOccludedFrom(const SceneView* scene, Vec3 o, Vec3 d, real tMax) {
    Ray ray = {o, d};
    Hit h;
    return bvhWideTraverse(scene->nodes, scene->packs, scene->primitives, ray, tMax, false, true,
                           &h, scene);
}

/* Closest hit with t in (0, tMax). On a miss *hit is left as {tMax, -1, 0, 0}, so it is
 * never read uninitialised. */
CB_FN bool sceneIntersect(const SceneView* scene, Ray ray, real tMax, Hit* hit) {
    return sceneIntersectFrom(scene, ray.o, ray.d, tMax, hit);
}

/* sceneIntersect for camera rays, whose neighbours in a work-group are neighbouring pixels:
 * the same hit, found with the coherent traversal (bvhWideNext). */
CB_FN bool sceneIntersectCoherent(const SceneView* scene, Ray ray, real tMax, Hit* hit) {
    return sceneIntersectCoherentFrom(scene, ray.o, ray.d, tMax, hit);
}

/* Any hit with t in (0, tMax): shadow rays stop at the first one. With the coherent traversal
 * whatever the rays: measured faster for any-hit queries, incoherent ones included (shadow and
 * incoherent any-hit rays 0-7%, every renderer 1-4%; docs/performance.md). */
CB_FN bool sceneOccluded(const SceneView* scene, Ray ray, real tMax) {
    return sceneOccludedFrom(scene, ray.o, ray.d, tMax);
}

CB_END_NAMESPACE

#endif /* CB_BVH_WIDE_H */
