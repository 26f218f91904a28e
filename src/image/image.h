// Images: the running per-pixel statistics of estimates, and OpenEXR / PNG output.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace cb {

// Linear RGB float image, row-major, top row first.
struct RgbImage {
    int width = 0;
    int height = 0;
    std::vector<float> rgb; // 3 * width * height
    // width * height, where readRgbImage read a file with an alpha channel (as pbrt-v4 decodes
    // it); empty otherwise. The RGB values are never premultiplied by it.
    std::vector<float> alpha;

    RgbImage() = default;
    RgbImage(int w, int h) : width(w), height(h), rgb(size_t(3) * size_t(w) * size_t(h), 0.f) {}
};

// Attributes written into an EXR header (OpenEXR string, int and double attributes), so a
// file says how it was made (image/render_record.h).
struct ExrAttributes {
    std::map<std::string, std::string> strings;
    std::map<std::string, int> ints;
    std::map<std::string, double> doubles;
};

// One RGB layer of an EXR file: channels NAME.R, NAME.G, NAME.B, or R, G, B for the name "".
struct ExrLayer {
    std::string name;
    const RgbImage* image = nullptr;
};

// OpenEXR with lossless ZIP compression: channels R, G, B (linear) and, if given, a layer
// "stderr" (stderr.R, stderr.G, stderr.B) holding the per-pixel standard error. Written to a
// temporary file in the same folder, then renamed, so a reader never sees a partial file.
void writeExr(const std::string& path, const RgbImage& image,
              const RgbImage* standardError = nullptr);
// Any layers (all of one size) and header attributes, written the same way.
void writeExr(const std::string& path, const std::vector<ExrLayer>& layers,
              const ExrAttributes& attributes);
RgbImage readExr(const std::string& path);
// Reads layer `name` ("" for R, G, B); false if the file lacks any of its three channels.
bool readExrLayer(const std::string& path, const std::string& name, RgbImage& out);
// Luminance Y of linear sRGB (Rec. 709 primaries, D65): 0.2126 R + 0.7152 G + 0.0722 B, in double.
double rec709Luminance(const float* rgb);

// A linear RGB image from an OpenEXR file (R, G, B channels; sRGB primaries, or none given), a
// PFM, a Radiance HDR, an image stb_image reads, or a PNG (8-bit decoded by `byteEncoding`;
// 16-bit by its gamma), with its alpha channel where it has
// one (EXR "A"; an RGBA PNG's, decoded as pbrt-v4 decodes it: by the 8-bit encoding, or for 16
// bits by the sRGB curve): what pbrt-v4's image lights and image textures read.
// std::runtime_error naming the file otherwise.
// pbrt-v4's "encoding" of 8-bit values v / 255: the sRGB curve, or v^gamma ("linear": gamma 1).
struct ByteEncoding {
    bool srgb = true;
    float gamma = 1.f;
};
RgbImage readRgbImage(const std::string& path, ByteEncoding byteEncoding = {});
// The header's string, int and double attributes (others, e.g. OpenEXR's own, are skipped).
ExrAttributes readExrAttributes(const std::string& path);

// Reinhard et al. 2002 global photographic operator (key 0.18, L_white = the largest scaled
// luminance, so nothing burns out), applied to luminance with colour ratios kept, then sRGB
// encoding; 8-bit RGB, row-major.
std::vector<std::uint8_t> tonemapReinhard(const RgbImage& image, float key = 0.18f);
void writePng(const std::string& path, const RgbImage& image, float key = 0.18f);
void writePng8(const std::string& path, int width, int height,
               const std::vector<std::uint8_t>& rgb);

} // namespace cb
