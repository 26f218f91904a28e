// Exact per-pixel sums of estimates, and the set of estimate indices they hold.
//
// Each sample (a float) and its square are added to fixed-point integers on a grid of 2^-112:
// integer addition is associative, so the sums of estimates rendered in any order, in any number
// of shards, processes or machines, merged in any order, are the same bits, and so are the
// image and the standard error computed from them (docs/scale-out.md).
#pragma once

#include "image/image.h"

#include <array>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace cb {

// A fixed-point number: `Words` 64-bit words, little-endian, two's complement, in units of
// 2^-kFixedPointFractionBits.
constexpr int kFixedPointFractionBits = 112;
template <int Words> struct FixedPoint {
    std::array<std::uint64_t, Words> word{};
    // this += value * 2^kFixedPointFractionBits rounded to an integer (deterministically, so
    // the same sample always adds the same bits). |value| must be below 2^(64 Words - 113).
    void addScaled(double value);
    void add(const FixedPoint& other);
    void subtract(const FixedPoint& other);
    bool negative() const { return (word[Words - 1] >> 63) != 0; }
    // The value in units of the grid (not scaled back), rounded to double.
    double toDouble() const;
    bool operator==(const FixedPoint&) const = default;
};
using SampleSum = FixedPoint<3>; // up to 2^79 in magnitude: samples below 2^48, 2^31 of them
using SquareSum = FixedPoint<4>; // up to 2^143: squares below 2^96, 2^47 of them
constexpr double kLargestSample = 281474976710656.0; // 2^48: larger samples are refused

// Estimate indices seed 32-bit random streams: an index past them would repeat an estimate.
constexpr std::uint64_t kEstimateIndexEnd = std::uint64_t(1) << 32;

// A set of estimate indices as sorted, disjoint, non-adjacent half-open ranges [begin, end).
class EstimateSet {
  public:
    using Range = std::pair<std::uint64_t, std::uint64_t>;
    EstimateSet() = default;
    static EstimateSet range(std::uint64_t begin, std::uint64_t end);
    // Throws std::invalid_argument if the ranges are not sorted, disjoint and non-empty.
    static EstimateSet fromRanges(std::vector<Range> ranges);
    const std::vector<Range>& ranges() const { return ranges_; }
    std::uint64_t count() const;
    bool empty() const { return ranges_.empty(); }
    bool contains(std::uint64_t index) const;
    bool intersects(const EstimateSet& other) const;
    void insert(std::uint64_t index);
    void unite(const EstimateSet& other);
    // The smallest index at or after `index` that is not in the set.
    std::uint64_t nextMissing(std::uint64_t index) const;
    // One past the largest index (0 when empty).
    std::uint64_t end() const { return ranges_.empty() ? 0 : ranges_.back().second; }
    // The indices of [begin, end) that are not in the set, ascending, at most `limit` of them.
    std::vector<std::uint64_t> missingIn(std::uint64_t begin, std::uint64_t end,
                                         std::uint64_t limit) const;
    // How many indices are even (parity 0) or odd (parity 1).
    std::uint64_t countWithParity(int parity) const;
    // "0:8,12:16" (A:B means indices A to B-1); "none" when empty.
    std::string toString() const;
    // The inverse of toString; throws std::invalid_argument naming `what`.
    static EstimateSet parse(const std::string& text, const std::string& what);
    bool operator==(const EstimateSet&) const = default;

  private:
    std::vector<Range> ranges_;
};

// Parses "A:B" (estimate indices A to B-1, A < B); throws std::invalid_argument naming `option`.
EstimateSet::Range parseEstimateRange(const std::string& text,
                                      const std::string& option = "--estimates");

class EstimateAccumulator {
  public:
    EstimateAccumulator(int width, int height);
    // Adds estimate number `index` (3 * width * height floats); throws std::invalid_argument
    // if that estimate is already held. A sample of magnitude kLargestSample or more is dropped
    // (counted by droppedSamples()): such values are a numerical accident, not radiance.
    void add(std::uint64_t index, const float* rgb);
    // Adds the estimate after the largest held (index 0 for an empty accumulator).
    void add(const float* rgb) { add(indices_.end(), rgb); }
    long estimates() const { return long(indices_.count()); }
    const EstimateSet& indices() const { return indices_; }
    int width() const { return width_; }
    int height() const { return height_; }
    long droppedSamples() const { return dropped_; }
    RgbImage mean() const;
    // Standard error of the mean per channel: sqrt(sample variance / n); zero for n < 2.
    RgbImage standardError() const;
    // Per-value mean and sample variance in double (for noise statistics).
    double meanAt(size_t value) const;
    double varianceAt(size_t value) const;
    // Adds another accumulator's estimates; throws std::invalid_argument when the sizes differ
    // or the two hold a common estimate (sums of sums, never means of means).
    void merge(const EstimateAccumulator& other);
    // How many values (3 per pixel).
    size_t values() const { return partSums_[0].size(); }
    // The exact sums of value i and of its squares over every estimate held.
    SampleSum sumAt(size_t i) const;
    SquareSum squareAt(size_t i) const;
    // The same for every value, as saved states store them.
    std::vector<SampleSum> sums() const;
    std::vector<SquareSum> squares() const;
    void setIndices(EstimateSet indices) { indices_ = std::move(indices); }
    void setDroppedSamples(long dropped) { dropped_ = dropped; }

    // Two disjoint halves of the estimates by index parity: half 0 holds the even indices,
    // half 1 the odd ones. They are independent, so the statistics of one can weight the values
    // of the other without bias (image/combine.h). Exact like the full sums, so shards and
    // merges keep them. Call trackHalves before the first estimate.
    void trackHalves();
    bool tracksHalves() const { return tracksHalves_; }
    // Stops tracking (a merge with an accumulator that has no halves); the full sums stay.
    void dropHalves();
    long halfEstimates(int half) const;
    RgbImage halfMean(int half) const;
    RgbImage halfStandardError(int half) const;
    // The odd indices' sums (empty unless tracked).
    const std::vector<SampleSum>& oddSums() const { return partSums_[1]; }
    const std::vector<SquareSum>& oddSquares() const { return partSquares_[1]; }
    // Sets the raw state as saved states store it: the full sums and, when halves are tracked,
    // the odd indices' (else empty); throws std::invalid_argument on a size that does not fit.
    void setSums(std::vector<SampleSum> sums, std::vector<SquareSum> squares,
                 std::vector<SampleSum> oddSums, std::vector<SquareSum> oddSquares);

    // The stored parts, for reductions across processes: part 1 holds the odd indices' sums
    // when halves are tracked (else it is empty), part 0 the other estimates'. Each estimate
    // is added to one part only, so an odd one costs no more than an even one.
    std::vector<SampleSum>& partSums(int part) { return partSums_[size_t(part)]; }
    std::vector<SquareSum>& partSquares(int part) { return partSquares_[size_t(part)]; }
    const std::vector<SampleSum>& partSums(int part) const { return partSums_[size_t(part)]; }
    const std::vector<SquareSum>& partSquares(int part) const { return partSquares_[size_t(part)]; }

  private:
    template <int Part> long addValues(size_t begin, size_t end, const float* rgb);
    int width_, height_;
    EstimateSet indices_;
    long dropped_ = 0;
    bool tracksHalves_ = false;
    std::array<std::vector<SampleSum>, 2> partSums_;
    std::array<std::vector<SquareSum>, 2> partSquares_;
};

} // namespace cb
