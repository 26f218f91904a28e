// cbdpt command line: `cbdpt render SCENE [options]` and `cbdpt info [SCENE]`.
#include "cl/cl_runtime.h"
#include "image/image.h"
#include "image/metrics.h"
#include "image/render_state.h"
#include "integrators/render.h"
#include "scene/device_scene.h"
#include "scene/scene_desc.h"

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <limits>
#include <optional>
#include <sstream>
#include <unistd.h>

namespace {

std::atomic<bool> gStopRequested{false};

extern "C" void onStopSignal(int) {
    gStopRequested.store(true);
    // A second Ctrl-C ends the program at once.
    std::signal(SIGINT, SIG_DFL);
    std::signal(SIGTERM, SIG_DFL);
}

std::string formatSeconds(double s) {
    if (s < 60.0) return fmt::format("{:.1f}s", s);
    if (s < 3600.0) return fmt::format("{}m{:02d}s", int(s) / 60, int(s) % 60);
    return fmt::format("{}h{:02d}m", int(s) / 3600, (int(s) / 60) % 60);
}

class ProgressBar {
  public:
    explicit ProgressBar(bool enabled) : enabled_(enabled), tty_(::isatty(2)) {}
    void update(const cb::RenderProgress& p) {
        if (!enabled_) return;
        double fraction =
            p.estimatesTarget > 0
                ? double(p.estimatesDone) / double(p.estimatesTarget)
                : std::min(1.0, p.elapsedSeconds /
                                    std::max(1e-9, p.elapsedSeconds + p.remainingSeconds));
        if (!tty_) {
            // Logs get a line per 10% rather than carriage returns.
            int decile = int(fraction * 10.0);
            if (decile <= lastDecile_) return;
            lastDecile_ = decile;
        }
        const int width = 30;
        int filled = int(fraction * width + 0.5);
        std::string bar(size_t(filled), '#');
        bar.append(size_t(width - filled), '.');
        std::string count = p.estimatesTarget > 0
                                ? fmt::format("{}/{} estimates", p.estimatesDone, p.estimatesTarget)
                                : fmt::format("{} estimates", p.estimatesDone);
        fmt::print(stderr, "{}[{}] {}  elapsed {}  remaining {}{}", tty_ ? "\r" : "", bar, count,
                   formatSeconds(p.elapsedSeconds), formatSeconds(p.remainingSeconds),
                   tty_ ? "   " : "\n");
        std::fflush(stderr);
    }
    void finish() {
        if (enabled_ && tty_) fmt::print(stderr, "\n");
    }

  private:
    bool enabled_;
    bool tty_;
    int lastDecile_ = -1;
};

cb::ChannelMode parseChannels(const std::string& s) {
    if (s == "auto") return cb::ChannelMode::Auto;
    if (s == "rgb") return cb::ChannelMode::Rgb;
    if (s == "spectral") return cb::ChannelMode::Spectral;
    throw std::invalid_argument("--channels must be auto, rgb or spectral");
}

int runInfo(const std::string& scenePath, const std::string& device) {
    auto devices = cb::listClDevices();
    fmt::print("OpenCL devices (select with --device P:D or CBDPT_DEVICE=P:D):\n");
    for (const auto& d : devices)
        fmt::print("  {}:{}  {} | {} | {} | {} compute units, {:.1f} GiB\n", d.platformIndex,
                   d.deviceIndex, d.platformName, d.deviceName, d.deviceVersion, d.computeUnits,
                   double(d.globalMemoryBytes) / (1024.0 * 1024.0 * 1024.0));
    (void)device;
    if (scenePath.empty()) return 0;
    cb::SceneDesc desc = cb::parseSceneFile(scenePath);
    cb::DeviceScene scene = cb::buildDeviceScene(desc);
    fmt::print("\nscene {}\n", scenePath);
    fmt::print("  triangles        {}\n", scene.triangleCount);
    fmt::print("  vertices         {}\n", scene.vertexCount);
    fmt::print("  spheres          {}\n", scene.sphereCount);
    fmt::print("  lights           {} ({} area-light primitives, {} point lights)\n",
               scene.lights.size(), scene.lights.size() - desc.pointLights.size(),
               desc.pointLights.size());
    fmt::print("  materials        {}\n", scene.materials.size());
    fmt::print("  bounding box     ({:.4g}, {:.4g}, {:.4g}) - ({:.4g}, {:.4g}, {:.4g})\n",
               scene.boundsMin[0], scene.boundsMin[1], scene.boundsMin[2], scene.boundsMax[0],
               scene.boundsMax[1], scene.boundsMax[2]);
    fmt::print("  BVH              {} nodes, depth {}; wide: {} nodes, {} leaf packs\n",
               scene.bvh.nodes.size(), scene.bvh.depth, scene.wide.nodes.size(),
               scene.wide.packs.size());
    fmt::print("  BVH settings     {}\n", scene.wideSettingsWhy);
    fmt::print("  film             {}x{}\n", scene.camera.width, scene.camera.height);
    fmt::print("  kernel features  {}\n", scene.featureNames());
    std::string defines;
    for (const auto& d : scene.kernelDefines())
        defines += " -D" + d;
    fmt::print("  kernel defines  {}\n", defines);
    if (desc.droppedDegenerateTriangles)
        fmt::print("  dropped          {} degenerate triangles\n", desc.droppedDegenerateTriangles);
    return 0;
}

struct RenderOptions {
    std::string scene;
    std::string output;
    std::string png;
    std::string statsPath;
    std::string channels = "auto";
    std::string device;
    long spp = 16;
    double seconds = 0.0;
    int width = 0;
    int height = 0;
    bool noRoulette = false;
    bool sppGiven = false;
    bool resume = false;
    bool keepState = false;
    std::string strategy;
    bool quiet = false;
    bool noWarmup = false;
    cb::IntegratorSettings integrator;
    // Error against time (issue 7).
    std::string checkpoints;
    double checkpointEvery = 0.0;
    std::string reference;
    std::string logPath;
    std::string checkpointImages;
};

// A number for the CSV log: empty when not available (no reference, fewer than 2 estimates).
std::string csvNumber(double v) {
    return std::isfinite(v) ? fmt::format("{:.9g}", v) : "";
}
nlohmann::json jsonNumber(double v) {
    return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json();
}

// The checkpoint log: a header describing the run (set-up times excluded from the rows' render
// seconds), then one row per checkpoint. Rewritten atomically at every checkpoint so that an
// interrupted render still leaves a complete, parseable log.
class CheckpointLog {
  public:
    static constexpr const char* columns[] = {"estimates",  "seconds",    "rmse",
                                              "rel_mse",    "mae",        "mean_stderr",
                                              "rms_stderr", "image_mean", "checkpoint_seconds",
                                              "cpu_seconds"};
    CheckpointLog(std::string path, nlohmann::json header)
        : path_(std::move(path)), header_(std::move(header)) {
        const auto ext = std::filesystem::path(path_).extension();
        if (ext == ".json")
            json_ = true;
        else if (ext != ".csv")
            throw std::invalid_argument(fmt::format("--log '{}' must end in .csv or .json", path_));
    }
    void add(const std::vector<double>& row) {
        rows_.push_back(row);
        write();
    }

  private:
    void write() const {
        if (json_) {
            nlohmann::json doc = header_;
            doc["columns"] = columns;
            nlohmann::json rows = nlohmann::json::array();
            for (const auto& r : rows_) {
                nlohmann::json o;
                for (size_t i = 0; i < r.size(); ++i)
                    o[columns[i]] = i == 0 ? nlohmann::json(long(r[i])) : jsonNumber(r[i]);
                rows.push_back(o);
            }
            doc["checkpoints"] = rows;
            cb::writeFileAtomically(path_, doc.dump(2) + "\n");
            return;
        }
        std::string text = "# cbdpt checkpoint log\n";
        for (const auto& [key, value] : header_.items())
            text += fmt::format("# {}: {}\n", key,
                                value.is_string() ? value.get<std::string>() : value.dump());
        for (size_t i = 0; i < std::size(columns); ++i) {
            if (i) text += ',';
            text += columns[i];
        }
        text += '\n';
        for (const auto& r : rows_) {
            for (size_t i = 0; i < r.size(); ++i) {
                if (i) text += ',';
                text += i == 0 ? std::to_string(long(r[i])) : csvNumber(r[i]);
            }
            text += '\n';
        }
        cb::writeFileAtomically(path_, text);
    }
    std::string path_;
    nlohmann::json header_;
    bool json_ = false;
    std::vector<std::vector<double>> rows_;
};

int runRender(RenderOptions& o) {
    using Clock = std::chrono::steady_clock;
    auto t0 = Clock::now();
    cb::SceneDesc desc = cb::parseSceneFile(o.scene);
    if (o.width > 0) desc.film.width = o.width;
    if (o.height > 0) desc.film.height = o.height;
    // Refuse absurd requests before any allocation.
    const long long pixels = (long long)desc.film.width * desc.film.height;
    if (desc.film.width <= 0 || desc.film.height <= 0 || desc.film.width > 32768 ||
        desc.film.height > 32768 || pixels > (1LL << 28))
        throw std::invalid_argument(fmt::format(
            "resolution {}x{} is outside what cbdpt renders (each side 1..32768, at most 2^28 "
            "pixels)",
            desc.film.width, desc.film.height));
    // Checkpoint requests are checked before the scene is built or kernels compiled.
    cb::CheckpointSchedule schedule;
    if (!o.checkpoints.empty()) schedule.estimates = cb::parseCheckpointList(o.checkpoints);
    if (o.checkpointEvery < 0.0 || !std::isfinite(o.checkpointEvery))
        throw std::invalid_argument("--checkpoint-every must be a positive number of seconds");
    schedule.everySeconds = o.checkpointEvery;
    // --checkpoints alone renders up to the last checkpoint.
    if (!schedule.estimates.empty() && !o.sppGiven && o.seconds <= 0.0) {
        o.spp = schedule.estimates.back();
        o.sppGiven = true;
    }
    std::optional<cb::RgbImage> reference;
    double referenceRmsError = std::numeric_limits<double>::quiet_NaN();
    if (!o.reference.empty()) {
        reference = cb::readExr(o.reference);
        if (reference->width != desc.film.width || reference->height != desc.film.height)
            throw std::invalid_argument(fmt::format(
                "--reference {} is {}x{} but the render is {}x{} (set --width/--height to match)",
                o.reference, reference->width, reference->height, desc.film.width,
                desc.film.height));
        cb::RgbImage referenceError;
        if (cb::readExrStandardError(o.reference, referenceError))
            referenceRmsError = cb::rootMeanSquareOf(referenceError.rgb);
    }
    if (!o.logPath.empty()) {
        const auto ext = std::filesystem::path(o.logPath).extension();
        if (ext != ".csv" && ext != ".json")
            throw std::invalid_argument(
                fmt::format("--log '{}' must end in .csv or .json", o.logPath));
    }
    const bool wantCheckpoints =
        !schedule.empty() || !o.logPath.empty() || !o.checkpointImages.empty();
    if (!o.checkpointImages.empty()) std::filesystem::create_directories(o.checkpointImages);
    cb::DeviceScene scene = cb::buildDeviceScene(desc, parseChannels(o.channels));
    double loadSeconds = std::chrono::duration<double>(Clock::now() - t0).count();
    if (o.noRoulette) o.integrator.rouletteVertex = 0;
    if (!o.strategy.empty()) {
        char comma = 0;
        std::istringstream in(o.strategy);
        if (!(in >> o.integrator.debugS >> comma >> o.integrator.debugT) || comma != ',' ||
            o.integrator.debugS < 0 || o.integrator.debugT < 1)
            throw std::invalid_argument(fmt::format(
                "--strategy '{}' must be S,T with S >= 0 light vertices and T >= 1 eye vertices",
                o.strategy));
    }

    std::string output =
        o.output.empty() ? std::filesystem::path(desc.film.filename).filename().string() : o.output;
    if (std::filesystem::path(output).extension() != ".exr")
        throw std::invalid_argument(fmt::format("output '{}' must end in .exr", output));
    std::string png =
        o.png.empty() ? std::filesystem::path(output).replace_extension(".png").string() : o.png;

    cb::ClRuntime runtime(o.device);
    auto integrator = cb::makeIntegrator(o.integrator, scene, runtime);
    if (!o.quiet)
        fmt::print(stderr, "cbdpt: {} on {} | {}x{} {} | {} | Ne={} | kernel build {:.2f}s\n",
                   o.integrator.name, runtime.info().deviceName, scene.camera.width,
                   scene.camera.height, scene.channels == 16 ? "spectral-16" : "rgb", o.scene,
                   o.integrator.eyeVertices, integrator->buildSeconds());

    std::signal(SIGINT, onStopSignal);
    std::signal(SIGTERM, onStopSignal);
    cb::EstimateAccumulator accumulator(scene.camera.width, scene.camera.height);
    // Everything that decides the estimates' values: a resumed render must match it exactly.
    const cb::RenderIdentity stateSettings = cb::renderIdentity(o.integrator, desc, scene);
    const std::string statePath = cb::renderStatePath(output);
    if (o.resume) {
        if (o.integrator.name == "mlt")
            throw std::invalid_argument("--resume is not supported for mlt: its Markov chains "
                                        "are not saved");
        cb::resumeRenderState(statePath, stateSettings, accumulator);
        if (!o.quiet)
            fmt::print(stderr, "cbdpt: resuming from {} estimates ({})\n", accumulator.estimates(),
                       statePath);
    }
    ProgressBar bar(!o.quiet);
    cb::RenderLimits limits;
    // --time alone renders until the time is up; with --spp too, whichever comes first.
    limits.estimates = o.seconds > 0.0 && !o.sppGiven ? 0 : o.spp;
    if (limits.estimates < 0 || limits.estimates > (1L << 40))
        throw std::invalid_argument(fmt::format("--spp {} is out of range", o.spp));
    limits.seconds = o.seconds;
    if (!schedule.estimates.empty() && limits.estimates > 0 &&
        schedule.estimates.back() > limits.estimates && !o.quiet)
        fmt::print(stderr, "cbdpt: warning: checkpoints past --spp {} will not be reached\n",
                   limits.estimates);

    // PoCL compiles a kernel for its work-group size at the first launch, not at clBuildProgram,
    // so on a cold kernel cache the first estimate can take seconds. Error-against-time logs
    // would charge that to the method; one discarded estimate before the clock starts keeps it
    // out (for stateful methods such as MLT it is extra burn-in).
    double warmupSeconds = 0.0;
    if (wantCheckpoints && !o.noWarmup) {
        const auto before = Clock::now();
        std::vector<float> discarded;
        integrator->renderEstimate(std::uint32_t(accumulator.estimates()), discarded);
        warmupSeconds = std::chrono::duration<double>(Clock::now() - before).count();
    }

    std::optional<CheckpointLog> log;
    if (!o.logPath.empty())
        log.emplace(o.logPath,
                    nlohmann::json{
                        {"scene", o.scene},
                        {"integrator", o.integrator.name},
                        {"eye_vertices", o.integrator.eyeVertices},
                        {"light_vertices", o.integrator.lightVertices},
                        {"weights", o.integrator.weights},
                        {"coherence_tile", o.integrator.coherenceTile},
                        {"seed", o.integrator.seed},
                        {"width", scene.camera.width},
                        {"height", scene.camera.height},
                        {"channels", scene.channels},
                        {"device", runtime.info().deviceName},
                        {"scene_load_seconds", loadSeconds},
                        {"kernel_build_seconds", integrator->buildSeconds()},
                        {"warmup_seconds", warmupSeconds},
                        {"reference", o.reference},
                        {"reference_rms_stderr", jsonNumber(referenceRmsError)},
                        {"rel_mse_epsilon", cb::kRelMseEpsilon},
                        {"seconds_note",
                         "render wall seconds: estimates only, scene load, "
                         "kernel build, warm-up estimate and checkpoint evaluation excluded"},
                    });
    double checkpointSeconds = 0.0;
    auto onCheckpoint = [&](const cb::Checkpoint& c) {
        const auto before = Clock::now();
        cb::NoiseEstimate noise = cb::estimateNoise(accumulator);
        cb::ImageMetrics metrics;
        if (reference || !o.checkpointImages.empty()) {
            cb::RgbImage mean = accumulator.mean();
            if (reference) metrics = cb::compareImages(mean, *reference);
            if (!o.checkpointImages.empty()) {
                cb::RgbImage error = accumulator.standardError();
                auto name = fmt::format("{}-{:08d}.exr",
                                        std::filesystem::path(output).stem().string(), c.estimates);
                cb::writeExr((std::filesystem::path(o.checkpointImages) / name).string(), mean,
                             &error);
            }
        }
        checkpointSeconds += std::chrono::duration<double>(Clock::now() - before).count();
        if (log)
            log->add({double(c.estimates), c.renderSeconds, metrics.rmse, metrics.relMse,
                      metrics.mae, noise.meanStandardError, noise.rmsStandardError, noise.imageMean,
                      checkpointSeconds, c.renderCpuSeconds});
    };
    auto outcome = cb::renderEstimates(
        *integrator, accumulator, limits, gStopRequested,
        [&](const cb::RenderProgress& p) { bar.update(p); }, schedule,
        wantCheckpoints ? std::function<void(const cb::Checkpoint&)>(onCheckpoint) : nullptr);
    bar.finish();
    if (outcome.interrupted)
        fmt::print(stderr, "cbdpt: interrupted; writing the {} estimates done\n",
                   accumulator.estimates());
    if (outcome.nonFiniteSamples > 0)
        fmt::print(stderr, "cbdpt: warning: {} samples were NaN or infinite and were dropped\n",
                   outcome.nonFiniteSamples);
    if (accumulator.estimates() == 0) {
        fmt::print(stderr, "cbdpt: no estimate finished; nothing written\n");
        return 130;
    }
    cb::RgbImage mean = accumulator.mean();
    cb::RgbImage error = accumulator.standardError();
    cb::writeExr(output, mean, &error);
    cb::writePng(png, mean);
    // An interrupted render leaves its exact sums beside the EXR for --resume; a finished one
    // removes them (unless asked to keep them, to extend the render later).
    if (outcome.interrupted || o.keepState) {
        cb::saveRenderState(statePath, stateSettings, accumulator);
        if (outcome.interrupted && !o.quiet)
            fmt::print(stderr, "cbdpt: continue with the same command plus --resume\n");
    } else {
        std::error_code ignored;
        std::filesystem::remove(statePath, ignored);
    }

    double meanError = 0.0;
    for (float e : error.rgb)
        meanError += e;
    meanError /= double(std::max<size_t>(1, error.rgb.size()));
    nlohmann::json stats = {
        {"scene", o.scene},
        {"integrator", o.integrator.name},
        {"eye_vertices", o.integrator.eyeVertices},
        {"light_vertices", o.integrator.lightVertices},
        {"weights", o.integrator.weights},
        {"coherence_tile", o.integrator.coherenceTile},
        {"seed", o.integrator.seed},
        {"width", scene.camera.width},
        {"height", scene.camera.height},
        {"channels", scene.channels},
        {"estimates", accumulator.estimates()},
        {"render_seconds", outcome.renderSeconds},
        {"render_cpu_seconds", outcome.renderCpuSeconds},
        {"estimates_rendered", outcome.estimatesRendered},
        {"first_estimate_seconds", outcome.firstEstimateSeconds},
        {"seconds_per_estimate", outcome.secondsPerEstimate()},
        {"kernel_build_seconds", integrator->buildSeconds()},
        {"scene_load_seconds", loadSeconds},
        {"non_finite_samples", outcome.nonFiniteSamples},
        {"mean_standard_error", meanError},
        {"interrupted", outcome.interrupted},
        {"device", runtime.info().deviceName},
    };
    if (const cb::MltStatistics* mlt = cb::mltStatistics(*integrator)) {
        stats["mlt"] = {{"normalization", mlt->normalization},
                        {"bootstrap_normalization", mlt->bootstrapNormalization},
                        {"bootstrap_standard_error", mlt->bootstrapStandardError},
                        {"bootstrap_samples", mlt->bootstrapSamples},
                        {"chains", mlt->chains},
                        {"mutations_per_chain", mlt->mutationsPerChain},
                        {"mutations", mlt->mutations},
                        {"accepted", mlt->accepted},
                        {"acceptance_rate", mlt->acceptanceRate()},
                        {"large_steps", mlt->largeSteps},
                        {"large_steps_accepted", mlt->largeStepsAccepted},
                        {"zero_proposals", mlt->zeroProposals}};
    }
    if (wantCheckpoints) {
        stats["checkpoint_seconds"] = checkpointSeconds;
        stats["warmup_seconds"] = warmupSeconds;
    }
    if (reference) {
        cb::ImageMetrics m = cb::compareImages(mean, *reference);
        stats["reference"] = o.reference;
        stats["rmse"] = jsonNumber(m.rmse);
        stats["rel_mse"] = jsonNumber(m.relMse);
        stats["mae"] = jsonNumber(m.mae);
    }
    if (!o.statsPath.empty()) cb::writeFileAtomically(o.statsPath, stats.dump(2) + "\n");
    if (!o.quiet)
        fmt::print(stderr, "cbdpt: {} estimates in {} ({:.3f} s/estimate); wrote {} and {}\n",
                   accumulator.estimates(), formatSeconds(outcome.renderSeconds),
                   outcome.renderSeconds / double(accumulator.estimates()), output, png);
    return outcome.interrupted ? 130 : 0;
}

struct CompareOptions {
    std::string image;
    std::string reference;
    std::string diffPng;
    double diffScale = 1.0;
    bool json = false;
};

int runCompare(const CompareOptions& o) {
    cb::RgbImage image = cb::readExr(o.image);
    cb::RgbImage reference = cb::readExr(o.reference);
    cb::requireSameSize(image, reference,
                        fmt::format("{} ({}x{})", o.image, image.width, image.height),
                        fmt::format("{} ({}x{})", o.reference, reference.width, reference.height));
    if (!(o.diffScale > 0.0) || !std::isfinite(o.diffScale))
        throw std::invalid_argument("--diff-scale must be a positive number");
    cb::ImageMetrics m = cb::compareImages(image, reference);
    double imageSe = std::numeric_limits<double>::quiet_NaN();
    double referenceSe = imageSe;
    cb::RgbImage se;
    if (cb::readExrStandardError(o.image, se)) imageSe = cb::meanOf(se.rgb);
    if (cb::readExrStandardError(o.reference, se)) referenceSe = cb::rootMeanSquareOf(se.rgb);
    if (!o.diffPng.empty())
        cb::writePng8(o.diffPng, image.width, image.height,
                      cb::relativeErrorColourMap(image, reference, o.diffScale));
    if (o.json) {
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
                            {"reference_rms_stderr", jsonNumber(referenceSe)}};
        fmt::print("{}\n", j.dump(2));
        return 0;
    }
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
    return 0;
}

} // namespace

int main(int argc, char** argv) {
    CLI::App app{"cbdpt - coherent bidirectional path tracing on OpenCL"};
    app.require_subcommand(1);

    RenderOptions render;
    auto* renderCmd = app.add_subcommand("render", "render a scene to EXR and PNG");
    renderCmd->add_option("scene", render.scene, "scene file (pbrt-v4 subset)")->required();
    renderCmd->add_option("-o,--output", render.output, "EXR output (default: the Film filename)");
    renderCmd->add_option("--png", render.png, "PNG preview (default: output with .png)");
    renderCmd->add_option("--integrator", render.integrator.name, "pt | cpt | bdpt | cbdpt | mlt");
    renderCmd->add_option("--spp", render.spp, "estimates (samples per pixel)");
    renderCmd->add_option("--time", render.seconds, "render for this many seconds");
    renderCmd->add_option("--eye-vertices", render.integrator.eyeVertices,
                          "Ne: path vertices, the camera included");
    renderCmd->add_option("--light-vertices", render.integrator.lightVertices,
                          "Nl: light subpath vertices, the point on the light included");
    renderCmd->add_option("--weights", render.integrator.weights,
                          "bidirectional MIS weights: power | lafortune");
    renderCmd->add_option("--strategy", render.strategy,
                          "debug: render only strategy S,T unweighted (e.g. 2,3)");
    renderCmd->add_option("--rr-vertex", render.integrator.rouletteVertex,
                          "Russian roulette from this vertex on (0: off)");
    renderCmd->add_flag("--no-rr", render.noRoulette, "disable Russian roulette");
    renderCmd->add_option("--seed", render.integrator.seed, "random seed");
    renderCmd->add_option("--coherence-tile", render.integrator.coherenceTile,
                          "cpt, cbdpt: k x k sample vectors per estimate (1: full coherence)");
    renderCmd->add_option("--large-step", render.integrator.largeStepProbability,
                          "mlt: probability of a large step (all samples new)");
    renderCmd->add_option("--mutation-size", render.integrator.mutationSize,
                          "mlt: largest small-step perturbation s2 (s1 = s2/16)");
    renderCmd->add_option("--chains", render.integrator.mltChains,
                          "mlt: Markov chains (work-items); 0: pixels / 16");
    renderCmd->add_option("--bootstrap", render.integrator.mltBootstrap,
                          "mlt: bootstrap samples for the normalisation; 0: automatic");
    renderCmd->add_option("--tile", render.integrator.tileSize, "pixel tile (work-group) edge");
    renderCmd->add_option("--channels", render.channels, "auto | rgb | spectral");
    renderCmd->add_option("--width", render.width, "override the film width");
    renderCmd->add_option("--height", render.height, "override the film height");
    renderCmd->add_option("--device", render.device,
                          "OpenCL device P:D (default: CBDPT_DEVICE or 0:0)");
    renderCmd->add_option("--stats", render.statsPath, "write render statistics as JSON");
    renderCmd->add_flag("-q,--quiet", render.quiet, "no progress output");
    renderCmd->add_option("--checkpoints", render.checkpoints,
                          "evaluate at these estimate counts, e.g. 1,2,4,8 (renders up to the "
                          "last unless --spp/--time say otherwise)");
    renderCmd->add_option("--checkpoint-every", render.checkpointEvery,
                          "evaluate every this many seconds of render time");
    renderCmd->add_option("--reference", render.reference,
                          "reference EXR: log RMSE, relative MSE and MAE at each checkpoint");
    renderCmd->add_option("--log", render.logPath,
                          "checkpoint log, CSV or JSON by extension (a final row is always "
                          "written)");
    renderCmd->add_flag("--resume", render.resume,
                        "continue an interrupted render from OUTPUT.exr.state (same settings; "
                        "--spp is the total)");
    renderCmd->add_flag("--keep-state", render.keepState,
                        "also save OUTPUT.exr.state when the render finishes");
    renderCmd->add_flag("--no-warmup", render.noWarmup,
                        "with checkpoints or --log: skip the discarded warm-up estimate");
    renderCmd->add_option("--checkpoint-images", render.checkpointImages,
                          "folder for the EXR image at each checkpoint");

    CompareOptions compare;
    auto* compareCmd = app.add_subcommand(
        "compare", "error metrics of an EXR against a reference EXR (the second file)");
    compareCmd->add_option("image", compare.image, "EXR to evaluate")->required();
    compareCmd->add_option("reference", compare.reference, "reference EXR")->required();
    compareCmd->add_option("--diff-png", compare.diffPng,
                           "write a signed relative luminance error map (blue: too dark, white: "
                           "exact, red: too bright)");
    compareCmd->add_option("--diff-scale", compare.diffScale,
                           "relative error at which the map saturates (default 1)");
    compareCmd->add_flag("--json", compare.json, "print the metrics as JSON");

    std::string infoScene, infoDevice;
    auto* infoCmd = app.add_subcommand("info", "list OpenCL devices; describe a scene");
    infoCmd->add_option("scene", infoScene, "scene file");
    infoCmd->add_option("--device", infoDevice, "OpenCL device P:D");

    CLI11_PARSE(app, argc, argv);
    render.sppGiven = renderCmd->count("--spp") > 0;
    try {
        if (*renderCmd) return runRender(render);
        if (*infoCmd) return runInfo(infoScene, infoDevice);
        if (*compareCmd) return runCompare(compare);
    } catch (const cl::Error& e) {
        // OpenCL reports failures by status; name it, and say what to do when memory ran out.
        const bool outOfMemory =
            e.err() == CL_MEM_OBJECT_ALLOCATION_FAILURE || e.err() == CL_OUT_OF_RESOURCES ||
            e.err() == CL_OUT_OF_HOST_MEMORY || e.err() == CL_INVALID_BUFFER_SIZE;
        fmt::print(stderr, "cbdpt: error: OpenCL call {} failed with {}{}\n", e.what(),
                   cb::clStatusName(e.err()),
                   outOfMemory ? ": the device ran out of memory (try a smaller --width/--height "
                                 "or lower vertex caps)"
                               : "");
        return 1;
    } catch (const std::exception& e) {
        fmt::print(stderr, "cbdpt: error: {}\n", e.what());
        return 1;
    }
    return 0;
}
