#include "image/metrics.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace cb {

void requireSameSize(const RgbImage& image, const RgbImage& reference, const std::string& imageName,
                     const std::string& referenceName) {
    if (image.width != reference.width || image.height != reference.height)
        throw std::invalid_argument(fmt::format("image sizes differ: {} is {}x{} but {} is {}x{}",
                                                imageName, image.width, image.height, referenceName,
                                                reference.width, reference.height));
    if (image.rgb.size() != reference.rgb.size() ||
        image.rgb.size() != size_t(3) * size_t(image.width) * size_t(image.height))
        throw std::invalid_argument(
            fmt::format("{} or {} has a malformed pixel buffer", imageName, referenceName));
}

ImageMetrics compareImages(const RgbImage& image, const RgbImage& reference) {
    requireSameSize(image, reference, "the image", "the reference");
    ImageMetrics m;
    const size_t n = image.rgb.size();
    if (n == 0) return m;
    double squared = 0.0, relative = 0.0, absolute = 0.0, refSum = 0.0;
    for (size_t i = 0; i < n; ++i) {
        const double r = reference.rgb[i];
        const double d = double(image.rgb[i]) - r;
        squared += d * d;
        relative += d * d / (r * r + kRelMseEpsilon);
        absolute += std::abs(d);
        refSum += r;
    }
    m.rmse = std::sqrt(squared / double(n));
    m.relMse = relative / double(n);
    m.mae = absolute / double(n);
    m.referenceMean = refSum / double(n);
    return m;
}

double rootMeanSquaredError(const RgbImage& image, const RgbImage& reference) {
    return compareImages(image, reference).rmse;
}

double relativeMeanSquaredError(const RgbImage& image, const RgbImage& reference, double epsilon) {
    requireSameSize(image, reference, "the image", "the reference");
    if (image.rgb.empty()) return ImageMetrics::nan;
    double sum = 0.0;
    for (size_t i = 0; i < image.rgb.size(); ++i) {
        const double r = reference.rgb[i];
        const double d = double(image.rgb[i]) - r;
        sum += d * d / (r * r + epsilon);
    }
    return sum / double(image.rgb.size());
}

double meanAbsoluteError(const RgbImage& image, const RgbImage& reference) {
    return compareImages(image, reference).mae;
}

double meanOf(const std::vector<float>& values) {
    if (values.empty()) return ImageMetrics::nan;
    double sum = 0.0;
    for (float v : values)
        sum += v;
    return sum / double(values.size());
}

double rootMeanSquareOf(const std::vector<float>& values) {
    if (values.empty()) return ImageMetrics::nan;
    double sum = 0.0;
    for (float v : values)
        sum += double(v) * double(v);
    return std::sqrt(sum / double(values.size()));
}

double meanValue(const RgbImage& image) {
    return meanOf(image.rgb);
}

NoiseEstimate estimateNoise(const EstimateAccumulator& accumulator) {
    NoiseEstimate out;
    const size_t values = accumulator.values();
    if (values == 0) return out;
    double meanSum = 0.0;
    for (size_t i = 0; i < values; ++i)
        meanSum += accumulator.meanAt(i);
    out.imageMean = meanSum / double(values);
    const long count = accumulator.estimates();
    if (count < 2) return out;
    // Variance of the mean = sample variance / n.
    double seSum = 0.0, varSum = 0.0;
    for (size_t i = 0; i < values; ++i) {
        const double var = accumulator.varianceAt(i) / double(count);
        seSum += std::sqrt(var);
        varSum += var;
    }
    out.meanStandardError = seSum / double(values);
    out.rmsStandardError = std::sqrt(varSum / double(values));
    return out;
}

bool readExrStandardError(const std::string& path, RgbImage& out) {
    return readExrLayer(path, "stderr", out);
}

std::vector<std::uint8_t> relativeErrorColourMap(const RgbImage& image, const RgbImage& reference,
                                                 double scale) {
    requireSameSize(image, reference, "the image", "the reference");
    if (!(scale > 0.0)) throw std::invalid_argument("the colour-map scale must be positive");
    const size_t n = size_t(image.width) * size_t(image.height);
    std::vector<std::uint8_t> out(3 * n, 0);
    for (size_t i = 0; i < n; ++i) {
        const double l = rec709Luminance(&image.rgb[3 * i]);
        const double lr = rec709Luminance(&reference.rgb[3 * i]);
        if (!std::isfinite(l) || !std::isfinite(lr)) continue; // black: no error to show
        double e = (l - lr) / (std::abs(lr) + kRelMseEpsilon);
        if (!std::isfinite(e)) e = l > lr ? scale : -scale; // overflow of finite values
        const double t = std::clamp(e / scale, -1.0, 1.0);
        // White at zero, fading linearly to pure red (t = 1) or pure blue (t = -1).
        const double fade = 1.0 - std::abs(t);
        double r = 1.0, g = fade, b = fade;
        if (t < 0.0) {
            r = fade;
            b = 1.0;
        }
        out[3 * i + 0] = std::uint8_t(std::lround(r * 255.0));
        out[3 * i + 1] = std::uint8_t(std::lround(g * 255.0));
        out[3 * i + 2] = std::uint8_t(std::lround(b * 255.0));
    }
    return out;
}

} // namespace cb
