#include "cli/checkpoint_log.h"

#include "cli/cli_format.h"
#include "image/image.h"
#include "io/files.h"

#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <stdexcept>

namespace cb::cli {

namespace {

// A number for the CSV log: empty when not available (no reference, fewer than 2 estimates).
std::string csvNumber(double v) {
    return std::isfinite(v) ? fmt::format("{:.9g}", v) : "";
}

} // namespace

CheckpointLog::CheckpointLog(std::string path, nlohmann::json header)
    : path_(std::move(path)), header_(std::move(header)) {
    const auto ext = std::filesystem::path(path_).extension();
    if (ext == ".json")
        json_ = true;
    else if (ext != ".csv")
        throw std::invalid_argument(fmt::format("--log '{}' must end in .csv or .json", path_));
}

void CheckpointLog::add(const std::vector<double>& row) {
    rows_.push_back(row);
    write();
}

void CheckpointLog::write() const {
    if (json_) {
        nlohmann::json doc = header_;
        doc["columns"] = columns;
        nlohmann::json rows = nlohmann::json::array();
        for (const auto& r : rows_) {
            nlohmann::json o;
            for (size_t i = 0; i < r.size(); ++i)
                o[columns[i]] = i == 0 ? nlohmann::json(long(r[i])) : jsonNumber(r[i]);
            rows.push_back(o);
        }
        doc["checkpoints"] = rows;
        cb::writeFileAtomically(path_, doc.dump(2) + "\n");
        return;
    }
    std::string text = "# cbdpt checkpoint log\n";
    for (const auto& [key, value] : header_.items())
        text += fmt::format("# {}: {}\n", key,
                            value.is_string() ? value.get<std::string>() : value.dump());
    for (size_t i = 0; i < std::size(columns); ++i) {
        if (i) text += ',';
        text += columns[i];
    }
    text += '\n';
    for (const auto& r : rows_) {
        for (size_t i = 0; i < r.size(); ++i) {
            if (i) text += ',';
            text += i == 0 ? std::to_string(long(r[i])) : csvNumber(r[i]);
        }
        text += '\n';
    }
    cb::writeFileAtomically(path_, text);
}

} // namespace cb::cli
