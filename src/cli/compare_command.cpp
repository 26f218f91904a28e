// `cbdpt compare IMAGE REFERENCE`: error metrics of an EXR against a reference EXR.
#include "cli/cli_format.h"
#include "cli/cli_options.h"
#include "cli/commands.h"
#include "image/image.h"
#include "image/metrics.h"
#include "io/files.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>

namespace cb::cli {

namespace {

struct CompareOptions {
    std::string image;
    std::string reference;
    std::string diffPng;
    double diffScale = 1.0;
    bool json = false;
};

size_t nonFiniteValues(const cb::RgbImage& image) {
    return size_t(std::count_if(image.rgb.begin(), image.rgb.end(),
                                [](float v) { return !std::isfinite(v); }));
}

// Two crops are comparable only where they cover the same film pixels (render_record.h's
// cbdpt_pixel_bounds); a crop beside an image without the record is taken as the user gives it.
void requireSameCrop(const CompareOptions& o) {
    auto bounds = [](const std::string& path) {
        const cb::ExrAttributes a = cb::readExrAttributes(path);
        const auto it = a.strings.find("cbdpt_pixel_bounds");
        return it == a.strings.end() ? std::string() : it->second;
    };
    const std::string imageBounds = bounds(o.image), referenceBounds = bounds(o.reference);
    if (!imageBounds.empty() && !referenceBounds.empty() && imageBounds != referenceBounds)
        throw std::invalid_argument(fmt::format(
            "{} and {} are crops of different film pixels (cbdpt_pixel_bounds {} and {}); "
            "compare crops of the same window",
            o.image, o.reference, imageBounds, referenceBounds));
}

void printCompareJson(const CompareOptions& o, const cb::RgbImage& image, const cb::ImageMetrics& m,
                      double imageSe, double referenceSe, size_t imageNonFinite,
                      size_t referenceNonFinite) {
    nlohmann::json j = {{"image", o.image},
                        {"reference", o.reference},
                        {"width", image.width},
                        {"height", image.height},
                        {"rmse", jsonNumber(m.rmse)},
                        {"rel_mse", jsonNumber(m.relMse)},
                        {"rel_mse_epsilon", cb::kRelMseEpsilon},
                        {"mae", jsonNumber(m.mae)},
                        {"image_mean", jsonNumber(cb::meanValue(image))},
                        {"reference_mean", jsonNumber(m.referenceMean)},
                        {"mean_stderr", jsonNumber(imageSe)},
                        {"reference_rms_stderr", jsonNumber(referenceSe)},
                        {"image_nonfinite_values", imageNonFinite},
                        {"reference_nonfinite_values", referenceNonFinite}};
    fmt::print("{}\n", j.dump(2));
}

void printCompareText(const CompareOptions& o, const cb::RgbImage& image, const cb::ImageMetrics& m,
                      double imageSe, double referenceSe) {
    auto optional = [](double v) { return std::isfinite(v) ? fmt::format("{:.6g}", v) : "n/a"; };
    fmt::print("image           {} ({}x{})\n", o.image, image.width, image.height);
    fmt::print("reference       {}\n", o.reference);
    fmt::print("rmse            {:.6g}\n", m.rmse);
    fmt::print("rel_mse         {:.6g}  (mean (x-ref)^2/(ref^2+{}))\n", m.relMse,
               cb::kRelMseEpsilon);
    fmt::print("mae             {:.6g}\n", m.mae);
    fmt::print("image mean      {:.6g}\n", cb::meanValue(image));
    fmt::print("reference mean  {:.6g}\n", m.referenceMean);
    fmt::print("mean stderr     {}  (image's stderr layer)\n", optional(imageSe));
    fmt::print("ref rms stderr  {}  (reference's stderr layer: the RMSE floor)\n",
               optional(referenceSe));
    if (!o.diffPng.empty()) fmt::print("wrote           {}\n", o.diffPng);
}

int runCompare(const CompareOptions& o) {
    if (!o.diffPng.empty()) cb::requireWritable(o.diffPng, "the difference map (--diff-png)");
    cb::RgbImage image = cb::readExr(o.image);
    cb::RgbImage reference = cb::readExr(o.reference);
    cb::requireSameSize(image, reference, o.image, "the reference " + o.reference);
    requireSameCrop(o);
    if (!(o.diffScale > 0.0) || !std::isfinite(o.diffScale))
        throw std::invalid_argument("--diff-scale must be a positive number");
    cb::ImageMetrics m = cb::compareImages(image, reference);
    // A NaN or infinity makes every metric NaN or infinite; say where, and fail.
    const size_t imageNonFinite = nonFiniteValues(image);
    const size_t referenceNonFinite = nonFiniteValues(reference);
    for (const auto& [path, count] :
         {std::pair{o.image, imageNonFinite}, std::pair{o.reference, referenceNonFinite}})
        if (count > 0)
            fmt::print(stderr,
                       "cbdpt compare: {} has {} of {} values not finite (NaN or infinity), so "
                       "the metrics are not finite either{}\n",
                       path, count, image.rgb.size(),
                       o.diffPng.empty() ? "" : " (black in the difference map)");
    double imageSe = std::numeric_limits<double>::quiet_NaN();
    double referenceSe = imageSe;
    cb::RgbImage se;
    if (cb::readExrStandardError(o.image, se)) imageSe = cb::meanOf(se.rgb);
    if (cb::readExrStandardError(o.reference, se)) referenceSe = cb::rootMeanSquareOf(se.rgb);
    if (!o.diffPng.empty())
        cb::writePng8(o.diffPng, image.width, image.height,
                      cb::relativeErrorColourMap(image, reference, o.diffScale));
    if (o.json)
        printCompareJson(o, image, m, imageSe, referenceSe, imageNonFinite, referenceNonFinite);
    else
        printCompareText(o, image, m, imageSe, referenceSe);
    return imageNonFinite + referenceNonFinite > 0 ? 1 : 0;
}

} // namespace

Command addCompareCommand(CLI::App& app) {
    auto o = std::make_shared<CompareOptions>();
    auto* cmd = app.add_subcommand(
        "compare", "error metrics of an EXR against a reference EXR (the second file)");
    cmd->add_option("image", o->image, "EXR to evaluate")->required();
    cmd->add_option("reference", o->reference, "reference EXR")->required();
    cmd->add_option("--diff-png", o->diffPng,
                    "write a signed relative luminance error map (blue: too dark, white: "
                    "exact, red: too bright, black: not finite)");
    cmd->add_option("--diff-scale", o->diffScale, "relative error at which the map saturates")
        ->check(finiteRange(0.0, 1e30, true))
        ->capture_default_str();
    cmd->add_flag("--json", o->json, "print the metrics as JSON");
    return {cmd, [o] { return runCompare(*o); }};
}

} // namespace cb::cli
