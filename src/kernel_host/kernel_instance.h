// One host instantiation of the shared kernel code (kernels/cb_*.h), for one real type and one
// channel count: the only place the host compiles those headers other than as the global `cbk`.
//
// The kernel headers are written once and compiled by PoCL as OpenCL C and by g++ as C++
// (kernels/cb_common.h). Their `real` (CB_REAL) and Spectrum (CB_CHANNELS floats) are fixed at
// compile time, so each (real type, channel count) the host needs is its own instantiation, in a
// translation unit of its own:
//
// - src/kernel_host/kernel_host.cmake compiles each source listed with an instance once, with
//   -DCB_REAL=<real> -DCB_CHANNELS=<channels>; no other file defines either.
// - Such a source includes this header before any header that includes the kernel headers. It
//   puts everything the kernel headers declare in namespace cb::kernels_<real>_<channels>::cbk,
//   so that the instances never collide (One Definition Rule), and adds HostScene, the scene's
//   arrays in that instance's types. The source then writes its code in
//   namespace cb::CB_KERNEL_INSTANCE against `cbk::`.
// - The instance (float, 3) is the kernels' default, the global `::cbk` that every other host
//   file sees (scene/device_scene.h, bvh/, tests): it is included at global scope, not copied,
//   and `cbk::` inside cb::kernels_float_3 names it.
//
// The standard headers the kernel code uses are included here first, at global scope, so that
// their include guards keep them out of the instance's namespace. Each translation unit includes
// the kernel headers once, so no include guard is ever reset.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "scene/scene_bytes.h"

#if !defined(CB_REAL) || !defined(CB_CHANNELS)
#error "kernel_instance.h needs CB_REAL and CB_CHANNELS (src/kernel_host/kernel_host.cmake)"
#endif

#define CB_KERNEL_INSTANCE_NAME_(real, channels) kernels_##real##_##channels
#define CB_KERNEL_INSTANCE_NAME(real, channels) CB_KERNEL_INSTANCE_NAME_(real, channels)
// The namespace of this translation unit's instance, e.g. kernels_double_3.
#define CB_KERNEL_INSTANCE CB_KERNEL_INSTANCE_NAME(CB_REAL, CB_CHANNELS)

// #if cannot compare type names: CB_REAL's size in bits instead.
#define CB_KERNEL_REAL_BITS_float 32
#define CB_KERNEL_REAL_BITS_double 64
#define CB_KERNEL_REAL_BITS_(real) CB_KERNEL_REAL_BITS_##real
#define CB_KERNEL_REAL_BITS(real) CB_KERNEL_REAL_BITS_(real)

#if CB_KERNEL_REAL_BITS(CB_REAL) == 32 && CB_CHANNELS == 3
// The kernels' defaults: the global instance.
#include "cb_bdpt.h"
#include "cb_pt.h"
namespace cb::CB_KERNEL_INSTANCE {
#else
#ifdef CB_COMMON_H
#error "kernel_instance.h must include the kernel headers first in this translation unit"
#endif
namespace cb::CB_KERNEL_INSTANCE {
#include "cb_bdpt.h"
#include "cb_pt.h"
static_assert(sizeof(cbk::real) == CB_KERNEL_REAL_BITS(CB_REAL) / 8);
#endif

// ---- The scene in this instance's types -----------------------------------------------------

// Every field of each scene struct, in declaration order. The device's arrays hold these structs
// in the float layout: only real and 32-bit integer fields and arrays of them (cb_types.h), so
// one struct is these fields' 4-byte words in this order.
template <class Visit> void forEachField(cbk::BvhNodeWide& s, Visit&& visit) {
    visit(s.lo);
    visit(s.hi);
    visit(s.child);
    visit(s.counts);
    visit(s.parent);
    visit(s.lane);
    visit(s.pad);
}
template <class Visit> void forEachField(cbk::TrianglePack& s, Visit&& visit) {
    visit(s.v);
    visit(s.prim);
    visit(s.count);
    visit(s.scalar);
    visit(s.alphaTested);
    visit(s.pad);
}
template <class Visit> void forEachField(cbk::Primitive& s, Visit&& visit) {
    visit(s.p0);
    visit(s.kind);
    visit(s.p1);
    visit(s.material);
    visit(s.p2);
    visit(s.light);
}
template <class Visit> void forEachField(cbk::CurveSegment& s, Visit&& visit) {
    visit(s.cp);
    visit(s.n);
    visit(s.width);
    visit(s.uMin);
    visit(s.uMax);
    visit(s.normalAngle);
    visit(s.invSinNormalAngle);
    visit(s.type);
    visit(s.mirrored);
    visit(s.reverse);
    visit(s.pad);
}
template <class Visit> void forEachField(cbk::Material& s, Visit&& visit) {
    visit(s.kind);
    visit(s.reflectance);
    visit(s.alpha);
    visit(s.eta);
    visit(s.mixFirst);
    visit(s.mixSecond);
    visit(s.mixAmount);
    visit(s.secondSpectrum);
    visit(s.thickness);
    visit(s.layerDepth);
    visit(s.layerSamples);
    visit(s.baseAlpha);
    visit(s.layerAlbedo);
    visit(s.layerG);
    visit(s.reflectanceTexture);
    visit(s.transmittanceTexture);
    visit(s.textureScale);
    visit(s.normalMap);
    visit(s.roughnessTexture);
    visit(s.remapRoughness);
    visit(s.thicknessTexture);
    visit(s.alphaTexture);
    visit(s.displacement);
    visit(s.dispersion);
    visit(s.alphaV);
    visit(s.mediumInside);
    visit(s.mediumOutside);
    visit(s.hairV);
    visit(s.hairS);
    visit(s.hairSinAlpha);
    visit(s.hairCosAlpha);
    visit(s.pad);
}
template <class Visit> void forEachField(cbk::Light& s, Visit&& visit) {
    visit(s.kind);
    visit(s.primitive);
    visit(s.emission);
    visit(s.twoSided);
    visit(s.position);
    visit(s.area);
    visit(s.pickProbability);
    visit(s.cdf);
    visit(s.spotCosStart);
    visit(s.spotCosEnd);
    visit(s.axis);
    visit(s.sceneRadius);
    visit(s.worldFromLight);
    visit(s.imageSize);
    visit(s.imageTable);
    visit(s.invisible);
    visit(s.portal);
}
template <class Visit> void forEachField(cbk::Camera& s, Visit&& visit) {
    visit(s.cameraToWorld);
    visit(s.worldToCamera);
    visit(s.tanHalfFovX);
    visit(s.tanHalfFovY);
    visit(s.width);
    visit(s.height);
    visit(s.screenCenterX);
    visit(s.screenCenterY);
    visit(s.lensRadius);
    visit(s.focalDistance);
    visit(s.filterType);
    visit(s.filterRadiusX);
    visit(s.filterRadiusY);
    visit(s.filterSigma);
    visit(s.filterMitchellB);
    visit(s.filterMitchellC);
    visit(s.filterSincTau);
    visit(s.filterNormalization);
    visit(s.filterAbsCdf);
    visit(s.filterSampleScale);
    visit(s.medium);
    visit(s.sampleClamp);
    visit(s.sensorFromRgb);
    visit(s.pad);
}

// Calls word(element) for each scalar of a field, arrays of arrays included.
template <class Field, class Word> void forEachWord(Field& field, Word&& word) {
    if constexpr (std::is_array_v<Field>) {
        for (auto& element : field)
            forEachWord(element, word);
    } else {
        static_assert(std::is_same_v<Field, cbk::real> || sizeof(Field) == 4,
                      "scene structs hold real and 32-bit integer fields only");
        word(field);
    }
}

// T's size in the float layout, from its field list. In a float instance, where T is that
// layout, also checks that each field sits at the offset the list gives it (the list is in
// declaration order and complete).
template <class T> std::size_t floatLayoutBytes(const char* what) {
    T probe{};
    std::size_t offset = 0;
    forEachField(probe, [&](auto& field) {
        if constexpr (sizeof(cbk::real) == sizeof(float)) {
            const auto at = std::size_t(reinterpret_cast<const unsigned char*>(&field) -
                                        reinterpret_cast<const unsigned char*>(&probe));
            if (at != offset)
                throw std::logic_error(std::string("kernel_instance.h: the field list of ") + what +
                                       " is not in declaration order");
        }
        forEachWord(field, [&](auto&) { offset += 4; });
    });
    if constexpr (sizeof(cbk::real) == sizeof(float))
        if (offset != sizeof(T))
            throw std::logic_error(std::string("kernel_instance.h: the field list of ") + what +
                                   " misses fields");
    return offset;
}

// Reads `count` structs of the device's float layout, `bytes` each, into this instance's T,
// word by word: a copy when real is float, an exact widening when it is double.
template <class T>
std::vector<T> loadSceneArray(const void* data, std::size_t count, std::size_t bytes,
                              const char* what) {
    if (count > 0 && bytes != floatLayoutBytes<T>(what))
        throw std::logic_error(std::string("kernel_instance.h: ") + what + " is " +
                               std::to_string(bytes) + " bytes on the device, " +
                               std::to_string(floatLayoutBytes<T>(what)) + " by its field list");
    std::vector<T> out(count);
    const auto* in = static_cast<const unsigned char*>(data);
    for (T& element : out)
        forEachField(element, [&](auto& field) {
            forEachWord(field, [&](auto& word) {
                using Word = std::remove_reference_t<decltype(word)>;
                if constexpr (std::is_same_v<Word, cbk::real>) {
                    float f;
                    std::memcpy(&f, in, 4);
                    word = cbk::real(f);
                } else {
                    std::memcpy(&word, in, 4);
                }
                in += 4;
            });
        });
    return out;
}

// The scene's arrays in this instance's types and the SceneView over them.
struct HostScene {
    std::vector<cbk::BvhNodeWide> nodes;
    std::vector<cbk::TrianglePack> packs;
    std::vector<cbk::Primitive> primitives;
    std::vector<cbk::Material> materials;
    std::vector<cbk::Light> lights;
    std::vector<cbk::real> spectra;
    std::vector<cbk::real> lightTables;
    std::vector<cbk::real> textures;
    std::vector<cbk::real> shadingNormals;
    std::vector<cbk::CurveSegment> curves;
    std::vector<cbk::real> toRgb; // 3 x CB_CHANNELS
    cbk::Camera camera{};
    cbk::SceneView view{}; // points into the vectors above

    explicit HostScene(const SceneBytes& scene) {
        if (scene.channels != CB_CHANNELS)
            throw std::invalid_argument(
                "host kernel code built for " + std::to_string(CB_CHANNELS) +
                " channels given a scene of " + std::to_string(scene.channels));
        nodes = loadSceneArray<cbk::BvhNodeWide>(scene.nodes, scene.nodeCount, scene.nodeBytes,
                                                 "BvhNodeWide");
        packs = loadSceneArray<cbk::TrianglePack>(scene.packs, scene.packCount, scene.packBytes,
                                                  "TrianglePack");
        primitives = loadSceneArray<cbk::Primitive>(scene.primitives, scene.primitiveCount,
                                                    scene.primitiveBytes, "Primitive");
        materials = loadSceneArray<cbk::Material>(scene.materials, scene.materialCount,
                                                  scene.materialBytes, "Material");
        lights =
            loadSceneArray<cbk::Light>(scene.lights, scene.lightCount, scene.lightBytes, "Light");
        camera = loadSceneArray<cbk::Camera>(scene.camera, 1, scene.cameraBytes, "Camera")[0];
        spectra.assign(scene.spectra, scene.spectra + scene.spectraCount);
        lightTables.assign(scene.lightTables, scene.lightTables + scene.lightTableCount);
        textures.assign(scene.textures, scene.textures + scene.textureCount);
        shadingNormals.assign(scene.shadingNormals,
                              scene.shadingNormals + scene.shadingNormalCount);
        curves = loadSceneArray<cbk::CurveSegment>(scene.curves, scene.curveCount, scene.curveBytes,
                                                   "CurveSegment");
        toRgb.assign(scene.toRgb, scene.toRgb + 3 * CB_CHANNELS);
        view.nodes = nodes.data();
        view.packs = packs.data();
        view.primitives = primitives.data();
        view.materials = materials.data();
        view.lights = lights.data();
        view.spectra = spectra.data();
        view.lightTables = lightTables.data();
        view.textures = textures.data();
        view.shadingNormals = shadingNormals.data();
        view.curves = curves.data();
        view.lightCount = int(lights.size());
        view.features = scene.features;
    }
    HostScene(const HostScene&) = delete;
    HostScene& operator=(const HostScene&) = delete;
};

} // namespace cb::CB_KERNEL_INSTANCE
