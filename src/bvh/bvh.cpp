#include "bvh/bvh.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace cb {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

struct Box {
    float lo[3] = {kInf, kInf, kInf};
    float hi[3] = {-kInf, -kInf, -kInf};

    void grow(const Box& b) {
        for (int a = 0; a < 3; ++a) {
            lo[a] = std::min(lo[a], b.lo[a]);
            hi[a] = std::max(hi[a], b.hi[a]);
        }
    }
    void grow(const float p[3]) {
        for (int a = 0; a < 3; ++a) {
            lo[a] = std::min(lo[a], p[a]);
            hi[a] = std::max(hi[a], p[a]);
        }
    }
    bool empty() const { return lo[0] > hi[0]; }
    // Half the surface area; SAH only needs ratios. Double, so huge scenes cannot overflow.
    double halfArea() const {
        if (empty()) return 0.0;
        double dx = double(hi[0]) - lo[0], dy = double(hi[1]) - lo[1], dz = double(hi[2]) - lo[2];
        return dx * dy + dy * dz + dz * dx;
    }
};

struct PrimRef {
    Box box;
    float centroid[3];
    int index;
};

struct Task {
    int begin, end, depth, parent; // parent >= 0: this task is the parent's second child
    uint32_t up;                   // the parent node (CB_BVH_NO_PARENT for the root)
};

// Relative costs of one traversal step and one primitive test (pbrt-v3's choice).
constexpr double kTraversalCost = 1.0;
constexpr double kIntersectionCost = 1.0;

struct Split {
    int axis = -1;
    int bin = 0; // left side: bins [0, bin)
    double cost = std::numeric_limits<double>::infinity();
};

// Primitive tests of a leaf of `count` primitives, tested `perTest` at a time.
double testBlocks(int count, int perTest) {
    return double((count + perTest - 1) / perTest);
}

int binOf(float c, float lo, float scale, int bins) {
    int b = int((c - lo) * scale);
    return std::clamp(b, 0, bins - 1);
}

// Binned SAH over the centroid bounds (Wald 2007, sec. 3): one pass bins the primitives, two
// sweeps evaluate the bins-1 candidate planes per axis.
Split findSplit(const std::vector<PrimRef>& refs, int begin, int end, const Box& centroids,
                int bins, int primitivesPerTest) {
    Split best;
    std::vector<Box> binBox(bins);
    std::vector<int> binCount(bins);
    std::vector<double> rightArea(bins);
    std::vector<int> rightCount(bins);
    for (int axis = 0; axis < 3; ++axis) {
        float lo = centroids.lo[axis], hi = centroids.hi[axis];
        if (!(hi > lo)) continue;
        float scale = float(bins) / (hi - lo);
        std::fill(binBox.begin(), binBox.end(), Box{});
        std::fill(binCount.begin(), binCount.end(), 0);
        for (int i = begin; i < end; ++i) {
            int b = binOf(refs[i].centroid[axis], lo, scale, bins);
            binBox[b].grow(refs[i].box);
            ++binCount[b];
        }
        Box acc;
        int count = 0;
        for (int b = bins - 1; b > 0; --b) {
            acc.grow(binBox[b]);
            count += binCount[b];
            rightArea[b] = acc.halfArea();
            rightCount[b] = count;
        }
        acc = Box{};
        count = 0;
        for (int b = 1; b < bins; ++b) {
            acc.grow(binBox[b - 1]);
            count += binCount[b - 1];
            if (count == 0 || rightCount[b] == 0) continue;
            double cost = testBlocks(count, primitivesPerTest) * acc.halfArea() +
                          testBlocks(rightCount[b], primitivesPerTest) * rightArea[b];
            if (cost < best.cost) {
                best.cost = cost;
                best.axis = axis;
                best.bin = b;
            }
        }
    }
    return best;
}

} // namespace

void primitiveBounds(const cbk::Primitive& prim, float lo[3], float hi[3]) {
    if (prim.kind == CB_PRIM_CURVE) { // its box, kept in p0 and p1
        for (int a = 0; a < 3; ++a) {
            lo[a] = prim.p0[a];
            hi[a] = prim.p1[a];
        }
        return;
    }
    if (prim.kind == CB_PRIM_SPHERE) {
        float r = std::fabs(prim.p1[0]);
        for (int a = 0; a < 3; ++a) {
            // c -/+ r rounds to nearest; step outwards so the box contains the sphere.
            lo[a] = std::nextafter(prim.p0[a] - r, -kInf);
            hi[a] = std::nextafter(prim.p0[a] + r, kInf);
        }
        return;
    }
    for (int a = 0; a < 3; ++a) {
        lo[a] = std::min({prim.p0[a], prim.p1[a], prim.p2[a]});
        hi[a] = std::max({prim.p0[a], prim.p1[a], prim.p2[a]});
    }
}

Bvh buildBvh(std::vector<cbk::Primitive> primitives, const BvhBuildOptions& options) {
    const int maxLeaf = std::max(1, options.maxLeafSize);
    const int bins = std::max(2, options.bins);
    const int perTest = std::max(1, options.primitivesPerTest);
    const int n = int(primitives.size());

    Bvh bvh;
    if (n == 0) {
        cbk::BvhNode empty{};
        for (int a = 0; a < 3; ++a) {
            empty.boundsMin[a] = kInf;
            empty.boundsMax[a] = -kInf;
        }
        empty.index = 0;
        empty.count = CB_BVH_LEAF;
        bvh.nodes.push_back(empty);
        bvh.depth = 1;
        return bvh;
    }

    std::vector<PrimRef> refs(n);
    for (int i = 0; i < n; ++i) {
        primitiveBounds(primitives[i], refs[i].box.lo, refs[i].box.hi);
        for (int a = 0; a < 3; ++a)
            refs[i].centroid[a] = 0.5f * refs[i].box.lo[a] + 0.5f * refs[i].box.hi[a];
        refs[i].index = i;
    }

    bvh.nodes.reserve(2 * size_t(n));
    std::vector<int> secondChild; // per node; -1 for leaves
    secondChild.reserve(2 * size_t(n));
    // An explicit stack keeps deep (unbalanced) trees from overflowing the call stack; popping
    // the first child before the second emits the nodes in depth-first preorder.
    if (2 * size_t(n) > size_t(CB_BVH_PARENT_MASK))
        throw std::length_error("BVH: too many primitives for 29-bit parent indices");
    std::vector<Task> stack{{0, n, 1, -1, CB_BVH_NO_PARENT}};
    while (!stack.empty()) {
        Task task = stack.back();
        stack.pop_back();
        const int nodeIndex = int(bvh.nodes.size());
        if (task.parent >= 0) secondChild[task.parent] = nodeIndex;
        bvh.depth = std::max(bvh.depth, task.depth);

        Box bounds, centroids;
        for (int i = task.begin; i < task.end; ++i) {
            bounds.grow(refs[i].box);
            centroids.grow(refs[i].centroid);
        }
        cbk::BvhNode node{};
        for (int a = 0; a < 3; ++a) {
            node.boundsMin[a] = bounds.lo[a];
            node.boundsMax[a] = bounds.hi[a];
        }

        const int count = task.end - task.begin;
        int mid = -1;
        int splitAxis = 0;
        if (count > 1) {
            Split split = findSplit(refs, task.begin, task.end, centroids, bins, perTest);
            const double leafCost = kIntersectionCost * testBlocks(count, perTest);
            const double splitCost =
                kTraversalCost + kIntersectionCost * split.cost / bounds.halfArea();
            const bool preferLeaf = split.axis < 0 || leafCost <= splitCost;
            if (count > maxLeaf || !preferLeaf) {
                if (split.axis >= 0) {
                    const int axis = split.axis;
                    splitAxis = axis;
                    const float lo = centroids.lo[axis];
                    const float scale = float(bins) / (centroids.hi[axis] - lo);
                    auto it = std::partition(
                        refs.begin() + task.begin, refs.begin() + task.end, [&](const PrimRef& r) {
                            return binOf(r.centroid[axis], lo, scale, bins) < split.bin;
                        });
                    mid = int(it - refs.begin());
                } else {
                    // All centroids coincide: no plane separates them, split the list in half.
                    mid = task.begin + count / 2;
                }
            }
        }

        if (mid < 0) {
            node.index = uint32_t(task.begin);
            node.count = uint32_t(count) | CB_BVH_LEAF;
            bvh.nodes.push_back(node);
            secondChild.push_back(-1);
        } else {
            // The first child is the low side of the split axis, which the ordered traversal
            // relies on to pick the near child.
            node.count = (uint32_t(splitAxis) << CB_BVH_AXIS_SHIFT) | task.up;
            bvh.nodes.push_back(node); // skip index filled in below
            secondChild.push_back(-1);
            stack.push_back({mid, task.end, task.depth + 1, nodeIndex, uint32_t(nodeIndex)});
            stack.push_back({task.begin, mid, task.depth + 1, -1, uint32_t(nodeIndex)});
        }
    }

    // A subtree ends where its last (second) child's subtree ends; a leaf's ends right after it.
    std::vector<uint32_t> skip(bvh.nodes.size());
    for (int i = int(bvh.nodes.size()) - 1; i >= 0; --i) {
        if (bvh.nodes[i].count & CB_BVH_LEAF)
            skip[i] = uint32_t(i + 1);
        else
            skip[i] = skip[secondChild[i]];
    }
    for (size_t i = 0; i < bvh.nodes.size(); ++i)
        if (!(bvh.nodes[i].count & CB_BVH_LEAF)) bvh.nodes[i].index = skip[i];

    bvh.primitives.resize(n);
    bvh.originalIndex.resize(n);
    for (int i = 0; i < n; ++i) {
        bvh.primitives[i] = primitives[refs[i].index];
        bvh.originalIndex[i] = refs[i].index;
    }
    return bvh;
}

} // namespace cb
