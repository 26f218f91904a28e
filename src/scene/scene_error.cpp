#include "scene/scene_desc.h"

#include <fmt/format.h>

#include <algorithm>
#include <string_view>

namespace cb {

namespace {

// Length of the valid UTF-8 sequence starting at text[i] (2 to 4 bytes), or 0.
size_t utf8SequenceLength(const std::string& text, size_t i) {
    const auto byte = [&](size_t k) { return static_cast<unsigned char>(text[k]); };
    const unsigned char lead = byte(i);
    size_t length = lead >= 0xC2 && lead <= 0xDF   ? 2
                    : lead >= 0xE0 && lead <= 0xEF ? 3
                    : lead >= 0xF0 && lead <= 0xF4 ? 4
                                                   : 0;
    if (length == 0 || i + length > text.size()) return 0;
    for (size_t k = 1; k < length; ++k)
        if ((byte(i + k) & 0xC0) != 0x80) return 0;
    // Overlong three- and four-byte forms, UTF-16 surrogates and code points past U+10FFFF.
    if ((lead == 0xE0 && byte(i + 1) < 0xA0) || (lead == 0xED && byte(i + 1) > 0x9F) ||
        (lead == 0xF0 && byte(i + 1) < 0x90) || (lead == 0xF4 && byte(i + 1) > 0x8F))
        return 0;
    return length;
}

bool isTextByte(unsigned char c) {
    return (c >= 0x20 && c < 0x7F) || c == '\t' || c == '\n' || c == '\r' || c == '\f';
}

} // namespace

std::string printableText(const std::string& text) {
    std::string out;
    out.reserve(text.size());
    for (size_t i = 0; i < text.size();) {
        const auto c = static_cast<unsigned char>(text[i]);
        if (isTextByte(c) && c != '\r' && c != '\f') {
            out += char(c);
            ++i;
        } else if (size_t n = c >= 0x80 ? utf8SequenceLength(text, i) : 0) {
            out.append(text, i, n);
            i += n;
        } else {
            out += fmt::format("\\x{:02x}", c);
            ++i;
        }
    }
    return out;
}

std::string describeNonTextFile(const std::string& bytes) {
    const std::string_view head(bytes.data(), std::min<size_t>(bytes.size(), 8192));
    const struct {
        std::string_view magic;
        const char* what;
    } signatures[] = {
        {"\x76\x2f\x31\x01", "an OpenEXR image"},
        {"\x89PNG\r\n\x1a\n", "a PNG image"},
        {"\xff\xd8\xff", "a JPEG image"},
        {"GIF87a", "a GIF image"},
        {"GIF89a", "a GIF image"},
        {std::string_view("II*\0", 4), "a TIFF image"},
        {std::string_view("MM\0*", 4), "a TIFF image"},
        {"#?RADIANCE", "a Radiance HDR image"},
        {"#?RGBE", "a Radiance HDR image"},
        {"ply\n", "a PLY mesh (a scene loads it with Shape \"plymesh\")"},
        {"ply\r\n", "a PLY mesh (a scene loads it with Shape \"plymesh\")"},
        {"\x1f\x8b", "a gzip-compressed file (decompress it first)"},
        {"PK\x03\x04", "a ZIP archive"},
        {"%PDF", "a PDF document"},
        {"\x7f"
         "ELF",
         "an executable (ELF)"},
    };
    for (const auto& s : signatures)
        if (head.substr(0, s.magic.size()) == s.magic) return s.what;
    // Text may hold a few stray bytes (a Latin-1 comment); binary data holds NULs or many.
    size_t odd = 0;
    for (size_t i = 0; i < head.size();) {
        const auto c = static_cast<unsigned char>(head[i]);
        if (c == 0) return "a binary file";
        const size_t n = c >= 0x80 ? utf8SequenceLength(bytes, i) : 0;
        if (n == 0 && !isTextByte(c)) ++odd;
        i += std::max<size_t>(n, 1);
    }
    return odd * 10 > head.size() ? "a binary file" : "";
}

std::string SourceLocation::str() const {
    if (line <= 0) return file; // the whole file: it could not be read, or its content is wrong
    return file + ":" + std::to_string(line) + ":" + std::to_string(column);
}

SceneError::SceneError(const SourceLocation& where, const std::string& message)
    : std::runtime_error(printableText(where.str() + ": " + message)), where_(where) {}

} // namespace cb
