/* pt.cl - path tracing (PT) and, through the shared sample vector, coherent path tracing
 * (CPT). One work-item per pixel; work-groups are square pixel tiles. */
#include "cb_kernel.h"
#include "cb_pt.h"

/* streamTile: 0 for PT, k > 0 for CPT with k x k shared sample vectors (ptPixelRgb), whose
 * first sharedDimensions values the host drew into sharedSamples (0: the kernel draws them). */
__kernel void renderPathTracing(CB_INTEGRATOR_KERNEL_PARAMS(PathSettings), uint estimate,
                                int streamTile, __global const float* sharedSamples,
                                uint sharedDimensions, __global float* outRgb, CB_COUNTER_PARAMS) {
    CB_PIXEL_KERNEL_BEGIN(x, y, scene);
    Vec3 rgb = ptPixelRgb(&scene, toRgb, &camera, settings, samplerCopy, estimate, streamTile,
                          sharedSamples, sharedDimensions, x, y);
    /* ptPixelRgb does not count its rays. */
    cbWritePixel(outRgb, CB_COUNTERS, (uint)(y * camera.width + x), rgb, 0, 0);
}

/* CPT with its coherent rays traced as packets: one work-item renders a tile of `tile` x `tile`
 * pixels that follow one shared sample vector (neighbours, or k apart with --coherence-tile k:
 * packetTilePixel, cb_rng.h), advancing their paths one vertex at a time together
 * (ptPathVertex, ptPathShadow, as in ptRadiance), and between the steps traces their rays in
 * packets of 4 x 2 or 4 x 4 of its pixels (cb_bvh_ray_packet.h) rather than one by one. Paths, rays
 * and answers wait in global scratch buffers, tile * tile entries per work-item, which stay in the
 * cache while the work-item runs (tMax 0: no ray). The work-item loops over its pixels itself,
 * without barriers: a work-item per pixel with barriers around the packets rendered wrong
 * images under PoCL 3.1 even with the packets' answers replaced by each work-item's own
 * traversal. `tile` must be a multiple of 4. */
#include "cb_bvh_ray_packet.h"

/* Each round traces one ray per path, so a ray that crosses an interface (and must be traced again
 * at the same vertex) cannot wait for the next, nor can its shadow rays be occlusion tests: the
 * host renders scenes with interfaces with renderPathTracing (PixelKernelIntegrator::
 * packetsWanted). */
#if !CB_HAS(CB_FEATURE_INTERFACE)

/* The host sizes the path buffer by CB_PT_PATH_BYTES (cb_pt.h): a compile error if it is not
 * PtPath's size. */
#define CB_PT_PATH_KERNEL_BYTES CB_PT_PATH_BYTES(CB_CHANNELS, CB_HAS_MEDIUM_TRACK)
typedef char cbPtPathBytesCheck[sizeof(PtPath) == CB_PT_PATH_KERNEL_BYTES ? 1 : -1];

__kernel void renderCoherentPathTracing(CB_INTEGRATOR_KERNEL_PARAMS(PathSettings), uint estimate,
                                        int streamTile, __global const float* sharedSamples,
                                        uint sharedDimensions, int tile, __global PtPath* paths,
                                        __global Ray* rays, __global float* tMaxes,
                                        __global Hit* hits, __global Ray* shadowRays,
                                        __global float* shadowTMaxes, __global int* occluded,
                                        __global float* outRgb, CB_COUNTER_PARAMS) {
    CB_RAY_PACKET_TILE_ITEM(tile, streamTile, camera.width, camera.height);
    const int pixels = tile * tile, packets = pixels / CB_RAY_PACKET;
    const int base = (tileY * tilesX + tileX) * pixels;
    CB_SCENE_VIEW(scene);
    const SamplerSettings samplerCopy = samplerSettingsCopy(sampler);
#define CB_CPT_PIXEL(p, x, y, inside)                                                              \
    const int x = packetTilePixel(tileX, (p) % tile, tile, streamTile);                            \
    const int y = packetTilePixel(tileY, (p) / tile, tile, streamTile);                            \
    const bool inside = x < camera.width && y < camera.height
#define CB_CPT_SAMPLES(x, y)                                                                       \
    ptPixelStream(samplerCopy, estimate, streamTile, sharedSamples, sharedDimensions,              \
                  camera.width, x, y)
    for (int p = 0; p < pixels; ++p) {
        CB_CPT_PIXEL(p, x, y, inside);
        real filterWeight; /* cameraSampleWeight's where the radiance is written */
        rays[base + p] = ptCameraRay(&camera, CB_CPT_SAMPLES(x, y), x, y, &filterWeight);
        tMaxes[base + p] = inside && settings.eyeVertices > 1 ? CB_INFINITY : 0.0f;
        paths[base + p] = ptPathBegin(camera.medium);
    }
    for (int vertex = 1; vertex < settings.eyeVertices; ++vertex) {
        for (int q = 0; q < packets; ++q)
            rayPacketTrace(nodes, packs, primitives, rays, tMaxes, rayPacketOfTile(base, tile, q),
                           true, hits, 0, &scene);
        for (int p = 0; p < pixels; ++p) {
            const int i = base + p;
            shadowTMaxes[i] = 0.0f;
            if (!(tMaxes[i] > 0.0f)) continue;
            CB_CPT_PIXEL(p, x, y, inside);
            (void)inside;
            PtPath path = paths[i];
            Ray ray = rays[i], shadow;
            real shadowTMax = 0.0f;
            const Hit hit = hits[i];
            const bool more = ptPathVertex(&scene, &path, &ray, hit.primitive >= 0, hit,
                                           CB_CPT_SAMPLES(x, y), settings, &shadow, &shadowTMax);
            rays[i] = ray;
            tMaxes[i] = more ? CB_INFINITY : 0.0f;
            if (path.shadowPending) {
                shadowRays[i] = shadow;
                shadowTMaxes[i] = shadowTMax;
            }
            paths[i] = path;
        }
        /* The last vertex makes no shadow ray (it would close a path of Ne + 1 vertices). */
        if (vertex + 1 >= settings.eyeVertices) break;
        for (int q = 0; q < packets; ++q)
            rayPacketTrace(nodes, packs, primitives, shadowRays, shadowTMaxes,
                           rayPacketOfTile(base, tile, q), false, 0, occluded, &scene);
        for (int p = 0; p < pixels; ++p) {
            const int i = base + p;
            if (!paths[i].shadowPending) continue;
            PtPath path = paths[i];
            ptPathShadow(&path, occluded[i] != 0);
            paths[i] = path;
        }
    }
    for (int p = 0; p < pixels; ++p) {
        CB_CPT_PIXEL(p, x, y, inside);
        if (!inside) continue;
        const real filterWeight = cameraSampleWeight(&camera, CB_CPT_SAMPLES(x, y));
        const Vec3 rgb = filmClampSample(
            &camera, specToRgb(specScale(paths[base + p].radiance, filterWeight), toRgb),
            filterWeight);
        cbWritePixel(outRgb, CB_COUNTERS, (uint)(y * camera.width + x), rgb, 0, 0);
    }
#undef CB_CPT_PIXEL
#undef CB_CPT_SAMPLES
}
#endif
