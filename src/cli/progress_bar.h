// The render's progress on stderr: a bar redrawn in place on a terminal, a line per 10% in logs.
#pragma once

#include "integrators/render.h"

namespace cb::cli {

class ProgressBar {
  public:
    explicit ProgressBar(bool enabled);
    void update(const cb::RenderProgress& p);
    void finish();

  private:
    bool enabled_;
    bool tty_;
    int lastDecile_ = -1;
};

} // namespace cb::cli
