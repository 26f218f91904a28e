// What made a render, recorded in its EXR header so that files can be combined (image/combine.h)
// and compared without side files: method, vertex caps, seed, estimates, CPU time and the scene.
#pragma once

#include "image/image.h"

#include <cstdint>
#include <string>

namespace cb {

struct RenderRecord {
    std::string method; // pt | cpt | bdpt | cbdpt | mlt, or "combine:HOW" for a combination
    int eyeVertices = 0;
    int lightVertices = 0;
    std::string weights;
    int coherenceTile = 0;
    int rouletteVertex = 0;
    std::uint32_t seed = 0;
    int channels = 0; // 3 (RGB) or 16 (spectral bins)
    int width = 0, height = 0;
    long estimates = 0;
    // Estimate numbers [estimateFirst, estimateFirst + estimates): with the seed they name the
    // random numbers used, so two renders with overlapping ranges and one seed are not
    // independent.
    long estimateFirst = 0;
    double renderSeconds = 0.0;
    double renderCpuSeconds = 0.0;
    std::string sceneFile; // the scene file's name (no folder)
    std::string sceneHash; // sceneContentHash of the scene file
    std::string inputs;    // combinations: the input files
};

// Attribute names are "cbdpt_" + the field in snake case (cbdpt_method, cbdpt_eye_vertices...).
ExrAttributes toExrAttributes(const RenderRecord& record);
// Throws std::runtime_error naming `path` if the header holds no render record.
RenderRecord renderRecordFromExr(const ExrAttributes& attributes, const std::string& path);

// Writes a render's EXR: R,G,B (the mean), stderr, the halves' means and standard errors
// (layers half0, half0.stderr, half1, half1.stderr) when the accumulator tracks them, and the
// record (its estimate count and size taken from the accumulator) in the header.
void writeRenderExr(const std::string& path, const EstimateAccumulator& accumulator,
                    RenderRecord record);

// 64-bit FNV-1a of the scene file's bytes, as 16 hex digits: two renders of one scene file agree.
// (Meshes the file references are not included; their names are part of the file.)
std::string sceneContentHash(const std::string& scenePath);

} // namespace cb
