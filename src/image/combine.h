// Combining several renders of one scene into one image (docs/combine.md): the thesis's
// proposals (its section 5.2) of merging pattern-prone images (CPT, CBDPT) with each other and
// with noisy ones (PT, BDPT). Every combination reads the per-pixel statistics each render
// writes into its EXR (image/render_record.h, EstimateAccumulator::trackHalves).
#pragma once

#include "image/image.h"
#include "image/render_record.h"

#include <array>
#include <string>
#include <vector>

namespace cb {

struct CombineInput {
    std::string path;
    RenderRecord record;
    RgbImage mean;
    RgbImage standardError; // of the mean, per pixel and channel
    // The two disjoint halves of the estimates (estimates with even / odd numbers), when the
    // file holds them: their means and standard errors are independent of each other.
    bool hasHalves = false;
    std::array<RgbImage, 2> halfMean, halfStandardError;
    std::array<long, 2> halfEstimates{0, 0};
};

// Reads a cbdpt EXR: R,G,B, stderr, the half layers if present, and the header's render record.
CombineInput readCombineInput(const std::string& path);
// The same from a render still in memory (`name` stands for the path in messages).
CombineInput combineInputFromAccumulator(const EstimateAccumulator& accumulator,
                                         const RenderRecord& record, const std::string& name);

// Longest path, in vertices (camera and light included), a render's method computes: N under
// --max-vertices N, else Ne for PT and CPT and Ne + Nl for the bidirectional methods. Renders
// of one scene with one such cap estimate the same image where no delta vertex needs a
// connection (docs/bdpt.md, "Which paths each method computes").
int pathVertexCap(const RenderRecord& record);

// True for methods whose error is spatially structured (the pixels of an estimate share random
// numbers or a Markov chain): cpt, cbdpt, mlt.
bool isPatternProne(const std::string& method);

// Throws std::invalid_argument naming both files and the values when inputs differ in scene
// (file name or content hash), size, channel mode or path vertex cap, or share random numbers
// (same seed with overlapping estimate numbers), so are not independent.
void requireCombinable(const std::vector<CombineInput>& inputs);

enum class Combination {
    Mean,                 // equal weights
    InverseVariance,      // weights from the other half's variance (unbiased)
    InverseVarianceNaive, // weights from the same estimates' variance (biased; for comparison)
    Median,               // per-pixel median of the inputs
    Reject,               // mean of the inputs within a threshold of the median
    Guided,               // pattern-prone image corrected by the noisy image's local mean
};
Combination parseCombination(const std::string& name); // throws std::invalid_argument
std::string combinationName(Combination how);
// "mean, inverse-variance, ..." for help texts.
std::string combinationNames();

struct CombineSettings {
    Combination how = Combination::InverseVariance;
    int varianceRadius = 1;       // inverse variance: box radius over which variances are averaged
    double rejectThreshold = 3.0; // reject: standard errors from the median that an input may be
    double guideSigma = 3.0;      // guided: Gaussian sigma of the correction filter, pixels
    double guideRange = 0.25; // guided: relative luminance difference of the edge stop (0: none)
    double guideClamp = 0.0;  // guided: the difference winsorised at this many std devs (0: off)
    bool guideBlend = false;  // guided: then mix with the noisy image by inverse variance
};

struct CombineResult {
    RgbImage image;
    // Standard error per pixel where the combination has one (mean: exact for independent inputs;
    // inverse variance: the first-order 1 / sqrt(sum of weights)); 0x0 otherwise.
    RgbImage standardError;
    std::string description; // what was combined how, for the log and the header
};

// Combines `inputs` (already checked by requireCombinable). Throws std::invalid_argument when
// the combination cannot use them (e.g. guided without a noisy and a pattern-prone input).
CombineResult combine(const std::vector<CombineInput>& inputs, const CombineSettings& settings);

// The edge-stopping Gaussian filter of the guided combination, exposed for tests: each pixel
// becomes the weighted mean of `values` around it, weights exp(-d^2 / 2 sigma^2) times, when
// `range` > 0, exp(-(g_p - g_q)^2 / (2 (range (g_p + g_q) / 2 + eps)^2)) on the guide's luminance.
RgbImage jointBilateralFilter(const RgbImage& values, const RgbImage& guide, double sigma,
                              double range);

} // namespace cb
