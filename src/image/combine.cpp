#include "image/combine.h"

#include "image/metrics.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace cb {

namespace {
const char* kHalfLayers[2] = {"half0", "half1"};
const char* kHalfErrorLayers[2] = {"half0.stderr", "half1.stderr"};

std::string describe(const CombineInput& in) {
    const std::string caps =
        in.record.maxVertices > 0
            ? fmt::format("N={}", in.record.maxVertices)
            : fmt::format("Ne={}{}", in.record.eyeVertices,
                          isPatternProne(in.record.method) || in.record.method == "bdpt"
                              ? fmt::format(" Nl={}", in.record.lightVertices)
                              : "");
    return fmt::format("{} ({}, {}, seed {}, {} estimates)", in.path, in.record.method, caps,
                       in.record.seed, in.record.estimates);
}

// Box mean of `values` over (2 radius + 1)^2 pixels, clipped at the borders, per channel.
std::vector<double> boxMean(const std::vector<double>& values, int width, int height, int radius) {
    if (radius <= 0) return values;
    std::vector<double> out(values.size(), 0.0);
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x)
            for (int c = 0; c < 3; ++c) {
                double sum = 0.0;
                int count = 0;
                for (int yy = std::max(0, y - radius); yy <= std::min(height - 1, y + radius); ++yy)
                    for (int xx = std::max(0, x - radius); xx <= std::min(width - 1, x + radius);
                         ++xx) {
                        sum += values[3 * (size_t(yy) * size_t(width) + size_t(xx)) + size_t(c)];
                        ++count;
                    }
                out[3 * (size_t(y) * size_t(width) + size_t(x)) + size_t(c)] = sum / count;
            }
    return out;
}

// Variance of one half's mean, estimated from the other half: the other half's squared standard
// error (smoothed over `radius`), scaled by the ratio of their estimate counts.
std::vector<double> crossVariance(const CombineInput& in, int valueHalf, int radius) {
    const int other = 1 - valueHalf;
    const RgbImage& se = in.halfStandardError[size_t(other)];
    std::vector<double> variance(se.rgb.size());
    const double scale =
        double(in.halfEstimates[size_t(other)]) / double(in.halfEstimates[size_t(valueHalf)]);
    for (size_t i = 0; i < variance.size(); ++i)
        variance[i] = double(se.rgb[i]) * double(se.rgb[i]) * scale;
    return boxMean(variance, se.width, se.height, radius);
}

std::vector<double> squaredSmoothed(const RgbImage& se, int radius) {
    std::vector<double> variance(se.rgb.size());
    for (size_t i = 0; i < variance.size(); ++i)
        variance[i] = double(se.rgb[i]) * se.rgb[i];
    return boxMean(variance, se.width, se.height, radius);
}

// Per element: sum_i w_i x_i / sum_i w_i with w_i = 1 / variance_i; where every variance is zero
// (a pixel every input computes exactly, e.g. black background) the inputs get equal weights,
// and an input with zero variance beside others that have some takes the pixel alone.
void inverseVarianceMix(const std::vector<const RgbImage*>& values,
                        const std::vector<std::vector<double>>& variances, RgbImage& out,
                        RgbImage* standardError, double share) {
    const size_t k = values.size();
    for (size_t e = 0; e < out.rgb.size(); ++e) {
        size_t exact = 0;
        double exactSum = 0.0;
        double weightSum = 0.0, weighted = 0.0;
        for (size_t i = 0; i < k; ++i) {
            const double v = variances[i][e];
            const double x = values[i]->rgb[e];
            if (!(v > 0.0)) {
                ++exact;
                exactSum += x;
            } else {
                weightSum += 1.0 / v;
                weighted += x / v;
            }
        }
        const double mixed = exact ? exactSum / double(exact) : weighted / weightSum;
        out.rgb[e] += float(share * mixed);
        if (standardError) standardError->rgb[e] = exact ? 0.f : float(std::sqrt(1.0 / weightSum));
    }
}

double median(std::vector<double>& xs) {
    const size_t k = xs.size();
    std::sort(xs.begin(), xs.end());
    return k % 2 ? xs[k / 2] : 0.5 * (xs[k / 2 - 1] + xs[k / 2]);
}
} // namespace

int pathVertexCap(const RenderRecord& r) {
    if (r.maxVertices > 0) return r.maxVertices;
    if (r.method == "pt" || r.method == "cpt") return r.eyeVertices;
    return r.eyeVertices + r.lightVertices;
}

bool isPatternProne(const std::string& method) {
    return method == "cpt" || method == "cbdpt" || method == "mlt";
}

CombineInput readCombineInput(const std::string& path) {
    CombineInput in;
    in.path = path;
    in.record = renderRecordFromExr(readExrAttributes(path), path);
    in.mean = readExr(path);
    if (!readExrStandardError(path, in.standardError))
        throw std::runtime_error(
            fmt::format("{} has no stderr layer (per-pixel standard error)", path));
    in.hasHalves = readExrLayer(path, kHalfLayers[0], in.halfMean[0]) &&
                   readExrLayer(path, kHalfLayers[1], in.halfMean[1]) &&
                   readExrLayer(path, kHalfErrorLayers[0], in.halfStandardError[0]) &&
                   readExrLayer(path, kHalfErrorLayers[1], in.halfStandardError[1]);
    if (in.hasHalves) {
        // Estimate index i is in half i % 2 (EstimateAccumulator::trackHalves).
        for (int half = 0; half < 2; ++half)
            in.halfEstimates[size_t(half)] = long(in.record.estimateSet.countWithParity(half));
    }
    return in;
}

CombineInput combineInputFromAccumulator(const EstimateAccumulator& accumulator,
                                         const RenderRecord& record, const std::string& name) {
    CombineInput in;
    in.path = name;
    in.record = record;
    in.record.estimates = accumulator.estimates();
    in.record.estimateSet = accumulator.indices();
    in.record.width = accumulator.width();
    in.record.height = accumulator.height();
    in.mean = accumulator.mean();
    in.standardError = accumulator.standardError();
    in.hasHalves = accumulator.tracksHalves();
    for (int half = 0; in.hasHalves && half < 2; ++half) {
        in.halfMean[size_t(half)] = accumulator.halfMean(half);
        in.halfStandardError[size_t(half)] = accumulator.halfStandardError(half);
        in.halfEstimates[size_t(half)] = accumulator.halfEstimates(half);
    }
    return in;
}

void requireCombinable(const std::vector<CombineInput>& inputs) {
    if (inputs.empty()) throw std::invalid_argument("combine: no input images");
    for (const CombineInput& in : inputs)
        if (!in.record.strategy.empty())
            throw std::invalid_argument(fmt::format(
                "combine: {} renders only strategy {} (--strategy, unweighted), not the image; "
                "render it without --strategy",
                describe(in), in.record.strategy));
    const CombineInput& a = inputs[0];
    for (size_t i = 1; i < inputs.size(); ++i) {
        const CombineInput& b = inputs[i];
        const RenderRecord &ra = a.record, &rb = b.record;
        auto refuse = [&](const std::string& what) {
            return std::invalid_argument(
                fmt::format("combine: {} and {} {}", describe(a), describe(b), what));
        };
        if (a.mean.width != b.mean.width || a.mean.height != b.mean.height)
            throw refuse(fmt::format("differ in size ({}x{} vs {}x{}); render both at one "
                                     "--width/--height",
                                     a.mean.width, a.mean.height, b.mean.width, b.mean.height));
        // The content hash decides (a merged image has no scene file name).
        if (ra.sceneHash != rb.sceneHash)
            throw refuse(fmt::format("are of different scenes ({} [{}] vs {} [{}])", ra.sceneFile,
                                     ra.sceneHash, rb.sceneFile, rb.sceneHash));
        if (ra.maxComponentValue != rb.maxComponentValue) {
            auto clamp = [](const RenderRecord& r) {
                return r.maxComponentValue.empty() ? std::string("the scene file's")
                                                   : "--max-component-value " + r.maxComponentValue;
            };
            throw refuse(fmt::format("differ in the film's sample clamp ({} vs {}); render both "
                                     "with one --max-component-value",
                                     clamp(ra), clamp(rb)));
        }
        if (ra.channels != rb.channels)
            throw refuse(fmt::format("differ in colour channels ({} vs {}); render both with one "
                                     "--channels",
                                     ra.channels, rb.channels));
        if (ra.pixelBounds != rb.pixelBounds)
            throw refuse(fmt::format(
                "are different parts of the film (pixel bounds {} vs {}): render both with one "
                "--cropwindow",
                ra.pixelBounds.empty() ? "the whole film" : ra.pixelBounds,
                rb.pixelBounds.empty() ? "the whole film" : rb.pixelBounds));
        if (pathVertexCap(ra) != pathVertexCap(rb))
            throw refuse(fmt::format(
                "differ in vertex caps (paths of up to {} vs {} vertices), so they compute "
                "different images; use PT Ne = bidirectional Ne + Nl, or one --max-vertices",
                pathVertexCap(ra), pathVertexCap(rb)));
        for (size_t j = 0; j < i; ++j) {
            const RenderRecord& rj = inputs[j].record;
            const bool overlap = rj.estimateSet.intersects(rb.estimateSet);
            if (rj.seed == rb.seed && overlap)
                throw std::invalid_argument(fmt::format(
                    "combine: {} and {} use one seed and overlapping estimate numbers, so they "
                    "share random numbers and are not independent; render one with another "
                    "--seed",
                    describe(inputs[j]), describe(b)));
            // Disjoint estimates of one Sobol sequence are not independent either: they are
            // parts of one randomised sequence, as shards of one render are.
            if (rj.seed == rb.seed && (rj.sampler == "sobol" || rb.sampler == "sobol"))
                throw std::invalid_argument(fmt::format(
                    "combine: {} and {} use one seed with the Sobol sampler, so their estimates "
                    "are parts of one randomised sequence and not independent; render one with "
                    "another --seed (shards of one render are added with cbdpt merge)",
                    describe(inputs[j]), describe(b)));
        }
    }
}

Combination parseCombination(const std::string& name) {
    for (Combination how :
         {Combination::Mean, Combination::InverseVariance, Combination::InverseVarianceNaive,
          Combination::Median, Combination::Reject, Combination::Guided})
        if (combinationName(how) == name) return how;
    throw std::invalid_argument(
        fmt::format("unknown combination '{}'; one of: {}", name, combinationNames()));
}

std::string combinationName(Combination how) {
    switch (how) {
    case Combination::Mean:
        return "mean";
    case Combination::InverseVariance:
        return "inverse-variance";
    case Combination::InverseVarianceNaive:
        return "inverse-variance-naive";
    case Combination::Median:
        return "median";
    case Combination::Reject:
        return "reject";
    case Combination::Guided:
        return "guided";
    }
    return "?";
}

std::string combinationNames() {
    return "mean, inverse-variance, inverse-variance-naive, median, reject, guided";
}

RgbImage jointBilateralFilter(const RgbImage& values, const RgbImage& guide, double sigma,
                              double range) {
    requireSameSize(values, guide, "the filtered image", "the guide");
    if (!(sigma > 0.0)) throw std::invalid_argument("the guided filter's sigma must be positive");
    const int w = values.width, h = values.height;
    const int radius = int(std::ceil(2.5 * sigma));
    std::vector<double> g(size_t(w) * size_t(h));
    double guideMean = 0.0;
    for (size_t p = 0; p < g.size(); ++p) {
        g[p] = std::max(0.0, rec709Luminance(&guide.rgb[3 * p]));
        guideMean += g[p] / double(g.size());
    }
    // Keeps the range kernel finite on black pixels.
    const double eps = 1e-3 * guideMean + 1e-12;
    std::vector<double> spatial(size_t(2 * radius + 1) * size_t(2 * radius + 1));
    for (int dy = -radius; dy <= radius; ++dy)
        for (int dx = -radius; dx <= radius; ++dx)
            spatial[size_t(dy + radius) * size_t(2 * radius + 1) + size_t(dx + radius)] =
                std::exp(-double(dx * dx + dy * dy) / (2.0 * sigma * sigma));
    RgbImage out(w, h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const size_t p = size_t(y) * size_t(w) + size_t(x);
            double sum[3] = {0, 0, 0}, weightSum = 0.0;
            for (int yy = std::max(0, y - radius); yy <= std::min(h - 1, y + radius); ++yy)
                for (int xx = std::max(0, x - radius); xx <= std::min(w - 1, x + radius); ++xx) {
                    const size_t q = size_t(yy) * size_t(w) + size_t(xx);
                    double weight = spatial[size_t(yy - y + radius) * size_t(2 * radius + 1) +
                                            size_t(xx - x + radius)];
                    if (range > 0.0) {
                        const double s = range * 0.5 * (g[p] + g[q]) + eps;
                        const double d = g[p] - g[q];
                        weight *= std::exp(-d * d / (2.0 * s * s));
                    }
                    weightSum += weight;
                    for (int c = 0; c < 3; ++c)
                        sum[c] += weight * double(values.rgb[3 * q + size_t(c)]);
                }
            for (int c = 0; c < 3; ++c)
                out.rgb[3 * p + size_t(c)] = float(sum[c] / weightSum);
        }
    return out;
}

CombineResult combine(const std::vector<CombineInput>& inputs, const CombineSettings& s) {
    if (inputs.empty()) throw std::invalid_argument("combine: no input images");
    const int w = inputs[0].mean.width, h = inputs[0].mean.height;
    const size_t k = inputs.size();
    CombineResult result;
    result.image = RgbImage(w, h);
    std::string names;
    for (const auto& in : inputs)
        names += (names.empty() ? "" : ", ") + in.path;
    result.description = fmt::format("{} of {}", combinationName(s.how), names);
    auto requireHalves = [&] {
        for (const auto& in : inputs)
            if (in.record.sampler == "sobol")
                throw std::invalid_argument(fmt::format(
                    "combine: {} weights each half of an input by the other half, which needs "
                    "independent halves; {} was rendered with the Sobol sampler, whose even and "
                    "odd estimates are points of one randomised sequence (correlated, so the "
                    "weights would bias the result: docs/combine.md). Render the inputs with "
                    "--sampler independent, or use --how mean, median or reject",
                    combinationName(s.how), in.path));
        for (const auto& in : inputs)
            if (!in.hasHalves || in.halfEstimates[0] < 2 || in.halfEstimates[1] < 2)
                throw std::invalid_argument(fmt::format(
                    "combine: {} needs each input's two halves with at least 2 estimates each; "
                    "{} has {} (render it again with this cbdpt, at least 4 estimates)",
                    combinationName(s.how), in.path,
                    in.hasHalves
                        ? fmt::format("{} and {}", in.halfEstimates[0], in.halfEstimates[1])
                        : std::string("no half layers")));
    };
    switch (s.how) {
    case Combination::Mean: {
        result.standardError = RgbImage(w, h);
        for (size_t e = 0; e < result.image.rgb.size(); ++e) {
            double sum = 0.0, variance = 0.0;
            for (const auto& in : inputs) {
                sum += in.mean.rgb[e];
                variance += double(in.standardError.rgb[e]) * in.standardError.rgb[e];
            }
            result.image.rgb[e] = float(sum / double(k));
            result.standardError.rgb[e] = float(std::sqrt(variance) / double(k));
        }
        break;
    }
    case Combination::InverseVariance: {
        // Cross weighting: half h of every input is weighted by the variance the other half
        // measured, so weights and weighted values are independent, and the two mixes averaged.
        requireHalves();
        for (int half = 0; half < 2; ++half) {
            std::vector<const RgbImage*> values;
            std::vector<std::vector<double>> variances;
            for (const auto& in : inputs) {
                values.push_back(&in.halfMean[size_t(half)]);
                variances.push_back(crossVariance(in, half, s.varianceRadius));
            }
            inverseVarianceMix(values, variances, result.image, nullptr, 0.5);
        }
        // The standard error of the first-order optimum from the full estimates' variances.
        std::vector<const RgbImage*> values;
        std::vector<std::vector<double>> variances;
        for (const auto& in : inputs) {
            values.push_back(&in.mean);
            variances.push_back(squaredSmoothed(in.standardError, s.varianceRadius));
        }
        RgbImage discard(w, h);
        result.standardError = RgbImage(w, h);
        inverseVarianceMix(values, variances, discard, &result.standardError, 1.0);
        break;
    }
    case Combination::InverseVarianceNaive: {
        std::vector<const RgbImage*> values;
        std::vector<std::vector<double>> variances;
        for (const auto& in : inputs) {
            values.push_back(&in.mean);
            variances.push_back(squaredSmoothed(in.standardError, s.varianceRadius));
        }
        result.standardError = RgbImage(w, h);
        inverseVarianceMix(values, variances, result.image, &result.standardError, 1.0);
        break;
    }
    case Combination::Median:
    case Combination::Reject: {
        if (!(s.rejectThreshold > 0.0))
            throw std::invalid_argument("combine: --reject-threshold must be positive");
        std::vector<double> xs(k);
        for (size_t e = 0; e < result.image.rgb.size(); ++e) {
            for (size_t i = 0; i < k; ++i)
                xs[i] = inputs[i].mean.rgb[e];
            const double m = median(xs);
            if (s.how == Combination::Median) {
                result.image.rgb[e] = float(m);
                continue;
            }
            double sum = 0.0;
            int kept = 0;
            for (const auto& in : inputs) {
                const double x = in.mean.rgb[e];
                if (std::fabs(x - m) <= s.rejectThreshold * double(in.standardError.rgb[e])) {
                    sum += x;
                    ++kept;
                }
            }
            result.image.rgb[e] = float(kept ? sum / kept : m);
        }
        break;
    }
    case Combination::Guided: {
        // P_h, C_h: the noisy and the pattern-prone inputs' half means. Each C_h is corrected by
        // the local mean of P_h - C_h, filtered with edge stops from C_(1-h); with blending, the
        // corrected C_h and P_h are then mixed by inverse variances that half 1-h measured. All
        // weights come from half 1-h, independent of the half-h values they weight.
        std::vector<const CombineInput*> noisy, patterned;
        for (const auto& in : inputs)
            (isPatternProne(in.record.method) ? patterned : noisy).push_back(&in);
        if (noisy.empty() || patterned.empty())
            throw std::invalid_argument(
                "combine: guided needs at least one noisy input (pt, bdpt) and one pattern-prone "
                "input (cpt, cbdpt, mlt)");
        requireHalves();
        // The mean of a group's half-h images and its variance estimated from half 1-h.
        auto groupHalf = [&](const std::vector<const CombineInput*>& group, int half,
                             RgbImage& mean, std::vector<double>& variance) {
            const double m = double(group.size());
            mean = RgbImage(w, h);
            variance.assign(mean.rgb.size(), 0.0);
            for (const auto* in : group) {
                const auto v = crossVariance(*in, half, s.varianceRadius);
                for (size_t e = 0; e < mean.rgb.size(); ++e) {
                    mean.rgb[e] += float(double(in->halfMean[size_t(half)].rgb[e]) / m);
                    variance[e] += v[e] / (m * m);
                }
            }
        };
        std::array<RgbImage, 2> p, c;
        std::array<std::vector<double>, 2> pVariance, cVariance;
        for (int half = 0; half < 2; ++half) {
            groupHalf(noisy, half, p[size_t(half)], pVariance[size_t(half)]);
            groupHalf(patterned, half, c[size_t(half)], cVariance[size_t(half)]);
        }
        for (int half = 0; half < 2; ++half) {
            const RgbImage& value = c[size_t(half)];
            RgbImage difference(w, h);
            for (size_t e = 0; e < difference.rgb.size(); ++e) {
                double d = double(p[size_t(half)].rgb[e]) - double(value.rgb[e]);
                // Winsorised at z standard deviations that the other half measured, so one
                // outlier (a firefly in P, a bright pattern in C) does not spread over the
                // filter's support; bias at most sigma_D / (4 z) (docs/combine.md).
                const double limit = s.guideClamp * std::sqrt(pVariance[size_t(half)][e] +
                                                              cVariance[size_t(half)][e]);
                if (s.guideClamp > 0.0 && limit > 0.0) d = std::clamp(d, -limit, limit);
                difference.rgb[e] = float(d);
            }
            RgbImage corrected =
                jointBilateralFilter(difference, c[size_t(1 - half)], s.guideSigma, s.guideRange);
            for (size_t e = 0; e < corrected.rgb.size(); ++e)
                corrected.rgb[e] += value.rgb[e];
            if (s.guideBlend)
                inverseVarianceMix({&corrected, &p[size_t(half)]},
                                   {cVariance[size_t(half)], pVariance[size_t(half)]}, result.image,
                                   nullptr, 0.5);
            else
                for (size_t e = 0; e < corrected.rgb.size(); ++e)
                    result.image.rgb[e] += 0.5f * corrected.rgb[e];
        }
        std::string roles = "noisy";
        for (size_t i = 0; i < noisy.size(); ++i)
            roles += (i ? ", " : " ") + noisy[i]->path;
        roles += "; pattern-prone";
        for (size_t i = 0; i < patterned.size(); ++i)
            roles += (i ? ", " : " ") + patterned[i]->path;
        result.description = fmt::format("guided (sigma {:g} px, range {:g}{}): {}", s.guideSigma,
                                         s.guideRange, s.guideBlend ? ", blended" : "", roles);
        break;
    }
    }
    return result;
}

} // namespace cb
