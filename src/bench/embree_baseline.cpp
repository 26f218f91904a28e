#include "bench/embree_baseline.h"

#include "bench/parallel_rays.h"

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
};

EmbreeBaseline::EmbreeBaseline(const PlyMesh& mesh, int threads)
    : impl_(std::make_unique<Impl>()), threads_(threads) {
    std::string config = "threads=" + std::to_string(threads);
    impl_->device = rtcNewDevice(config.c_str());
    if (!impl_->device) throw std::runtime_error("rtcNewDevice failed");
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
    rtcCommitGeometry(geom);
    rtcAttachGeometry(impl_->scene, geom);
    rtcReleaseGeometry(geom);
    rtcCommitScene(impl_->scene);
    buildSeconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

EmbreeBaseline::~EmbreeBaseline() {
    if (impl_->scene) rtcReleaseScene(impl_->scene);
    if (impl_->device) rtcReleaseDevice(impl_->device);
}

std::string EmbreeBaseline::version() const {
    return std::to_string(rtcGetDeviceProperty(impl_->device, RTC_DEVICE_PROPERTY_VERSION));
}

void EmbreeBaseline::intersect(const std::vector<cbk::Ray>& rays,
                               std::vector<BaselineHit>& out) const {
    out.resize(rays.size());
    RTCScene scene = impl_->scene;
    parallelRayChunks(rays.size(), threads_, [&](size_t begin, size_t end) {
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        for (size_t i = begin; i < end; ++i) {
            RTCRayHit rh;
            rh.ray.org_x = rays[i].o.x;
            rh.ray.org_y = rays[i].o.y;
            rh.ray.org_z = rays[i].o.z;
            rh.ray.dir_x = rays[i].d.x;
            rh.ray.dir_y = rays[i].d.y;
            rh.ray.dir_z = rays[i].d.z;
            rh.ray.tnear = 0.0f;
            rh.ray.tfar = std::numeric_limits<float>::infinity();
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
void EmbreeBaseline::intersect(const std::vector<cbk::Ray>&, std::vector<BaselineHit>&) const {}
void EmbreeBaseline::occluded(const std::vector<cbk::Ray>&, const std::vector<float>&,
                              std::vector<int>&) const {}

#endif

} // namespace cb::bench
