#include "bvh/bvh_wide.h"

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>

namespace cb {
namespace {

double halfArea(const cbk::BvhNode& n) {
    double d[3];
    for (int a = 0; a < 3; ++a)
        d[a] = double(n.boundsMax[a]) - double(n.boundsMin[a]);
    if (d[0] < 0.0) return 0.0;
    return d[0] * d[1] + d[1] * d[2] + d[2] * d[0];
}

bool isLeaf(const cbk::BvhNode& n) {
    return (n.count & CB_BVH_LEAF) != 0u;
}

// The two children of binary interior node i (preorder: the first is i + 1).
void binaryChildren(const std::vector<cbk::BvhNode>& nodes, uint32_t i, uint32_t out[2]) {
    out[0] = i + 1;
    out[1] = isLeaf(nodes[i + 1]) ? i + 2 : nodes[i + 1].index;
}

// Appends the packs of primitives [first, first + count): the triangles four to a pack, the
// alpha-tested ones in packs of their own, then any other primitives (spheres) in packs of their
// own. Returns the number of packs.
uint32_t packLeaf(const std::vector<cbk::Primitive>& prims, uint32_t first, uint32_t count,
                  std::vector<cbk::TrianglePack>* packs) {
    std::vector<uint32_t> triangles, alphaTested, others;
    for (uint32_t p = first; p < first + count; ++p)
        (prims[p].kind == CB_PRIM_TRIANGLE         ? triangles
         : prims[p].kind == CB_PRIM_ALPHA_TRIANGLE ? alphaTested
                                                   : others)
            .push_back(p);
    const auto start = packs->size();
    for (const auto* group : {&triangles, &alphaTested, &others})
        for (size_t i = 0; i < group->size(); i += CB_PACK_LANES) {
            cbk::TrianglePack pack{};
            pack.count = int(std::min<size_t>(CB_PACK_LANES, group->size() - i));
            pack.scalar = group == &others;
            pack.alphaTested = group == &alphaTested;
            for (int k = 0; k < CB_PACK_LANES; ++k) {
                // Lanes past the count repeat lane 0.
                const uint32_t index = (*group)[i + size_t(k < pack.count ? k : 0)];
                pack.prim[k] = int(index);
                if (pack.scalar) continue;
                for (int a = 0; a < 3; ++a) {
                    pack.v[0][a][k] = prims[index].p0[a];
                    pack.v[1][a][k] = prims[index].p1[a];
                    pack.v[2][a][k] = prims[index].p2[a];
                }
            }
            packs->push_back(pack);
        }
    return uint32_t(packs->size() - start);
}

} // namespace

bool treePrefetchPays(std::size_t treeBytes, unsigned long long cacheBytes, bool cpuDevice) {
    return cpuDevice && cacheBytes > 0 && treeBytes > cacheBytes;
}

BvhWide collapseBvhWide(const Bvh& bvh) {
    const auto& bin = bvh.nodes;
    constexpr float kInf = std::numeric_limits<float>::infinity();
    BvhWide wide;
    std::vector<cbk::BvhNodeWide>& out = wide.nodes;
    struct Task {
        uint32_t binary; // binary node whose children this wide node holds (or a root leaf)
        uint32_t parent; // wide parent
        uint32_t slot;   // wide node to write, already allocated
        uint32_t lane;   // its lane in the parent
    };
    out.push_back({});
    std::vector<Task> todo{{0u, CB_BVHW_NONE, 0u, 0u}};
    while (!todo.empty()) {
        Task t = todo.back();
        todo.pop_back();
        // Children: open the interior child with the largest area until there are four.
        std::vector<uint32_t> kids;
        if (isLeaf(bin[t.binary])) {
            kids.push_back(t.binary); // a tree that is one leaf: the root holds it
        } else {
            uint32_t c[2];
            binaryChildren(bin, t.binary, c);
            kids = {c[0], c[1]};
            while (kids.size() < CB_BVH_WIDE_LANES) {
                int best = -1;
                double bestArea = -1.0;
                for (size_t k = 0; k < kids.size(); ++k)
                    if (!isLeaf(bin[kids[k]]) && halfArea(bin[kids[k]]) > bestArea) {
                        best = int(k);
                        bestArea = halfArea(bin[kids[k]]);
                    }
                if (best < 0) break;
                binaryChildren(bin, kids[size_t(best)], c);
                kids[size_t(best)] = c[0];
                kids.insert(kids.begin() + best + 1, c[1]);
            }
        }
        // Interior children first, then leaves, then empty leaves: an interior child at lane k
        // is then node child[0] + k (its block of siblings is allocated in lane order below),
        // so the traversal computes the next node's address without waiting for a load.
        auto rank = [&](uint32_t b) {
            if (!isLeaf(bin[b])) return 0;
            return (bin[b].count & ~CB_BVH_LEAF) != 0 ? 1 : 2;
        };
        std::stable_sort(kids.begin(), kids.end(),
                         [&](uint32_t a, uint32_t b) { return rank(a) < rank(b); });
        cbk::BvhNodeWide node{};
        node.parent = t.parent;
        node.lane = t.lane;
        for (uint32_t k = 0; k < uint32_t(CB_BVH_WIDE_LANES); ++k) {
            const bool emptyLeaf =
                k < kids.size() && isLeaf(bin[kids[k]]) && (bin[kids[k]].count & ~CB_BVH_LEAF) == 0;
            if (k >= kids.size() || emptyLeaf) {
                for (int a = 0; a < 3; ++a) {
                    node.lo[a][k] = kInf;
                    node.hi[a][k] = -kInf;
                }
                node.child[k] = CB_BVHW_NONE;
                continue;
            }
            const auto& b = bin[kids[k]];
            for (int a = 0; a < 3; ++a) {
                node.lo[a][k] = b.boundsMin[a];
                node.hi[a][k] = b.boundsMax[a];
            }
            if (isLeaf(b)) {
                node.child[k] = uint32_t(wide.packs.size());
                const uint32_t packCount =
                    packLeaf(bvh.primitives, b.index, b.count & ~CB_BVH_LEAF, &wide.packs);
                if (packCount > 255)
                    throw std::length_error("wide BVH: leaves hold at most 255 packs of " +
                                            std::to_string(CB_PACK_LANES) + " primitives");
                node.counts[k / 4] |= packCount << (8 * (k % 4));
            } else {
                node.child[k] = uint32_t(out.size());
                out.push_back({});
                todo.push_back({kids[k], t.slot, node.child[k], k});
            }
        }
        out[t.slot] = node;
    }
    return wide;
}

} // namespace cb
