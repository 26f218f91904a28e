/* cbdpt_packets.cl - CBDPT with its coherent rays traced as packets, on CPU devices (GPUs run
 * the per-pixel renderCbdpt of cbdpt.cl, whose code this shares).
 *
 * One work-item renders a tile of `tile` x `tile` pixels that follow one shared sample vector
 * (neighbours, or k apart with --coherence-tile k: packetTilePixel, cb_rng.h). Their eye
 * subpaths advance one vertex at a time together (bdptWalkStep, as bdptRandomWalk), each
 * round's rays traced in packets of 4 x 2 or 4 x 4 of its pixels (cb_bvh_ray_packet.h). Then each
 * pixel's strategies are renderCbdpt's, but each shadow ray waits (bdptConnectDeferred) with its
 * weighted contribution; the shadow rays of each strategy (t, s), all aimed at the estimate's
 * same few light vertices from nearby eye vertices, are traced in packets, and each pixel adds
 * its strategies in renderCbdpt's order. Everything waits in global scratch buffers, per
 * work-item tile * tile entries (times Ne eye vertices, or times the (Ne - 1) (Nl + 1)
 * strategies), which stay in the cache while the work-item runs; tMax 0: no ray. `tile` must be
 * a multiple of 4. */
#include "cbdpt.cl"
/* After cbdpt.cl, whose headers define what it needs (CB_HAS). */
#include "cb_bvh_ray_packet.h"

/* Each round traces one ray per eye subpath, so a ray that crosses an interface (and must be
 * traced again without a vertex) cannot wait for the next: the host renders scenes with
 * interfaces with renderCbdpt (PixelKernelIntegrator::packetsWanted). */
#if CB_HAS(CB_FEATURE_INTERFACE)
#error "renderCoherentBdpt does not take scenes with interfaces"
#endif

/* The host sizes the walks' buffer by CB_CBDPT_WALK_BYTES (cb_bdpt.h). */
typedef char cbCbdptWalkBytesCheck[sizeof(CbdptWalk) == CB_CBDPT_WALK_BYTES(CB_CHANNELS) ? 1 : -1];

__kernel void renderCoherentBdpt(CB_CBDPT_PARAMS, int tile, __global PathVertex* eyes,
                                 __global CbdptWalk* walks, __global Ray* rays,
                                 __global float* tMaxes, __global Hit* hits,
                                 __global Spectrum* terms, __global Ray* shadowRays,
                                 __global float* shadowTMaxes, __global int* occluded,
                                 __global float* outRgb, CB_COUNTER_PARAMS) {
    CB_RAY_PACKET_TILE_ITEM(tile, streamTile, camera.width, camera.height);
    CB_SCENE_VIEW(scene);
    BdptSettings settingsCopy = bdptSettingsCopy(settings);
    const SamplerSettings samplerCopy = samplerSettingsCopy(sampler);
    const int pixels = tile * tile, packets = pixels / CB_RAY_PACKET;
    const int tileIndex = tileY * tilesX + tileX;
    const int maxEye = settingsCopy.eyeVertices;
    int tracedRays = 0;
#define CB_CBDPT_PIXEL(p, x, y)                                                                    \
    const int x = packetTilePixel(tileX, (p) % tile, tile, streamTile),                            \
              y = packetTilePixel(tileY, (p) / tile, tile, streamTile)
#define CB_CBDPT_INSIDE(x, y) ((x) < camera.width && (y) < camera.height)

    /* The eye subpaths: pixel p's walk and ray at tileIndex * pixels + p, its vertices from
     * (tileIndex * pixels + p) * Ne. */
    const int walkBase = tileIndex * pixels;
    for (int p = 0; p < pixels; ++p) {
        CB_CBDPT_PIXEL(p, x, y);
        const int i = walkBase + p;
        const SampleStream eyeStream = samplerStreamShared(
            samplerCopy, estimate, (uint)((y % streamTile) * streamTile + x % streamTile),
            sharedSamples, sharedDimensions);
        float rasterX, rasterY;
        /* Its filter weight: cameraSampleWeight's, where the strategies are weighed. */
        (void)cameraSampleRaster(&camera, eyeStream, x, y, &rasterX, &rasterY);
        PathVertex eye0[1];
        real pdfDir;
        rays[i] =
            bdptEyeStart(&camera, rasterX, rasterY,
                         cameraStreamLensPoint(&camera, eyeStream, CB_DIM_LENS), eye0, &pdfDir);
        eyes[i * maxEye] = eye0[0];
        CbdptWalk walk;
        walk.beta = specConst(1.0f);
        walk.pdfW = pdfDir;
        walk.count = 1;
        walks[i] = walk;
        tMaxes[i] = CB_CBDPT_INSIDE(x, y) && maxEye >= 2 ? CB_INFINITY : 0.0f;
    }
    for (int vertex = 1; vertex < maxEye; ++vertex) {
        for (int q = 0; q < packets; ++q)
            rayPacketTrace(nodes, packs, primitives, rays, tMaxes,
                           rayPacketOfTile(walkBase, tile, q), true, hits, 0, &scene);
        for (int p = 0; p < pixels; ++p) {
            const int i = walkBase + p;
            if (!(tMaxes[i] > 0.0f)) continue;
            CB_CBDPT_PIXEL(p, x, y);
            ++tracedRays;
            const SampleStream eyeStream = samplerStreamShared(
                samplerCopy, estimate, (uint)((y % streamTile) * streamTile + x % streamTile),
                sharedSamples, sharedDimensions);
            CbdptWalk walk = walks[i];
            PathVertex prev = eyes[i * maxEye + walk.count - 1], v;
            Ray ray = rays[i];
            const Hit hit = hits[i];
            /* Without interfaces each ray's way through media starts at its vertex. */
            MediumTrack track = mediumTrackStart(pvMediumToward(&scene, &prev, ray.d));
            const int step =
                bdptWalkStep(&scene, hit.primitive >= 0, hit, &ray, &walk.beta, &walk.pdfW, 0,
                             eyeStream, CB_DIM_FIRST_BOUNCE, &prev, &v, walk.count, maxEye, &track);
            if (step > 0) {
                eyes[i * maxEye + walk.count - 1] = prev;
                eyes[i * maxEye + walk.count] = v;
                ++walk.count;
            }
            walks[i] = walk;
            rays[i] = ray;
            tMaxes[i] = step == 2 ? CB_INFINITY : 0.0f;
        }
    }

    /* The strategies: entry (strategy m, pixel p) at base + m * pixels + p. */
    const int lightSlots = settingsCopy.lightVertices + 1; /* s = 0 .. Nl */
    const int strategies = (maxEye - 1) * lightSlots;
    const int base = tileIndex * strategies * pixels;
    for (int p = 0; p < pixels; ++p) {
        CB_CBDPT_PIXEL(p, x, y);
        for (int m = 0; m < strategies; ++m)
            shadowTMaxes[base + m * pixels + p] = -1.0f; /* < 0: no contribution */
        if (!CB_CBDPT_INSIDE(x, y)) continue;
        PathVertex light[CB_MAX_LIGHT_VERTICES];
        int nLight;
        SampleStream eyeStream;
        CB_CBDPT_PIXEL_LIGHT(&samplerCopy, x, y, light, nLight, eyeStream);
        const float filterWeight = cameraSampleWeight(&camera, eyeStream);
        PathVertex eye[CB_MAX_EYE_VERTICES];
        const int nEye = walks[walkBase + p].count;
        for (int k = 0; k < nEye; ++k)
            eye[k] = eyes[(walkBase + p) * maxEye + k];
#define CB_CBDPT_STRATEGY(t, s, lightOrNee)                                                        \
    do {                                                                                           \
        const int i = base + ((t - 2) * lightSlots + s) * pixels + p;                              \
        float rx = 0.0f, ry = 0.0f;                                                                \
        Spectrum c;                                                                                \
        int needsShadow;                                                                           \
        Ray shadow;                                                                                \
        real shadowTMax = 0.0f;                                                                    \
        if (!bdptConnectDeferred(&scene, &camera, lightOrNee, s, eye, t, settingsCopy,             \
                                 cameraCount, &rx, &ry, &c, &needsShadow, &shadow, &shadowTMax,    \
                                 &tracedRays))                                                     \
            break;                                                                                 \
        terms[i] = specScale(c, filterWeight);                                                     \
        /* 0: no shadow ray (rayPacketTrace skips it: never occluded). */                          \
        shadowTMaxes[i] = needsShadow ? fmax(shadowTMax, 0.0f) : 0.0f;                             \
        if (needsShadow) shadowRays[i] = shadow;                                                   \
    } while (0)
        CB_CBDPT_STRATEGIES(&scene, eye, nEye, light, nLight, eyeStream)
#undef CB_CBDPT_STRATEGY
    }
    for (int m = 0; m < strategies; ++m)
        for (int q = 0; q < packets; ++q)
            rayPacketTrace(nodes, packs, primitives, shadowRays, shadowTMaxes,
                           rayPacketOfTile(base + m * pixels, tile, q), false, 0, occluded, &scene);
    for (int p = 0; p < pixels; ++p) {
        CB_CBDPT_PIXEL(p, x, y);
        if (!CB_CBDPT_INSIDE(x, y)) continue;
        Spectrum radiance = specZero();
        int nonFinite = 0;
        for (int m = 0; m < strategies; ++m) {
            const int i = base + m * pixels + p;
            if (shadowTMaxes[i] < 0.0f || occluded[i]) continue;
            Spectrum c = terms[i];
            CB_CBDPT_ADD(radiance, c, nonFinite);
        }
        /* The filter's weight again, which the clamp takes out (none without a clamp). */
        const float filterWeight =
            CB_HAS(CB_FEATURE_SAMPLE_CLAMP)
                ? cameraSampleWeight(&camera, CB_CBDPT_EYE_STREAM(&samplerCopy, x, y))
                : 1.0f;
        /* The tile's rays, counted once (countRays: CBDPT_RAY_STATS). */
        cbWritePixel(outRgb, CB_COUNTERS, (uint)(y * camera.width + x),
                     filmClampSample(&camera, specToRgb(radiance, toRgb), filterWeight), nonFinite,
                     p == 0 ? tracedRays : 0);
    }
#undef CB_CBDPT_PIXEL
#undef CB_CBDPT_INSIDE
}
