// Images: the running per-pixel statistics of estimates, and OpenEXR / PNG output.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace cb {

// Linear RGB float image, row-major, top row first.
struct RgbImage {
    int width = 0;
    int height = 0;
    std::vector<float> rgb; // 3 * width * height

    RgbImage() = default;
    RgbImage(int w, int h) : width(w), height(h), rgb(size_t(3) * size_t(w) * size_t(h), 0.f) {}
};

// OpenEXR with lossless ZIP compression: channels R, G, B (linear) and, if given, a layer
// "stderr" (stderr.R, stderr.G, stderr.B) holding the per-pixel standard error. Written to a
// temporary file in the same folder, then renamed, so a reader never sees a partial file.
void writeExr(const std::string& path, const RgbImage& image,
              const RgbImage* standardError = nullptr);
RgbImage readExr(const std::string& path);

// Reinhard et al. 2002 global photographic operator (key 0.18, L_white = the largest scaled
// luminance, so nothing burns out), applied to luminance with colour ratios kept, then sRGB
// encoding; 8-bit RGB, row-major.
std::vector<std::uint8_t> tonemapReinhard(const RgbImage& image, float key = 0.18f);
void writePng(const std::string& path, const RgbImage& image, float key = 0.18f);
void writePng8(const std::string& path, int width, int height,
               const std::vector<std::uint8_t>& rgb);

// Write `bytes` to `path` atomically (temporary file in the same folder, then rename).
void writeFileAtomically(const std::string& path, const std::string& bytes);
// Throws std::runtime_error naming `what` and `path` unless a file can be created at `path`
// (its folder exists and is writable, and it is not a folder): checked before long work. Leaves
// nothing behind and never touches an existing file at `path`.
void requireWritable(const std::string& path, const std::string& what);
// Where to keep work when its own destination cannot be written: `name` in $TMPDIR (or /tmp),
// else in the current folder; the first folder where a file can be created. Throws if none.
std::string fallbackPath(const std::string& name);
// Temporary name next to `path` for writers that need a file name (OpenEXR, libpng).
std::string temporarySiblingPath(const std::string& path);
void commitTemporary(const std::string& temporary, const std::string& path);

} // namespace cb
