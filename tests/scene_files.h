// Scene files written by a test case: images and scene text in a temporary folder, so that the
// scene's relative file names resolve there, removed when the case ends.
#pragma once

#include "image/image.h"
#include "scene/device_scene.h"
#include "scene/scene_desc.h"

#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <system_error>
#include <unistd.h>

namespace cbtest::scene_files {

inline std::filesystem::path tempDirPath() {
    return std::filesystem::temp_directory_path() /
           ("cbdpt-scene-files-" + std::to_string(::getpid()));
}

// Removes tempDir() when a test case ends, passed or not.
struct TempDirCleanup {
    ~TempDirCleanup() {
        std::error_code ignored;
        std::filesystem::remove_all(tempDirPath(), ignored);
    }
};

// The folder, created on first use; removed when the process exits too, so that a case that only
// parses (CTest runs each case in its own process) leaves nothing behind.
inline std::filesystem::path tempDir() {
    static const TempDirCleanup atExit;
    const std::filesystem::path d = tempDirPath();
    std::filesystem::create_directories(d);
    return d;
}

// An image whose pixel (x, y) is value(x, y, channel), written as EXR.
template <class Value> std::string writeImage(const std::string& name, int w, int h, Value value) {
    cb::RgbImage image(w, h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < 3; ++c)
                image.rgb[3 * size_t(y * w + x) + size_t(c)] = value(x, y, c);
    const std::string path = (tempDir() / name).string();
    cb::writeExr(path, image);
    return path;
}

// A scene in the temporary folder (so that relative image names resolve there).
inline cb::SceneDesc parseInTemp(const std::string& text) {
    return cb::parseSceneString(text, (tempDir() / "t.pbrt").string());
}

inline std::string errorOf(const std::string& text) {
    try {
        parseInTemp(text);
    } catch (const cb::SceneError& e) {
        return e.what();
    }
    return "";
}

// The error of parsing `text` in the temporary folder and building its device scene; "" for none.
inline std::string deviceErrorOf(const std::string& text) {
    try {
        cb::buildDeviceScene(parseInTemp(text));
    } catch (const cb::SceneError& e) {
        return e.what();
    }
    return "";
}

// The sRGB curve's inverse, as pbrt-v4 decodes an 8-bit texture's channels (alpha included),
// written apart from the reader's.
inline double srgbByte(int byte) {
    const double v = byte / 255.0;
    return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
}

// A closed box from (x0, y0, z0) to (x1, y1, z1), its normals out (a medium's boundary).
inline std::string boxShape(double x0, double y0, double z0, double x1, double y1, double z1) {
    return fmt::format("Shape \"trianglemesh\" \"integer indices\" [0 2 1 0 3 2  4 5 6 4 6 7  "
                       "0 1 5 0 5 4  1 2 6 1 6 5  2 3 7 2 7 6  3 0 4 3 4 7] \"point3 P\" "
                       "[{0} {1} {2}  {3} {1} {2}  {3} {4} {2}  {0} {4} {2}  {0} {1} {5}  "
                       "{3} {1} {5}  {3} {4} {5}  {0} {4} {5}]\n",
                       x0, y0, z0, x1, y1, z1);
}

inline bool contains(const std::string& s, const std::string& part) {
    return s.find(part) != std::string::npos;
}

} // namespace cbtest::scene_files
