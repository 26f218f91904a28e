// Writes the NanoVDB test file scenes/pbrt-v4/volumes/ball.nvdb and, on stdout, NanoVDB's own
// trilinear samples of its "density" grid at 400 world points in and around it
// (tests/nanovdb/ball-samples.txt), for tests/test_grid_media.cpp and docs/pbrt-v4.md's "NanoVDB
// media". Built against NanoVDB's headers (the nanovdb/ folder of OpenVDB, as pbrt-v4 pins it),
// not part of the build:
//
//   g++ -std=c++17 -I PBRT_SRC/src/ext/openvdb/nanovdb tests/nanovdb/make_ball.cpp -o make_ball
//   ./make_ball scenes/pbrt-v4/volumes/ball.nvdb > tests/nanovdb/ball-samples.txt
//
// Two grids: "temperature" (three times the density) first, "density" second; each a ball of
// varying density beside a block of constant 0.5 whose leaves NanoVDB's builder prunes into
// tiles, with voxels of 0.25 translated by (1, 2, -0.5).
#include <cmath>
#include <cstdio>
#include <nanovdb/NanoVDB.h>
#include <nanovdb/util/GridBuilder.h>
#include <nanovdb/util/IO.h>
#include <nanovdb/util/SampleFromVoxels.h>
#include <random>
#include <vector>
int main(int argc, char** argv) {
    using namespace nanovdb;
    auto makeGrid = [](const char* name, float scaleValue) {
        GridBuilder<float> builder(0.0f, GridClass::FogVolume);
        auto func = [scaleValue](const Coord& ijk) -> float {
            // A constant block of whole leaves (pruned into tiles) beside a smooth ball.
            if (ijk[0] >= 24 && ijk[0] <= 39 && ijk[1] >= 8 && ijk[1] <= 23 && ijk[2] >= 8 &&
                ijk[2] <= 15)
                return 0.5f * scaleValue;
            const double dx = ijk[0] - 11.0, dy = ijk[1] - 10.0, dz = ijk[2] - 10.0;
            const double r = std::sqrt(dx * dx + dy * dy + dz * dz);
            return r < 10.0
                       ? float((1.0 - r / 10.0) * (1.0 + 0.3 * std::sin(0.7 * ijk[0]))) * scaleValue
                       : 0.0f;
        };
        builder(func, CoordBBox(Coord(0, 0, 0), Coord(39, 27, 20)));
        Map map;
        const double dx = 0.25;
        const double mat[4][4] = {{dx, 0, 0, 0}, {0, dx, 0, 0}, {0, 0, dx, 0}, {1.0, 2.0, -0.5, 1}};
        const double inv[4][4] = {{1 / dx, 0, 0, 0},
                                  {0, 1 / dx, 0, 0},
                                  {0, 0, 1 / dx, 0},
                                  {-1.0 / dx, -2.0 / dx, 0.5 / dx, 1}};
        map.set(mat, inv, 1.0);
        return builder.getHandle(map, name);
    };
    std::vector<GridHandle<HostBuffer>> handles;
    handles.push_back(makeGrid("temperature", 3.0f));
    handles.push_back(makeGrid("density", 1.0f));
    io::writeGrids(argv[1], handles, io::Codec::NONE);
    // Trilinear samples of the density grid at world points in and around its bounds.
    auto* grid = handles[1].grid<float>();
    auto acc = grid->getAccessor();
    auto sampler = createSampler<1>(acc);
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    auto wb = grid->worldBBox();
    std::printf("# world bbox %.9g %.9g %.9g %.9g %.9g %.9g\n", wb.min()[0], wb.min()[1],
                wb.min()[2], wb.max()[0], wb.max()[1], wb.max()[2]);
    auto ib = grid->indexBBox();
    std::printf("# index bbox %d %d %d %d %d %d\n", ib.min()[0], ib.min()[1], ib.min()[2],
                ib.max()[0], ib.max()[1], ib.max()[2]);
    std::printf("# tiles in lower nodes %u, leaves %u\n", grid->tree().data()->mTileCount[0],
                grid->tree().nodeCount(0));
    for (int i = 0; i < 400; ++i) {
        Vec3d p(wb.min()[0] - 0.5 + u(rng) * (wb.max()[0] - wb.min()[0] + 1.0),
                wb.min()[1] - 0.5 + u(rng) * (wb.max()[1] - wb.min()[1] + 1.0),
                wb.min()[2] - 0.5 + u(rng) * (wb.max()[2] - wb.min()[2] + 1.0));
        Vec3d idx = grid->worldToIndexF(p);
        std::printf("%.9g %.9g %.9g %.9g\n", p[0], p[1], p[2], double(sampler(idx)));
    }
}
