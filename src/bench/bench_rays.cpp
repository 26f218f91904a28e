// cbdpt-bench: the rays the traverse and build sections trace (bench.h).
#include "bench/bench.h"

#include "cb_sampling.h"

#include <algorithm>
#include <cmath>
#include <random>

using cbk::Ray;
using cbk::Vec3;

namespace cb::bench {

Box3 meshBounds(const PlyMesh& m) {
    Box3 b{cbk::vec3(INFINITY, INFINITY, INFINITY), cbk::vec3(-INFINITY, -INFINITY, -INFINITY)};
    for (const auto& p : m.positions) {
        Vec3 v = cbk::vec3(p[0], p[1], p[2]);
        b.lo = cbk::vmin(b.lo, v);
        b.hi = cbk::vmax(b.hi, v);
    }
    return b;
}

namespace {
Vec3 uniformDirection(std::mt19937& rng) {
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    float z = 1.0f - 2.0f * u(rng);
    float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
    float phi = 2.0f * CB_PI * u(rng);
    return cbk::vec3(r * std::cos(phi), r * std::sin(phi), z);
}
} // namespace

std::vector<Ray> primaryRays(const Box3& b, long count) {
    int side = std::max(8, int(std::sqrt(double(count))) / 8 * 8);
    Vec3 centre = cbk::vscale(cbk::vadd(b.lo, b.hi), 0.5f);
    float radius = 0.5f * cbk::vlength(cbk::vsub(b.hi, b.lo));
    Vec3 eye = cbk::vadd(centre, cbk::vec3(0.3f * radius, 0.4f * radius, 2.6f * radius));
    Vec3 fwd = cbk::vnormalize(cbk::vsub(centre, eye));
    Vec3 right = cbk::vnormalize(cbk::vcross(fwd, cbk::vec3(0, 1, 0)));
    Vec3 up = cbk::vcross(right, fwd);
    float tanHalf = std::tan(0.5f * 40.0f * CB_PI / 180.0f);
    std::vector<Ray> rays;
    rays.reserve(size_t(side) * side);
    for (int ty = 0; ty < side; ty += 8)
        for (int tx = 0; tx < side; tx += 8)
            for (int y = ty; y < ty + 8; ++y)
                for (int x = tx; x < tx + 8; ++x) {
                    float sx = (2.0f * (x + 0.5f) / side - 1.0f) * tanHalf;
                    float sy = (1.0f - 2.0f * (y + 0.5f) / side) * tanHalf;
                    Vec3 d = cbk::vadd(fwd, cbk::vadd(cbk::vscale(right, sx), cbk::vscale(up, sy)));
                    rays.push_back(Ray{eye, cbk::vnormalize(d)});
                }
    return rays;
}

std::vector<Ray> incoherentRays(const Box3& b, long count, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<Ray> rays(static_cast<size_t>(count));
    for (auto& r : rays) {
        r.o = cbk::vec3(b.lo.x + u(rng) * (b.hi.x - b.lo.x), b.lo.y + u(rng) * (b.hi.y - b.lo.y),
                        b.lo.z + u(rng) * (b.hi.z - b.lo.z));
        r.d = uniformDirection(rng);
    }
    return rays;
}

void shadowRays(const Box3& b, const std::vector<Ray>& primary, const std::vector<cbk::Hit>& hits,
                unsigned seed, std::vector<Ray>& rays, std::vector<float>& tMax) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    Vec3 centre = cbk::vscale(cbk::vadd(b.lo, b.hi), 0.5f);
    float size = cbk::vlength(cbk::vsub(b.hi, b.lo));
    rays.resize(primary.size());
    tMax.resize(primary.size());
    for (size_t i = 0; i < primary.size(); ++i) {
        Vec3 o;
        if (hits[i].primitive >= 0)
            o = cbk::vmadd(primary[i].o, primary[i].d, hits[i].t - 1e-4f * size);
        else
            o = cbk::vec3(b.lo.x + u(rng) * (b.hi.x - b.lo.x), b.lo.y + u(rng) * (b.hi.y - b.lo.y),
                          b.lo.z + u(rng) * (b.hi.z - b.lo.z));
        Vec3 light = cbk::vadd(
            centre, cbk::vec3((u(rng) - 0.5f) * size, 0.8f * size, (u(rng) - 0.5f) * size));
        Vec3 d = cbk::vsub(light, o);
        float len = cbk::vlength(d);
        rays[i] = Ray{o, cbk::vscale(d, 1.0f / len)};
        tMax[i] = len * (1.0f - 1e-4f);
    }
}

void coherentBounce(const Box3& b, const std::vector<cbk::Primitive>& prims,
                    const std::vector<Ray>& rays, const std::vector<float>* tMax,
                    const std::vector<cbk::Hit>& hits, float u0, float u1, std::vector<Ray>& out,
                    std::vector<float>& outTMax) {
    const float offset = 1e-4f * cbk::vlength(cbk::vsub(b.hi, b.lo));
    const Vec3 local = cbk::sampleCosineHemisphere(u0, u1);
    out.assign(rays.size(), Ray{cbk::vec3(0, 0, 0), cbk::vec3(0, 0, 1)});
    outTMax.assign(rays.size(), 0.0f);
    for (size_t i = 0; i < rays.size(); ++i) {
        if ((tMax && !((*tMax)[i] > 0.0f)) || hits[i].primitive < 0) continue;
        const cbk::Primitive& p = prims[size_t(hits[i].primitive)];
        const Vec3 p0 = cbk::vec3(p.p0[0], p.p0[1], p.p0[2]);
        Vec3 n = cbk::vnormalize(cbk::vcross(cbk::vsub(cbk::vec3(p.p1[0], p.p1[1], p.p1[2]), p0),
                                             cbk::vsub(cbk::vec3(p.p2[0], p.p2[1], p.p2[2]), p0)));
        if (cbk::vdot(n, rays[i].d) > 0.0f) n = cbk::vneg(n);
        const Vec3 hit = cbk::vmadd(rays[i].o, rays[i].d, hits[i].t);
        out[i] = Ray{cbk::vmadd(hit, n, offset),
                     cbk::vnormalize(cbk::frameToWorld(cbk::frameFromNormal(n), local))};
        outTMax[i] = CB_INFINITY;
    }
}

void coherentShadowRays(const Box3& b, const std::vector<Ray>& primary,
                        const std::vector<cbk::Hit>& hits, std::vector<Ray>& rays,
                        std::vector<float>& tMax) {
    Vec3 centre = cbk::vscale(cbk::vadd(b.lo, b.hi), 0.5f);
    float size = cbk::vlength(cbk::vsub(b.hi, b.lo));
    const Vec3 light = cbk::vadd(centre, cbk::vec3(0.21f * size, 0.8f * size, -0.13f * size));
    rays.assign(primary.size(), primary.empty() ? Ray{} : primary[0]);
    tMax.assign(primary.size(), 0.0f);
    for (size_t i = 0; i < primary.size(); ++i) {
        if (hits[i].primitive < 0) continue;
        Vec3 o = cbk::vmadd(primary[i].o, primary[i].d, hits[i].t - 1e-4f * size);
        Vec3 d = cbk::vsub(light, o);
        float len = cbk::vlength(d);
        rays[i] = Ray{o, cbk::vscale(d, 1.0f / len)};
        tMax[i] = len * (1.0f - 1e-4f);
    }
}

std::vector<int> tilePackets(size_t count, int width) {
    const int rows = width == 8 ? 2 : 4, cols = width / rows;
    std::vector<int> packets;
    packets.reserve(count);
    for (size_t tile = 0; tile + 64 <= count; tile += 64)
        for (int y = 0; y < 8; y += rows)
            for (int x = 0; x < 8; x += cols)
                for (int dy = 0; dy < rows; ++dy)
                    for (int dx = 0; dx < cols; ++dx)
                        packets.push_back(int(tile) + (y + dy) * 8 + x + dx);
    return packets;
}

std::vector<Ray> cameraSample(const std::vector<Ray>& primary) {
    const size_t step = std::max<size_t>(1, primary.size() / 1024);
    std::vector<Ray> sample;
    for (size_t i = step / 2; i < primary.size(); i += step)
        sample.push_back(primary[i]);
    return sample;
}

} // namespace cb::bench
