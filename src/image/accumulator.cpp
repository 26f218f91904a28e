#include "image/accumulator.h"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <thread>

namespace cb {

namespace {
__extension__ typedef unsigned __int128 u128;

// Adds (or, if `subtract`, subtracts) the magnitude `mantissa` * 2^shift to a little-endian
// two's complement word array; bits past the top word wrap (callers keep values in range).
template <size_t N>
void addShifted(std::array<std::uint64_t, N>& words, std::uint64_t mantissa, int shift,
                bool subtract) {
    if (mantissa == 0) return;
    const size_t first = size_t(shift / 64);
    const int bit = shift % 64;
    const std::uint64_t low = mantissa << bit;
    const std::uint64_t high = bit ? mantissa >> (64 - bit) : 0;
    std::uint64_t parts[2] = {low, high};
    std::uint64_t carry = 0;
    for (size_t i = first; i < N; ++i) {
        const std::uint64_t part = i - first < 2 ? parts[i - first] : 0;
        if (i - first >= 2 && carry == 0) break;
        if (!subtract) {
            const u128 sum = u128(words[i]) + part + carry;
            words[i] = std::uint64_t(sum);
            carry = std::uint64_t(sum >> 64);
        } else {
            const u128 diff = u128(words[i]) - part - carry;
            words[i] = std::uint64_t(diff);
            carry = std::uint64_t(diff >> 64) ? 1 : 0;
        }
    }
}

template <size_t N> void negate(std::array<std::uint64_t, N>& words) {
    std::uint64_t carry = 1;
    for (auto& w : words) {
        const u128 sum = u128(~w) + carry;
        w = std::uint64_t(sum);
        carry = std::uint64_t(sum >> 64);
    }
}

// An unsigned magnitude rounded to double from its top 128 bits: deterministic, and within an
// ulp of the exact value.
template <size_t N> double magnitudeToDouble(const std::array<std::uint64_t, N>& words) {
    size_t top = N;
    while (top > 0 && words[top - 1] == 0)
        --top;
    if (top == 0) return 0.0;
    if (top == 1) return double(words[0]);
    const u128 head = (u128(words[top - 1]) << 64) | words[top - 2];
    return std::ldexp(double(head), int(64 * (top - 2)));
}

template <size_t N> std::array<std::uint64_t, N> magnitude(std::array<std::uint64_t, N> words) {
    if (words[N - 1] >> 63) negate(words);
    return words;
}

// Unsigned product of two little-endian word arrays, truncated to R words.
template <size_t R, size_t A, size_t B>
std::array<std::uint64_t, R> multiply(const std::array<std::uint64_t, A>& a,
                                      const std::array<std::uint64_t, B>& b) {
    std::array<std::uint64_t, R> out{};
    for (size_t i = 0; i < A; ++i) {
        std::uint64_t carry = 0;
        for (size_t j = 0; j < B && i + j < R; ++j) {
            const u128 t = u128(a[i]) * b[j] + out[i + j] + carry;
            out[i + j] = std::uint64_t(t);
            carry = std::uint64_t(t >> 64);
        }
        for (size_t k = i + B; carry && k < R; ++k) {
            const u128 t = u128(out[k]) + carry;
            out[k] = std::uint64_t(t);
            carry = std::uint64_t(t >> 64);
        }
    }
    return out;
}
} // namespace

template <int Words> void FixedPoint<Words>::addScaled(double value) {
    if (value == 0.0) return;
    // value = mantissa * 2^exponent with a 53-bit integer mantissa (value is finite).
    const std::uint64_t bits = std::bit_cast<std::uint64_t>(value);
    const int biased = int((bits >> 52) & 0x7ff);
    std::uint64_t mantissa = bits & ((std::uint64_t(1) << 52) - 1);
    int exponent = biased ? biased - 1075 : -1074;
    if (biased) mantissa |= std::uint64_t(1) << 52;
    int shift = exponent + kFixedPointFractionBits;
    if (shift < 0) {
        // Below the grid: round to the nearest grid point, ties away from zero.
        if (shift < -53) return;
        const std::uint64_t half = std::uint64_t(1) << (-shift - 1);
        mantissa = (mantissa + half) >> -shift;
        shift = 0;
    }
    const bool subtract = std::signbit(value);
    if (shift <= 64) {
        // The common case, kept fast: the scaled value fits the two low words.
        const u128 scaled = u128(mantissa) << shift;
        const u128 low = (u128(word[1]) << 64) | word[0];
        const u128 result = subtract ? low - scaled : low + scaled;
        word[0] = std::uint64_t(result);
        word[1] = std::uint64_t(result >> 64);
        if (subtract ? result > low : result < low) {
            for (size_t i = 2; i < size_t(Words); ++i)
                if (subtract ? word[i]-- != 0 : ++word[i] != 0) break;
        }
        return;
    }
    addShifted(word, mantissa, shift, subtract);
}

template <int Words> void FixedPoint<Words>::add(const FixedPoint& other) {
    std::uint64_t carry = 0;
    for (int i = 0; i < Words; ++i) {
        const u128 sum = u128(word[size_t(i)]) + other.word[size_t(i)] + carry;
        word[size_t(i)] = std::uint64_t(sum);
        carry = std::uint64_t(sum >> 64);
    }
}

template <int Words> void FixedPoint<Words>::subtract(const FixedPoint& other) {
    std::uint64_t borrow = 0;
    for (int i = 0; i < Words; ++i) {
        const u128 diff = u128(word[size_t(i)]) - other.word[size_t(i)] - borrow;
        word[size_t(i)] = std::uint64_t(diff);
        borrow = std::uint64_t(diff >> 64) ? 1 : 0;
    }
}

template <int Words> double FixedPoint<Words>::toDouble() const {
    const double m = magnitudeToDouble(magnitude(word));
    return negative() ? -m : m;
}

template struct FixedPoint<3>;
template struct FixedPoint<4>;

EstimateSet EstimateSet::range(std::uint64_t begin, std::uint64_t end) {
    EstimateSet s;
    if (begin < end) s.ranges_.push_back({begin, end});
    return s;
}

EstimateSet EstimateSet::fromRanges(std::vector<Range> ranges) {
    for (size_t i = 0; i < ranges.size(); ++i) {
        if (ranges[i].first >= ranges[i].second)
            throw std::invalid_argument(
                fmt::format("estimate range {}:{} is empty", ranges[i].first, ranges[i].second));
        if (i && ranges[i].first <= ranges[i - 1].second)
            throw std::invalid_argument(fmt::format(
                "estimate ranges {}:{} and {}:{} are not sorted and apart", ranges[i - 1].first,
                ranges[i - 1].second, ranges[i].first, ranges[i].second));
    }
    EstimateSet s;
    s.ranges_ = std::move(ranges);
    return s;
}

std::uint64_t EstimateSet::count() const {
    std::uint64_t n = 0;
    for (const auto& r : ranges_)
        n += r.second - r.first;
    return n;
}

bool EstimateSet::contains(std::uint64_t index) const {
    auto it = std::upper_bound(ranges_.begin(), ranges_.end(), index,
                               [](std::uint64_t i, const Range& r) { return i < r.first; });
    return it != ranges_.begin() && index < std::prev(it)->second;
}

bool EstimateSet::intersects(const EstimateSet& other) const {
    size_t i = 0, j = 0;
    while (i < ranges_.size() && j < other.ranges_.size()) {
        const auto& a = ranges_[i];
        const auto& b = other.ranges_[j];
        if (a.first < b.second && b.first < a.second) return true;
        if (a.second <= b.second)
            ++i;
        else
            ++j;
    }
    return false;
}

std::uint64_t EstimateSet::nextMissing(std::uint64_t index) const {
    auto it = std::upper_bound(ranges_.begin(), ranges_.end(), index,
                               [](std::uint64_t i, const Range& r) { return i < r.first; });
    if (it != ranges_.begin() && index < std::prev(it)->second) return std::prev(it)->second;
    return index;
}

void EstimateSet::insert(std::uint64_t index) {
    unite(range(index, index + 1));
}

void EstimateSet::unite(const EstimateSet& other) {
    std::vector<Range> all = ranges_;
    all.insert(all.end(), other.ranges_.begin(), other.ranges_.end());
    std::sort(all.begin(), all.end());
    std::vector<Range> merged;
    for (const auto& r : all) {
        if (!merged.empty() && r.first <= merged.back().second)
            merged.back().second = std::max(merged.back().second, r.second);
        else
            merged.push_back(r);
    }
    ranges_ = std::move(merged);
}

std::vector<std::uint64_t> EstimateSet::missingIn(std::uint64_t begin, std::uint64_t end,
                                                  std::uint64_t limit) const {
    std::vector<std::uint64_t> out;
    std::uint64_t i = begin;
    size_t r = 0;
    while (i < end && out.size() < limit) {
        while (r < ranges_.size() && ranges_[r].second <= i)
            ++r;
        if (r < ranges_.size() && ranges_[r].first <= i) {
            i = ranges_[r].second;
            continue;
        }
        out.push_back(i++);
    }
    return out;
}

std::string EstimateSet::toString() const {
    if (ranges_.empty()) return "none";
    std::string s;
    for (const auto& r : ranges_) {
        if (!s.empty()) s += ',';
        s += fmt::format("{}:{}", r.first, r.second);
    }
    return s;
}

std::uint64_t EstimateSet::countWithParity(int parity) const {
    std::uint64_t n = 0;
    for (const auto& [begin, end] : ranges_)
        n += parity == 0 ? (end + 1) / 2 - (begin + 1) / 2 : end / 2 - begin / 2;
    return n;
}

EstimateSet EstimateSet::parse(const std::string& text, const std::string& what) {
    if (text == "none") return {};
    std::vector<Range> ranges;
    size_t start = 0;
    while (true) {
        const size_t comma = text.find(',', start);
        ranges.push_back(parseEstimateRange(text.substr(start, comma - start), what));
        if (comma == std::string::npos) break;
        start = comma + 1;
    }
    return fromRanges(std::move(ranges));
}

EstimateSet::Range parseEstimateRange(const std::string& text, const std::string& option) {
    const auto colon = text.find(':');
    auto number = [&](const std::string& part, std::uint64_t& value) {
        if (part.empty() || part.find_first_not_of("0123456789") != std::string::npos ||
            part.size() > 15)
            return false;
        value = std::stoull(part);
        return true;
    };
    std::uint64_t a = 0, b = 0;
    if (colon == std::string::npos || !number(text.substr(0, colon), a) ||
        !number(text.substr(colon + 1), b))
        throw std::invalid_argument(fmt::format(
            "{} '{}' must be A:B, estimate indices A to B-1 (e.g. 0:64)", option, text));
    if (a >= b)
        throw std::invalid_argument(fmt::format(
            "{} '{}' is empty: it renders indices A to B-1, so B must exceed A", option, text));
    return {a, b};
}

EstimateAccumulator::EstimateAccumulator(int width, int height) : width_(width), height_(height) {
    partSums_[0].resize(size_t(3) * size_t(width) * size_t(height));
    partSquares_[0].resize(partSums_[0].size());
}

template <int Part>
long EstimateAccumulator::addValues(size_t begin, size_t end, const float* rgb) {
    std::vector<SampleSum>& sums = partSums_[Part];
    std::vector<SquareSum>& squares = partSquares_[Part];
    long dropped = 0;
    for (size_t i = begin; i < end; ++i) {
        const double x = rgb[i];
        if (!(std::fabs(x) < kLargestSample)) {
            ++dropped;
            continue;
        }
        sums[i].addScaled(x);
        squares[i].addScaled(x * x); // exact: a float's square fits a double
    }
    return dropped;
}

void EstimateAccumulator::add(std::uint64_t index, const float* rgb) {
    if (indices_.contains(index))
        throw std::invalid_argument(
            fmt::format("estimate {} is already in the accumulated image", index));
    const bool odd = tracksHalves_ && (index % 2) == 1;
    auto addPart = [&](size_t begin, size_t end, long& dropped) {
        dropped = odd ? addValues<1>(begin, end, rgb) : addValues<0>(begin, end, rgb);
    };
    // Adding to wide integers is memory bound: large images are split among the cores (idle
    // while the host accumulates between kernel launches).
    const size_t values = this->values();
    const size_t parts = values < (size_t(1) << 16)
                             ? 1
                             : std::clamp<size_t>(std::thread::hardware_concurrency(), 1, 8);
    std::vector<long> dropped(parts, 0);
    {
        std::vector<std::jthread> helpers;
        for (size_t p = 1; p < parts; ++p)
            helpers.emplace_back(
                [&, p] { addPart(values * p / parts, values * (p + 1) / parts, dropped[p]); });
        addPart(0, values / parts, dropped[0]);
    }
    for (long d : dropped)
        dropped_ += d;
    indices_.insert(index);
}

namespace {
double meanOf(const SampleSum& sum, long n) {
    if (n == 0) return 0.0;
    return std::ldexp(sum.toDouble(), -kFixedPointFractionBits) / double(n);
}

double varianceOf(const SampleSum& sum, const SquareSum& squares, long n) {
    if (n < 2) return 0.0;
    // n * sum(x^2) - (sum x)^2 in exact integers (units 2^-224), then one rounding: no
    // cancellation even where every estimate is nearly the same.
    const std::array<std::uint64_t, 1> count{std::uint64_t(n)};
    auto scaledSquares = multiply<9>(squares.word, count); // squares are never negative
    // Shift by 112 bits (one word and 48 bits) so both terms are in units of 2^-224.
    std::array<std::uint64_t, 10> left{};
    for (size_t k = 0; k < 9; ++k) {
        left[k + 1] |= scaledSquares[k] << 48;
        if (k + 2 < 10) left[k + 2] |= scaledSquares[k] >> 16;
    }
    const auto s = magnitude(sum.word);
    const auto right = multiply<10>(s, s);
    // left - right, clamped at zero (rounding of single samples can make it slightly negative).
    std::array<std::uint64_t, 10> diff = left;
    std::uint64_t borrow = 0;
    for (size_t k = 0; k < 10; ++k) {
        const u128 d = u128(diff[k]) - right[k] - borrow;
        diff[k] = std::uint64_t(d);
        borrow = std::uint64_t(d >> 64) ? 1 : 0;
    }
    if (borrow) return 0.0;
    const double nd = double(n);
    return std::ldexp(magnitudeToDouble(diff), -2 * kFixedPointFractionBits) / (nd * (nd - 1.0));
}

// The mean and standard-error images of n estimates whose sums of value i are sumAt(i) and
// squareAt(i).
template <typename SumAt> RgbImage meanImage(int width, int height, long n, const SumAt& sumAt) {
    RgbImage out(width, height);
    for (size_t i = 0; i < out.rgb.size(); ++i)
        out.rgb[i] = float(meanOf(sumAt(i), n));
    return out;
}

template <typename SumAt, typename SquareAt>
RgbImage standardErrorImage(int width, int height, long n, const SumAt& sumAt,
                            const SquareAt& squareAt) {
    RgbImage out(width, height);
    if (n < 2) return out;
    for (size_t i = 0; i < out.rgb.size(); ++i)
        out.rgb[i] = float(std::sqrt(varianceOf(sumAt(i), squareAt(i), n) / double(n)));
    return out;
}

} // namespace

SampleSum EstimateAccumulator::sumAt(size_t i) const {
    SampleSum sum = partSums_[0][i];
    if (tracksHalves_) sum.add(partSums_[1][i]);
    return sum;
}

SquareSum EstimateAccumulator::squareAt(size_t i) const {
    SquareSum square = partSquares_[0][i];
    if (tracksHalves_) square.add(partSquares_[1][i]);
    return square;
}

std::vector<SampleSum> EstimateAccumulator::sums() const {
    std::vector<SampleSum> out(values());
    for (size_t i = 0; i < out.size(); ++i)
        out[i] = sumAt(i);
    return out;
}

std::vector<SquareSum> EstimateAccumulator::squares() const {
    std::vector<SquareSum> out(values());
    for (size_t i = 0; i < out.size(); ++i)
        out[i] = squareAt(i);
    return out;
}

void EstimateAccumulator::setSums(std::vector<SampleSum> sums, std::vector<SquareSum> squares,
                                  std::vector<SampleSum> oddSums,
                                  std::vector<SquareSum> oddSquares) {
    const size_t odd = tracksHalves_ ? values() : 0;
    if (sums.size() != values() || squares.size() != values() || oddSums.size() != odd ||
        oddSquares.size() != odd)
        throw std::invalid_argument(fmt::format(
            "EstimateAccumulator::setSums: {}, {}, {} and {} sums for {} values ({} halves)",
            sums.size(), squares.size(), oddSums.size(), oddSquares.size(), values(),
            tracksHalves_ ? "with" : "without"));
    // Part 0 holds the even indices' sums when halves are tracked: the full ones less the odd.
    for (size_t i = 0; i < odd; ++i) {
        sums[i].subtract(oddSums[i]);
        squares[i].subtract(oddSquares[i]);
    }
    partSums_ = {std::move(sums), std::move(oddSums)};
    partSquares_ = {std::move(squares), std::move(oddSquares)};
}

double EstimateAccumulator::meanAt(size_t i) const {
    return meanOf(sumAt(i), estimates());
}

double EstimateAccumulator::varianceAt(size_t i) const {
    return varianceOf(sumAt(i), squareAt(i), estimates());
}

RgbImage EstimateAccumulator::mean() const {
    return meanImage(width_, height_, estimates(), [&](size_t i) { return sumAt(i); });
}

RgbImage EstimateAccumulator::standardError() const {
    return standardErrorImage(
        width_, height_, estimates(), [&](size_t i) { return sumAt(i); },
        [&](size_t i) { return squareAt(i); });
}

void EstimateAccumulator::trackHalves() {
    if (estimates() != 0)
        throw std::logic_error("EstimateAccumulator::trackHalves after estimates were added");
    tracksHalves_ = true;
    partSums_[1].assign(values(), SampleSum{});
    partSquares_[1].assign(values(), SquareSum{});
}

void EstimateAccumulator::dropHalves() {
    if (tracksHalves_)
        for (size_t i = 0; i < values(); ++i) {
            partSums_[0][i].add(partSums_[1][i]);
            partSquares_[0][i].add(partSquares_[1][i]);
        }
    tracksHalves_ = false;
    partSums_[1] = {};
    partSquares_[1] = {};
}

long EstimateAccumulator::halfEstimates(int half) const {
    return long(indices_.countWithParity(half));
}

RgbImage EstimateAccumulator::halfMean(int half) const {
    if (!tracksHalves_) throw std::logic_error("EstimateAccumulator::halfMean: no halves kept");
    const std::vector<SampleSum>& sums = partSums_[size_t(half)];
    return meanImage(width_, height_, halfEstimates(half), [&](size_t i) { return sums[i]; });
}

RgbImage EstimateAccumulator::halfStandardError(int half) const {
    if (!tracksHalves_)
        throw std::logic_error("EstimateAccumulator::halfStandardError: no halves kept");
    const std::vector<SampleSum>& sums = partSums_[size_t(half)];
    const std::vector<SquareSum>& squares = partSquares_[size_t(half)];
    return standardErrorImage(
        width_, height_, halfEstimates(half), [&](size_t i) { return sums[i]; },
        [&](size_t i) { return squares[i]; });
}

void EstimateAccumulator::merge(const EstimateAccumulator& other) {
    if (other.width_ != width_ || other.height_ != height_)
        throw std::invalid_argument(fmt::format("cannot merge a {}x{} image into a {}x{} one",
                                                other.width_, other.height_, width_, height_));
    if (indices_.intersects(other.indices_))
        throw std::invalid_argument(
            fmt::format("the estimate sets overlap ({} and {}): an estimate would be counted twice",
                        indices_.toString(), other.indices_.toString()));
    // The halves survive only if both sides kept them.
    if (tracksHalves_ && other.tracksHalves_) {
        for (size_t part = 0; part < 2; ++part)
            for (size_t i = 0; i < values(); ++i) {
                partSums_[part][i].add(other.partSums_[part][i]);
                partSquares_[part][i].add(other.partSquares_[part][i]);
            }
    } else {
        dropHalves();
        for (size_t i = 0; i < values(); ++i) {
            partSums_[0][i].add(other.sumAt(i));
            partSquares_[0][i].add(other.squareAt(i));
        }
    }
    indices_.unite(other.indices_);
    dropped_ += other.dropped_;
}

} // namespace cb
