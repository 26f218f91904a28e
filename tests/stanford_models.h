#pragma once
// The Stanford models (bunny, dragon, Buddha) are not part of the repository. Tests find them
// the way the renderer does, through CBDPT_MODEL_PATH (':'-separated folders), which
// scripts/run-tests and CI set; scripts/get-models downloads them.
#include <cstdlib>
#include <filesystem>
#include <string>

#include <doctest/doctest.h>

namespace cbtest {

// The first folder of CBDPT_MODEL_PATH holding bunny.ply, dragon.ply and buddha.ply, or an
// empty path.
inline std::filesystem::path stanfordModelDir() {
    const char* path = std::getenv("CBDPT_MODEL_PATH");
    std::string rest = path ? path : "";
    while (!rest.empty()) {
        const size_t colon = rest.find(':');
        const std::filesystem::path dir = rest.substr(0, colon);
        rest = colon == std::string::npos ? "" : rest.substr(colon + 1);
        if (dir.empty()) continue;
        bool all = true;
        for (const char* name : {"bunny.ply", "dragon.ply", "buddha.ply"})
            all = all && std::filesystem::is_regular_file(dir / name);
        if (all) return dir;
    }
    return {};
}

// True when the models are on CBDPT_MODEL_PATH. Otherwise the calling test case must return at
// once: with CBDPT_REQUIRE_MODELS=1 (CI, which always has them) this fails the test; elsewhere
// it prints how to get them, marked "cbdpt-skip:", which CTest reports as a skipped test
// (SKIP_REGULAR_EXPRESSION in tests/tests.cmake; the marker matches whatever the exit code, so
// nothing may be checked after it).
inline bool stanfordModelsOrSkip() {
    if (!stanfordModelDir().empty()) return true;
    const char* where = std::getenv("CBDPT_MODEL_PATH");
    const std::string how = std::string("the Stanford models (bunny.ply, dragon.ply, buddha.ply) "
                                        "are not in any folder of CBDPT_MODEL_PATH (\"") +
                            (where ? where : "") +
                            "\"); run scripts/get-models and set CBDPT_MODEL_PATH=$PWD/models";
    if (const char* require = std::getenv("CBDPT_REQUIRE_MODELS"); require && *require == '1')
        FAIL("CBDPT_REQUIRE_MODELS=1 but " << how);
    MESSAGE("cbdpt-skip: " << how);
    return false;
}

} // namespace cbtest
