// libFuzzer target for the scene parser (cb::parseSceneString). A SceneError is the parser's
// documented answer to bad input; anything else escaping, a crash, a sanitizer report, a hang or
// a huge allocation is a finding. So is a scene that loads but breaks the guarantees the rest of
// cbdpt relies on (checked below): the parser promises to reject what the renderer cannot use,
// e.g. a parameter that is finite as written but overflows to Inf once stored as a float.
#include "scene/scene_desc.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <string>

namespace {

// Written to stdout: scripts/fuzz closes stderr (-close_fd_mask=2) to silence parser warnings.
[[noreturn]] void broken(const char* what) {
    std::printf("fuzz_scene: loaded scene breaks an invariant: %s\n", what);
    std::fflush(stdout);
    std::abort();
}

bool finiteFloat(double v) {
    return std::isfinite(v) && std::fabs(v) <= std::numeric_limits<float>::max();
}

void checkSpectrum(const cb::SpectrumValue& s, bool reflectance, const char* what) {
    auto ok = [&](float v) { return std::isfinite(v) && v >= 0.f && (!reflectance || v <= 1.f); };
    if (s.isRgb) {
        for (float v : s.rgb)
            if (!ok(v)) broken(what);
        return;
    }
    if (s.samples.empty()) broken(what);
    float last = 0.f;
    for (const auto& [lambda, v] : s.samples) {
        if (!std::isfinite(lambda) || !(lambda > last) || !ok(v)) broken(what);
        last = lambda;
    }
}

void checkIndex(int i, size_t n, bool optional, const char* what) {
    if (optional && i == -1) return;
    if (i < 0 || static_cast<size_t>(i) >= n) broken(what);
}

void checkScene(const cb::SceneDesc& s) {
    const size_t nm = s.materials.size(), nl = s.areaLights.size();
    for (double v : s.camera.worldToCamera)
        if (!std::isfinite(v)) broken("camera matrix not finite");
    if (!(s.camera.fovDegrees > 0.f && s.camera.fovDegrees < 180.f)) broken("fov out of range");
    if (!(s.camera.lensRadius >= 0.f && s.camera.lensRadius <= 1e6f)) broken("lens radius");
    if (!(s.camera.focalDistance > 0.f && std::isfinite(s.camera.focalDistance)))
        broken("focal distance");
    if (s.film.width < 1 || s.film.height < 1 || s.film.width > 65536 || s.film.height > 65536)
        broken("film resolution out of range");
    const cb::FilterDesc& f = s.filter;
    if (!(f.radiusX > 0.0 && f.radiusX <= 32.0 && f.radiusY > 0.0 && f.radiusY <= 32.0))
        broken("filter radius");
    if (!(f.sigma > 0.0 && f.sigma <= 32.0)) broken("filter sigma");
    if (!(std::fabs(f.mitchellB) <= 100.0 && std::fabs(f.mitchellC) <= 100.0))
        broken("filter B or C");
    if (!(f.sincTau >= 0.1 && f.sincTau <= 32.0)) broken("filter tau");
    for (const cb::MaterialDesc& m : s.materials) {
        checkSpectrum(m.reflectance, true, "material reflectance");
        checkSpectrum(m.transmittance, true, "material transmittance");
        if (!std::isfinite(m.scale)) broken("material scale");
        if (!(m.thickness >= 0.f && std::isfinite(m.thickness))) broken("coat thickness");
        if (m.layerDepth < 0 || m.layerDepth > 1000) broken("coat maxdepth");
        if (m.layerSamples < 1 || m.layerSamples > 1000) broken("coat nsamples");
        if (!(m.layerG >= -1.f && m.layerG <= 1.f)) broken("coat g");
        if (m.layerAlbedo) checkSpectrum(*m.layerAlbedo, true, "coat albedo");
        if (!std::isfinite(m.roughness) || m.roughness < 0.f) broken("roughness");
        if (!std::isfinite(m.baseRoughness) || m.baseRoughness < 0.f) broken("conductor roughness");
        if (!std::isfinite(m.eta) || !(m.eta > 0.f)) broken("eta");
        if (m.etaSpectrum) {
            checkSpectrum(*m.etaSpectrum, false, "dispersive eta");
            for (const auto& sample : m.etaSpectrum->samples)
                if (!(sample.second > 0.f)) broken("dispersive eta not positive");
        }
        if (!(m.amount >= 0.f && m.amount <= 1.f)) broken("mix amount");
        checkIndex(m.reflectanceTexture, s.textures.size(), true, "reflectance texture");
        checkIndex(m.normalMap, s.textures.size(), true, "normal map");
        checkIndex(m.roughnessTexture, s.textures.size(), true, "roughness texture");
        checkIndex(m.displacement, s.textures.size(), true, "displacement texture");
        if (m.kind == cb::MaterialKind::Mix) {
            for (int i : m.mix)
                checkIndex(i, nm, false, "mix component index");
            double total = 0.0;
            for (const auto& [leaf, weight] : cb::mixLeaves(s, int(&m - s.materials.data()))) {
                if (s.materials[size_t(leaf)].kind == cb::MaterialKind::Mix) broken("mix leaf");
                total += weight;
            }
            if (std::fabs(total - 1.0) > 1e-9) broken("mix weights");
        }
    }
    for (const cb::AreaLightDesc& l : s.areaLights) {
        checkSpectrum(l.radiance, false, "area light L");
        if (!std::isfinite(l.scale) || l.scale < 0.f) broken("area light scale");
    }
    for (const cb::PointLightDesc& l : s.pointLights) {
        checkSpectrum(l.intensity, false, "point light I");
        if (!std::isfinite(l.scale) || l.scale < 0.f) broken("point light scale");
        for (double c : l.position)
            if (!finiteFloat(c)) broken("point light position");
    }
    for (const cb::InfiniteLightDesc& l : s.infiniteLights) {
        checkSpectrum(l.radiance, false, "infinite light L");
        if (!std::isfinite(l.scale) || l.scale < 0.f) broken("infinite light scale");
        if (l.image.size < 0 || l.image.rgb.size() != 3 * static_cast<size_t>(l.image.size) *
                                                          static_cast<size_t>(l.image.size))
            broken("infinite light image size");
        for (float v : l.image.rgb)
            if (!std::isfinite(v)) broken("infinite light pixel");
        // The light's frame must be a rotation (the image map stays equal-area).
        for (int a = 0; a < 3; ++a)
            for (int b = 0; b < 3; ++b) {
                double dot = 0.0;
                for (int r = 0; r < 3; ++r)
                    dot += l.worldFromLight[static_cast<size_t>(r * 3 + a)] *
                           l.worldFromLight[static_cast<size_t>(r * 3 + b)];
                if (!(std::fabs(dot - (a == b ? 1.0 : 0.0)) < 1e-5)) broken("infinite light frame");
            }
    }
    for (const cb::SphereDesc& sp : s.spheres) {
        for (double c : sp.center)
            if (!finiteFloat(c)) broken("sphere centre");
        if (!std::isfinite(sp.radius) || !(sp.radius > 0.f)) broken("sphere radius");
        checkIndex(sp.material, nm, false, "sphere material");
        checkIndex(sp.areaLight, nl, true, "sphere area light");
    }
    for (const cb::CurveDesc& c : s.curves) {
        for (const auto& p : c.cp)
            for (double v : p)
                if (!finiteFloat(v)) broken("curve control point");
        if (!std::isfinite(c.width0) || !std::isfinite(c.width1) || c.width0 < 0.f ||
            c.width1 < 0.f || !(std::max(c.width0, c.width1) > 0.f))
            broken("curve width");
        if (c.type == cb::CurveDesc::Type::Ribbon)
            for (const auto& n : c.normals)
                if (!(std::fabs(n[0] * n[0] + n[1] * n[1] + n[2] * n[2] - 1.0) < 1e-6))
                    broken("ribbon normal not unit");
        if (c.splitDepth < 0 || c.splitDepth > 10) broken("curve split depth");
        checkIndex(c.material, nm, false, "curve material");
    }
    for (const cb::TriangleMeshDesc& m : s.meshes) {
        for (const auto& p : m.positions)
            for (double c : p)
                if (!finiteFloat(c)) broken("mesh vertex");
        for (const auto& t : m.triangles) {
            for (unsigned i : t)
                if (i >= m.positions.size()) broken("triangle index");
            if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) broken("degenerate triangle kept");
        }
        checkIndex(m.material, nm, false, "mesh material");
        checkIndex(m.areaLight, nl, true, "mesh area light");
        checkIndex(m.alphaTexture, s.textures.size(), true, "mesh alpha texture");
        if (!m.cornerUv.empty() && m.cornerUv.size() != m.triangles.size())
            broken("texture coordinates not one per triangle");
        for (const auto& uv : m.cornerUv)
            for (float c : uv)
                if (!std::isfinite(c)) broken("texture coordinate");
        if (!m.normals.empty() && m.normals.size() != m.positions.size())
            broken("vertex normals not one per vertex");
        for (const auto& n : m.normals)
            for (double c : n)
                if (!std::isfinite(c)) broken("vertex normal");
    }
    for (const cb::TextureDesc& t : s.textures) {
        if (t.width < 1 || t.height < 1 ||
            t.rgb.size() != 3 * static_cast<size_t>(t.width) * static_cast<size_t>(t.height))
            broken("texture size");
        for (float v : t.rgb)
            if (!std::isfinite(v)) broken("texel");
        for (float v : t.mapping)
            if (!std::isfinite(v)) broken("texture mapping");
    }
    if (s.droppedDegenerateTriangles < 0) broken("negative dropped-triangle count");
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string text(reinterpret_cast<const char*>(data), size);
    cb::SceneDesc scene;
    try {
        // The virtual path sits in a folder that does not exist, so relative Include/plymesh
        // names resolve nowhere and the target does not depend on what lies in the working
        // directory (the model search path is cleared by scripts/fuzz).
        scene = cb::parseSceneString(text, "/nonexistent-cbdpt-fuzz/fuzz.pbrt");
    } catch (const cb::SceneError&) {
        return 0;
    }
    checkScene(scene);
    return 0;
}
