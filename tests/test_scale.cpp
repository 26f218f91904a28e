// Exact sums, estimate sets and the portable render state: merges of shards in any order give
// the bits of one render, and every truncation or byte flip of a state file is refused cleanly.
#include "image/accumulator.h"
#include "image/image.h"
#include "image/render_state.h"
#include "io/files.h"

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sys/resource.h>

namespace {

// Estimate `index` of a fake render: heavy-tailed values (fireflies), negative ones (RGB from
// spectra can be), zeros, tiny values, from a stream seeded by the index as the integrators' are.
std::vector<float> fakeEstimate(std::uint64_t index, int width, int height) {
    std::mt19937_64 rng(0x5eed + index);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::vector<float> v(size_t(3 * width * height));
    for (auto& x : v) {
        const double r = u(rng);
        x = r < 0.1    ? 0.f
            : r < 0.2  ? float(-u(rng) * 0.01)
            : r < 0.25 ? float(1e-30 * u(rng))
                       : float(std::pow(u(rng), -1.5) * 0.3); // heavy tail
    }
    return v;
}

cb::EstimateAccumulator render(std::uint64_t begin, std::uint64_t end, int w, int h,
                               bool halves = false) {
    cb::EstimateAccumulator acc(w, h);
    if (halves) acc.trackHalves();
    for (std::uint64_t i = begin; i < end; ++i)
        acc.add(i, fakeEstimate(i, w, h).data());
    return acc;
}

bool sameBits(const cb::RgbImage& a, const cb::RgbImage& b) {
    return a.rgb.size() == b.rgb.size() &&
           std::memcmp(a.rgb.data(), b.rgb.data(), a.rgb.size() * sizeof(float)) == 0;
}

cb::RenderIdentity identity(std::uint32_t seed = 1) {
    cb::RenderIdentity id;
    id.settings = {{"integrator", "pt"}, {"seed", seed}};
    id.sceneHash = "0123456789abcdef";
    return id;
}

} // namespace

TEST_CASE("exact sums: shards merged in any order equal one render bit for bit") {
    const int w = 7, h = 5;
    const auto whole = render(0, 40, w, h);
    CHECK(whole.estimates() == 40);
    // Shards of uneven sizes, merged in several orders and groupings.
    const std::vector<std::pair<int, int>> cuts = {{0, 3}, {3, 17}, {17, 18}, {18, 40}};
    std::vector<cb::EstimateAccumulator> shards;
    for (auto [a, b] : cuts)
        shards.push_back(render(std::uint64_t(a), std::uint64_t(b), w, h));
    std::vector<size_t> order = {0, 1, 2, 3};
    int orders = 0;
    do {
        cb::EstimateAccumulator merged(w, h);
        for (size_t i : order)
            merged.merge(shards[i]);
        CHECK(merged.indices() == whole.indices());
        CHECK(merged.sums() == whole.sums());
        CHECK(merged.squares() == whole.squares());
        CHECK(sameBits(merged.mean(), whole.mean()));
        CHECK(sameBits(merged.standardError(), whole.standardError()));
        ++orders;
    } while (std::next_permutation(order.begin(), order.end()));
    CHECK(orders == 24);
    // Estimates added in reverse order: the same bits too.
    cb::EstimateAccumulator reversed(w, h);
    for (std::uint64_t i = 40; i-- > 0;)
        reversed.add(i, fakeEstimate(i, w, h).data());
    CHECK(sameBits(reversed.mean(), whole.mean()));
    CHECK(sameBits(reversed.standardError(), whole.standardError()));
}

TEST_CASE("exact sums: mean and standard error agree with a double computation") {
    const int w = 3, h = 2;
    const auto acc = render(0, 25, w, h);
    const auto mean = acc.mean();
    const auto error = acc.standardError();
    for (size_t i = 0; i < mean.rgb.size(); ++i) {
        double sum = 0.0, sq = 0.0;
        for (std::uint64_t k = 0; k < 25; ++k) {
            const double x = fakeEstimate(k, w, h)[i];
            sum += x;
        }
        const double m = sum / 25.0;
        for (std::uint64_t k = 0; k < 25; ++k) {
            const double x = fakeEstimate(k, w, h)[i];
            sq += (x - m) * (x - m);
        }
        CHECK(mean.rgb[i] == doctest::Approx(m).epsilon(1e-6));
        CHECK(error.rgb[i] == doctest::Approx(std::sqrt(sq / 24.0 / 25.0)).epsilon(1e-5));
    }
    // Identical estimates: the variance is exactly zero (no cancellation), the mean exact.
    cb::EstimateAccumulator constant(1, 1);
    const float v[3] = {0.1f, 3.0e7f, -2.5f};
    for (std::uint64_t k = 0; k < 1000; ++k)
        constant.add(k, v);
    CHECK(constant.mean().rgb == std::vector<float>{0.1f, 3.0e7f, -2.5f});
    CHECK(constant.standardError().rgb == std::vector<float>{0.f, 0.f, 0.f});
    // A sample too large for the exact sums is dropped and counted, not wrapped around.
    const float huge[3] = {1e30f, 1.f, 1.f};
    constant.add(1000, huge);
    CHECK(constant.droppedSamples() == 1);
    CHECK(constant.mean().rgb[1] == doctest::Approx((3.0e7 * 1000 + 1) / 1001));
}

TEST_CASE("exact sums: overlapping estimates and other sizes are refused") {
    auto a = render(0, 5, 2, 2);
    auto b = render(4, 8, 2, 2);
    CHECK_THROWS_WITH_AS(a.merge(b), doctest::Contains("overlap"), std::invalid_argument);
    CHECK_THROWS_WITH_AS(a.merge(a), doctest::Contains("overlap"), std::invalid_argument);
    auto c = render(0, 1, 3, 2);
    CHECK_THROWS_WITH_AS(a.merge(c), doctest::Contains("2x2"), std::invalid_argument);
    CHECK_THROWS_AS(a.add(3, fakeEstimate(3, 2, 2).data()), std::invalid_argument);
    CHECK(a.estimates() == 5);
}

TEST_CASE("estimate sets: ranges, gaps and parsing") {
    cb::EstimateSet s;
    for (std::uint64_t i : {5, 3, 4, 10, 0})
        s.insert(i);
    CHECK(s.toString() == "0:1,3:6,10:11");
    CHECK(s.count() == 5);
    CHECK(s.contains(4));
    CHECK_FALSE(s.contains(6));
    CHECK(s.nextMissing(3) == 6);
    CHECK(s.nextMissing(7) == 7);
    CHECK(s.missingIn(0, 12, 100) == std::vector<std::uint64_t>{1, 2, 6, 7, 8, 9, 11});
    CHECK(s.intersects(cb::EstimateSet::range(9, 11)));
    CHECK_FALSE(s.intersects(cb::EstimateSet::range(6, 10)));
    CHECK(cb::parseEstimateRange("16:32") == cb::EstimateSet::Range{16, 32});
    CHECK_THROWS_WITH_AS(cb::parseEstimateRange("8:8"), doctest::Contains("empty"),
                         std::invalid_argument);
    CHECK_THROWS_WITH_AS(cb::parseEstimateRange("9:3"), doctest::Contains("empty"),
                         std::invalid_argument);
    for (const char* bad : {"", "5", "a:b", "-1:3", "3:", ":4", "1:2:3", "1.5:3"})
        CHECK_THROWS_AS(cb::parseEstimateRange(bad), std::invalid_argument);
    CHECK_THROWS_AS(cb::EstimateSet::fromRanges({{0, 4}, {4, 6}}), std::invalid_argument);
    CHECK_THROWS_AS(cb::EstimateSet::fromRanges({{3, 3}}), std::invalid_argument);
}

TEST_CASE("render state: round trip, little-endian layout, differences named") {
    const auto acc = render(2, 9, 4, 3);
    const std::string bytes = cb::encodeRenderState(identity(), acc);
    CHECK(bytes.compare(0, 19, "cbdpt render state\n") == 0);
    CHECK(bytes[19] == 3); // version 3, little-endian u32
    CHECK(bytes[20] == 0);
    const cb::RenderState back = cb::decodeRenderState(bytes, "x.state");
    CHECK(back.accumulator.indices().toString() == "2:9");
    CHECK(back.accumulator.sums() == acc.sums());
    CHECK(back.accumulator.squares() == acc.squares());
    CHECK(back.identity.settings == identity().settings);
    CHECK(cb::identityDifferences(back.identity, identity()).empty());
    auto other = identity(7);
    other.sceneHash = "fedcba9876543210";
    const auto diff = cb::identityDifferences(back.identity, other);
    REQUIRE(diff.size() == 2);
    CHECK(diff[0].find("scene content") != std::string::npos);
    CHECK(diff[1] == "seed: 1 there, 7 here");
    // The first sample sum's low word sits right after the value count, little-endian.
    const size_t headerBytes = size_t(std::uint8_t(bytes[23])) | size_t(std::uint8_t(bytes[24]))
                                                                     << 8;
    const size_t first = 19 + 4 + 8 + headerBytes + 8;
    std::uint64_t low = 0;
    for (int b = 0; b < 8; ++b)
        low |= std::uint64_t(std::uint8_t(bytes[first + size_t(b)])) << (8 * b);
    CHECK(low == acc.sums()[0].word[0]);
}

TEST_CASE("render state: every truncation and random byte flips are refused with a message") {
    bool halves = false;
    SUBCASE("without halves") {}
    SUBCASE("with the halves' sums") {
        halves = true;
    }
    const auto acc = render(0, 3, 2, 1, halves);
    const std::string bytes = cb::encodeRenderState(identity(), acc);
    const cb::RenderState back = cb::decodeRenderState(bytes, "h.state");
    CHECK(back.accumulator.tracksHalves() == halves);
    CHECK(back.accumulator.oddSums() == acc.oddSums());
    CHECK(back.accumulator.oddSquares() == acc.oddSquares());
    for (size_t n = 0; n < bytes.size(); ++n) {
        CAPTURE(n);
        try {
            cb::decodeRenderState(bytes.substr(0, n), "t.state");
            FAIL("a truncated state was accepted");
        } catch (const std::runtime_error& e) {
            const std::string what = e.what();
            CHECK(what.find("t.state is not a usable render state") == 0);
        }
    }
    std::mt19937 rng(3);
    for (int trial = 0; trial < 3000; ++trial) {
        std::string bad = bytes;
        const int flips = 1 + trial % 4;
        for (int f = 0; f < flips; ++f)
            bad[rng() % bad.size()] ^= char(1 + rng() % 255);
        CAPTURE(trial);
        try {
            cb::decodeRenderState(bad, "f.state");
            FAIL("a corrupted state was accepted");
        } catch (const std::runtime_error& e) {
            CHECK(std::string(e.what()).find("f.state is not a usable render state") == 0);
        }
    }
    // Extra bytes, another version, the old machine-order format.
    CHECK_THROWS_WITH_AS(cb::decodeRenderState(bytes + "x", "e.state"),
                         doctest::Contains("truncated or corrupted"), std::runtime_error);
    std::string v2 = bytes;
    v2[19] = 2;
    CHECK_THROWS_WITH_AS(cb::decodeRenderState(v2, "v.state"),
                         doctest::Contains("format version 2, this cbdpt reads version 3"),
                         std::runtime_error);
    CHECK_THROWS_WITH_AS(cb::decodeRenderState("cbdpt render state v1\n....", "o.state"),
                         doctest::Contains("format version 1"), std::runtime_error);
}

TEST_CASE("render state: estimate indices past the random streams' 2^32 are refused") {
    // A state whose checksum holds but whose ranges reach past 2^32 (whose count would not fit
    // a long at 2^63): such indices would repeat the estimates of index mod 2^32.
    for (const std::uint64_t end :
         {cb::kEstimateIndexEnd + 1, std::uint64_t(1) << 63, ~std::uint64_t(0)}) {
        CAPTURE(end);
        auto acc = render(0, 2, 2, 1);
        acc.setIndices(cb::EstimateSet::fromRanges({{0, 1}, {end - 1, end}}));
        CHECK_THROWS_WITH_AS(cb::decodeRenderState(cb::encodeRenderState(identity(), acc), "b"),
                             doctest::Contains("past the 4294967296 indices"), std::runtime_error);
    }
    auto acc = render(0, 2, 2, 1);
    acc.setIndices(
        cb::EstimateSet::fromRanges({{0, 1}, {cb::kEstimateIndexEnd - 1, cb::kEstimateIndexEnd}}));
    CHECK(cb::decodeRenderState(cb::encodeRenderState(identity(), acc), "b")
              .accumulator.indices()
              .toString() == "0:1,4294967295:4294967296");
}

TEST_CASE("render state: resume refuses another render, saving is atomic") {
    const auto dir = std::filesystem::temp_directory_path();
    const std::string path = (dir / "cbdpt_test_scale.state").string();
    const auto acc = render(0, 4, 2, 2);
    cb::saveRenderState(path, identity(), acc);
    cb::EstimateAccumulator resumed(2, 2);
    cb::resumeRenderState(path, identity(), resumed);
    CHECK(resumed.estimates() == 4);
    CHECK(sameBits(resumed.mean(), acc.mean()));
    cb::EstimateAccumulator other(2, 2);
    CHECK_THROWS_WITH_AS(cb::resumeRenderState(path, identity(9), other),
                         doctest::Contains("different render:\n  seed: 1 there, 9 here"),
                         std::runtime_error);
    cb::EstimateAccumulator bigger(3, 2);
    CHECK_THROWS_WITH_AS(cb::resumeRenderState(path, identity(), bigger),
                         doctest::Contains("2x2 image, this render is 3x2"), std::runtime_error);
    std::filesystem::remove(path);
    CHECK_THROWS_WITH_AS(cb::resumeRenderState(path, identity(), other),
                         doctest::Contains("no saved state"), std::runtime_error);
}

namespace {

// Writes in its scope fail past `bytes` (RLIMIT_FSIZE, EFBIG; SIGXFSZ ignored): a disk that fills
// up, without needing root to mount a small one.
class FileSizeLimit {
  public:
    explicit FileSizeLimit(rlim_t bytes) {
        getrlimit(RLIMIT_FSIZE, &saved_);
        previousHandler_ = std::signal(SIGXFSZ, SIG_IGN);
        rlimit limit = saved_;
        limit.rlim_cur = bytes;
        setrlimit(RLIMIT_FSIZE, &limit);
    }
    ~FileSizeLimit() {
        setrlimit(RLIMIT_FSIZE, &saved_);
        std::signal(SIGXFSZ, previousHandler_);
    }
    FileSizeLimit(const FileSizeLimit&) = delete;
    FileSizeLimit& operator=(const FileSizeLimit&) = delete;

  private:
    rlimit saved_{};
    void (*previousHandler_)(int) = SIG_DFL;
};

// Nothing at `path` and no temporary file beside it.
bool leftNothing(const std::filesystem::path& folder) {
    return std::filesystem::is_empty(folder);
}

} // namespace

TEST_CASE("a write that fails at the end is reported and leaves no file") {
    // 3000 bytes stay in the stream's buffer until it is flushed or closed, where a full disk
    // answers: an empty state had been renamed into place as if written (exit 0).
    const auto folder = std::filesystem::temp_directory_path() / "cbdpt_test_full_disk";
    std::filesystem::remove_all(folder);
    std::filesystem::create_directories(folder);
    const std::string state = (folder / "r.exr.state").string();
    const auto acc = render(0, 3, 8, 8, true);
    {
        FileSizeLimit limit(1000);
        CHECK_THROWS_WITH_AS(
            cb::writeFileAtomically((folder / "s.json").string(), std::string(3000, 'x')),
            doctest::Contains("cannot write"), std::runtime_error);
        CHECK_THROWS_WITH_AS(cb::saveRenderState(state, identity(), acc),
                             doctest::Contains(("cannot write " + state).c_str()),
                             std::runtime_error);
        CHECK_THROWS_WITH_AS(cb::writeExr((folder / "r.exr").string(), render(0, 1, 32, 32).mean()),
                             doctest::Contains("cannot write"), std::runtime_error);
    }
    CHECK(leftNothing(folder));
    // Under the limit the same writes succeed.
    cb::writeFileAtomically((folder / "s.json").string(), std::string(3000, 'x'));
    cb::saveRenderState(state, identity(), acc);
    CHECK(std::filesystem::file_size(folder / "s.json") == 3000);
    cb::EstimateAccumulator resumed(8, 8);
    cb::resumeRenderState(state, identity(), resumed);
    CHECK(resumed.estimates() == 3);
    std::filesystem::remove_all(folder);
}

TEST_CASE("scene content hash: bytes, not names") {
    const auto dir = std::filesystem::temp_directory_path();
    const std::string a = (dir / "cbdpt_hash_a.pbrt").string();
    const std::string b = (dir / "cbdpt_hash_b.pbrt").string();
    std::ofstream(a) << "WorldBegin\n";
    std::ofstream(b) << "WorldBegin\n";
    CHECK(cb::sceneContentHash({a}) == cb::sceneContentHash({b}));
    std::ofstream(b) << "WorldBegin \n";
    CHECK(cb::sceneContentHash({a}) != cb::sceneContentHash({b}));
    // Moving a byte between files changes the hash.
    CHECK(cb::sceneContentHash({a, b}) != cb::sceneContentHash({b, a}));
    CHECK_THROWS_WITH_AS(cb::sceneContentHash({(dir / "cbdpt_no_such.ply").string()}),
                         doctest::Contains("cbdpt_no_such.ply"), std::runtime_error);
    std::filesystem::remove(a);
    std::filesystem::remove(b);
}

namespace {

// The state's checksum as docs/scale-out.md states it, written out here independently: FNV-1a
// over 64-bit little-endian words (the tail zero-padded), then the byte count.
std::uint64_t documentedChecksum(const std::string& bytes) {
    const std::uint64_t prime = 0x100000001b3ull;
    std::uint64_t h = 0xcbf29ce484222325ull;
    for (size_t i = 0; i < bytes.size(); i += 8) {
        std::uint64_t w = 0;
        for (size_t b = 0; b < 8 && i + b < bytes.size(); ++b)
            w |= std::uint64_t(std::uint8_t(bytes[i + b])) << (8 * b);
        h = (h ^ w) * prime;
    }
    if (bytes.size() % 8 == 0) h = (h ^ 0) * prime; // an empty tail still takes a step
    return (h ^ std::uint64_t(bytes.size())) * prime;
}

// A state with its header replaced by `header` and a valid checksum: what a writer with another
// idea of the format (or a bug) would produce, past the checksum and down to the validation.
std::string resealed(const std::string& state, const std::string& header) {
    const size_t fixed = 19 + 4;
    std::uint64_t oldLength = 0;
    for (size_t b = 0; b < 8; ++b)
        oldLength |= std::uint64_t(std::uint8_t(state[fixed + b])) << (8 * b);
    std::string out = state.substr(0, fixed);
    for (size_t b = 0; b < 8; ++b)
        out.push_back(char((header.size() >> (8 * b)) & 0xff));
    out += header;
    out += state.substr(fixed + 8 + size_t(oldLength), state.size() - 8 - fixed - 8 - oldLength);
    const std::uint64_t sum = documentedChecksum(out);
    for (size_t b = 0; b < 8; ++b)
        out.push_back(char((sum >> (8 * b)) & 0xff));
    return out;
}

std::string headerOf(const std::string& state) {
    std::uint64_t length = 0;
    for (size_t b = 0; b < 8; ++b)
        length |= std::uint64_t(std::uint8_t(state[23 + b])) << (8 * b);
    return state.substr(31, size_t(length));
}

} // namespace

TEST_CASE("render state: a sealed header that contradicts the sums is refused") {
    const auto acc = render(0, 5, 3, 2, true);
    const std::string bytes = cb::encodeRenderState(identity(), acc);
    const auto header = nlohmann::json::parse(headerOf(bytes));
    // The documented checksum seals the file as written, and resealing an unchanged header
    // gives a state that loads.
    CHECK(resealed(bytes, header.dump()) == bytes);
    auto refusal = [&](const std::string& key, const nlohmann::json& value) {
        auto changed = header;
        changed[key] = value;
        try {
            cb::decodeRenderState(resealed(bytes, changed.dump()), "s.state");
        } catch (const std::runtime_error& e) {
            return std::string(e.what());
        }
        return std::string("accepted");
    };
    CHECK(refusal("width", 2).find("image size 2x2 does not match its 18 values") !=
          std::string::npos);
    CHECK(refusal("fraction_bits", 111).find("another fixed-point layout") != std::string::npos);
    CHECK(refusal("sample_sum_words", 4).find("another fixed-point layout") != std::string::npos);
    CHECK(refusal("estimates", 6).find("estimate count does not match") != std::string::npos);
    CHECK(refusal("estimate_ranges", nlohmann::json::array({{0, 3}, {3, 5}}))
              .find("not sorted and apart") != std::string::npos);
}

TEST_CASE("render state: settings set on one side only are differences") {
    cb::RenderIdentity saved = identity(), here = identity();
    here.settings["sampler"] = "independent";
    const auto added = cb::identityDifferences(saved, here);
    REQUIRE(added.size() == 1);
    CHECK(added[0] == "sampler: not set there, \"independent\" here");
    const auto removed = cb::identityDifferences(here, saved);
    REQUIRE(removed.size() == 1);
    CHECK(removed[0] == "sampler: \"independent\" there, not set here");
}

TEST_CASE("scene content hash: the same bytes split between files differently differ") {
    const auto dir = std::filesystem::temp_directory_path();
    const std::string files[4] = {
        (dir / "cbdpt_split_1.pbrt").string(), (dir / "cbdpt_split_2.pbrt").string(),
        (dir / "cbdpt_split_3.pbrt").string(), (dir / "cbdpt_split_4.pbrt").string()};
    std::ofstream(files[0]) << "Shape \"sphere\"";
    std::ofstream(files[1]) << "\n";
    std::ofstream(files[2]) << "Shape \"sphere\"\n";
    std::ofstream(files[3]) << "";
    // "Shape \"sphere\"" + "\n" and "Shape \"sphere\"\n" + "" concatenate to the same bytes.
    CHECK(cb::sceneContentHash({files[0], files[1]}) != cb::sceneContentHash({files[2], files[3]}));
    for (const auto& f : files)
        std::filesystem::remove(f);
}

TEST_CASE("exact sums: limits, rounding to the grid and images split among threads") {
    cb::EstimateSet s = cb::EstimateSet::fromRanges({{0, 1}, {3, 6}, {10, 11}});
    CHECK(s.missingIn(0, 12, 3) == std::vector<std::uint64_t>{1, 2, 6});
    CHECK(s.missingIn(0, 12, 0).empty());
    // A sample below the grid's unit is rounded to the nearest grid point (ties away from zero):
    // 0.75 and 0.5 units give 1, 0.25 gives 0, in either sign.
    const double unit = std::ldexp(1.0, -cb::kFixedPointFractionBits);
    for (double units : {0.75, 0.5, -0.75}) {
        CAPTURE(units);
        cb::SampleSum sum;
        sum.addScaled(units * unit);
        CHECK(sum.toDouble() == (units < 0 ? -1.0 : 1.0));
    }
    cb::SampleSum quarter;
    quarter.addScaled(0.25 * unit);
    CHECK(quarter.toDouble() == 0.0);
    // 160 x 150 pixels (72000 values) are added in parts by several threads where there are
    // cores: every value, each part's first and last included, gets its sample.
    const int w = 160, h = 150;
    const auto acc = render(0, 3, w, h);
    const auto mean = acc.mean();
    std::vector<std::vector<float>> estimates;
    for (std::uint64_t k = 0; k < 3; ++k)
        estimates.push_back(fakeEstimate(k, w, h));
    size_t wrong = 0;
    for (size_t i = 0; i < mean.rgb.size(); ++i) {
        const double expected =
            (double(estimates[0][i]) + double(estimates[1][i]) + double(estimates[2][i])) / 3.0;
        if (!(std::fabs(mean.rgb[i] - expected) <= 1e-6 * std::fabs(expected) + 1e-30)) ++wrong;
    }
    CHECK(wrong == 0);
}
