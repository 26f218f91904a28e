/* cb_bvh_ray_packet.h - packets of CB_RAY_PACKET rays (8 or 16), each packet traced by one
 * work-item through the wide BVH (cb_bvh_wide.h): how CPT (pt.cl) and CBDPT (cbdpt_packets.cl)
 * trace their coherent rays, and cbdpt-bench's `--traversal ray8` and `ray16`. Kernel code only.
 *
 * The work-group-wide packet of src/bench/kernels/bench_bvh_packet.h paid for its shared node
 * sequence with a barrier per node visit, across which PoCL stores and reloads every live value.
 * Here one work-item holds a tile of rays in vector registers (Embree's rtcIntersect8/16 layout:
 * structure of arrays, a ray per lane; 4 x 2 pixels for 8 rays, 4 x 4 for 16) and walks one node
 * sequence for all of them, without barriers: per node it tests each child's box against the
 * packet's rays at once, and enters a child when any live ray hits it within its own closest
 * hit. Still without a stack, as cb_bvh_wide.h: the children's order must be the same on every
 * return to a node, so it is the order of one representative ray (the mean of the packet's
 * active rays) by cb_bvh_wide.h's integer keys, which depend only on the node and that ray. The
 * set of children any ray still hits only shrinks as the closest hits get closer, so the trail
 * stays exact and every child is visited at most once. A leaf's triangles are tested the other
 * way round from the single-ray traversal's packs: one triangle against the packet's rays
 * (cbTriangleLanes of cb_intersect.h with a lane per ray), for the rays whose own box test kept
 * the leaf. Each ray gets the single-ray traversal's answer, up to which of two hits within
 * rounding of each other is kept (the triangles of a pack are tested one after the other,
 * against the closest hit so far).
 *
 * The width is the host's choice per device (kernel_integrator.cpp, rayPacketWidth): 16 where
 * the device's native float vectors have 16 lanes (AVX-512 under PoCL, one zmm register per
 * value), else 8 (docs/performance.md, "Packets in CPT and CBDPT"). */
#ifndef CB_BVH_RAY_PACKET_H
#define CB_BVH_RAY_PACKET_H
#ifdef CB_KERNEL_SIDE

#include "cb_bvh_group.h"

#ifndef CB_RAY_PACKET
#define CB_RAY_PACKET 8
#endif

/* The sum of eight lanes, pairwise. */
CB_FN float rayPacketSum8(float8 v) {
    const float4 a = v.lo + v.hi;
    const float2 b = a.lo + a.hi;
    return b.x + b.y;
}

/* What differs between the widths: the lane types, their lane numbers, a packet's gather of
 * field f of its rays a[index.s0], a[index.s1], ... and its lanes as bits (bvhWideBits per eight
 * lanes). */
#if CB_RAY_PACKET == 16
typedef float16 RayPacketReal;
typedef int16 RayPacketInt;
#define CB_RAY_PACKET_LANES ((RayPacketInt)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15))
#define CB_RAY_PACKET_LOAD(p, a) vload16(p, a)
#define CB_RAY_PACKET_AS_INT(v) as_int16(v)
#define CB_RAY_PACKET_GATHER(a, index, f)                                                          \
    (RayPacketReal)(a[index.s0] f, a[index.s1] f, a[index.s2] f, a[index.s3] f, a[index.s4] f,     \
                    a[index.s5] f, a[index.s6] f, a[index.s7] f, a[index.s8] f, a[index.s9] f,     \
                    a[index.sa] f, a[index.sb] f, a[index.sc] f, a[index.sd] f, a[index.se] f,     \
                    a[index.sf] f)
CB_FN uint rayPacketBits(RayPacketInt mask) {
    return bvhWideBits(mask.lo) | (bvhWideBits(mask.hi) << 8);
}
CB_FN int rayPacketOrAll(RayPacketInt v) {
    return bvhWideOrAll(v.lo | v.hi);
}
/* The sum of the lanes where mask is set (the representative ray). */
CB_FN float rayPacketSum(RayPacketReal v, RayPacketInt mask) {
    const RayPacketReal m = select((RayPacketReal)(0.0f), v, mask);
    return rayPacketSum8(m.lo + m.hi);
}
#elif CB_RAY_PACKET == 8
typedef float8 RayPacketReal;
typedef int8 RayPacketInt;
#define CB_RAY_PACKET_LANES ((RayPacketInt)(0, 1, 2, 3, 4, 5, 6, 7))
#define CB_RAY_PACKET_LOAD(p, a) vload8(p, a)
#define CB_RAY_PACKET_AS_INT(v) as_int8(v)
#define CB_RAY_PACKET_GATHER(a, index, f)                                                          \
    (RayPacketReal)(a[index.s0] f, a[index.s1] f, a[index.s2] f, a[index.s3] f, a[index.s4] f,     \
                    a[index.s5] f, a[index.s6] f, a[index.s7] f)
CB_FN uint rayPacketBits(RayPacketInt mask) {
    return bvhWideBits(mask);
}
CB_FN int rayPacketOrAll(RayPacketInt v) {
    return bvhWideOrAll(v);
}
CB_FN float rayPacketSum(RayPacketReal v, RayPacketInt mask) {
    return rayPacketSum8(select((RayPacketReal)(0.0f), v, mask));
}
#else
#error "CB_RAY_PACKET must be 8 or 16"
#endif

/* bvhWideSlabLanesP: the slab set-up of cb_bvh_wide.h, a lane per ray. */
CB_DEFINE_WIDE_SLAB_LANES(RayPacketReal, P)

/* Lane j of v (j not a constant): a select and an OR across the lanes, not a private array
 * (PoCL gives every private array a copy per work-item); exact, the other lanes' bits being
 * zeros, and folded to a lane extract where j is a constant. */
CB_FN int rayPacketLaneInt(RayPacketInt v, int j) {
    return rayPacketOrAll(select((RayPacketInt)(0), v, CB_RAY_PACKET_LANES == (RayPacketInt)(j)));
}
CB_FN float rayPacketLaneReal(RayPacketReal v, int j) {
    return as_float(rayPacketLaneInt(CB_RAY_PACKET_AS_INT(v), j));
}

/* The nearer and farther of two lanes, bvhWideMax and bvhWideMin's selects (NaNs there). */
CB_FN RayPacketReal rayPacketMax(RayPacketReal a, RayPacketReal b) {
    return select(a, b, b > a);
}
CB_FN RayPacketReal rayPacketMin(RayPacketReal a, RayPacketReal b) {
    return select(a, b, b < a);
}

/* The packet's slab set-up (BvhWideSlabs, lane by lane) and the signs of their directions
 * (lanes -1 where positive, as bvhWideBoxes's per-ray choice of the near plane). */
typedef struct RayPacketSlabs {
    RayPacketReal invNearX, invNearY, invNearZ, addNearX, addNearY, addNearZ;
    RayPacketReal invFarX, invFarY, invFarZ, addFarX, addFarY, addFarZ;
    RayPacketInt posX, posY, posZ;
    /* Whether every live ray's direction has the same signs (a packet of neighbouring pixels
     * almost always): then the near planes are picked once per child, not per lane. */
    bool uniform;
    bool px, py, pz;
} RayPacketSlabs;

/* Which of the packet's rays enter child c's box before their closest hit (lanes -1): bvhWideBoxes
 * for one child and the packet's rays. A ray that is done has closest < 0, below every entry. */
CB_FN __attribute__((always_inline)) RayPacketInt rayPacketBox(CB_GLOBAL const BvhNodeWide* node,
                                                               int c, const RayPacketSlabs* s,
                                                               RayPacketReal closest) {
    RayPacketReal lx = (RayPacketReal)(node->lo[0][c]), hx = (RayPacketReal)(node->hi[0][c]);
    RayPacketReal ly = (RayPacketReal)(node->lo[1][c]), hy = (RayPacketReal)(node->hi[1][c]);
    RayPacketReal lz = (RayPacketReal)(node->lo[2][c]), hz = (RayPacketReal)(node->hi[2][c]);
    RayPacketReal nearX, farX, nearY, farY, nearZ, farZ;
    if (s->uniform) {
        nearX = s->px ? lx : hx;
        farX = s->px ? hx : lx;
        nearY = s->py ? ly : hy;
        farY = s->py ? hy : ly;
        nearZ = s->pz ? lz : hz;
        farZ = s->pz ? hz : lz;
    } else {
        nearX = select(hx, lx, s->posX);
        farX = select(lx, hx, s->posX);
        nearY = select(hy, ly, s->posY);
        farY = select(ly, hy, s->posY);
        nearZ = select(hz, lz, s->posZ);
        farZ = select(lz, hz, s->posZ);
    }
    RayPacketReal nx = fma(nearX, s->invNearX, s->addNearX);
    RayPacketReal fx = fma(farX, s->invFarX, s->addFarX);
    RayPacketReal ny = fma(nearY, s->invNearY, s->addNearY);
    RayPacketReal fy = fma(farY, s->invFarY, s->addFarY);
    RayPacketReal nz = fma(nearZ, s->invNearZ, s->addNearZ);
    RayPacketReal fz = fma(farZ, s->invFarZ, s->addFarZ);
    RayPacketReal tn = rayPacketMax(rayPacketMax(nx, (RayPacketReal)(0.0f)), rayPacketMax(ny, nz));
    RayPacketReal far = rayPacketMin(rayPacketMin(fx, closest), rayPacketMin(fy, fz));
    return tn <= far;
}

/* The watertight test's per-ray set-up (TriangleRay) for the packet's rays at once: each lane its
 * ray's permutation (kxLanes, kyLanes, kzLanes); when the live rays' directions share the largest
 * axis (uniformAxis) the permutation is one for all (kx, ky, kz), and a vertex's coordinates are
 * picked once for the packet rather than lane by lane. */
typedef struct RayPacketSheared {
    bool uniformAxis;
    int kx, ky, kz;
    RayPacketInt kxLanes, kyLanes, kzLanes;
    RayPacketReal sx, sy, sz, ox, oy, oz;
} RayPacketSheared;

/* Lane by lane: x, y or z by that lane's axis k (0, 1, 2), as vcomponent. */
CB_FN RayPacketReal rayPacketComponent(RayPacketReal x, RayPacketReal y, RayPacketReal z,
                                       RayPacketInt k) {
    return select(select(z, y, k == (RayPacketInt)(1)), x, k == (RayPacketInt)(0));
}

/* Vertex i of a pack's triangle l in the packet's rays' permuted frames, relative to their
 * origins. */
CB_FN __attribute__((always_inline)) void rayPacketVertex(CB_GLOBAL const TrianglePack* pack, int i,
                                                          int l, const RayPacketSheared* sh,
                                                          RayPacketReal* px, RayPacketReal* py,
                                                          RayPacketReal* pz) {
    if (sh->uniformAxis) {
        *px = (RayPacketReal)(pack->v[i][sh->kx][l]) - sh->ox;
        *py = (RayPacketReal)(pack->v[i][sh->ky][l]) - sh->oy;
        *pz = (RayPacketReal)(pack->v[i][sh->kz][l]) - sh->oz;
    } else {
        const RayPacketReal x = (RayPacketReal)(pack->v[i][0][l]),
                            y = (RayPacketReal)(pack->v[i][1][l]),
                            z = (RayPacketReal)(pack->v[i][2][l]);
        *px = rayPacketComponent(x, y, z, sh->kxLanes) - sh->ox;
        *py = rayPacketComponent(x, y, z, sh->kyLanes) - sh->oy;
        *pz = rayPacketComponent(x, y, z, sh->kzLanes) - sh->oz;
    }
}

/* No fused multiply-adds in the triangle test, as in cb_intersect.h (whose pragma ends with
 * it): the edge functions must be exactly antisymmetric for the test to stay watertight. */
#pragma OPENCL FP_CONTRACT OFF
CB_DEFINE_TRIANGLE_ARITHMETIC(RayPacketReal, P)
CB_FN bool rayPacketAnyLane(RayPacketInt mask) {
    return rayPacketOrAll(mask) != 0;
}
/* cbTriangleLanesP: the pack test of cb_intersect.h with a lane per ray. */
CB_DEFINE_TRIANGLE_LANES(RayPacketReal, RayPacketInt, RayPacketReal, P, rayPacketAnyLane)

/* The hits of ray j (one lane) recorded in the packet's lanes. */
CB_FN void rayPacketRecord(int j, Hit h, bool closestHit, RayPacketReal* closest,
                           RayPacketInt* found, RayPacketInt* hitPrim, RayPacketReal* hitB1,
                           RayPacketReal* hitB2) {
    const RayPacketInt at = CB_RAY_PACKET_LANES == (RayPacketInt)(j);
    *found |= at;
    *closest = select(*closest, (RayPacketReal)(closestHit ? h.t : -1.0f), at);
    if (!closestHit) return;
    *hitPrim = select(*hitPrim, (RayPacketInt)(h.primitive), at);
    *hitB1 = select(*hitB1, (RayPacketReal)(h.b1), at);
    *hitB2 = select(*hitB2, (RayPacketReal)(h.b2), at);
}

/* A leaf's packs first .. first + count - 1 against the rays of rayBits (bit j: lane j). Each
 * triangle is tested against the packet's rays at once, each in its own permuted frame
 * (rayPacketVertex): the pack test's arithmetic (cbTriangleLanesP) with the roles of lanes turned
 * (a lane per ray, not per triangle), lanes that would take its double-precision path decided one
 * by one by intersectPrimitiveSheared, as intersectPack decides them. Packs of other primitives
 * go ray by ray through intersectPack, and so do any-hit queries whose rays' largest axes
 * differ: there each ray's own pack test, which stops at its first hit, was faster. Triangles are
 * taken in order, each against the closest hit so far, so the nearest hit wins and the first
 * triangle among equal distances, as in intersectPack; an alpha-tested triangle's hits count
 * where alphaKeepsHit keeps them (hitScene, as intersectPack's). A ray that is done (an any-hit
 * query that hit) gets closest -1 and takes no further part. */
CB_FN __attribute__((always_inline)) void
rayPacketLeaf(CB_GLOBAL const TrianglePack* packs, CB_GLOBAL const Primitive* prims,
              CB_GLOBAL const Ray* rays, RayPacketInt index, uint first, uint count, uint rayBits,
              const RayPacketSheared* sh, bool closestHit, RayPacketReal* closest,
              RayPacketInt* found, RayPacketInt* hitPrim, RayPacketReal* hitB1,
              RayPacketReal* hitB2, const SceneView* hitScene) {
    const RayPacketInt mask = ((RayPacketInt)((int)rayBits) &
                               ((RayPacketInt)(1) << CB_RAY_PACKET_LANES)) != (RayPacketInt)(0);
    for (uint p = first; p < first + count; ++p) {
        CB_GLOBAL const TrianglePack* pack = packs + p;
        uint bits = rayBits & rayPacketBits(*closest >= (RayPacketReal)(0.0f));
        if (bits == 0u) return;
        if (pack->scalar || (!sh->uniformAxis && !closestHit)) {
            while (bits != 0u) {
                const int j = 31 - (int)clz(bits & (0u - bits));
                bits &= bits - 1u;
                const Ray ray = rays[rayPacketLaneInt(index, j)];
                Hit h;
                if (intersectPack(pack, prims, ray, triangleRayOf(ray),
                                  rayPacketLaneReal(*closest, j), closestHit, &h, hitScene))
                    rayPacketRecord(j, h, closestHit, closest, found, hitPrim, hitB1, hitB2);
            }
            continue;
        }
        for (int l = 0; l < pack->count; ++l) {
            const RayPacketInt live = mask & (*closest >= (RayPacketReal)(0.0f));
            RayPacketReal t, b1, b2, p0x, p0y, p0z, p1x, p1y, p1z, p2x, p2y, p2z;
            RayPacketInt slow;
            rayPacketVertex(pack, 0, l, sh, &p0x, &p0y, &p0z);
            rayPacketVertex(pack, 1, l, sh, &p1x, &p1y, &p1z);
            rayPacketVertex(pack, 2, l, sh, &p2x, &p2y, &p2z);
            /* Every lane its own answer (closestHit true: no return at the first hit). */
            if (cbTriangleLanesP(p0x, p0y, p0z, p1x, p1y, p1z, p2x, p2y, p2z, sh->sx, sh->sy,
                                 sh->sz, *closest, live, true, &t, &b1, &b2, &slow) == CB_PACK_MISS)
                continue;
            RayPacketInt exact = t < (RayPacketReal)(INFINITY);
#if CB_HAS(CB_FEATURE_ALPHA)
            /* An alpha-tested triangle: the rays whose hit the alpha test skips keep theirs. */
            if (pack->alphaTested) {
                uint kept = rayPacketBits(exact);
                for (uint bits = kept; bits != 0u; bits &= bits - 1u) {
                    const int j = 31 - (int)clz(bits & (0u - bits));
                    if (!alphaKeepsHit(hitScene, pack->prim[l], rays[rayPacketLaneInt(index, j)],
                                       rayPacketLaneReal(b1, j), rayPacketLaneReal(b2, j)))
                        kept &= ~(1u << j);
                }
                exact &= ((RayPacketInt)((int)kept) & ((RayPacketInt)(1) << CB_RAY_PACKET_LANES)) !=
                         (RayPacketInt)(0);
            }
#endif
            *found |= exact;
            if (closestHit) {
                *closest = select(*closest, t, exact);
                *hitPrim = select(*hitPrim, (RayPacketInt)(pack->prim[l]), exact);
                *hitB1 = select(*hitB1, b1, exact);
                *hitB2 = select(*hitB2, b2, exact);
            } else {
                *closest = select(*closest, (RayPacketReal)(-1.0f), exact);
            }
            uint slowBits = rayPacketBits(slow);
            while (slowBits != 0u) {
                const int j = 31 - (int)clz(slowBits & (0u - slowBits));
                slowBits &= slowBits - 1u;
                const Ray ray = rays[rayPacketLaneInt(index, j)];
                const real rayClosest = rayPacketLaneReal(*closest, j);
                /* intersectPrimitiveSheared leaves the primitive to its caller. */
                Hit h = {rayClosest, pack->prim[l], 0.0f, 0.0f};
                if (intersectPrimitiveSheared(prims + pack->prim[l], ray, triangleRayOf(ray),
                                              rayClosest, &h, hitScene, true) &&
                    (!CB_HAS(CB_FEATURE_ALPHA) || !pack->alphaTested ||
                     alphaKeepsHit(hitScene, pack->prim[l], ray, h.b1, h.b2)))
                    rayPacketRecord(j, h, closestHit, closest, found, hitPrim, hitB1, hitB2);
            }
        }
    }
}
#pragma OPENCL FP_CONTRACT ON

/* The rays of one packet, rays[index[0 .. CB_RAY_PACKET - 1]] (index < 0: no ray), each with t in
 * (0, tMax) (tMax <= 0: an inactive ray, a miss), traced together: closest hits (closestHit) into
 * hitT, hitPrim, hitB1, hitB2 (t, primitive, b1, b2 per lane, as bvhWideTraverse's Hit), or any
 * hits (!closestHit) as the lanes of the returned mask. Returns the lanes that hit. */
CB_FN __attribute__((always_inline)) RayPacketInt
rayPacketTraverse(CB_GLOBAL const BvhNodeWide* nodes, CB_GLOBAL const TrianglePack* packs,
                  CB_GLOBAL const Primitive* prims, CB_GLOBAL const Ray* rays,
                  CB_GLOBAL const float* tMaxes, RayPacketInt index, bool closestHit,
                  RayPacketReal* hitT, RayPacketInt* hitPrim, RayPacketReal* hitB1,
                  RayPacketReal* hitB2, const SceneView* hitScene) {
    /* index < 0: no ray (padding of the last packet), an inactive lane. */
    const RayPacketInt valid = index >= (RayPacketInt)(0);
    index = select((RayPacketInt)(0), index, valid);
    const RayPacketReal ox = CB_RAY_PACKET_GATHER(rays, index, .o.x),
                        oy = CB_RAY_PACKET_GATHER(rays, index, .o.y),
                        oz = CB_RAY_PACKET_GATHER(rays, index, .o.z);
    const RayPacketReal dx = CB_RAY_PACKET_GATHER(rays, index, .d.x),
                        dy = CB_RAY_PACKET_GATHER(rays, index, .d.y),
                        dz = CB_RAY_PACKET_GATHER(rays, index, .d.z);
    const RayPacketReal tMax = CB_RAY_PACKET_GATHER(tMaxes, index, );
    const RayPacketInt active = (tMax > (RayPacketReal)(0.0f)) & valid;
    /* Live rays keep their closest hit here; a ray that is done (inactive, or an any-hit query
     * that hit) has -1, which no box is entered before. */
    RayPacketReal closest = select((RayPacketReal)(-1.0f), tMax, active);
    *hitT = tMax;
    *hitPrim = (RayPacketInt)(-1);
    *hitB1 = (RayPacketReal)(0.0f);
    *hitB2 = (RayPacketReal)(0.0f);
    RayPacketInt found = (RayPacketInt)(0);
    if (rayPacketBits(active) == 0u) return found;

    RayPacketSlabs s;
    bvhWideSlabLanesP(dx, ox, &s.invNearX, &s.addNearX, &s.invFarX, &s.addFarX);
    bvhWideSlabLanesP(dy, oy, &s.invNearY, &s.addNearY, &s.invFarY, &s.addFarY);
    bvhWideSlabLanesP(dz, oz, &s.invNearZ, &s.addNearZ, &s.invFarZ, &s.addFarZ);
    s.posX = s.invFarX >= (RayPacketReal)(0.0f);
    s.posY = s.invFarY >= (RayPacketReal)(0.0f);
    s.posZ = s.invFarZ >= (RayPacketReal)(0.0f);
    /* Inactive rays do not count: no box is entered before their closest, -1, whichever
     * planes they get. */
    const uint live = rayPacketBits(active);
    const uint bx = rayPacketBits(s.posX) & live, by = rayPacketBits(s.posY) & live,
               bz = rayPacketBits(s.posZ) & live;
    s.px = bx != 0u;
    s.py = by != 0u;
    s.pz = bz != 0u;
    s.uniform = (bx == 0u || bx == live) && (by == 0u || by == live) && (bz == 0u || bz == live);

    /* The triangle test's set-up (triangleRayOf, lane by lane), when the live rays share the
     * largest axis of their directions. */
    RayPacketSheared sh;
    {
        const RayPacketReal ax = fabs(dx), ay = fabs(dy), az = fabs(dz);
        const RayPacketInt kLanes =
            select(select((RayPacketInt)(2), (RayPacketInt)(1), ay > az),
                   select((RayPacketInt)(2), (RayPacketInt)(0), ax > az), ax > ay);
        sh.kz = rayPacketLaneInt(kLanes, 31 - (int)clz(live & (0u - live)));
        sh.uniformAxis = (rayPacketBits(kLanes == (RayPacketInt)(sh.kz)) & live) == live;
        sh.kx = sh.kz == 2 ? 0 : sh.kz + 1;
        sh.ky = sh.kx == 2 ? 0 : sh.kx + 1;
        sh.kzLanes = kLanes;
        sh.kxLanes =
            select(kLanes + (RayPacketInt)(1), (RayPacketInt)(0), kLanes == (RayPacketInt)(2));
        sh.kyLanes = select(sh.kxLanes + (RayPacketInt)(1), (RayPacketInt)(0),
                            sh.kxLanes == (RayPacketInt)(2));
        sh.sz = 1.0f / rayPacketComponent(dx, dy, dz, sh.kzLanes);
        sh.sx = -rayPacketComponent(dx, dy, dz, sh.kxLanes) * sh.sz;
        sh.sy = -rayPacketComponent(dx, dy, dz, sh.kyLanes) * sh.sz;
        sh.ox = rayPacketComponent(ox, oy, oz, sh.kxLanes);
        sh.oy = rayPacketComponent(ox, oy, oz, sh.kyLanes);
        sh.oz = rayPacketComponent(ox, oy, oz, sh.kzLanes);
    }

    /* The representative ray: the mean origin and direction of the active rays. */
    const float inv = 1.0f / (float)popcount(rayPacketBits(active));
    const BvhWideSlabs rep =
        bvhWideSlabsOf(vec3(rayPacketSum(ox, active) * inv, rayPacketSum(oy, active) * inv,
                            rayPacketSum(oz, active) * inv),
                       vec3(rayPacketSum(dx, active) * inv, rayPacketSum(dy, active) * inv,
                            rayPacketSum(dz, active) * inv));

    uint cur = 0u;
    int fromLane = -1; /* as in bvhWideTraverse: the lane just finished, -1 coming down */
    ulong trail = 0;   /* bvhWideTraverse's trail, for the packet's node sequence */
    int depth = 0;
    for (;;) {
        CB_GLOBAL const BvhNodeWide* node = nodes + cur;
        /* The children some live ray enters, as bits. */
        const uint presentBits = bvhWideBits(CB_BVHW_LOAD(node->child) != CB_BVHW_NONE);
        uint group = 0u;
        for (int c = 0; c < CB_BVH_WIDE_LANES; ++c) {
            if (((presentBits >> c) & 1u) == 0u) continue;
            if (rayPacketBits(rayPacketBox(node, c, &s, closest)) != 0u) group |= 1u << c;
        }
#if CB_TREE_PREFETCH
        /* Coming down: the children any of the packet's rays will enter. */
        if (fromLane < 0) bvhWidePrefetch(nodes, packs, node, group);
#endif
        bool more;
        const int k = bvhGroupNext(node, rep, group, fromLane, &more);
        if (k >= 0) {
            const uint count = bvhWideCount(node, k);
            if (count == 0u) {
                bvhGroupDescend(node, k, more, &cur, &fromLane, &depth, &trail);
                continue;
            }
            /* The leaf's packs, for the rays whose own box test keeps it: that child's test
             * again (one of the node's eight), rather than the eight masks of the loop above
             * kept in a private array, which PoCL would copy per work-item. */
            const uint rayBits = rayPacketBits(rayPacketBox(node, k, &s, closest));
            rayPacketLeaf(packs, prims, rays, index, node->child[k], count, rayBits, &sh,
                          closestHit, &closest, &found, hitPrim, hitB1, hitB2, hitScene);
            if (!closestHit && rayPacketBits(closest >= (RayPacketReal)(0.0f)) == 0u) break;
            if (more) {
                fromLane = k;
                continue;
            }
        }
        if (!bvhGroupClimb(nodes, trail, &cur, &fromLane, &depth)) break;
    }
    if (closestHit) *hitT = select(tMax, closest, found);
    return found;
}

/* rayPacketTraverse of the packet rays[index], , each answer stored at its ray's index:
 * closest hits into hits (primitive -1: none), or any hits into occluded (1 or 0). */
CB_FN __attribute__((always_inline)) void
rayPacketTrace(CB_GLOBAL const BvhNodeWide* nodes, CB_GLOBAL const TrianglePack* packs,
               CB_GLOBAL const Primitive* prims, CB_GLOBAL const Ray* rays,
               CB_GLOBAL const float* tMaxes, RayPacketInt index, bool closestHit,
               CB_GLOBAL Hit* hits, CB_GLOBAL int* occluded, const SceneView* hitScene) {
    RayPacketReal t, b1, b2;
    RayPacketInt prim;
    const RayPacketInt hit = rayPacketTraverse(nodes, packs, prims, rays, tMaxes, index, closestHit,
                                               &t, &prim, &b1, &b2, hitScene);
    /* Lane by lane, each a constant (a loop over lane numbers kept 6% more instructions). */
#define CB_RAY_PACKET_OUT(L)                                                                       \
    do {                                                                                           \
        if (index.L < 0) break;                                                                    \
        if (closestHit) {                                                                          \
            Hit h = {t.L, prim.L, b1.L, b2.L};                                                     \
            hits[index.L] = h;                                                                     \
        } else {                                                                                   \
            occluded[index.L] = hit.L != 0 ? 1 : 0;                                                \
        }                                                                                          \
    } while (0)
    CB_RAY_PACKET_OUT(s0);
    CB_RAY_PACKET_OUT(s1);
    CB_RAY_PACKET_OUT(s2);
    CB_RAY_PACKET_OUT(s3);
    CB_RAY_PACKET_OUT(s4);
    CB_RAY_PACKET_OUT(s5);
    CB_RAY_PACKET_OUT(s6);
    CB_RAY_PACKET_OUT(s7);
#if CB_RAY_PACKET == 16
    CB_RAY_PACKET_OUT(s8);
    CB_RAY_PACKET_OUT(s9);
    CB_RAY_PACKET_OUT(sa);
    CB_RAY_PACKET_OUT(sb);
    CB_RAY_PACKET_OUT(sc);
    CB_RAY_PACKET_OUT(sd);
    CB_RAY_PACKET_OUT(se);
    CB_RAY_PACKET_OUT(sf);
#endif
#undef CB_RAY_PACKET_OUT
}

/* The first lines of a kernel whose work-item renders a tile of `tile` x `tile` pixels `stride`
 * apart (packetTilesAcross, cb_rng.h): its tile (tileX, tileY), tilesX across the image;
 * work-items past the image's tiles return. */
#define CB_RAY_PACKET_TILE_ITEM(tile, stride, width, height)                                       \
    const int tileX = (int)get_global_id(0), tileY = (int)get_global_id(1);                        \
    const int tilesX = packetTilesAcross(width, tile, stride);                                     \
    if (tileX >= tilesX || tileY >= packetTilesAcross(height, tile, stride)) return

/* Rows of pixels in a packet: packets are 4 pixels wide. */
#define CB_RAY_PACKET_ROWS (CB_RAY_PACKET / 4)

/* The packets of a tile of `tile` x `tile` pixels stored row by row from index `base` (tile a
 * multiple of 4): packet q's 4 x CB_RAY_PACKET_ROWS pixels' indices, lane by lane row by row,
 * rows of tile / 4 packets. */
CB_FN RayPacketInt rayPacketOfTile(int base, int tile, int q) {
    const int packetsX = tile / 4;
    const int x = 4 * (q % packetsX), y = CB_RAY_PACKET_ROWS * (q / packetsX);
    return (RayPacketInt)(base + y * tile + x) + (CB_RAY_PACKET_LANES & (RayPacketInt)(3)) +
           (CB_RAY_PACKET_LANES >> (RayPacketInt)(2)) * (RayPacketInt)(tile);
}

#endif /* CB_KERNEL_SIDE */
#endif /* CB_BVH_RAY_PACKET_H */
