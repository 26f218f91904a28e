// Scenes built in code for tests that must not depend on the parser.
#pragma once

#include "scene/scene_desc.h"

#include <array>

namespace cbtest {

// An axis-aligned box [lo, hi]^3 as 12 triangles whose normals point inward, so that a camera
// inside sees the front faces.
inline cb::TriangleMeshDesc insideOutBox(float lo, float hi, int material, int areaLight) {
    cb::TriangleMeshDesc mesh;
    for (int i = 0; i < 8; ++i)
        mesh.positions.push_back({(i & 1) ? hi : lo, (i & 2) ? hi : lo, (i & 4) ? hi : lo});
    const unsigned faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                  {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    for (const auto& f : faces) {
        // The quads are listed counter-clockwise seen from outside; reverse them.
        mesh.triangles.push_back({f[0], f[2], f[1]});
        mesh.triangles.push_back({f[0], f[3], f[2]});
    }
    mesh.material = material;
    mesh.areaLight = areaLight;
    return mesh;
}

// The furnace: a closed box of diffuse albedo `albedo` whose every face emits radiance
// `emission` inward, camera at the centre. Radiance is Le * (1 - a^(n-1)) / (1 - a) for paths of
// at most n vertices (camera included).
inline cb::SceneDesc furnaceScene(float albedo, float emission, int size = 16) {
    cb::SceneDesc desc;
    desc.path = "<furnace>";
    desc.film.width = size;
    desc.film.height = size;
    desc.camera.fovDegrees = 60.f;
    cb::MaterialDesc material;
    material.kind = cb::MaterialKind::Diffuse;
    material.reflectance = cb::SpectrumValue::constant(albedo);
    desc.materials.push_back(material);
    cb::AreaLightDesc light;
    light.radiance = cb::SpectrumValue::constant(emission);
    desc.areaLights.push_back(light);
    desc.meshes.push_back(insideOutBox(-1.f, 1.f, 0, 0));
    return desc;
}

// Maps the world by p -> s p + t: geometry, lights and camera (so the image must not change).
inline void transformWorld(cb::SceneDesc& desc, double s, const std::array<double, 3>& t) {
    auto map = [&](std::array<double, 3>& p) {
        for (int a = 0; a < 3; ++a)
            p[size_t(a)] = s * p[size_t(a)] + t[size_t(a)];
    };
    for (auto& mesh : desc.meshes)
        for (auto& p : mesh.positions)
            map(p);
    for (auto& sphere : desc.spheres) {
        map(sphere.center);
        sphere.radius = float(s * double(sphere.radius));
    }
    for (auto& light : desc.pointLights) {
        map(light.position);
        light.scale = float(double(light.scale) * s * s); // intensity scales with r^2
    }
    // worldToCamera' = worldToCamera * T^-1, with T^-1 p = (p - t) / s.
    auto& m = desc.camera.worldToCamera;
    std::array<double, 16> out = m;
    for (int r = 0; r < 4; ++r) {
        for (int c = 0; c < 3; ++c)
            out[size_t(r * 4 + c)] = m[size_t(r * 4 + c)] / s;
        double shift = 0.0;
        for (int c = 0; c < 3; ++c)
            shift += m[size_t(r * 4 + c)] * t[size_t(c)] / s;
        out[size_t(r * 4 + 3)] = m[size_t(r * 4 + 3)] - shift;
    }
    m = out;
}

} // namespace cbtest
