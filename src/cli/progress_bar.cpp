#include "cli/progress_bar.h"

#include "cli/cli_format.h"

#include <fmt/format.h>

#include <algorithm>
#include <cstdio>
#include <string>
#include <unistd.h>

namespace cb::cli {

ProgressBar::ProgressBar(bool enabled) : enabled_(enabled), tty_(::isatty(2)) {}

void ProgressBar::update(const cb::RenderProgress& p) {
    if (!enabled_) return;
    double fraction =
        p.estimatesTarget > 0
            ? double(p.estimatesDone) / double(p.estimatesTarget)
            : std::min(1.0,
                       p.elapsedSeconds / std::max(1e-9, p.elapsedSeconds + p.remainingSeconds));
    if (!tty_) {
        // Logs get a line per 10% rather than carriage returns.
        int decile = int(fraction * 10.0);
        if (decile <= lastDecile_) return;
        lastDecile_ = decile;
    }
    const int width = 30;
    int filled = int(fraction * width + 0.5);
    std::string bar(size_t(filled), '#');
    bar.append(size_t(width - filled), '.');
    std::string count = p.estimatesTarget > 0
                            ? fmt::format("{}/{} estimates", p.estimatesDone, p.estimatesTarget)
                            : fmt::format("{} estimates", p.estimatesDone);
    fmt::print(stderr, "{}[{}] {}  elapsed {}  remaining {}{}", tty_ ? "\r" : "", bar, count,
               formatSeconds(p.elapsedSeconds), formatSeconds(p.remainingSeconds),
               tty_ ? "   " : "\n");
    std::fflush(stderr);
}

void ProgressBar::finish() {
    if (enabled_ && tty_) fmt::print(stderr, "\n");
}

} // namespace cb::cli
