// `cbdpt merge S1.state S2.state ... -o OUT.exr [--state MERGED.state]`: adds the exact sums of
// render states of disjoint estimate sets (shards, or the ranks of separate jobs) into one
// image; the result is the render of the union of their estimates, bit for bit.
#include "cli/command_support.h"
#include "cli/commands.h"
#include "image/image.h"
#include "image/render_record.h"
#include "image/render_state.h"
#include "io/files.h"

#include <fmt/format.h>

#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace cb::cli {

namespace {

struct MergeOptions {
    std::vector<std::string> states;
    std::string output;
    std::string png;
    std::string state;
    bool quiet = false;
};

int runMerge(MergeOptions& o) {
    namespace fs = std::filesystem;
    o.png = previewPngPath(o.output, o.png);
    // Outputs are checked before any state is read; nothing is written unless all succeeds.
    requireDistinctOutputs({{o.output, "the image (-o)"},
                            {o.png, "the PNG (--png)"},
                            {o.state, "the merged state (--state)"}});
    cb::requireWritable(o.output, "the image (-o)");
    cb::requireWritable(o.png, "the PNG (--png)");
    if (!o.state.empty()) cb::requireWritable(o.state, "the merged state (--state)");
    for (size_t i = 0; i < o.states.size(); ++i)
        for (size_t j = 0; j < i; ++j) {
            std::error_code ec;
            if (o.states[i] == o.states[j] || fs::equivalent(o.states[i], o.states[j], ec))
                throw std::invalid_argument(fmt::format(
                    "{} is given twice: merging a state with itself would count its estimates "
                    "twice",
                    o.states[i]));
        }
    cb::RenderState merged = cb::loadRenderState(o.states.front());
    // One mlt state alone gives its image (a render whose final write failed keeps one).
    if (o.states.size() > 1 && merged.identity.settings.value("integrator", "") == "mlt")
        throw std::invalid_argument(fmt::format(
            "{} is an mlt render: its estimates are steps of Markov chains, not independent, so "
            "mlt states are not merged with others",
            o.states.front()));
    for (size_t i = 1; i < o.states.size(); ++i) {
        cb::RenderState next = cb::loadRenderState(o.states[i]);
        const auto differences = cb::identityDifferences(merged.identity, next.identity);
        if (!differences.empty()) {
            std::string list;
            for (const auto& d : differences)
                list += "\n  " + d;
            throw std::invalid_argument(fmt::format("{} and {} are different renders ({} there, "
                                                    "{} here):{}",
                                                    o.states.front(), o.states[i], o.states.front(),
                                                    o.states[i], list));
        }
        if (merged.accumulator.indices().intersects(next.accumulator.indices()))
            throw std::invalid_argument(fmt::format(
                "{} holds estimates {} and the states before it {}: they overlap, so an estimate "
                "would be counted twice",
                o.states[i], next.accumulator.indices().toString(),
                merged.accumulator.indices().toString()));
        merged.accumulator.merge(next.accumulator);
    }
    const cb::RgbImage mean = merged.accumulator.mean();
    // The halves and the render record too, so a merged image can be combined (docs/combine.md).
    cb::writeRenderExr(o.output, merged.accumulator, cb::renderRecordFromIdentity(merged.identity));
    cb::writePng(o.png, mean);
    // The merged state last: it is written only when the image was.
    if (!o.state.empty()) cb::saveRenderState(o.state, merged.identity, merged.accumulator);
    if (!o.quiet)
        fmt::print(stderr, "cbdpt: merged {} state{}: {} estimates ({}); wrote {} and {}{}\n",
                   o.states.size(), o.states.size() == 1 ? "" : "s", merged.accumulator.estimates(),
                   merged.accumulator.indices().toString(), o.output, o.png,
                   o.state.empty() ? "" : " and " + o.state);
    return 0;
}

} // namespace

Command addMergeCommand(CLI::App& app) {
    auto o = std::make_shared<MergeOptions>();
    auto* cmd = app.add_subcommand(
        "merge", "add render states of disjoint estimate sets (shards) into one image");
    cmd->add_option("states", o->states, "render states (.state) of one render's estimates")
        ->required();
    cmd->add_option("-o,--output", o->output, "EXR output")->required();
    cmd->add_option("--png", o->png, "PNG preview (default: output with .png)");
    cmd->add_option("--state", o->state, "also write the merged state (to merge or resume later)");
    cmd->add_flag("-q,--quiet", o->quiet, "no summary line");
    return {cmd, [o] { return runMerge(*o); }};
}

} // namespace cb::cli
