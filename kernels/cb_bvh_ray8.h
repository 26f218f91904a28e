/* cb_bvh_ray8.h - packets of eight rays, each packet traced by one work-item through the wide
 * BVH (cb_bvh_wide.h): how CPT's wavefront (pt.cl) traces its coherent rays, and cbdpt-bench's
 * `--traversal ray8`. Kernel code only (float8 lanes).
 *
 * The work-group-wide packet of src/bench/kernels/bench_bvh_packet.h paid for its shared node
 * sequence with a barrier per node visit, across which PoCL stores and reloads every live value.
 * Here one work-item holds a 2x4 tile of rays in float8 registers (Embree's rtcIntersect8 layout:
 * structure of arrays, a ray per lane) and walks one node sequence for all of them, without
 * barriers: per node it tests each child's box against the eight rays at once, and enters a
 * child when any live ray hits it within its own closest hit. Still without a stack, as
 * cb_bvh_wide.h: the children's order must be the same on every return to a node, so it is the
 * order of one representative ray (the mean of the packet's active rays) by cb_bvh_wide.h's
 * integer keys, which depend only on the node and that ray. The set of children any ray still
 * hits only shrinks as the closest hits get closer, so the trail stays exact and every child is
 * visited at most once. A leaf's triangles are tested the other way round from the single-ray
 * traversal's packs: one triangle against the eight rays (cbTriangleLanes of cb_intersect.h with a
 * lane per ray), for the rays whose own box test kept the leaf. Each ray gets the single-ray
 * traversal's answer, up to which of two hits within rounding of each other is kept (the
 * triangles of a pack are tested one after the other, against the closest hit so far). */
#ifndef CB_BVH_RAY8_H
#define CB_BVH_RAY8_H
#ifdef CB_KERNEL_SIDE

#include "cb_bvh_group.h"

/* Rays per packet: float8 lanes, a 2x4 tile of pixels (Embree's rtcIntersect8 packet). */
#define CB_RAY8_SIZE 8
#define CB_RAY8_LANES ((int8)(0, 1, 2, 3, 4, 5, 6, 7))

CB_DEFINE_WIDE_SLAB_LANES(float8, 8)

/* Lane j of v (j not a constant): a select and an OR across the lanes, not a private array
 * (PoCL gives every private array a copy per work-item); exact, the other lanes' bits being
 * zeros, and folded to a lane extract where j is a constant. */
CB_FN int ray8LaneInt(int8 v, int j) {
    return bvhWideOrAll(select((int8)(0), v, CB_RAY8_LANES == (int8)(j)));
}
CB_FN float ray8LaneReal(float8 v, int j) {
    return as_float(ray8LaneInt(as_int8(v), j));
}

/* The sum of the lanes where mask is set (the representative ray). */
CB_FN float ray8Sum(float8 v, int8 mask) {
    float8 m = select((float8)(0.0f), v, mask);
    float4 a = m.lo + m.hi;
    float2 b = a.lo + a.hi;
    return b.x + b.y;
}

/* The eight rays' slab set-up (BvhWideSlabs, lane by lane) and the signs of their directions
 * (lanes -1 where positive, as bvhWideBoxes's per-ray choice of the near plane). */
typedef struct Ray8Slabs {
    float8 invNearX, invNearY, invNearZ, addNearX, addNearY, addNearZ;
    float8 invFarX, invFarY, invFarZ, addFarX, addFarY, addFarZ;
    int8 posX, posY, posZ;
    /* Whether every live ray's direction has the same signs (a packet of neighbouring pixels
     * almost always): then the near planes are picked once per child, not per lane. */
    bool uniform;
    bool px, py, pz;
} Ray8Slabs;

/* Which of the eight rays enter child c's box before their closest hit (lanes -1): bvhWideBoxes
 * for one child and eight rays. A ray that is done has closest < 0, below every entry. */
CB_FN __attribute__((always_inline)) int8 ray8Box(CB_GLOBAL const BvhNodeWide* node, int c,
                                                  const Ray8Slabs* s, float8 closest) {
    float8 lx = (float8)(node->lo[0][c]), hx = (float8)(node->hi[0][c]);
    float8 ly = (float8)(node->lo[1][c]), hy = (float8)(node->hi[1][c]);
    float8 lz = (float8)(node->lo[2][c]), hz = (float8)(node->hi[2][c]);
    float8 nearX, farX, nearY, farY, nearZ, farZ;
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
    float8 nx = fma(nearX, s->invNearX, s->addNearX);
    float8 fx = fma(farX, s->invFarX, s->addFarX);
    float8 ny = fma(nearY, s->invNearY, s->addNearY);
    float8 fy = fma(farY, s->invFarY, s->addFarY);
    float8 nz = fma(nearZ, s->invNearZ, s->addNearZ);
    float8 fz = fma(farZ, s->invFarZ, s->addFarZ);
    float8 tn = bvhWideMax(bvhWideMax(nx, (float8)(0.0f)), bvhWideMax(ny, nz));
    float8 far = bvhWideMin(bvhWideMin(fx, closest), bvhWideMin(fy, fz));
    return tn <= far;
}

/* The watertight test's per-ray set-up (TriangleRay) for the eight rays at once: each lane its
 * ray's permutation (kx8, ky8, kz8); when the live rays' directions share the largest axis
 * (uniformAxis) the permutation is one for all (kx, ky, kz), and a vertex's coordinates are
 * picked once for the eight rays rather than lane by lane. */
typedef struct Ray8Sheared {
    bool uniformAxis;
    int kx, ky, kz;
    int8 kx8, ky8, kz8;
    float8 sx, sy, sz, ox, oy, oz;
} Ray8Sheared;

/* Lane by lane: x, y or z by that lane's axis k (0, 1, 2), as vcomponent. */
CB_FN float8 ray8Component(float8 x, float8 y, float8 z, int8 k) {
    return select(select(z, y, k == (int8)(1)), x, k == (int8)(0));
}

/* Vertex i of a pack's triangle l in the eight rays' permuted frames, relative to their
 * origins. */
CB_FN __attribute__((always_inline)) void ray8Vertex(CB_GLOBAL const TrianglePack* pack, int i,
                                                     int l, const Ray8Sheared* sh, float8* px,
                                                     float8* py, float8* pz) {
    if (sh->uniformAxis) {
        *px = (float8)(pack->v[i][sh->kx][l]) - sh->ox;
        *py = (float8)(pack->v[i][sh->ky][l]) - sh->oy;
        *pz = (float8)(pack->v[i][sh->kz][l]) - sh->oz;
    } else {
        const float8 x = (float8)(pack->v[i][0][l]), y = (float8)(pack->v[i][1][l]),
                     z = (float8)(pack->v[i][2][l]);
        *px = ray8Component(x, y, z, sh->kx8) - sh->ox;
        *py = ray8Component(x, y, z, sh->ky8) - sh->oy;
        *pz = ray8Component(x, y, z, sh->kz8) - sh->oz;
    }
}

/* No fused multiply-adds in the triangle test, as in cb_intersect.h (whose pragma ends with
 * it): the edge functions must be exactly antisymmetric for the test to stay watertight. */
#pragma OPENCL FP_CONTRACT OFF
CB_DEFINE_TRIANGLE_ARITHMETIC(float8, 8)
CB_FN bool ray8AnyLane(int8 mask) {
    return bvhWideOrAll(mask) != 0;
}
/* cbTriangleLanes8: the pack test of cb_intersect.h with a lane per ray. */
CB_DEFINE_TRIANGLE_LANES(float8, int8, float8, 8, ray8AnyLane)

/* The hits of ray j (one lane) recorded in the packet's lanes. */
CB_FN void ray8Record(int j, Hit h, bool closestHit, float8* closest, int8* found, int8* hitPrim,
                      float8* hitB1, float8* hitB2) {
    const int8 at = CB_RAY8_LANES == (int8)(j);
    *found |= at;
    *closest = select(*closest, (float8)(closestHit ? h.t : -1.0f), at);
    if (!closestHit) return;
    *hitPrim = select(*hitPrim, (int8)(h.primitive), at);
    *hitB1 = select(*hitB1, (float8)(h.b1), at);
    *hitB2 = select(*hitB2, (float8)(h.b2), at);
}

/* A leaf's packs first .. first + count - 1 against the rays of rayBits (bit j: lane j). Each
 * triangle is tested against the eight rays at once, each in its own permuted frame
 * (ray8Vertex): the pack test's arithmetic (cbTriangleLanes8) with the roles of lanes turned (a
 * lane per ray, not per triangle), lanes that would take its double-precision path decided one
 * by one by intersectPrimitiveSheared, as intersectPack decides them. Packs of other primitives
 * go ray by ray through intersectPack, and so do any-hit queries whose rays' largest axes
 * differ: there each ray's own pack test, which stops at its first hit, was faster. Triangles are
 * taken in order, each against the closest hit so far, so the nearest hit wins and the first
 * triangle among equal distances, as in intersectPack. A ray that is done (an any-hit query that
 * hit) gets closest -1 and takes no further part. */
CB_FN __attribute__((always_inline)) void
ray8Leaf(CB_GLOBAL const TrianglePack* packs, CB_GLOBAL const Primitive* prims,
         CB_GLOBAL const Ray* rays, int8 index, uint first, uint count, uint rayBits,
         const Ray8Sheared* sh, bool closestHit, float8* closest, int8* found, int8* hitPrim,
         float8* hitB1, float8* hitB2) {
    const int8 mask = ((int8)((int)rayBits) & ((int8)(1) << CB_RAY8_LANES)) != (int8)(0);
    for (uint p = first; p < first + count; ++p) {
        CB_GLOBAL const TrianglePack* pack = packs + p;
        uint bits = rayBits & bvhWideBits(*closest >= (float8)(0.0f));
        if (bits == 0u) return;
        if (pack->scalar || (!sh->uniformAxis && !closestHit)) {
            while (bits != 0u) {
                const int j = 31 - (int)clz(bits & (0u - bits));
                bits &= bits - 1u;
                const Ray ray = rays[ray8LaneInt(index, j)];
                Hit h;
                if (intersectPack(pack, prims, ray, triangleRayOf(ray), ray8LaneReal(*closest, j),
                                  closestHit, &h))
                    ray8Record(j, h, closestHit, closest, found, hitPrim, hitB1, hitB2);
            }
            continue;
        }
        for (int l = 0; l < pack->count; ++l) {
            const int8 live = mask & (*closest >= (float8)(0.0f));
            float8 t, b1, b2, p0x, p0y, p0z, p1x, p1y, p1z, p2x, p2y, p2z;
            int8 slow;
            ray8Vertex(pack, 0, l, sh, &p0x, &p0y, &p0z);
            ray8Vertex(pack, 1, l, sh, &p1x, &p1y, &p1z);
            ray8Vertex(pack, 2, l, sh, &p2x, &p2y, &p2z);
            /* Every lane its own answer (closestHit true: no return at the first hit). */
            if (cbTriangleLanes8(p0x, p0y, p0z, p1x, p1y, p1z, p2x, p2y, p2z, sh->sx, sh->sy,
                                 sh->sz, *closest, live, true, &t, &b1, &b2, &slow) == CB_PACK_MISS)
                continue;
            const int8 exact = t < (float8)(INFINITY);
            *found |= exact;
            if (closestHit) {
                *closest = select(*closest, t, exact);
                *hitPrim = select(*hitPrim, (int8)(pack->prim[l]), exact);
                *hitB1 = select(*hitB1, b1, exact);
                *hitB2 = select(*hitB2, b2, exact);
            } else {
                *closest = select(*closest, (float8)(-1.0f), exact);
            }
            uint slowBits = bvhWideBits(slow);
            while (slowBits != 0u) {
                const int j = 31 - (int)clz(slowBits & (0u - slowBits));
                slowBits &= slowBits - 1u;
                const Ray ray = rays[ray8LaneInt(index, j)];
                const real rayClosest = ray8LaneReal(*closest, j);
                /* intersectPrimitiveSheared leaves the primitive to its caller. */
                Hit h = {rayClosest, pack->prim[l], 0.0f, 0.0f};
                if (intersectPrimitiveSheared(prims + pack->prim[l], ray, triangleRayOf(ray),
                                              rayClosest, &h))
                    ray8Record(j, h, closestHit, closest, found, hitPrim, hitB1, hitB2);
            }
        }
    }
}
#pragma OPENCL FP_CONTRACT ON

/* The rays of one packet, rays[index[0..7]] (index < 0: no ray), each with t in (0, tMax)
 * (tMax <= 0: an inactive ray, a miss), traced together: closest hits (closestHit) into hit8 (t,
 * primitive, b1, b2 per lane, as bvhWideTraverse's Hit), or any hits (!closestHit) as the lanes of
 * the returned mask. Returns the lanes that hit. */
CB_FN __attribute__((always_inline)) int8
ray8Traverse(CB_GLOBAL const BvhNodeWide* nodes, CB_GLOBAL const TrianglePack* packs,
             CB_GLOBAL const Primitive* prims, CB_GLOBAL const Ray* rays,
             CB_GLOBAL const float* tMaxes, int8 index, bool closestHit, float8* hitT,
             int8* hitPrim, float8* hitB1, float8* hitB2) {
    /* index < 0: no ray (padding of the last packet), an inactive lane. */
    const int8 valid = index >= (int8)(0);
    index = select((int8)(0), index, valid);
#define CB_RAY8_GATHER(a, f)                                                                       \
    (float8)(a[index.s0] f, a[index.s1] f, a[index.s2] f, a[index.s3] f, a[index.s4] f,            \
             a[index.s5] f, a[index.s6] f, a[index.s7] f)
    const float8 ox = CB_RAY8_GATHER(rays, .o.x), oy = CB_RAY8_GATHER(rays, .o.y),
                 oz = CB_RAY8_GATHER(rays, .o.z);
    const float8 dx = CB_RAY8_GATHER(rays, .d.x), dy = CB_RAY8_GATHER(rays, .d.y),
                 dz = CB_RAY8_GATHER(rays, .d.z);
    const float8 tMax = CB_RAY8_GATHER(tMaxes, );
#undef CB_RAY8_GATHER
    const int8 active = (tMax > (float8)(0.0f)) & valid;
    /* Live rays keep their closest hit here; a ray that is done (inactive, or an any-hit query
     * that hit) has -1, which no box is entered before. */
    float8 closest = select((float8)(-1.0f), tMax, active);
    *hitT = tMax;
    *hitPrim = (int8)(-1);
    *hitB1 = (float8)(0.0f);
    *hitB2 = (float8)(0.0f);
    int8 found = (int8)(0);
    if (bvhWideBits(active) == 0u) return found;

    Ray8Slabs s;
    bvhWideSlabLanes8(dx, ox, &s.invNearX, &s.addNearX, &s.invFarX, &s.addFarX);
    bvhWideSlabLanes8(dy, oy, &s.invNearY, &s.addNearY, &s.invFarY, &s.addFarY);
    bvhWideSlabLanes8(dz, oz, &s.invNearZ, &s.addNearZ, &s.invFarZ, &s.addFarZ);
    s.posX = s.invFarX >= (float8)(0.0f);
    s.posY = s.invFarY >= (float8)(0.0f);
    s.posZ = s.invFarZ >= (float8)(0.0f);
    /* Inactive rays do not count: no box is entered before their closest, -1, whichever
     * planes they get. */
    const uint live = bvhWideBits(active);
    const uint bx = bvhWideBits(s.posX) & live, by = bvhWideBits(s.posY) & live,
               bz = bvhWideBits(s.posZ) & live;
    s.px = bx != 0u;
    s.py = by != 0u;
    s.pz = bz != 0u;
    s.uniform = (bx == 0u || bx == live) && (by == 0u || by == live) && (bz == 0u || bz == live);

    /* The triangle test's set-up (triangleRayOf, lane by lane), when the live rays share the
     * largest axis of their directions. */
    Ray8Sheared sh;
    {
        const float8 ax = fabs(dx), ay = fabs(dy), az = fabs(dz);
        const int8 k8 = select(select((int8)(2), (int8)(1), ay > az),
                               select((int8)(2), (int8)(0), ax > az), ax > ay);
        sh.kz = ray8LaneInt(k8, 31 - (int)clz(live & (0u - live)));
        sh.uniformAxis = (bvhWideBits(k8 == (int8)(sh.kz)) & live) == live;
        sh.kx = sh.kz == 2 ? 0 : sh.kz + 1;
        sh.ky = sh.kx == 2 ? 0 : sh.kx + 1;
        sh.kz8 = k8;
        sh.kx8 = select(k8 + (int8)(1), (int8)(0), k8 == (int8)(2));
        sh.ky8 = select(sh.kx8 + (int8)(1), (int8)(0), sh.kx8 == (int8)(2));
        sh.sz = 1.0f / ray8Component(dx, dy, dz, sh.kz8);
        sh.sx = -ray8Component(dx, dy, dz, sh.kx8) * sh.sz;
        sh.sy = -ray8Component(dx, dy, dz, sh.ky8) * sh.sz;
        sh.ox = ray8Component(ox, oy, oz, sh.kx8);
        sh.oy = ray8Component(ox, oy, oz, sh.ky8);
        sh.oz = ray8Component(ox, oy, oz, sh.kz8);
    }

    /* The representative ray: the mean origin and direction of the active rays. */
    const float inv = 1.0f / (float)popcount(bvhWideBits(active));
    const BvhWideSlabs rep = bvhWideSlabsOf(
        vec3(ray8Sum(ox, active) * inv, ray8Sum(oy, active) * inv, ray8Sum(oz, active) * inv),
        vec3(ray8Sum(dx, active) * inv, ray8Sum(dy, active) * inv, ray8Sum(dz, active) * inv));

    uint cur = 0u;
    int fromLane = -1; /* as in bvhWideTraverse: the lane just finished, -1 coming down */
    ulong trail = 0;   /* bvhWideTraverse's trail, for the packet's node sequence */
    int depth = 0;
    for (;;) {
        CB_GLOBAL const BvhNodeWide* node = nodes + cur;
        /* The children some live ray enters, as bits. */
        const int8 present = CB_BVHW_LOAD(node->child) != CB_BVHW_NONE;
        const uint presentBits = bvhWideBits(present);
        uint group = 0u;
        for (int c = 0; c < CB_BVH_WIDE_LANES; ++c) {
            if (((presentBits >> c) & 1u) == 0u) continue;
            if (bvhWideBits(ray8Box(node, c, &s, closest)) != 0u) group |= 1u << c;
        }
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
            const uint rayBits = bvhWideBits(ray8Box(node, k, &s, closest));
            ray8Leaf(packs, prims, rays, index, node->child[k], count, rayBits, &sh, closestHit,
                     &closest, &found, hitPrim, hitB1, hitB2);
            if (!closestHit && bvhWideBits(closest >= (float8)(0.0f)) == 0u) break;
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

/* ray8Traverse of the rays rays[index.s0 .. index.s7], each answer stored at its ray's index:
 * closest hits into hits (primitive -1: none), or any hits into occluded (1 or 0). */
CB_FN __attribute__((always_inline)) void
ray8Trace(CB_GLOBAL const BvhNodeWide* nodes, CB_GLOBAL const TrianglePack* packs,
          CB_GLOBAL const Primitive* prims, CB_GLOBAL const Ray* rays,
          CB_GLOBAL const float* tMaxes, int8 index, bool closestHit, CB_GLOBAL Hit* hits,
          CB_GLOBAL int* occluded) {
    float8 t, b1, b2;
    int8 prim;
    const int8 hit =
        ray8Traverse(nodes, packs, prims, rays, tMaxes, index, closestHit, &t, &prim, &b1, &b2);
    /* Lane by lane, each a constant (a loop over lane numbers kept 6% more instructions). */
#define CB_RAY8_OUT(L)                                                                             \
    do {                                                                                           \
        if (index.L < 0) break;                                                                    \
        if (closestHit) {                                                                          \
            Hit h = {t.L, prim.L, b1.L, b2.L};                                                     \
            hits[index.L] = h;                                                                     \
        } else {                                                                                   \
            occluded[index.L] = hit.L != 0 ? 1 : 0;                                                \
        }                                                                                          \
    } while (0)
    CB_RAY8_OUT(s0);
    CB_RAY8_OUT(s1);
    CB_RAY8_OUT(s2);
    CB_RAY8_OUT(s3);
    CB_RAY8_OUT(s4);
    CB_RAY8_OUT(s5);
    CB_RAY8_OUT(s6);
    CB_RAY8_OUT(s7);
#undef CB_RAY8_OUT
}

/* The first lines of a kernel whose work-item renders a tile of `tile` x `tile` pixels `stride`
 * apart (packetTilesAcross, cb_rng.h): its tile (tileX, tileY), tilesX across the image;
 * work-items past the image's tiles return. */
#define CB_RAY8_TILE_ITEM(tile, stride, width, height)                                             \
    const int tileX = (int)get_global_id(0), tileY = (int)get_global_id(1);                        \
    const int tilesX = packetTilesAcross(width, tile, stride);                                     \
    if (tileX >= tilesX || tileY >= packetTilesAcross(height, tile, stride)) return

/* The packets of a tile of `tile` x `tile` pixels stored row by row from index `base` (tile a
 * multiple of 4): packet q's 4 x 2 pixels' indices, rows of 4 packets' width. */
CB_FN int8 ray8TilePacket(int base, int tile, int q) {
    const int packetsX = tile / 4;
    const int x = 4 * (q % packetsX), y = 2 * (q / packetsX);
    return (int8)(base + y * tile + x) + (int8)(0, 1, 2, 3, tile, tile + 1, tile + 2, tile + 3);
}

#endif /* CB_KERNEL_SIDE */
#endif /* CB_BVH_RAY8_H */
