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

// Per-pixel running mean and variance of estimates (Welford 1962), in double so that
// thousands of estimates add without loss (METHOD.md, vocabulary).
class EstimateAccumulator {
  public:
    EstimateAccumulator(int width, int height);
    void add(const float* rgb); // one estimate: 3 * width * height floats
    long estimates() const { return count_; }
    int width() const { return width_; }
    int height() const { return height_; }
    RgbImage mean() const;
    // Standard error of the mean per channel: sqrt(sample variance / n); zero for n < 2.
    RgbImage standardError() const;
    // Raw state, for checkpoints and resume.
    const std::vector<double>& meanData() const { return mean_; }
    const std::vector<double>& m2Data() const { return m2_; }
    void restore(long count, std::vector<double> mean, std::vector<double> m2);

  private:
    int width_, height_;
    long count_ = 0;
    std::vector<double> mean_, m2_;
};

// OpenEXR with lossless ZIP compression: channels R, G, B (linear) and, if given, a layer
// "stderr" (stderr.R, stderr.G, stderr.B) holding the per-pixel standard error. Written to a
// temporary file in the same folder, then renamed, so a reader never sees a partial file.
void writeExr(const std::string& path, const RgbImage& image, const RgbImage* standardError = nullptr);
RgbImage readExr(const std::string& path);

// Reinhard et al. 2002 global photographic operator (key 0.18, L_white = the largest scaled
// luminance, so nothing burns out), applied to luminance with colour ratios kept, then sRGB
// encoding; 8-bit RGB, row-major.
std::vector<std::uint8_t> tonemapReinhard(const RgbImage& image, float key = 0.18f);
void writePng(const std::string& path, const RgbImage& image, float key = 0.18f);
void writePng8(const std::string& path, int width, int height, const std::vector<std::uint8_t>& rgb);

// Write `bytes` to `path` atomically (temporary file in the same folder, then rename).
void writeFileAtomically(const std::string& path, const std::string& bytes);
// Temporary name next to `path` for writers that need a file name (OpenEXR, libpng).
std::string temporarySiblingPath(const std::string& path);
void commitTemporary(const std::string& temporary, const std::string& path);

} // namespace cb
