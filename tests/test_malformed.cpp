// The malformed-input corpus (tests/malformed/, docs/robustness.md): every scene and PLY file in
// the folder must be rejected with a SceneError whose message contains the text of its sidecar
// NAME.expected, location included. A file without a sidecar, or a sidecar without a file, fails
// the test, so the corpus cannot rot; inputs found by the fuzzers are added here as regressions.
#include <doctest/doctest.h>

#include "scene/ply.h"
#include "scene/scene_desc.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;

std::string readAll(const fs::path& p) {
    std::ifstream f(p, std::ios::binary);
    REQUIRE_MESSAGE(f, "cannot open " << p.string());
    return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

// Sidecar lines may end in CRLF or spaces; the message never does.
std::string trimmed(std::string s) {
    while (!s.empty() && (s.back() == '\n' || s.back() == '\r' || s.back() == ' '))
        s.pop_back();
    return s;
}

// The error from the file API, "<no error>" when it loads, or a note for other exceptions (which
// are themselves failures: bad input must surface as SceneError only).
std::string errorOf(const fs::path& input, bool fromMemory) {
    const std::string path = input.string();
    const bool ply = input.extension() == ".ply";
    try {
        if (ply && fromMemory)
            cb::readPlyFromMemory(readAll(input), path);
        else if (ply)
            cb::readPly(path);
        else if (fromMemory)
            cb::parseSceneString(readAll(input), path);
        else
            cb::parseSceneFile(path);
    } catch (const cb::SceneError& e) {
        return e.what();
    } catch (const std::exception& e) {
        return std::string("<not a SceneError: ") + e.what() + ">";
    }
    return "<no error>";
}

// Whether `s` contains "<name>.pbrt:<digits>:<digits>: ", or "<name>.pbrt: " for an error of the
// whole file (SourceLocation::str), or the same for .ply. (Not std::regex: g++ 12 warns inside
// <regex> in the sanitized -O1 build.)
bool hasLocation(const std::string& s) {
    for (const char* ext : {".pbrt:", ".ply:"}) {
        for (size_t at = s.find(ext); at != std::string::npos; at = s.find(ext, at + 1)) {
            size_t i = at + std::string(ext).size();
            if (at > 0 && s.compare(i, 1, " ") == 0) return true;
            auto digits = [&] {
                const size_t from = i;
                while (i < s.size() && s[i] >= '0' && s[i] <= '9')
                    ++i;
                return i > from;
            };
            if (at > 0 && digits() && i < s.size() && s[i++] == ':' && digits() &&
                s.compare(i, 2, ": ") == 0)
                return true;
        }
    }
    return false;
}

} // namespace

TEST_CASE("malformed corpus: every file is rejected with its expected message and location") {
    const fs::path dir = fs::path(CBDPT_SOURCE_DIR) / "tests" / "malformed";
    REQUIRE(fs::is_directory(dir));

    std::map<std::string, fs::path> inputs; // stem -> file
    std::set<std::string> sidecars;
    for (const auto& entry : fs::directory_iterator(dir)) {
        const fs::path& p = entry.path();
        const std::string ext = p.extension().string();
        INFO("file: " << p.string());
        CHECK_MESSAGE((ext == ".pbrt" || ext == ".ply" || ext == ".expected"),
                      "only .pbrt, .ply and .expected files belong in tests/malformed");
        if (ext == ".expected") {
            sidecars.insert(p.stem().string());
        } else if (ext == ".pbrt" || ext == ".ply") {
            const bool fresh = inputs.emplace(p.stem().string(), p).second;
            CHECK_MESSAGE(fresh, "two inputs share the stem " << p.stem().string()
                                                              << " (one sidecar each)");
        }
    }
    for (const std::string& s : sidecars) {
        INFO("sidecar: " << s << ".expected");
        CHECK_MESSAGE(inputs.count(s) == 1, "sidecar without an input file");
    }
    // The issue asks for a corpus covering many failure kinds; it only ever grows.
    CHECK(inputs.size() >= 25);

    int ply = 0, scene = 0;
    for (const auto& [stem, input] : inputs) {
        (input.extension() == ".ply" ? ply : scene)++;
        INFO("input: " << input.string());
        const fs::path sidecar = dir / (stem + ".expected");
        if (!fs::exists(sidecar)) {
            FAIL_CHECK("missing sidecar " << sidecar.string()
                                          << " (the expected error message substring)");
            continue;
        }
        // One substring per line; the first carries the location. Several lines let a message
        // that quotes an absolute path (or a nested file's error) be pinned around it.
        std::vector<std::string> expected;
        {
            std::istringstream lines(readAll(sidecar));
            for (std::string l; std::getline(lines, l);)
                if (!trimmed(l).empty()) expected.push_back(trimmed(l));
        }
        INFO("expected: " << (expected.empty() ? std::string("<empty>") : expected[0]));
        REQUIRE_FALSE(expected.empty());
        CHECK_MESSAGE(hasLocation(expected[0]),
                      "the sidecar's first line must contain 'file:line:column: ' or 'file: '");
        const std::string fromFile = errorOf(input, false);
        INFO("got: " << fromFile);
        // Locations are reported in the file where the error is (an included one, for a
        // recursive Include), always with the path as opened: inside this folder.
        CHECK(fromFile.rfind((dir / "").string(), 0) == 0);
        for (const std::string& e : expected) {
            INFO("expected part: " << e);
            CHECK(fromFile.find(e) != std::string::npos);
        }
        // The in-memory entry points the fuzzers use report the same error.
        CHECK(errorOf(input, true) == fromFile);
    }
    CHECK(ply >= 10);
    CHECK(scene >= 10);
}

TEST_CASE("messages: bytes that are not printable text are escaped, valid UTF-8 is kept") {
    CHECK(cb::printableText("plain text\twith tab") == "plain text\twith tab");
    CHECK(cb::printableText("caf\xc3\xa9 \xe2\x86\x92") == "caf\xc3\xa9 \xe2\x86\x92");
    CHECK(cb::printableText(std::string("a\0b", 3)) == "a\\x00b");
    CHECK(cb::printableText("\x1b[31mred\r") == "\\x1b[31mred\\x0d");
    // Latin-1, a lone continuation byte, an overlong form, a truncated sequence.
    CHECK(cb::printableText("caf\xe9") == "caf\\xe9");
    CHECK(cb::printableText("\x80x") == "\\x80x");
    CHECK(cb::printableText("\xc0\xaf") == "\\xc0\\xaf");
    CHECK(cb::printableText("\xe2\x86") == "\\xe2\\x86");
    const cb::SceneError error(cb::SourceLocation{"f.pbrt", 1, 2}, "unknown directive '\x01\xff'");
    CHECK(std::string(error.what()) == "f.pbrt:1:2: unknown directive '\\x01\\xff'");
}

TEST_CASE("messages: files that are not text are named by their first bytes") {
    CHECK(cb::describeNonTextFile("WorldBegin\nShape \"sphere\"\n").empty());
    CHECK(cb::describeNonTextFile("").empty());
    // A scene with a Latin-1 comment is still text.
    CHECK(cb::describeNonTextFile("# ilumina\xe7\xe3o\nWorldBegin\n").empty());
    CHECK(cb::describeNonTextFile("v/1\x01rest") == "an OpenEXR image");
    CHECK(cb::describeNonTextFile("\x89PNG\r\n\x1a\nrest") == "a PNG image");
    CHECK(cb::describeNonTextFile("\xff\xd8\xff\xe0") == "a JPEG image");
    CHECK(cb::describeNonTextFile("ply\nformat ascii 1.0\n").rfind("a PLY mesh", 0) == 0);
    CHECK(cb::describeNonTextFile("\x1f\x8b\x08").find("gzip") != std::string::npos);
    CHECK(cb::describeNonTextFile(std::string("Shape\0", 6)) == "a binary file");
    std::string noisy;
    for (int i = 0; i < 1000; ++i)
        noisy += char(0x80 + (i * 37) % 64); // continuation bytes only: never valid UTF-8
    CHECK(cb::describeNonTextFile(noisy) == "a binary file");
}
