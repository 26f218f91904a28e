#include "image/render_state.h"

#include <array>
#include <cstdint>
#include <cstring>
#include <fmt/format.h>
#include <fstream>
#include <iterator>
#include <sstream>
#include <stdexcept>

namespace cb {

namespace {
// Format: the magic line, a 64-bit settings length and the settings text, then the estimate
// count, width and height as 64-bit integers and the mean and M2 arrays as doubles, all in
// the machine's byte order (the file is meant for the machine that wrote it). Version 2 adds
// the two halves of the estimates (EstimateAccumulator::trackHalves): per half its count, mean
// and M2 arrays.
const char kMagic[] = "cbdpt render state v1\n";
const char kMagicHalves[] = "cbdpt render state v2\n";

template <typename T> void put(std::string& out, const T& v) {
    out.append(reinterpret_cast<const char*>(&v), sizeof v);
}
} // namespace

std::string renderStatePath(const std::string& exrPath) {
    return exrPath + ".state";
}

void saveRenderState(const std::string& path, const std::string& settings,
                     const EstimateAccumulator& accumulator) {
    std::string out(accumulator.tracksHalves() ? kMagicHalves : kMagic);
    put(out, std::uint64_t(settings.size()));
    out += settings;
    put(out, std::int64_t(accumulator.estimates()));
    put(out, std::int64_t(accumulator.width()));
    put(out, std::int64_t(accumulator.height()));
    for (double v : accumulator.meanData())
        put(out, v);
    for (double v : accumulator.m2Data())
        put(out, v);
    if (accumulator.tracksHalves())
        for (int half = 0; half < 2; ++half) {
            put(out, std::int64_t(accumulator.halfEstimates(half)));
            for (double v : accumulator.halfMeanData(half))
                put(out, v);
            for (double v : accumulator.halfM2Data(half))
                put(out, v);
        }
    writeFileAtomically(path, out);
}

void loadRenderState(const std::string& path, const std::string& settings,
                     EstimateAccumulator& accumulator) {
    std::ifstream in(path, std::ios::binary);
    if (!in)
        throw std::runtime_error(fmt::format(
            "--resume: no saved state at {} (it is written when a render is interrupted)", path));
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    size_t pos = 0;
    auto fail = [&](const std::string& why) {
        return std::runtime_error(
            fmt::format("--resume: {} is not a usable render state: {}", path, why));
    };
    auto take = [&](void* dst, size_t n) {
        if (bytes.size() - pos < n) throw fail("the file is truncated");
        std::memcpy(dst, bytes.data() + pos, n);
        pos += n;
    };
    const bool halves = bytes.compare(0, sizeof kMagicHalves - 1, kMagicHalves) == 0;
    if (!halves && bytes.compare(0, sizeof kMagic - 1, kMagic) != 0) throw fail("wrong magic line");
    pos = sizeof kMagic - 1;
    std::uint64_t length = 0;
    take(&length, sizeof length);
    if (length > bytes.size() - pos) throw fail("the file is truncated");
    std::string saved = bytes.substr(pos, length);
    pos += length;
    if (saved != settings)
        throw std::runtime_error(
            fmt::format("--resume: {} was made by a different render; saved: {}; now: {}", path,
                        saved, settings));
    std::int64_t count = 0, width = 0, height = 0;
    take(&count, sizeof count);
    take(&width, sizeof width);
    take(&height, sizeof height);
    if (width != accumulator.width() || height != accumulator.height() || count < 0)
        throw fail(fmt::format("it holds a {}x{} image, this render is {}x{}", width, height,
                               accumulator.width(), accumulator.height()));
    const size_t n = accumulator.meanData().size();
    std::vector<double> mean(n), m2(n);
    take(mean.data(), n * sizeof(double));
    take(m2.data(), n * sizeof(double));
    std::array<std::int64_t, 2> halfCount{0, 0};
    std::array<std::vector<double>, 2> halfMean, halfM2;
    for (int half = 0; halves && half < 2; ++half) {
        take(&halfCount[size_t(half)], sizeof(std::int64_t));
        if (halfCount[size_t(half)] < 0) throw fail("negative estimate count of a half");
        halfMean[size_t(half)].resize(n);
        halfM2[size_t(half)].resize(n);
        take(halfMean[size_t(half)].data(), n * sizeof(double));
        take(halfM2[size_t(half)].data(), n * sizeof(double));
    }
    if (pos != bytes.size()) throw fail("trailing bytes");
    if (halves && halfCount[0] + halfCount[1] != count)
        throw fail(fmt::format("its halves hold {} + {} estimates, not {}", halfCount[0],
                               halfCount[1], count));
    accumulator.restore(long(count), std::move(mean), std::move(m2));
    if (!halves) accumulator.dropHalves();
    for (int half = 0; halves && half < 2; ++half)
        accumulator.restoreHalf(half, long(halfCount[size_t(half)]),
                                std::move(halfMean[size_t(half)]), std::move(halfM2[size_t(half)]));
}

} // namespace cb
