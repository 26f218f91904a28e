#include "image/image.h"

#include "io/files.h"

#include <ImfChannelList.h>
#include <ImfDoubleAttribute.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfIntAttribute.h>
#include <ImfOutputFile.h>
#include <ImfStandardAttributes.h>
#include <ImfStdIO.h>
#include <ImfStringAttribute.h>
#include <png.h>
#include <stb_image.h>
// The decoder's one definition in the program (qoi.h is header-only).
#define QOI_IMPLEMENTATION
#include <qoi.h>

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <stdexcept>
#include <unistd.h>

namespace cb {

void writeExr(const std::string& path, const RgbImage& image, const RgbImage* standardError) {
    std::vector<ExrLayer> layers{{"", &image}};
    if (standardError) layers.push_back({"stderr", standardError});
    writeExr(path, layers, {});
}

namespace {
std::string channelName(const std::string& layer, int channel) {
    const char* names[3] = {"R", "G", "B"};
    return layer.empty() ? names[channel] : layer + "." + names[channel];
}
} // namespace

void writeExr(const std::string& path, const std::vector<ExrLayer>& layers,
              const ExrAttributes& attributes) {
    if (layers.empty() || !layers[0].image)
        throw std::invalid_argument("writeExr: no image to write to " + path);
    const int w = layers[0].image->width, h = layers[0].image->height;
    Imf::Header header(w, h);
    header.compression() = Imf::ZIP_COMPRESSION;
    for (const auto& [name, value] : attributes.strings)
        header.insert(name, Imf::StringAttribute(value));
    for (const auto& [name, value] : attributes.ints)
        header.insert(name, Imf::IntAttribute(value));
    for (const auto& [name, value] : attributes.doubles)
        header.insert(name, Imf::DoubleAttribute(value));
    Imf::FrameBuffer fb;
    const size_t xStride = 3 * sizeof(float), yStride = xStride * size_t(w);
    for (const ExrLayer& layer : layers) {
        if (!layer.image || layer.image->width != w || layer.image->height != h)
            throw std::invalid_argument("writeExr: layer '" + layer.name + "' of " + path +
                                        " is missing or not " + std::to_string(w) + "x" +
                                        std::to_string(h));
        for (int c = 0; c < 3; ++c) {
            const std::string name = channelName(layer.name, c);
            header.channels().insert(name, Imf::Channel(Imf::FLOAT));
            fb.insert(name, Imf::Slice(Imf::FLOAT, (char*)(layer.image->rgb.data() + c), xStride,
                                       yStride));
        }
    }
    std::string tmp = temporarySiblingPath(path);
    // Our own stream, checked once OpenEXR is done: its OutputFile writes the line offsets when
    // it is destroyed and swallows a failure there (a disk that filled up at the end).
    std::ofstream stream(tmp, std::ios::binary);
    try {
        if (!stream) throw std::runtime_error("cannot create " + tmp);
        {
            Imf::StdOFStream exrStream(stream, tmp.c_str());
            Imf::OutputFile file(exrStream, header);
            file.setFrameBuffer(fb);
            file.writePixels(h);
        }
        stream.close();
        if (stream.fail()) throw std::runtime_error("the file system refused the last bytes");
    } catch (const std::exception& e) {
        stream.close();
        std::error_code ignored;
        std::filesystem::remove(tmp, ignored);
        throw std::runtime_error("cannot write " + path + ": " + e.what());
    }
    commitTemporary(tmp, path);
}

RgbImage readExr(const std::string& path) {
    RgbImage image;
    if (!readExrLayer(path, "", image))
        throw std::runtime_error("cannot read " + path + ": it has no R, G, B channels");
    return image;
}

bool readExrLayer(const std::string& path, const std::string& layer, RgbImage& out) {
    try {
        Imf::InputFile file(path.c_str());
        for (int c = 0; c < 3; ++c)
            if (!file.header().channels().findChannel(channelName(layer, c))) return false;
        Imath::Box2i dw = file.header().dataWindow();
        const int w = dw.max.x - dw.min.x + 1, h = dw.max.y - dw.min.y + 1;
        out = RgbImage(w, h);
        Imf::FrameBuffer fb;
        const size_t xStride = 3 * sizeof(float), yStride = xStride * size_t(w);
        // OpenEXR addresses pixels by absolute data-window coordinates.
        char* base = (char*)out.rgb.data() - (ptrdiff_t(dw.min.x) * ptrdiff_t(xStride) +
                                              ptrdiff_t(dw.min.y) * ptrdiff_t(yStride));
        for (int c = 0; c < 3; ++c)
            fb.insert(channelName(layer, c),
                      Imf::Slice(Imf::FLOAT, base + size_t(c) * sizeof(float), xStride, yStride));
        file.setFrameBuffer(fb);
        file.readPixels(dw.min.y, dw.max.y);
        return true;
    } catch (const std::exception& e) {
        throw std::runtime_error("cannot read " + path + ": " + e.what());
    }
}

namespace {

// The EXR's "A" channel into image.alpha, where the file has one (pbrt-v4 reads every channel).
void readExrAlpha(const std::string& path, RgbImage& image) {
    try {
        Imf::InputFile file(path.c_str());
        if (!file.header().channels().findChannel("A")) return;
        const Imath::Box2i dw = file.header().dataWindow();
        if (dw.max.x - dw.min.x + 1 != image.width || dw.max.y - dw.min.y + 1 != image.height)
            return;
        image.alpha.assign(size_t(image.width) * size_t(image.height), 1.f);
        const size_t xStride = sizeof(float), yStride = xStride * size_t(image.width);
        char* base = (char*)image.alpha.data() - (ptrdiff_t(dw.min.x) * ptrdiff_t(xStride) +
                                                  ptrdiff_t(dw.min.y) * ptrdiff_t(yStride));
        Imf::FrameBuffer fb;
        fb.insert("A", Imf::Slice(Imf::FLOAT, base, xStride, yStride));
        file.setFrameBuffer(fb);
        file.readPixels(dw.min.y, dw.max.y);
    } catch (const std::exception& e) {
        throw std::runtime_error("cannot read " + path + ": " + e.what());
    }
}

// The EXR's primaries and white point, if the header gives them and they are not sRGB's (Rec.
// 709 primaries, D65 white): pbrt-v4 reads such a file in its own colour space.
std::optional<std::string> nonSrgbChromaticities(const std::string& path) {
    Imf::InputFile file(path.c_str());
    if (!Imf::hasChromaticities(file.header())) return std::nullopt;
    const Imf::Chromaticities c = Imf::chromaticities(file.header());
    const Imf::Chromaticities srgb; // OpenEXR's default: Rec. 709 with D65
    const Imath::V2f given[4] = {c.red, c.green, c.blue, c.white};
    const Imath::V2f expected[4] = {srgb.red, srgb.green, srgb.blue, srgb.white};
    for (int i = 0; i < 4; ++i)
        if (std::fabs(given[i].x - expected[i].x) > 1e-3f ||
            std::fabs(given[i].y - expected[i].y) > 1e-3f)
            return fmt::format("red ({}, {}) green ({}, {}) blue ({}, {}) white ({}, {})", c.red.x,
                               c.red.y, c.green.x, c.green.y, c.blue.x, c.blue.y, c.white.x,
                               c.white.y);
    return std::nullopt;
}

// The sRGB transfer function's inverse (IEC 61966-2-1).
float srgbToLinear(float v) {
    return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
}

RgbImage readPng(const std::string& path, ByteEncoding encoding) {
    png_image png{};
    png.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_file(&png, path.c_str()))
        throw std::runtime_error("cannot read " + path + ": " + png.message);
    // 8-bit files stay encoded and are decoded below, as pbrt-v4 decodes them;
    // 16-bit files come linear (libpng applies their gamma), with alpha premultiplied.
    const bool sixteenBit = (png.format & PNG_FORMAT_FLAG_LINEAR) != 0;
    const bool alpha = (png.format & PNG_FORMAT_FLAG_ALPHA) != 0;
    // pbrt-v4 keeps the alpha of RGBA files only (a grey one's it drops) and decodes it as the
    // colour channels: an 8-bit file's by the texture's encoding, a 16-bit file's by sRGB.
    const bool keepAlpha = alpha && (png.format & PNG_FORMAT_FLAG_COLOR) != 0;
    png.format = sixteenBit ? (alpha ? PNG_FORMAT_LINEAR_RGB_ALPHA : PNG_FORMAT_LINEAR_RGB)
                            : (alpha ? PNG_FORMAT_RGBA : PNG_FORMAT_RGB);
    const int channels = alpha ? 4 : 3;
    RgbImage out(int(png.width), int(png.height));
    const size_t count = size_t(png.width) * size_t(png.height);
    if (keepAlpha) out.alpha.resize(count);
    bool ok;
    if (sixteenBit) {
        std::vector<png_uint_16> data(count * size_t(channels));
        ok = png_image_finish_read(&png, nullptr, data.data(), 0, nullptr) != 0;
        for (size_t i = 0; ok && i < count; ++i) {
            const float a = alpha ? float(data[i * 4 + 3]) : 65535.f;
            for (size_t c = 0; c < 3; ++c)
                out.rgb[i * 3 + c] = a > 0.f ? float(data[i * size_t(channels) + c]) / a : 0.f;
            if (keepAlpha) out.alpha[i] = srgbToLinear(a / 65535.f);
        }
    } else {
        std::vector<png_byte> data(count * size_t(channels));
        ok = png_image_finish_read(&png, nullptr, data.data(), 0, nullptr) != 0;
        auto decode = [&encoding](png_byte byte) {
            const float v = float(byte) / 255.f;
            return encoding.srgb           ? srgbToLinear(v)
                   : encoding.gamma == 1.f ? v
                                           : std::pow(v, encoding.gamma);
        };
        for (size_t i = 0; ok && i < count; ++i) {
            for (size_t c = 0; c < 3; ++c)
                out.rgb[i * 3 + c] = decode(data[i * size_t(channels) + c]);
            if (keepAlpha) out.alpha[i] = decode(data[i * 4 + 3]);
        }
    }
    if (!ok) {
        const std::string message = png.message;
        png_image_free(&png);
        throw std::runtime_error("cannot read " + path + ": " + message);
    }
    return out;
}

// The formats pbrt-v4 reads through stb_image (8-bit values, decoded from sRGB as pbrt-v4 takes
// them whatever the texture's "encoding"), and Radiance HDR (linear floats, as pbrt-v4's reader).
RgbImage readStb(const std::string& path, bool hdr) {
    int w = 0, h = 0, channels = 0;
    void* data = hdr ? static_cast<void*>(stbi_loadf(path.c_str(), &w, &h, &channels, 3))
                     : static_cast<void*>(stbi_load(path.c_str(), &w, &h, &channels, 3));
    if (!data)
        throw std::runtime_error("cannot read " + path + ": " + std::string(stbi_failure_reason()));
    RgbImage out(w, h);
    for (size_t i = 0; i < out.rgb.size(); ++i)
        out.rgb[i] = hdr ? static_cast<const float*>(data)[i]
                         : srgbToLinear(float(static_cast<const unsigned char*>(data)[i]) / 255.f);
    stbi_image_free(data);
    return out;
}

// A QOI image as pbrt-v4's ReadQOI reads it: 8-bit RGB or RGBA decoded by the file's own colour
// space (sRGB, or linear), whatever the texture's "encoding"; an RGBA file's alpha alike.
RgbImage readQoi(const std::string& path) {
    qoi_desc desc{};
    auto* data = static_cast<unsigned char*>(qoi_read(path.c_str(), &desc, 0));
    if (!data)
        throw std::runtime_error("cannot read " + path +
                                 ": not a QOI file, or it ends before its pixels");
    const bool srgb = desc.colorspace == QOI_SRGB;
    auto decode = [srgb](unsigned char byte) {
        const float v = float(byte) / 255.f;
        return srgb ? srgbToLinear(v) : v;
    };
    const size_t channels = desc.channels, count = size_t(desc.width) * size_t(desc.height);
    RgbImage out(int(desc.width), int(desc.height));
    if (channels == 4) out.alpha.resize(count);
    for (size_t i = 0; i < count; ++i) {
        for (size_t c = 0; c < 3; ++c)
            out.rgb[i * 3 + c] = decode(data[i * channels + c]);
        if (channels == 4) out.alpha[i] = decode(data[i * 4 + 3]);
    }
    std::free(data);
    return out;
}

// A portable float map as pbrt-v4's ReadPFM reads it: "PF" (RGB) or "Pf" (grey, read into all
// three channels), width, height and a scale whose sign gives the byte order (negative: little
// endian) and whose magnitude multiplies the values, one whitespace character, then 32-bit
// floats row by row from the image's bottom.
RgbImage readPfm(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw std::runtime_error("cannot read " + path + ": " + std::strerror(errno));
    std::string type;
    long long width = 0, height = 0;
    double scale = 0.0;
    in >> type >> width >> height >> scale;
    if (!in || (type != "PF" && type != "Pf"))
        throw std::runtime_error("cannot read " + path +
                                 ": not a PFM file (expected \"PF\" or \"Pf\", the width, the "
                                 "height and the scale)");
    if (width < 1 || height < 1 || width > 65536 || height > 65536 || !std::isfinite(scale) ||
        scale == 0.0)
        throw std::runtime_error(fmt::format("cannot read {}: PFM size {} x {} or scale {} out of "
                                             "range (1 to 65536 pixels a side, a nonzero scale)",
                                             path, width, height, scale));
    in.get(); // the one whitespace character before the data
    const size_t channels = type == "PF" ? 3 : 1;
    std::vector<float> data(channels * size_t(width) * size_t(height));
    in.read(reinterpret_cast<char*>(data.data()), std::streamsize(data.size() * sizeof(float)));
    if (size_t(in.gcount()) != data.size() * sizeof(float))
        throw std::runtime_error(
            fmt::format("cannot read {}: it ends before its {} x {} pixels", path, width, height));
    const bool fileLittleEndian = scale < 0.0;
    const bool swap = fileLittleEndian != (std::endian::native == std::endian::little);
    const float magnitude = float(std::fabs(scale));
    RgbImage out(static_cast<int>(width), static_cast<int>(height));
    for (size_t row = 0; row < size_t(height); ++row)
        for (size_t x = 0; x < size_t(width); ++x)
            for (size_t c = 0; c < 3; ++c) {
                float v = data[((size_t(height) - 1 - row) * size_t(width) + x) * channels +
                               (channels == 3 ? c : 0)];
                if (swap) {
                    uint32_t bits;
                    std::memcpy(&bits, &v, sizeof bits);
                    bits = (bits >> 24) | ((bits >> 8) & 0xff00u) | ((bits << 8) & 0xff0000u) |
                           (bits << 24);
                    std::memcpy(&v, &bits, sizeof v);
                }
                out.rgb[(row * size_t(width) + x) * 3 + c] = magnitude != 1.f ? v * magnitude : v;
            }
    return out;
}

} // namespace

double rec709Luminance(const float* rgb) {
    return 0.2126 * double(rgb[0]) + 0.7152 * double(rgb[1]) + 0.0722 * double(rgb[2]);
}

RgbImage readRgbImage(const std::string& path, ByteEncoding byteEncoding) {
    std::string extension = std::filesystem::path(path).extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    if (extension == ".png") return readPng(path, byteEncoding);
    if (extension == ".hdr") return readStb(path, true);
    if (extension == ".pfm") return readPfm(path);
    if (extension == ".qoi") return readQoi(path);
    for (const char* stb :
         {".jpg", ".jpeg", ".tga", ".bmp", ".gif", ".psd", ".pnm", ".ppm", ".pgm"})
        if (extension == stb) return readStb(path, false);
    if (extension != ".exr")
        throw std::runtime_error("cannot read " + path +
                                 ": cbdpt reads OpenEXR (.exr), PNG (.png), Radiance HDR (.hdr), "
                                 "PFM (.pfm), QOI (.qoi) and, as pbrt-v4 does through stb_image, "
                                 "JPEG, TGA, BMP, GIF, PSD and PNM images, not \"" +
                                 extension + "\" files");
    RgbImage image = readExr(path);
    readExrAlpha(path, image);
    std::optional<std::string> primaries;
    try {
        primaries = nonSrgbChromaticities(path);
    } catch (const std::exception& e) {
        throw std::runtime_error("cannot read " + path + ": " + e.what());
    }
    if (primaries)
        throw std::runtime_error("cannot use " + path + ": its chromaticities (" + *primaries +
                                 ") are not sRGB's; cbdpt reads images in sRGB (Rec. 709 " +
                                 "primaries, D65 white) only");
    return image;
}

ExrAttributes readExrAttributes(const std::string& path) {
    try {
        Imf::InputFile file(path.c_str());
        ExrAttributes out;
        for (auto it = file.header().begin(); it != file.header().end(); ++it) {
            if (auto* s = dynamic_cast<const Imf::StringAttribute*>(&it.attribute()))
                out.strings[it.name()] = s->value();
            else if (auto* i = dynamic_cast<const Imf::IntAttribute*>(&it.attribute()))
                out.ints[it.name()] = i->value();
            else if (auto* d = dynamic_cast<const Imf::DoubleAttribute*>(&it.attribute()))
                out.doubles[it.name()] = d->value();
        }
        return out;
    } catch (const std::exception& e) {
        throw std::runtime_error("cannot read " + path + ": " + e.what());
    }
}

namespace {
float srgbEncode(float linear) {
    linear = std::clamp(linear, 0.f, 1.f);
    return linear <= 0.0031308f ? 12.92f * linear : 1.055f * std::pow(linear, 1.f / 2.4f) - 0.055f;
}
} // namespace

std::vector<std::uint8_t> tonemapReinhard(const RgbImage& image, float key) {
    const size_t n = size_t(image.width) * size_t(image.height);
    // Log-average luminance (Reinhard et al. 2002, eq. 1), delta avoids log(0) on black pixels.
    const double delta = 1e-6;
    double logSum = 0.0;
    for (size_t i = 0; i < n; ++i)
        logSum += std::log(delta + std::max(0.0, rec709Luminance(&image.rgb[3 * i])));
    const double logAverage = n ? std::exp(logSum / double(n)) : 1.0;
    const double scale = key / logAverage;
    double whiteSquared = 0.0;
    for (size_t i = 0; i < n; ++i) {
        double l = scale * std::max(0.0, rec709Luminance(&image.rgb[3 * i]));
        whiteSquared = std::max(whiteSquared, l * l);
    }
    if (whiteSquared <= 0.0) whiteSquared = 1.0;
    std::vector<std::uint8_t> out(3 * n);
    for (size_t i = 0; i < n; ++i) {
        const float* px = &image.rgb[3 * i];
        double lw = std::max(0.0, rec709Luminance(px));
        double l = scale * lw;
        double ld = l * (1.0 + l / whiteSquared) / (1.0 + l); // eq. 4
        double ratio = lw > 0.0 ? ld / lw : 0.0;
        for (int c = 0; c < 3; ++c) {
            float v = srgbEncode(float(std::max(0.f, px[c]) * ratio));
            out[3 * i + size_t(c)] = std::uint8_t(std::lround(v * 255.f));
        }
    }
    return out;
}

void writePng8(const std::string& path, int width, int height,
               const std::vector<std::uint8_t>& rgb) {
    std::string tmp = temporarySiblingPath(path);
    FILE* fp = std::fopen(tmp.c_str(), "wb");
    if (!fp) throw std::runtime_error("cannot create " + tmp);
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    if (!png || !info || setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        std::fclose(fp);
        std::filesystem::remove(tmp);
        throw std::runtime_error("cannot write PNG " + path);
    }
    png_init_io(png, fp);
    png_set_IHDR(png, info, png_uint_32(width), png_uint_32(height), 8, PNG_COLOR_TYPE_RGB,
                 PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_set_sRGB(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
    png_write_info(png, info);
    for (int y = 0; y < height; ++y)
        png_write_row(png, rgb.data() + size_t(y) * size_t(width) * 3);
    png_write_end(png, nullptr);
    png_destroy_write_struct(&png, &info);
    if (std::fclose(fp) != 0) {
        std::filesystem::remove(tmp);
        throw std::runtime_error("cannot write PNG " + path);
    }
    commitTemporary(tmp, path);
}

void writePng(const std::string& path, const RgbImage& image, float key) {
    writePng8(path, image.width, image.height, tonemapReinhard(image, key));
}

} // namespace cb
