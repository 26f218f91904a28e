// What made a render, recorded in its EXR header so that files can be combined (image/combine.h)
// and compared without side files: method, vertex caps, seed, estimates, CPU time and the scene.
#pragma once

#include "image/accumulator.h"
#include "image/image.h"
#include "image/render_state.h"

#include <array>
#include <cstdint>
#include <string>

namespace cb {

struct RenderRecord {
    std::string method; // pt | cpt | bdpt | cbdpt | mlt, or "combine:HOW" for a combination
    int eyeVertices = 0;
    int lightVertices = 0;
    int maxVertices = 0; // --max-vertices N: every strategy with s + t <= N; 0: the caps alone
    std::string weights;
    int coherenceTile = 0;
    int rouletteVertex = 0;
    std::uint32_t seed = 0;
    // sobol | independent (the sample vectors, docs/sampling.md) | mlt (its chains' own samples);
    // empty in files written before it was recorded. A Sobol render's estimates are points of
    // one randomised sequence, so its halves (and its shards) are not independent.
    std::string sampler;
    // --cropwindow's pixel bounds of the full film, "x0 x1 y0 y1"; empty for the whole film.
    std::string pixelBounds;
    // --strategy S,T: one BDPT strategy, unweighted (a debugging image); empty otherwise.
    std::string strategy;
    // --max-component-value V: the film's per-sample clamp given on the command line ("inf":
    // none); empty where the scene file's holds (its hash covers it).
    std::string maxComponentValue;
    int channels = 0; // 3 (RGB) or 16 (spectral bins)
    int width = 0, height = 0;
    long estimates = 0;
    // The estimate indices held: with the seed they name the random numbers used, so two
    // renders with overlapping sets and one seed are not independent.
    EstimateSet estimateSet;
    double renderSeconds = 0.0;
    double renderCpuSeconds = 0.0;
    std::string sceneFile; // the scene file's name (no folder)
    std::string sceneHash; // sceneContentHash of the scene file, its Includes and meshes
    std::string inputs;    // combinations: the input files
};

// --cropwindow's pixel bounds as RenderRecord::pixelBounds writes them.
std::string pixelBoundsText(const std::array<int, 4>& bounds);
// RenderRecord::sampler of a render of `method` with --sampler `sampler` (MLT: its own chains).
std::string recordedSampler(const std::string& method, const std::string& sampler);
// RenderRecord::strategy of --strategy S,T; empty when S < 0 (no --strategy).
std::string strategyText(int s, int t);

// The record of a render from its state's identity (`cbdpt merge`): the scene file's name and
// the render times are not in a state, so they are left empty and zero.
RenderRecord renderRecordFromIdentity(const RenderIdentity& identity);

// Attribute names are "cbdpt_" + the field in snake case (cbdpt_method, cbdpt_eye_vertices...).
ExrAttributes toExrAttributes(const RenderRecord& record);
// Throws std::runtime_error naming `path` if the header holds no render record.
RenderRecord renderRecordFromExr(const ExrAttributes& attributes, const std::string& path);

// Writes a render's EXR: R,G,B (the mean), stderr, the halves' means and standard errors
// (layers half0, half0.stderr, half1, half1.stderr) when the accumulator tracks them, and the
// record (its estimate count and size taken from the accumulator) in the header.
void writeRenderExr(const std::string& path, const EstimateAccumulator& accumulator,
                    RenderRecord record);

} // namespace cb
