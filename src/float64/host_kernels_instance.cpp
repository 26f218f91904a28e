// The float64 check's HostKernels in one host instance of the kernel code: compiled for
// (float, 3) and (double, 3) (src/kernel_host/kernel_host.cmake).
#include "kernel_host/kernel_instance.h"

#include <array>
#include <memory>

#include "float64/host_kernels.h"

static_assert(CB_CHANNELS == 3, "the float64 check's host kernels are RGB only");

namespace cb::CB_KERNEL_INSTANCE {
namespace {

using float64::HostKernels;
using float64::Precision;
using float64::PtPixelSettings;
using float64::RayHit;
using float64::RayQuery;

class Instance final : public HostKernels {
  public:
    explicit Instance(const SceneBytes& scene)
        : scene_(scene), view_(scene_.view), camera_(scene_.camera) {}

    Precision precision() const override {
        return sizeof(cbk::real) == sizeof(double) ? Precision::Double : Precision::Float;
    }

    RayQuery cameraRay(double rasterX, double rasterY) const override {
        cbk::Ray ray = cbk::cameraGenerateRay(&camera_, cbk::real(rasterX), cbk::real(rasterY),
                                              cbk::vec3(0.0, 0.0, 0.0)); // the lens centre
        RayQuery q;
        q.origin = {ray.o.x, ray.o.y, ray.o.z};
        q.direction = {ray.d.x, ray.d.y, ray.d.z};
        return q;
    }

    RayHit closestHit(const RayQuery& query) const override {
        cbk::Hit hit;
        RayHit out;
        out.hit = cbk::sceneIntersect(&view_, toRay(query), cbk::real(query.tMax), &hit);
        if (out.hit) {
            out.primitive = hit.primitive;
            out.t = hit.t;
            out.b1 = hit.b1;
            out.b2 = hit.b2;
        }
        return out;
    }

    bool occluded(const RayQuery& query) const override {
        return cbk::sceneOccluded(&view_, toRay(query), cbk::real(query.tMax));
    }

    std::array<double, 3> ptPixel(int x, int y, const PtPixelSettings& settings) const override {
        if (x < 0 || y < 0 || x >= camera_.width || y >= camera_.height)
            throw std::out_of_range("ptPixel: pixel outside the film");
        cbk::PathSettings path{};
        path.eyeVertices = settings.eyeVertices;
        path.rouletteVertex = settings.rouletteVertex;
        cbk::SamplerSettings sampler{};
        sampler.seed = settings.seed;
        sampler.kind = settings.sampler;
        cbk::Vec3 rgb = cbk::ptPixelRgb(&view_, scene_.toRgb.data(), &camera_, path, sampler,
                                        settings.estimate, settings.streamTile, nullptr, 0u, x, y);
        return {rgb.x, rgb.y, rgb.z};
    }

    float64::BsdfValue bsdf(int material, const std::array<double, 3>& n,
                            const std::array<double, 3>& wo, const std::array<double, 3>& wi,
                            int adjoint) const override {
        auto vec = [](const std::array<double, 3>& v) {
            return cbk::vec3(cbk::real(v[0]), cbk::real(v[1]), cbk::real(v[2]));
        };
        float64::BsdfValue out;
        cbk::real pdfFwd, pdfRev;
        const cbk::TexCoord uv{0, 0, -1}; // untextured: the precision checks' materials have none
        const cbk::Spectrum f = cbk::bsdfEval(&view_, material, uv, cbk::frameFromNormal(vec(n)),
                                              vec(wo), vec(wi), adjoint, &pdfFwd, &pdfRev);
        out.f = f.c[0];
        out.pdfFwd = pdfFwd;
        out.pdfRev = pdfRev;
        return out;
    }

  private:
    static cbk::Ray toRay(const RayQuery& q) {
        cbk::Ray ray;
        ray.o = cbk::vec3(cbk::real(q.origin[0]), cbk::real(q.origin[1]), cbk::real(q.origin[2]));
        ray.d = cbk::vec3(cbk::real(q.direction[0]), cbk::real(q.direction[1]),
                          cbk::real(q.direction[2]));
        return ray;
    }

    HostScene scene_;
    const cbk::SceneView& view_;
    const cbk::Camera& camera_;
};

} // namespace
} // namespace cb::CB_KERNEL_INSTANCE

namespace cb::float64 {
template <> std::unique_ptr<HostKernels> makeHostKernelsFor<CB_REAL>(const SceneBytes& scene) {
    return std::make_unique<CB_KERNEL_INSTANCE::Instance>(scene);
}
} // namespace cb::float64
