// `cbdpt info [SCENE]`: the OpenCL devices, and a scene's statistics and kernel features.
#include "cl/cl_runtime.h"
#include "cli/cli_options.h"
#include "cli/commands.h"
#include "scene/device_scene.h"
#include "scene/scene_desc.h"

#include <fmt/format.h>

#include <algorithm>

#include <memory>
#include <string>

namespace cb::cli {

namespace {

struct InfoOptions {
    std::string scene;
    DeviceOptions device;
};

// Every device, the one that --device (or CBDPT_DEVICE, or the default) selects marked with *.
void printDevices(const DeviceOptions& o) {
    const auto devices = cb::listClDevices();
    const std::string selector = cb::deviceSelector(o.device);
    const cb::ClDeviceInfo& chosen = cb::chooseClDevice(devices, selector);
    fmt::print("OpenCL devices (select with --device cpu|gpu|P:D or CBDPT_DEVICE; * selected):\n");
    for (const auto& d : devices)
        fmt::print("{} {}:{}  {} | {} | {} | {} compute units, {:.1f} GiB\n",
                   &d == &chosen ? "*" : " ", d.platformIndex, d.deviceIndex, d.platformName,
                   d.deviceName, d.deviceVersion, d.computeUnits,
                   double(d.globalMemoryBytes) / (1024.0 * 1024.0 * 1024.0));
    fmt::print("selected {}:{} ({})\n", chosen.platformIndex, chosen.deviceIndex,
               !o.device.empty()  ? "--device " + o.device
               : selector.empty() ? std::string("default: PoCL's CPU device")
                                  : "CBDPT_DEVICE=" + selector);
}

void printScene(const std::string& scenePath) {
    cb::SceneDesc desc = cb::parseSceneFile(scenePath);
    cb::DeviceScene scene = cb::buildDeviceScene(desc);
    fmt::print("\nscene {}\n", scenePath);
    fmt::print("  triangles        {}\n", scene.triangleCount);
    fmt::print("  vertices         {}\n", scene.vertexCount);
    fmt::print("  spheres          {}\n", scene.sphereCount);
    if (scene.curveCount > 0)
        fmt::print("  curves           {} Bezier segments in {} pieces\n", scene.curveCount,
                   scene.curves.size());
    const auto spots = std::count_if(desc.pointLights.begin(), desc.pointLights.end(),
                                     [](const cb::PointLightDesc& l) { return l.spot; });
    fmt::print("  lights           {} ({} area-light primitives, {} point lights, {} spot, {} "
               "distant, {} infinite)\n",
               scene.lights.size(),
               scene.lights.size() - desc.pointLights.size() - desc.distantLights.size() -
                   desc.infiniteLights.size(),
               desc.pointLights.size() - size_t(spots), spots, desc.distantLights.size(),
               desc.infiniteLights.size());
    for (const cb::InfiniteLightDesc& l : desc.infiniteLights)
        if (l.image.size > 0)
            fmt::print("  environment      {} ({} x {} pixels, equal-area)\n", l.image.path,
                       l.image.size, l.image.size);
    fmt::print("  materials        {}\n", scene.materials.size());
    for (const cb::TextureDesc& t : desc.textures)
        fmt::print("  texture          \"{}\": {} ({} x {} texels)\n", t.name,
                   t.path.empty() ? "made of constants" : t.path, t.width, t.height);
    fmt::print("  bounding box     ({:.4g}, {:.4g}, {:.4g}) - ({:.4g}, {:.4g}, {:.4g})\n",
               scene.boundsMin[0], scene.boundsMin[1], scene.boundsMin[2], scene.boundsMax[0],
               scene.boundsMax[1], scene.boundsMax[2]);
    fmt::print("  BVH              {} nodes, depth {}; wide: {} nodes, {} leaf packs, {:.3g} MB\n",
               scene.bvh.nodes.size(), scene.bvh.depth, scene.wide.nodes.size(),
               scene.wide.packs.size(), double(scene.wide.bytes()) / 1e6);
    fmt::print("  BVH settings     {}\n", scene.wideSettingsWhy);
    // The sensor's colour: a camera's white balance is 6500 K where the file gives none.
    const double kelvin = desc.film.whiteBalance > 0.0 ? desc.film.whiteBalance
                          : desc.film.sensor.empty()   ? 0.0
                                                       : 6500.0;
    fmt::print("  film             {}x{}, sensor {}{}, imaging ratio {:g}{}\n", scene.camera.width,
               scene.camera.height, desc.film.sensor.empty() ? "cie1931" : desc.film.sensor,
               kelvin > 0.0 ? fmt::format(" white-balanced at {:g} K", kelvin) : std::string(),
               desc.film.exposureTime * desc.film.iso / 100.0,
               scene.camera.sampleClamp > 0.f
                   ? fmt::format(", each sample clamped to sensor RGB {:g} (maxcomponentvalue)",
                                 scene.camera.sampleClamp)
                   : std::string());
    if (desc.camera.lensRadius > 0.f)
        fmt::print("  camera           fov {:g}, thin lens of radius {:g}, in focus at {:g}\n",
                   desc.camera.fovDegrees, desc.camera.lensRadius, desc.camera.focalDistance);
    else
        fmt::print("  camera           fov {:g}, pinhole\n", desc.camera.fovDegrees);
    const cb::FilterDesc& f = desc.filter;
    std::string filter = fmt::format("radius {:g} x {:g}", f.radiusX, f.radiusY);
    switch (f.type) {
    case cb::FilterDesc::Type::Box:
        filter = "box, " + filter;
        break;
    case cb::FilterDesc::Type::Triangle:
        filter = "triangle, " + filter;
        break;
    case cb::FilterDesc::Type::Gaussian:
        filter = fmt::format("gaussian, {}, sigma {:g}", filter, f.sigma);
        break;
    case cb::FilterDesc::Type::Mitchell:
        filter = fmt::format("mitchell, {}, B {:.4g}, C {:.4g}", filter, f.mitchellB, f.mitchellC);
        break;
    case cb::FilterDesc::Type::Sinc:
        filter = fmt::format("sinc (Lanczos), {}, tau {:g}", filter, f.sincTau);
        break;
    }
    fmt::print("  pixel filter     {}\n", filter);
    fmt::print("  kernel features  {}\n", scene.featureNames());
    std::string defines;
    for (const auto& d : scene.kernelDefines())
        defines += " -D" + d;
    fmt::print("  kernel defines  {}\n", defines);
    if (desc.droppedDegenerateTriangles)
        fmt::print("  dropped          {} degenerate triangles\n", desc.droppedDegenerateTriangles);
}

int runInfo(const InfoOptions& o) {
    applyThreadLimit(o.device);
    printDevices(o.device);
    if (!o.scene.empty()) printScene(o.scene);
    return 0;
}

} // namespace

Command addInfoCommand(CLI::App& app) {
    auto o = std::make_shared<InfoOptions>();
    auto* cmd = app.add_subcommand("info", "list OpenCL devices; describe a scene");
    cmd->add_option("scene", o->scene, "scene file");
    addDeviceOptions(*cmd, o->device);
    return {cmd, [o] { return runInfo(*o); }};
}

} // namespace cb::cli
