// Image error metrics for error-against-time studies: RMSE, relative MSE, mean
// absolute error against a reference, and the noise level a render reports about itself (the
// per-pixel standard error from the spread across estimates).
#pragma once

#include "image/accumulator.h"
#include "image/image.h"

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace cb {

// Relative MSE's epsilon. Relative MSE as in Rousselle, Knaus and Zwicker 2011 ("Adaptive
// sampling and reconstruction using greedy error minimization"): squared error divided by the
// squared reference plus a small epsilon so that near-black pixels do not dominate. Our images are
// linear radiance with means around 0.1-1, so we fix epsilon = 1e-2 for every log and report.
inline constexpr double kRelMseEpsilon = 1e-2;

// Every average below runs over all pixels and all three channels, in double.
struct ImageMetrics {
    static constexpr double nan = std::numeric_limits<double>::quiet_NaN();
    double rmse = nan;   // sqrt(mean (x - ref)^2)
    double relMse = nan; // mean (x - ref)^2 / (ref^2 + kRelMseEpsilon)
    double mae = nan;    // mean |x - ref|
    double referenceMean = nan;
};

// `what` names the images in the size-mismatch error, e.g. "a.exr (64x64) vs ref.exr (32x32)".
void requireSameSize(const RgbImage& image, const RgbImage& reference, const std::string& imageName,
                     const std::string& referenceName);

double rootMeanSquaredError(const RgbImage& image, const RgbImage& reference);
double relativeMeanSquaredError(const RgbImage& image, const RgbImage& reference,
                                double epsilon = kRelMseEpsilon);
double meanAbsoluteError(const RgbImage& image, const RgbImage& reference);
// All three at once (one pass); throws std::invalid_argument on a size mismatch.
ImageMetrics compareImages(const RgbImage& image, const RgbImage& reference);

// Mean over pixels and channels.
double meanValue(const RgbImage& image);
// Mean and root-mean-square of a standard-error image. The RMS is what the RMSE of an unbiased
// method is expected to be (E[(x - mu)^2] = sigma^2 per pixel), so it predicts the RMSE curve
// without a reference.
double meanOf(const std::vector<float>& values);
double rootMeanSquareOf(const std::vector<float>& values);

// Same statistics straight from the accumulator's Welford state (no image allocated):
// per-pixel standard error of the mean sqrt(M2 / (n (n - 1))); NaN for fewer than 2 estimates.
struct NoiseEstimate {
    double meanStandardError = ImageMetrics::nan;
    double rmsStandardError = ImageMetrics::nan;
    double imageMean = ImageMetrics::nan;
};
NoiseEstimate estimateNoise(const EstimateAccumulator& accumulator);

// Reads the "stderr" layer cbdpt writes next to R,G,B; returns false if the file has none.
bool readExrStandardError(const std::string& path, RgbImage& out);

// False-colour map of the signed relative luminance error
//   e = (L(image) - L(reference)) / (|L(reference)| + kRelMseEpsilon),
// clamped to [-scale, scale]: blue (too dark) through white (exact) to red (too bright), linear in
// e, so full blue/red means |e| >= scale. 8-bit sRGB, row-major.
std::vector<std::uint8_t> relativeErrorColourMap(const RgbImage& image, const RgbImage& reference,
                                                 double scale = 1.0);

} // namespace cb
