// cbdpt-bench: timing helpers, model search and the test meshes (bench.h).
#include "bench/bench.h"

#include <fmt/format.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <time.h>

namespace fs = std::filesystem;

namespace cb::bench {

double processCpuSeconds() {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

double median(std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::vector<std::string> splitCommas(const std::string& v) {
    std::vector<std::string> out;
    std::stringstream ss(v);
    for (std::string item; std::getline(ss, item, ',');)
        if (!item.empty()) out.push_back(item);
    return out;
}

std::string findModel(const Options& o, const std::string& file) {
    std::vector<std::string> dirs;
    if (!o.models.empty()) dirs.push_back(o.models);
    if (const char* env = std::getenv("CBDPT_MODEL_PATH")) {
        std::stringstream ss(env);
        std::string d;
        while (std::getline(ss, d, ':'))
            if (!d.empty()) dirs.push_back(d);
    }
    dirs.push_back("models"); // where scripts/get-models puts them
    for (const auto& d : dirs)
        if (fs::exists(fs::path(d) / file)) return (fs::path(d) / file).string();
    return "";
}

std::vector<BenchMesh> loadMeshes(const Options& o) {
    std::vector<std::string> names = o.meshes;
    if (names.empty())
        names = o.quick ? std::vector<std::string>{"bunny", "sphere-10k"}
                        : std::vector<std::string>{"bunny", "dragon", "sphere-1M"};
    std::vector<BenchMesh> out;
    for (const auto& name : names) {
        // NAME-room: the mesh NAME in a room (withRoom).
        const bool room = name.size() > 5 && name.compare(name.size() - 5, 5, "-room") == 0;
        const std::string n = room ? name.substr(0, name.size() - 5) : name;
        const size_t before = out.size();
        if (n.rfind("sphere-", 0) == 0) {
            std::string s = n.substr(7);
            double scale = 1.0;
            if (!s.empty() && (s.back() == 'k' || s.back() == 'M')) {
                scale = s.back() == 'k' ? 1e3 : 1e6;
                s.pop_back();
            }
            long tris = long(std::stod(s) * scale);
            const float c[3] = {0.0f, 0.0f, 0.0f};
            out.push_back({name, displacedSphere(tris, c, 1.0f)});
        } else if (std::string path = findModel(o, n + ".ply"); !path.empty()) {
            out.push_back({name, readPly(path)});
        } else {
            fmt::print(stderr,
                       "warning: {}.ply not found (--models or CBDPT_MODEL_PATH); skipped\n", n);
        }
        if (room && out.size() > before) out.back().mesh = withRoom(std::move(out.back().mesh));
    }
    return out;
}

std::string selfPath() {
    return fs::read_symlink("/proc/self/exe").string();
}

} // namespace cb::bench
