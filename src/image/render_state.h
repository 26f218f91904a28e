// The portable state of a render: its exact sums, the estimate indices they hold, the render's
// settings and a hash of the scene's content, in a versioned little-endian file with a checksum
// (format in docs/scale-out.md). `--resume` continues a state, `cbdpt merge` adds states of
// disjoint estimate sets, and MPI ranks reduce the same sums.
#pragma once

#include "image/accumulator.h"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace cb {

constexpr std::uint32_t kRenderStateVersion = 3;

// "<exr path>.state"
std::string renderStatePath(const std::string& exrPath);

// What identifies a render: the settings that change its image (integrator, caps, seed, size,
// channels, kernel sources...) and the hash of its scene files' bytes. Two states merge or
// resume only when these are equal.
struct RenderIdentity {
    nlohmann::json settings = nlohmann::json::object();
    std::string sceneHash; // hex of contentHash over the scene file, its Includes and meshes
};

// A 64-bit FNV-1a hash of the bytes of `files` in order (their names are left out, so the
// same scene in another folder or on another machine hashes the same). Throws naming a file
// it cannot read.
std::string sceneContentHash(const std::vector<std::string>& files);
// A hash of the kernel sources in use (kernelSources: CBDPT_KERNEL_DIR's files replace the
// embedded ones) and of CBDPT_KERNEL_OPTIONS: states of other kernels do not mix.
std::string kernelSourceHash();

// Lines "key: saved X, here Y" for each difference, empty when the identities match.
std::vector<std::string> identityDifferences(const RenderIdentity& saved,
                                             const RenderIdentity& here);

struct RenderState {
    RenderIdentity identity;
    EstimateAccumulator accumulator{0, 0};
};

// Serialises to the portable format (checksum last); saveRenderState writes it atomically.
std::string encodeRenderState(const RenderIdentity& identity,
                              const EstimateAccumulator& accumulator);
void saveRenderState(const std::string& path, const RenderIdentity& identity,
                     const EstimateAccumulator& accumulator);

// Parses a state; throws std::runtime_error naming `path` and what is wrong: not a state
// file, another format version, truncated, corrupted (checksum), inconsistent contents.
RenderState decodeRenderState(const std::string& bytes, const std::string& path);
RenderState loadRenderState(const std::string& path);

// Loads `path` for `--resume` into `accumulator` after checking it was made by the same render
// (same identity and image size); throws std::runtime_error saying what differs.
void resumeRenderState(const std::string& path, const RenderIdentity& identity,
                       EstimateAccumulator& accumulator);

} // namespace cb
