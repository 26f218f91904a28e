// Where the tests find the Stanford models: the first folder of CBDPT_MODEL_PATH
// (':'-separated, as the scene parser reads it) that exists, else the build's default
// (CBDPT_MODELS_DIR, ../shared/models beside the source tree).
#pragma once

#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>

namespace cbtest {

inline std::filesystem::path modelsDir() {
    if (const char* path = std::getenv("CBDPT_MODEL_PATH")) {
        std::stringstream folders(path);
        std::string folder;
        while (std::getline(folders, folder, ':'))
            if (!folder.empty() && std::filesystem::is_directory(folder)) return folder;
    }
    return CBDPT_MODELS_DIR;
}

} // namespace cbtest
