// CBDPT's host light pass, written once against the shared kernel code and compiled once per
// host instance that lists it (src/kernel_host/kernel_host.cmake: float with 3 and 16 channels,
// double with 3 for the float64 check). No path code is duplicated: the light subpaths, the
// camera connection and its MIS weight are the kernels' own functions (kernels/cb_bdpt.h).
#include "kernel_host/kernel_instance.h"

#include <algorithm>
#include <memory>

#include "integrators/cbdpt_light.h"

namespace cb::CB_KERNEL_INSTANCE {
namespace {

class LightTracer final : public CbdptLightTracer {
  public:
    LightTracer(const SceneBytes& scene, const CbdptLightSettings& settings)
        : settings_(settings), scene_(scene), view_(scene_.view), camera_(scene_.camera) {
        bdpt_ = cbk::BdptSettings{};
        bdpt_.eyeVertices = settings.eyeVertices;
        bdpt_.lightVertices = settings.lightVertices;
        bdpt_.weights = settings.weights;
        bdpt_.debugS = -1;
        bdpt_.debugT = -1;
        bdpt_.maxPathVertices = settings.maxPathVertices;
        subpaths_ = settings.tileRows * settings.tileColumns;
        cameraCount_ = cbdptCameraCount(camera_.width, camera_.height, settings);
        sampler_ = cbk::SamplerSettings{};
        sampler_.seed = settings.seed;
        sampler_.kind = settings.sampler;
        path_.resize(std::size_t(settings.lightVertices));
    }

    std::size_t vertexBytes() const override { return sizeof(cbk::PathVertex); }

    void trace(std::uint32_t estimate, CbdptLightPass& out) override {
        const int nl = settings_.lightVertices;
        const int width = camera_.width, height = camera_.height;
        out.vertices.assign(std::size_t(subpaths_) * std::size_t(nl) * sizeof(cbk::PathVertex), 0);
        out.counts.assign(std::size_t(subpaths_), 0);
        const std::size_t splatFloats = 3 * std::size_t(width) * std::size_t(height);
        if (out.splatRgb.size() != splatFloats) {
            out.splatRgb.assign(splatFloats, 0.0f);
        } else {
            for (std::uint32_t p : out.splatPixels)
                std::fill_n(&out.splatRgb[3 * std::size_t(p)], 3, 0.0f);
        }
        out.splatPixels.clear();
        out.nonFinite = 0;
        out.rays = 0;
        // BDPT: W*H subpaths per estimate, each splatting with the importance of "some pixel"
        // (pbrt-v4's We, see cameraImportance). Here `subpaths_` stand for all of them.
        const float scale = float(double(width) * double(height) / double(subpaths_));
        for (int i = 0; i < settings_.tileRows; ++i)
            for (int j = 0; j < settings_.tileColumns; ++j) {
                const int index = i * settings_.tileColumns + j;
                const auto stream = std::uint32_t(i * settings_.coherenceTile + j);
                for (auto& v : path_)
                    v = cbk::PathVertex{};
                int rays = 0;
                const cbk::SampleStream lightStream = cbk::bdptLightStream(
                    sampler_, estimate, stream,
                    std::uint32_t(settings_.coherenceTile * settings_.coherenceTile));
                const int count =
                    cbk::bdptLightSubpath(&view_, lightStream, nl, path_.data(), &rays);
                // Its t = 1 connections meet the camera at one point of the lens (a pinhole:
                // the camera position), drawn from its own stream.
                cbk::PathVertex eye[1] = {cbk::bdptCameraVertex(
                    &camera_,
                    cbk::cameraStreamLensPoint(&camera_, lightStream, CB_LIGHT_DIM_LENS))};
                out.counts[std::size_t(index)] = count;
                std::memcpy(out.vertices.data() +
                                std::size_t(index) * std::size_t(nl) * sizeof(cbk::PathVertex),
                            static_cast<const void*>(path_.data()),
                            std::size_t(count) * sizeof(cbk::PathVertex));
                // t = 1: the few light vertices this estimate has, projected and tested here.
                for (int s = 2; s <= count; ++s) {
                    cbk::real rx = 0.0f, ry = 0.0f;
                    cbk::Spectrum c = cbk::bdptConnect(&view_, &camera_, path_.data(), s, eye, 1,
                                                       bdpt_, cameraCount_, &rx, &ry, &rays);
                    if (cbk::specIsBlack(c)) continue;
                    if (!cbk::specIsFinite(c)) {
                        ++out.nonFinite;
                        continue;
                    }
                    // Clamped as one light path's splat, before `scale` spreads it over the
                    // W x H / (light subpaths) paths it stands for (pbrt-v4's AddSplat).
                    const cbk::Vec3 rgb = cbk::filmClampSample(
                        &camera_, cbk::specToRgb(c, scene_.toRgb.data()), 1.0f);
                    const cbk::FilterSplat splat = cbk::filterSplatAt(&camera_, rx, ry);
                    for (int y = splat.y0; y <= splat.y1; ++y) {
                        const cbk::real row = scale * cbk::filterSplatRow(&camera_, &splat, y);
                        for (int x = splat.x0; x <= splat.x1; ++x) {
                            const auto pixel = std::uint32_t(y * width + x);
                            const cbk::real share =
                                row * cbk::filterSplatColumn(&camera_, &splat, x);
                            out.splatPixels.push_back(pixel);
                            float* dst = &out.splatRgb[3 * std::size_t(pixel)];
                            dst[0] += float(share * rgb.x);
                            dst[1] += float(share * rgb.y);
                            dst[2] += float(share * rgb.z);
                        }
                    }
                }
                out.rays += rays;
            }
        std::sort(out.splatPixels.begin(), out.splatPixels.end());
        out.splatPixels.erase(std::unique(out.splatPixels.begin(), out.splatPixels.end()),
                              out.splatPixels.end());
    }

  private:
    CbdptLightSettings settings_;
    HostScene scene_;
    const cbk::SceneView& view_;
    const cbk::Camera& camera_;
    cbk::BdptSettings bdpt_{};
    cbk::SamplerSettings sampler_{};
    std::vector<cbk::PathVertex> path_;
    int subpaths_ = 1;
    float cameraCount_ = 1.0f;
};

} // namespace
} // namespace cb::CB_KERNEL_INSTANCE

namespace cb {
template <>
std::unique_ptr<CbdptLightTracer>
makeCbdptLightTracerFor<CB_REAL, CB_CHANNELS>(const SceneBytes& scene,
                                              const CbdptLightSettings& settings) {
    return std::make_unique<CB_KERNEL_INSTANCE::LightTracer>(scene, settings);
}
} // namespace cb
