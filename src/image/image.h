// Images: the running per-pixel statistics of estimates, and OpenEXR / PNG output.
#pragma once

#include <array>
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

    RgbImage() = default;
    RgbImage(int w, int h) : width(w), height(h), rgb(size_t(3) * size_t(w) * size_t(h), 0.f) {}
};

// Per-pixel running mean and variance of estimates (Welford 1962), in double so that
// thousands of estimates add without loss.
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

    // Two disjoint halves of the estimates: the accumulator's k-th estimate (from 0) also goes
    // to half k % 2. The halves are independent, so statistics of one can weight the values of
    // the other without bias (image/combine.h). Call before the first add.
    void trackHalves();
    bool tracksHalves() const { return halvesTracked_; }
    long halfEstimates(int half) const { return halves_[size_t(half)].count; }
    RgbImage halfMean(int half) const;
    RgbImage halfStandardError(int half) const;
    const std::vector<double>& halfMeanData(int half) const { return halves_[size_t(half)].mean; }
    const std::vector<double>& halfM2Data(int half) const { return halves_[size_t(half)].m2; }
    void restoreHalf(int half, long count, std::vector<double> mean, std::vector<double> m2);
    // A resumed render whose saved state has no halves stops tracking them.
    void dropHalves();

  private:
    struct Half {
        long count = 0;
        std::vector<double> mean, m2;
    };
    int width_, height_;
    long count_ = 0;
    std::vector<double> mean_, m2_;
    bool halvesTracked_ = false;
    std::array<Half, 2> halves_;
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
// The header's string, int and double attributes (others, e.g. OpenEXR's own, are skipped).
ExrAttributes readExrAttributes(const std::string& path);

// Reinhard et al. 2002 global photographic operator (key 0.18, L_white = the largest scaled
// luminance, so nothing burns out), applied to luminance with colour ratios kept, then sRGB
// encoding; 8-bit RGB, row-major.
std::vector<std::uint8_t> tonemapReinhard(const RgbImage& image, float key = 0.18f);
void writePng(const std::string& path, const RgbImage& image, float key = 0.18f);
void writePng8(const std::string& path, int width, int height,
               const std::vector<std::uint8_t>& rgb);

// Write `bytes` to `path` atomically (temporary file in the same folder, then rename).
void writeFileAtomically(const std::string& path, const std::string& bytes);
// Temporary name next to `path` for writers that need a file name (OpenEXR, libpng).
std::string temporarySiblingPath(const std::string& path);
void commitTemporary(const std::string& temporary, const std::string& path);

} // namespace cb
