// The scene as the kernels see it: flat arrays of shared structs (kernels/cb_types.h), a BVH,
// the spectra table, and the feature set that decides which kernel code is compiled.
#pragma once

#include "bvh/bvh.h"
#include "bvh/bvh_choice.h"
#include "bvh/bvh_wide.h"
#include "scene/scene_desc.h"

#include "cb_types.h"

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace cb {

enum class ChannelMode { Auto, Rgb, Spectral };

struct DeviceScene {
    int channels = 3; // 3 (RGB) or 16 (spectral bins)
    // Nodes and primitives in leaf order; invisible lights' primitives after the leaves' (in
    // none: no ray finds them).
    Bvh bvh;
    // What the kernels traverse (cb_bvh_wide.h): bvh.nodes collapsed, over bvh.primitives.
    BvhWide wide;
    WideBvhSettings wideSettings; // the SAH settings chosen for it (bvh/bvh_choice.h)
    std::string wideSettingsWhy;  // and the estimates that chose them (describeChoice)
    std::vector<cbk::Material> materials;
    std::vector<cbk::Light> lights;
    std::vector<float> spectra;     // `channels` floats per entry
    std::vector<float> lightTables; // image lights' sampling tables (cb_lights.h)
    // Texture scenes: per primitive (leaf order) its vertices' uv, then the image textures
    // (cb_texture.h); empty otherwise.
    std::vector<float> textures;
    // Scenes with vertex normals: per primitive (leaf order) its vertices' normals, zeros for a
    // primitive without; empty otherwise.
    std::vector<float> shadingNormals;
    // The pieces of pbrt-v4's curves, indexed by their primitives (cb_curve.h).
    std::vector<cbk::CurveSegment> curves;
    std::vector<float> toRgb; // 3 x channels, row-major: linear sRGB from channels
    cbk::Camera camera{};
    // Device coordinates are world coordinates minus this point (the camera position, clamped
    // to the scene's bounds): see buildDeviceScene.
    std::array<double, 3> origin{0, 0, 0};
    std::uint64_t features = 0; // CB_FEATURE_* bits
    // Statistics for `cbdpt info`.
    long triangleCount = 0;
    long vertexCount = 0;
    long sphereCount = 0;
    long curveCount = 0; // pbrt-v4's curves' Bezier segments (each split into pieces)
    long droppedDegenerateTriangles = 0;      // zero area once made camera-relative and rounded
    std::array<double, 3> boundsMin{0, 0, 0}; // world space
    std::array<double, 3> boundsMax{0, 0, 0};

    // Kernel -D defines for this scene: channel count and feature bits.
    std::vector<std::string> kernelDefines() const;
    // The feature bits as words, e.g. "diffuse conductor area-light spheres".
    std::string featureNames() const;
};

// Convert a parsed scene: resolve spectra for the channel mode (Auto: spectral when the file
// uses any `spectrum` parameter), build the BVH, compute light selection probabilities
// (proportional to emitted power) and the camera. Throws SceneError for scenes that cannot be
// rendered (e.g. no lights, invalid film size).
DeviceScene buildDeviceScene(const SceneDesc& desc, ChannelMode mode = ChannelMode::Auto);

} // namespace cb
