#include "image/render_record.h"

#include <fmt/format.h>

#include <array>
#include <climits>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>

namespace cb {

namespace {
int checkedInt(long value, const char* what) {
    if (value < INT_MIN || value > INT_MAX)
        throw std::out_of_range(
            fmt::format("{} {} does not fit an EXR int attribute", what, value));
    return int(value);
}
} // namespace

std::string pixelBoundsText(const std::array<int, 4>& bounds) {
    return fmt::format("{} {} {} {}", bounds[0], bounds[1], bounds[2], bounds[3]);
}

std::string recordedSampler(const std::string& method, const std::string& sampler) {
    return method == "mlt" ? "mlt" : sampler;
}

std::string strategyText(int s, int t) {
    return s >= 0 ? fmt::format("{},{}", s, t) : std::string();
}

ExrAttributes toExrAttributes(const RenderRecord& r) {
    ExrAttributes a;
    a.strings["cbdpt_method"] = r.method;
    a.strings["cbdpt_weights"] = r.weights;
    a.strings["cbdpt_scene"] = r.sceneFile;
    a.strings["cbdpt_scene_hash"] = r.sceneHash;
    if (!r.inputs.empty()) a.strings["cbdpt_inputs"] = r.inputs;
    if (!r.sampler.empty()) a.strings["cbdpt_sampler"] = r.sampler;
    if (!r.pixelBounds.empty()) a.strings["cbdpt_pixel_bounds"] = r.pixelBounds;
    if (!r.strategy.empty()) a.strings["cbdpt_strategy"] = r.strategy;
    if (!r.maxComponentValue.empty()) a.strings["cbdpt_max_component_value"] = r.maxComponentValue;
    a.ints["cbdpt_eye_vertices"] = r.eyeVertices;
    a.ints["cbdpt_light_vertices"] = r.lightVertices;
    a.ints["cbdpt_max_vertices"] = r.maxVertices;
    a.ints["cbdpt_coherence_tile"] = r.coherenceTile;
    a.ints["cbdpt_roulette_vertex"] = r.rouletteVertex;
    // The 32-bit seed in a signed int attribute, bit for bit.
    a.ints["cbdpt_seed"] = int(r.seed);
    a.ints["cbdpt_channels"] = r.channels;
    a.ints["cbdpt_width"] = r.width;
    a.ints["cbdpt_height"] = r.height;
    a.ints["cbdpt_estimates"] = checkedInt(r.estimates, "estimate count");
    a.strings["cbdpt_estimate_ranges"] = r.estimateSet.toString();
    a.doubles["cbdpt_render_seconds"] = r.renderSeconds;
    a.doubles["cbdpt_render_cpu_seconds"] = r.renderCpuSeconds;
    return a;
}

RenderRecord renderRecordFromExr(const ExrAttributes& a, const std::string& path) {
    auto it = a.strings.find("cbdpt_method");
    if (it == a.strings.end())
        throw std::runtime_error(fmt::format(
            "{} has no cbdpt render record in its header (attribute cbdpt_method); render it "
            "again with this cbdpt",
            path));
    auto str = [&](const char* name) {
        auto s = a.strings.find(name);
        return s == a.strings.end() ? std::string() : s->second;
    };
    auto integer = [&](const char* name) {
        auto s = a.ints.find(name);
        if (s == a.ints.end())
            throw std::runtime_error(fmt::format(
                "{}: the header's render record lacks the int attribute {}", path, name));
        return s->second;
    };
    auto real = [&](const char* name) {
        auto s = a.doubles.find(name);
        if (s == a.doubles.end())
            throw std::runtime_error(fmt::format(
                "{}: the header's render record lacks the double attribute {}", path, name));
        return s->second;
    };
    RenderRecord r;
    r.method = it->second;
    r.weights = str("cbdpt_weights");
    r.sceneFile = str("cbdpt_scene");
    r.sceneHash = str("cbdpt_scene_hash");
    r.inputs = str("cbdpt_inputs");
    r.sampler = str("cbdpt_sampler");
    r.pixelBounds = str("cbdpt_pixel_bounds");
    r.strategy = str("cbdpt_strategy");
    r.maxComponentValue = str("cbdpt_max_component_value");
    r.eyeVertices = integer("cbdpt_eye_vertices");
    r.lightVertices = integer("cbdpt_light_vertices");
    // Absent from files written before the total-length cap was recorded: the caps alone.
    if (auto m = a.ints.find("cbdpt_max_vertices"); m != a.ints.end()) r.maxVertices = m->second;
    r.coherenceTile = integer("cbdpt_coherence_tile");
    r.rouletteVertex = integer("cbdpt_roulette_vertex");
    r.seed = std::uint32_t(integer("cbdpt_seed"));
    r.channels = integer("cbdpt_channels");
    r.width = integer("cbdpt_width");
    r.height = integer("cbdpt_height");
    r.estimates = integer("cbdpt_estimates");
    try {
        r.estimateSet = EstimateSet::parse(str("cbdpt_estimate_ranges"), "cbdpt_estimate_ranges");
    } catch (const std::invalid_argument& e) {
        throw std::runtime_error(fmt::format("{}: {}", path, e.what()));
    }
    if (long(r.estimateSet.count()) != r.estimates)
        throw std::runtime_error(
            fmt::format("{}: cbdpt_estimate_ranges {} holds {} estimates, cbdpt_estimates says {}",
                        path, r.estimateSet.toString(), r.estimateSet.count(), r.estimates));
    r.renderSeconds = real("cbdpt_render_seconds");
    r.renderCpuSeconds = real("cbdpt_render_cpu_seconds");
    return r;
}

RenderRecord renderRecordFromIdentity(const RenderIdentity& identity) {
    const nlohmann::json& s = identity.settings;
    RenderRecord r;
    r.method = s.value("integrator", "");
    r.eyeVertices = s.value("eye_vertices", 0);
    r.lightVertices = s.value("light_vertices", 0);
    r.maxVertices = s.value("max_vertices", 0);
    r.weights = s.value("weights", "");
    r.coherenceTile = s.value("coherence_tile", 0);
    r.rouletteVertex = s.value("roulette_vertex", 0);
    r.seed = s.value("seed", std::uint32_t(0));
    r.channels = s.value("channels", 0);
    r.sampler = recordedSampler(r.method, s.value("sampler", ""));
    if (s.contains("pixel_bounds"))
        r.pixelBounds = pixelBoundsText(s["pixel_bounds"].get<std::array<int, 4>>());
    if (const auto st = s.value("strategy", std::vector<int>{-1, -1}); st.size() == 2)
        r.strategy = strategyText(st[0], st[1]);
    r.maxComponentValue = s.value("max_component_value", "");
    r.sceneHash = identity.sceneHash;
    return r;
}

void writeRenderExr(const std::string& path, const EstimateAccumulator& accumulator,
                    RenderRecord record) {
    record.estimates = accumulator.estimates();
    record.estimateSet = accumulator.indices();
    record.width = accumulator.width();
    record.height = accumulator.height();
    const RgbImage mean = accumulator.mean(), error = accumulator.standardError();
    std::vector<ExrLayer> layers{{"", &mean}, {"stderr", &error}};
    std::array<RgbImage, 2> halfMean, halfError;
    if (accumulator.tracksHalves()) {
        for (int half = 0; half < 2; ++half) {
            halfMean[size_t(half)] = accumulator.halfMean(half);
            halfError[size_t(half)] = accumulator.halfStandardError(half);
        }
        layers.push_back({"half0", &halfMean[0]});
        layers.push_back({"half0.stderr", &halfError[0]});
        layers.push_back({"half1", &halfMean[1]});
        layers.push_back({"half1.stderr", &halfError[1]});
    }
    writeExr(path, layers, toExrAttributes(record));
}

} // namespace cb
