// The renderers' wide BVH, built under each of a few SAH settings; the one kept is the one
// whose traversal costs least for rays sampled from the scene's own camera. No one setting
// suits every scene: SAH block 4 with leaves of up to eight fills the leaf packs and halves
// the node count on an isolated mesh (+5-25% on incoherent rays), but in a room it groups
// walls whose union box is the whole room, which most rays then test (docs/performance.md).
#pragma once

#include <string>
#include <vector>

#include "bvh/bvh.h"
#include "bvh/bvh_wide.h"
#include "cb_types.h"

namespace cb {

struct WideBvhSettings {
    int sahBlock = 2;    // BvhBuildOptions::primitivesPerTest
    int maxLeafSize = 4; // BvhBuildOptions::maxLeafSize
};

// The two candidates, the first being the one kept on ties and for scenes with no sample
// rays: SAH block 2 with leaves of up to 4, block 4 with leaves of up to 8.
std::vector<WideBvhSettings> defaultWideBvhCandidates();

// What the renderers and the bench choose from: the default candidates, or the one that the
// environment variable CBDPT_BVH_SETTINGS=BLOCK,LEAF (e.g. 4,8) names; a malformed value
// throws std::invalid_argument.
std::vector<WideBvhSettings> wideBvhCandidates();

// The work of a closest-hit traversal that knew the hit distance in advance: the wide nodes
// it enters before the hit (each costs one node visit) and the leaf packs under them, as the
// traversal's own box test (bvhWideBoxes) decides with the hit as the closest distance. A
// near-first traversal does this work and a little more; both trees of a comparison are
// charged the same way.
struct TraversalWork {
    double nodeVisits = 0.0; // per ray
    double packTests = 0.0;  // per ray
    // A pack test (four triangles) counts as 0.3 node visits. Not the instruction counts
    // (about 90 against 60 under callgrind): a node visit is a chain of dependent loads and
    // picks that ends in the next node's address, while the tests of a leaf's packs are
    // independent of each other and overlap. Fitted to render and traversal times of both
    // candidates in the seven scenes and on three isolated meshes: every weight from 0.17 to
    // 0.51 picks the faster tree in all ten (docs/performance.md).
    static constexpr double kPackWeight = 0.3;
    double cost() const { return nodeVisits + kPackWeight * packTests; }
};

// `curves`: the curve pieces that the primitives of kind CB_PRIM_CURVE index (null: none).
TraversalWork measureTraversalWork(const Bvh& bvh, const BvhWide& wide,
                                   const std::vector<cbk::Ray>& rays,
                                   const cbk::CurveSegment* curves = nullptr);

// Rays that stand for a path tracer's: the camera rays, each followed by up to `bounces`
// diffuse (cosine-distributed) bounces off the geometric surfaces it hits. Deterministic.
std::vector<cbk::Ray> sampleBounceRays(const Bvh& bvh, const BvhWide& wide,
                                       const std::vector<cbk::Ray>& cameraRays, int bounces = 3,
                                       const cbk::CurveSegment* curves = nullptr);

struct WideBvhChoice {
    Bvh bvh;
    BvhWide wide;
    WideBvhSettings settings;
    std::vector<WideBvhSettings> candidates; // what it was chosen from
    std::vector<TraversalWork> work;         // per candidate, when more than one was measured
    int chosen = 0;                          // index into candidates
};

// Builds each candidate (at least one) and keeps the cheapest for
// sampleBounceRays(cameraRays). With no camera rays, or a single candidate, only the first is
// built.
WideBvhChoice
buildWideBvhForRays(const std::vector<cbk::Primitive>& primitives,
                    const std::vector<cbk::Ray>& cameraRays,
                    const std::vector<WideBvhSettings>& candidates = wideBvhCandidates(),
                    const cbk::CurveSegment* curves = nullptr);

// "SAH block 4, leaves <= 8 (cost per sample ray 31.2; block 2, leaves <= 4: 40.5)".
std::string describeChoice(const WideBvhChoice& choice);

} // namespace cb
