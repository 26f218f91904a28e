#include "bench/embree_baseline.h"

#include "bench/parallel_rays.h"

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>

#ifdef CBDPT_HAVE_EMBREE
#include <embree3/rtcore.h>
#endif

namespace cb::bench {

#ifdef CBDPT_HAVE_EMBREE

bool embreeAvailable() {
    return true;
}

struct EmbreeBaseline::Impl {
    RTCDevice device = nullptr;
    RTCScene scene = nullptr;
    std::atomic<long long> bytes{0}; // Embree's own allocations less its frees
};

namespace {
// Embree calls this once per allocation (bytes > 0) and once per free (bytes < 0).
bool countEmbreeBytes(void* impl, ssize_t bytes, bool /*post*/) {
    static_cast<std::atomic<long long>*>(impl)->fetch_add(bytes);
    return true;
}
} // namespace

EmbreeBaseline::EmbreeBaseline(const PlyMesh& mesh, int threads)
    : impl_(std::make_unique<Impl>()), threads_(threads) {
    std::string config = "threads=" + std::to_string(threads);
    impl_->device = rtcNewDevice(config.c_str());
    if (!impl_->device) throw std::runtime_error("rtcNewDevice failed");
    rtcSetDeviceMemoryMonitorFunction(impl_->device, countEmbreeBytes, &impl_->bytes);
    auto start = std::chrono::steady_clock::now();
    impl_->scene = rtcNewScene(impl_->device);
    RTCGeometry geom = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
    // rtcSetNewGeometryBuffer pads the buffer as Embree's SIMD loads require.
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0,
                                                          RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                                          mesh.positions.size()));
    std::memcpy(v, mesh.positions.data(), mesh.positions.size() * 3 * sizeof(float));
    auto* idx = static_cast<unsigned*>(
        rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                3 * sizeof(unsigned), mesh.triangles.size()));
    std::memcpy(idx, mesh.triangles.data(), mesh.triangles.size() * 3 * sizeof(unsigned));
    meshBufferBytes_ = static_cast<std::size_t>(impl_->bytes.load());
    rtcCommitGeometry(geom);
    rtcAttachGeometry(impl_->scene, geom);
    rtcReleaseGeometry(geom);
    rtcCommitScene(impl_->scene);
    buildSeconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    // The build's scratch memory is freed by now: what is left is the BVH and the mesh buffers.
    sceneBytes_ = static_cast<std::size_t>(impl_->bytes.load());
}

EmbreeBaseline::~EmbreeBaseline() {
    if (impl_->scene) rtcReleaseScene(impl_->scene);
    if (impl_->device) rtcReleaseDevice(impl_->device);
}

std::string EmbreeBaseline::version() const {
    return std::to_string(rtcGetDeviceProperty(impl_->device, RTC_DEVICE_PROPERTY_VERSION));
}

void EmbreeBaseline::intersect(const std::vector<cbk::Ray>& rays, std::vector<BaselineHit>& out,
                               const std::vector<float>* tMax) const {
    out.resize(rays.size());
    RTCScene scene = impl_->scene;
    parallelRayChunks(rays.size(), threads_, [&](size_t begin, size_t end) {
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        for (size_t i = begin; i < end; ++i) {
            const float tFar = tMax ? (*tMax)[i] : std::numeric_limits<float>::infinity();
            if (!(tFar > 0.0f)) {
                out[i] = {std::numeric_limits<float>::infinity(), -1};
                continue;
            }
            RTCRayHit rh;
            rh.ray.org_x = rays[i].o.x;
            rh.ray.org_y = rays[i].o.y;
            rh.ray.org_z = rays[i].o.z;
            rh.ray.dir_x = rays[i].d.x;
            rh.ray.dir_y = rays[i].d.y;
            rh.ray.dir_z = rays[i].d.z;
            rh.ray.tnear = 0.0f;
            rh.ray.tfar = tFar;
            rh.ray.time = 0.0f;
            rh.ray.mask = 0xffffffffu;
            rh.ray.id = 0;
            rh.ray.flags = 0;
            rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
            rtcIntersect1(scene, &ctx, &rh);
            if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID)
                out[i] = {std::numeric_limits<float>::infinity(), -1};
            else
                out[i] = {rh.ray.tfar, int(rh.hit.primID)};
        }
    });
}

void EmbreeBaseline::occluded(const std::vector<cbk::Ray>& rays, const std::vector<float>& tMax,
                              std::vector<int>& out) const {
    out.resize(rays.size());
    RTCScene scene = impl_->scene;
    parallelRayChunks(rays.size(), threads_, [&](size_t begin, size_t end) {
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        for (size_t i = begin; i < end; ++i) {
            if (!(tMax[i] > 0.0f)) {
                out[i] = 0;
                continue;
            }
            RTCRay r;
            r.org_x = rays[i].o.x;
            r.org_y = rays[i].o.y;
            r.org_z = rays[i].o.z;
            r.dir_x = rays[i].d.x;
            r.dir_y = rays[i].d.y;
            r.dir_z = rays[i].d.z;
            r.tnear = 0.0f;
            r.tfar = tMax[i];
            r.time = 0.0f;
            r.mask = 0xffffffffu;
            r.id = 0;
            r.flags = 0;
            rtcOccluded1(scene, &ctx, &r);
            // Embree sets tfar to -inf when something blocks the ray.
            out[i] = r.tfar < 0.0f ? 1 : 0;
        }
    });
}

namespace {

// Embree's packet types by width, and their entry points.
template <int W> struct Packet;
template <> struct Packet<8> {
    using RayHit = RTCRayHit8;
    using Ray = RTCRay8;
    static void intersect(const int* v, RTCScene s, RTCIntersectContext* c, RayHit* r) {
        rtcIntersect8(v, s, c, r);
    }
    static void occluded(const int* v, RTCScene s, RTCIntersectContext* c, Ray* r) {
        rtcOccluded8(v, s, c, r);
    }
};
template <> struct Packet<16> {
    using RayHit = RTCRayHit16;
    using Ray = RTCRay16;
    static void intersect(const int* v, RTCScene s, RTCIntersectContext* c, RayHit* r) {
        rtcIntersect16(v, s, c, r);
    }
    static void occluded(const int* v, RTCScene s, RTCIntersectContext* c, Ray* r) {
        rtcOccluded16(v, s, c, r);
    }
};

// Fills lane `lane` of a packet ray (RTCRay8 or RTCRay16) with ray `r`, tfar `tFar`.
template <typename P> void setLane(P& p, int lane, const cbk::Ray& r, float tFar) {
    p.org_x[lane] = r.o.x;
    p.org_y[lane] = r.o.y;
    p.org_z[lane] = r.o.z;
    p.dir_x[lane] = r.d.x;
    p.dir_y[lane] = r.d.y;
    p.dir_z[lane] = r.d.z;
    p.tnear[lane] = 0.0f;
    p.tfar[lane] = tFar;
    p.time[lane] = 0.0f;
    p.mask[lane] = 0xffffffffu;
    p.id[lane] = 0;
    p.flags[lane] = 0;
}

template <int W>
void intersectPacketsW(RTCScene scene, int threads, const std::vector<cbk::Ray>& rays,
                       const std::vector<float>* tMax, const std::vector<int>& packets,
                       std::vector<BaselineHit>& out) {
    parallelRayChunks(packets.size() / W, threads, [&](size_t begin, size_t end) {
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        alignas(64) typename Packet<W>::RayHit rh;
        alignas(64) int valid[W];
        for (size_t p = begin; p < end; ++p) {
            const int* index = &packets[p * W];
            for (int l = 0; l < W; ++l) {
                const int i = index[l];
                const float tFar = i < 0  ? 0.0f
                                   : tMax ? (*tMax)[size_t(i)]
                                          : std::numeric_limits<float>::infinity();
                valid[l] = tFar > 0.0f ? -1 : 0;
                setLane(rh.ray, l, rays[size_t(i < 0 ? 0 : i)], tFar > 0.0f ? tFar : 0.0f);
                rh.hit.geomID[l] = RTC_INVALID_GEOMETRY_ID;
                rh.hit.instID[0][l] = RTC_INVALID_GEOMETRY_ID;
            }
            Packet<W>::intersect(valid, scene, &ctx, &rh);
            for (int l = 0; l < W; ++l) {
                const int i = index[l];
                if (i < 0) continue;
                if (!valid[l] || rh.hit.geomID[l] == RTC_INVALID_GEOMETRY_ID)
                    out[size_t(i)] = {std::numeric_limits<float>::infinity(), -1};
                else
                    out[size_t(i)] = {rh.ray.tfar[l], int(rh.hit.primID[l])};
            }
        }
    });
}

template <int W>
void occludedPacketsW(RTCScene scene, int threads, const std::vector<cbk::Ray>& rays,
                      const std::vector<float>& tMax, const std::vector<int>& packets,
                      std::vector<int>& out) {
    parallelRayChunks(packets.size() / W, threads, [&](size_t begin, size_t end) {
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        alignas(64) typename Packet<W>::Ray r;
        alignas(64) int valid[W];
        for (size_t p = begin; p < end; ++p) {
            const int* index = &packets[p * W];
            for (int l = 0; l < W; ++l) {
                const int i = index[l];
                const float tFar = i < 0 ? 0.0f : tMax[size_t(i)];
                valid[l] = tFar > 0.0f ? -1 : 0;
                setLane(r, l, rays[size_t(i < 0 ? 0 : i)], tFar > 0.0f ? tFar : 0.0f);
            }
            Packet<W>::occluded(valid, scene, &ctx, &r);
            for (int l = 0; l < W; ++l)
                if (index[l] >= 0) out[size_t(index[l])] = valid[l] && r.tfar[l] < 0.0f ? 1 : 0;
        }
    });
}

void checkPackets(const std::vector<int>& packets, int width) {
    if ((width != 8 && width != 16) || packets.size() % size_t(width) != 0)
        throw std::invalid_argument("EmbreeBaseline: packets of width " + std::to_string(width) +
                                    " (expected 8 or 16) over " + std::to_string(packets.size()) +
                                    " indices (expected a multiple of the width)");
}

} // namespace

void EmbreeBaseline::intersectPackets(const std::vector<cbk::Ray>& rays,
                                      const std::vector<float>* tMax,
                                      const std::vector<int>& packets, int width,
                                      std::vector<BaselineHit>& out) const {
    checkPackets(packets, width);
    out.assign(rays.size(), {std::numeric_limits<float>::infinity(), -1});
    if (width == 8)
        intersectPacketsW<8>(impl_->scene, threads_, rays, tMax, packets, out);
    else
        intersectPacketsW<16>(impl_->scene, threads_, rays, tMax, packets, out);
}

void EmbreeBaseline::occludedPackets(const std::vector<cbk::Ray>& rays,
                                     const std::vector<float>& tMax,
                                     const std::vector<int>& packets, int width,
                                     std::vector<int>& out) const {
    checkPackets(packets, width);
    out.assign(rays.size(), 0);
    if (width == 8)
        occludedPacketsW<8>(impl_->scene, threads_, rays, tMax, packets, out);
    else
        occludedPacketsW<16>(impl_->scene, threads_, rays, tMax, packets, out);
}

#else

bool embreeAvailable() {
    return false;
}
struct EmbreeBaseline::Impl {};
EmbreeBaseline::EmbreeBaseline(const PlyMesh&, int threads) : threads_(threads) {
    throw std::runtime_error("cbdpt-bench was built without Embree (install libembree-dev)");
}
EmbreeBaseline::~EmbreeBaseline() = default;
std::string EmbreeBaseline::version() const {
    return "";
}
void EmbreeBaseline::intersect(const std::vector<cbk::Ray>&, std::vector<BaselineHit>&,
                               const std::vector<float>*) const {}
void EmbreeBaseline::intersectPackets(const std::vector<cbk::Ray>&, const std::vector<float>*,
                                      const std::vector<int>&, int,
                                      std::vector<BaselineHit>&) const {}
void EmbreeBaseline::occludedPackets(const std::vector<cbk::Ray>&, const std::vector<float>&,
                                     const std::vector<int>&, int, std::vector<int>&) const {}
void EmbreeBaseline::occluded(const std::vector<cbk::Ray>&, const std::vector<float>&,
                              std::vector<int>&) const {}

#endif

} // namespace cb::bench
