// `cbdpt combine INPUT.exr... -o OUT.exr`: combines renders of one scene (image/combine.h,
// docs/combine.md); with --split-budget SECONDS --methods A,B SCENE it first renders the
// methods within one time budget (integrators/split_budget.h), then combines them.
#include "cl/cl_runtime.h"
#include "cli/cli_format.h"
#include "cli/cli_options.h"
#include "cli/command_support.h"
#include "cli/commands.h"
#include "cli/progress_bar.h"
#include "image/combine.h"
#include "image/image.h"
#include "image/render_record.h"
#include "integrators/integrator.h"
#include "integrators/split_budget.h"
#include "io/files.h"
#include "scene/device_scene.h"
#include "scene/scene_desc.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <atomic>
#include <filesystem>
#include <memory>
#include <sstream>
#include <stdexcept>

namespace cb::cli {

namespace {

struct CombineOptions {
    std::vector<std::string> inputs; // EXR files, or the scene with --split-budget
    std::string output;
    std::string png;
    std::string statsPath;
    std::string how = "inverse-variance";
    CombineSettings settings;
    // --split-budget
    double budget = 0.0;
    std::string methods = "pt,cbdpt";
    std::string shares;
    int eyeVertices = 4;
    int lightVertices = 4;
    int maxVertices = 0;
    std::uint32_t seed = 1;
    int width = 0;
    int height = 0;
    std::string channels = "auto";
    std::string keepInputs;
    std::string device;
    bool quiet = false;
};

std::vector<std::string> splitList(const std::string& text) {
    std::vector<std::string> out;
    std::istringstream in(text);
    std::string item;
    while (std::getline(in, item, ','))
        if (!item.empty()) out.push_back(item);
    return out;
}

nlohmann::json recordJson(const RenderRecord& r, const std::string& path) {
    return {{"path", path},
            {"method", r.method},
            {"eye_vertices", r.eyeVertices},
            {"light_vertices", r.lightVertices},
            {"max_vertices", r.maxVertices},
            {"seed", r.seed},
            {"estimates", r.estimates},
            {"render_seconds", r.renderSeconds},
            {"render_cpu_seconds", r.renderCpuSeconds}};
}

// Renders the methods of --split-budget; returns them as inputs (written to --keep-inputs too).
std::vector<CombineInput> renderInputs(const CombineOptions& o, nlohmann::json& stats) {
    if (o.inputs.size() != 1)
        throw std::invalid_argument(
            fmt::format("--split-budget takes one scene file, got {} arguments", o.inputs.size()));
    const std::string& scenePath = o.inputs[0];
    const auto methods = splitList(o.methods);
    if (methods.empty()) throw std::invalid_argument("--methods is empty");
    SplitBudgetSettings split;
    split.seconds = o.budget;
    split.shares = o.shares.empty()
                       ? std::vector<double>(methods.size(), 1.0 / double(methods.size()))
                       : parseShares(o.shares, methods.size());
    for (size_t i = 0; i < methods.size(); ++i) {
        IntegratorSettings s;
        s.name = methods[i];
        // One path-length cap for all: PT and CPT get Ne + Nl eye vertices.
        const bool unidirectional = s.name == "pt" || s.name == "cpt";
        s.eyeVertices = unidirectional ? o.eyeVertices + o.lightVertices : o.eyeVertices;
        s.lightVertices = o.lightVertices;
        // The total-length cap, PT's integral for every method; its records state the subpath
        // caps it resolves to, as `cbdpt render` does.
        s.maxPathVertices = o.maxVertices;
        s = withResolvedCaps(s);
        // Distinct seeds: the methods' random numbers must be independent. The independent
        // sampler: the combinations that weight one half of an input by the other need halves
        // that are independent, which a Sobol render's are not (docs/combine.md).
        s.seed = o.seed + std::uint32_t(i);
        s.sampler = "independent";
        split.methods.push_back(s);
    }
    SceneDesc desc = parseSceneFile(scenePath);
    if (o.width > 0) desc.film.width = o.width;
    if (o.height > 0) desc.film.height = o.height;
    DeviceScene scene = buildDeviceScene(desc, parseChannels(o.channels));
    ClRuntime runtime(o.device);
    installStopHandler();
    ProgressBar bar(!o.quiet);
    size_t current = 0;
    auto rendered = renderSplitBudget(scene, runtime, desc, split, stopRequested(),
                                      [&](size_t i, const RenderProgress& p) {
                                          if (i != current) {
                                              bar.finish();
                                              bar = ProgressBar(!o.quiet);
                                              current = i;
                                          }
                                          bar.update(p);
                                      });
    bar.finish();
    if (rendered.interrupted) throw std::runtime_error("interrupted; nothing combined");
    std::vector<CombineInput> inputs;
    if (!o.keepInputs.empty()) std::filesystem::create_directories(o.keepInputs);
    for (size_t i = 0; i < methods.size(); ++i) {
        std::string name = fmt::format("{}-{}.exr", i, methods[i]);
        if (!o.keepInputs.empty()) {
            name = (std::filesystem::path(o.keepInputs) / name).string();
            writeRenderExr(name, rendered.accumulators[i], rendered.records[i]);
        }
        inputs.push_back(
            combineInputFromAccumulator(rendered.accumulators[i], rendered.records[i], name));
        if (!o.quiet)
            fmt::print(stderr, "cbdpt: {} (seed {}): {} estimates in {:.2f} s ({:.2f} CPU s)\n",
                       methods[i], split.methods[i].seed, rendered.accumulators[i].estimates(),
                       rendered.outcomes[i].renderSeconds, rendered.outcomes[i].renderCpuSeconds);
    }
    stats["split_budget"] = {{"seconds", o.budget},
                             {"methods", methods},
                             {"shares", split.shares},
                             {"kernel_build_seconds", rendered.kernelBuildSeconds},
                             {"scene", scenePath}};
    return inputs;
}

int runCombine(CombineOptions& o) {
    o.settings.how = parseCombination(o.how);
    const std::string png = previewPngPath(o.output, o.png);
    // Before --split-budget's renders, not after them.
    requireWritable(o.output, "the combined image (-o)");
    requireWritable(png, "the PNG (--png)");
    if (!o.statsPath.empty()) requireWritable(o.statsPath, "the statistics (--stats)");
    nlohmann::json stats;
    std::vector<CombineInput> inputs;
    if (o.budget > 0.0) {
        inputs = renderInputs(o, stats);
    } else {
        if (o.inputs.size() < 2)
            throw std::invalid_argument("combine needs at least two EXR files (or --split-budget "
                                        "SECONDS --methods A,B SCENE)");
        for (const auto& path : o.inputs)
            inputs.push_back(readCombineInput(path));
    }
    requireCombinable(inputs);
    CombineResult result = combine(inputs, o.settings);

    RenderRecord record;
    const RenderRecord& first = inputs[0].record;
    record.method = "combine:" + combinationName(o.settings.how);
    // A combination computes the inputs' image: its cap, as eye vertices alone.
    record.eyeVertices = pathVertexCap(first);
    record.maxVertices = first.maxVertices;
    record.channels = first.channels;
    record.sceneFile = first.sceneFile;
    record.sceneHash = first.sceneHash;
    record.seed = first.seed;
    record.pixelBounds = first.pixelBounds;
    record.sampler = first.sampler;
    for (const auto& in : inputs) {
        if (in.record.sampler != record.sampler) record.sampler = "mixed";
        record.estimates += in.record.estimates;
        record.renderSeconds += in.record.renderSeconds;
        record.renderCpuSeconds += in.record.renderCpuSeconds;
        record.inputs +=
            (record.inputs.empty() ? "" : ", ") + fmt::format("{} ({})", in.path, in.record.method);
    }
    record.width = result.image.width;
    record.height = result.image.height;
    std::vector<ExrLayer> layers{{"", &result.image}};
    if (!result.standardError.rgb.empty()) layers.push_back({"stderr", &result.standardError});
    writeExr(o.output, layers, toExrAttributes(record));
    writePng(png, result.image);

    stats["combination"] = combinationName(o.settings.how);
    stats["description"] = result.description;
    stats["output"] = o.output;
    stats["render_seconds"] = record.renderSeconds;
    stats["render_cpu_seconds"] = record.renderCpuSeconds;
    stats["inputs"] = nlohmann::json::array();
    for (const auto& in : inputs)
        stats["inputs"].push_back(recordJson(in.record, in.path));
    if (!o.statsPath.empty()) writeFileAtomically(o.statsPath, stats.dump(2) + "\n");
    if (!o.quiet)
        fmt::print(stderr, "cbdpt: {}; {} CPU s in all; wrote {} and {}\n", result.description,
                   fmt::format("{:.2f}", record.renderCpuSeconds), o.output, png);
    return 0;
}

} // namespace

Command addCombineCommand(CLI::App& app) {
    auto options = std::make_shared<CombineOptions>();
    CombineOptions& o = *options;
    auto* cmd = app.add_subcommand(
        "combine", "combine renders of one scene (EXR files), or render methods within one "
                   "time budget and combine them (--split-budget)");
    cmd->add_option("inputs", o.inputs,
                    "EXR files rendered by cbdpt, or the scene with "
                    "--split-budget")
        ->required();
    cmd->add_option("-o,--output", o.output, "combined EXR")->required();
    cmd->add_option("--png", o.png, "PNG preview (default: output with .png)");
    // Values are checked as the command line is read: a bad one exits 2 before any work.
    cmd->add_option("--how", o.how, "combination: " + combinationNames())
        ->check(
            [](const std::string& name) {
                try {
                    parseCombination(name);
                    return std::string();
                } catch (const std::exception& e) {
                    return std::string(e.what());
                }
            },
            "COMBINATION")
        ->capture_default_str();
    cmd->add_option("--variance-radius", o.settings.varianceRadius,
                    "inverse-variance: box radius (pixels) of the averaged variances")
        ->check(CLI::Range(0, 64))
        ->capture_default_str();
    cmd->add_option("--reject-threshold", o.settings.rejectThreshold,
                    "reject: standard errors from the median beyond which an input is dropped")
        ->check(finiteRange(0.0, 1e6, true))
        ->capture_default_str();
    cmd->add_option("--guide-sigma", o.settings.guideSigma,
                    "guided: Gaussian sigma (pixels) of the correction filter")
        ->check(finiteRange(0.0, 1024.0, true))
        ->capture_default_str();
    cmd->add_option("--guide-range", o.settings.guideRange,
                    "guided: relative luminance difference of the edge stop (0: none)")
        ->check(finiteRange(0.0, 1e6))
        ->capture_default_str();
    cmd->add_option("--guide-clamp", o.settings.guideClamp,
                    "guided: clamp the noisy - pattern-prone difference at this many standard "
                    "deviations before filtering (0: off)")
        ->check(finiteRange(0.0, 1e6))
        ->capture_default_str();
    cmd->add_flag("--guide-blend", o.settings.guideBlend,
                  "guided: then mix the corrected image with the noisy one per pixel by inverse "
                  "variance");
    cmd->add_option("--stats", o.statsPath, "write the inputs' records and times as JSON");
    cmd->add_option("--split-budget", o.budget,
                    "render the --methods within this many render seconds in all, then combine")
        ->check(finiteRange(0.0, 1e9, true));
    cmd->add_option("--methods", o.methods, "--split-budget: methods, e.g. pt,cbdpt");
    cmd->add_option("--shares", o.shares,
                    "--split-budget: fractions of the budget per method (default: equal)");
    auto* eye =
        cmd->add_option("--eye-vertices", o.eyeVertices,
                        "--split-budget: Ne of the bidirectional methods (PT, CPT: Ne + Nl)")
            ->check(CLI::Range(2, 1024))
            ->capture_default_str();
    auto* light = cmd->add_option("--light-vertices", o.lightVertices, "--split-budget: Nl")
                      ->check(CLI::Range(1, 1024))
                      ->capture_default_str();
    cmd->add_option("--max-vertices", o.maxVertices,
                    "--split-budget: N, a cap on the whole path instead of Ne and Nl (every "
                    "strategy with s + t <= N: PT's integral for every method)")
        ->check(CLI::Range(2, 1024))
        ->excludes(eye)
        ->excludes(light);
    cmd->add_option("--seed", o.seed, "--split-budget: seed of the first method (+1 per method)");
    cmd->add_option("--width", o.width, "--split-budget: override the film width")
        ->check(CLI::Range(1, 32768));
    cmd->add_option("--height", o.height, "--split-budget: override the film height")
        ->check(CLI::Range(1, 32768));
    cmd->add_option("--channels", o.channels, "--split-budget: auto | rgb | spectral")
        ->check(CLI::IsMember({"auto", "rgb", "spectral"}));
    cmd->add_option("--keep-inputs", o.keepInputs,
                    "--split-budget: also write each method's render to this folder");
    cmd->add_option("--device", o.device, "OpenCL device P:D");
    cmd->add_flag("-q,--quiet", o.quiet, "no progress output");
    return {cmd, [options] { return runCombine(*options); }};
}

} // namespace cb::cli
