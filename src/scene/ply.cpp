#include "scene/ply.h"

#include "io/files.h"
#include "scene/scene_desc.h"

#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <sstream>
#include <string_view>

namespace cb {
namespace {

enum class PlyType { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };

std::optional<PlyType> parseType(std::string_view s) {
    if (s == "char" || s == "int8") return PlyType::Int8;
    if (s == "uchar" || s == "uint8") return PlyType::UInt8;
    if (s == "short" || s == "int16") return PlyType::Int16;
    if (s == "ushort" || s == "uint16") return PlyType::UInt16;
    if (s == "int" || s == "int32") return PlyType::Int32;
    if (s == "uint" || s == "uint32") return PlyType::UInt32;
    if (s == "float" || s == "float32") return PlyType::Float32;
    if (s == "double" || s == "float64") return PlyType::Float64;
    return std::nullopt;
}

size_t typeSize(PlyType t) {
    switch (t) {
    case PlyType::Int8:
    case PlyType::UInt8:
        return 1;
    case PlyType::Int16:
    case PlyType::UInt16:
        return 2;
    case PlyType::Int32:
    case PlyType::UInt32:
    case PlyType::Float32:
        return 4;
    case PlyType::Float64:
        return 8;
    }
    return 0;
}

bool isIntegerType(PlyType t) {
    return t != PlyType::Float32 && t != PlyType::Float64;
}

struct Property {
    std::string name;
    PlyType type = PlyType::Float32; // the item type for lists
    bool isList = false;
    PlyType countType = PlyType::UInt8;
    int line = 0;
};

struct Element {
    std::string name;
    uint64_t count = 0;
    std::vector<Property> props;
    int line = 0;
};

enum class Format { Ascii, BinaryLE, BinaryBE };

std::vector<std::string_view> splitWords(std::string_view line) {
    std::vector<std::string_view> words;
    size_t i = 0;
    while (i < line.size()) {
        while (i < line.size() && (line[i] == ' ' || line[i] == '\t'))
            ++i;
        size_t j = i;
        while (j < line.size() && line[j] != ' ' && line[j] != '\t')
            ++j;
        if (j > i) words.push_back(line.substr(i, j - i));
        i = j;
    }
    return words;
}

// Reads the payload value by value in either encoding, with every failure reported in terms a
// user can find in the file (ascii: line/column; binary: element, row and byte offset).
class PayloadReader {
  public:
    PayloadReader(std::string_view data, size_t start, int firstLine, Format fmt,
                  const std::string& path)
        : data_(data), pos_(start), line_(firstLine), lineStart_(start), tokStart_(start),
          fmt_(fmt), path_(path) {}

    void setContext(const std::string* element, uint64_t row) {
        element_ = element;
        row_ = row;
    }

    size_t remaining() const { return data_.size() - pos_; }
    size_t offset() const { return pos_; }
    bool binary() const { return fmt_ != Format::Ascii; }

    [[noreturn]] void fail(const std::string& what) const {
        std::ostringstream os;
        os << "element '" << *element_ << "' row " << row_;
        if (binary()) {
            os << " (byte offset " << tokStart_ << "): " << what;
            throw SceneError(SourceLocation{path_, 0, 0}, os.str());
        }
        os << ": " << what;
        throw SceneError(SourceLocation{path_, line_, static_cast<int>(tokStart_ - lineStart_) + 1},
                         os.str());
    }

    // Bytes left once trailing whitespace is skipped (ascii files may end in newlines).
    size_t trailing() {
        if (!binary())
            while (pos_ < data_.size() && (data_[pos_] == ' ' || data_[pos_] == '\t' ||
                                           data_[pos_] == '\r' || data_[pos_] == '\n')) {
                if (data_[pos_] == '\n') {
                    ++line_;
                    lineStart_ = pos_ + 1;
                }
                ++pos_;
            }
        tokStart_ = pos_;
        return remaining();
    }

    double read(PlyType t) { return binary() ? readBinary(t) : readAscii(t); }

    // Skip `n` values of type t without decoding them (binary only: ascii must tokenise).
    void skipBinary(uint64_t n, PlyType t) {
        tokStart_ = pos_;
        const uint64_t sz = typeSize(t);
        if (n > remaining() / sz)
            fail("truncated: needs " + std::to_string(n) + " more values of " + std::to_string(sz) +
                 " bytes, only " + std::to_string(remaining()) + " bytes left");
        pos_ += static_cast<size_t>(n * sz);
    }

  private:
    double readBinary(PlyType t) {
        tokStart_ = pos_;
        const size_t sz = typeSize(t);
        if (remaining() < sz)
            fail("truncated: needs " + std::to_string(sz) + " bytes, only " +
                 std::to_string(remaining()) + " left");
        unsigned char b[8];
        std::memcpy(b, data_.data() + pos_, sz);
        pos_ += sz;
        const bool swap = (fmt_ == Format::BinaryBE) != (std::endian::native == std::endian::big);
        if (swap)
            for (size_t i = 0; i < sz / 2; ++i)
                std::swap(b[i], b[sz - 1 - i]);
        switch (t) {
        case PlyType::Int8: {
            int8_t v;
            std::memcpy(&v, b, 1);
            return v;
        }
        case PlyType::UInt8:
            return b[0];
        case PlyType::Int16: {
            int16_t v;
            std::memcpy(&v, b, 2);
            return v;
        }
        case PlyType::UInt16: {
            uint16_t v;
            std::memcpy(&v, b, 2);
            return v;
        }
        case PlyType::Int32: {
            int32_t v;
            std::memcpy(&v, b, 4);
            return v;
        }
        case PlyType::UInt32: {
            uint32_t v;
            std::memcpy(&v, b, 4);
            return v;
        }
        case PlyType::Float32: {
            float v;
            std::memcpy(&v, b, 4);
            return v;
        }
        case PlyType::Float64: {
            double v;
            std::memcpy(&v, b, 8);
            return v;
        }
        }
        return 0.0;
    }

    double readAscii(PlyType t) {
        while (pos_ < data_.size()) {
            const char c = data_[pos_];
            if (c == '\n') {
                ++pos_;
                ++line_;
                lineStart_ = pos_;
            } else if (c == ' ' || c == '\t' || c == '\r') {
                ++pos_;
            } else {
                break;
            }
        }
        tokStart_ = pos_;
        if (pos_ >= data_.size()) fail("truncated: unexpected end of file");
        size_t end = pos_;
        while (end < data_.size() && data_[end] != ' ' && data_[end] != '\t' &&
               data_[end] != '\r' && data_[end] != '\n')
            ++end;
        std::string_view tok = data_.substr(pos_, end - pos_);
        std::string_view digits = (tok.size() > 1 && tok[0] == '+') ? tok.substr(1) : tok;
        double v = 0.0;
        if (isIntegerType(t)) {
            long long iv = 0;
            auto [p, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), iv);
            if (ec != std::errc() || p != digits.data() + digits.size())
                fail("expected an integer, got '" + std::string(tok) + "'");
            v = static_cast<double>(iv);
            const double lo = t == PlyType::Int8    ? -128.0
                              : t == PlyType::Int16 ? -32768.0
                              : t == PlyType::Int32 ? -2147483648.0
                                                    : 0.0;
            const double hi = t == PlyType::Int8     ? 127.0
                              : t == PlyType::UInt8  ? 255.0
                              : t == PlyType::Int16  ? 32767.0
                              : t == PlyType::UInt16 ? 65535.0
                              : t == PlyType::Int32  ? 2147483647.0
                                                     : 4294967295.0;
            if (v < lo || v > hi) fail("value " + std::string(tok) + " out of range for its type");
        } else {
            auto [p, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), v);
            if (ec != std::errc() || p != digits.data() + digits.size())
                fail("expected a number, got '" + std::string(tok) + "'");
        }
        pos_ = end;
        return v;
    }

    std::string_view data_;
    size_t pos_;
    int line_;
    size_t lineStart_;
    size_t tokStart_; // start of the value being read: errors point here
    Format fmt_;
    const std::string& path_;
    const std::string* element_ = nullptr;
    uint64_t row_ = 0;
};

} // namespace

PlyMesh readPlyFromMemory(const std::string& bytes, const std::string& path) {
    const std::string_view data(bytes);
    auto headerError = [&](int line, const std::string& msg) -> SceneError {
        return SceneError(SourceLocation{path, line, 1}, msg);
    };

    // --- Header: one keyword per line, up to end_header.
    std::optional<Format> format;
    std::vector<Element> elements;
    size_t pos = 0;
    int line = 0;
    bool ended = false;
    while (pos < data.size()) {
        size_t eol = data.find('\n', pos);
        const bool lastLine = eol == std::string_view::npos;
        if (lastLine) eol = data.size();
        std::string_view text = data.substr(pos, eol - pos);
        if (!text.empty() && text.back() == '\r') text.remove_suffix(1);
        ++line;
        pos = lastLine ? data.size() : eol + 1;
        if (line == 1) {
            if (text != "ply") throw headerError(1, "not a PLY file (first line must be 'ply')");
            continue;
        }
        const auto w = splitWords(text);
        if (w.empty()) throw headerError(line, "empty header line");
        if (w[0] == "comment" || w[0] == "obj_info") continue;
        if (w[0] == "end_header") {
            if (w.size() != 1) throw headerError(line, "unexpected text after end_header");
            ended = true;
            break;
        }
        if (w[0] == "format") {
            if (format) throw headerError(line, "second 'format' line");
            if (w.size() != 3) throw headerError(line, "expected 'format <encoding> 1.0'");
            if (w[2] != "1.0")
                throw headerError(line, "unsupported PLY version '" + std::string(w[2]) + "'");
            if (w[1] == "ascii")
                format = Format::Ascii;
            else if (w[1] == "binary_little_endian")
                format = Format::BinaryLE;
            else if (w[1] == "binary_big_endian")
                format = Format::BinaryBE;
            else
                throw headerError(line, "unknown PLY format '" + std::string(w[1]) + "'");
            continue;
        }
        if (!format) throw headerError(line, "expected 'format' line after 'ply'");
        if (w[0] == "element") {
            if (w.size() != 3) throw headerError(line, "expected 'element <name> <count>'");
            Element e;
            e.name = std::string(w[1]);
            e.line = line;
            auto [p, ec] = std::from_chars(w[2].data(), w[2].data() + w[2].size(), e.count);
            if (ec != std::errc() || p != w[2].data() + w[2].size())
                throw headerError(line, "bad element count '" + std::string(w[2]) + "'");
            for (const Element& other : elements)
                if (other.name == e.name)
                    throw headerError(line, "element '" + e.name + "' declared twice");
            elements.push_back(std::move(e));
            continue;
        }
        if (w[0] == "property") {
            if (elements.empty()) throw headerError(line, "property before any element");
            Property prop;
            prop.line = line;
            if (w.size() >= 2 && w[1] == "list") {
                if (w.size() != 5)
                    throw headerError(line, "expected 'property list <count type> <item type> "
                                            "<name>'");
                const auto ct = parseType(w[2]);
                const auto it = parseType(w[3]);
                if (!ct || !it)
                    throw headerError(line, "unknown property type '" +
                                                std::string(!ct ? w[2] : w[3]) + "'");
                if (!isIntegerType(*ct))
                    throw headerError(line, "list count type must be an integer type");
                prop.isList = true;
                prop.countType = *ct;
                prop.type = *it;
                prop.name = std::string(w[4]);
            } else {
                if (w.size() != 3) throw headerError(line, "expected 'property <type> <name>'");
                const auto t = parseType(w[1]);
                if (!t)
                    throw headerError(line, "unknown property type '" + std::string(w[1]) + "'");
                prop.type = *t;
                prop.name = std::string(w[2]);
            }
            for (const Property& other : elements.back().props)
                if (other.name == prop.name)
                    throw headerError(line, "property '" + prop.name + "' declared twice");
            elements.back().props.push_back(std::move(prop));
            continue;
        }
        throw headerError(line, "unknown header keyword '" + std::string(w[0]) + "'");
    }
    if (!ended) throw headerError(line, "missing end_header");
    const int payloadFirstLine = line + 1;
    const size_t payloadStart = pos;
    const size_t payloadSize = data.size() - payloadStart;

    // --- Locate what we need and check the counts against the file size before allocating.
    const Element* vertexEl = nullptr;
    const Element* faceEl = nullptr;
    for (const Element& e : elements) {
        if (e.count > 0 && e.props.empty())
            throw headerError(e.line, "element '" + e.name + "' has no properties");
        if (e.name == "vertex") vertexEl = &e;
        if (e.name == "face") faceEl = &e;
    }
    if (!vertexEl) throw headerError(line, "no 'element vertex'");
    if (!faceEl) throw headerError(line, "no 'element face' (point clouds are not supported)");

    int ix = -1, iy = -1, iz = -1, inx = -1, iny = -1, inz = -1, iu = -1, iv = -1;
    for (size_t i = 0; i < vertexEl->props.size(); ++i) {
        const Property& p = vertexEl->props[i];
        // Texture coordinates under any of the names pbrt-v4's reader accepts.
        const bool u =
            p.name == "u" || p.name == "s" || p.name == "texture_u" || p.name == "texture_s";
        const bool v =
            p.name == "v" || p.name == "t" || p.name == "texture_v" || p.name == "texture_t";
        int* slot = p.name == "x"    ? &ix
                    : p.name == "y"  ? &iy
                    : p.name == "z"  ? &iz
                    : p.name == "nx" ? &inx
                    : p.name == "ny" ? &iny
                    : p.name == "nz" ? &inz
                    : u              ? &iu
                    : v              ? &iv
                                     : nullptr;
        if (!slot) continue;
        if (p.isList) throw headerError(p.line, "vertex property '" + p.name + "' is a list");
        *slot = static_cast<int>(i);
    }
    if (ix < 0 || iy < 0 || iz < 0)
        throw headerError(vertexEl->line, "vertex element lacks x, y or z");
    const bool haveNormals = inx >= 0 && iny >= 0 && inz >= 0;
    const bool haveUv = iu >= 0 && iv >= 0;
    int iIndices = -1;
    for (size_t i = 0; i < faceEl->props.size(); ++i) {
        const Property& p = faceEl->props[i];
        if (p.name != "vertex_indices" && p.name != "vertex_index") continue;
        if (!p.isList) throw headerError(p.line, "'" + p.name + "' must be a list property");
        if (!isIntegerType(p.type))
            throw headerError(p.line, "vertex indices must have an integer type");
        if (iIndices >= 0) throw headerError(p.line, "face element has two index lists");
        iIndices = static_cast<int>(i);
    }
    if (iIndices < 0)
        throw headerError(faceEl->line, "face element lacks 'vertex_indices' / 'vertex_index'");

    // Binary rows take at least the scalar sizes plus the list count fields; ascii rows at
    // least two bytes per value (a digit and a separator), except the file's very last value.
    long double minBytes = 0.0L;
    for (const Element& e : elements) {
        uint64_t row = 0;
        for (const Property& p : e.props)
            row += (*format == Format::Ascii) ? 2 : typeSize(p.isList ? p.countType : p.type);
        minBytes += static_cast<long double>(row) * static_cast<long double>(e.count);
    }
    if (*format == Format::Ascii) minBytes -= 1.0L;
    if (minBytes > static_cast<long double>(payloadSize)) {
        std::ostringstream os;
        os << "the header declares ";
        for (size_t i = 0; i < elements.size(); ++i)
            os << (i ? ", " : "") << elements[i].count << " '" << elements[i].name << "'";
        os << ", needing at least " << static_cast<double>(minBytes) << " bytes of data, but only "
           << payloadSize << " bytes follow the header (truncated file or bad counts)";
        throw headerError(line, os.str());
    }

    if (vertexEl->count > std::numeric_limits<unsigned>::max())
        throw headerError(vertexEl->line,
                          "too many vertices (" + std::to_string(vertexEl->count) + ")");

    // --- Payload.
    PlyMesh mesh;
    PayloadReader in(data, payloadStart, payloadFirstLine, *format, path);
    const uint64_t nVerts = vertexEl->count;
    std::vector<uint64_t> poly;
    for (const Element& e : elements) {
        const bool isVertex = &e == vertexEl, isFace = &e == faceEl;
        if (isVertex) {
            mesh.positions.reserve(static_cast<size_t>(e.count));
            if (haveNormals) mesh.normals.reserve(static_cast<size_t>(e.count));
            if (haveUv) mesh.uv.reserve(static_cast<size_t>(e.count));
        }
        if (isFace) mesh.triangles.reserve(static_cast<size_t>(e.count));
        std::vector<double> scalars(e.props.size(), 0.0);
        for (uint64_t row = 0; row < e.count; ++row) {
            in.setContext(&e.name, row);
            for (size_t pi = 0; pi < e.props.size(); ++pi) {
                const Property& p = e.props[pi];
                if (!p.isList) {
                    if (!isVertex && in.binary())
                        in.skipBinary(1, p.type);
                    else
                        scalars[pi] = in.read(p.type);
                    continue;
                }
                const double n = in.read(p.countType);
                if (n < 0) in.fail("negative list length");
                const auto count = static_cast<uint64_t>(n);
                if (!(isFace && static_cast<int>(pi) == iIndices)) {
                    if (in.binary())
                        in.skipBinary(count, p.type);
                    else
                        for (uint64_t k = 0; k < count; ++k)
                            in.read(p.type);
                    continue;
                }
                if (count < 3)
                    in.fail("face has " + std::to_string(count) + " vertices (at least 3 needed)");
                if (in.binary() && count > in.remaining() / typeSize(p.type))
                    in.fail("truncated: face list of " + std::to_string(count) +
                            " indices runs past the end of the file");
                poly.clear();
                for (uint64_t k = 0; k < count; ++k) {
                    const double idx = in.read(p.type);
                    if (idx < 0 || idx >= static_cast<double>(nVerts)) {
                        std::ostringstream os;
                        os << "vertex index " << static_cast<long long>(idx)
                           << " out of range (the file has " << nVerts << " vertices)";
                        in.fail(os.str());
                    }
                    poly.push_back(static_cast<uint64_t>(idx));
                }
                // pbrt-v4 (rply_face_callback) reads triangles and quads only and ignores
                // larger faces with a warning; the parser reports the count.
                if (poly.size() > 4) {
                    ++mesh.skippedFaces;
                    continue;
                }
                for (size_t k = 1; k + 1 < poly.size(); ++k)
                    mesh.triangles.push_back({static_cast<unsigned>(poly[0]),
                                              static_cast<unsigned>(poly[k]),
                                              static_cast<unsigned>(poly[k + 1])});
            }
            if (isVertex) {
                const std::array<double, 3> p{scalars[ix], scalars[iy], scalars[iz]};
                for (double c : p)
                    if (!std::isfinite(c) || std::fabs(c) > std::numeric_limits<float>::max())
                        in.fail("vertex coordinate is not a finite float");
                mesh.positions.push_back(
                    {static_cast<float>(p[0]), static_cast<float>(p[1]), static_cast<float>(p[2])});
                if (haveNormals) {
                    const std::array<double, 3> nn{scalars[inx], scalars[iny], scalars[inz]};
                    for (double c : nn)
                        if (!std::isfinite(c) || std::fabs(c) > std::numeric_limits<float>::max())
                            in.fail("vertex normal is not a finite float");
                    mesh.normals.push_back({static_cast<float>(nn[0]), static_cast<float>(nn[1]),
                                            static_cast<float>(nn[2])});
                }
                if (haveUv) {
                    const std::array<double, 2> uv{scalars[iu], scalars[iv]};
                    for (double c : uv)
                        if (!std::isfinite(c) || std::fabs(c) > std::numeric_limits<float>::max())
                            in.fail("vertex texture coordinate is not a finite float");
                    mesh.uv.push_back({static_cast<float>(uv[0]), static_cast<float>(uv[1])});
                }
            }
        }
    }
    // Leftover bytes mean the header does not describe the data; refuse rather than guess.
    if (in.trailing() > 0) {
        std::ostringstream os;
        os << in.remaining() << " unexpected bytes after the last element (byte offset "
           << in.offset() << ")";
        throw SceneError(SourceLocation{path, 0, 0}, os.str());
    }
    return mesh;
}

PlyMesh readPly(const std::string& path) {
    std::string bytes;
    if (!tryReadWholeFile(path, bytes))
        throw SceneError(SourceLocation{path, 0, 0},
                         "cannot read the PLY file: " + unreadableReason(path));
    return readPlyFromMemory(bytes, path);
}

} // namespace cb
