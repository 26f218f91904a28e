// The checkpoint log of `render --log`: a header describing the run (set-up times excluded from
// the rows' render seconds), then one row per checkpoint. Rewritten atomically at every
// checkpoint so that an interrupted render still leaves a complete, parseable log.
#pragma once

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace cb::cli {

class CheckpointLog {
  public:
    static constexpr const char* columns[] = {"estimates",  "seconds",    "rmse",
                                              "rel_mse",    "mae",        "mean_stderr",
                                              "rms_stderr", "image_mean", "checkpoint_seconds",
                                              "cpu_seconds"};
    // `path` must end in .csv or .json (the format); throws std::invalid_argument otherwise.
    CheckpointLog(std::string path, nlohmann::json header);
    // One value per column; non-finite values are written as empty (CSV) or null (JSON).
    void add(const std::vector<double>& row);

  private:
    void write() const;
    std::string path_;
    nlohmann::json header_;
    bool json_ = false;
    std::vector<std::vector<double>> rows_;
};

} // namespace cb::cli
