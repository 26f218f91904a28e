#include "image/render_state.h"

#include "cl/embedded_kernels.h"
#include "io/files.h"

#include <fmt/format.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <utility>

namespace cb {

namespace {
// Layout (docs/scale-out.md): the magic line, the format version (u32), the header length
// (u64) and the header (JSON text), the number of values (u64, 3 per pixel), each value's
// sample sum (3 words) then each value's square sum (4 words), when the header's "halves" is
// true the same two arrays over the odd estimate indices only, and the checksum (u64) of all
// bytes before it. Every integer is little-endian whatever the machine.
const char kMagic[] = "cbdpt render state\n";
const char kVersion1Magic[] = "cbdpt render state v1\n";
constexpr size_t kMagicBytes = sizeof kMagic - 1;
constexpr std::uint64_t kFnvOffset = 0xcbf29ce484222325ull, kFnvPrime = 0x100000001b3ull;

void putU64(std::string& out, std::uint64_t v) {
    for (int i = 0; i < 8; ++i)
        out.push_back(char((v >> (8 * i)) & 0xff));
}
std::uint64_t getU64(const std::string& in, size_t pos) {
    std::uint64_t v = 0;
    for (int i = 0; i < 8; ++i)
        v |= std::uint64_t(std::uint8_t(in[pos + size_t(i)])) << (8 * i);
    return v;
}

// FNV-1a over 64-bit little-endian words (the tail zero-padded), then the length: every step
// is a bijection of the running hash, so any change to a single word is always detected.
std::uint64_t checksum(const char* data, size_t size) {
    std::uint64_t h = kFnvOffset;
    size_t i = 0;
    for (; i + 8 <= size; i += 8) {
        std::uint64_t w = 0;
        for (int b = 0; b < 8; ++b)
            w |= std::uint64_t(std::uint8_t(data[i + size_t(b)])) << (8 * b);
        h = (h ^ w) * kFnvPrime;
    }
    std::uint64_t tail = 0;
    for (int b = 0; i + size_t(b) < size; ++b)
        tail |= std::uint64_t(std::uint8_t(data[i + size_t(b)])) << (8 * b);
    h = (h ^ tail) * kFnvPrime;
    return (h ^ std::uint64_t(size)) * kFnvPrime;
}

std::uint64_t fnv1a(std::uint64_t h, const std::string& bytes) {
    for (char c : bytes)
        h = (h ^ std::uint8_t(c)) * kFnvPrime;
    return h;
}

} // namespace

std::string renderStatePath(const std::string& exrPath) {
    return exrPath + ".state";
}

std::string sceneContentHash(const std::vector<std::string>& files) {
    std::uint64_t h = kFnvOffset;
    for (const auto& file : files) {
        const std::string bytes = readWholeFile(file, "scene file");
        h = fnv1a(h, bytes);
        h = (h ^ std::uint64_t(bytes.size())) * kFnvPrime; // file boundaries count
    }
    return fmt::format("{:016x}", h);
}

std::string kernelSourceHash() {
    std::uint64_t h = kFnvOffset;
    for (const auto& [name, source] : kernelSources()) {
        // The first line is a #line directive naming where the file was built: left out.
        const auto firstLine = source.find('\n');
        h = fnv1a(h, name);
        h = fnv1a(h, firstLine == std::string::npos ? source : source.substr(firstLine));
    }
    // Extra build options change the kernels as much as their sources (cl_runtime.cpp).
    if (const char* extra = std::getenv("CBDPT_KERNEL_OPTIONS"); extra && *extra)
        h = fnv1a(h, std::string("options ") + extra);
    return fmt::format("{:016x}", h);
}

std::vector<std::string> identityDifferences(const RenderIdentity& saved,
                                             const RenderIdentity& here) {
    std::vector<std::string> out;
    if (saved.sceneHash != here.sceneHash)
        out.push_back(fmt::format("scene content (the scene file, its Includes and meshes) hash "
                                  "{} there, {} here",
                                  saved.sceneHash, here.sceneHash));
    for (const auto& [key, value] : saved.settings.items()) {
        if (!here.settings.contains(key))
            out.push_back(fmt::format("{}: {} there, not set here", key, value.dump()));
        else if (here.settings[key] != value)
            out.push_back(
                fmt::format("{}: {} there, {} here", key, value.dump(), here.settings[key].dump()));
    }
    for (const auto& [key, value] : here.settings.items())
        if (!saved.settings.contains(key))
            out.push_back(fmt::format("{}: not set there, {} here", key, value.dump()));
    return out;
}

std::string encodeRenderState(const RenderIdentity& identity,
                              const EstimateAccumulator& accumulator) {
    nlohmann::json ranges = nlohmann::json::array();
    for (const auto& [begin, end] : accumulator.indices().ranges())
        ranges.push_back({begin, end});
    const nlohmann::json header = {{"settings", identity.settings},
                                   {"scene_hash", identity.sceneHash},
                                   {"width", accumulator.width()},
                                   {"height", accumulator.height()},
                                   {"estimate_ranges", ranges},
                                   {"estimates", accumulator.estimates()},
                                   {"dropped_samples", accumulator.droppedSamples()},
                                   {"halves", accumulator.tracksHalves()},
                                   {"fraction_bits", kFixedPointFractionBits},
                                   {"sample_sum_words", SampleSum{}.word.size()},
                                   {"square_sum_words", SquareSum{}.word.size()}};
    const std::string headerText = header.dump();
    const size_t values = accumulator.values();
    std::string out;
    const size_t arrays = accumulator.tracksHalves() ? 2 : 1;
    out.reserve(kMagicBytes + 4 + 8 + headerText.size() + 8 + arrays * values * 56 + 8);
    out += kMagic;
    for (int i = 0; i < 4; ++i)
        out.push_back(char((kRenderStateVersion >> (8 * i)) & 0xff));
    putU64(out, headerText.size());
    out += headerText;
    putU64(out, values);
    for (size_t i = 0; i < values; ++i)
        for (auto w : accumulator.sumAt(i).word)
            putU64(out, w);
    for (size_t i = 0; i < values; ++i)
        for (auto w : accumulator.squareAt(i).word)
            putU64(out, w);
    for (const auto& s : accumulator.oddSums())
        for (auto w : s.word)
            putU64(out, w);
    for (const auto& s : accumulator.oddSquares())
        for (auto w : s.word)
            putU64(out, w);
    putU64(out, checksum(out.data(), out.size()));
    return out;
}

void saveRenderState(const std::string& path, const RenderIdentity& identity,
                     const EstimateAccumulator& accumulator) {
    writeFileAtomically(path, encodeRenderState(identity, accumulator));
}

RenderState decodeRenderState(const std::string& bytes, const std::string& path) {
    auto fail = [&](const std::string& why) {
        return std::runtime_error(fmt::format("{} is not a usable render state: {}", path, why));
    };
    if (bytes.compare(0, sizeof kVersion1Magic - 1, kVersion1Magic) == 0)
        throw fail(fmt::format("it was written by an older cbdpt in format version 1 (machine "
                               "byte order, no checksum); this cbdpt reads version {}: render "
                               "it again",
                               kRenderStateVersion));
    if (bytes.size() < kMagicBytes || bytes.compare(0, kMagicBytes, kMagic) != 0)
        throw fail("it does not start with the line \"cbdpt render state\"");
    size_t pos = kMagicBytes;
    const size_t fixed = kMagicBytes + 4 + 8;
    if (bytes.size() < fixed) throw fail(fmt::format("truncated at {} bytes", bytes.size()));
    std::uint32_t version = 0;
    for (int i = 0; i < 4; ++i)
        version |= std::uint32_t(std::uint8_t(bytes[pos + size_t(i)])) << (8 * i);
    pos += 4;
    if (version != kRenderStateVersion)
        throw fail(fmt::format("it is format version {}, this cbdpt reads version {}", version,
                               kRenderStateVersion));
    const std::uint64_t headerBytes = getU64(bytes, pos);
    pos += 8;
    if (headerBytes > bytes.size() - pos || bytes.size() - pos - headerBytes < 8)
        throw fail(fmt::format("truncated or corrupted: its header length {} runs past the end "
                               "of its {} bytes",
                               headerBytes, bytes.size()));
    const size_t headerPos = pos;
    pos += size_t(headerBytes);
    const std::uint64_t values = getU64(bytes, pos);
    pos += 8;
    // Whether the halves' arrays follow (a header that does not parse is reported below, after
    // the checksum says whether the file is corrupted).
    bool halves = false;
    std::string headerError;
    try {
        halves = nlohmann::json::parse(bytes.substr(headerPos, size_t(headerBytes)))
                     .at("halves")
                     .get<bool>();
    } catch (const nlohmann::json::exception& e) {
        headerError = e.what();
    }
    const std::uint64_t wordsPerValue =
        (halves ? 2 : 1) * (SampleSum{}.word.size() + SquareSum{}.word.size());
    const std::uint64_t remaining = bytes.size() - pos;
    if (values > remaining / (8 * wordsPerValue) || values * 8 * wordsPerValue + 8 != remaining)
        throw fail(fmt::format("truncated or corrupted: {} bytes where its {} values need {}",
                               bytes.size(), values, pos + values * 8 * wordsPerValue + 8));
    const size_t checksumPos = bytes.size() - 8;
    if (getU64(bytes, checksumPos) != checksum(bytes.data(), checksumPos))
        throw fail("corrupted: the checksum does not match its contents");
    if (!headerError.empty())
        throw fail(fmt::format("its header is not what this cbdpt writes ({})", headerError));

    RenderState state;
    nlohmann::json header;
    try {
        header = nlohmann::json::parse(bytes.substr(headerPos, size_t(headerBytes)));
        state.identity.settings = header.at("settings");
        state.identity.sceneHash = header.at("scene_hash").get<std::string>();
        const int width = header.at("width").get<int>();
        const int height = header.at("height").get<int>();
        if (width <= 0 || height <= 0 || std::uint64_t(width) * std::uint64_t(height) * 3 != values)
            throw fail(fmt::format("its image size {}x{} does not match its {} values", width,
                                   height, values));
        if (header.at("fraction_bits").get<int>() != kFixedPointFractionBits ||
            header.at("sample_sum_words").get<size_t>() != SampleSum{}.word.size() ||
            header.at("square_sum_words").get<size_t>() != SquareSum{}.word.size())
            throw fail("its sums use another fixed-point layout");
        std::vector<EstimateSet::Range> ranges;
        for (const auto& r : header.at("estimate_ranges"))
            ranges.emplace_back(r.at(0).get<std::uint64_t>(), r.at(1).get<std::uint64_t>());
        EstimateSet indices = EstimateSet::fromRanges(std::move(ranges));
        if (!indices.ranges().empty() && indices.ranges().back().second > kEstimateIndexEnd)
            throw fail(fmt::format("its estimate ranges end at {}, past the {} indices that seed "
                                   "the random streams",
                                   indices.ranges().back().second, kEstimateIndexEnd));
        if (indices.count() != header.at("estimates").get<std::uint64_t>())
            throw fail("its estimate count does not match its estimate ranges");
        state.accumulator = EstimateAccumulator(width, height);
        if (halves) state.accumulator.trackHalves();
        state.accumulator.setIndices(std::move(indices));
        state.accumulator.setDroppedSamples(header.at("dropped_samples").get<long>());
    } catch (const nlohmann::json::exception& e) {
        throw fail(fmt::format("its header is not what this cbdpt writes ({})", e.what()));
    } catch (const std::invalid_argument& e) {
        throw fail(e.what());
    }
    // The file holds the full sums and the odd indices' (the layout before the accumulator
    // kept its halves apart, so older states load unchanged).
    auto read = [&](auto& sums, size_t count) {
        sums.resize(count);
        for (auto& s : sums)
            for (auto& w : s.word) {
                w = getU64(bytes, pos);
                pos += 8;
            }
    };
    const size_t odd = state.accumulator.tracksHalves() ? values : 0;
    std::vector<SampleSum> sums, oddSums;
    std::vector<SquareSum> squares, oddSquares;
    read(sums, values);
    read(squares, values);
    read(oddSums, odd);
    read(oddSquares, odd);
    state.accumulator.setSums(std::move(sums), std::move(squares), std::move(oddSums),
                              std::move(oddSquares));
    return state;
}

RenderState loadRenderState(const std::string& path) {
    return decodeRenderState(readWholeFile(path, "the render state"), path);
}

void resumeRenderState(const std::string& path, const RenderIdentity& identity,
                       EstimateAccumulator& accumulator) {
    std::error_code ec;
    if (!std::filesystem::exists(path, ec))
        throw std::runtime_error(fmt::format(
            "--resume: no saved state at {} (it is written periodically, when a render is "
            "interrupted, and with --keep-state)",
            path));
    RenderState state = loadRenderState(path);
    const auto differences = identityDifferences(state.identity, identity);
    if (!differences.empty()) {
        std::string list;
        for (const auto& d : differences)
            list += "\n  " + d;
        throw std::runtime_error(
            fmt::format("--resume: {} was made by a different render:{}", path, list));
    }
    if (state.accumulator.width() != accumulator.width() ||
        state.accumulator.height() != accumulator.height())
        throw std::runtime_error(
            fmt::format("--resume: {} holds a {}x{} image, this render is {}x{}", path,
                        state.accumulator.width(), state.accumulator.height(), accumulator.width(),
                        accumulator.height()));
    accumulator = std::move(state.accumulator);
}

} // namespace cb
