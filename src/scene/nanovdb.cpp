#include "scene/nanovdb.h"

#include <fmt/format.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <stdexcept>

namespace cb {

namespace {

// NanoVDB's constants and byte offsets for its format version 32 (NanoVDB.h, util/IO.h):
// little-endian structures aligned to 32 bytes.
constexpr std::uint64_t kMagic = 0x304244566f6e614eULL; // "NanoVDB0"
constexpr std::uint32_t kMajorVersion = 32;
constexpr std::size_t kFileHeaderBytes = 16; // magic, version, grid count, codec
constexpr std::size_t kFileMetaBytes = 176;  // per grid, then its name
constexpr std::size_t kGridDataBytes = 672;  // GridData, then the tree
constexpr std::size_t kGridMapMatrixD = 384; // Map's 3 x 3 doubles (index to world)
constexpr std::size_t kGridMapTranslationD = 528;
constexpr std::size_t kGridTypeAt = 636;
constexpr std::uint32_t kGridTypeFloat = 1;
constexpr std::size_t kRootBytes = 64, kRootTileBytes = 32;
// Internal nodes: a bounding box, flags, value mask, child mask, 4 statistics, then the table of
// 8-byte entries (a tile's value or a child's byte offset from the node) at a 32-byte boundary.
struct InternalLayout {
    int log2Dim;       // 5 for the upper nodes, 4 for the lower ones
    int childTotal;    // log2 of the child's edge in voxels
    std::size_t table; // byte offset of the table
};
constexpr InternalLayout kUpper{5, 7, 8256}, kLower{4, 3, 1088};
constexpr std::size_t kLeafValues = 96; // a float leaf's 512 values

struct Reader {
    const std::string& path;
    const std::vector<char>& bytes;

    [[noreturn]] void fail(const std::string& why) const {
        throw std::runtime_error(fmt::format("{}: {}", path, why));
    }
    template <class T> T at(std::size_t offset) const {
        if (offset > bytes.size() || bytes.size() - offset < sizeof(T))
            fail(fmt::format("malformed NanoVDB grid: a read at byte {} beyond its {} bytes",
                             offset, bytes.size()));
        T v;
        std::memcpy(&v, bytes.data() + offset, sizeof(T));
        return v;
    }
};

std::vector<char> readRange(std::ifstream& in, const std::string& path, std::uint64_t offset,
                            std::uint64_t size) {
    std::vector<char> out(size);
    in.seekg(std::streamoff(offset));
    in.read(out.data(), std::streamsize(size));
    if (!in)
        throw std::runtime_error(fmt::format("{}: truncated NanoVDB file ({} bytes expected at "
                                             "byte {})",
                                             path, size, offset));
    return out;
}

struct GridEntry {
    std::string name;
    std::uint64_t offset = 0, gridSize = 0, fileSize = 0;
    std::uint16_t codec = 0;
    std::uint32_t type = 0;
};

// Every grid of every segment: a header, each grid's metadata and name, then the grids' bytes.
std::vector<GridEntry> listGrids(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw std::runtime_error(path + ": cannot open the NanoVDB file");
    in.seekg(0, std::ios::end);
    const std::uint64_t fileBytes = std::uint64_t(in.tellg());
    std::vector<GridEntry> grids;
    std::uint64_t pos = 0;
    while (pos < fileBytes) {
        const std::vector<char> header = readRange(in, path, pos, kFileHeaderBytes);
        const Reader r{path, header};
        const auto magic = r.at<std::uint64_t>(0);
        if (magic != kMagic)
            r.fail(fmt::format("not a NanoVDB file (magic number {:#x} at byte {})", magic, pos));
        const std::uint32_t major = r.at<std::uint32_t>(8) >> 21;
        if (major != kMajorVersion)
            r.fail(fmt::format("NanoVDB format version {}, cbdpt reads version {} (pbrt-v4's)",
                               major, kMajorVersion));
        const auto count = r.at<std::uint16_t>(12);
        const auto codec = r.at<std::uint16_t>(14);
        pos += kFileHeaderBytes;
        std::vector<GridEntry> segment;
        for (int g = 0; g < count; ++g) {
            const std::vector<char> meta = readRange(in, path, pos, kFileMetaBytes);
            const Reader m{path, meta};
            GridEntry e;
            e.gridSize = m.at<std::uint64_t>(0);
            e.fileSize = m.at<std::uint64_t>(8);
            e.type = m.at<std::uint32_t>(32);
            const auto nameSize = m.at<std::uint32_t>(136);
            e.codec = codec;
            pos += kFileMetaBytes;
            if (nameSize > 1 << 20) m.fail("malformed NanoVDB metadata (a grid name's size)");
            const std::vector<char> name = readRange(in, path, pos, nameSize);
            e.name.assign(name.data(), strnlen(name.data(), name.size()));
            pos += nameSize;
            segment.push_back(std::move(e));
        }
        for (GridEntry& e : segment) {
            e.offset = pos;
            pos += e.fileSize;
            if (pos > fileBytes)
                throw std::runtime_error(
                    fmt::format("{}: truncated NanoVDB file (grid \"{}\" ends at byte {} of {})",
                                path, e.name, pos, fileBytes));
            grids.push_back(std::move(e));
        }
    }
    return grids;
}

bool maskBit(const Reader& r, std::size_t mask, std::uint32_t n) {
    return (r.at<std::uint64_t>(mask + 8 * (n >> 6)) >> (n & 63)) & 1u;
}

// Writes `value` over the index box [lo, lo + edge) clipped to the dense box.
// Coordinates are 64-bit here: a malformed file's may be anywhere in int32.
using Coord = std::array<long long, 3>;

void fillBox(NanoVdbGrid& g, Coord lo, long long edge, float value) {
    const auto d = g.dims();
    std::array<long long, 3> a{}, b{};
    for (size_t k = 0; k < 3; ++k) {
        a[k] = std::max<long long>(lo[k], g.indexMin[k]) - g.indexMin[k];
        b[k] = std::min<long long>(lo[k] + edge, (long long)g.indexMin[k] + d[k]) - g.indexMin[k];
        if (a[k] >= b[k]) return;
    }
    for (long long z = a[2]; z < b[2]; ++z)
        for (long long y = a[1]; y < b[1]; ++y)
            std::fill_n(g.values.begin() +
                            std::ptrdiff_t((std::size_t(z) * std::size_t(d[1]) + std::size_t(y)) *
                                               std::size_t(d[0]) +
                                           std::size_t(a[0])),
                        b[0] - a[0], value);
}

// A leaf's 8 x 8 x 8 values, voxel n at (n >> 6, (n >> 3) & 7, n & 7) from its origin.
void fillLeaf(const Reader& r, std::size_t leaf, Coord origin, NanoVdbGrid& g) {
    const auto d = g.dims();
    const float* values = reinterpret_cast<const float*>(r.bytes.data() + leaf + kLeafValues);
    (void)r.at<float>(leaf + kLeafValues + 4 * 511); // the whole leaf is inside the grid's bytes
    for (std::uint32_t n = 0; n < 512; ++n) {
        const long long x = origin[0] + (n >> 6) - g.indexMin[0];
        const long long y = origin[1] + ((n >> 3) & 7) - g.indexMin[1];
        const long long z = origin[2] + (n & 7) - g.indexMin[2];
        if (x < 0 || y < 0 || z < 0 || x >= d[0] || y >= d[1] || z >= d[2]) continue;
        float v;
        std::memcpy(&v, values + n, sizeof v);
        g.values[(std::size_t(z) * std::size_t(d[1]) + std::size_t(y)) * std::size_t(d[0]) +
                 std::size_t(x)] = v;
    }
}

void fillInternal(const Reader& r, std::size_t node, const InternalLayout& layout, Coord origin,
                  NanoVdbGrid& g) {
    const int dim = 1 << layout.log2Dim;
    const std::uint32_t count = 1u << (3 * layout.log2Dim);
    const std::size_t maskBytes = std::size_t(count) / 8;
    const std::size_t childMask = 32 + maskBytes; // after the value mask
    for (std::uint32_t n = 0; n < count; ++n) {
        const long long x = n >> (2 * layout.log2Dim), y = (n >> layout.log2Dim) & (dim - 1),
                        z = n & std::uint32_t(dim - 1);
        const Coord at{origin[0] + (x << layout.childTotal), origin[1] + (y << layout.childTotal),
                       origin[2] + (z << layout.childTotal)};
        const std::size_t entry = node + layout.table + 8 * n;
        if (!maskBit(r, node + childMask, n)) {
            fillBox(g, at, 1 << layout.childTotal, r.at<float>(entry));
            continue;
        }
        const auto offset = r.at<std::int64_t>(entry);
        const std::size_t child = node + std::size_t(offset);
        if (offset <= 0 || child >= r.bytes.size())
            r.fail("malformed NanoVDB tree (a child offset)");
        if (layout.log2Dim == kUpper.log2Dim)
            fillInternal(r, child, kLower, at, g);
        else
            fillLeaf(r, child, at, g);
    }
}

} // namespace

std::vector<std::string> nanoVdbGridNames(const std::string& path) {
    std::vector<std::string> names;
    for (const GridEntry& e : listGrids(path))
        names.push_back(e.name);
    return names;
}

NanoVdbGrid readNanoVdbGrid(const std::string& path, const std::string& name,
                            std::uint64_t maxValues) {
    const std::vector<GridEntry> grids = listGrids(path);
    const auto it = std::find_if(grids.begin(), grids.end(),
                                 [&](const GridEntry& e) { return e.name == name; });
    if (it == grids.end()) {
        std::string names;
        for (const GridEntry& e : grids)
            names += (names.empty() ? "\"" : ", \"") + e.name + "\"";
        throw std::runtime_error(fmt::format("{}: no grid \"{}\" (the file holds {})", path, name,
                                             names.empty() ? "none" : names));
    }
    if (it->codec != 0)
        throw std::runtime_error(fmt::format(
            "{}: grid \"{}\" is compressed ({}); cbdpt reads uncompressed NanoVDB files "
            "(nanovdb_convert or nanovdb::io::writeGrid with Codec::NONE writes one)",
            path, name,
            it->codec == 1   ? "ZIP"
            : it->codec == 2 ? "BLOSC"
                             : "an unknown codec"));
    if (it->type != kGridTypeFloat)
        throw std::runtime_error(fmt::format(
            "{}: grid \"{}\" holds values of NanoVDB type {}, not floats", path, name, it->type));
    if (it->gridSize != it->fileSize)
        throw std::runtime_error(fmt::format("{}: malformed NanoVDB file (grid \"{}\": {} bytes in "
                                             "memory, {} in the file, uncompressed)",
                                             path, name, it->gridSize, it->fileSize));
    std::ifstream in(path, std::ios::binary);
    const std::vector<char> bytes = readRange(in, path, it->offset, it->gridSize);
    const Reader r{path, bytes};
    if (r.at<std::uint64_t>(0) != kMagic) r.fail("malformed NanoVDB grid (its magic number)");
    if (r.at<std::uint32_t>(kGridTypeAt) != kGridTypeFloat)
        r.fail(fmt::format("grid \"{}\" is not a float grid", name));
    NanoVdbGrid g;
    for (int k = 0; k < 9; ++k)
        g.matrix[size_t(k)] = r.at<double>(kGridMapMatrixD + 8 * std::size_t(k));
    for (int k = 0; k < 3; ++k)
        g.translation[size_t(k)] = r.at<double>(kGridMapTranslationD + 8 * std::size_t(k));
    const std::size_t tree = kGridDataBytes;
    const std::size_t root = tree + std::size_t(r.at<std::uint64_t>(tree + 24));
    for (int k = 0; k < 3; ++k) {
        g.indexMin[size_t(k)] = r.at<std::int32_t>(root + 4 * std::size_t(k));
        g.indexMax[size_t(k)] = r.at<std::int32_t>(root + 12 + 4 * std::size_t(k));
        if (g.indexMax[size_t(k)] < g.indexMin[size_t(k)])
            r.fail(fmt::format("grid \"{}\" has no active values", name));
    }
    const auto tableSize = r.at<std::uint32_t>(root + 24);
    g.background = r.at<float>(root + 28);
    std::array<long long, 3> d{};
    for (size_t k = 0; k < 3; ++k)
        d[k] = (long long)g.indexMax[k] - g.indexMin[k] + 2;
    const double total = double(d[0]) * double(d[1]) * double(d[2]);
    if (total > double(maxValues) || std::max({d[0], d[1], d[2]}) > (1LL << 30))
        r.fail(fmt::format("grid \"{}\" spans {} x {} x {} voxels, {:g} dense values; cbdpt "
                           "expands a grid to dense samples and takes at most {}",
                           name, d[0], d[1], d[2], total, maxValues));
    g.values.assign(std::size_t(total), g.background);
    for (std::uint32_t t = 0; t < tableSize; ++t) {
        const std::size_t tile = root + kRootBytes + kRootTileBytes * t;
        const auto key = r.at<std::uint64_t>(tile);
        const auto child = r.at<std::int64_t>(tile + 8);
        // The key packs each coordinate's top 21 bits (an upper node spans 2^12 voxels).
        constexpr std::uint64_t kMask = (1u << 21) - 1;
        const Coord origin{std::int32_t(std::uint32_t(((key >> 42) & kMask) << 12)),
                           std::int32_t(std::uint32_t(((key >> 21) & kMask) << 12)),
                           std::int32_t(std::uint32_t((key & kMask) << 12))};
        if (child == 0) {
            fillBox(g, origin, 1 << 12, r.at<float>(tile + 20));
            continue;
        }
        const std::size_t upper = root + std::size_t(child);
        if (child < 0 || upper >= bytes.size()) r.fail("malformed NanoVDB tree (a root child)");
        fillInternal(r, upper, kUpper, origin, g);
    }
    return g;
}

} // namespace cb
