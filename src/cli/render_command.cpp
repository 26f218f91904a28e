// `cbdpt render SCENE [options]`: renders estimates to an EXR (mean and standard error) and a
// PNG preview, with checkpoints, logs, statistics and interruption (Ctrl-C, --resume).
#include "cl/cl_runtime.h"
#include "cli/checkpoint_log.h"
#include "cli/cli_format.h"
#include "cli/cli_options.h"
#include "cli/command_support.h"
#include "cli/commands.h"
#include "cli/progress_bar.h"
#include "cluster/mpi_team.h"
#include "image/image.h"
#include "image/metrics.h"
#include "image/render_state.h"
#include "integrators/render.h"
#include "io/files.h"
#include "scene/device_scene.h"
#include "scene/scene_desc.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <unistd.h>

namespace cb::cli {

namespace {

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point start) {
    return std::chrono::duration<double>(Clock::now() - start).count();
}

struct RenderOptions {
    std::string scene;
    std::string output;
    std::string png;
    std::string statsPath;
    std::string channels = "auto";
    DeviceOptions device;
    long spp = 16;
    double seconds = 0.0;
    double targetStandardError = 0.0; // 0: none
    bool quick = false;
    int width = 0; // 0: the scene's
    int height = 0;
    std::vector<double> cropWindow; // empty or x0 x1 y0 y1
    std::string maxComponentValue;  // --max-component-value: empty, the scene's; "inf", none
    bool noRoulette = false;
    bool sppGiven = false;
    bool integratorGiven = false;
    bool eyeVerticesGiven = false;
    bool maxVerticesGiven = false; // --max-vertices, 0 (off) included: the scene's maxdepth yields
    bool lightVerticesGiven = false;
    bool resume = false;
    bool keepState = false;
    std::string estimateRange; // --estimates A:B
    double saveStateEvery = 60.0;
    std::string strategy;
    bool quiet = false;
    bool noWarmup = false;
    cb::IntegratorSettings integrator;
    // Error against time: checkpoints, a reference and a log.
    std::string checkpoints;
    double checkpointEvery = 0.0;
    std::string reference;
    std::string logPath;
    std::string checkpointImages;
};

// One render, in the order its steps run: everything that can be checked is checked before the
// scene is built and the kernels compiled; the images and statistics are written at the end.
class RenderJob {
  public:
    explicit RenderJob(RenderOptions& options) : o_(options) {}
    int run();

  private:
    int runSteps();
    void joinTeam();
    void readSceneDescription();
    void applySceneDefaults();
    void readShard();
    void checkOutputs() const;
    void applyQuick();
    void applyMaxComponentValue();
    // --cropwindow's pixel bounds [x0, x1, y0, y1] of the full film, or null.
    nlohmann::json pixelBoundsJson() const {
        return desc_.film.pixelBounds ? nlohmann::json(*desc_.film.pixelBounds) : nlohmann::json();
    }
    void readCheckpointRequests();
    void readReference();
    void buildScene();
    void applyPathOptions();
    void refuseMltContinuation() const;
    void chooseOutputPaths();
    void startIntegrator();
    void startAccumulator();
    void resumeOnRoot();
    void requireOneRenderOnEveryRank() const;
    cb::RenderLimits renderLimits() const;
    void warmUp();
    void openLog();
    void onCheckpoint(const cb::Checkpoint& c);
    void evaluateCheckpoint(const cb::Checkpoint& c);
    cb::RenderOutcome renderWithProgress(const cb::RenderLimits& limits);
    int finish(const cb::RenderOutcome& outcome);
    void writeOutputs(const cb::RenderOutcome& outcome, const cb::EstimateAccumulator& image);
    void keepWork(const cb::EstimateAccumulator& image, const std::string& failure) const;
    nlohmann::json statistics(const cb::RenderOutcome& outcome) const;
    // `fields` and the settings that identify the render, shared by the log header and --stats.
    nlohmann::json withRenderSettings(nlohmann::json fields) const;
    cb::RenderRecord renderRecord(const cb::RenderOutcome& outcome) const;

    RenderOptions& o_;
    Clock::time_point start_ = Clock::now();
    cb::SceneDesc desc_;
    cb::CheckpointSchedule schedule_;
    std::optional<cb::RgbImage> reference_;
    double referenceRmsError_ = std::numeric_limits<double>::quiet_NaN();
    bool wantCheckpoints_ = false;
    cb::DeviceScene scene_;
    double loadSeconds_ = 0.0;
    std::string output_;
    std::string png_;
    std::optional<cb::ClRuntime> runtime_;
    std::unique_ptr<cb::Integrator> integrator_;
    std::optional<cb::EstimateAccumulator> accumulator_;
    std::unique_ptr<cb::RenderTeam> team_; // MPI ranks; null when rendering alone
    bool root_ = true;                     // writes outputs and shows progress
    std::optional<cb::EstimateSet::Range> shard_;
    cb::RenderIdentity identity_;
    std::string statePath_;
    cb::RenderRecord previous_; // of the runs before a --resume: their render seconds
    double warmupSeconds_ = 0.0;
    std::optional<CheckpointLog> log_;
    double checkpointSeconds_ = 0.0;
    // The first failure of a periodic state save and of a checkpoint output (--log,
    // --checkpoint-images): the render goes on and reports them at the end.
    std::string stateSaveFailure_;
    std::string checkpointOutputFailure_;
    cb::RgbImage mean_;
    cb::RgbImage error_;
    long estimates_ = 0; // in the written image (every rank's)
    std::string estimateRanges_;
};

int RenderJob::run() {
    try {
        return runSteps();
    } catch (const std::exception& e) {
        if (!team_ || team_->size() < 2) throw;
        // One failing rank would leave the others waiting in a collective call.
        fmt::print(stderr, "cbdpt: error (rank {}): {}\n", team_->rank(), e.what());
        std::fflush(stderr);
        cb::abortMpiJob(1);
        throw;
    }
}

int RenderJob::runSteps() {
    joinTeam();
    readSceneDescription();
    readShard();
    refuseMltContinuation();
    readCheckpointRequests();
    chooseOutputPaths();
    checkOutputs();
    readReference();
    buildScene();
    applyPathOptions();
    startIntegrator();
    startAccumulator();
    const cb::RenderLimits limits = renderLimits();
    warmUp();
    openLog();
    return finish(renderWithProgress(limits));
}

// Under mpirun (or srun) the ranks form a team: rank 0 reads states, shows progress and writes
// every output; the others render their share quietly.
void RenderJob::joinTeam() {
    team_ = cb::joinMpiTeam();
    if (!team_) return;
    root_ = team_->rank() == 0;
    if (!root_) o_.quiet = true;
    if (o_.integrator.name == "mlt" && team_->size() > 1)
        throw std::invalid_argument(
            "mlt cannot be split among MPI ranks: its Markov chains carry their state from one "
            "estimate to the next, so estimates are not independent (run it in one process)");
}

// --quick, as pbrt-v4 does it: a quarter of the film's width and height, one estimate (MLT,
// whose estimates are mutations per pixel: a sixteenth of them and of the bootstrap).
void RenderJob::applyQuick() {
    desc_.film.width = std::max(1, desc_.film.width / 4);
    desc_.film.height = std::max(1, desc_.film.height / 4);
    o_.sppGiven = true;
    if (o_.integrator.name != "mlt") {
        o_.spp = 1;
        return;
    }
    o_.spp = std::max(1L, o_.spp / 16);
    const long pixels = long(desc_.film.width) * long(desc_.film.height);
    o_.integrator.mltBootstrap = std::max(1L, cb::mltBootstrapSamples(o_.integrator, pixels) / 16);
}

// --max-component-value: the film's per-sample clamp in place of the file's (pbrt-v4's
// maxcomponentvalue; inf, its default, clamps nothing), kept in the render's identity and record
// as its text, since the scene's hash covers only the file's.
void RenderJob::applyMaxComponentValue() {
    if (o_.maxComponentValue.empty()) return;
    double v = 0.0;
    size_t used = 0;
    try {
        v = std::stod(o_.maxComponentValue, &used);
    } catch (const std::exception&) {
        used = 0;
    }
    if (used != o_.maxComponentValue.size() || !(v > 0.0))
        throw std::invalid_argument(fmt::format(
            "--max-component-value {}: expected a positive number (the largest sensor RGB "
            "component a sample keeps) or inf (no clamp)",
            o_.maxComponentValue));
    desc_.film.maxComponentValue = std::isinf(v) ? std::nullopt : std::optional<double>(v);
    o_.maxComponentValue = fmt::format("{:g}", v);
}

void RenderJob::readSceneDescription() {
    desc_ = cb::parseSceneFile(o_.scene);
    applySceneDefaults();
    const int fileWidth = desc_.film.width, fileHeight = desc_.film.height;
    if (o_.width > 0) desc_.film.width = o_.width;
    if (o_.height > 0) desc_.film.height = o_.height;
    applyMaxComponentValue();
    if (o_.quick) applyQuick();
    if (!o_.cropWindow.empty())
        desc_.film.pixelBounds = cb::cropWindowPixels(
            desc_.film.width, desc_.film.height,
            {o_.cropWindow[0], o_.cropWindow[1], o_.cropWindow[2], o_.cropWindow[3]});
    else if (desc_.film.cropWindow &&
             (desc_.film.width != fileWidth || desc_.film.height != fileHeight))
        // The file's window in pixels of its own resolution: the same fractions of the new one.
        desc_.film.pixelBounds =
            cb::cropWindowPixels(desc_.film.width, desc_.film.height, *desc_.film.cropWindow,
                                 o_.scene + ": Film's crop window");
    // Refuse absurd requests before any allocation.
    const long long pixels = (long long)desc_.film.width * desc_.film.height;
    if (desc_.film.width <= 0 || desc_.film.height <= 0 || desc_.film.width > 32768 ||
        desc_.film.height > 32768 || pixels > (1LL << 28))
        throw std::invalid_argument(fmt::format(
            "resolution {}x{} is outside what cbdpt renders (each side 1..32768, at most 2^28 "
            "pixels)",
            desc_.film.width, desc_.film.height));
}

// A pbrt-v4 file's Sampler and Integrator lines are defaults that the command line overrides:
// pixelsamples -> --spp; the integrator -> --integrator; maxdepth d -> d + 2 path vertices (pbrt
// counts bounces): --eye-vertices for PT, and for the bidirectional methods pbrt-v4's own
// convention, the total-length cap --max-vertices d + 2 (unless a subpath cap is given: then the
// other one makes Ne + Nl = d + 2).
void RenderJob::applySceneDefaults() {
    if (!o_.sppGiven && desc_.sampler.pixelSamples > 0) o_.spp = desc_.sampler.pixelSamples;
    const cb::IntegratorDesc& in = desc_.integrator;
    if (!o_.integratorGiven && !in.type.empty()) o_.integrator.name = in.type;
    if (in.maxDepth < 0 || o_.maxVerticesGiven) return;
    const int vertices = in.maxDepth + 2;
    if (o_.integrator.name == "pt" || o_.integrator.name == "cpt") {
        if (!o_.eyeVerticesGiven) o_.integrator.eyeVertices = vertices;
    } else if (!o_.eyeVerticesGiven && !o_.lightVerticesGiven) {
        if (o_.integrator.maxPathVertices == 0) o_.integrator.maxPathVertices = vertices;
    } else {
        const int light = std::max(1, vertices / 2);
        if (!o_.lightVerticesGiven) o_.integrator.lightVertices = light;
        if (!o_.eyeVerticesGiven) o_.integrator.eyeVertices = std::max(2, vertices - light);
    }
}

// MLT's Markov chains carry their state from one estimate to the next and are not saved, so its
// renders cannot be continued or extended; refused before the scene is built.
void RenderJob::refuseMltContinuation() const {
    if (o_.integrator.name != "mlt") return;
    if (o_.resume)
        throw std::invalid_argument("--resume is not supported for mlt: its Markov chains "
                                    "are not saved");
    if (o_.keepState)
        throw std::invalid_argument("--keep-state is not supported for mlt: its Markov chains are "
                                    "not saved, so the render cannot be extended");
}

// --estimates A:B: a shard of a render, estimate indices A to B-1.
void RenderJob::readShard() {
    if (o_.estimateRange.empty()) return;
    if (o_.integrator.name == "mlt")
        throw std::invalid_argument(
            "--estimates: mlt renders cannot be split into shards: its Markov chains carry "
            "their state from one estimate to the next, so estimate A cannot start alone");
    shard_ = cb::parseEstimateRange(o_.estimateRange);
    if (shard_->second > cb::kEstimateIndexEnd)
        throw std::invalid_argument(fmt::format(
            "--estimates {}: estimate indices seed 32-bit random streams, so B must be at most "
            "{}",
            o_.estimateRange, cb::kEstimateIndexEnd));
    if (o_.sppGiven && shard_->second > std::uint64_t(std::max(0L, o_.spp)))
        throw std::invalid_argument(
            fmt::format("--estimates {} is outside the render of --spp {} (indices 0 to {})",
                        o_.estimateRange, o_.spp, o_.spp - 1));
}

// Checkpoint requests are checked before the scene is built or kernels compiled.
void RenderJob::readCheckpointRequests() {
    if (!o_.checkpoints.empty()) schedule_.estimates = cb::parseCheckpointList(o_.checkpoints);
    if (o_.checkpointEvery < 0.0 || !std::isfinite(o_.checkpointEvery))
        throw std::invalid_argument("--checkpoint-every must be a positive number of seconds");
    schedule_.everySeconds = o_.checkpointEvery;
    if (o_.saveStateEvery < 0.0 || !std::isfinite(o_.saveStateEvery))
        throw std::invalid_argument(
            "--save-state-every must be a positive number of seconds (0: never)");
    // --checkpoints alone renders up to the last checkpoint.
    if (!schedule_.estimates.empty() && !o_.sppGiven && o_.seconds <= 0.0) {
        o_.spp = schedule_.estimates.back();
        o_.sppGiven = true;
    }
}

// The reference image (--reference), the log's name (--log) and the checkpoint image folder.
void RenderJob::readReference() {
    if (!o_.reference.empty()) {
        reference_ = cb::readExr(o_.reference);
        // The image's size: the crop's with --cropwindow.
        int width = desc_.film.width, height = desc_.film.height;
        if (const auto& b = desc_.film.pixelBounds) {
            width = (*b)[1] - (*b)[0];
            height = (*b)[3] - (*b)[2];
        }
        if (reference_->width != width || reference_->height != height)
            throw std::invalid_argument(fmt::format(
                "--reference {} is {}x{} but the image is {}x{} (set --width/--height{} to match)",
                o_.reference, reference_->width, reference_->height, width, height,
                desc_.film.pixelBounds ? " or --cropwindow" : ""));
        cb::RgbImage referenceError;
        if (cb::readExrStandardError(o_.reference, referenceError))
            referenceRmsError_ = cb::rootMeanSquareOf(referenceError.rgb);
    }
    if (!o_.logPath.empty()) {
        const auto ext = std::filesystem::path(o_.logPath).extension();
        if (ext != ".csv" && ext != ".json")
            throw std::invalid_argument(
                fmt::format("--log '{}' must end in .csv or .json", o_.logPath));
    }
    wantCheckpoints_ = !schedule_.empty() || !o_.logPath.empty() || !o_.checkpointImages.empty();
}

void RenderJob::buildScene() {
    scene_ = cb::buildDeviceScene(desc_, parseChannels(o_.channels));
    loadSeconds_ = secondsSince(start_);
}

// --no-rr and --strategy S,T.
void RenderJob::applyPathOptions() {
    if (o_.noRoulette) o_.integrator.rouletteVertex = 0;
    if (o_.strategy.empty()) return;
    char comma = 0;
    std::istringstream in(o_.strategy);
    if (!(in >> o_.integrator.debugS >> comma >> o_.integrator.debugT) || comma != ',' ||
        o_.integrator.debugS < 0 || o_.integrator.debugT < 1)
        throw std::invalid_argument(fmt::format(
            "--strategy '{}' must be S,T with S >= 0 light vertices and T >= 1 eye vertices",
            o_.strategy));
}

namespace {

// Whether the render state at `state` exists and the image at `output` is missing or older.
bool unsavedState(const std::string& state, const std::string& output) {
    namespace fs = std::filesystem;
    std::error_code ec;
    if (!fs::exists(state, ec)) return false;
    if (!fs::exists(output, ec)) return true;
    const auto stateTime = fs::last_write_time(state, ec);
    if (ec) return true;
    const auto outputTime = fs::last_write_time(output, ec);
    return ec || outputTime < stateTime;
}

} // namespace

// Every output is checked before the scene is built: a render must not run for hours and then
// fail to write. Nothing is created or touched but the checkpoint image folder.
void RenderJob::checkOutputs() const {
    if (!root_) return;
    requireDistinctOutputs({{output_, "the image (-o)"},
                            {png_, "the PNG (--png)"},
                            {statePath_, "the render state"},
                            {o_.statsPath, "the statistics (--stats)"},
                            {o_.logPath, "the log (--log)"}});
    // A state that no image shows (its render was killed, or could not write the image) is the
    // only copy of that work: a new render would replace it. A state older than the image (kept
    // with --keep-state, or left by Ctrl-C, which writes the image after it) is replaced with
    // the image, as asked.
    if (!o_.resume && unsavedState(statePath_, output_))
        throw std::invalid_argument(fmt::format(
            "{} holds estimates that no image shows (a render to {} was killed or could not write "
            "it); {}write its image with: cbdpt merge {} -o IMAGE.exr, or remove it to start over",
            statePath_, output_,
            o_.integrator.name == "mlt" ? "" : "continue it with --resume (the same command), ",
            statePath_));
    cb::requireWritable(output_, "the image (-o)");
    cb::requireWritable(png_, "the PNG (--png)");
    cb::requireWritable(statePath_, "the render state");
    if (!o_.statsPath.empty()) cb::requireWritable(o_.statsPath, "the statistics (--stats)");
    if (!o_.logPath.empty()) cb::requireWritable(o_.logPath, "the log (--log)");
    if (!o_.checkpointImages.empty()) {
        std::filesystem::create_directories(o_.checkpointImages);
        cb::requireWritable(
            (std::filesystem::path(o_.checkpointImages) / "checkpoint.exr").string(),
            "the checkpoint images (--checkpoint-images)");
    }
}

void RenderJob::chooseOutputPaths() {
    output_ = o_.output.empty() ? std::filesystem::path(desc_.film.filename).filename().string()
                                : o_.output;
    png_ = previewPngPath(output_, o_.png);
    statePath_ = cb::renderStatePath(output_);
}

void RenderJob::startIntegrator() {
    runtime_.emplace(o_.device.device);
    integrator_ = cb::makeIntegrator(o_.integrator, scene_, *runtime_);
    // Logs and statistics state the subpath caps the total-length cap resolved to.
    o_.integrator = cb::withResolvedCaps(o_.integrator);
    if (!o_.quiet)
        fmt::print(stderr, "cbdpt: {} on {} | {}x{} {} | {} | {} | kernel build {:.2f}s\n",
                   o_.integrator.name, runtime_->info().deviceName, scene_.camera.width,
                   scene_.camera.height, scene_.channels == 16 ? "spectral-16" : "rgb", o_.scene,
                   o_.integrator.maxPathVertices > 0
                       ? fmt::format("N={} (Ne={}, Nl={})", o_.integrator.maxPathVertices,
                                     o_.integrator.eyeVertices, o_.integrator.lightVertices)
                   : o_.integrator.name == "pt" || o_.integrator.name == "cpt"
                       ? fmt::format("Ne={}", o_.integrator.eyeVertices)
                       : fmt::format("Ne={}, Nl={}", o_.integrator.eyeVertices,
                                     o_.integrator.lightVertices),
                   integrator_->buildSeconds());
}

// The ranks share one render only if each runs the same command on the same scene: otherwise
// their sums mix other images, or they meet in different collective calls and hang. Each rank
// compares a hash of its identity and of the options that drive collectives with process 0's.
void RenderJob::requireOneRenderOnEveryRank() const {
    if (!team_ || team_->size() < 2) return;
    const std::string command = fmt::format(
        "{}|{}|spp {}|time {}|target {}|estimates {}|save {}|checkpoints {}|every {}|log {}|"
        "reference {}|images {}|resume {}|warm-up {}",
        identity_.settings.dump(), identity_.sceneHash, o_.spp, o_.seconds, o_.targetStandardError,
        o_.estimateRange, o_.saveStateEvery, o_.checkpoints, o_.checkpointEvery,
        !o_.logPath.empty(), !o_.reference.empty(), !o_.checkpointImages.empty(), o_.resume,
        !o_.noWarmup);
    // 16-bit parts, which sums of doubles over any number of ranks keep exactly.
    const std::uint64_t hash = std::hash<std::string>{}(command);
    std::vector<double> rootHash(4);
    for (size_t i = 0; i < 4; ++i)
        rootHash[i] = root_ ? double((hash >> (16 * i)) & 0xffffu) : 0.0;
    team_->sumAll(rootHash);
    bool same = true;
    for (size_t i = 0; i < 4; ++i)
        same = same && rootHash[i] == double((hash >> (16 * i)) & 0xffffu);
    std::vector<double> differing{same ? 0.0 : 1.0};
    team_->sumAll(differing);
    const std::string why = "the scene, the render settings or the options --spp, --time, "
                            "--estimates, --checkpoints, --log, --save-state-every differ; every "
                            "rank must run the same command";
    if (!same)
        throw std::invalid_argument(
            fmt::format("MPI rank {} runs another render than rank 0 ({})", team_->rank(), why));
    if (root_ && differing[0] > 0.0)
        throw std::invalid_argument(
            fmt::format("{} of {} MPI ranks run another render than rank 0 ({})",
                        long(differing[0]), team_->size(), why));
}

// Ctrl-C handling, the accumulator, and what it holds already when resuming.
void RenderJob::startAccumulator() {
    installStopHandler();
    accumulator_.emplace(scene_.camera.width, scene_.camera.height);
    // Two independent halves of the estimates, for `cbdpt combine` (image/combine.h).
    accumulator_->trackHalves();
    identity_ = cb::renderIdentity(o_.integrator, desc_, scene_);
    if (!o_.maxComponentValue.empty())
        identity_.settings["max_component_value"] = o_.maxComponentValue;
    requireOneRenderOnEveryRank();
    if (o_.resume && root_) resumeOnRoot();
    // A state of an earlier build may hold no halves: every rank's sums must then have none,
    // for each reduction moves the same arrays on every rank.
    if (o_.resume && team_) {
        std::vector<double> rootHasNoHalves{root_ && !accumulator_->tracksHalves() ? 1.0 : 0.0};
        team_->sumAll(rootHasNoHalves);
        if (rootHasNoHalves[0] > 0.0 && !root_)
            accumulator_.emplace(scene_.camera.width, scene_.camera.height);
    }
}

void RenderJob::resumeOnRoot() {
    cb::resumeRenderState(statePath_, identity_, *accumulator_);
    if (o_.sppGiven && !shard_ && accumulator_->estimates() > o_.spp)
        throw std::invalid_argument(
            fmt::format("--spp {} is the total with --resume, and {} holds {} estimates already",
                        o_.spp, statePath_, accumulator_->estimates()));
    // The render time of the runs before, from the image they wrote, so the record's time
    // covers all the estimates.
    try {
        previous_ = cb::renderRecordFromExr(cb::readExrAttributes(output_), output_);
    } catch (const std::exception& e) {
        if (!o_.quiet)
            fmt::print(stderr, "cbdpt: warning: the earlier runs' render time is unknown ({})\n",
                       e.what());
    }
    if (!o_.quiet)
        fmt::print(stderr, "cbdpt: resuming from {} estimates {} ({})\n", accumulator_->estimates(),
                   accumulator_->indices().toString(), statePath_);
}

cb::RenderLimits RenderJob::renderLimits() const {
    cb::RenderLimits limits;
    // --time or --target-stderr alone render until they are met; with --spp too, until the first
    // limit is reached.
    const bool otherLimit = o_.seconds > 0.0 || o_.targetStandardError > 0.0;
    limits.estimates = otherLimit && !o_.sppGiven ? 0 : o_.spp;
    if (limits.estimates < 0 || limits.estimates > (1L << 32))
        throw std::invalid_argument(fmt::format(
            "--spp {} is out of range (estimate indices seed 32-bit random streams)", o_.spp));
    if (shard_) {
        limits.firstEstimate = shard_->first;
        limits.estimates = long(shard_->second - shard_->first);
    }
    limits.seconds = o_.seconds;
    limits.targetStandardError = o_.targetStandardError;
    if (!schedule_.estimates.empty() && limits.estimates > 0 &&
        schedule_.estimates.back() > limits.estimates && !o_.quiet)
        fmt::print(stderr, "cbdpt: warning: checkpoints past --spp {} will not be reached\n",
                   limits.estimates);
    return limits;
}

// PoCL compiles a kernel for its work-group size at the first launch, not at clBuildProgram, so
// on a cold kernel cache the first estimate can take seconds. Error-against-time logs would
// charge that to the method; one discarded estimate before the clock starts keeps it out (for
// stateful methods such as MLT it is extra burn-in).
void RenderJob::warmUp() {
    if (!wantCheckpoints_ || o_.noWarmup) return;
    const auto before = Clock::now();
    std::vector<float> discarded;
    integrator_->renderEstimate(std::uint32_t(accumulator_->estimates()), discarded);
    warmupSeconds_ = secondsSince(before);
}

nlohmann::json RenderJob::withRenderSettings(nlohmann::json fields) const {
    fields.update(nlohmann::json{{"scene", o_.scene},
                                 {"integrator", o_.integrator.name},
                                 {"eye_vertices", o_.integrator.eyeVertices},
                                 {"light_vertices", o_.integrator.lightVertices},
                                 {"max_vertices", o_.integrator.maxPathVertices},
                                 {"weights", o_.integrator.weights},
                                 {"coherence_tile", o_.integrator.coherenceTile},
                                 {"seed", o_.integrator.seed},
                                 {"sampler", o_.integrator.sampler},
                                 {"width", scene_.camera.width},
                                 {"height", scene_.camera.height},
                                 {"channels", scene_.channels}});
    if (!o_.maxComponentValue.empty()) fields["max_component_value"] = o_.maxComponentValue;
    return fields;
}

void RenderJob::openLog() {
    if (o_.logPath.empty()) return;
    log_.emplace(
        o_.logPath,
        withRenderSettings(nlohmann::json{
            {"device", runtime_->info().deviceName},
            {"scene_load_seconds", loadSeconds_},
            {"kernel_build_seconds", integrator_->buildSeconds()},
            {"warmup_seconds", warmupSeconds_},
            {"reference", o_.reference},
            {"reference_rms_stderr", jsonNumber(referenceRmsError_)},
            {"rel_mse_epsilon", cb::kRelMseEpsilon},
            {"seconds_note", "render wall seconds: estimates only, scene load, "
                             "kernel build, warm-up estimate and checkpoint evaluation excluded"},
        }));
}

// Noise, error against the reference and checkpoint images; its time is reported apart.
void RenderJob::onCheckpoint(const cb::Checkpoint& c) {
    const cb::EstimateAccumulator& image = *c.image;
    // The periodic state: what a SIGKILL, the out-of-memory killer or a power cut would lose.
    if (c.saveState) {
        try {
            cb::saveRenderState(statePath_, identity_, image);
        } catch (const std::exception& e) {
            // Insurance that failed must not end the render it insures: the final write keeps
            // the work where it can (keepWork).
            // A leading newline ends the progress bar's line.
            if (stateSaveFailure_.empty())
                fmt::print(stderr,
                           "{}cbdpt: warning: {}; the render goes on, the state is saved again at "
                           "the next period and at the end\n",
                           o_.quiet ? "" : "\n", e.what());
            stateSaveFailure_ = e.what();
        }
    }
    if (!c.evaluate || !wantCheckpoints_) return;
    try {
        evaluateCheckpoint(c);
    } catch (const std::exception& e) {
        if (checkpointOutputFailure_.empty())
            fmt::print(stderr, "{}cbdpt: error: {}; the render goes on\n", o_.quiet ? "" : "\n",
                       e.what());
        checkpointOutputFailure_ = e.what();
    }
}

void RenderJob::evaluateCheckpoint(const cb::Checkpoint& c) {
    const cb::EstimateAccumulator& image = *c.image;
    const auto before = Clock::now();
    cb::NoiseEstimate noise = cb::estimateNoise(image);
    cb::ImageMetrics metrics;
    if (reference_ || !o_.checkpointImages.empty()) {
        cb::RgbImage mean = image.mean();
        if (reference_) metrics = cb::compareImages(mean, *reference_);
        if (!o_.checkpointImages.empty()) {
            auto name = fmt::format("{}-{:08d}.exr", std::filesystem::path(output_).stem().string(),
                                    c.estimates);
            cb::RenderOutcome sofar;
            sofar.renderSeconds = c.renderSeconds;
            sofar.renderCpuSeconds = c.renderCpuSeconds;
            cb::writeRenderExr((std::filesystem::path(o_.checkpointImages) / name).string(), image,
                               renderRecord(sofar));
        }
    }
    checkpointSeconds_ += secondsSince(before);
    if (log_)
        log_->add({double(c.estimates), c.renderSeconds, metrics.rmse, metrics.relMse, metrics.mae,
                   noise.meanStandardError, noise.rmsStandardError, noise.imageMean,
                   checkpointSeconds_, c.renderCpuSeconds});
}

cb::RenderOutcome RenderJob::renderWithProgress(const cb::RenderLimits& limits) {
    ProgressBar bar(!o_.quiet);
    // MLT cannot resume, so its state is not saved periodically.
    if (o_.integrator.name != "mlt") schedule_.saveStateEverySeconds = o_.saveStateEvery;
    const bool callback = wantCheckpoints_ || schedule_.saveStateEverySeconds > 0.0;
    auto outcome = cb::renderEstimates(
        *integrator_, *accumulator_, limits, stopRequested(),
        [&](const cb::RenderProgress& p) { bar.update(p); }, schedule_,
        callback ? std::function<void(const cb::Checkpoint&)>(
                       [this](const cb::Checkpoint& c) { onCheckpoint(c); })
                 : nullptr,
        team_.get());
    bar.finish();
    return outcome;
}

int RenderJob::finish(const cb::RenderOutcome& outcome) {
    // Every rank's estimates, on rank 0 (a collective call: every rank makes it).
    const cb::EstimateAccumulator* image = team_ ? team_->gather(*accumulator_) : &*accumulator_;
    if (!image) return outcome.interrupted ? 130 : 0;
    estimates_ = image->estimates();
    estimateRanges_ = image->indices().toString();
    if (outcome.interrupted)
        fmt::print(stderr, "cbdpt: interrupted; writing the {} estimates done\n", estimates_);
    if (outcome.reachedTargetStandardError && !o_.quiet)
        fmt::print(stderr, "cbdpt: the mean standard error fell below --target-stderr {:g}\n",
                   o_.targetStandardError);
    if (outcome.nonFiniteSamples > 0)
        fmt::print(stderr, "cbdpt: warning: {} samples were NaN or infinite and were dropped\n",
                   outcome.nonFiniteSamples);
    if (image->droppedSamples() > 0)
        fmt::print(stderr,
                   "cbdpt: warning: {} samples of magnitude 2^48 or more were dropped (too large "
                   "for the exact sums)\n",
                   image->droppedSamples());
    if (estimates_ == 0) {
        fmt::print(stderr, "cbdpt: no estimate finished; nothing written\n");
        return 130;
    }
    try {
        writeOutputs(outcome, *image);
    } catch (const std::exception& e) {
        keepWork(*image, e.what());
        return 1;
    }
    if (!o_.quiet)
        fmt::print(stderr, "cbdpt: {} estimates in {} ({}); wrote {} and {}\n", estimates_,
                   formatSeconds(outcome.renderSeconds),
                   perEstimateSummary(outcome.secondsPerEstimate(), outcome.firstEstimateSeconds,
                                      outcome.estimatesRendered),
                   output_, png_);
    if (const cb::MltStatistics* mlt = cb::mltStatistics(*integrator_);
        mlt && mlt->mutations > 0 && !o_.quiet)
        fmt::print(stderr, "{}\n", cb::mltSummary(*mlt));
    if (!checkpointOutputFailure_.empty()) {
        fmt::print(stderr, "cbdpt: error: the checkpoint outputs are incomplete: {}\n",
                   checkpointOutputFailure_);
        return 1;
    }
    return outcome.interrupted ? 130 : 0;
}

void RenderJob::writeOutputs(const cb::RenderOutcome& outcome,
                             const cb::EstimateAccumulator& image) {
    mean_ = image.mean();
    error_ = image.standardError();
    // The state first: if anything below fails, the work is on disk already.
    // MLT's Markov chains are not saved, so its state could not be resumed or extended.
    const bool keep = o_.integrator.name != "mlt" && (outcome.interrupted || o_.keepState);
    if (keep) cb::saveRenderState(statePath_, identity_, image);
    cb::writeRenderExr(output_, image, renderRecord(outcome));
    cb::writePng(png_, mean_);
    if (!o_.statsPath.empty())
        cb::writeFileAtomically(o_.statsPath, statistics(outcome).dump(2) + "\n");
    // An interrupted render leaves its exact sums beside the EXR for --resume; a finished one
    // removes them (unless asked to keep them, to extend the render later).
    if (keep) {
        if (outcome.interrupted && !o_.quiet)
            fmt::print(stderr, "cbdpt: continue with the same command plus --resume\n");
    } else {
        std::error_code ignored;
        std::filesystem::remove(statePath_, ignored);
    }
}

// The EXR header's record of the estimates so far, earlier runs' time included when resuming.
cb::RenderRecord RenderJob::renderRecord(const cb::RenderOutcome& outcome) const {
    cb::RenderRecord record = cb::makeRenderRecord(o_.integrator, o_.scene, identity_.sceneHash,
                                                   scene_.channels, outcome);
    if (desc_.film.pixelBounds) record.pixelBounds = cb::pixelBoundsText(*desc_.film.pixelBounds);
    record.maxComponentValue = o_.maxComponentValue;
    record.renderSeconds += previous_.renderSeconds;
    record.renderCpuSeconds += previous_.renderCpuSeconds;
    return record;
}

// A final write failed although the outputs were checked before rendering (a disk filled up, a
// folder was removed): the work is saved where it can be, and the message says where.
void RenderJob::keepWork(const cb::EstimateAccumulator& image, const std::string& failure) const {
    fmt::print(stderr, "cbdpt: error: {}\n", failure);
    const std::string name = std::filesystem::path(statePath_).filename().string();
    for (const std::string& path : {statePath_, std::string()}) {
        try {
            const std::string target =
                path.empty() ? cb::fallbackPath(fmt::format("{}.{}", name, ::getpid())) : path;
            cb::saveRenderState(target, identity_, image);
            fmt::print(stderr,
                       "cbdpt: the render's {} estimates are kept in {}; write its image with: "
                       "cbdpt merge {} -o IMAGE.exr\n",
                       estimates_, target, target);
            return;
        } catch (const std::exception& e) {
            fmt::print(stderr, "cbdpt: cannot keep the state there either: {}\n", e.what());
        }
    }
}

// The --stats JSON.
nlohmann::json RenderJob::statistics(const cb::RenderOutcome& outcome) const {
    double meanError = 0.0;
    for (float e : error_.rgb)
        meanError += e;
    meanError /= double(std::max<size_t>(1, error_.rgb.size()));
    nlohmann::json stats = withRenderSettings({
        {"estimates", estimates_},
        {"estimate_ranges", estimateRanges_},
        {"processes", team_ ? team_->size() : 1},
        {"reductions", team_ ? team_->reductions() : 0},
        {"reduction_seconds", team_ ? team_->reductionSeconds() : 0.0},
        {"render_seconds", outcome.renderSeconds},
        {"render_cpu_seconds", outcome.renderCpuSeconds},
        {"estimates_rendered", outcome.estimatesRendered},
        {"first_estimate_seconds", outcome.firstEstimateSeconds},
        {"seconds_per_estimate", outcome.secondsPerEstimate()},
        {"kernel_build_seconds", integrator_->buildSeconds()},
        {"host_sample_streams", integrator_->hostSampleStreams()},
        {"packets", integrator_->tracesPackets()},
        {"ray_packet_rays", integrator_->rayPacketRays()},
        {"tree_prefetch", integrator_->treePrefetch()},
        {"scene_load_seconds", loadSeconds_},
        {"non_finite_samples", outcome.nonFiniteSamples},
        {"mean_standard_error", meanError},
        {"interrupted", outcome.interrupted},
        {"device", runtime_->info().deviceName},
        {"device_compute_units", runtime_->info().computeUnits},
        {"pixel_bounds", pixelBoundsJson()},
    });
    if (o_.targetStandardError > 0.0) {
        stats["target_stderr"] = o_.targetStandardError;
        stats["reached_target_stderr"] = outcome.reachedTargetStandardError;
    }
    if (const cb::MltStatistics* mlt = cb::mltStatistics(*integrator_)) {
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
    if (wantCheckpoints_) {
        stats["checkpoint_seconds"] = checkpointSeconds_;
        stats["warmup_seconds"] = warmupSeconds_;
    }
    if (reference_) {
        cb::ImageMetrics m = cb::compareImages(mean_, *reference_);
        stats["reference"] = o_.reference;
        stats["rmse"] = jsonNumber(m.rmse);
        stats["rel_mse"] = jsonNumber(m.relMse);
        stats["mae"] = jsonNumber(m.mae);
    }
    return stats;
}

// The options, by group, in the order --help lists them. Values out of range are refused when
// parsed; the integrator checks its settings again for callers of the library.
void addOutputOptions(CLI::App& cmd, RenderOptions& o) {
    const char* group = "Output";
    cmd.add_option("scene", o.scene, "scene file (pbrt-v4 subset)")->required();
    cmd.add_option("-o,--output,--outfile", o.output, "EXR output (default: the Film filename)")
        ->group(group);
    cmd.add_option("--png", o.png, "PNG preview (default: the output with .png)")->group(group);
    cmd.add_option("--stats", o.statsPath, "write render statistics as JSON")->group(group);
    cmd.add_option("--width", o.width, "film width (default: the scene's)")
        ->check(CLI::Range(1, 32768))
        ->group(group);
    cmd.add_option("--height", o.height, "film height (default: the scene's)")
        ->check(CLI::Range(1, 32768))
        ->group(group);
    cmd.add_option("--max-component-value", o.maxComponentValue,
                   "clamp each sample's largest sensor RGB component to this, in place of the "
                   "Film's \"maxcomponentvalue\" (inf: no clamp, an unbiased image)")
        ->group(group);
    cmd.add_option("--cropwindow", o.cropWindow,
                   "x0 x1 y0 y1: render only this part of the film, in [0,1] fractions of it "
                   "(pbrt's crop window; the image has the crop's size)")
        ->expected(4)
        ->check(finiteRange(0.0, 1.0))
        ->group(group);
    cmd.add_option("--channels", o.channels,
                   "auto (spectral when the scene has spectrum values) | rgb | spectral")
        ->check(CLI::IsMember({"auto", "rgb", "spectral"}))
        ->capture_default_str()
        ->group(group);
    cmd.add_flag("-q,--quiet", o.quiet, "no progress output")->group(group);
}

void addMethodOptions(CLI::App& cmd, RenderOptions& o) {
    const char* group = "Method";
    auto& s = o.integrator;
    cmd.add_option("--integrator", s.name,
                   "pt | cpt | bdpt | cbdpt | mlt (default: the scene's Integrator, else pt)")
        ->check(CLI::IsMember({"pt", "cpt", "bdpt", "cbdpt", "mlt"}))
        ->capture_default_str()
        ->group(group);
    auto* eye =
        cmd.add_option("--eye-vertices", s.eyeVertices, "Ne: path vertices, the camera included")
            ->check(CLI::Range(2, 1024))
            ->capture_default_str()
            ->group(group);
    auto* light = cmd.add_option("--light-vertices", s.lightVertices,
                                 "Nl: light subpath vertices, the point on the light included")
                      ->check(CLI::Range(1, 1024))
                      ->capture_default_str()
                      ->group(group);
    cmd.add_option("--max-vertices", s.maxPathVertices,
                   "N: a cap on the whole path's vertices instead of Ne and Nl (pbrt-v4's "
                   "maxdepth + 2): every strategy with s + t <= N, so bdpt, cbdpt and mlt "
                   "cover PT's paths of N vertices (0: off, the thesis's caps)")
        ->check(CLI::Range(0, 1024))
        ->excludes(light)
        ->excludes(eye)
        ->group(group);
    cmd.add_option("--weights", s.weights, "bidirectional MIS weights: power | lafortune")
        ->check(CLI::IsMember({"power", "lafortune"}))
        ->capture_default_str()
        ->group(group);
    cmd.add_option("--strategy", o.strategy,
                   "debug: render only strategy S,T unweighted (e.g. 2,3)")
        ->group(group);
    cmd.add_option("--rr-vertex", s.rouletteVertex, "Russian roulette from this vertex on (0: off)")
        ->check(CLI::Range(0, 1024))
        ->capture_default_str()
        ->group(group);
    cmd.add_flag("--no-rr", o.noRoulette, "disable Russian roulette")->group(group);
    cmd.add_option("--seed", s.seed, "random seed")->capture_default_str()->group(group);
    cmd.add_option("--sampler", s.sampler,
                   "sobol | independent: the sample vectors (docs/sampling.md); mlt's chains "
                   "choose their own")
        ->check(CLI::IsMember({"sobol", "independent"}))
        ->capture_default_str()
        ->group(group);
    cmd.add_option("--coherence-tile", s.coherenceTile,
                   "cpt, cbdpt: k x k sample vectors per estimate (1: full coherence)")
        ->check(CLI::Range(1, 4096))
        ->capture_default_str()
        ->group(group);
    cmd.add_option("--large-step", s.largeStepProbability,
                   "mlt: probability of a large step (all samples new)")
        ->check(finiteRange(0.0, 1.0))
        ->capture_default_str()
        ->group(group);
    cmd.add_option("--mutation-size", s.mutationSize,
                   "mlt: largest small-step perturbation s2 (s1 = s2/16)")
        ->check(finiteRange(0.0, 0.5, true))
        ->capture_default_str()
        ->group(group);
    cmd.add_option("--chains", s.mltChains, "mlt: Markov chains (work-items); 0: pixels / 16")
        ->check(CLI::Range(0, 1 << 24))
        ->capture_default_str()
        ->group(group);
    cmd.add_option("--bootstrap", s.mltBootstrap,
                   "mlt: bootstrap samples for the normalisation; 0: max(pixels, 65536)")
        ->check(CLI::Range(0L, 1L << 31))
        ->capture_default_str()
        ->group(group);
    cmd.add_option("--tile", s.tileSize,
                   "pixel tile edge: a work-group of the per-pixel kernels; on a CPU, a "
                   "work-item of CPT's and CBDPT's packets when a multiple of 4")
        ->check(CLI::Range(1, 32))
        ->capture_default_str()
        ->group(group);
}

void addBudgetOptions(CLI::App& cmd, RenderOptions& o) {
    const char* group = "Budget (the first limit reached ends the render)";
    cmd.add_option(
           "--spp", o.spp,
           "estimates (samples per pixel; default: the scene's Sampler pixelsamples, else 16)")
        ->check(CLI::Range(1L, long(cb::kEstimateIndexEnd)))
        ->capture_default_str()
        ->group(group);
    cmd.add_option("--time", o.seconds, "render for this many seconds")
        ->check(finiteRange(0.0, 1e9, true))
        ->group(group);
    cmd.add_option("--target-stderr", o.targetStandardError,
                   "stop when the mean per-pixel standard error falls below this")
        ->check(finiteRange(0.0, 1e30, true))
        ->group(group);
    cmd.add_flag("--quick", o.quick,
                 "as pbrt-v4: a quarter of the film's width and height, 1 estimate (mlt: "
                 "--spp and the bootstrap / 16)")
        ->group(group);
    cmd.add_flag("--resume", o.resume,
                 "continue an interrupted render from OUTPUT.exr.state (same settings; "
                 "--spp is the total)")
        ->group(group);
    cmd.add_flag("--keep-state", o.keepState, "also save OUTPUT.exr.state when the render finishes")
        ->group(group);
    cmd.add_option("--estimates", o.estimateRange,
                   "render only estimate indices A to B-1 (A:B), a shard: shards of one seed "
                   "merge (cbdpt merge) into the render of their union")
        ->group(group);
    cmd.add_option("--save-state-every", o.saveStateEvery,
                   "save OUTPUT.exr.state every this many seconds (default 60; 0: never), so "
                   "that a killed render can --resume")
        ->check(finiteRange(0.0, 1e9))
        ->group(group);
}

void addCheckpointOptions(CLI::App& cmd, RenderOptions& o) {
    const char* group = "Error against time";
    cmd.add_option("--checkpoints", o.checkpoints,
                   "evaluate at these estimate counts, e.g. 1,2,4,8 (renders up to the "
                   "last unless --spp/--time say otherwise)")
        ->group(group);
    cmd.add_option("--checkpoint-every", o.checkpointEvery,
                   "evaluate every this many seconds of render time")
        ->check(finiteRange(0.0, 1e9, true))
        ->group(group);
    cmd.add_option("--reference", o.reference,
                   "reference EXR: log RMSE, relative MSE and MAE at each checkpoint")
        ->group(group);
    cmd.add_option("--log", o.logPath,
                   "checkpoint log, CSV or JSON by extension (a final row is always written)")
        ->group(group);
    cmd.add_flag("--no-warmup", o.noWarmup,
                 "with checkpoints or --log: skip the discarded warm-up estimate")
        ->group(group);
    cmd.add_option("--checkpoint-images", o.checkpointImages,
                   "folder for the EXR image at each checkpoint")
        ->group(group);
}

constexpr const char* kRenderExamples = R"(Examples:
  cbdpt render scenes/cornell-box.pbrt --quick
  cbdpt render scenes/cornell-box.pbrt --integrator cbdpt --eye-vertices 4 --light-vertices 4 \
      --spp 64 -o cornell.exr --stats cornell.json
  cbdpt render scenes/cornell-box.pbrt --integrator bdpt --target-stderr 0.002 --time 600
  cbdpt render scenes/cornell-box.pbrt --cropwindow 0.25 0.75 0.5 1 --nthreads 1
  cbdpt render scenes/cornell-box.pbrt --checkpoints 1,4,16,64 --reference ref.exr --log err.csv)";

} // namespace

Command addRenderCommand(CLI::App& app) {
    auto o = std::make_shared<RenderOptions>();
    auto* cmd = app.add_subcommand("render", "render a scene to EXR and PNG");
    addOutputOptions(*cmd, *o);
    addMethodOptions(*cmd, *o);
    addBudgetOptions(*cmd, *o);
    addCheckpointOptions(*cmd, *o);
    addDeviceOptions(*cmd, o->device);
    cmd->footer(kRenderExamples);
    return {cmd, [o, cmd] {
                o->sppGiven = cmd->count("--spp") > 0;
                o->integratorGiven = cmd->count("--integrator") > 0;
                o->eyeVerticesGiven = cmd->count("--eye-vertices") > 0;
                o->maxVerticesGiven = cmd->count("--max-vertices") > 0;
                o->lightVerticesGiven = cmd->count("--light-vertices") > 0;
                applyThreadLimit(o->device);
                return RenderJob(*o).run();
            }};
}

} // namespace cb::cli
