// Embree 3 as the traversal baseline of cbdpt-bench (compiled only when Embree is found).
#pragma once

#include "scene/ply.h"

#include "cb_types.h"

#include <memory>
#include <string>
#include <vector>

namespace cb::bench {

struct BaselineHit {
    float t;       // +inf on a miss
    int primitive; // input triangle index, -1 on a miss
};

class EmbreeBaseline {
  public:
    // Builds Embree's BVH over the mesh (one triangle geometry, shared vertices).
    explicit EmbreeBaseline(const PlyMesh& mesh, int threads);
    ~EmbreeBaseline();
    EmbreeBaseline(const EmbreeBaseline&) = delete;
    EmbreeBaseline& operator=(const EmbreeBaseline&) = delete;

    double buildSeconds() const { return buildSeconds_; }
    std::string version() const;
    // rtcIntersect1 per ray, rays split into `threads` contiguous ranges on std::threads.
    void intersect(const std::vector<cbk::Ray>& rays, std::vector<BaselineHit>& out) const;
    // rtcOccluded1 with tfar = tMax[i].
    void occluded(const std::vector<cbk::Ray>& rays, const std::vector<float>& tMax,
                  std::vector<int>& out) const;

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
    int threads_;
    double buildSeconds_ = 0.0;
};

bool embreeAvailable();

} // namespace cb::bench
