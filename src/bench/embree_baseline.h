// Embree 3 as the traversal baseline of cbdpt-bench (compiled only when Embree is found).
#pragma once

#include "scene/ply.h"

#include "cb_types.h"

#include <cstddef>
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
    // Bytes Embree holds once the scene is built (its memory monitor's allocations less frees):
    // the BVH with its triangle blocks, and the mesh's vertex and index buffers.
    std::size_t sceneBytes() const { return sceneBytes_; }
    // Of those, the mesh's vertex and index buffers (counted before the build).
    std::size_t meshBufferBytes() const { return meshBufferBytes_; }
    std::string version() const;
    // rtcIntersect1 per ray, in chunks on `threads` std::threads (parallelRayChunks). With
    // tMax, tfar = tMax[i], and a ray with tMax[i] <= 0 is inactive (a path that ended): it
    // is skipped and reported as a miss.
    void intersect(const std::vector<cbk::Ray>& rays, std::vector<BaselineHit>& out,
                   const std::vector<float>* tMax = nullptr) const;
    // rtcOccluded1 with tfar = tMax[i]; tMax[i] <= 0 is inactive (not occluded).
    void occluded(const std::vector<cbk::Ray>& rays, const std::vector<float>& tMax,
                  std::vector<int>& out) const;
    // The packet interface: rtcIntersect8/16 (width 8 or 16) on the packets of `packets`,
    // `width` ray indices each (-1 for an empty lane), inactive rays as invalid lanes; chunks
    // of packets on `threads` std::threads. Same results as intersect().
    void intersectPackets(const std::vector<cbk::Ray>& rays, const std::vector<float>* tMax,
                          const std::vector<int>& packets, int width,
                          std::vector<BaselineHit>& out) const;
    // rtcOccluded8/16 likewise.
    void occludedPackets(const std::vector<cbk::Ray>& rays, const std::vector<float>& tMax,
                         const std::vector<int>& packets, int width, std::vector<int>& out) const;

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
    int threads_;
    double buildSeconds_ = 0.0;
    std::size_t sceneBytes_ = 0;
    std::size_t meshBufferBytes_ = 0;
};

bool embreeAvailable();

} // namespace cb::bench
