// Parser for the pbrt-v4 scene-format subset documented in docs/scene-format.md.
//
// Structure follows pbrt-v4's own parser (src/pbrt/parser.cpp): a tokenizer per file, a loop
// over directives, parameter lists of `"type name" value(s)`, and a graphics state (CTM,
// orientation, material, area light) saved and restored by AttributeBegin/AttributeEnd. Unlike
// pbrt, nothing is ever ignored with a warning: anything outside the subset is a SceneError
// that points at the offending token.
#include "image/image.h"
#include "io/files.h"
#include "scene/loop_subdivision.h"
#include "scene/nanovdb.h"
#include "scene/ply.h"
#include "scene/scene_desc.h"
#include "scene/transform.h"
#include "spectral/camera_sensors.h"
#include "spectral/named_spectra.h"
#include "spectral/spectral.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <string_view>

#include <fmt/format.h>

#include "cb_sampling.h"

namespace cb {
namespace {

namespace fs = std::filesystem;

struct Token {
    std::string text; // strings are stored without quotes, escapes resolved
    bool quoted = false;
    SourceLocation where;
    bool isBracket(char c) const { return !quoted && text.size() == 1 && text[0] == c; }
};

std::string describe(const Token& t) {
    return t.quoted ? "\"" + t.text + "\"" : "'" + t.text + "'";
}

class Tokenizer {
  public:
    Tokenizer(std::string text, std::string path) : text_(std::move(text)), path_(std::move(path)) {
        if (text_.compare(0, 3, "\xEF\xBB\xBF") == 0) pos_ = 3; // UTF-8 byte order mark
    }

    const std::string& path() const { return path_; }
    SourceLocation here() const { return SourceLocation{path_, line_, col_}; }

    std::optional<Token> next() {
        for (;;) {
            while (pos_ < text_.size() && isSpace(text_[pos_]))
                bump();
            if (pos_ >= text_.size()) return std::nullopt;
            if (text_[pos_] != '#') break;
            while (pos_ < text_.size() && text_[pos_] != '\n')
                bump();
        }
        Token t;
        t.where = here();
        const char c = text_[pos_];
        if (c == '"') {
            t.quoted = true;
            bump();
            for (;;) {
                if (pos_ >= text_.size() || text_[pos_] == '\n')
                    throw SceneError(t.where, "unterminated string (missing closing '\"')");
                const char d = text_[pos_];
                if (d == '"') {
                    bump();
                    return t;
                }
                if (d == '\\') {
                    const SourceLocation escLoc = here();
                    bump();
                    const char e = pos_ < text_.size() ? text_[pos_] : '\0';
                    switch (e) {
                    case 'n':
                        t.text += '\n';
                        break;
                    case 't':
                        t.text += '\t';
                        break;
                    case 'r':
                        t.text += '\r';
                        break;
                    case 'b':
                        t.text += '\b';
                        break;
                    case 'f':
                        t.text += '\f';
                        break;
                    case '\\':
                        t.text += '\\';
                        break;
                    case '"':
                        t.text += '"';
                        break;
                    case '\'':
                        t.text += '\'';
                        break;
                    default:
                        throw SceneError(escLoc, "unknown escape sequence in string");
                    }
                    bump();
                    continue;
                }
                t.text += d;
                bump();
            }
        }
        if (c == '[' || c == ']') {
            t.text = std::string(1, c);
            bump();
            return t;
        }
        // Bare tokens end where pbrt-v4's do: whitespace, a quote or a bracket.
        while (pos_ < text_.size() && !isSpace(text_[pos_]) && text_[pos_] != '"' &&
               text_[pos_] != '[' && text_[pos_] != ']') {
            t.text += text_[pos_];
            bump();
        }
        return t;
    }

  private:
    static bool isSpace(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }
    void bump() {
        if (text_[pos_] == '\n') {
            ++line_;
            col_ = 1;
        } else {
            ++col_;
        }
        ++pos_;
    }

    std::string text_;
    std::string path_;
    size_t pos_ = 0;
    int line_ = 1;
    int col_ = 1;
};

// A number token; empty when the token is not entirely a number. Leading '+' is allowed as in
// strtod, which pbrt-v4 uses. Non-finite values are reported by the caller.
std::optional<double> parseNumber(std::string_view s, bool& outOfRange) {
    outOfRange = false;
    if (s.size() > 1 && s[0] == '+' && s[1] != '-') s.remove_prefix(1);
    if (s.empty()) return std::nullopt;
    double v = 0.0;
    auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (p != s.data() + s.size()) return std::nullopt;
    if (ec == std::errc::result_out_of_range) {
        outOfRange = true;
        return std::nullopt;
    }
    if (ec != std::errc()) return std::nullopt;
    return v;
}

double numberFromToken(const Token& t, const std::string& context) {
    if (t.quoted || t.isBracket('[') || t.isBracket(']'))
        throw SceneError(t.where, "expected a number " + context + ", found " + describe(t));
    bool outOfRange = false;
    const auto v = parseNumber(t.text, outOfRange);
    if (outOfRange) throw SceneError(t.where, "number '" + t.text + "' is out of range");
    if (!v) throw SceneError(t.where, "expected a number " + context + ", found " + describe(t));
    if (!std::isfinite(*v))
        throw SceneError(t.where, "'" + t.text + "' is not a finite number (NaN/Inf rejected)");
    return *v;
}

// ---------------------------------------------------------------------------------------------
// Parameter lists

struct Param {
    enum class Kind { None, Number, String, Bool };
    std::string type, name;
    SourceLocation where; // of the "type name" string
    Kind kind = Kind::None;
    std::vector<double> numbers;
    std::vector<std::string> strings;
    std::vector<bool> bools;
    std::vector<std::pair<int, int>> valuePos; // line, column of each value
    bool used = false;

    size_t size() const { return valuePos.size(); }
    SourceLocation valueLoc(size_t i) const {
        return SourceLocation{where.file, valuePos[i].first, valuePos[i].second};
    }
    std::string decl() const { return "\"" + type + " " + name + "\""; }
};

bool knownParamType(const std::string& t) {
    for (const char* k : {"bool", "integer", "float", "point2", "vector2", "point3", "vector3",
                          "normal", "string", "texture", "rgb", "spectrum", "blackbody"})
        if (t == k) return true;
    return false;
}

// What a spectral parameter's values may be: a fraction of light in [0, 1] (a reflectance or a
// transmittance), an emission >= 0, a conductor's eta or k in [0, kMaxConductorIndex], a
// dielectric's index in (0, kMaxDielectricIndex], or a medium's coefficient (sigma_a, sigma_s)
// >= 0.
enum class SpectrumRole { Reflectance, Emission, ConductorIndex, DielectricIndex, Coefficient };
// fresnelConductor's float arithmetic stays finite to about 1e9; no material comes near 1e6.
constexpr double kMaxConductorIndex = 1e6;
// 4^levels triangles per control triangle: 16 million (about 3 GB of device scene) is a bound
// a typo in "levels" meets long before the machine's memory.
constexpr double kMaxSubdividedTriangles = 16777216.0;
// Glasses and crystals stay below 5; the bound keeps a typo from passing.
constexpr double kMaxDielectricIndex = 100.0;
// Planck's law stays finite in double far beyond; no light comes near.
constexpr double kMaxBlackbodyKelvin = 1e9;

class ParamList {
  public:
    // Reads a spectrum file named by a "spectrum" parameter's string: the same parameter with
    // the file's numbers, their locations in that file.
    using SpectrumFileReader = std::function<Param(const Param&)>;

    ParamList(std::vector<Param> params, std::string owner, SceneDesc& scene,
              SpectrumFileReader spectrumFiles = {})
        : params_(std::move(params)), owner_(std::move(owner)), scene_(scene),
          spectrumFiles_(std::move(spectrumFiles)) {}

    bool has(const std::string& name) const {
        for (const Param& p : params_)
            if (p.name == name) return true;
        return false;
    }
    const Param* peek(const std::string& name) const {
        for (const Param& p : params_)
            if (p.name == name) return &p;
        return nullptr;
    }

    std::optional<double> oneFloat(const std::string& name) {
        const Param* p = numeric(name, "float", 1);
        if (!p) return std::nullopt;
        if (p->size() != 1) wrongCount(*p, "exactly 1 value");
        // Found by the fuzz target's checks (docs/robustness.md): "float" parameters are stored as
        // floats, and a finite double beyond FLT_MAX became Inf there (e.g. "float scale" 1e300).
        checkFitsFloat(*p, 0);
        return p->numbers[0];
    }

    std::optional<int> oneInt(const std::string& name) {
        const Param* p = numeric(name, "integer", 1);
        if (!p) return std::nullopt;
        if (p->size() != 1) wrongCount(*p, "exactly 1 value");
        return static_cast<int>(p->numbers[0]);
    }

    std::optional<bool> oneBool(const std::string& name) {
        const Param* p = lookup(name, {"bool"});
        if (!p) return std::nullopt;
        if (p->size() != 1) wrongCount(*p, "exactly 1 value");
        if (p->kind == Param::Kind::Bool) return bool(p->bools[0]);
        // pbrt-v4 reads quoted "true" only when upgrading pbrt-v3 files (pbrt --upgrade); a
        // plain render rejects it, so cbdpt does too.
        if (p->kind == Param::Kind::String && (p->strings[0] == "true" || p->strings[0] == "false"))
            throw SceneError(p->valueLoc(0), "parameter " + p->decl() +
                                                 ": write bare true/false (quoted \"" +
                                                 p->strings[0] + "\" is pbrt-v3 syntax)");
        throw SceneError(p->valueLoc(0), "parameter " + p->decl() + " expects true or false");
    }

    // A "texture" parameter: the name of the texture it refers to.
    std::optional<std::string> oneTexture(const std::string& name) {
        const Param* p = lookup(name, {"texture"});
        if (!p) return std::nullopt;
        if (p->kind != Param::Kind::String)
            throw SceneError(p->valueLoc(0),
                             "parameter " + p->decl() + " expects a texture's name in quotes");
        if (p->size() != 1) wrongCount(*p, "exactly 1 value");
        return p->strings[0];
    }

    std::optional<std::string> oneString(const std::string& name) {
        const Param* p = stringList(name);
        if (!p) return std::nullopt;
        if (p->size() != 1) wrongCount(*p, "exactly 1 value");
        return p->strings[0];
    }

    const Param* stringList(const std::string& name) {
        const Param* p = lookup(name, {"string"});
        if (p && p->kind != Param::Kind::String)
            throw SceneError(p->valueLoc(0), "parameter " + p->decl() + " expects strings");
        return p;
    }

    // A numeric array of `type` whose length is a positive multiple of perItem.
    const Param* numeric(const std::string& name, const char* type, size_t perItem) {
        const Param* p = lookup(name, {type});
        if (!p) return nullptr;
        if (p->kind != Param::Kind::Number)
            throw SceneError(p->size() ? p->valueLoc(0) : p->where,
                             "parameter " + p->decl() + " expects numbers");
        if (p->size() % perItem != 0)
            wrongCount(*p, "a multiple of " + std::to_string(perItem) + " values");
        if (std::string(type) == "integer")
            for (size_t i = 0; i < p->size(); ++i) {
                const double v = p->numbers[i];
                if (v != std::floor(v) || v < std::numeric_limits<int>::lowest() ||
                    v > std::numeric_limits<int>::max())
                    throw SceneError(p->valueLoc(i),
                                     "parameter " + p->decl() + " expects integers (in int range)");
            }
        return p;
    }

    std::optional<SpectrumValue> spectrum(const std::string& name, SpectrumRole role) {
        const Param* p = lookup(name, {"rgb", "spectrum", "blackbody"});
        if (!p) return std::nullopt;
        SpectrumValue s;
        if (p->type == "blackbody") {
            // pbrt-v4's BlackbodySpectrum: one temperature, Planck's law normalised to its peak.
            if (p->kind != Param::Kind::Number)
                throw SceneError(p->valueLoc(0),
                                 "parameter " + p->decl() + " expects a temperature in kelvin");
            if (p->size() != 1) wrongCount(*p, "one temperature in kelvin");
            const double kelvin = p->numbers[0];
            if (!(kelvin > 0.0 && kelvin <= kMaxBlackbodyKelvin))
                throw SceneError(p->valueLoc(0),
                                 fmt::format("parameter {} must be a temperature "
                                             "in (0, {:g}] kelvin, got {:g}",
                                             p->decl(), kMaxBlackbodyKelvin, kelvin));
            scene_.usesSpectra = true;
            s.isRgb = false;
            s.samples = blackbody(kelvin);
            return s;
        }
        if (p->type == "spectrum") {
            scene_.usesSpectra = true;
            Param fromFile;
            if (p->kind == Param::Kind::String) {
                if (p->size() != 1) wrongCount(*p, "one spectrum name or file name");
                // pbrt-v4 looks a name up among its named spectra before it reads a file.
                if (const NamedGlass* glass = findNamedGlass(p->strings[0]);
                    glass && role == SpectrumRole::DielectricIndex) {
                    s.isRgb = false;
                    s.samples = glassIndexSpectrum(*glass);
                    return s;
                }
                if (const NamedSpectrum* named = findNamedSpectrum(p->strings[0]))
                    fromFile = namedSpectrumParam(*p, *named);
                else if (!spectrumFiles_)
                    throw SceneError(p->where, "parameter " + p->decl() +
                                                   ": spectrum files are not read here; give "
                                                   "[wavelength value ...] pairs or one of the "
                                                   "named spectra " +
                                                   namedSpectrumNames());
                else
                    fromFile = spectrumFiles_(*p);
                p = &fromFile;
            }
            if (p->kind != Param::Kind::Number)
                throw SceneError(p->valueLoc(0), "parameter " + p->decl() + " expects numbers");
            if (p->size() % 2 != 0)
                wrongCount(*p, "(wavelength, value) pairs, i.e. an even number of values");
            s.isRgb = false;
            for (size_t i = 0; i < p->size(); i += 2) {
                const double lambda = p->numbers[i];
                if (!(lambda > 0.0))
                    throw SceneError(p->valueLoc(i), "wavelength must be positive (nm)");
                checkFitsFloat(*p, i);
                if (!s.samples.empty() && !(static_cast<float>(lambda) > s.samples.back().first))
                    throw SceneError(p->valueLoc(i),
                                     "wavelengths must be strictly increasing in " + p->decl());
                checkValue(*p, i + 1, role);
                s.samples.emplace_back(static_cast<float>(lambda),
                                       static_cast<float>(p->numbers[i + 1]));
            }
            // Outside its samples a spectrum is 0: an eta = k = 0 vacuum, where pbrt-v4's Fresnel
            // gives NaN and cbdpt's a perfect mirror, so a conductor's must cover cbdpt's bins;
            // a dielectric's index of 0 pbrt-v4 takes as 1, no interface.
            if ((role == SpectrumRole::ConductorIndex || role == SpectrumRole::DielectricIndex) &&
                (s.samples.front().first > kLambdaMin || s.samples.back().first < kLambdaMax))
                throw SceneError(
                    p->where,
                    fmt::format("parameter {} covers {:g}-{:g} nm; {} must cover "
                                "{:g}-{:g} nm (pbrt-v4 samples 360-830 nm)",
                                p->decl(), s.samples.front().first, s.samples.back().first,
                                role == SpectrumRole::ConductorIndex ? "a conductor's eta and k"
                                                                     : "a dielectric's index",
                                kLambdaMin, kLambdaMax));
            return s;
        }
        if (p->kind != Param::Kind::Number)
            throw SceneError(p->valueLoc(0), "parameter " + p->decl() + " expects 3 numbers");
        if (p->size() != 3) wrongCount(*p, "exactly 3 values");
        for (size_t i = 0; i < 3; ++i) {
            checkValue(*p, i, role);
            s.rgb[i] = static_cast<float>(p->numbers[i]);
        }
        return s;
    }

    // A default that pbrt-v4 gives as a named spectrum; measured spectra render spectrally, as
    // a spectrum parameter does.
    SpectrumValue namedDefault(std::string_view name) {
        scene_.usesSpectra = true;
        SpectrumValue s;
        s.isRgb = false;
        s.samples = toPiecewiseLinear(*findNamedSpectrum(name));
        return s;
    }

    // A built-in named spectrum in place of the parameter's name: its pairs, each at the name.
    static Param namedSpectrumParam(const Param& p, const NamedSpectrum& named) {
        Param out = p;
        out.kind = Param::Kind::Number;
        out.strings.clear();
        out.numbers = namedSpectrumPairs(named);
        out.valuePos.assign(out.numbers.size(), p.valuePos[0]);
        return out;
    }

    [[noreturn]] void wrongCount(const Param& p, const std::string& expected) const {
        throw SceneError(p.where, "parameter " + p.decl() + " of " + owner_ + " expects " +
                                      expected + ", got " + std::to_string(p.size()));
    }

    // pbrt-v4's Attribute parameters of this directive's kind: looked up after its own, the
    // latest first, and never reported unused (pbrt-v4's mayBeUnused).
    void addAttributes(const std::vector<Param>& attributes) {
        for (auto a = attributes.rbegin(); a != attributes.rend(); ++a) {
            params_.push_back(*a);
            params_.back().used = true;
        }
    }

    // The parameters as read (for Attribute, which keeps them for later directives).
    std::vector<Param> release() { return std::move(params_); }

    // Every parameter must have been consumed: an unknown name is an error, never ignored.
    void finish() const {
        for (const Param& p : params_)
            if (!p.used)
                throw SceneError(p.where,
                                 "unknown or unsupported parameter " + p.decl() + " for " + owner_);
    }

    const std::string& owner() const { return owner_; }

    // Marks every parameter not read so far as used and returns their declarations: for
    // directives whose other parameters cbdpt accepts without using them.
    std::vector<std::string> takeRest() {
        std::vector<std::string> rest;
        for (Param& p : params_)
            if (!p.used) {
                p.used = true;
                rest.push_back(p.decl());
            }
        return rest;
    }

    // Reads a parameter that cbdpt accepts and ignores; true if it was present.
    bool ignore(const std::string& name, std::initializer_list<const char*> types) {
        return lookup(name, types) != nullptr;
    }

  private:
    const Param* lookup(const std::string& name, std::initializer_list<const char*> types) {
        for (Param& p : params_) {
            if (p.name != name) continue;
            p.used = true;
            for (const char* t : types)
                if (p.type == t) {
                    if (p.size() == 0)
                        throw SceneError(p.where, "parameter " + p.decl() + " has no values");
                    return &p;
                }
            std::string expected;
            const size_t count = types.size();
            size_t i = 0;
            for (const char* t : types) {
                if (i > 0) expected += i + 1 == count ? " or " : ", ";
                expected += '"';
                expected += t;
                expected += '"';
                ++i;
            }
            std::string why;
            if (p.type == "texture")
                why = " (cbdpt takes spectrum textures as the \"reflectance\" of diffuse, "
                      "coateddiffuse, diffusetransmission and coatedconductor materials and the "
                      "\"transmittance\" of diffusetransmission, float textures as roughness, "
                      "\"displacement\" and \"alpha\")";
            throw SceneError(p.where, "parameter \"" + name + "\" of " + owner_ +
                                          " must have type " + expected + ", not \"" + p.type +
                                          "\"" + why);
        }
        return nullptr;
    }

    static void checkFitsFloat(const Param& p, size_t i) {
        if (std::fabs(p.numbers[i]) > std::numeric_limits<float>::max())
            throw SceneError(p.valueLoc(i), "parameter " + p.decl() +
                                                " has a value beyond the float range (3.4e38)");
    }

    void checkValue(const Param& p, size_t i, SpectrumRole role) const {
        checkFitsFloat(p, i);
        const double v = p.numbers[i];
        if (v < 0.0)
            throw SceneError(p.valueLoc(i), "parameter " + p.decl() + " has a negative value");
        if (role == SpectrumRole::Reflectance && v > 1.0)
            throw SceneError(p.valueLoc(i),
                             "parameter " + p.decl() + " is a " +
                                 (p.name == "transmittance" ? "transmittance" : "reflectance") +
                                 " and must be <= 1");
        if (role == SpectrumRole::ConductorIndex && v > kMaxConductorIndex)
            throw SceneError(p.valueLoc(i), fmt::format("parameter {} has {:g}; cbdpt evaluates "
                                                        "a conductor's eta and k up to {:g}",
                                                        p.decl(), v, kMaxConductorIndex));
        if (role == SpectrumRole::DielectricIndex && !(v > 0.0 && v <= kMaxDielectricIndex))
            throw SceneError(p.valueLoc(i),
                             fmt::format("parameter {} has {:g}; a dielectric's index must be in "
                                         "(0, {:g}]",
                                         p.decl(), v, kMaxDielectricIndex));
    }

    std::vector<Param> params_;
    std::string owner_;
    SceneDesc& scene_;
    SpectrumFileReader spectrumFiles_;
};

// ---------------------------------------------------------------------------------------------
// The parser proper

struct GraphicsState {
    Mat4 ctm;
    bool reverseOrientation = false;
    // -1: pbrt's default material, created on first use; <= -2: a named material defined later
    // (kLaterMaterial)
    int material = -1;
    int areaLight = -1;
    // pbrt-v4's MediumInterface: indices into SceneDesc::media, -1 vacuum ("")
    int mediumInside = -1, mediumOutside = -1;
    // pbrt-v4's Attribute "shape" / "light" / "material" / ... parameters: defaults for the
    // directives of that kind, in the order given.
    std::map<std::string, std::vector<Param>> attributes;
    SourceLocation openedAt; // of the AttributeBegin that saved this state
    std::string openedBy;    // that directive: AttributeBegin, TransformBegin or ObjectBegin
};

// What an Import saves of the importing file, restored when the imported file ends.
struct ImportScope {
    GraphicsState state;
    size_t stackDepth = 0; // of the attribute stack: the imported file may not pop below it
    std::map<std::string, Mat4> coordinateSystems;
};

struct SourceFile {
    Tokenizer tokens;
    std::string dir;                   // folder for relative paths ("" = current directory)
    fs::path key;                      // canonical path, for recursive-include detection
    std::optional<ImportScope> import; // set for a file read by Import
};

// Refuses a file that is not text (an image, a mesh, any binary data), saying what it is.
void requireText(const std::string& bytes, const SourceLocation& where, const std::string& path) {
    const std::string what = describeNonTextFile(bytes);
    if (!what.empty())
        throw SceneError(where, "\"" + path + "\" is " + what + ", not a pbrt scene (text)");
}

// pbrt-v4 reads a scene file whose name ends in ".gz" as gzip-compressed text.
void decompressIfGzipped(std::string& bytes, const std::string& path, const SourceLocation& where) {
    if (fs::path(path).extension() != ".gz") return;
    try {
        bytes = gunzip(bytes);
    } catch (const std::exception& e) {
        throw SceneError(where, "cannot decompress \"" + path + "\": " + e.what());
    }
}

fs::path canonicalKey(const std::string& path) {
    std::error_code ec;
    fs::path p = fs::weakly_canonical(fs::path(path), ec);
    return ec ? fs::path(path).lexically_normal() : p;
}

std::string parentDir(const std::string& path) {
    return fs::path(path).parent_path().string();
}

std::string joinPath(const std::string& dir, const std::string& name) {
    return dir.empty() ? name : (fs::path(dir) / name).lexically_normal().string();
}

class Parser {
  public:
    explicit Parser(SceneDesc& scene) : scene_(scene) {}

    void run(std::string text, const std::string& path) {
        topDir_ = parentDir(path);
        files_.push_back(std::make_unique<SourceFile>(
            SourceFile{Tokenizer(std::move(text), path), topDir_, canonicalKey(path), {}}));
        SourceLocation end;
        for (;;) {
            std::optional<Token> t = next();
            if (!t) {
                end = files_.back()->tokens.here();
                if (files_.size() == 1) break;
                if (files_.back()->import) endImport(*files_.back()->import);
                files_.pop_back();
                continue;
            }
            directive(*t);
        }
        if (!stack_.empty()) throw unclosedBlock("");
        if (!inWorld_) throw SceneError(end, "end of file before WorldBegin");
        instantiateLaterObjects();
        resolveLaterMaterials();
        resolveLaterMixParts();
        resolveLaterTextures();
        checkInterfaces();
        checkTangents();
        checkMedia();
    }

  private:
    // Tokens come from the innermost file only; the directive loop pops finished files, so a
    // directive and its parameters can never straddle an Include boundary.
    std::optional<Token> next() {
        if (peeked_) return std::exchange(peeked_, std::nullopt);
        return files_.back()->tokens.next();
    }
    const std::optional<Token>& peek() {
        if (!peeked_) peeked_ = files_.back()->tokens.next();
        return peeked_;
    }

    Token required(const Token& dir, const std::string& what) {
        std::optional<Token> t = next();
        if (!t)
            throw SceneError(dir.where, "unexpected end of file: " + dir.text + " expects " + what);
        return *t;
    }

    double number(const Token& dir, int count) {
        const Token t = required(dir, std::to_string(count) + " numbers");
        return numberFromToken(t, "for " + dir.text);
    }

    std::array<double, 3> number3(const Token& dir, int count) {
        const double a = number(dir, count), b = number(dir, count), c = number(dir, count);
        return {a, b, c};
    }

    Token quoted(const Token& dir, const std::string& what) {
        Token t = required(dir, what);
        if (!t.quoted)
            throw SceneError(t.where, dir.text + " expects " + what + " in double quotes, found " +
                                          describe(t));
        return t;
    }

    ParamList params(const std::string& owner) {
        std::vector<Param> list;
        for (;;) {
            const std::optional<Token>& pk = peek();
            if (!pk || !pk->quoted) break;
            Token declTok = *next();
            Param p;
            p.where = declTok.where;
            std::istringstream words(declTok.text);
            std::string extra;
            if (!(words >> p.type >> p.name) || (words >> extra))
                throw SceneError(p.where, "parameter declaration must be \"type name\", found \"" +
                                              declTok.text + "\"");
            if (!knownParamType(p.type)) {
                std::string hint;
                if (p.type == "color") hint = " (pbrt-v3 syntax; pbrt-v4 uses \"rgb\")";
                if (p.type == "point" || p.type == "vector" || p.type == "normal3")
                    hint = " (pbrt-v4 uses \"point3\", \"vector3\" and \"normal\")";
                throw SceneError(p.where, "unknown parameter type \"" + p.type + "\"" + hint);
            }
            for (const Param& q : list)
                if (q.name == p.name)
                    throw SceneError(p.where, "parameter \"" + p.name + "\" given twice");
            std::optional<Token> v = next();
            if (!v)
                throw SceneError(p.where, "parameter " + p.decl() + " has no value (end of file)");
            if (v->isBracket('[')) {
                const SourceLocation open = v->where;
                for (;;) {
                    std::optional<Token> e = next();
                    if (!e)
                        throw SceneError(open, "end of file inside '[' of parameter " + p.decl() +
                                                   " (missing ']')");
                    if (e->isBracket(']')) break;
                    addValue(p, *e, true);
                }
            } else {
                if (looksLikeDirective(*v))
                    throw SceneError(p.where, "parameter " + p.decl() + " has no value (found " +
                                                  describe(*v) + ")");
                addValue(p, *v, false);
            }
            list.push_back(std::move(p));
        }
        return ParamList(std::move(list), owner, scene_,
                         [this](const Param& p) { return readSpectrumFile(p); });
    }

    // A directive's parameters followed by the Attribute parameters of its kind ("shape",
    // "light", "material").
    ParamList params(const std::string& owner, const char* kind) {
        ParamList pl = params(owner);
        if (auto a = state_.attributes.find(kind); a != state_.attributes.end())
            pl.addAttributes(a->second);
        return pl;
    }

    // pbrt-v4's Attribute "target" params: defaults for later directives of that kind, kept in
    // the graphics state (so AttributeBegin/End scope them).
    void attribute(const Token& t) {
        const Token target = quoted(t, "an attribute target");
        const char* const kinds[] = {"shape", "light", "material", "medium", "texture"};
        if (std::find(std::begin(kinds), std::end(kinds), target.text) == std::end(kinds))
            throw SceneError(target.where, "unknown Attribute target \"" + target.text +
                                               "\" (pbrt-v4's are \"shape\", \"light\", "
                                               "\"material\", \"medium\" and \"texture\")");
        ParamList pl = params("Attribute \"" + target.text + "\"");
        for (Param& p : pl.release())
            state_.attributes[target.text].push_back(std::move(p));
    }

    // pbrt-v4's spectrum files: whitespace-separated (wavelength, value) pairs with '#' comments,
    // found beside the file that names them or the main scene file, as Include finds files.
    Param readSpectrumFile(const Param& p) {
        const std::string& name = p.strings[0];
        const SourceLocation where = p.valueLoc(0);
        const std::vector<std::string> candidates = nearbyPaths(name);
        for (const std::string& path : candidates) {
            if (!fs::is_regular_file(path)) continue;
            std::string text;
            if (!tryReadWholeFile(path, text))
                throw SceneError(where, "cannot read spectrum file \"" + path +
                                            "\": " + unreadableReason(path));
            requireText(text, where, path);
            scene_.sourceFiles.push_back(path);
            Param out = p;
            out.where = SourceLocation{path, 0, 0};
            out.kind = Param::Kind::Number;
            out.strings.clear();
            out.valuePos.clear();
            Tokenizer tokens(std::move(text), path);
            while (std::optional<Token> t = tokens.next()) {
                if (t->quoted || t->isBracket('[') || t->isBracket(']'))
                    throw SceneError(t->where, "spectrum file holds " + describe(*t) +
                                                   "; expected (wavelength, value) numbers");
                out.numbers.push_back(numberFromToken(*t, "in spectrum file"));
                out.valuePos.emplace_back(t->where.line, t->where.column);
            }
            if (out.numbers.empty())
                throw SceneError(out.where, "spectrum file holds no (wavelength, value) pairs");
            return out;
        }
        std::string tried;
        for (const std::string& c : candidates)
            tried += " " + c;
        throw SceneError(where, "parameter " + p.decl() + ": no spectrum file \"" + name +
                                    "\" (tried" + tried +
                                    ") and no built-in spectrum of that name (cbdpt has " +
                                    namedSpectrumNames() +
                                    ", and pbrt-v4's glass-* as a dielectric's eta; its "
                                    "stdillum-*, metal-TiO2-* and camera spectra are not built "
                                    "in): give [wavelength value ...] pairs or a file of them");
    }

    // A bare capitalised word that is not a number ("Infinity" is one) is a directive name:
    // the parameter's value or its closing bracket is missing.
    static bool looksLikeDirective(const Token& t) {
        if (t.quoted || t.text.empty() || !std::isupper(static_cast<unsigned char>(t.text[0])))
            return false;
        bool outOfRange = false;
        return !parseNumber(t.text, outOfRange) && !outOfRange;
    }

    static bool isIntegerText(std::string_view s) {
        if (!s.empty() && (s[0] == '+' || s[0] == '-')) s.remove_prefix(1);
        if (s.empty()) return false;
        for (char c : s)
            if (c < '0' || c > '9') return false;
        return true;
    }

    static void addValue(Param& p, const Token& t, bool inBrackets) {
        if (t.isBracket('['))
            throw SceneError(t.where, "unexpected '[' in the values of parameter " + p.decl());
        if (t.isBracket(']')) throw SceneError(t.where, "unexpected ']' (no matching '[')");
        Param::Kind kind;
        if (t.quoted)
            kind = Param::Kind::String;
        else if (t.text == "true" || t.text == "false")
            kind = Param::Kind::Bool;
        else
            kind = Param::Kind::Number;
        if (p.kind != Param::Kind::None && p.kind != kind)
            throw SceneError(t.where, "mixed value types in parameter " + p.decl());
        if (kind == Param::Kind::Number) {
            if (inBrackets && looksLikeDirective(t))
                throw SceneError(t.where, "expected a value or ']' in parameter " + p.decl() +
                                              ", found " + describe(t) + " (missing ']'?)");
            p.numbers.push_back(numberFromToken(t, "in parameter " + p.decl()));
            // pbrt-v4's parseInt takes an optional sign and digits only, for every "integer"
            // parameter as it is read: 2.0 or 2e0 is an error there, not the integer 2.
            if (p.type == "integer" && !isIntegerText(t.text))
                throw SceneError(t.where, "parameter " + p.decl() +
                                              " expects integers (in int range), found '" + t.text +
                                              "'");
        } else if (kind == Param::Kind::String) {
            p.strings.push_back(t.text);
        } else {
            p.bools.push_back(t.text == "true");
        }
        p.kind = kind;
        p.valuePos.emplace_back(t.where.line, t.where.column);
    }

    void requireWorld(const Token& dir) const {
        if (!inWorld_) throw SceneError(dir.where, dir.text + " is only allowed after WorldBegin");
    }
    void requireOptions(const Token& dir) const {
        if (inWorld_) throw SceneError(dir.where, dir.text + " is only allowed before WorldBegin");
    }

    void concat(const Mat4& m) { state_.ctm = state_.ctm * m; }

    void directive(const Token& t) {
        bool outOfRange = false;
        if (t.quoted || t.isBracket('[') || t.isBracket(']') || parseNumber(t.text, outOfRange) ||
            outOfRange)
            throw SceneError(t.where, "expected a directive, found " + describe(t));
        const std::string& d = t.text;
        if (d == "LookAt") {
            const auto eye = number3(t, 9), look = number3(t, 9), up = number3(t, 9);
            const auto m = lookAtMatrix(eye, look, up);
            if (!m)
                throw SceneError(t.where, "LookAt: eye equals look point, or up is parallel to "
                                          "the viewing direction");
            concat(*m);
        } else if (d == "Translate") {
            const auto v = number3(t, 3);
            concat(translateMatrix(v[0], v[1], v[2]));
        } else if (d == "Scale") {
            const auto v = number3(t, 3);
            concat(scaleMatrix(v[0], v[1], v[2]));
        } else if (d == "Rotate") {
            const double angle = number(t, 4);
            const auto axis = number3(t, 4);
            const auto m = rotateMatrix(angle, axis[0], axis[1], axis[2]);
            if (!m) throw SceneError(t.where, "Rotate: the axis has zero length");
            concat(*m);
        } else if (d == "Transform" || d == "ConcatTransform") {
            const Token open = required(t, "[ 16 numbers ]");
            if (!open.isBracket('['))
                throw SceneError(open.where,
                                 d + " expects '[' and 16 numbers, found " + describe(open));
            std::array<double, 16> v{};
            for (double& x : v)
                x = number(t, 16);
            const Token close = required(t, "']' after 16 numbers");
            if (!close.isBracket(']'))
                throw SceneError(close.where, d + " expects exactly 16 numbers then ']', found " +
                                                  describe(close));
            const Mat4 m = matrixFromPbrtFileOrder(v);
            if (d == "Transform")
                state_.ctm = m;
            else
                concat(m);
        } else if (d == "Identity") {
            state_.ctm = Mat4::identity();
        } else if (d == "ReverseOrientation") {
            requireWorld(t);
            state_.reverseOrientation = !state_.reverseOrientation;
        } else if (d == "Camera") {
            camera(t);
        } else if (d == "Film") {
            film(t);
        } else if (d == "WorldBegin") {
            if (inWorld_) throw SceneError(t.where, "second WorldBegin");
            inWorld_ = true;
            state_.ctm = Mat4::identity();
            // pbrt-v4's WorldBegin defines "world" as the (new) CTM, replacing any earlier one.
            namedCoordinateSystems_["world"] = state_.ctm;
        } else if (d == "AttributeBegin" || d == "TransformBegin") {
            requireWorld(t);
            // pbrt-v4's parser reads TransformBegin/End as AttributeBegin/End (the whole graphics
            // state, not only the CTM) and warns once that they are deprecated.
            if (d == "TransformBegin")
                note(t.where, "transformbegin",
                     "TransformBegin/TransformEnd are deprecated in pbrt-v4, which reads them as "
                     "AttributeBegin/AttributeEnd (the whole graphics state is saved); so does "
                     "cbdpt");
            stack_.push_back(state_);
            stack_.back().openedAt = t.where;
            stack_.back().openedBy = d;
        } else if (d == "AttributeEnd" || d == "TransformEnd") {
            requireWorld(t);
            // An imported file has its own attribute stack in pbrt-v4.
            const ImportScope* scope = importBase();
            if (stack_.size() == (scope ? scope->stackDepth : 0))
                throw SceneError(t.where, d + " without matching " + d.substr(0, d.size() - 3) +
                                              "Begin" + (scope ? " in this Import-ed file" : ""));
            if (openObject_ && stack_.size() == openObject_->depth)
                throw SceneError(t.where, d + " would close ObjectBegin \"" + openObject_->name +
                                              "\"; use ObjectEnd");
            state_ = stack_.back();
            stack_.pop_back();
        } else if (d == "Texture") {
            requireWorld(t);
            texture(t);
        } else if (d == "Material") {
            requireWorld(t);
            const Token type = quoted(t, "a material type");
            ParamList pl = params("Material \"" + type.text + "\"", "material");
            state_.material = makeMaterial(type.text, type.where, pl, "", t.where);
        } else if (d == "MakeNamedMaterial") {
            requireWorld(t);
            const Token name = quoted(t, "a material name");
            ParamList pl = params("MakeNamedMaterial \"" + name.text + "\"", "material");
            for (const MaterialDesc& m : scene_.materials)
                if (!m.name.empty() && m.name == name.text)
                    throw SceneError(name.where, "named material \"" + name.text +
                                                     "\" is already defined (at " + m.where.str() +
                                                     ")");
            const Param* typeParam = pl.peek("type");
            const std::optional<std::string> type = pl.oneString("type");
            if (!type)
                throw SceneError(t.where, "MakeNamedMaterial \"" + name.text +
                                              "\" needs a \"string type\" parameter");
            makeMaterial(*type, typeParam->valueLoc(0), pl, name.text, t.where);
        } else if (d == "NamedMaterial") {
            requireWorld(t);
            const Token name = quoted(t, "a material name");
            const int idx = findNamedMaterial(name.text);
            state_.material = idx >= 0 ? idx : laterNamedMaterial(name);
        } else if (d == "AreaLightSource") {
            requireWorld(t);
            areaLight(t);
        } else if (d == "LightSource") {
            requireWorld(t);
            lightSource(t);
        } else if (d == "Shape") {
            requireWorld(t);
            shape(t);
        } else if (d == "Include") {
            include(t, false);
        } else if (d == "Import") {
            if (!inWorld_)
                throw SceneError(t.where, "Import statement only allowed inside world definition "
                                          "block (after WorldBegin), as in pbrt-v4");
            include(t, true);
        } else if (d == "Sampler") {
            sampler(t);
        } else if (d == "Integrator") {
            integrator(t);
        } else if (d == "PixelFilter") {
            pixelFilter(t);
        } else if (d == "Accelerator") {
            accelerator(t);
        } else if (d == "ColorSpace") {
            const Token name = quoted(t, "a colour space name");
            if (name.text != "srgb")
                throw SceneError(name.where, "unsupported ColorSpace \"" + name.text +
                                                 "\" (cbdpt supports \"srgb\")");
        } else if (d == "Option") {
            option(t);
        } else if (d == "CoordinateSystem") {
            const Token name = quoted(t, "a coordinate system name");
            namedCoordinateSystems_[name.text] = state_.ctm;
            if (importBase() != nullptr) importedCoordinateSystems_[name.text] = name.where;
        } else if (d == "CoordSysTransform") {
            const Token name = quoted(t, "a coordinate system name");
            const auto it = namedCoordinateSystems_.find(name.text);
            if (it == namedCoordinateSystems_.end()) {
                std::string why = " (define it with CoordinateSystem first)";
                if (importBase() != nullptr)
                    why = " (an Import-ed file starts without named coordinate systems, as in "
                          "pbrt-v4; define it in this file)";
                else if (const auto d2 = importedCoordinateSystems_.find(name.text);
                         d2 != importedCoordinateSystems_.end())
                    why = " (it was defined in an Import-ed file, at " + d2->second.str() +
                          "; pbrt-v4 does not pass named coordinate systems back from Import)";
                throw SceneError(name.where,
                                 "unknown coordinate system \"" + name.text + "\"" + why);
            }
            state_.ctm = it->second;
        } else if (d == "ObjectBegin") {
            objectBegin(t);
        } else if (d == "ObjectEnd") {
            objectEnd(t);
        } else if (d == "ObjectInstance") {
            objectInstance(t);
        } else if (d == "Attribute") {
            attribute(t);
        } else if (d == "MakeNamedMedium") {
            makeNamedMedium(t);
        } else if (d == "MediumInterface") {
            mediumInterface(t);
        } else if (d == "WorldEnd") {
            throw SceneError(t.where, "WorldEnd is pbrt-v3 syntax and not part of pbrt-v4");
        } else {
            for (const char* known : {"ActiveTransform", "TransformTimes"})
                if (d == known)
                    throw SceneError(t.where, "pbrt-v4 directive '" + d +
                                                  "' is not supported by cbdpt (see "
                                                  "docs/scene-format.md)");
            throw SceneError(t.where, "unknown directive '" + d + "'");
        }
    }

    void camera(const Token& t) {
        requireOptions(t);
        if (haveCamera_) throw SceneError(t.where, "second Camera directive");
        haveCamera_ = true;
        const Token type = quoted(t, "a camera type");
        if (type.text != "perspective")
            throw SceneError(type.where, "unsupported camera \"" + type.text +
                                             "\" (cbdpt supports \"perspective\" only)");
        ParamList pl = params("Camera \"perspective\"");
        CameraDesc& cam = scene_.camera;
        cam.where = t.where;
        // pbrt-v4's camera sits in the outside medium of its MediumInterface.
        cam.medium = mediumUsed(state_.mediumOutside, t.where, "the camera");
        cam.worldToCamera = state_.ctm.m;
        // pbrt-v4 names the camera's space "camera" for CoordSysTransform.
        if (const auto worldFromCamera = inverse(state_.ctm))
            namedCoordinateSystems_["camera"] = *worldFromCamera;
        if (const Param* p = pl.peek("fov"); p) {
            const double fov = *pl.oneFloat("fov");
            if (!(fov > 0.0 && fov < 180.0))
                throw SceneError(p->where, "\"float fov\" must be in (0, 180) degrees");
            cam.fovDegrees = static_cast<float>(fov);
        }
        if (const Param* p = pl.peek("frameaspectratio")) {
            const double a = *pl.oneFloat("frameaspectratio");
            if (!(a > 0.0))
                throw SceneError(
                    p->valueLoc(0),
                    fmt::format("\"float frameaspectratio\" must be > 0, got {:g}", a));
            cam.frameAspectRatio = a;
        }
        if (const Param* p = pl.numeric("screenwindow", "float", 4)) {
            if (p->size() != 4) pl.wrongCount(*p, "4 values x0 x1 y0 y1");
            const auto& w = p->numbers;
            if (!(w[0] < w[1] && w[2] < w[3]))
                throw SceneError(p->where, fmt::format("\"float screenwindow\" {:g} {:g} {:g} {:g} "
                                                       "must be x0 x1 y0 y1 with x0 < x1 and y0 < "
                                                       "y1",
                                                       w[0], w[1], w[2], w[3]));
            cam.screenWindow = std::array<double, 4>{w[0], w[1], w[2], w[3]};
        }
        // The film's exposure time is the shutter interval (pbrt-v4's CameraBase).
        const double open = pl.oneFloat("shutteropen").value_or(0.0);
        const double close = pl.oneFloat("shutterclose").value_or(1.0);
        if (!(close > open))
            throw SceneError(t.where, "\"float shutterclose\" must be greater than "
                                      "\"float shutteropen\"");
        scene_.film.exposureTime = close - open;
        // pbrt-v4's thin lens (PerspectiveCamera): depth of field.
        if (const Param* p = pl.peek("lensradius")) {
            const double r = *pl.oneFloat("lensradius");
            if (!(r >= 0.0 && r <= 1e6))
                throw SceneError(
                    p->valueLoc(0),
                    fmt::format("\"float lensradius\" must be in [0, 1e6], got {:g}", r));
            cam.lensRadius = static_cast<float>(r);
        }
        if (const Param* p = pl.peek("focaldistance")) {
            const double d = *pl.oneFloat("focaldistance");
            if (!(d > 0.0 && d <= 1e30))
                throw SceneError(p->valueLoc(0),
                                 fmt::format("\"float focaldistance\" must be in (0, 1e30], got "
                                             "{:g}",
                                             d));
            cam.focalDistance = static_cast<float>(d);
        }
        pl.finish();
    }

    // Reported once per kind on stderr and kept in SceneDesc::notes.
    void note(const SourceLocation& where, const std::string& kind, const std::string& message) {
        if (!notedKinds_.insert(kind).second) return;
        const std::string line = where.file + ":" + std::to_string(where.line) + ": " + message;
        std::cerr << "cbdpt: note: " << line << "\n";
        scene_.notes.push_back(line);
    }

    static std::string joined(const std::vector<std::string>& v) {
        std::string out;
        for (const std::string& s : v)
            out += (out.empty() ? "" : ", ") + s;
        return out;
    }

    void sampler(const Token& t) {
        requireOptions(t);
        const Token type = quoted(t, "a sampler type");
        ParamList pl = params("Sampler \"" + type.text + "\"");
        SamplerDesc& s = scene_.sampler;
        s.type = type.text;
        s.where = t.where;
        if (type.text == "stratified") {
            // pbrt-v4's stratified sampler takes xsamples x ysamples per pixel (4 x 4).
            const int nx = pl.oneInt("xsamples").value_or(4),
                      ny = pl.oneInt("ysamples").value_or(4);
            if (nx < 1 || ny < 1)
                throw SceneError(t.where, "\"integer xsamples\" and \"ysamples\" must be >= 1");
            s.pixelSamples = nx * ny;
        } else if (const Param* p = pl.peek("pixelsamples")) {
            s.pixelSamples = *pl.oneInt("pixelsamples");
            if (s.pixelSamples < 1)
                throw SceneError(p->where, "\"integer pixelsamples\" must be >= 1");
        } else {
            s.pixelSamples = 16; // pbrt-v4's default for every other sampler
        }
        const std::vector<std::string> rest = pl.takeRest();
        note(t.where, "sampler",
             "Sampler \"" + type.text +
                 "\" is not used: each cbdpt method draws its own samples; " +
                 std::to_string(s.pixelSamples) +
                 " samples per pixel become the estimate count where --spp is not given" +
                 (rest.empty() ? std::string() : " (ignored: " + joined(rest) + ")"));
    }

    void integrator(const Token& t) {
        requireOptions(t);
        const Token type = quoted(t, "an integrator type");
        std::string method;
        if (type.text == "path" || type.text == "volpath")
            method = "pt"; // cbdpt's path tracer renders media as volpath
        else if (type.text == "bdpt")
            method = "bdpt";
        else if (type.text == "mlt")
            method = "mlt";
        else
            throw SceneError(type.where, "unsupported integrator \"" + type.text +
                                             "\" (cbdpt supports \"path\", \"volpath\", \"bdpt\" "
                                             "and \"mlt\")");
        ParamList pl = params("Integrator \"" + type.text + "\"");
        IntegratorDesc& in = scene_.integrator;
        in.type = method;
        in.where = t.where;
        if (const Param* p = pl.peek("maxdepth")) {
            in.maxDepth = *pl.oneInt("maxdepth");
            if (in.maxDepth < 0 || in.maxDepth > 1000)
                throw SceneError(p->where, "\"integer maxdepth\" must be in [0, 1000]");
        } else {
            in.maxDepth = 5; // pbrt-v4's default for path, volpath, bdpt and mlt
        }
        const std::vector<std::string> rest = pl.takeRest();
        if (!rest.empty())
            note(t.where, "integrator", "Integrator parameters not used by cbdpt: " + joined(rest));
    }

    // pbrt-v4's filters and their defaults and parameters (Filter::Create, its filters.cpp).
    void pixelFilter(const Token& t) {
        requireOptions(t);
        const Token type = quoted(t, "a filter type");
        ParamList pl = params("PixelFilter \"" + type.text + "\"");
        FilterDesc f = FilterDesc::pbrtDefault();
        f.where = t.where;
        if (type.text == "box") {
            f.type = FilterDesc::Type::Box;
            f.radiusX = f.radiusY = 0.5;
        } else if (type.text == "triangle") {
            f.type = FilterDesc::Type::Triangle;
            f.radiusX = f.radiusY = 2.0;
        } else if (type.text == "mitchell") {
            f.type = FilterDesc::Type::Mitchell;
            f.radiusX = f.radiusY = 2.0;
        } else if (type.text == "sinc") {
            f.type = FilterDesc::Type::Sinc;
            f.radiusX = f.radiusY = 4.0;
        } else if (type.text != "gaussian") {
            throw SceneError(type.where, "PixelFilter \"" + type.text +
                                             "\" is not a filter: expected \"box\", "
                                             "\"gaussian\", \"triangle\", \"mitchell\" or "
                                             "\"sinc\"");
        }
        for (const char* name : {"xradius", "yradius"})
            if (const Param* p = pl.peek(name)) {
                const double r = *pl.oneFloat(name);
                if (!(r > 0.0 && r <= 32.0))
                    throw SceneError(
                        p->valueLoc(0),
                        fmt::format("\"float {}\" must be in (0, 32] pixels, got {:g}", name, r));
                (std::string(name) == "xradius" ? f.radiusX : f.radiusY) = r;
            }
        if (f.type == FilterDesc::Type::Gaussian)
            if (const Param* p = pl.peek("sigma")) {
                f.sigma = *pl.oneFloat("sigma");
                if (!(f.sigma > 0.0 && f.sigma <= 32.0))
                    throw SceneError(
                        p->valueLoc(0),
                        fmt::format("\"float sigma\" must be in (0, 32] pixels, got {:g}",
                                    f.sigma));
            }
        // Mitchell and Netravali's B and C: any finite values give a cubic of integral 1 (their
        // paper's region B + 2C = 1 is where it interpolates; B = C = 1/3 is pbrt-v4's default).
        if (f.type == FilterDesc::Type::Mitchell)
            for (const char* name : {"B", "C"})
                if (const Param* p = pl.peek(name)) {
                    const double value = *pl.oneFloat(name);
                    if (!(std::fabs(value) <= 100.0))
                        throw SceneError(
                            p->valueLoc(0),
                            fmt::format("\"float {}\" must be in [-100, 100], got {:g}", name,
                                        value));
                    (std::string(name) == "B" ? f.mitchellB : f.mitchellC) = value;
                }
        if (f.type == FilterDesc::Type::Sinc)
            if (const Param* p = pl.peek("tau")) {
                f.sincTau = *pl.oneFloat("tau");
                if (!(f.sincTau >= 0.1 && f.sincTau <= 32.0))
                    throw SceneError(
                        p->valueLoc(0),
                        fmt::format("\"float tau\" must be in [0.1, 32], got {:g}", f.sincTau));
            }
        pl.finish();
        scene_.filter = f;
    }

    // pbrt-v4's aggregates (CreateAccelerator) with the parameters each reads; an unknown type or
    // parameter is an error there too. Neither changes the image, and cbdpt builds its own BVH.
    void accelerator(const Token& t) {
        requireOptions(t);
        const Token type = quoted(t, "an accelerator type");
        ParamList pl = params("Accelerator \"" + type.text + "\"");
        if (type.text == "bvh") {
            if (const Param* p = pl.peek("splitmethod")) {
                const std::string m = *pl.oneString("splitmethod");
                if (m != "sah" && m != "hlbvh" && m != "middle" && m != "equal")
                    throw SceneError(p->valueLoc(0), "unknown BVH split method \"" + m +
                                                         "\" (pbrt-v4 knows sah, hlbvh, middle, "
                                                         "equal)");
            }
            pl.oneInt("maxnodeprims");
        } else if (type.text == "kdtree") {
            for (const char* name : {"intersectcost", "traversalcost", "maxprims", "maxdepth"})
                pl.oneInt(name);
            pl.oneFloat("emptybonus");
        } else {
            throw SceneError(type.where, "unknown accelerator \"" + type.text +
                                             "\" (pbrt-v4 has \"bvh\" and \"kdtree\")");
        }
        pl.finish();
        note(t.where, "accelerator",
             "Accelerator \"" + type.text +
                 "\" is not used: cbdpt builds its own BVH (the image does not depend on it)");
    }

    // pbrt-v4's Option "name" value (parser.cpp, BasicSceneBuilder::Option): a quoted name, matched
    // ignoring case, '-' and '_' as normalizeArg does, then one value token whose kind depends on
    // the option. Those that change pbrt-v4's image when true are refused; the rest have no
    // effect in cbdpt.
    void option(const Token& t) {
        const Token name = quoted(t, "an option name");
        const Token value = required(t, "a value");
        enum class Kind { Bool, Float, Int, String };
        struct Known {
            const char* name;
            Kind kind;
            const char* effect; // what pbrt-v4 does with it
            bool changesImage;  // when true
        };
        static const Known known[] = {
            {"disablepixeljitter", Kind::Bool, "samples every pixel at its centre", true},
            {"disablewavelengthjitter", Kind::Bool, "uses the same wavelengths for every sample",
             true},
            {"forcediffuse", Kind::Bool, "renders every material as diffuse", true},
            {"disabletexturefiltering", Kind::Bool,
             "looks textures up at the hit point, unfiltered, as cbdpt always does", false},
            {"displacementedgescale", Kind::Float, "sets displacement tessellation", false},
            {"msereferenceimage", Kind::String, "reports the error against an image", false},
            {"msereferenceout", Kind::String, "writes the error against an image", false},
            {"rendercoordsys", Kind::String, "chooses the space it renders in", false},
            {"seed", Kind::Int, "seeds the samplers, as cbdpt's --seed does", false},
            {"pixelstats", Kind::Bool, "writes per-pixel statistics", false},
            {"wavefront", Kind::Bool, "chooses its wavefront renderer", false},
        };
        auto normalized = [](std::string_view n) {
            std::string out;
            for (const unsigned char c : n)
                if (c != '_' && c != '-') out += static_cast<char>(std::tolower(c));
            return out;
        };
        auto find = [&](const std::string& key) -> const Known* {
            for (const Known& k : known)
                if (key == k.name) return &k;
            return nullptr;
        };
        const Known* opt = find(normalized(name.text));
        if (!opt) {
            // pbrt-v4 takes "bool forcediffuse" as the name of an unknown option.
            const size_t space = name.text.find(' ');
            if (space != std::string::npos && find(normalized(name.text.substr(space + 1))))
                throw SceneError(name.where,
                                 "Option \"" + name.text +
                                     "\": pbrt-v4 names the option without a type; "
                                     "write Option \"" +
                                     name.text.substr(space + 1) + "\" " +
                                     (value.quoted ? "\"" + value.text + "\"" : value.text));
            std::string names;
            for (const Known& k : known)
                names += std::string(names.empty() ? "" : ", ") + k.name;
            throw SceneError(name.where,
                             "unknown option \"" + name.text + "\" (pbrt-v4's are " + names + ")");
        }
        const std::string what = "Option \"" + name.text + "\"";
        switch (opt->kind) {
        case Kind::Bool:
            if (value.quoted || (value.text != "true" && value.text != "false"))
                throw SceneError(value.where,
                                 what + " expects true or false, found " + describe(value));
            break;
        case Kind::Float:
            numberFromToken(value, "for " + what);
            break;
        case Kind::Int:
            if (value.quoted || !isIntegerText(value.text))
                throw SceneError(value.where,
                                 what + " expects an integer, found " + describe(value));
            break;
        case Kind::String:
            if (!value.quoted)
                throw SceneError(value.where,
                                 what + " expects a quoted string, found " + describe(value));
            if (std::string(opt->name) == "rendercoordsys" && value.text != "camera" &&
                value.text != "cameraworld" && value.text != "world")
                throw SceneError(value.where, "unknown rendering coordinate system \"" +
                                                  value.text + "\" (camera, cameraworld or world)");
            break;
        }
        if (std::string(opt->name) == "disabletexturefiltering")
            textureFilteringDisabled_ = value.text == "true";
        if (opt->changesImage && value.text == "true")
            throw SceneError(name.where, what + " true is not supported: pbrt-v4 then " +
                                             opt->effect + ", which cbdpt does not implement");
        note(t.where, std::string("option:") + opt->name,
             opt->changesImage
                 ? what + " false has no effect (pbrt-v4's default)"
                 : what + " has no effect in cbdpt (in pbrt-v4 it " + opt->effect + ")");
    }

    struct ObjectDef {
        std::vector<TriangleMeshDesc> meshes;
        std::vector<SphereDesc> spheres;
        std::vector<CurveDesc> curves;
        SourceLocation where;
    };

    void objectBegin(const Token& t) {
        requireWorld(t);
        const Token name = quoted(t, "an object name");
        if (openObject_)
            throw SceneError(t.where, "ObjectBegin inside the definition of \"" +
                                          openObject_->name + "\" (nesting is not allowed)");
        if (objects_.count(name.text))
            throw SceneError(name.where, "object \"" + name.text + "\" is already defined");
        stack_.push_back(state_); // ObjectBegin implies AttributeBegin, as in pbrt-v4
        stack_.back().openedAt = t.where;
        stack_.back().openedBy = "ObjectBegin";
        openObject_ = OpenObject{name.text, scene_.meshes.size(), scene_.spheres.size(),
                                 scene_.curves.size(), stack_.size()};
    }

    void objectEnd(const Token& t) {
        requireWorld(t);
        if (!openObject_) throw SceneError(t.where, "ObjectEnd without ObjectBegin");
        if (const ImportScope* scope = importBase();
            scope && openObject_->depth <= scope->stackDepth)
            throw SceneError(t.where, "ObjectEnd in an Import-ed file cannot close ObjectBegin \"" +
                                          openObject_->name + "\" of the importing file");
        if (stack_.size() != openObject_->depth)
            throw SceneError(t.where, "ObjectEnd inside an AttributeBegin block of the object");
        ObjectDef& def = objects_[openObject_->name];
        def.where = t.where;
        for (size_t i = openObject_->firstMesh; i < scene_.meshes.size(); ++i)
            def.meshes.push_back(std::move(scene_.meshes[i]));
        for (size_t i = openObject_->firstSphere; i < scene_.spheres.size(); ++i)
            def.spheres.push_back(scene_.spheres[i]);
        scene_.meshes.resize(openObject_->firstMesh);
        scene_.spheres.resize(openObject_->firstSphere);
        def.curves.assign(scene_.curves.begin() + long(openObject_->firstCurve),
                          scene_.curves.end());
        scene_.curves.resize(openObject_->firstCurve);
        bool hadLight = false;
        for (auto& m : def.meshes)
            hadLight |= std::exchange(m.areaLight, -1) >= 0;
        for (auto& sp : def.spheres)
            hadLight |= std::exchange(sp.areaLight, -1) >= 0;
        if (hadLight)
            note(t.where, "instance-light",
                 "area lights inside object definitions do not emit (as in pbrt-v4)");
        openObject_.reset();
        state_ = stack_.back();
        stack_.pop_back();
    }

    // Instances are flattened: each shape of the object is copied with the instance's CTM
    // applied on top of the CTM it was defined with (pbrt-v4's renderFromInstance). An object
    // defined later in the file is flattened at the end, as pbrt-v4 resolves names after parsing.
    void objectInstance(const Token& t) {
        requireWorld(t);
        const Token name = quoted(t, "an object name");
        if (openObject_) throw SceneError(t.where, "ObjectInstance inside an object definition");
        requireAffine(t.where);
        const auto it = objects_.find(name.text);
        if (it == objects_.end())
            laterInstances_.push_back({name, state_.ctm});
        else
            instantiate(it->second, state_.ctm, t.where);
    }

    void instantiateLaterObjects() {
        for (const LaterInstance& use : laterInstances_) {
            const auto it = objects_.find(use.name.text);
            if (it == objects_.end())
                throw SceneError(use.name.where, "unknown object \"" + use.name.text +
                                                     "\" (no ObjectBegin defines it)");
            instantiate(it->second, use.ctm, use.name.where);
        }
    }

    void instantiate(const ObjectDef& object, const Mat4& m, const SourceLocation& where) {
        for (const TriangleMeshDesc& src : object.meshes) {
            TriangleMeshDesc mesh = src;
            for (auto& p : mesh.positions)
                p = checkedPoint(m.point(p), where, "an instanced vertex position");
            const double det = m.det3();
            for (auto& n : mesh.normals)
                n = det != 0.0 ? checkedPoint(m.normal(n), where, "an instanced vertex normal")
                               : std::array<double, 3>{0, 0, 0};
            // A mirroring instance keeps each surface's side (its normal is transformed too).
            if (det < 0.0)
                for (size_t t = 0; t < mesh.triangles.size(); ++t)
                    mesh.reverseTriangle(t);
            scene_.meshes.push_back(std::move(mesh));
        }
        for (const SphereDesc& src : object.spheres) {
            const double scale = similarityScale(m, where);
            SphereDesc sp = src;
            sp.center = checkedPoint(m.point(src.center), where, "an instanced sphere centre");
            sp.radius = static_cast<float>(src.radius * scale);
            if (!(sp.radius > 0.f) || !std::isfinite(sp.radius))
                throw SceneError(where, "instanced sphere radius is not a positive float");
            // The instance's rotation after the definition's.
            for (int row = 0; row < 3; ++row)
                for (int c = 0; c < 3; ++c) {
                    double sum = 0.0;
                    for (int k = 0; k < 3; ++k)
                        sum += m(row, k) / scale * src.worldFromObject[size_t(k * 3 + c)];
                    sp.worldFromObject[size_t(row * 3 + c)] = sum;
                }
            scene_.spheres.push_back(sp);
        }
        for (const CurveDesc& src : object.curves) {
            const double scale = similarityScale(m, where, "an instanced curve's");
            CurveDesc c = src;
            for (auto& p : c.cp)
                p = checkedPoint(m.point(p), where, "an instanced curve's control point");
            for (auto& n : c.normals)
                n = unit(m.normal(n));
            c.width0 = float(src.width0 * scale);
            c.width1 = float(src.width1 * scale);
            requireCurveWidths(c, where);
            c.mirrored = src.mirrored != (m.det3() < 0.0);
            scene_.curves.push_back(c);
        }
    }

    void film(const Token& t) {
        requireOptions(t);
        if (haveFilm_) throw SceneError(t.where, "second Film directive");
        haveFilm_ = true;
        const Token type = quoted(t, "a film type");
        if (type.text != "rgb" && type.text != "gbuffer")
            throw SceneError(type.where, "unsupported film \"" + type.text +
                                             "\" (cbdpt supports \"rgb\" and \"gbuffer\")");
        ParamList pl = params("Film \"" + type.text + "\"");
        if (type.text == "gbuffer") {
            // pbrt-v4's GBufferFilm: the RGB film's image plus geometry channels.
            if (const Param* p = pl.peek("coordinatesystem")) {
                const std::string system = *pl.oneString("coordinatesystem");
                if (system != "camera" && system != "world")
                    throw SceneError(p->valueLoc(0), "unknown \"string coordinatesystem\" \"" +
                                                         system +
                                                         "\" (pbrt-v4 expects \"camera\" or "
                                                         "\"world\")");
            }
            note(type.where, "gbuffer",
                 "Film \"gbuffer\" renders as \"rgb\": the same image, without pbrt-v4's "
                 "G-buffer channels (albedo, normals, positions, depth)");
        }
        FilmDesc& f = scene_.film;
        for (const char* axis : {"xresolution", "yresolution"}) {
            const Param* p = pl.peek(axis);
            if (!p) continue;
            const int v = *pl.oneInt(axis);
            if (v < 1 || v > 65536)
                throw SceneError(p->where,
                                 std::string("\"integer ") + axis + "\" must be in [1, 65536]");
            (std::string(axis) == "xresolution" ? f.width : f.height) = v;
        }
        if (const Param* p = pl.peek("filename"); p) {
            f.filename = *pl.oneString("filename");
            if (f.filename.empty()) throw SceneError(p->where, "empty \"string filename\"");
        }
        if (const Param* p = pl.peek("sensor")) {
            const std::string sensor = *pl.oneString("sensor");
            if (sensor != "cie1931") {
                if (!findCameraSensor(sensor))
                    throw SceneError(p->valueLoc(0), "unknown sensor \"" + sensor +
                                                         "\" (cbdpt knows " + cameraSensorNames() +
                                                         ")");
                // A camera's response is spectral: the scene renders with the 16 bins.
                f.sensor = sensor;
                f.sensorWhere = p->valueLoc(0);
                scene_.usesSpectra = true;
            }
        }
        if (const Param* p = pl.peek("iso")) {
            f.iso = *pl.oneFloat("iso");
            if (!(f.iso > 0.0)) throw SceneError(p->where, "\"float iso\" must be > 0");
        }
        if (const Param* p = pl.peek("whitebalance")) {
            f.whiteBalance = *pl.oneFloat("whitebalance");
            if (f.whiteBalance != 0.0 && !(f.whiteBalance >= 1000.0 && f.whiteBalance <= 25000.0))
                throw SceneError(p->where,
                                 "\"float whitebalance\" must be 0 (none) or in [1000, 25000] K");
        }
        if (auto fp16 = pl.oneBool("savefp16")) {
            f.saveFp16 = *fp16;
            f.saveFp16Given = true;
        }
        filmWindow(pl, f);
        if (pl.ignore("diagonal", {"float"}))
            note(type.where, "diagonal",
                 "Film \"float diagonal\" is not used: only pbrt-v4's realistic camera reads the "
                 "sensor's size");
        if (const Param* p = pl.peek("maxcomponentvalue")) {
            // pbrt-v4 clamps each sample's sensor RGB to this largest component (its default,
            // infinity, cannot be written: the value must be a float).
            const double v = *pl.oneFloat("maxcomponentvalue");
            if (!(v > 0.0))
                throw SceneError(
                    p->valueLoc(0),
                    fmt::format("\"float maxcomponentvalue\" {:g} must be positive (it "
                                "is the largest sensor RGB component a sample keeps)",
                                v));
            f.maxComponentValue = v;
            note(p->where, "maxcomponentvalue",
                 fmt::format("Film \"float maxcomponentvalue\" {:g}: each sample is clamped as "
                             "pbrt-v4 clamps it, which biases the image (darker where samples "
                             "exceed it); render with --max-component-value inf for no clamp",
                             v));
        }
        pl.finish();
    }

    // pbrt-v4's "cropwindow" fractions, or its "pixelbounds" (which win over them, as pbrt-v4's
    // FilmBaseParameters): the pixels rendered, into an image of their size.
    static void filmWindow(ParamList& pl, FilmDesc& f) {
        const Param* crop = pl.numeric("cropwindow", "float", 4);
        const Param* bounds = pl.numeric("pixelbounds", "integer", 4);
        if (crop) {
            if (crop->size() != 4) pl.wrongCount(*crop, "4 values x0 x1 y0 y1");
            const auto& c = crop->numbers;
            f.cropWindow = std::array<double, 4>{c[0], c[1], c[2], c[3]};
        }
        if (bounds) {
            if (bounds->size() != 4) pl.wrongCount(*bounds, "4 values x0 x1 y0 y1");
            std::array<int, 4> b{};
            for (size_t i = 0; i < 4; ++i)
                b[i] = static_cast<int>(bounds->numbers[i]);
            if (!(0 <= b[0] && b[0] < b[1] && b[1] <= f.width && 0 <= b[2] && b[2] < b[3] &&
                  b[3] <= f.height))
                throw SceneError(bounds->where,
                                 fmt::format("\"integer pixelbounds\" {} {} {} {} must be x0 x1 "
                                             "y0 y1 with 0 <= x0 < x1 <= {} and 0 <= y0 < y1 <= {} "
                                             "(the film's resolution)",
                                             b[0], b[1], b[2], b[3], f.width, f.height));
            f.pixelBounds = b;
            f.cropWindow = std::array<double, 4>{double(b[0]) / f.width, double(b[1]) / f.width,
                                                 double(b[2]) / f.height, double(b[3]) / f.height};
        } else if (crop) {
            try {
                f.pixelBounds =
                    cropWindowPixels(f.width, f.height, *f.cropWindow, "\"float cropwindow\"");
            } catch (const std::invalid_argument& e) {
                throw SceneError(crop->where, e.what());
            }
        }
    }

    int findNamedMaterial(const std::string& name) const {
        for (size_t i = 0; i < scene_.materials.size(); ++i)
            if (!scene_.materials[i].name.empty() && scene_.materials[i].name == name)
                return static_cast<int>(i);
        return -1;
    }

    // ---- Media (pbrt-v4's MakeNamedMedium and MediumInterface) ----------------------------

    // The index in scene_.media of the medium `name` (-1 for "", vacuum), made on first mention:
    // pbrt-v4 resolves the names once the file is read, so a MediumInterface may come first.
    int mediumNamed(const Token& name) {
        if (name.text.empty()) return -1;
        const auto [it, added] = mediumIndex_.try_emplace(name.text, int(scene_.media.size()));
        if (added) {
            MediumDesc m;
            m.name = name.text;
            m.where = name.where;
            scene_.media.push_back(std::move(m));
        }
        return it->second;
    }

    // pbrt-v4's "homogeneous" and "uniformgrid" media, absorbing and scattering. Any other is
    // kept with the reason, an error only where something sits in it (checkMedia), as pbrt-v4
    // creates media that nothing uses without complaint.
    void makeNamedMedium(const Token& t) {
        const Token name = quoted(t, "a medium name");
        ParamList pl = params("MakeNamedMedium \"" + name.text + "\"", "medium");
        if (name.text.empty()) throw SceneError(name.where, "a medium's name must not be empty");
        MediumDesc& m = scene_.media[size_t(mediumNamed(name))];
        if (m.defined)
            throw SceneError(name.where, "named medium \"" + name.text +
                                             "\" is already defined (at " + m.where.str() + ")");
        m.defined = true;
        m.where = t.where;
        const std::optional<std::string> type = pl.oneString("type");
        if (!type)
            throw SceneError(t.where, "MakeNamedMedium \"" + name.text +
                                          "\" needs a \"string type\" parameter");
        const bool grid = *type == "uniformgrid", vdb = *type == "nanovdb";
        if (*type != "homogeneous" && !grid && !vdb) {
            m.unsupported = "is of type \"" + *type + "\"";
            pl.takeRest();
            pl.finish();
            return;
        }
        if (grid)
            gridMedium(t, pl, m);
        else if (vdb)
            nanoVdbMedium(t, pl, m);
        else if (const std::optional<std::string> preset = pl.oneString("preset"))
            m.unsupported = "names the measured \"preset\" \"" + *preset +
                            "\", whose table cbdpt does not have";
        if (auto sigmaA = pl.spectrum("sigma_a", SpectrumRole::Coefficient)) m.sigmaA = *sigmaA;
        if (auto sigmaS = pl.spectrum("sigma_s", SpectrumRole::Coefficient)) m.sigmaS = *sigmaS;
        if (const std::optional<SpectrumValue> le = pl.spectrum("Le", SpectrumRole::Emission);
            le && !isZero(*le) && m.unsupported.empty())
            m.unsupported = "emits (its \"Le\" is not 0)";
        pl.ignore("Lescale", {"float"});
        if (const Param* p = pl.peek("g")) {
            const double g = *pl.oneFloat("g");
            // The Henyey-Greenstein phase function has no density at |g| = 1.
            if (!(g > -1.0 && g < 1.0))
                throw SceneError(p->valueLoc(0),
                                 fmt::format("\"float g\" must be in (-1, 1), got {:g}", g));
            m.g = float(g);
        }
        if (const Param* p = pl.peek("scale")) {
            const double scale = *pl.oneFloat("scale");
            if (!(scale >= 0.0 && scale <= std::numeric_limits<float>::max()))
                throw SceneError(p->valueLoc(0),
                                 fmt::format("\"float scale\" must be >= 0, got {:g}", scale));
            m.scale = float(scale);
        }
        pl.finish();
    }

    // pbrt-v4's GridMedium::Create: "density" (nx ny nz values, x fastest) over the box "p0" to
    // "p1" of the medium's space (the CTM here). A "temperature" grid emits, which cbdpt does not
    // render; "Lescale" and the temperature's offset and scale only matter with emission.
    void gridMedium(const Token& t, ParamList& pl, MediumDesc& m) {
        const Param* density = pl.numeric("density", "float", 1);
        if (!density)
            throw SceneError(t.where, "MakeNamedMedium \"" + m.name +
                                          "\" of type \"uniformgrid\" needs \"float density\"");
        std::uint64_t count = 1;
        for (int axis = 0; axis < 3; ++axis) {
            const std::string name = std::string(1, "xyz"[axis]);
            const Param* p = pl.peek("n" + name);
            const int n = pl.oneInt("n" + name).value_or(1);
            if (n < 1)
                throw SceneError(
                    p->valueLoc(0),
                    fmt::format("\"integer n{}\" must be at least 1, got {}", name, n));
            m.samples[size_t(axis)] = n;
            count *= std::uint64_t(n);
        }
        if (density->size() != count)
            throw SceneError(density->where,
                             fmt::format("\"float density\" has {} values; nx x ny x nz = {} x {} "
                                         "x {} = {} expected",
                                         density->size(), m.samples[0], m.samples[1], m.samples[2],
                                         count));
        m.density.reserve(density->size());
        for (size_t i = 0; i < density->size(); ++i) {
            const double v = density->numbers[i];
            if (!(v >= 0.0 && v <= std::numeric_limits<float>::max()))
                throw SceneError(density->valueLoc(i),
                                 fmt::format("\"float density\" value {} is {:g}; a density must "
                                             "be finite and >= 0",
                                             i, v));
            m.density.push_back(float(v));
        }
        for (auto [name, value] : {std::pair{"p0", &m.p0}, std::pair{"p1", &m.p1}})
            if (const Param* p = pl.numeric(name, "point3", 3)) {
                if (p->size() != 3)
                    throw SceneError(p->where,
                                     "\"point3 " + std::string(name) + "\" expects 3 values");
                *value = {p->numbers[0], p->numbers[1], p->numbers[2]};
            }
        for (int axis = 0; axis < 3; ++axis) {
            const double lo = std::min(m.p0[size_t(axis)], m.p1[size_t(axis)]);
            const double hi = std::max(m.p0[size_t(axis)], m.p1[size_t(axis)]);
            if (!(hi > lo) || !std::isfinite(hi - lo))
                throw SceneError(t.where, fmt::format("medium \"{}\": its box \"p0\" to \"p1\" "
                                                      "has no extent along {} ({:g} to {:g})",
                                                      m.name, "xyz"[axis], lo, hi));
            m.p0[size_t(axis)] = lo;
            m.p1[size_t(axis)] = hi;
        }
        mediumSpace(t, m);
        if (pl.ignore("temperature", {"float"}) && m.unsupported.empty())
            m.unsupported = "emits (it has a \"temperature\" grid)";
        for (const char* unused : {"temperatureoffset", "temperaturecutoff", "temperaturescale"})
            pl.ignore(unused, {"float"});
    }

    // A grid medium's space: the CTM at its MakeNamedMedium.
    void mediumSpace(const Token& t, MediumDesc& m) const {
        const std::optional<Mat4> mediumFromWorld = inverse(state_.ctm);
        if (!mediumFromWorld || !mediumFromWorld->isAffine())
            throw SceneError(t.where, "medium \"" + m.name +
                                          "\" needs an invertible affine transform (the CTM here)");
        for (size_t i = 0; i < 12; ++i)
            m.mediumFromWorld[i] = mediumFromWorld->m[i];
    }

    // pbrt-v4's NanoVDBMedium::Create: the float grid "gridname" ("density") of the NanoVDB file
    // "filename", trilinear between the voxels' integer index points (NanoVDB's sampler), in the
    // medium's space through the grid's index-to-world map. It becomes a "uniformgrid" of those
    // points, the cells' centres, over indexMin - 0.5 to indexMax + 1.5, clipped half a sample
    // inside as pbrt-v4 clips the grid to its world bounds, indexMin to indexMax + 1. A
    // "temperaturename" grid emits, which cbdpt does not render.
    void nanoVdbMedium(const Token& t, ParamList& pl, MediumDesc& m) {
        const Param* fileParam = pl.peek("filename");
        const std::string file = fileParam ? *pl.oneString("filename") : std::string();
        if (file.empty())
            throw SceneError(t.where, "MakeNamedMedium \"" + m.name +
                                          "\" of type \"nanovdb\" needs \"string filename\"");
        const std::string gridName = pl.oneString("gridname").value_or("density");
        const std::string temperatureName = pl.oneString("temperaturename").value_or("temperature");
        for (const char* unused : {"temperatureoffset", "temperaturecutoff", "temperaturescale"})
            pl.ignore(unused, {"float"});
        const SourceLocation where = fileParam->valueLoc(0);
        const std::string path = findSceneFile(file, where, "NanoVDB file");
        NanoVdbGrid grid;
        try {
            const std::vector<std::string> names = nanoVdbGridNames(path);
            if (std::find(names.begin(), names.end(), temperatureName) != names.end()) {
                m.unsupported = "emits (its file holds a \"" + temperatureName + "\" grid)";
                return;
            }
            grid = readNanoVdbGrid(path, gridName);
        } catch (const std::runtime_error& e) {
            throw SceneError(where, e.what());
        }
        if (grid.background != 0.f)
            throw SceneError(where, fmt::format("{}: grid \"{}\" has the background value {:g}, a "
                                                "density everywhere outside its voxels; cbdpt's "
                                                "grid media are 0 outside their grid",
                                                path, gridName, grid.background));
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c) {
                const double v = grid.matrix[size_t(3 * r + c)];
                if (r == c ? !(v > 0.0) : v != 0.0)
                    throw SceneError(where,
                                     fmt::format("{}: grid \"{}\" turns or mirrors its "
                                                 "voxels (index-to-world matrix row {}: "
                                                 "{:g} {:g} {:g}); cbdpt takes grids "
                                                 "whose map only scales and translates",
                                                 path, gridName, r, grid.matrix[size_t(3 * r)],
                                                 grid.matrix[size_t(3 * r + 1)],
                                                 grid.matrix[size_t(3 * r + 2)]));
            }
        for (size_t i = 0; i < grid.values.size(); ++i)
            if (!(grid.values[i] >= 0.f && grid.values[i] <= std::numeric_limits<float>::max()))
                throw SceneError(where, fmt::format("{}: grid \"{}\" value {} is {:g}; a "
                                                    "density must be finite and >= 0",
                                                    path, gridName, i, grid.values[i]));
        const auto dims = grid.dims();
        for (size_t k = 0; k < 3; ++k) {
            const double scale = grid.matrix[4 * k], shift = grid.translation[k];
            m.samples[k] = dims[k];
            m.p0[k] = scale * (grid.indexMin[k] - 0.5) + shift;
            m.p1[k] = scale * (grid.indexMax[k] + 1.5) + shift;
        }
        m.density = std::move(grid.values);
        m.clipSamples = 0.5;
        mediumSpace(t, m);
    }

    static bool isZero(const SpectrumValue& s) {
        if (s.isRgb) return s.rgb == std::array<float, 3>{0.f, 0.f, 0.f};
        return std::all_of(s.samples.begin(), s.samples.end(),
                           [](const auto& sample) { return sample.second == 0.f; });
    }

    // pbrt-v4's MediumInterface "inside" "outside" (one name: both sides).
    void mediumInterface(const Token& t) {
        const Token inside = quoted(t, "a medium name (\"\" for none)");
        Token outside = inside;
        if (const std::optional<Token>& pk = peek(); pk && pk->quoted) outside = *next();
        state_.mediumInside = mediumNamed(inside);
        state_.mediumOutside = mediumNamed(outside);
    }

    // Medium `index` where a shape's side or the camera sits in it: recorded for checkMedia.
    int mediumUsed(int index, const SourceLocation& where, const char* user) {
        if (index >= 0) {
            MediumDesc& m = scene_.media[size_t(index)];
            if (!m.used) {
                m.firstUse = where;
                m.firstUser = user;
            }
            m.used = true;
        }
        return index;
    }

    // Lights other than area lights: cbdpt's sit in vacuum.
    void sitsInMedium(int index, const SourceLocation& where, const std::string& what) const {
        if (index < 0) return;
        throw SceneError(where, what + " inside the medium \"" + scene_.media[size_t(index)].name +
                                    "\" (its MediumInterface's outside) is not supported: only "
                                    "shapes and the camera may sit in cbdpt's media");
    }

    // Every medium a shape or the camera sits in is defined, and one cbdpt renders.
    void checkMedia() const {
        for (const MediumDesc& m : scene_.media) {
            if (!m.used) continue;
            if (!m.defined)
                throw SceneError(m.where, "unknown medium \"" + m.name +
                                              "\" (no MakeNamedMedium defines it; " + m.firstUser +
                                              " sits in it at " + m.firstUse.str() + ")");
            if (!m.unsupported.empty())
                throw SceneError(m.where, "medium \"" + m.name + "\" " + m.unsupported +
                                              ": cbdpt renders \"homogeneous\", "
                                              "\"uniformgrid\" and \"nanovdb\" media of "
                                              "\"sigma_a\" and "
                                              "\"sigma_s\" without \"Le\" (" +
                                              m.firstUser + " sits in it at " + m.firstUse.str() +
                                              ")");
        }
    }

    // A mesh's tangents beside an anisotropic material (or a mix with one): an error.
    void checkTangents() const {
        auto anisotropic = [&](int i) {
            return i >= 0 && (scene_.materials[size_t(i)].vRoughness.has_value() ||
                              scene_.materials[size_t(i)].kind == MaterialKind::Hair);
        };
        for (const TangentsBeside& t : tangentsBeside_) {
            const int m =
                t.material <= kLaterMaterial
                    ? findNamedMaterial(laterMaterials_[size_t(kLaterMaterial - t.material)].name)
                    : t.material;
            if (m < 0) continue;
            const auto leaves = mixLeaves(scene_, m);
            if (std::any_of(leaves.begin(), leaves.end(),
                            [&](const auto& leaf) { return anisotropic(leaf.first); }))
                throw SceneError(t.where, "\"vector3 S\" (tangents) with an anisotropic material "
                                          "is not supported (nor with hair): cbdpt turns its "
                                          "lobe with dp/du");
        }
    }

    // A mix's parts named before their MakeNamedMaterial. pbrt-v4 creates every material, used
    // or not, so a name nothing defines is an error even in a mix no shape uses.
    void resolveLaterMixParts() {
        for (const LaterMixPart& part : laterMixParts_) {
            const int idx = findNamedMaterial(part.name);
            if (idx < 0)
                throw SceneError(part.where, "unknown named material \"" + part.name +
                                                 "\" in mix (no MakeNamedMaterial defines it)");
            scene_.materials[static_cast<size_t>(part.mix)].mix[part.index] = idx;
        }
        // A part named before its definition can close a loop of mixes; mixLeaves names it.
        for (size_t i = 0; i < scene_.materials.size(); ++i)
            if (scene_.materials[i].kind == MaterialKind::Mix) mixLeaves(scene_, int(i));
    }

    // pbrt-v4's "interface" material, once every name is resolved: a shape of it emits nothing
    // (pbrt-v4 ignores its area light, with a warning), and a mix may not choose it (pbrt-v4
    // would skip the surface where it does: a stochastic cut-out cbdpt does not have).
    void checkInterfaces() {
        auto isInterface = [&](int material) {
            return material >= 0 &&
                   scene_.materials[size_t(material)].kind == MaterialKind::Interface;
        };
        for (const MaterialDesc& m : scene_.materials)
            if (m.kind == MaterialKind::Mix && (isInterface(m.mix[0]) || isInterface(m.mix[1])))
                throw SceneError(m.where, "a mix of an \"interface\" material is not supported "
                                          "(pbrt-v4 skips the surface where the mix chooses it)");
        auto dropLight = [&](int& areaLight, int material, const SourceLocation& where) {
            if (areaLight < 0 || !isInterface(material)) return;
            areaLight = -1;
            note(where, "interface-light",
                 "an area light on a shape of the \"interface\" material emits nothing (as in "
                 "pbrt-v4, which ignores it)");
        };
        for (TriangleMeshDesc& mesh : scene_.meshes)
            dropLight(mesh.areaLight, mesh.material, mesh.where);
        for (SphereDesc& sphere : scene_.spheres)
            dropLight(sphere.areaLight, sphere.material, sphere.where);
    }

    // pbrt-v4's "roughness", or "uroughness" and "vroughness" (defaulting to "roughness", which
    // defaults to 0; they may differ on a conductor or a dielectric, whose GGX lobe is then
    // anisotropic, not on a coat), and "remaproughness"; a coated conductor's names begin with
    // "interface." or "conductor.".
    void readRoughness(ParamList& pl, MaterialDesc& m, const std::string& prefix = "",
                       float MaterialDesc::*field = &MaterialDesc::roughness) {
        const std::string name = prefix + "roughness", uName = prefix + "uroughness",
                          vName = prefix + "vroughness";
        if (const int texture = roughnessTexture(pl, {name, uName, vName}); texture >= 0) {
            if (field != &MaterialDesc::roughness)
                throw SceneError(pl.peek(name) ? pl.peek(name)->where : pl.peek(uName)->where,
                                 "a texture as \"" + name +
                                     "\" is not supported (cbdpt reads a float texture as the "
                                     "roughness of a conductor, a dielectric or a coat)");
            m.roughnessTexture = texture;
            if (auto remap = pl.oneBool("remaproughness")) m.remapRoughness = *remap;
            return;
        }
        const Param* pr = pl.peek(name);
        const std::optional<double> rough = pl.oneFloat(name);
        const std::optional<double> ur = pl.oneFloat(uName);
        const std::optional<double> vr = pl.oneFloat(vName);
        // pbrt-v4: u/v roughness default to "roughness", which defaults to 0.
        const double u = ur ? *ur : (rough ? *rough : 0.0);
        const double v = vr ? *vr : (rough ? *rough : 0.0);
        if (rough && ur && vr)
            throw SceneError(pr->where, fmt::format("\"{}\" is overridden by \"{}\" and \"{}\"; "
                                                    "give one or the other",
                                                    name, uName, vName));
        const bool anisotropicLobe =
            field == &MaterialDesc::roughness &&
            (m.kind == MaterialKind::Conductor || m.kind == MaterialKind::Dielectric);
        if (u != v && !anisotropicLobe) {
            const Param* pu = pl.peek(ur ? uName : vName);
            throw SceneError(pu->where, fmt::format("anisotropic roughness ({} != {}) is not "
                                                    "supported on a coat (only on \"conductor\" "
                                                    "and \"dielectric\")",
                                                    uName, vName));
        }
        for (double value : {u, v})
            if (value < 0.0) {
                const Param* p = pl.peek(value == u ? (ur ? uName : name) : (vr ? vName : name));
                throw SceneError(p->where,
                                 fmt::format("{} must be >= 0, got {:g}", p->name, value));
            }
        m.*field = static_cast<float>(u);
        if (u != v) m.vRoughness = static_cast<float>(v);
        if (auto remap = pl.oneBool("remaproughness")) m.remapRoughness = *remap;
    }

    // pbrt-v4's "texture roughness" (or "texture uroughness" and "vroughness", which must name one
    // texture: cbdpt's lobes are isotropic): the float texture's index in scene_.textures, -1
    // where none of `names` is a texture. A number beside the texture is an error.
    int roughnessTexture(ParamList& pl, const std::array<std::string, 3>& names) {
        const Param* first = nullptr;
        std::string texture;
        for (const std::string& n : names) {
            const Param* p = pl.peek(n);
            if (!p || p->type != "texture") continue;
            const std::string t = *pl.oneTexture(n);
            if (first && t != texture)
                throw SceneError(p->where, "anisotropic roughness (\"" + first->name + "\" and \"" +
                                               n + "\" name two textures) is not supported");
            if (!first) first = p, texture = t;
        }
        if (!first) return -1;
        for (const std::string& n : names)
            if (const Param* p = pl.peek(n); p && p->type != "texture")
                throw SceneError(p->where, "\"" + n + "\" is a number beside the texture of \"" +
                                               first->name + "\"; give one or the other");
        return floatTextureBefore(texture, first->valueLoc(0), "roughness");
    }

    // The index in scene_.textures of float texture `name`, which a material's parameter `what`
    // names at `at`: it must be defined before the material, and of a class cbdpt reads.
    int floatTextureBefore(const std::string& name, const SourceLocation& at,
                           const std::string& what) {
        const auto it = floatTextures_.find(name);
        if (it == floatTextures_.end())
            throw SceneError(at, "no float texture \"" + name +
                                     "\" is defined before this material (cbdpt reads a texture " +
                                     what + " from a Texture defined before the material)");
        if (it->second.index < 0) throw SceneError(at, it->second.unsupported);
        return it->second.index;
    }

    // A dielectric's, thin dielectric's or coat's "float eta" (pbrt-v4's default 1.5; a coated
    // conductor's "interface.eta"). A (thin) dielectric also takes "spectrum eta", an index that
    // varies with wavelength (a named glass, pairs or a file: etaSpectrum), whose paths follow one
    // wavelength (pbrt-v4's TerminateSecondary; cb_bsdf.h, dispersionFollowOne); a coat's walk
    // has no such path.
    static void readEta(ParamList& pl, MaterialDesc& m, const std::string& name = "eta",
                        bool dispersive = false) {
        const Param* p = pl.peek(name);
        if (!p) return;
        if (p->type == "spectrum" && p->kind == Param::Kind::String && p->size() == 1 &&
            !dispersive)
            if (const NamedGlass* g = findNamedGlass(p->strings[0]))
                throw SceneError(p->valueLoc(0),
                                 fmt::format("\"{}\" is a dispersive index, which cbdpt's coats "
                                             "do not take (only \"dielectric\" and "
                                             "\"thindielectric\"); give \"float {}\" {} ({} at "
                                             "587.6 nm)",
                                             g->name, name, g->nd, g->glass));
        if (p->type == "spectrum" && dispersive) {
            m.etaSpectrum = pl.spectrum(name, SpectrumRole::DielectricIndex);
            return;
        }
        if (p->type == "spectrum" || p->type == "rgb" || p->type == "blackbody")
            throw SceneError(p->where,
                             dispersive ? fmt::format("a dielectric's \"{0}\" is \"float {0}\" or "
                                                      "\"spectrum {0}\", not {1}",
                                                      name, p->type)
                                        : fmt::format("spectrally varying dielectric \"{0}\" is "
                                                      "not supported on coats (their walk "
                                                      "carries every bin); give \"float {0}\"",
                                                      name));
        const double eta = *pl.oneFloat(name);
        if (!(eta > 0.0))
            throw SceneError(p->valueLoc(0),
                             fmt::format("\"float {}\" must be > 0, got {:g}", name, eta));
        m.eta = static_cast<float>(eta);
    }

    // A conductor's "reflectance", or its complex index "eta" + i "k" (pbrt-v4's
    // ConductorMaterial; a coated conductor's "conductor.eta" and "conductor.k").
    static void readConductorSpectra(ParamList& pl, MaterialDesc& m, const std::string& type,
                                     const std::string& prefix) {
        const std::string etaName = prefix + "eta", kName = prefix + "k";
        const Param* pEta = pl.peek(etaName);
        const Param* pK = pl.peek(kName);
        if (const Param* pr = pl.peek("reflectance"); pr && (pEta || pK))
            throw SceneError(pEta ? pEta->where : pK->where,
                             fmt::format("{} takes \"reflectance\" or \"{}\" and \"{}\", not both "
                                         "(as pbrt-v4)",
                                         type, etaName, kName));
        if (pEta || pK || !pl.peek("reflectance")) {
            // pbrt-v4's default for either: copper's measured spectra.
            m.conductorEta = pEta ? pl.spectrum(etaName, SpectrumRole::ConductorIndex)
                                  : pl.namedDefault("metal-Cu-eta");
            m.conductorK = pK ? pl.spectrum(kName, SpectrumRole::ConductorIndex)
                              : pl.namedDefault("metal-Cu-k");
        } else if (m.reflectanceTexture == -1) {
            m.reflectance = *pl.spectrum("reflectance", SpectrumRole::Reflectance);
        }
    }

    // pbrt-v4's "coateddiffuse": a diffuse base under a dielectric coat, smooth or rough, with a
    // layer between them that absorbs (cb_bsdf.h). cbdpt's layer does not scatter.
    void readCoatedDiffuse(ParamList& pl, MaterialDesc& m) {
        m.kind = MaterialKind::CoatedDiffuse;
        if (m.reflectanceTexture == -1)
            if (auto r = pl.spectrum("reflectance", SpectrumRole::Reflectance)) m.reflectance = *r;
        readEta(pl, m);
        readRoughness(pl, m);
        readLayer(pl, m);
    }

    // pbrt-v4's "coatedconductor": a conductor, smooth or rough, under a dielectric coat,
    // smooth or rough, the layer between them as coateddiffuse's.
    void readCoatedConductor(ParamList& pl, MaterialDesc& m) {
        m.kind = MaterialKind::CoatedConductor;
        readConductorSpectra(pl, m, "coatedconductor", "conductor.");
        readEta(pl, m, "interface.eta");
        readRoughness(pl, m, "interface.");
        readRoughness(pl, m, "conductor.", &MaterialDesc::baseRoughness);
        readLayer(pl, m);
    }

    // The layer of the coated materials: "thickness" (a number or a float texture, looked up
    // per hit), the walk's "maxdepth" and "nsamples", and the medium's "albedo" and "g".
    void readLayer(ParamList& pl, MaterialDesc& m) {
        if (const Param* p = pl.peek("thickness"); p && p->type == "texture") {
            m.thicknessTexture =
                floatTextureBefore(*pl.oneTexture("thickness"), p->valueLoc(0), "thickness");
        } else if (p) {
            const double t = *pl.oneFloat("thickness");
            if (!(t >= 0.0))
                throw SceneError(p->valueLoc(0),
                                 fmt::format("\"float thickness\" must be >= 0, got {:g}", t));
            m.thickness = static_cast<float>(t);
        }
        if (const Param* p = pl.peek("maxdepth")) {
            m.layerDepth = *pl.oneInt("maxdepth");
            if (m.layerDepth < 0 || m.layerDepth > 1000)
                throw SceneError(
                    p->valueLoc(0),
                    fmt::format("\"integer maxdepth\" must be in [0, 1000], got {}", m.layerDepth));
        }
        if (const Param* p = pl.peek("nsamples")) {
            m.layerSamples = *pl.oneInt("nsamples");
            if (m.layerSamples < 1 || m.layerSamples > 1000)
                throw SceneError(p->valueLoc(0),
                                 fmt::format("\"integer nsamples\" must be in [1, 1000], got {}",
                                             m.layerSamples));
        }
        // The layer scatters where its single-scattering albedo is not 0 (pbrt-v4's default),
        // by a Henyey-Greenstein phase function of asymmetry g, clamped to [-1, 1] as pbrt-v4
        // (the kernels keep it within 0.99, as pbrt-v4's phase function does).
        if (pl.peek("albedo")) {
            SpectrumValue albedo = *pl.spectrum("albedo", SpectrumRole::Reflectance);
            bool zero = albedo.isRgb ? albedo.rgb == std::array<float, 3>{0.f, 0.f, 0.f} : true;
            if (!albedo.isRgb)
                for (const auto& sample : albedo.samples)
                    zero = zero && sample.second == 0.f;
            if (!zero) m.layerAlbedo = std::move(albedo);
        }
        if (pl.peek("g")) {
            m.layerG = static_cast<float>(std::clamp(*pl.oneFloat("g"), -1.0, 1.0));
        }
    }

    // pbrt-v4's "hair" (HairMaterial::Create): the absorption from "sigma_a", else "reflectance"
    // (or "color"), else "eumelanin" and "pheomelanin" (eumelanin 1.3 where none of them is
    // given), the others ignored with a note as pbrt-v4 warns; "eta", "beta_m", "beta_n" and
    // "alpha". cbdpt's hair is the same at every point of the surface: a texture is an error,
    // but for a float texture of class "constant", which counts as its number.
    void readHair(ParamList& pl, MaterialDesc& m) {
        m.kind = MaterialKind::Hair;
        m.eta = 1.55f;
        auto number = [&](const std::string& name) -> std::optional<double> {
            const Param* p = pl.peek(name);
            if (!p || p->type != "texture") return pl.oneFloat(name);
            const std::string texture = *pl.oneTexture(name);
            const auto it = floatTextures_.find(texture);
            if (it == floatTextures_.end() || !it->second.constant)
                throw SceneError(p->valueLoc(0),
                                 "hair's \"texture " + name +
                                     "\" must name a float texture of "
                                     "class \"constant\" defined before the material (cbdpt's hair "
                                     "is the same at every point)");
            return *it->second.constant;
        };
        auto spectrum = [&](const std::string& name,
                            SpectrumRole role) -> std::optional<SpectrumValue> {
            if (const Param* p = pl.peek(name); p && p->type == "texture")
                throw SceneError(p->where, "a texture as hair's \"" + name +
                                               "\" is not supported (cbdpt's hair is the same at "
                                               "every point): give \"rgb " +
                                               name + "\" or \"spectrum " + name + "\"");
            return pl.spectrum(name, role);
        };
        std::optional<SpectrumValue> sigmaA = spectrum("sigma_a", SpectrumRole::Coefficient);
        std::optional<SpectrumValue> reflectance =
            spectrum("reflectance", SpectrumRole::Reflectance);
        if (!reflectance) reflectance = spectrum("color", SpectrumRole::Reflectance);
        const std::optional<double> eumelanin = number("eumelanin");
        const std::optional<double> pheomelanin = number("pheomelanin");
        const bool melanin = eumelanin || pheomelanin;
        if (sigmaA && (reflectance || melanin))
            note(m.where, "hair-ignored",
                 "hair given \"sigma_a\" ignores \"reflectance\", \"eumelanin\" and "
                 "\"pheomelanin\" (as pbrt-v4)");
        else if (reflectance && melanin)
            note(m.where, "hair-ignored",
                 "hair given \"reflectance\" ignores \"eumelanin\" and \"pheomelanin\" (as "
                 "pbrt-v4)");
        if (sigmaA) {
            m.hairSigmaA = std::move(sigmaA);
        } else if (reflectance) {
            m.hairReflectance = std::move(reflectance);
        } else {
            // HairBxDF::SigmaAFromConcentration: the pigments' absorption in sRGB per unit
            // concentration, negative concentrations taken as 0; brown-ish hair by default.
            const double ce = melanin ? std::max(eumelanin.value_or(0.0), 0.0) : 1.3;
            const double cp = melanin ? std::max(pheomelanin.value_or(0.0), 0.0) : 0.0;
            const std::array<double, 3> eu{0.419, 0.697, 1.37}, pheo{0.187, 0.4, 1.05};
            SpectrumValue s;
            for (size_t c = 0; c < 3; ++c)
                s.rgb[c] = static_cast<float>(ce * eu[c] + cp * pheo[c]);
            m.hairSigmaA = s;
        }
        if (const Param* p = pl.peek("eta")) {
            const double eta = *number("eta");
            if (!(eta > 0.0 && eta <= kMaxDielectricIndex))
                throw SceneError(p->valueLoc(0),
                                 fmt::format("hair's \"eta\" must be in (0, {:g}], got {:g}",
                                             kMaxDielectricIndex, eta));
            m.eta = static_cast<float>(eta);
        }
        if (auto b = number("beta_m")) m.hairBetaM = static_cast<float>(*b);
        if (auto b = number("beta_n")) m.hairBetaN = static_cast<float>(*b);
        if (auto a = number("alpha")) m.hairAlpha = static_cast<float>(*a);
    }

    int makeMaterial(const std::string& type, const SourceLocation& typeLoc, ParamList& pl,
                     const std::string& name, const SourceLocation& where) {
        MaterialDesc m;
        m.name = name;
        m.where = where;
        if (type == "diffuse" || type == "diffusetransmission" || type == "coateddiffuse" ||
            type == "coatedconductor")
            m.reflectanceTexture =
                spectrumTexture(pl, "reflectance", &MaterialDesc::reflectanceTexture);
        if (type == "diffuse") {
            m.kind = MaterialKind::Diffuse;
            if (m.reflectanceTexture == -1)
                if (auto r = pl.spectrum("reflectance", SpectrumRole::Reflectance))
                    m.reflectance = *r;
        } else if (type == "conductor") {
            m.kind = MaterialKind::Conductor;
            readConductorSpectra(pl, m, type, "");
            readRoughness(pl, m);
        } else if (type == "dielectric") {
            m.kind = MaterialKind::Dielectric;
            readEta(pl, m, "eta", true);
            readRoughness(pl, m);
        } else if (type == "thindielectric") {
            m.kind = MaterialKind::ThinDielectric;
            readEta(pl, m, "eta", true);
        } else if (type == "diffusetransmission") {
            m.kind = MaterialKind::DiffuseTransmission;
            m.reflectance = SpectrumValue::constant(0.25f); // pbrt-v4's defaults
            m.transmittanceTexture =
                spectrumTexture(pl, "transmittance", &MaterialDesc::transmittanceTexture);
            if (m.reflectanceTexture == -1)
                if (auto r = pl.spectrum("reflectance", SpectrumRole::Reflectance))
                    m.reflectance = *r;
            if (m.transmittanceTexture == -1)
                if (auto t = pl.spectrum("transmittance", SpectrumRole::Reflectance))
                    m.transmittance = *t;
            // Any scale, as in pbrt-v4: the products are clamped to [0, 1] (a negative scale
            // makes the surface black).
            if (pl.peek("scale")) m.scale = static_cast<float>(*pl.oneFloat("scale"));
        } else if (type == "coateddiffuse") {
            readCoatedDiffuse(pl, m);
        } else if (type == "coatedconductor") {
            readCoatedConductor(pl, m);
        } else if (type == "hair") {
            readHair(pl, m);
        } else if (type == "interface" || type == "none" || type.empty()) {
            // pbrt-v4 takes "none" and "" as "interface" (deprecated names, with a warning).
            m.kind = MaterialKind::Interface;
        } else if (type == "mix") {
            m.kind = MaterialKind::Mix;
            const Param* mats = pl.stringList("materials");
            if (!mats) throw SceneError(where, "mix needs \"string materials\" [ \"a\" \"b\" ]");
            if (mats->size() != 2)
                throw SceneError(mats->where, "\"string materials\" of a mix needs exactly 2 "
                                              "named materials, got " +
                                                  std::to_string(mats->size()));
            // pbrt-v4 creates materials after parsing: a name defined later is looked up then.
            const int self = static_cast<int>(scene_.materials.size());
            for (size_t i = 0; i < 2; ++i) {
                const int idx = findNamedMaterial(mats->strings[i]);
                if (idx < 0)
                    laterMixParts_.push_back({self, i, mats->strings[i], mats->valueLoc(i)});
                else
                    m.mix[i] = idx;
            }
            if (const Param* p = pl.peek("amount")) {
                const double a = *pl.oneFloat("amount");
                if (!(a >= 0.0 && a <= 1.0))
                    throw SceneError(p->where, "\"float amount\" must be in [0, 1]");
                m.amount = static_cast<float>(a);
            }
        } else {
            throw SceneError(typeLoc, "unsupported material type \"" + type +
                                          "\" (cbdpt supports diffuse, conductor, dielectric, "
                                          "thindielectric, diffusetransmission, coateddiffuse, "
                                          "coatedconductor, hair, mix, interface)");
        }
        // (pbrt-v4's hair reads neither map)
        if (type != "mix" && m.kind != MaterialKind::Interface && m.kind != MaterialKind::Hair) {
            m.normalMap = normalMap(pl);
            m.displacement = displacement(pl, m.normalMap >= 0);
        }
        pl.finish();
        scene_.materials.push_back(std::move(m));
        return static_cast<int>(scene_.materials.size()) - 1;
    }

    void areaLight(const Token& t) {
        const Token type = quoted(t, "an area light type");
        if (type.text != "diffuse")
            throw SceneError(type.where, "unsupported area light \"" + type.text +
                                             "\" (cbdpt supports \"diffuse\" only)");
        ParamList pl = params("AreaLightSource \"diffuse\"", "light");
        AreaLightDesc a;
        a.where = t.where;
        if (auto l = pl.spectrum("L", SpectrumRole::Emission)) a.radiance = *l;
        a.scale = static_cast<float>(scaleParam(pl) / photometric(a.radiance, pl.peek("L")));
        if (auto two = pl.oneBool("twosided")) a.twoSided = *two;
        // As pbrt-v4: per shape (each triangle of a mesh is one), <= 0 meaning none.
        if (auto power = pl.oneFloat("power")) a.power = std::max(*power, 0.0);
        pl.finish();
        scene_.areaLights.push_back(std::move(a));
        state_.areaLight = static_cast<int>(scene_.areaLights.size()) - 1;
    }

    // pbrt-v4's SpectrumToPhotometric divisor: a spectrum's luminance integral; 1 for an RGB
    // value, whose spectrum is taken as RGB times the illuminant at luminance 1 (see
    // SpectraTable::add in device_scene.cpp).
    static double photometric(const SpectrumValue& v, const Param* p) {
        if (v.isRgb) return 1.0;
        const double y = photometricIntegral(v.samples);
        if (!(y > 0.0))
            throw SceneError(p->where, "parameter " + p->decl() +
                                           " has zero luminance between 360 and 830 nm; pbrt-v4 "
                                           "divides light spectra by it");
        return y;
    }

    static double scaleParam(ParamList& pl) {
        const Param* p = pl.peek("scale");
        if (!p) return 1.0;
        const double s = *pl.oneFloat("scale");
        if (s < 0.0) throw SceneError(p->where, "\"float scale\" must be >= 0");
        return s;
    }

    void lightSource(const Token& t) {
        const Token type = quoted(t, "a light type");
        // pbrt-v4's light sits in the outside medium of its MediumInterface.
        sitsInMedium(state_.mediumOutside, t.where, "a LightSource");
        const bool spot = type.text == "spot";
        if (type.text == "distant") return distantLight(t);
        if (type.text == "infinite") return infiniteLight(t);
        if (type.text == "goniometric") return goniometricLight(t);
        if (type.text != "point" && !spot)
            throw SceneError(type.where, "unsupported light \"" + type.text +
                                             "\" (cbdpt supports \"point\", \"spot\", "
                                             "\"goniometric\", \"distant\" and \"infinite\")");
        ParamList pl = params("LightSource \"" + type.text + "\"", "light");
        double scale = 1.0;
        PointLightDesc l = pointLightIntensity(t, pl, scale);
        std::array<double, 3> from{0, 0, 0}, to{0, 0, 1};
        for (auto [name, value] : {std::pair{"from", &from}, std::pair{"to", &to}}) {
            if (!spot && std::string(name) == "to") continue;
            if (const Param* p = pl.numeric(name, "point3", 3)) {
                if (p->size() != 3)
                    throw SceneError(p->where,
                                     "\"point3 " + std::string(name) + "\" expects 3 values");
                *value = {p->numbers[0], p->numbers[1], p->numbers[2]};
            }
        }
        // pbrt-v4: "power" is the luminous power; a unit-scale point light emits 4 pi, a spot
        // 2 pi (1 - (cosStart + cosEnd) / 2).
        double solidAngle = 4.0 * M_PI;
        if (spot) {
            const double cone = pl.oneFloat("coneangle").value_or(30.0);
            const double delta = pl.oneFloat("conedeltaangle").value_or(5.0);
            if (!(cone > 0.0 && cone <= 180.0) || !(delta >= 0.0 && delta <= cone))
                throw SceneError(t.where, "spot light: \"coneangle\" must be in (0, 180] and "
                                          "\"conedeltaangle\" in [0, coneangle]");
            l.spot = true;
            l.spotCosEnd = static_cast<float>(std::cos(cone * M_PI / 180.0));
            l.spotCosStart = static_cast<float>(std::cos((cone - delta) * M_PI / 180.0));
            solidAngle = 2.0 * M_PI * (1.0 - 0.5 * (double(l.spotCosStart) + l.spotCosEnd));
            // The cone's angles are measured in the light's space; only a similarity keeps them.
            similarityScale(t.where, "a spot light's");
            const std::array<double, 3> d{to[0] - from[0], to[1] - from[1], to[2] - from[2]};
            const Mat4& m = state_.ctm;
            std::array<double, 3> axis{};
            for (int r = 0; r < 3; ++r)
                axis[r] = m(r, 0) * d[0] + m(r, 1) * d[1] + m(r, 2) * d[2];
            const double len = std::sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
            if (!(len > 0.0) || !std::isfinite(len))
                throw SceneError(t.where, "spot light: \"from\" and \"to\" must differ");
            for (double& c : axis)
                c /= len;
            l.spotAxis = axis;
        }
        if (const auto power = pl.oneFloat("power"); power && *power > 0.0)
            scale *= *power / solidAngle;
        l.scale = static_cast<float>(scale);
        pl.finish();
        requireAffine(t.where);
        const auto w = state_.ctm.point(from);
        l.position = checkedPoint(w, t.where, "light position");
        scene_.pointLights.push_back(std::move(l));
    }

    // A point light's "I" (default the illuminant) and, in *scale, its "scale" over I's
    // luminance integral, as pbrt-v4 normalises point, spot and goniometric lights.
    PointLightDesc pointLightIntensity(const Token& t, ParamList& pl, double& scale) {
        PointLightDesc l;
        l.where = t.where;
        if (auto i = pl.spectrum("I", SpectrumRole::Emission)) l.intensity = *i;
        scale = scaleParam(pl) / photometric(l.intensity, pl.peek("I"));
        return l;
    }

    // pbrt-v4's GoniometricLight::Create: a point light at the CTM's origin whose intensity I
    // (normalised to luminance 1) times scale is weighted by the image's pixel, the mean of its
    // R, G, B, in each direction of the light's frame: the CTM with y and z swapped, as pbrt-v4
    // swaps them. "power" over 4 pi times the pixels' mean.
    void goniometricLight(const Token& t) {
        ParamList pl = params("LightSource \"goniometric\"", "light");
        double scale = 1.0;
        PointLightDesc l = pointLightIntensity(t, pl, scale);
        const Param* fileParam = pl.peek("filename");
        const std::string file = fileParam ? *pl.oneString("filename") : std::string();
        if (file.empty())
            throw SceneError(t.where, "LightSource \"goniometric\" needs \"string filename\", "
                                      "the image of its emission (pbrt-v4 warns and emits "
                                      "nothing without one)");
        l.image = readLightImage(file, fileParam->valueLoc(0), "the goniometric light's");
        double sum = 0.0;
        for (size_t p = 0; 3 * p < l.image.rgb.size(); ++p)
            sum += (l.image.rgb[3 * p] + l.image.rgb[3 * p + 1] + l.image.rgb[3 * p + 2]) / 3.0;
        if (const Param* p = pl.peek("power")) {
            const double power = *pl.oneFloat("power");
            const double unitPower = 4.0 * M_PI * sum / (double(l.image.size) * l.image.size);
            if (power > 0.0 && !(unitPower > 0.0))
                throw SceneError(p->where, "\"float power\": the image \"" + l.image.path +
                                               "\" is black, so no scale gives it power");
            if (power > 0.0) scale *= power / unitPower;
        }
        l.scale = static_cast<float>(scale);
        pl.finish();
        const std::array<double, 9> r = rotationOfCtm(t.where, "a goniometric light's");
        for (size_t row = 0; row < 3; ++row) {
            l.worldFromLight[row * 3 + 0] = r[row * 3 + 0];
            l.worldFromLight[row * 3 + 1] = r[row * 3 + 2];
            l.worldFromLight[row * 3 + 2] = r[row * 3 + 1];
        }
        l.position = checkedPoint(state_.ctm.point({0, 0, 0}), t.where, "light position");
        scene_.pointLights.push_back(std::move(l));
    }

    // pbrt-v4's DistantLight::Create: L normalised to luminance 1, times scale, times
    // "illuminance" where given (the illuminance on a surface facing the light); the light shines
    // from the CTM applied to the vector from - to.
    void distantLight(const Token& t) {
        ParamList pl = params("LightSource \"distant\"", "light");
        DistantLightDesc l;
        l.where = t.where;
        if (auto v = pl.spectrum("L", SpectrumRole::Emission)) l.radiance = *v;
        double scale = scaleParam(pl) / photometric(l.radiance, pl.peek("L"));
        std::array<double, 3> from{0, 0, 0}, to{0, 0, 1};
        for (auto [name, value] : {std::pair{"from", &from}, std::pair{"to", &to}}) {
            if (const Param* p = pl.numeric(name, "point3", 3)) {
                if (p->size() != 3)
                    throw SceneError(p->where,
                                     "\"point3 " + std::string(name) + "\" expects 3 values");
                *value = {p->numbers[0], p->numbers[1], p->numbers[2]};
            }
        }
        if (const Param* p = pl.peek("illuminance")) {
            const double e = *pl.oneFloat("illuminance");
            if (e < 0.0) throw SceneError(p->where, "\"float illuminance\" must be >= 0");
            if (e > 0.0) scale *= e; // pbrt-v4 ignores values <= 0
        }
        l.scale = static_cast<float>(scale);
        pl.finish();
        requireAffine(t.where);
        const std::array<double, 3> d{from[0] - to[0], from[1] - to[1], from[2] - to[2]};
        const Mat4& m = state_.ctm;
        std::array<double, 3> w{};
        for (int r = 0; r < 3; ++r)
            w[r] = m(r, 0) * d[0] + m(r, 1) * d[1] + m(r, 2) * d[2];
        const double len = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
        if (!(len > 0.0) || !std::isfinite(len))
            throw SceneError(t.where, "distant light: \"from\" and \"to\" must differ (and the "
                                      "CTM must not collapse their difference)");
        for (double& c : w)
            c /= len;
        l.direction = w;
        scene_.distantLights.push_back(std::move(l));
    }

    // pbrt-v4's infinite light (Light::Create): UniformInfiniteLight, L normalised to luminance
    // 1, or with "string filename" ImageInfiniteLight, its RGB pixels emitting as "rgb L" does;
    // times scale, times illuminance over the light's illuminance at an upward-facing surface
    // (+z in the light's frame) where given.
    void infiniteLight(const Token& t) {
        ParamList pl = params("LightSource \"infinite\"", "light");
        InfiniteLightDesc l;
        l.where = t.where;
        if (const Param* p = pl.numeric("portal", "point3", 3)) l.portal = portalOf(*p);
        const Param* fileParam = pl.peek("filename");
        const std::string file = fileParam ? *pl.oneString("filename") : std::string();
        if (!file.empty()) {
            if (const Param* p = pl.peek("L"))
                throw SceneError(p->where, "LightSource \"infinite\" takes \"L\" or \"string "
                                           "filename\", not both (as pbrt-v4)");
            l.image = readLightImage(file, fileParam->valueLoc(0), "the infinite light's");
            l.worldFromLight = rotationOfCtm(t.where, "an image infinite light's");
        }
        if (auto v = pl.spectrum("L", SpectrumRole::Emission)) l.radiance = *v;
        double scale =
            scaleParam(pl) / (l.image.size > 0 ? 1.0 : photometric(l.radiance, pl.peek("L")));
        if (const Param* p = pl.peek("illuminance")) {
            const double e = *pl.oneFloat("illuminance");
            if (e < 0.0) throw SceneError(p->where, "\"float illuminance\" must be >= 0");
            // pbrt-v4 ignores values <= 0; a constant sky of luminance 1 gives pi.
            const double unitIlluminance = l.image.size > 0 ? imageIlluminance(l.image) : M_PI;
            if (e > 0.0 && !(unitIlluminance > 0.0))
                throw SceneError(p->where, "\"float illuminance\" " + fmt::format("{:g}", e) +
                                               ": the image \"" + l.image.path +
                                               "\" sends no light to an upward-facing surface "
                                               "(+z in the light's frame) to scale");
            if (e > 0.0) scale *= e / unitIlluminance;
        }
        l.scale = static_cast<float>(scale);
        pl.finish();
        if (!scene_.infiniteLights.empty())
            throw SceneError(t.where, "a second LightSource \"infinite\": cbdpt supports one "
                                      "(the first is at " +
                                          scene_.infiniteLights[0].where.str() + ")");
        scene_.infiniteLights.push_back(std::move(l));
    }

    // pbrt-v4's portal (PortalImageInfiniteLight): four corners in world space (not through the
    // CTM), a rectangle, p0 -> p1 and p0 -> p3 its edges; pbrt-v4 checks the edges' directions
    // to 0.001 and only warns, cbdpt refuses.
    static std::vector<std::array<double, 3>> portalOf(const Param& p) {
        if (p.size() != 12)
            throw SceneError(p.where, fmt::format("\"point3 portal\" expects 4 points (12 values), "
                                                  "got {}",
                                                  p.size()));
        std::vector<std::array<double, 3>> c = pointsOf(p);
        auto unit = [&](int from, int to) {
            const Vec3d e = vecSub(c[size_t(to)], c[size_t(from)]);
            const double length = std::sqrt(vecDot(e, e));
            if (!(length > 0.0) || !std::isfinite(length))
                throw SceneError(p.where, fmt::format("\"point3 portal\": corners {} and {} "
                                                      "coincide",
                                                      from, to));
            return Vec3d{e[0] / length, e[1] / length, e[2] / length};
        };
        const Vec3d p01 = unit(0, 1), p12 = unit(1, 2), p32 = unit(3, 2), p03 = unit(0, 3);
        if (std::fabs(vecDot(p01, p32) - 1.0) > 1e-3 || std::fabs(vecDot(p12, p03) - 1.0) > 1e-3 ||
            std::fabs(vecDot(p01, p12)) > 1e-3 || std::fabs(vecDot(p03, p01)) > 1e-3)
            throw SceneError(p.where, "\"point3 portal\" must be a rectangle p0 p1 p2 p3 (its "
                                      "opposite edges parallel, its corners right angles)");
        return c;
    }

    // The image of pbrt-v4's ImageInfiniteLight and GoniometricLight: square (its equal-area
    // map), finite values; `whose` names the light in errors ("the infinite light's").
    LightImage readLightImage(const std::string& file, const SourceLocation& where,
                              const std::string& whose) {
        const std::string path = findImageFile(file, where);
        RgbImage image = readImageAt(path, where);
        if (image.width != image.height || image.width < 1)
            throw SceneError(where, fmt::format("{} image {} is {} x {}; pbrt-v4's equal-area "
                                                "maps are square",
                                                whose, path, image.width, image.height));
        for (size_t i = 0; i < image.rgb.size(); ++i)
            if (!std::isfinite(image.rgb[i]))
                throw SceneError(where, fmt::format("{} image {} has a {} at pixel ({}, {}); a "
                                                    "light needs finite values",
                                                    whose, path, image.rgb[i],
                                                    (i / 3) % image.width, (i / 3) / image.width));
        LightImage out;
        out.path = path;
        out.size = image.width;
        out.rgb = std::move(image.rgb);
        return out;
    }

    // The path of image file `file` (relative to the scene file's folder, then the models'), an
    // error naming the places tried when there is none; the file joins the scene's sources.
    std::string findImageFile(const std::string& file, const SourceLocation& where) {
        return findSceneFile(file, where, "image file");
    }

    // The path of the `what` `file` a scene names, as findImageFile.
    std::string findSceneFile(const std::string& file, const SourceLocation& where,
                              const std::string& what) {
        const std::vector<std::string> candidates = nearbyPaths(file);
        auto found = std::find_if(candidates.begin(), candidates.end(),
                                  [](const std::string& c) { return fs::is_regular_file(c); });
        if (found == candidates.end()) {
            std::string tried;
            for (const std::string& c : candidates)
                tried += " " + c;
            throw SceneError(where, "no " + what + " \"" + file + "\" (tried" + tried + ")");
        }
        scene_.sourceFiles.push_back(*found);
        return *found;
    }

    static RgbImage readImageAt(const std::string& path, const SourceLocation& where,
                                ByteEncoding encoding = {}) {
        try {
            return readRgbImage(path, encoding);
        } catch (const std::exception& e) {
            throw SceneError(where, e.what());
        }
    }

    // pbrt-v4's Texture directive. A "spectrum" texture of class "imagemap" is read now (pbrt-v4's
    // ImageTexture), and "constant", "scale" (of a constant or of such a texture, by a constant),
    // "mix" (of two such, by a constant) and the 2D "checkerboard" of two constants become image
    // textures too; other textures are
    // recorded with why cbdpt cannot render them, an error only where a material uses one (files
    // often define textures they never use).
    void texture(const Token& t) {
        const Token name = quoted(t, "a texture name");
        const Token type = quoted(t, "a texture type (\"spectrum\" or \"float\")");
        const Token cls = quoted(t, "a texture class");
        if (type.text != "spectrum" && type.text != "float")
            throw SceneError(type.where, "texture type must be \"spectrum\" or \"float\", not \"" +
                                             type.text + "\"");
        ParamList pl = params("Texture \"" + name.text + "\"", "texture");
        auto& names = type.text == "spectrum" ? spectrumTextures_ : floatTextures_;
        if (auto it = names.find(name.text); it != names.end())
            throw SceneError(name.where, "texture \"" + name.text +
                                             "\" redefined (first defined at " +
                                             it->second.where.str() + ")");
        NamedTexture entry;
        entry.where = t.where;
        std::string why = "cbdpt renders \"spectrum\" textures of class \"imagemap\", "
                          "\"constant\", \"scale\", \"mix\", \"checkerboard\" and "
                          "\"directionmix\" only";
        std::optional<TextureDesc> made;
        if (type.text == "spectrum") made = spectrumTexture(cls.text, pl, name.text, t.where, why);
        if (type.text == "float") made = floatTexture(cls.text, pl, name.text, t.where, why);
        if (made) {
            if (type.text == "float" && cls.text == "constant") entry.constant = made->rgb[0];
            made->name = name.text;
            made->where = t.where;
            entry.index = int(scene_.textures.size());
            scene_.textures.push_back(std::move(*made));
        } else {
            entry.unsupported = "the " + type.text + " texture \"" + name.text + "\" of class \"" +
                                cls.text + "\" (" + t.where.str() + "): " + why;
            pl.takeRest();
        }
        names[name.text] = entry;
    }

    // A spectrum texture of class `cls` as an image texture, or none with *why set.
    std::optional<TextureDesc> spectrumTexture(const std::string& cls, ParamList& pl,
                                               const std::string& name, const SourceLocation& where,
                                               std::string& why) {
        if (cls == "imagemap") return readImageTexture(pl, name, where);
        if (cls == "constant") {
            std::optional<TextureDesc> tex = constantTexture(pl, "value", 1.f, why, false);
            if (tex) pl.finish();
            return tex;
        }
        if (cls == "scale") return scaledTexture(pl, why, false);
        if (cls == "mix") return mixTexture(pl, why, false);
        if (cls == "checkerboard") return checkerboardTexture(pl, why, false);
        if (cls == "directionmix") return directionMixTexture(pl, why, where);
        return std::nullopt;
    }

    // pbrt-v4's SpectrumDirectionMixTexture: |n . dir| tex1 + (1 - |n . dir|) tex2 at a hit of
    // geometric normal n, "vector3 dir" (0 1 0) taken by the CTM to world space and normalised;
    // the parts are textures or constants as a mix's, kept as images (the kernels mix per hit:
    // textureReflectance).
    std::optional<TextureDesc> directionMixTexture(ParamList& pl, std::string& why,
                                                   const SourceLocation& where) {
        std::array<double, 3> dir{0, 1, 0};
        SourceLocation dirWhere = where;
        if (const Param* p = pl.numeric("dir", "vector3", 3)) {
            if (p->size() != 3) throw SceneError(p->where, "\"vector3 dir\" expects 3 values");
            dir = {p->numbers[0], p->numbers[1], p->numbers[2]};
            dirWhere = p->where;
        }
        std::optional<TextureDesc> one = textureOperand(pl, "tex1", 0.f, why, false);
        if (!one) return std::nullopt;
        std::optional<TextureDesc> two = textureOperand(pl, "tex2", 1.f, why, false);
        if (!two) return std::nullopt;
        pl.finish();
        requireAffine(where);
        const Mat4& m = state_.ctm;
        std::array<double, 3> world{};
        for (int i = 0; i < 3; ++i)
            world[size_t(i)] = m(i, 0) * dir[0] + m(i, 1) * dir[1] + m(i, 2) * dir[2];
        const double length = std::sqrt(vecDot(world, world));
        if (!(length > 0.0) || !std::isfinite(length))
            throw SceneError(dirWhere, "\"vector3 dir\" must be a direction (not zero), also "
                                       "after the CTM");
        TextureDesc tex;
        for (size_t i = 0; i < 3; ++i)
            tex.mixDirection[i] = world[i] / length;
        tex.mixParts = {std::move(*one), std::move(*two)};
        return tex;
    }

    // A float texture of class `cls` as an image texture whose texels hold their value three
    // times (the kernels read the mean of the channels), or none with *why set: the classes of
    // spectrumTexture, their operands float textures and numbers.
    std::optional<TextureDesc> floatTexture(const std::string& cls, ParamList& pl,
                                            const std::string& name, const SourceLocation& where,
                                            std::string& why) {
        why = "cbdpt renders \"float\" textures of class \"imagemap\", \"constant\", \"scale\", "
              "\"mix\", \"checkerboard\", \"fbm\", \"wrinkled\" and \"windy\" only";
        if (cls == "imagemap") return readImageTexture(pl, name, where, true);
        if (cls == "fbm" || cls == "wrinkled" || cls == "windy")
            return noiseTexture(cls, pl, where);
        if (cls == "constant") {
            std::optional<TextureDesc> tex = constantTexture(pl, "value", 1.f, why, true);
            if (tex) pl.finish();
            return tex;
        }
        if (cls == "scale") return scaledTexture(pl, why, true);
        if (cls == "mix") return mixTexture(pl, why, true);
        if (cls == "checkerboard") return checkerboardTexture(pl, why, true);
        return std::nullopt;
    }

    // pbrt-v4's procedural float textures FBmTexture ("fbm"), WrinkledTexture ("wrinkled": its
    // turbulence) and WindyTexture, at the hit point in texture space, the inverse of the CTM
    // here (pbrt-v4's TextureMapping3D, which takes no "mapping" parameters). "octaves" (8) and
    // "roughness" (0.5) for the first two; windy has none.
    TextureDesc noiseTexture(const std::string& cls, ParamList& pl, const SourceLocation& where) {
        TextureDesc tex;
        tex.noise = cls == "fbm"        ? TextureDesc::Noise::Fbm
                    : cls == "wrinkled" ? TextureDesc::Noise::Wrinkled
                                        : TextureDesc::Noise::Windy;
        tex.mappingKind = TextureDesc::Mapping::Point;
        if (cls != "windy") {
            if (const Param* p = pl.peek("octaves")) {
                tex.octaves = *pl.oneInt("octaves");
                if (tex.octaves < 0 || tex.octaves > 32)
                    throw SceneError(p->valueLoc(0), fmt::format("\"integer octaves\" {} must be "
                                                                 "in [0, 32]",
                                                                 tex.octaves));
            }
            if (const Param* p = pl.peek("roughness")) {
                tex.omega = *pl.oneFloat("roughness");
                if (!(tex.omega >= 0.0 && tex.omega <= 1.0))
                    throw SceneError(p->valueLoc(0),
                                     fmt::format("\"float roughness\" {:g} (each octave's weight "
                                                 "over the last's) must be in [0, 1]",
                                                 tex.omega));
            }
        }
        const std::optional<Mat4> textureFromWorld = inverse(state_.ctm);
        if (!textureFromWorld || !textureFromWorld->isAffine())
            throw SceneError(where, "the \"" + cls +
                                        "\" texture needs an invertible affine transform (the "
                                        "CTM here)");
        for (size_t i = 0; i < 12; ++i)
            tex.textureFromWorld[i] = textureFromWorld->m[i];
        pl.finish();
        if (!textureFilteringDisabled_)
            note(where, "noise-octaves",
                 "pbrt-v4 drops the octaves of \"fbm\", \"wrinkled\" and \"windy\" textures "
                 "finer than each ray's footprint unless Option \"disabletexturefiltering\" is "
                 "true; cbdpt sums every octave, as pbrt-v4 does with that option");
        return tex;
    }

    // A 1 x 1 image texture of the constant `param` (default `fallback`): an RGB value, or for a
    // float texture (`isFloat`) a number held three times; none where the parameter is a texture
    // or a spectrum.
    std::optional<TextureDesc> constantTexture(ParamList& pl, const std::string& param,
                                               float fallback, std::string& why, bool isFloat) {
        if (const Param* p = pl.peek(param); p && p->type == "texture") {
            why = "its \"texture " + param + "\" is a texture, where cbdpt needs " +
                  (isFloat ? "a number" : "an RGB constant");
            return std::nullopt;
        }
        if (isFloat) {
            TextureDesc tex;
            tex.width = tex.height = 1;
            tex.rgb.assign(3, float(pl.oneFloat(param).value_or(fallback)));
            return tex;
        }
        SpectrumValue value = SpectrumValue::constant(fallback);
        if (auto v = pl.spectrum(param, SpectrumRole::Reflectance)) value = *v;
        if (!value.isRgb) {
            why = "its \"" + param + "\" is a spectrum, where cbdpt's textures hold RGB";
            return std::nullopt;
        }
        TextureDesc tex;
        tex.width = tex.height = 1;
        tex.rgb.assign(value.rgb.begin(), value.rgb.end());
        return tex;
    }

    // A texture's float parameter `param` (default `fallback`) where it is a constant; none, with
    // *why, where it names a float texture.
    static std::optional<double> constantFloat(ParamList& pl, const std::string& param,
                                               double fallback, std::string& why) {
        if (const Param* p = pl.peek(param); p && p->type == "texture") {
            why = "its \"texture " + param + "\" is a float texture, where cbdpt needs a constant";
            return std::nullopt;
        }
        return pl.peek(param) ? *pl.oneFloat(param) : fallback;
    }

    // pbrt-v4's SpectrumScaledTexture (FloatScaledTexture where isFloat): "tex" (a constant or a
    // texture cbdpt renders) times the constant "float scale", folded into the texels.
    std::optional<TextureDesc> scaledTexture(ParamList& pl, std::string& why, bool isFloat) {
        const std::optional<double> scale = constantFloat(pl, "scale", 1.0, why);
        if (!scale) return std::nullopt;
        std::optional<TextureDesc> tex = textureOperand(pl, "tex", 1.f, why, isFloat);
        if (!tex) return std::nullopt;
        pl.finish();
        for (float& v : tex->rgb) {
            v = static_cast<float>(*scale * v);
            if (!std::isfinite(v))
                throw SceneError(pl.peek("scale")->valueLoc(0),
                                 fmt::format("\"float scale\" {:g} takes a texel beyond the "
                                             "float range",
                                             *scale));
        }
        return tex;
    }

    // A texture's texture-valued parameter `param`: the named texture of its type (spectrum, or
    // float where isFloat; defined before, as pbrt-v4 creates textures in order), or its constant
    // as a 1 x 1 image (default `fallback`); none, with *why, where cbdpt cannot render it.
    std::optional<TextureDesc> textureOperand(ParamList& pl, const std::string& param,
                                              float fallback, std::string& why, bool isFloat) {
        const Param* p = pl.peek(param);
        if (!p || p->type != "texture") return constantTexture(pl, param, fallback, why, isFloat);
        const std::string inner = *pl.oneTexture(param);
        const auto& names = isFloat ? floatTextures_ : spectrumTextures_;
        auto it = names.find(inner);
        if (it == names.end())
            throw SceneError(p->valueLoc(0), "\"texture " + param + "\" names no " +
                                                 (isFloat ? "float" : "spectrum") + " texture \"" +
                                                 inner +
                                                 "\" (no Texture directive before it defines one)");
        if (it->second.index < 0) {
            why = "its \"texture " + param + "\" names " + it->second.unsupported;
            return std::nullopt;
        }
        const TextureDesc& tex = scene_.textures[size_t(it->second.index)];
        if (!tex.mixParts.empty()) {
            why = "its \"texture " + param + "\" names the \"directionmix\" \"" + inner +
                  "\", which cbdpt evaluates as a material's texture only, not inside another";
            return std::nullopt;
        }
        if (tex.noise != TextureDesc::Noise::None) {
            why = "its \"texture " + param + "\" names the procedural \"" + inner +
                  "\", which cbdpt evaluates as a material's texture only, not inside another";
            return std::nullopt;
        }
        return tex;
    }

    // pbrt-v4's MixTexture, (1 - amount) tex1 + amount tex2 for a constant "float amount",
    // folded into texels: two constants, an image and a constant (which mixes into each texel,
    // unless the image is black outside, where pbrt-v4 keeps the constant's share), or two
    // images of one layout (size, wrap, filter, mapping).
    std::optional<TextureDesc> mixTexture(ParamList& pl, std::string& why, bool isFloat) {
        const std::optional<double> amount = constantFloat(pl, "amount", 0.5, why);
        if (!amount) return std::nullopt;
        std::optional<TextureDesc> one = textureOperand(pl, "tex1", 0.f, why, isFloat);
        if (!one) return std::nullopt;
        std::optional<TextureDesc> two = textureOperand(pl, "tex2", 1.f, why, isFloat);
        if (!two) return std::nullopt;
        pl.finish();
        auto uniform = [](const TextureDesc& t) {
            return t.width == 1 && t.height == 1 && t.wrap != TextureDesc::Wrap::Black;
        };
        const bool oneUniform = uniform(*one), twoUniform = uniform(*two);
        TextureDesc out = oneUniform ? *two : *one; // the layout the result keeps
        if (!oneUniform && !twoUniform &&
            (one->width != two->width || one->height != two->height || one->wrap != two->wrap ||
             one->nearest != two->nearest || one->mapping != two->mapping ||
             one->mappingKind != two->mappingKind ||
             one->textureFromWorld != two->textureFromWorld)) {
            why = "it mixes two images of different sizes, wraps, filters or mappings";
            return std::nullopt;
        }
        if ((oneUniform != twoUniform) && out.wrap == TextureDesc::Wrap::Black) {
            why = "it mixes a constant into an image that is black outside itself";
            return std::nullopt;
        }
        for (size_t i = 0; i < out.rgb.size(); ++i) {
            const float a = one->rgb[oneUniform ? i % 3 : i];
            const float b = two->rgb[twoUniform ? i % 3 : i];
            out.rgb[i] = static_cast<float>((1.0 - *amount) * a + *amount * b);
        }
        return out;
    }

    // pbrt-v4's 2D "checkerboard" of the constants "tex1" (where floor(s) + floor(t) is even)
    // and "tex2": a 2 x 2 image looked up at the nearest texel, repeated every 2 (s, t).
    std::optional<TextureDesc> checkerboardTexture(ParamList& pl, std::string& why, bool isFloat) {
        if (pl.peek("dimension") && *pl.oneInt("dimension") != 2) {
            why = "it is three-dimensional, where cbdpt maps textures by (u, v)";
            return std::nullopt;
        }
        std::optional<TextureDesc> one = constantTexture(pl, "tex1", 1.f, why, isFloat);
        if (!one) return std::nullopt;
        std::optional<TextureDesc> two = constantTexture(pl, "tex2", 0.f, why, isFloat);
        if (!two) return std::nullopt;
        TextureDesc tex;
        readMapping(pl, tex);
        pl.finish();
        for (float& m : tex.mapping)
            m *= 0.5f;
        tex.width = tex.height = 2;
        tex.nearest = true;
        // Texel x is floor(s) mod 2; the top row (y = 0) has floor(t) odd (t runs up the image).
        for (const TextureDesc* texel : {&*two, &*one, &*one, &*two})
            tex.rgb.insert(tex.rgb.end(), texel->rgb.begin(), texel->rgb.end());
        return tex;
    }

    // pbrt-v4's texture mappings (TextureMapping2D::Create): "uv" with "uscale", "vscale",
    // "udelta", "vdelta"; "spherical" and "cylindrical" of the point in texture space, the
    // inverse of the CTM here; "planar" along "vector3 v1" (1 0 0) and "v2" (0 1 0) in texture
    // space, offset by "udelta" and "vdelta".
    void readMapping(ParamList& pl, TextureDesc& tex) {
        std::string kind = "uv";
        const Param* kindParam = pl.peek("mapping");
        if (kindParam) kind = *pl.oneString("mapping");
        if (kind == "uv") {
            const char* const mappingNames[] = {"uscale", "vscale", "udelta", "vdelta"};
            for (size_t i = 0; i < 4; ++i)
                if (pl.peek(mappingNames[i]))
                    tex.mapping[i] = static_cast<float>(*pl.oneFloat(mappingNames[i]));
            return;
        }
        if (kind != "spherical" && kind != "cylindrical" && kind != "planar")
            throw SceneError(kindParam->valueLoc(0),
                             "\"string mapping\" must be \"uv\", \"spherical\", \"cylindrical\" "
                             "or \"planar\", not \"" +
                                 kind + "\"");
        const std::optional<Mat4> textureFromWorld = inverse(state_.ctm);
        if (!textureFromWorld || !textureFromWorld->isAffine())
            throw SceneError(kindParam->valueLoc(0),
                             "texture mapping \"" + kind +
                                 "\" needs an invertible affine transform (the CTM here)");
        for (size_t i = 0; i < 12; ++i)
            tex.textureFromWorld[i] = textureFromWorld->m[i];
        if (kind == "spherical") {
            tex.mappingKind = TextureDesc::Mapping::Spherical;
        } else if (kind == "cylindrical") {
            tex.mappingKind = TextureDesc::Mapping::Cylindrical;
        } else {
            tex.mappingKind = TextureDesc::Mapping::Planar;
            std::array<double, 3> v1{1, 0, 0}, v2{0, 1, 0};
            for (auto [name, value] : {std::pair{"v1", &v1}, std::pair{"v2", &v2}})
                if (const Param* p = pl.numeric(name, "vector3", 3)) {
                    if (p->size() != 3)
                        throw SceneError(p->where,
                                         "\"vector3 " + std::string(name) + "\" expects 3 values");
                    *value = {p->numbers[0], p->numbers[1], p->numbers[2]};
                }
            // s = udelta + v1 . (M p): v1's row of M, and v2's, replace M's first two rows.
            std::array<double, 12> rows{};
            for (int j = 0; j < 4; ++j)
                for (int k = 0; k < 3; ++k) {
                    rows[size_t(j)] += v1[size_t(k)] * textureFromWorld->m[size_t(4 * k + j)];
                    rows[size_t(4 + j)] += v2[size_t(k)] * textureFromWorld->m[size_t(4 * k + j)];
                }
            tex.textureFromWorld = rows;
            for (size_t i = 2; i < 4; ++i) {
                const char* name = i == 2 ? "udelta" : "vdelta";
                if (pl.peek(name)) tex.mapping[i] = static_cast<float>(*pl.oneFloat(name));
            }
        }
    }

    // The parameters of pbrt-v4's "imagemap" and the image they name, "scale" and "invert"
    // applied to every texel (linear, so the same before or after bilinear interpolation).
    TextureDesc readImageTexture(ParamList& pl, const std::string& name,
                                 const SourceLocation& where, bool asFloat = false) {
        TextureDesc tex;
        tex.name = name;
        tex.where = where;
        const Param* fileParam = pl.peek("filename");
        const std::optional<std::string> file = pl.oneString("filename");
        if (!file)
            throw SceneError(where, "imagemap texture \"" + name + "\" needs \"string filename\"");
        ByteEncoding encoding;
        if (const Param* p = pl.peek("encoding")) {
            const std::string e = *pl.oneString("encoding");
            float gamma = 0.f;
            if (e == "linear") {
                encoding.srgb = false;
            } else if (e.rfind("gamma ", 0) == 0 &&
                       std::from_chars(e.data() + 6, e.data() + e.size(), gamma).ec ==
                           std::errc{} &&
                       gamma > 0.f && std::isfinite(gamma)) {
                encoding.srgb = false;
                encoding.gamma = gamma;
            } else if (e != "sRGB") {
                throw SceneError(p->valueLoc(0), "\"string encoding\" must be \"sRGB\", \"linear\" "
                                                 "or \"gamma <value > 0>\", not \"" +
                                                     e + "\"");
            }
        }
        const double scale = pl.peek("scale") ? *pl.oneFloat("scale") : 1.0;
        const bool invert = pl.oneBool("invert").value_or(false);
        if (const Param* p = pl.peek("filter")) {
            const std::string f = *pl.oneString("filter");
            if (f == "point") {
                tex.nearest = true;
            } else if (f != "bilinear" && f != "trilinear" && f != "ewa" && f != "EWA") {
                throw SceneError(p->valueLoc(0), "\"string filter\" must be \"bilinear\", "
                                                 "\"point\", \"trilinear\" or \"ewa\", not \"" +
                                                     f + "\"");
            }
        }
        pl.ignore("maxanisotropy", {"float"});
        // With the option, each of pbrt-v4's filters but "point" is bilinear at full resolution.
        if (!textureFilteringDisabled_)
            note(where, "texture-filter",
                 "pbrt-v4 filters image textures over each ray's footprint (MIP maps) unless "
                 "Option \"disabletexturefiltering\" is true; cbdpt looks them up at the hit "
                 "point (bilinear, or \"point\": the nearest texel) and antialiases by its pixel "
                 "samples, so where a texture is minified pbrt-v4's image is the blurrier");
        if (const Param* p = pl.peek("wrap")) {
            const std::string w = *pl.oneString("wrap");
            if (w == "black")
                tex.wrap = TextureDesc::Wrap::Black;
            else if (w == "clamp")
                tex.wrap = TextureDesc::Wrap::Clamp;
            else if (w != "repeat")
                throw SceneError(p->valueLoc(0), "\"string wrap\" must be \"repeat\", \"black\" or "
                                                 "\"clamp\" (cbdpt's), not \"" +
                                                     w + "\"");
        }
        readMapping(pl, tex);
        pl.finish();
        const SourceLocation fileWhere = fileParam->valueLoc(0);
        tex.path = findImageFile(*file, fileWhere);
        RgbImage image = readImageAt(tex.path, fileWhere, encoding);
        if (image.width < 1 || image.height < 1)
            throw SceneError(fileWhere, "texture image " + tex.path + " has no pixels");
        if (asFloat) {
            // pbrt-v4's float lookup of an image: its alpha channel where it has one that is not
            // all 1, else the mean of R, G and B (MIPMap::Bilerp<Float>); "point" reads R
            // (MIPMap::Texel<Float>), the alpha channel's file included.
            const bool useAlpha =
                !tex.nearest && std::any_of(image.alpha.begin(), image.alpha.end(),
                                            [](float a) { return a != 1.f; });
            for (size_t i = 0; i < image.rgb.size(); i += 3) {
                const float* texel = &image.rgb[i];
                const float v = tex.nearest ? texel[0]
                                : useAlpha  ? image.alpha[i / 3]
                                            : (texel[0] + texel[1] + texel[2]) / 3.f;
                std::fill_n(&image.rgb[i], 3, v);
            }
        }
        for (size_t i = 0; i < image.rgb.size(); ++i) {
            const double v = invert ? 1.0 - scale * image.rgb[i] : scale * image.rgb[i];
            if (!std::isfinite(image.rgb[i]) || !std::isfinite(float(v)))
                throw SceneError(fileWhere,
                                 fmt::format("texture image {} has {} at pixel ({}, {}) (times "
                                             "\"float scale\" {:g}); a texture needs finite values",
                                             tex.path, image.rgb[i], (i / 3) % size_t(image.width),
                                             (i / 3) / size_t(image.width), scale));
            image.rgb[i] = float(v);
        }
        tex.width = image.width;
        tex.height = image.height;
        tex.rgb = std::move(image.rgb);
        return tex;
    }

    // A material's "string normalmap" (pbrt-v4 reads the image linear, whatever its format): an
    // index into scene_.textures, one per file; -1 for none or "".
    int normalMap(ParamList& pl) {
        const Param* p = pl.peek("normalmap");
        if (!p) return -1;
        const std::string file = *pl.oneString("normalmap");
        if (file.empty()) return -1;
        const SourceLocation at = p->valueLoc(0);
        const std::string path = findImageFile(file, at);
        if (auto it = normalMaps_.find(path); it != normalMaps_.end()) return it->second;
        TextureDesc tex;
        tex.name = "normal map " + file;
        tex.where = at;
        tex.path = path;
        ByteEncoding linear;
        linear.srgb = false;
        RgbImage image = readImageAt(path, at, linear);
        if (image.width < 1 || image.height < 1)
            throw SceneError(at, "normal map " + path + " has no pixels");
        for (size_t i = 0; i < image.rgb.size(); ++i)
            if (!std::isfinite(image.rgb[i]))
                throw SceneError(at, fmt::format("normal map {} has {} at pixel ({}, {}); a "
                                                 "normal map needs finite values",
                                                 path, image.rgb[i], (i / 3) % size_t(image.width),
                                                 (i / 3) / size_t(image.width)));
        tex.width = image.width;
        tex.height = image.height;
        tex.rgb = std::move(image.rgb);
        scene_.textures.push_back(std::move(tex));
        const int index = int(scene_.textures.size()) - 1;
        normalMaps_.emplace(path, index);
        return index;
    }

    // A material's "displacement" (pbrt-v4's bump map): a float texture defined before the
    // material, or a constant (0: none); its index in scene_.textures, -1 for none. pbrt-v4 uses
    // a material's normal map instead where it has both (`hasNormalMap`), and so does cbdpt.
    int displacement(ParamList& pl, bool hasNormalMap) {
        const Param* p = pl.peek("displacement");
        if (!p) return -1;
        int index = -1;
        if (p->type == "texture") {
            const std::string name = *pl.oneTexture("displacement");
            const auto it = floatTextures_.find(name);
            if (it == floatTextures_.end())
                throw SceneError(p->valueLoc(0), "\"texture displacement\" names no float texture "
                                                 "\"" +
                                                     name +
                                                     "\" (cbdpt reads a displacement texture "
                                                     "defined before its material)");
            if (it->second.index < 0) throw SceneError(p->valueLoc(0), it->second.unsupported);
            index = it->second.index;
        } else if (const double d = *pl.oneFloat("displacement"); d != 0.0) {
            index = constantFloatTexture(d, p->valueLoc(0));
        }
        if (index >= 0 && !hasNormalMap && !textureFilteringDisabled_)
            note(p->where, "displacement-step",
                 "pbrt-v4 takes a displacement's slopes over each ray's footprint unless Option "
                 "\"disabletexturefiltering\" is true; cbdpt over 0.0005 in u and in v, as "
                 "pbrt-v4 does with that option");
        if (index < 0 || !hasNormalMap) return index;
        note(p->where, "displacement-normalmap",
             "a material with both a \"normalmap\" and a \"displacement\" is shaded by its "
             "normal map, as pbrt-v4 shades it; the displacement is not used");
        return -1;
    }

    // "texture reflectance" of diffuse, coated diffuse, diffuse transmission and coated conductor
    // materials, and "texture transmittance" of diffuse transmission (`param`): the named spectrum
    // texture's index in scene_.textures; -1 when the parameter is not a texture;
    // kLaterTexture for a name no Texture has defined yet, which pbrt-v4 looks up once the file
    // is read (resolveLaterTextures, into `field`).
    static constexpr int kLaterTexture = -2;
    int spectrumTexture(ParamList& pl, const std::string& param, int MaterialDesc::*field) {
        const Param* p = pl.peek(param);
        if (!p || p->type != "texture") return -1;
        const std::string name = *pl.oneTexture(param);
        if (!spectrumTextures_.count(name) && !floatTextures_.count(name)) {
            // makeMaterial adds this material next.
            laterTextures_.push_back(
                {int(scene_.materials.size()), field, param, name, p->valueLoc(0)});
            return kLaterTexture;
        }
        return namedSpectrumTexture(param, name, p->valueLoc(0));
    }

    int namedSpectrumTexture(const std::string& param, const std::string& name,
                             const SourceLocation& where) const {
        auto it = spectrumTextures_.find(name);
        if (it == spectrumTextures_.end()) {
            const bool isFloat = floatTextures_.count(name) != 0;
            throw SceneError(where, "\"texture " + param + "\" names " +
                                        (isFloat ? "a float texture \"" + name + "\"; a " + param +
                                                       " needs a \"spectrum\" texture"
                                                 : "no texture \"" + name +
                                                       "\" (no Texture directive defines it)"));
        }
        if (it->second.index < 0)
            throw SceneError(where, "\"texture " + param + "\" names " + it->second.unsupported);
        return it->second.index;
    }

    void resolveLaterTextures() {
        for (const LaterTexture& later : laterTextures_)
            scene_.materials[size_t(later.material)].*later.field =
                namedSpectrumTexture(later.param, later.name, later.where);
    }

    // The image's illuminance at a surface facing +z in the light's frame, per unit scale:
    // luminance times cos theta over the pixels whose centre lies above the horizon, each pixel
    // 4 pi / N^2 sr. (pbrt-v4 weighs each pixel 2 pi / N^2, which makes its image lights twice
    // as bright as the illuminance they are given.)
    static double imageIlluminance(const LightImage& image) {
        const int n = image.size;
        double sum = 0.0;
        for (int y = 0; y < n; ++y)
            for (int x = 0; x < n; ++x) {
                const cbk::Vec3 w = cbk::equalAreaSquareToSphere((float(x) + 0.5f) / float(n),
                                                                 (float(y) + 0.5f) / float(n));
                if (!(w.z > 0.f)) continue;
                const float* rgb = &image.rgb[3 * (size_t(y) * size_t(n) + size_t(x))];
                sum += rec709Luminance(rgb) * double(w.z);
            }
        return sum * 4.0 * M_PI / (double(n) * double(n));
    }

    // The CTM's linear part with its uniform scale divided out: directions in a light's frame
    // go to world by a rotation (a mirror allowed), which keeps the image map equal-area.
    std::array<double, 9> rotationOfCtm(const SourceLocation& where, const char* whose) const {
        const double scale = similarityScale(where, whose);
        const Mat4& m = state_.ctm;
        std::array<double, 9> r{};
        for (int row = 0; row < 3; ++row)
            for (int c = 0; c < 3; ++c)
                r[size_t(row * 3 + c)] = m(row, c) / scale;
        return r;
    }

    void requireAffine(const SourceLocation& where) const {
        if (!state_.ctm.isAffine())
            throw SceneError(where, "projective transformations are not supported (the CTM's "
                                    "bottom row is not 0 0 0 1)");
    }

    // World positions stay in double (see scene_desc.h) but must fit a float once made
    // camera-relative.
    static std::array<double, 3> checkedPoint(const std::array<double, 3>& v,
                                              const SourceLocation& where, const char* what) {
        for (double c : v)
            if (!std::isfinite(c) || std::fabs(c) > std::numeric_limits<float>::max())
                throw SceneError(where, std::string(what) + " is not finite after transformation");
        return v;
    }

    // A name NamedMaterial used before its MakeNamedMaterial: pbrt-v4 looks names up after
    // parsing, so shapes carry a placeholder (kLaterMaterial - k) until resolveLaterMaterials.
    int laterNamedMaterial(const Token& name) {
        for (size_t k = 0; k < laterMaterials_.size(); ++k)
            if (laterMaterials_[k].name == name.text) return kLaterMaterial - static_cast<int>(k);
        laterMaterials_.push_back({name.text, name.where});
        return kLaterMaterial - static_cast<int>(laterMaterials_.size() - 1);
    }

    void resolveLaterMaterials() {
        if (laterMaterials_.empty()) return;
        std::vector<int> resolved(laterMaterials_.size(), -1);
        auto resolve = [&](int& material) {
            if (material > kLaterMaterial) return;
            const size_t k = static_cast<size_t>(kLaterMaterial - material);
            if (resolved[k] < 0) {
                resolved[k] = findNamedMaterial(laterMaterials_[k].name);
                if (resolved[k] < 0)
                    throw SceneError(laterMaterials_[k].where,
                                     "unknown named material \"" + laterMaterials_[k].name +
                                         "\" (no MakeNamedMaterial defines it)");
            }
            material = resolved[k];
        };
        for (TriangleMeshDesc& mesh : scene_.meshes)
            resolve(mesh.material);
        for (SphereDesc& sphere : scene_.spheres)
            resolve(sphere.material);
    }

    int currentMaterial() {
        if (state_.material >= 0 || state_.material <= kLaterMaterial) return state_.material;
        if (defaultMaterial_ < 0) {
            // pbrt-v4's initial graphics state uses a "diffuse" material with reflectance 0.5.
            MaterialDesc m;
            m.kind = MaterialKind::Diffuse;
            scene_.materials.push_back(m);
            defaultMaterial_ = static_cast<int>(scene_.materials.size()) - 1;
        }
        return defaultMaterial_;
    }

    // Whether the current area light is given by "power", which needs each shape's area.
    bool poweredAreaLight() const {
        return state_.areaLight >= 0 && scene_.areaLights[size_t(state_.areaLight)].power > 0.0;
    }

    // A 1 x 1 float texture of `value` (a constant alpha or displacement), one per value: its
    // index in scene_.textures.
    int constantFloatTexture(double value, const SourceLocation& where) {
        auto [at, added] = constantFloatTextures_.try_emplace(value, -1);
        if (added) {
            TextureDesc tex;
            tex.name = fmt::format("constant {:g}", value);
            tex.where = where;
            tex.width = tex.height = 1;
            tex.rgb.assign(3, float(value));
            at->second = int(scene_.textures.size());
            scene_.textures.push_back(std::move(tex));
        }
        return at->second;
    }

    // A shape's "alpha" (pbrt-v4's GeometricPrimitive), a float or a float texture: where it is
    // 1 a hit counts, where 0 the hit is skipped, between it counts at random with that
    // probability (stochastic transparency). A constant >= 1 is opaque (the default); one <= 0
    // skips every hit, so the shape is `hidden` (not added), unless it is an area light's: then
    // it is `invisible`, a light that light sampling reaches and no ray finds (pbrt-v4's
    // DiffuseAreaLight of alpha 0). A float texture of class "constant" counts as its number, as
    // pbrt-v4 tells its FloatConstantTexture apart. Otherwise `texture` indexes the alpha texture
    // in scene_.textures, a 1 x 1 one for a constant.
    struct ShapeAlpha {
        bool hidden = false;
        bool invisible = false;
        int texture = -1;
    };
    ShapeAlpha shapeAlpha(ParamList& pl, const Token& t, const char* shapeKind) {
        const Param* p = pl.peek("alpha");
        if (!p) return {};
        ShapeAlpha out;
        std::optional<double> constant;
        if (p->type == "texture") {
            const std::string name = *pl.oneTexture("alpha");
            const auto it = floatTextures_.find(name);
            if (it == floatTextures_.end())
                throw SceneError(p->valueLoc(0),
                                 "\"texture alpha\" names no float texture \"" + name +
                                     "\" (cbdpt reads an alpha texture defined before its shape)");
            if (it->second.index < 0) throw SceneError(p->valueLoc(0), it->second.unsupported);
            constant = it->second.constant;
            out.texture = it->second.index;
        } else {
            constant = *pl.oneFloat("alpha");
        }
        if (constant) {
            const double alpha = *constant;
            if (alpha >= 1.0) return {};
            if (alpha <= 0.0 && state_.areaLight >= 0) {
                note(t.where, "alpha-zero-light",
                     "an area light's shape of alpha 0 is an invisible light (as in "
                     "pbrt-v4): it lights the scene, and rays pass through it");
                return {false, true, -1};
            }
            if (alpha <= 0.0) {
                note(t.where, "alpha-zero",
                     "a shape of alpha 0 is invisible (pbrt-v4 skips its hits): not "
                     "added");
                return {true, false, -1};
            }
            out.texture = constantFloatTexture(alpha, p->valueLoc(0));
        }
        if (shapeKind)
            throw SceneError(p->valueLoc(0),
                             std::string("an \"alpha\" below 1 on a ") + shapeKind +
                                 " is not supported: cbdpt tests alpha on triangles (meshes, "
                                 "PLY meshes, bilinear patches and disks) only");
        return out;
    }

    void shape(const Token& t) {
        const Token type = quoted(t, "a shape type");
        if (type.text == "sphere") {
            ParamList pl = params("Shape \"sphere\"", "shape");
            double radius = 1.0;
            if (const Param* p = pl.peek("radius")) {
                radius = *pl.oneFloat("radius");
                if (!(radius > 0.0)) throw SceneError(p->where, "\"float radius\" must be > 0");
            }
            const ShapeAlpha alpha = shapeAlpha(pl, t, "sphere");
            pl.finish();
            if (!alpha.hidden) sphere(t.where, radius, alpha.invisible);
        } else if (type.text == "trianglemesh") {
            ParamList pl = params("Shape \"trianglemesh\"", "shape");
            const Param* P = pl.numeric("P", "point3", 3);
            if (!P) throw SceneError(t.where, "trianglemesh needs \"point3 P\"");
            const size_t nv = P->size() / 3;
            const std::vector<std::array<double, 3>> pos = pointsOf(*P);
            std::vector<std::array<unsigned, 3>> tris;
            if (const Param* I = pl.numeric("indices", "integer", 3)) {
                tris = indicesOf<3>(*I, nv);
            } else {
                if (nv != 3)
                    throw SceneError(t.where, "\"integer indices\" may only be omitted for a "
                                              "single triangle (exactly 3 vertices); got " +
                                                  std::to_string(nv));
                tris.push_back({0u, 1u, 2u});
            }
            const std::vector<std::array<double, 3>> normals = vertexNormals(pl, nv);
            std::vector<std::array<float, 6>> cornerUv = cornersOf(tris, vertexTexCoords(pl, nv));
            ignoreTangents(pl, t.where);
            const ShapeAlpha alpha = shapeAlpha(pl, t, nullptr);
            pl.finish();
            if (!alpha.hidden)
                addMesh(t.where, pos, std::move(tris), normals, {}, std::move(cornerUv), {}, alpha);
        } else if (type.text == "bilinearmesh") {
            bilinearMesh(t);
        } else if (type.text == "loopsubdiv") {
            loopSubdivision(t);
        } else if (type.text == "disk") {
            disk(t);
        } else if (type.text == "cylinder") {
            cylinder(t);
        } else if (type.text == "curve") {
            curve(t);
        } else if (type.text == "plymesh") {
            ParamList pl = params("Shape \"plymesh\"", "shape");
            const Param* fp = pl.peek("filename");
            const std::optional<std::string> file = pl.oneString("filename");
            if (!file) throw SceneError(t.where, "plymesh needs \"string filename\"");
            const ShapeAlpha alpha = shapeAlpha(pl, t, nullptr);
            pl.finish();
            if (alpha.hidden) return;
            const std::string path = resolveModel(*file, fp->valueLoc(0));
            scene_.sourceFiles.push_back(path);
            PlyMesh ply;
            try {
                ply = readPly(path);
            } catch (const SceneError& e) {
                throw SceneError(t.where, "cannot load plymesh: " + std::string(e.what()));
            }
            if (ply.skippedFaces > 0)
                note(t.where, "ply-faces:" + path,
                     "plymesh \"" + path + "\": skipped " + std::to_string(ply.skippedFaces) +
                         (ply.skippedFaces == 1 ? " face" : " faces") +
                         " of more than 4 vertices, as pbrt-v4 does (it reads triangles and "
                         "quads only)");
            std::vector<std::array<double, 3>> pos(ply.positions.size());
            for (size_t i = 0; i < pos.size(); ++i)
                pos[i] = {ply.positions[i][0], ply.positions[i][1], ply.positions[i][2]};
            std::vector<std::array<double, 3>> normals(ply.normals.size());
            for (size_t i = 0; i < normals.size(); ++i)
                normals[i] = {ply.normals[i][0], ply.normals[i][1], ply.normals[i][2]};
            std::vector<std::array<float, 6>> cornerUv = cornersOf(ply.triangles, ply.uv);
            addMesh(t.where, pos, std::move(ply.triangles), normals, {}, std::move(cornerUv), {},
                    alpha);
        } else {
            throw SceneError(type.where, "unsupported shape \"" + type.text +
                                             "\" (cbdpt supports trianglemesh, bilinearmesh "
                                             "(planar patches), plymesh, loopsubdiv, sphere, "
                                             "disk, cylinder, curve)");
        }
    }

    // "vector3 S" only turns shading frames about their normal, which changes only anisotropic
    // materials: cbdpt's turn with dp/du, so S beside one is an error (checkTangents, once every
    // material is known).
    void ignoreTangents(ParamList& pl, const SourceLocation& where) {
        const Param* tangents = pl.peek("S");
        if (!pl.ignore("S", {"vector3"})) return;
        tangentsBeside_.push_back({currentMaterial(), tangents->where});
        note(where, "tangents",
             "\"vector3 S\" is ignored: it turns the shading frame about its normal, which "
             "changes none of cbdpt's isotropic materials (anisotropic ones turn with dp/du)");
    }

    // "point2 uv": texture coordinates, one (u, v) per vertex; empty when not given.
    static std::vector<std::array<float, 2>> vertexTexCoords(ParamList& pl, size_t vertexCount) {
        const Param* uv = pl.numeric("uv", "point2", 2);
        if (!uv) return {};
        if (uv->size() != 2 * vertexCount)
            throw SceneError(uv->where, fmt::format("\"point2 uv\" needs one (u, v) per vertex "
                                                    "({}), got {}",
                                                    vertexCount, uv->size() / 2));
        std::vector<std::array<float, 2>> out(vertexCount);
        for (size_t i = 0; i < uv->size(); ++i) {
            const float v = static_cast<float>(uv->numbers[i]);
            if (!std::isfinite(v))
                throw SceneError(uv->valueLoc(i), "texture coordinate " +
                                                      fmt::format("{:g}", uv->numbers[i]) +
                                                      " is not a finite float");
            out[i / 2][i % 2] = v;
        }
        return out;
    }

    // Each triangle's corners' (u, v) from per-vertex ones; empty when there are none.
    static std::vector<std::array<float, 6>>
    cornersOf(const std::vector<std::array<unsigned, 3>>& tris,
              const std::vector<std::array<float, 2>>& uv) {
        if (uv.empty()) return {};
        std::vector<std::array<float, 6>> out(tris.size());
        for (size_t t = 0; t < tris.size(); ++t)
            for (size_t k = 0; k < 3; ++k) {
                out[t][2 * k] = uv[tris[t][k]][0];
                out[t][2 * k + 1] = uv[tris[t][k]][1];
            }
        return out;
    }

    static std::vector<std::array<double, 3>> pointsOf(const Param& P) {
        std::vector<std::array<double, 3>> out(P.size() / 3);
        for (size_t i = 0; i < out.size(); ++i)
            out[i] = {P.numbers[3 * i], P.numbers[3 * i + 1], P.numbers[3 * i + 2]};
        return out;
    }

    // A mesh's "integer indices", K per triangle or patch, each checked against its vertex count.
    template <size_t K>
    static std::vector<std::array<unsigned, K>> indicesOf(const Param& I, size_t vertices) {
        std::vector<std::array<unsigned, K>> out(I.size() / K);
        for (size_t i = 0; i < I.size(); ++i) {
            const double v = I.numbers[i];
            if (v < 0 || v >= static_cast<double>(vertices))
                throw SceneError(I.valueLoc(i), "index " +
                                                    std::to_string(static_cast<long long>(v)) +
                                                    " out of range (the mesh has " +
                                                    std::to_string(vertices) + " vertices)");
            out[i / K][i % K] = static_cast<unsigned>(v);
        }
        return out;
    }

    // "normal N": one normal per vertex; empty when not given.
    static std::vector<std::array<double, 3>> vertexNormals(ParamList& pl, size_t vertexCount) {
        const Param* N = pl.numeric("N", "normal", 3);
        if (!N) return {};
        if (N->size() != 3 * vertexCount)
            throw SceneError(N->where, "\"normal N\" needs one normal per vertex (" +
                                           std::to_string(vertexCount) + "), got " +
                                           std::to_string(N->size() / 3));
        return pointsOf(*N);
    }

    // pbrt-v4's "loopsubdiv": its control mesh subdivided "levels" times (pbrt-v4's default 3),
    // each vertex then on the limit surface with the surface's normal, which shades it
    // (loop_subdivision.h); (u, v) and alpha as a triangle mesh's without "uv".
    void loopSubdivision(const Token& t) {
        ParamList pl = params("Shape \"loopsubdiv\"", "shape");
        const Param* P = pl.numeric("P", "point3", 3);
        if (!P) throw SceneError(t.where, "loopsubdiv needs \"point3 P\"");
        const Param* I = pl.numeric("indices", "integer", 3);
        if (!I) throw SceneError(t.where, "loopsubdiv needs \"integer indices\"");
        const std::vector<std::array<unsigned, 3>> control = indicesOf<3>(*I, P->size() / 3);
        int levels = 3;
        if (const Param* p = pl.peek("levels")) {
            levels = *pl.oneInt("levels");
            if (levels < 0)
                throw SceneError(p->valueLoc(0),
                                 fmt::format("\"integer levels\" must be >= 0, got {}", levels));
            const double made = loopSubdividedTriangles(control.size(), levels);
            if (made > kMaxSubdividedTriangles)
                throw SceneError(p->valueLoc(0),
                                 fmt::format("\"integer levels\" {} makes {:g} triangles; cbdpt "
                                             "subdivides into at most {:g}",
                                             levels, made, kMaxSubdividedTriangles));
        }
        if (const Param* p = pl.peek("scheme")) {
            const std::string scheme = *pl.oneString("scheme");
            if (scheme != "loop")
                note(p->valueLoc(0), "loopsubdiv-scheme",
                     "loopsubdiv \"scheme\" \"" + scheme +
                         "\" is subdivided by Loop's rules, as pbrt-v4 does whatever it says");
        }
        const ShapeAlpha alpha = shapeAlpha(pl, t, nullptr);
        pl.finish();
        if (alpha.hidden) return;
        SubdivisionSurface surface;
        try {
            surface = loopSubdivide(pointsOf(*P), control, levels);
        } catch (const std::invalid_argument& e) {
            throw SceneError(t.where, std::string("loopsubdiv: ") + e.what());
        }
        addMesh(t.where, surface.positions, std::move(surface.triangles), surface.normals, {}, {},
                {}, alpha);
    }

    // pbrt-v4's bilinear patches (p00, p10, p01, p11). A planar patch is exactly the two triangles
    // (p00, p10, p11) and (p00, p11, p01), whose winding normal is pbrt's cross(dpdu, dpdv); a
    // curved one is not representable with triangles and is an error.
    void bilinearMesh(const Token& t) {
        ParamList pl = params("Shape \"bilinearmesh\"", "shape");
        const Param* P = pl.numeric("P", "point3", 3);
        if (!P) throw SceneError(t.where, "bilinearmesh needs \"point3 P\"");
        const size_t nv = P->size() / 3;
        const std::vector<std::array<double, 3>> pos = pointsOf(*P);
        std::vector<std::array<unsigned, 4>> patches;
        if (const Param* I = pl.numeric("indices", "integer", 4)) {
            patches = indicesOf<4>(*I, nv);
        } else {
            if (nv != 4)
                throw SceneError(t.where, "\"integer indices\" may only be omitted for a single "
                                          "patch (exactly 4 vertices); got " +
                                              std::to_string(nv));
            patches.push_back({0u, 1u, 2u, 3u});
        }
        const std::vector<std::array<double, 3>> normals = vertexNormals(pl, nv);
        // pbrt-v4's patch (u, v) at p00, p10, p01, p11 when "uv" is not given.
        std::vector<std::array<float, 2>> uv = vertexTexCoords(pl, nv);
        ignoreTangents(pl, t.where);
        const ShapeAlpha alpha = shapeAlpha(pl, t, nullptr);
        pl.finish();
        std::vector<std::array<unsigned, 3>> tris;
        std::vector<std::array<float, 6>> cornerUv;
        std::string noTexCoords;
        std::vector<double> patchArea; // per triangle
        for (const auto& q : patches) {
            const auto &p00 = pos[q[0]], &p10 = pos[q[1]], &p01 = pos[q[2]], &p11 = pos[q[3]];
            // Planar when p11 lies in the plane of the other three (relative to the patch size).
            const Vec3d a = vecSub(p10, p00), b = vecSub(p01, p00), c = vecSub(p11, p00);
            const Vec3d n = vecCross(a, b);
            if (std::fabs(vecDot(n, c)) > 1e-6 * std::sqrt(vecDot(n, n)) * std::sqrt(vecDot(c, c)))
                throw SceneError(t.where, "a curved (non-planar) bilinear patch is not supported; "
                                          "cbdpt renders planar patches only");
            // A planar patch's cross(dpdu, dpdv) is bilinear in (u, v), so it keeps one side
            // everywhere iff it does at the four corners; otherwise (a bowtie, or a non-convex
            // quadrilateral) pbrt-v4's surface folds over itself and two triangles are not it.
            const Vec3d d = vecSub(p11, p01), e = vecSub(p11, p10);
            const Vec3d corners[4] = {n, vecCross(a, e), vecCross(d, b), vecCross(d, e)};
            const Vec3d* largest = &corners[0];
            for (const Vec3d& corner : corners)
                if (vecDot(corner, corner) > vecDot(*largest, *largest)) largest = &corner;
            for (const Vec3d& corner : corners)
                if (vecDot(corner, *largest) < -1e-6 * vecDot(*largest, *largest))
                    throw SceneError(
                        t.where,
                        "bilinear patch" +
                            (patches.size() > 1 ? " " + std::to_string(&q - patches.data() + 1) +
                                                      " of " + std::to_string(patches.size())
                                                : std::string()) +
                            " is flat but folded (a bowtie or a non-convex quadrilateral): "
                            "pbrt-v4's surface turns over inside it, which cbdpt does not render. "
                            "The corners are p00 p10 p01 p11, so p11 is opposite p00");
            tris.push_back({q[0], q[1], q[3]});
            tris.push_back({q[0], q[3], q[2]});
            const std::array<float, 2> patchUv[4] = {
                {0.f, 0.f}, {1.f, 0.f}, {0.f, 1.f}, {1.f, 1.f}};
            auto at = [&](size_t corner) { return uv.empty() ? patchUv[corner] : uv[q[corner]]; };
            cornerUv.push_back({at(0)[0], at(0)[1], at(1)[0], at(1)[1], at(3)[0], at(3)[1]});
            cornerUv.push_back({at(0)[0], at(0)[1], at(3)[0], at(3)[1], at(2)[0], at(2)[1]});
            // The patch's (u, v) is linear over its two triangles only on a parallelogram.
            const Vec3d skew = vecSub(d, a); // p00 + p11 - p10 - p01
            if (vecDot(skew, skew) > 1e-12 * (vecDot(a, a) + vecDot(b, b)))
                noTexCoords = "a bilinear patch that is not a parallelogram (its (u, v) is not "
                              "linear over the two triangles cbdpt renders it as)";
            if (!normals.empty()) {
                // pbrt-v4 interpolates N bilinearly in (u, v); over the two triangles that is
                // linear only on a parallelogram whose n00 + n11 = n10 + n01.
                const Vec3d twist = vecSub(vecAdd(normals[q[0]], normals[q[3]]),
                                           vecAdd(normals[q[1]], normals[q[2]]));
                double scale = 0.0;
                for (unsigned corner : q)
                    scale += vecDot(normals[corner], normals[corner]);
                if (!noTexCoords.empty() || vecDot(twist, twist) > 1e-12 * scale)
                    note(t.where, "bilinear-normals",
                         "a bilinear patch's \"normal N\" is interpolated linearly over each of "
                         "the two triangles cbdpt renders it as; pbrt-v4 interpolates it "
                         "bilinearly, which differs inside this patch");
            }
            if (poweredAreaLight()) {
                // pbrt-v4's BilinearPatch::Area, of the patch in world space: both triangles'.
                const Mat4& m = state_.ctm;
                const Vec3d w00 = m.point(p00), w10 = m.point(p10), w01 = m.point(p01),
                            w11 = m.point(p11);
                const Vec3d c1 = vecCross(vecSub(w10, w00), vecSub(w11, w00));
                const Vec3d c2 = vecCross(vecSub(w11, w00), vecSub(w01, w00));
                const double area = 0.5 * (std::sqrt(vecDot(c1, c1)) + std::sqrt(vecDot(c2, c2)));
                patchArea.insert(patchArea.end(), 2, area);
            }
        }
        if (!alpha.hidden)
            addMesh(t.where, pos, std::move(tris), normals, patchArea, std::move(cornerUv),
                    noTexCoords, alpha);
    }

    // A shape's float parameter or its default, with the parameter (null when absent) for errors.
    static std::pair<double, const Param*> floatOr(ParamList& pl, const char* name,
                                                   double fallback) {
        const Param* p = pl.peek(name);
        return {p ? *pl.oneFloat(name) : fallback, p};
    }

    // Ring segments of a full disk; a partial one (phimax < 360) gets its share, at least 4.
    static constexpr int kDiskSegments = 256;

    // pbrt-v4's disk: the points (r cos phi, r sin phi, height) with innerradius <= r <= radius
    // and 0 <= phi <= phimax, normal +z in object space, flipped when ReverseOrientation XOR the
    // CTM swaps handedness (Disk::InteractionFromIntersection). Tessellated into a fan (or, with
    // an inner radius, a ring of quads) whose ring radii are scaled by sqrt(dphi / sin dphi), so
    // that the polygon's area is the disk's exactly: emitted power and every integral over the
    // surface match; only the outline differs (by at most dphi^2 / 12 of the radius).
    void disk(const Token& t) {
        ParamList pl = params("Shape \"disk\"", "shape");
        auto get = [&](const char* name, double fallback) { return floatOr(pl, name, fallback); };
        const auto [height, hp] = get("height", 0.0);
        const auto [radius, rp] = get("radius", 1.0);
        const auto [inner, ip] = get("innerradius", 0.0);
        const auto [phimax, pp] = get("phimax", 360.0);
        (void)hp;
        if (!(radius > 0.0)) throw SceneError(rp->where, "\"float radius\" must be > 0");
        if (!(inner >= 0.0 && inner < radius))
            throw SceneError(ip->where, "\"float innerradius\" must be in [0, radius)");
        if (!(phimax > 0.0 && phimax <= 360.0))
            throw SceneError(pp->where, "\"float phimax\" must be in (0, 360] degrees");
        const ShapeAlpha alpha = shapeAlpha(pl, t, nullptr);
        pl.finish();
        const double phiMax = phimax * M_PI / 180.0;
        const int segments = std::max(4, int(std::ceil(kDiskSegments * phimax / 360.0 - 1e-9)));
        const double dphi = phiMax / segments;
        const double k = std::sqrt(dphi / std::sin(dphi));
        const bool full = phimax >= 360.0;
        const int ringVertices = full ? segments : segments + 1;
        std::vector<std::array<double, 3>> pos;
        // A copy of the binding: clang 14 (the fuzz build) cannot capture structured bindings.
        auto ring = [&, z = height](double r) {
            for (int i = 0; i < ringVertices; ++i) {
                const double phi = dphi * i;
                pos.push_back({k * r * std::cos(phi), k * r * std::sin(phi), z});
            }
        };
        std::vector<std::array<unsigned, 3>> tris;
        // Object-space winding normal +z; a mirroring CTM reverses it once more than addMesh
        // does for meshes (pbrt-v4 flips the disk's normal with transformSwapsHandedness).
        const bool mirror = state_.ctm.det3() < 0.0;
        auto triangle = [&](unsigned a, unsigned b, unsigned c) {
            tris.push_back(mirror ? std::array<unsigned, 3>{a, c, b}
                                  : std::array<unsigned, 3>{a, b, c});
        };
        auto next = [&](int i) { return unsigned(full ? (i + 1) % segments : i + 1); };
        if (inner > 0.0) {
            ring(radius);
            ring(inner);
            const unsigned innerBase = unsigned(ringVertices);
            for (int i = 0; i < segments; ++i) {
                const unsigned o0 = unsigned(i), o1 = next(i);
                triangle(innerBase + o0, o0, o1);
                triangle(innerBase + o0, o1, innerBase + o1);
            }
        } else {
            ring(radius);
            const unsigned centre = unsigned(pos.size());
            pos.push_back({0.0, 0.0, height});
            for (int i = 0; i < segments; ++i)
                triangle(centre, unsigned(i), next(i));
        }
        // pbrt-v4's Disk::Area, in object space (as pbrt-v4 divides a light's power by it).
        const double area = 0.5 * phiMax * (radius * radius - inner * inner);
        std::vector<double> diskArea(poweredAreaLight() ? tris.size() : 0, area);
        if (!alpha.hidden)
            addMesh(t.where, pos, std::move(tris), {}, diskArea, {},
                    "a disk (its polar (u, v) is not linear over the triangles cbdpt renders it "
                    "as)",
                    alpha);
    }

    // pbrt-v4's cylinder: the points (r cos phi, r sin phi, z), zmin <= z <= zmax, 0 <= phi <=
    // phimax, open at both ends, normal outward in object space and flipped when
    // ReverseOrientation XOR the CTM swaps handedness (Cylinder::InteractionFromIntersection),
    // (u, v) = (phi / phimax, (z - zmin) / (zmax - zmin)). Tessellated into a band of quads,
    // kDiskSegments per full turn, at radius r (dphi / 2) / sin(dphi / 2), so that each facet is
    // r dphi wide and the band's area is the cylinder's exactly (every integral over the surface,
    // a light's power); the vertex normals are the surface's, so shading follows the curve and
    // only the silhouette is polygonal (within dphi^2 / 12 of the radius).
    void cylinder(const Token& t) {
        ParamList pl = params("Shape \"cylinder\"", "shape");
        auto get = [&](const char* name, double fallback) { return floatOr(pl, name, fallback); };
        const auto [radius, rp] = get("radius", 1.0);
        const auto [zmin, zp] = get("zmin", -1.0);
        const auto [zmax, zq] = get("zmax", 1.0);
        const auto [phimax, pp] = get("phimax", 360.0);
        if (!(radius > 0.0)) throw SceneError(rp->where, "\"float radius\" must be > 0");
        // pbrt-v4 takes the smaller of the two as zmin; equal ones leave no surface.
        if (!(zmin != zmax) || !std::isfinite(zmin) || !std::isfinite(zmax))
            throw SceneError(zq   ? zq->where
                             : zp ? zp->where
                                  : t.where,
                             fmt::format("\"float zmin\" and \"float zmax\" must differ, got "
                                         "{:g} and {:g}",
                                         zmin, zmax));
        if (!(phimax > 0.0 && phimax <= 360.0))
            throw SceneError(pp->where, "\"float phimax\" must be in (0, 360] degrees");
        const ShapeAlpha alpha = shapeAlpha(pl, t, nullptr);
        pl.finish();
        const double z0 = std::min(zmin, zmax), z1 = std::max(zmin, zmax);
        const double phiMax = phimax * M_PI / 180.0;
        const int segments = std::max(4, int(std::ceil(kDiskSegments * phimax / 360.0 - 1e-9)));
        const double dphi = phiMax / segments;
        const double ringRadius = radius * (0.5 * dphi) / std::sin(0.5 * dphi);
        // pbrt-v4 flips the object-space normal for a mirroring CTM as for a disk; addMesh
        // negates the normals for ReverseOrientation.
        const double outward = state_.ctm.det3() < 0.0 ? -1.0 : 1.0;
        std::vector<std::array<double, 3>> pos, normals;
        std::vector<std::array<float, 2>> uv;
        // Both rings run to phimax (the seam's vertices twice), so that u reaches 1.
        for (const double z : {z0, z1})
            for (int i = 0; i <= segments; ++i) {
                const double phi = dphi * i;
                pos.push_back({ringRadius * std::cos(phi), ringRadius * std::sin(phi), z});
                normals.push_back({outward * std::cos(phi), outward * std::sin(phi), 0.0});
                uv.push_back({float(double(i) / segments), z == z0 ? 0.0f : 1.0f});
            }
        std::vector<std::array<unsigned, 3>> tris;
        const unsigned top = unsigned(segments + 1);
        for (unsigned i = 0; i < unsigned(segments); ++i) {
            tris.push_back({i, i + 1, top + i});
            tris.push_back({i + 1, top + i + 1, top + i});
        }
        // pbrt-v4's Cylinder::Area, in object space (as pbrt-v4 divides a light's power by it).
        const double area = phiMax * radius * (z1 - z0);
        std::vector<double> cylinderArea(poweredAreaLight() ? tris.size() : 0, area);
        std::vector<std::array<float, 6>> cornerUv = cornersOf(tris, uv);
        if (!alpha.hidden)
            addMesh(t.where, pos, std::move(tris), normals, cylinderArea, std::move(cornerUv), {},
                    alpha);
    }

    // The CTM's scale factor; an error unless the CTM is a similarity (only those keep a sphere
    // a sphere): A^T A must be s^2 I for the 3x3 block A.
    double similarityScale(const SourceLocation& where, const char* whose = "a sphere's") const {
        requireAffine(where);
        return similarityScale(state_.ctm, where, whose);
    }

    // `whose` names what needs it in the error ("a sphere's"): the spot light shares the check.
    static double similarityScale(const Mat4& m, const SourceLocation& where,
                                  const char* whose = "a sphere's") {
        double g[3][3];
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                g[i][j] = m(0, i) * m(0, j) + m(1, i) * m(1, j) + m(2, i) * m(2, j);
        const double s2 = (g[0][0] + g[1][1] + g[2][2]) / 3.0;
        bool similar = s2 > 0.0 && std::isfinite(s2);
        for (int i = 0; i < 3 && similar; ++i)
            for (int j = 0; j < 3; ++j)
                if (std::fabs(g[i][j] - (i == j ? s2 : 0.0)) > 1e-6 * s2) similar = false;
        if (!similar)
            throw SceneError(where, std::string(whose) +
                                        " transformation must be a similarity (rotation, uniform "
                                        "scale, translation); this CTM is not");
        return std::sqrt(s2);
    }

    static std::array<double, 3> unit(const std::array<double, 3>& v) {
        const double length = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        return {v[0] / length, v[1] / length, v[2] / length};
    }

    // A width that the CTM's scale took beyond float's range would make every box infinite.
    static void requireCurveWidths(const CurveDesc& c, const SourceLocation& where) {
        if (!std::isfinite(c.width0) || !std::isfinite(c.width1))
            throw SceneError(where, "a curve's width exceeds the float range (3.4e38) once "
                                    "scaled by its transformation");
    }

    // pbrt-v4's "curve" (its Curve::Create): cubic or quadratic, Bezier or uniform B-spline
    // control points "P", each segment made a cubic Bezier (degree elevated, B-spline blossomed)
    // of widths interpolated along the whole curve from "width0" to "width1", hit in its
    // 2^"splitdepth" pieces (cb_curve.h). The widths are the object's, scaled by the CTM, which
    // must be a similarity, as pbrt-v4 intersects curves in object space.
    void curve(const Token& t) {
        ParamList pl = params("Shape \"curve\"", "shape");
        const auto [width, wp] = floatOr(pl, "width", 1.0);
        const auto [width0, w0p] = floatOr(pl, "width0", width);
        const auto [width1, w1p] = floatOr(pl, "width1", width);
        for (const auto& [value, param] :
             {std::pair{width0, w0p ? w0p : wp}, std::pair{width1, w1p ? w1p : wp}})
            if (!(value >= 0.0) || !std::isfinite(value))
                throw SceneError(
                    param ? param->where : t.where,
                    fmt::format("a curve's width must be finite and >= 0, got {:g}", value));
        if (!(std::max(width0, width1) > 0.0))
            throw SceneError(wp ? wp->where : t.where, "a curve's widths must not both be 0");
        int degree = 3;
        if (const Param* p = pl.peek("degree")) {
            degree = *pl.oneInt("degree");
            if (degree != 2 && degree != 3)
                throw SceneError(p->valueLoc(0),
                                 fmt::format("invalid degree {}: only degree 2 and 3 curves are "
                                             "supported (as in pbrt-v4)",
                                             degree));
        }
        std::string basis = "bezier";
        if (const Param* p = pl.peek("basis")) {
            basis = *pl.oneString("basis");
            if (basis != "bezier" && basis != "bspline")
                throw SceneError(p->valueLoc(0), "invalid basis \"" + basis +
                                                     "\": only \"bezier\" and \"bspline\" are "
                                                     "supported (as in pbrt-v4)");
        }
        const Param* P = pl.numeric("P", "point3", 3);
        if (!P) throw SceneError(t.where, "a curve needs \"point3 P\"");
        const std::vector<std::array<double, 3>> cp = pointsOf(*P);
        const int n = int(cp.size());
        int segments = 0;
        if (basis == "bezier") {
            // After the first segment's degree + 1 points, each reuses the last one.
            if (n < degree + 1 || (n - 1 - degree) % degree != 0)
                throw SceneError(P->where, fmt::format("{} control points: a degree {} Bezier "
                                                       "curve needs {} + n * {} (n >= 0)",
                                                       n, degree, degree + 1, degree));
            segments = (n - 1) / degree;
        } else {
            if (n < degree + 1)
                throw SceneError(P->where, fmt::format("{} control points: a degree {} "
                                                       "B-spline needs at least {}",
                                                       n, degree, degree + 1));
            segments = n - degree;
        }
        CurveDesc::Type type = CurveDesc::Type::Flat;
        if (const Param* p = pl.peek("type")) {
            const std::string name = *pl.oneString("type");
            if (name == "ribbon")
                type = CurveDesc::Type::Ribbon;
            else if (name == "cylinder")
                type = CurveDesc::Type::Cylinder;
            else if (name != "flat")
                throw SceneError(p->valueLoc(0), "unknown curve type \"" + name +
                                                     "\" (pbrt-v4's are \"flat\", \"ribbon\" "
                                                     "and \"cylinder\")");
        }
        std::vector<std::array<double, 3>> normals;
        if (const Param* N = pl.numeric("N", "normal", 3)) {
            if (type != CurveDesc::Type::Ribbon) {
                note(N->where, "curve-normals",
                     "curve normals \"N\" are only used by \"ribbon\" curves (as in pbrt-v4): "
                     "ignored");
            } else {
                normals = pointsOf(*N);
                if (int(normals.size()) != segments + 1)
                    throw SceneError(N->where, fmt::format("{} normals: a ribbon curve of {} "
                                                           "segments needs {}",
                                                           normals.size(), segments, segments + 1));
            }
        }
        if (type == CurveDesc::Type::Ribbon && normals.empty())
            throw SceneError(t.where, "a \"ribbon\" curve needs normals \"N\" at its segments' "
                                      "ends");
        int splitDepth = 3;
        if (const Param* p = pl.peek("splitdepth")) {
            splitDepth = *pl.oneInt("splitdepth");
            if (splitDepth < 0 || splitDepth > 10)
                throw SceneError(
                    p->valueLoc(0),
                    fmt::format("\"integer splitdepth\" must be in [0, 10], got {}", splitDepth));
        }
        const ShapeAlpha alpha = shapeAlpha(pl, t, "curve");
        pl.finish();
        if (alpha.hidden) return;
        if (state_.areaLight >= 0)
            throw SceneError(t.where, "a curve cannot be an area light (pbrt-v4 cannot sample "
                                      "curves either)");
        const double scale = similarityScale(t.where, "a curve's");
        const Mat4& m = state_.ctm;
        for (const auto& nv : normals)
            if (!(nv[0] * nv[0] + nv[1] * nv[1] + nv[2] * nv[2] > 0.0))
                throw SceneError(t.where, "a ribbon curve's normal \"N\" is zero");
        const auto lerp = [](double s, const std::array<double, 3>& a,
                             const std::array<double, 3>& b) {
            return std::array<double, 3>{a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1]),
                                         a[2] + s * (b[2] - a[2])};
        };
        for (int seg = 0; seg < segments; ++seg) {
            std::array<std::array<double, 3>, 4> bezier;
            if (basis == "bezier") {
                const auto* c = &cp[size_t(seg * degree)];
                if (degree == 2) // elevated to degree 3
                    bezier = {c[0], lerp(2.0 / 3.0, c[0], c[1]), lerp(1.0 / 3.0, c[1], c[2]), c[2]};
                else
                    bezier = {c[0], c[1], c[2], c[3]};
            } else if (degree == 2) {
                // The uniform quadratic B-spline's Bezier points by blossoming, then elevated.
                const auto* c = &cp[size_t(seg)];
                const auto q0 = lerp(0.5, c[0], c[1]), q2 = lerp(0.5, c[1], c[2]);
                bezier = {q0, lerp(2.0 / 3.0, q0, c[1]), lerp(1.0 / 3.0, c[1], q2), q2};
            } else {
                // The uniform cubic B-spline's: p222, p223, p233, p333 from p012 .. p345.
                const auto* c = &cp[size_t(seg)];
                const auto p122 = lerp(2.0 / 3.0, c[0], c[1]), p223 = lerp(1.0 / 3.0, c[1], c[2]);
                const auto p233 = lerp(2.0 / 3.0, c[1], c[2]), p334 = lerp(1.0 / 3.0, c[2], c[3]);
                bezier = {lerp(0.5, p122, p223), p223, p233, lerp(0.5, p233, p334)};
            }
            CurveDesc curve;
            curve.where = t.where;
            for (int i = 0; i < 4; ++i)
                curve.cp[size_t(i)] =
                    checkedPoint(m.point(bezier[size_t(i)]), t.where, "a curve control point");
            curve.width0 = float(scale * (width0 + (width1 - width0) * seg / segments));
            curve.width1 = float(scale * (width0 + (width1 - width0) * (seg + 1) / segments));
            requireCurveWidths(curve, t.where);
            curve.type = type;
            if (!normals.empty())
                for (int i = 0; i < 2; ++i)
                    curve.normals[size_t(i)] = unit(m.normal(unit(normals[size_t(seg + i)])));
            curve.splitDepth = splitDepth;
            curve.mirrored = m.det3() < 0.0;
            curve.reverseOrientation = state_.reverseOrientation;
            curve.material = currentMaterial();
            curve.mediumInside = mediumUsed(state_.mediumInside, t.where, "a shape");
            curve.mediumOutside = mediumUsed(state_.mediumOutside, t.where, "a shape");
            scene_.curves.push_back(curve);
        }
    }

    void sphere(const SourceLocation& where, double radius, bool invisible) {
        const double scale = similarityScale(where);
        const Mat4& m = state_.ctm;
        SphereDesc s;
        s.where = where;
        s.center = checkedPoint(m.point({0, 0, 0}), where, "sphere centre");
        const double r = radius * scale;
        if (!(r <= std::numeric_limits<float>::max()))
            throw SceneError(where, "sphere radius is not finite after transformation");
        s.radius = static_cast<float>(r);
        // Found the same way: a radius positive in double can round to 0 as a float.
        if (!(s.radius > 0.f))
            throw SceneError(where, "sphere radius rounds to 0 as a float after transformation");
        // pbrt flips sphere normals when ReverseOrientation XOR the transform swaps handedness.
        s.reverseOrientation = state_.reverseOrientation != (m.det3() < 0.0);
        s.material = currentMaterial();
        s.areaLight = state_.areaLight;
        s.mediumInside = mediumUsed(state_.mediumInside, where, "a shape");
        s.mediumOutside = mediumUsed(state_.mediumOutside, where, "a shape");
        s.invisible = invisible;
        s.shapeArea = 4.0 * M_PI * radius * radius;
        s.scale = scale;
        for (int row = 0; row < 3; ++row)
            for (int c = 0; c < 3; ++c)
                s.worldFromObject[size_t(row * 3 + c)] = m(row, c) / scale;
        scene_.spheres.push_back(s);
    }

    // Transform to world space and orient each triangle so that cross(p1-p0, p2-p0) is the
    // normal pbrt-v4 would use (Triangle::InteractionFromIntersection): the winding normal,
    // negated when ReverseOrientation XOR the CTM swaps handedness, then - if per-vertex normals
    // are given - flipped to face them (pbrt does this per hit with the interpolated normal; we
    // use the triangle's centroid normal, the same for any consistent normal field).
    // shapeArea: per triangle of `tris`, the area of the pbrt-v4 shape it belongs to, given for
    // a powered area light only; empty when each triangle is its own shape.
    void addMesh(const SourceLocation& where, const std::vector<std::array<double, 3>>& objPos,
                 std::vector<std::array<unsigned, 3>> tris,
                 const std::vector<std::array<double, 3>>& objNormals,
                 const std::vector<double>& shapeArea,
                 const std::vector<std::array<float, 6>>& cornerUv, const std::string& noTexCoords,
                 const ShapeAlpha& alpha) {
        requireAffine(where);
        const Mat4& m = state_.ctm;
        TriangleMeshDesc mesh;
        mesh.where = where;
        mesh.positions.resize(objPos.size());
        for (size_t i = 0; i < objPos.size(); ++i)
            mesh.positions[i] = checkedPoint(m.point(objPos[i]), where, "a vertex position");
        std::vector<std::array<double, 3>> n(objNormals.size());
        const double det = m.det3();
        for (size_t i = 0; i < n.size(); ++i) {
            n[i] = det != 0.0 ? checkedPoint(m.normal(objNormals[i]), where, "a vertex normal")
                              : std::array<double, 3>{0, 0, 0};
            if (state_.reverseOrientation)
                for (double& c : n[i])
                    c = -c;
        }
        const bool flip = state_.reverseOrientation != (det < 0.0);
        const bool powered = poweredAreaLight();
        long dropped = 0;
        mesh.triangles.reserve(tris.size());
        mesh.noTexCoords = noTexCoords;
        if (!cornerUv.empty()) mesh.cornerUv.reserve(tris.size());
        std::vector<size_t> reversed; // kept triangles whose other side faces out
        for (size_t t = 0; t < tris.size(); ++t) {
            auto tri = tris[t];
            const auto& p0 = mesh.positions[tri[0]];
            const auto& p1 = mesh.positions[tri[1]];
            const auto& p2 = mesh.positions[tri[2]];
            const Vec3d c = vecCross(vecSub(p1, p0), vecSub(p2, p0));
            if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2] ||
                (c[0] == 0.0 && c[1] == 0.0 && c[2] == 0.0)) {
                ++dropped;
                continue;
            }
            if (powered)
                mesh.shapeArea.push_back(shapeArea.empty() ? 0.5 * std::sqrt(vecDot(c, c))
                                                           : shapeArea[t]);
            bool reverse = flip;
            if (!n.empty()) {
                Vec3d ns;
                for (size_t k = 0; k < 3; ++k)
                    ns[k] = n[tri[0]][k] + n[tri[1]][k] + n[tri[2]][k];
                const double sign = reverse ? -1.0 : 1.0;
                const double d = sign * vecDot(c, ns);
                if (d < 0.0) reverse = !reverse;
            }
            if (reverse) reversed.push_back(mesh.triangles.size());
            mesh.triangles.push_back(tri);
            if (!cornerUv.empty()) mesh.cornerUv.push_back(cornerUv[t]);
        }
        for (size_t t : reversed)
            mesh.reverseTriangle(t);
        mesh.normals = std::move(n);
        if (dropped > 0) {
            scene_.droppedDegenerateTriangles += dropped;
            std::cerr << "warning: " << where.file << ":" << where.line << ": dropped " << dropped
                      << " degenerate (zero-area) triangle" << (dropped == 1 ? "" : "s") << "\n";
        }
        mesh.material = currentMaterial();
        mesh.areaLight = state_.areaLight;
        mesh.mediumInside = mediumUsed(state_.mediumInside, where, "a shape");
        mesh.mediumOutside = mediumUsed(state_.mediumOutside, where, "a shape");
        mesh.alphaTexture = alpha.texture;
        mesh.invisible = alpha.invisible;
        scene_.meshes.push_back(std::move(mesh));
    }

    std::vector<std::string> searchDirs() const {
        std::vector<std::string> dirs{files_.back()->dir};
        if (topDir_ != dirs[0]) dirs.push_back(topDir_);
        if (const char* env = std::getenv("CBDPT_MODEL_PATH")) {
            std::string_view rest(env);
            while (!rest.empty()) {
                const size_t colon = rest.find(':');
                const std::string_view part = rest.substr(0, colon);
                if (!part.empty()) dirs.emplace_back(part);
                if (colon == std::string_view::npos) break;
                rest.remove_prefix(colon + 1);
            }
        }
        return dirs;
    }

    std::string resolveModel(const std::string& file, const SourceLocation& where) const {
        std::vector<std::string> tried;
        if (fs::path(file).is_absolute()) {
            if (fs::is_regular_file(file)) return file;
            tried.push_back(fs::path(file).parent_path().string());
        } else {
            for (const std::string& dir : searchDirs()) {
                const std::string p = joinPath(dir, file);
                if (fs::is_regular_file(p)) return p;
                tried.push_back(dir.empty() ? "." : dir);
            }
        }
        std::string msg = "cannot find model file \"" + file + "\"; folders tried:";
        for (const std::string& d : tried)
            msg += " " + d;
        msg += ". The Stanford models (bunny.ply, dragon.ply, buddha.ply) can be obtained with "
               "scripts/get-models, or set CBDPT_MODEL_PATH (':'-separated folders) to a folder "
               "holding them";
        throw SceneError(where, msg);
    }

    // The innermost open block's error: "XBegin without matching XEnd" where it was opened.
    SceneError unclosedBlock(const std::string& why) const {
        const std::string& by = stack_.back().openedBy; // "...Begin"
        return SceneError(stack_.back().openedAt,
                          by + " without matching " + by.substr(0, by.size() - 5) + "End" + why);
    }

    // The innermost Import being read, if any.
    const ImportScope* importBase() const {
        for (auto f = files_.rbegin(); f != files_.rend(); ++f)
            if ((*f)->import) return &*(*f)->import;
        return nullptr;
    }

    // pbrt-v4 parses an imported file with a copy of the importer's graphics state and keeps only
    // its shapes, objects and named materials (CopyForImport, MergeImported): the CTM, material,
    // area light and orientation it sets, and its named coordinate systems, do not leak out.
    void endImport(const ImportScope& scope) {
        if (stack_.size() > scope.stackDepth)
            throw unclosedBlock(" (an Import-ed file must close the blocks it opens)");
        state_ = scope.state;
        namedCoordinateSystems_ = scope.coordinateSystems;
    }

    // Where a file named in the scene may be: as given when absolute, else beside the file
    // naming it, then beside the main scene file (pbrt-v4's folder, tried second).
    std::vector<std::string> nearbyPaths(const std::string& name) const {
        if (fs::path(name).is_absolute()) return {name};
        std::vector<std::string> paths{joinPath(files_.back()->dir, name)};
        const std::string top = joinPath(topDir_, name);
        if (top != paths[0]) paths.push_back(top);
        return paths;
    }

    void include(const Token& t, bool isImport) {
        const Token name = quoted(t, "a file name");
        const std::vector<std::string> candidates = nearbyPaths(name.text);
        for (const std::string& path : candidates) {
            if (!fs::is_regular_file(path)) continue;
            const fs::path key = canonicalKey(path);
            for (const auto& f : files_)
                if (f->key == key)
                    throw SceneError(name.where, "recursive Include of \"" + path + "\"");
            std::string text;
            if (!tryReadWholeFile(path, text))
                throw SceneError(name.where, "cannot read included file \"" + path +
                                                 "\": " + unreadableReason(path));
            decompressIfGzipped(text, path, name.where);
            requireText(text, name.where, path);
            scene_.sourceFiles.push_back(path);
            files_.push_back(std::make_unique<SourceFile>(
                SourceFile{Tokenizer(std::move(text), path), parentDir(path), key, {}}));
            if (isImport) {
                files_.back()->import =
                    ImportScope{state_, stack_.size(), std::move(namedCoordinateSystems_)};
                namedCoordinateSystems_.clear();
            }
            return;
        }
        std::string msg = "cannot find included file \"" + name.text + "\"; tried:";
        for (const std::string& c : candidates)
            msg += " " + c;
        throw SceneError(name.where, msg);
    }

    SceneDesc& scene_;
    std::vector<std::unique_ptr<SourceFile>> files_;
    std::optional<Token> peeked_;
    std::string topDir_;
    GraphicsState state_;
    std::vector<GraphicsState> stack_;
    bool inWorld_ = false;
    bool haveCamera_ = false;
    bool haveFilm_ = false;
    int defaultMaterial_ = -1;
    static constexpr int kLaterMaterial = -2;
    struct LaterMaterial {
        std::string name;
        SourceLocation where; // its first NamedMaterial
    };
    std::vector<LaterMaterial> laterMaterials_;
    struct LaterMixPart {
        int mix = -1;     // the mix material
        size_t index = 0; // which of its two parts
        std::string name;
        SourceLocation where;
    };
    std::vector<LaterMixPart> laterMixParts_;
    struct TangentsBeside {
        int material = -1; // the shape's: an index, or a placeholder (kLaterMaterial - k)
        SourceLocation where;
    };
    std::vector<TangentsBeside> tangentsBeside_;
    struct LaterTexture {
        int material = -1;                  // index in scene_.materials
        int MaterialDesc::*field = nullptr; // where the texture's index goes
        std::string param;                  // "reflectance", "transmittance"
        std::string name;
        SourceLocation where;
    };
    std::vector<LaterTexture> laterTextures_;
    // pbrt-v4's named textures, "spectrum" and "float" each a name space of its own: the index
    // in scene_.textures, or (index -1) why cbdpt cannot use it, an error only where one is.
    struct NamedTexture {
        int index = -1;
        std::string unsupported;
        SourceLocation where;
        std::optional<double> constant; // a float texture of class "constant": its value
    };
    std::map<std::string, NamedTexture> spectrumTextures_, floatTextures_;
    std::map<std::string, int> normalMaps_;       // image path -> index in scene_.textures
    std::map<double, int> constantFloatTextures_; // a constant alpha or displacement -> its index
    bool textureFilteringDisabled_ = false;       // Option "disabletexturefiltering" true
    std::set<std::string> notedKinds_;
    std::map<std::string, Mat4> namedCoordinateSystems_;
    std::map<std::string, int> mediumIndex_; // medium name -> index in scene_.media
    std::map<std::string, SourceLocation> importedCoordinateSystems_; // defined inside an Import
    struct OpenObject {
        std::string name;
        size_t firstMesh = 0, firstSphere = 0, firstCurve = 0, depth = 0;
    };
    std::map<std::string, ObjectDef> objects_;
    std::optional<OpenObject> openObject_;
    struct LaterInstance {
        Token name; // ObjectInstance's name, before its ObjectBegin
        Mat4 ctm;
    };
    std::vector<LaterInstance> laterInstances_;
};

} // namespace

std::array<int, 4> cropWindowPixels(int width, int height, const std::array<double, 4>& crop,
                                    const std::string& label) {
    const auto [x0, x1, y0, y1] = crop;
    for (double f : crop)
        if (!(f >= 0.0 && f <= 1.0))
            throw std::invalid_argument(
                fmt::format("{} {} {} {} {}: each value must be in [0, 1]", label, x0, x1, y0, y1));
    if (!(x0 < x1 && y0 < y1))
        throw std::invalid_argument(fmt::format(
            "{} {} {} {} {}: must be x0 x1 y0 y1 with x0 < x1 and y0 < y1", label, x0, x1, y0, y1));
    const std::array<int, 4> pixels = {int(std::ceil(width * x0)), int(std::ceil(width * x1)),
                                       int(std::ceil(height * y0)), int(std::ceil(height * y1))};
    if (pixels[0] >= pixels[1] || pixels[2] >= pixels[3])
        throw std::invalid_argument(fmt::format("{} {} {} {} {} holds no pixel of the {}x{} film",
                                                label, x0, x1, y0, y1, width, height));
    return pixels;
}

std::vector<std::pair<int, double>> mixLeaves(const SceneDesc& scene, int material) {
    std::vector<std::pair<int, double>> leaves;
    std::vector<int> path; // the mixes from `material` down to the one being expanded
    long steps = 0;        // a mix of the same mix, nested, doubles its expansion each level
    auto named = [&](int m) {
        const std::string& name = scene.materials.at(size_t(m)).name;
        return name.empty() ? std::string("this mix") : "mix \"" + name + "\"";
    };
    auto expand = [&](auto&& self, int m, double weight) -> void {
        const MaterialDesc& d = scene.materials.at(size_t(m));
        if (++steps > 100000)
            throw SceneError(scene.materials.at(size_t(material)).where,
                             named(material) + " nests mixes into more than 100000 parts");
        if (d.kind != MaterialKind::Mix) {
            auto same = std::find_if(leaves.begin(), leaves.end(),
                                     [&](const auto& leaf) { return leaf.first == m; });
            if (same != leaves.end())
                same->second += weight;
            else
                leaves.emplace_back(m, weight);
            return;
        }
        if (auto loop = std::find(path.begin(), path.end(), m); loop != path.end()) {
            std::string chain; // the loop alone, from m back to m
            for (; loop != path.end(); ++loop)
                chain += "\"" + scene.materials[size_t(*loop)].name + "\" -> ";
            throw SceneError(d.where,
                             named(m) + " contains itself (" + chain + "\"" + d.name + "\")");
        }
        path.push_back(m);
        self(self, d.mix[0], weight * (1.0 - double(d.amount)));
        self(self, d.mix[1], weight * double(d.amount));
        path.pop_back();
    };
    expand(expand, material, 1.0);
    return leaves;
}

SceneDesc parseSceneString(const std::string& text, const std::string& virtualPath) {
    requireText(text, SourceLocation{virtualPath, 0, 0}, virtualPath);
    SceneDesc scene;
    scene.path = virtualPath;
    scene.filter = FilterDesc::pbrtDefault();
    Parser(scene).run(text, virtualPath);
    return scene;
}

SceneDesc parseSceneFile(const std::string& path) {
    std::string text;
    if (!tryReadWholeFile(path, text))
        throw SceneError(SourceLocation{path, 0, 0},
                         "cannot read the scene file: " + unreadableReason(path));
    decompressIfGzipped(text, path, SourceLocation{path, 0, 0});
    SceneDesc scene = parseSceneString(text, path);
    scene.sourceFiles.insert(scene.sourceFiles.begin(), path);
    return scene;
}

} // namespace cb
