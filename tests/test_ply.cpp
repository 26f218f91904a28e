// PLY reader: all three encodings written by the test itself (with properties and elements the
// reader must skip, quads and a skipped pentagon), hostile files, and the Stanford meshes.
#include <doctest/doctest.h>

#include "scene/ply.h"
#include "scene/scene_desc.h"
#include "stanford_models.h"

#include <bit>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>

namespace {

namespace fs = std::filesystem;

std::string plyError(const std::string& bytes, const std::string& name = "mem.ply") {
    try {
        cb::readPlyFromMemory(bytes, name);
    } catch (const cb::SceneError& e) {
        return e.what();
    }
    return "<no error>";
}

bool contains(const std::string& s, const std::string& sub) {
    return s.find(sub) != std::string::npos;
}

// Binary writer for one endianness.
struct Bin {
    bool big;
    std::string out;
    template <typename T> void put(T v) {
        unsigned char b[sizeof(T)];
        std::memcpy(b, &v, sizeof(T));
        if (big != (std::endian::native == std::endian::big))
            for (size_t i = 0; i < sizeof(T) / 2; ++i)
                std::swap(b[i], b[sizeof(T) - 1 - i]);
        out.append(reinterpret_cast<const char*>(b), sizeof(T));
    }
};

// 5 vertices: a unit square (0..3) plus an apex (4). Faces: a quad, a triangle and a pentagon,
// which is skipped as pbrt-v4 skips faces of more than 4 vertices.
const float kPos[5][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.5f, 0.5f, 2.5f}};

std::string binaryHeader(const char* fmt) {
    return std::string("ply\nformat ") + fmt +
           " 1.0\ncomment written by test_ply\n"
           "element vertex 5\n"
           "property double x\nproperty uchar red\nproperty float y\n"
           "property list uchar float extra\nproperty float z\nproperty short s\n"
           "element face 3\n"
           "property int flags\nproperty list ushort uint vertex_index\nproperty float q\n"
           "element material 2\nproperty list int int ids\nproperty double shine\n"
           "end_header\n";
}

std::string binaryPly(bool big) {
    Bin b{big, binaryHeader(big ? "binary_big_endian" : "binary_little_endian")};
    for (int i = 0; i < 5; ++i) {
        b.put<double>(kPos[i][0]);
        b.put<uint8_t>(200);
        b.put<float>(kPos[i][1]);
        b.put<uint8_t>(static_cast<uint8_t>(i)); // list of i extra floats
        for (int k = 0; k < i; ++k)
            b.put<float>(9.f);
        b.put<float>(kPos[i][2]);
        b.put<int16_t>(-7);
    }
    const std::vector<std::vector<uint32_t>> faces{{0, 1, 2, 3}, {0, 1, 4}, {0, 1, 2, 3, 4}};
    for (const auto& f : faces) {
        b.put<int32_t>(42);
        b.put<uint16_t>(static_cast<uint16_t>(f.size()));
        for (uint32_t v : f)
            b.put<uint32_t>(v);
        b.put<float>(1.5f);
    }
    for (int m = 0; m < 2; ++m) {
        b.put<int32_t>(3);
        for (int k = 0; k < 3; ++k)
            b.put<int32_t>(k);
        b.put<double>(0.25);
    }
    return b.out;
}

void checkTestMesh(const cb::PlyMesh& m) {
    REQUIRE(m.positions.size() == 5);
    for (int i = 0; i < 5; ++i)
        for (int k = 0; k < 3; ++k)
            CHECK(m.positions[i][k] == kPos[i][k]);
    // quad -> 2, triangle -> 1, pentagon -> skipped and counted (pbrt-v4's rply_face_callback)
    REQUIRE(m.triangles.size() == 3);
    const std::array<unsigned, 3> expect[3] = {{0, 1, 2}, {0, 2, 3}, {0, 1, 4}};
    for (int i = 0; i < 3; ++i)
        CHECK(m.triangles[i] == expect[i]);
    CHECK(m.skippedFaces == 1);
    CHECK(m.normals.empty());
}

fs::path tempDir() {
    static int counter = 0;
    fs::path d = fs::temp_directory_path() /
                 ("cbdpt_test_ply_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
    fs::create_directories(d);
    return d;
}

} // namespace

TEST_CASE("ply: ascii with extra properties, lists, quads and skipped elements") {
    const std::string text = "ply\r\nformat ascii 1.0\r\ncomment x\nobj_info y\n"
                             "element vertex 5\nproperty float x\nproperty list uchar int junk\n"
                             "property float y\nproperty float z\nproperty uchar alpha\n"
                             "element face 3\nproperty uchar tag\n"
                             "property list uchar int vertex_indices\n"
                             "element edge 1\nproperty int v1\nproperty int v2\n"
                             "end_header\n"
                             "0 0 0 0 255\n"
                             "1 2 7 8 0 0 1\n"
                             "1 0 1 0 2\n"
                             "0 0 1 0 3\n"
                             "+0.5 3 1 2 3 0.5 2.5e0 4\n"
                             "9 4 0 1 2 3\n"
                             "9 3 0 1 4\n"
                             "9 5 0 1 2 3 4\n"
                             "0 1\n\n";
    checkTestMesh(cb::readPlyFromMemory(text, "a.ply"));
}

TEST_CASE("ply: binary little and big endian with skipped properties and elements") {
    checkTestMesh(cb::readPlyFromMemory(binaryPly(false), "le.ply"));
    checkTestMesh(cb::readPlyFromMemory(binaryPly(true), "be.ply"));
    // Through the file API as well.
    const fs::path d = tempDir();
    std::ofstream(d / "be.ply", std::ios::binary) << binaryPly(true);
    checkTestMesh(cb::readPly((d / "be.ply").string()));
    fs::remove_all(d);
}

TEST_CASE("ply: vertex normals are read when nx ny nz are present") {
    const std::string text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                             "property float y\nproperty float z\nproperty float nx\n"
                             "property float ny\nproperty float nz\nelement face 1\n"
                             "property list uchar uint vertex_indices\nend_header\n"
                             "0 0 0 0 0 -1\n1 0 0 0 0 -1\n0 1 0 0 0.5 -1\n3 0 1 2\n";
    const cb::PlyMesh m = cb::readPlyFromMemory(text, "n.ply");
    REQUIRE(m.normals.size() == 3);
    CHECK(m.normals[2][1] == 0.5f);
    CHECK(m.normals[2][2] == -1.f);
}

TEST_CASE("ply: truncated binary payload names element, row and byte offset") {
    std::string full = binaryPly(false);
    // Dropping the last byte leaves the header's minimum size satisfied (list contents are
    // not part of the minimum), so the failure comes from the reader itself, in element
    // 'material' row 1.
    const std::string e = plyError(full.substr(0, full.size() - 1), "cut.ply");
    CHECK(contains(e, "cut.ply:"));
    CHECK(contains(e, "element 'material' row 1"));
    CHECK(contains(e, "byte offset"));
    CHECK(contains(e, "truncated"));
    // Cut into the index list of the third face (the pentagon).
    const size_t header = binaryHeader("binary_little_endian").size();
    const size_t vertexBytes = 5 * (8 + 1 + 4 + 1 + 4 + 2) + (0 + 1 + 2 + 3 + 4) * 4;
    const size_t cut = header + vertexBytes + 26 + 22 + 4 + 2 + 6;
    const std::string e2 = plyError(full.substr(0, cut), "cut.ply");
    CHECK(contains(e2, "element 'face' row 2 (byte offset " + std::to_string(cut - 8) + ")"));
    CHECK(contains(e2, "face list of 5 indices runs past the end of the file"));
    // Cutting most of the payload fails the size check before any allocation.
    const std::string e3 = plyError(full.substr(0, header + 10), "cut.ply");
    CHECK(contains(e3, "cut.ply:18:1:"));
    CHECK(contains(e3, "only 10 bytes follow the header"));
}

TEST_CASE("ply: absurd element counts fail fast without allocating") {
    const auto t0 = std::chrono::steady_clock::now();
    for (const char* fmt : {"binary_little_endian", "ascii"}) {
        const std::string text =
            std::string("ply\nformat ") + fmt +
            " 1.0\nelement vertex 1000000000000\nproperty float x\n"
            "property float y\nproperty float z\nelement face 18446744073709551615\n"
            "property list uchar int vertex_indices\nend_header\n" +
            std::string(64, '1');
        const std::string e = plyError(text, "huge.ply");
        CHECK(contains(e, "huge.ply:9:1:"));
        CHECK(contains(e, "1000000000000 'vertex'"));
        CHECK(contains(e, "truncated file or bad counts"));
    }
    // A list length larger than the rest of the file is caught before reading it.
    Bin b{false, "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
                 "property float y\nproperty float z\nelement face 1\n"
                 "property list uint int vertex_indices\nend_header\n"};
    for (int i = 0; i < 9; ++i)
        b.put<float>(float(i));
    b.put<uint32_t>(4000000000u);
    b.put<int32_t>(0);
    const std::string e = plyError(b.out, "list.ply");
    CHECK(contains(e, "element 'face' row 0"));
    CHECK(contains(e, "4000000000 indices runs past the end"));
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    CHECK(seconds < 0.5);
}

TEST_CASE("ply: bad indices, counts and values are rejected with their position") {
    const std::string head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                             "property float y\nproperty float z\nelement face 1\n"
                             "property list uchar int vertex_indices\nend_header\n"
                             "0 0 0\n1 0 0\n0 1 0\n";
    std::string e = plyError(head + "3 0 1 3\n");
    CHECK(contains(e, "mem.ply:13:7:"));
    CHECK(contains(e, "vertex index 3 out of range (the file has 3 vertices)"));
    e = plyError(head + "3 0 -1 2\n");
    CHECK(contains(e, "mem.ply:13:5:"));
    CHECK(contains(e, "out of range"));
    e = plyError(head + "2 0 1\n");
    CHECK(contains(e, "face has 2 vertices"));
    e = plyError(head + "3 0 1 x2\n");
    CHECK(contains(e, "mem.ply:13:7:"));
    CHECK(contains(e, "expected an integer, got 'x2'"));
    e = plyError(head + "300 0 1 2\n");
    CHECK(contains(e, "mem.ply:13:1:"));
    CHECK(contains(e, "out of range for its type"));
    e = plyError(head + "3 0 1 2\n7\n");
    CHECK(contains(e, "unexpected bytes after the last element"));
    std::string nanVerts = head;
    nanVerts.replace(nanVerts.find("1 0 0\n"), 6, "nan 0 0\n");
    e = plyError(nanVerts + "3 0 1 2\n");
    CHECK(contains(e, "element 'vertex' row 1"));
    CHECK(contains(e, "not a finite float"));
    // Binary: out-of-range index and negative list length, located by element/row/offset.
    Bin b{true, "ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty float x\n"
                "property float y\nproperty float z\nelement face 2\n"
                "property list char int vertex_indices\nend_header\n"};
    for (int i = 0; i < 9; ++i)
        b.put<float>(float(i));
    b.put<int8_t>(3);
    for (int v : {0, 1, 2})
        b.put<int32_t>(v);
    b.put<int8_t>(3);
    for (int v : {0, 1, 99})
        b.put<int32_t>(v);
    e = plyError(b.out);
    CHECK(contains(e, "element 'face' row 1 (byte offset"));
    CHECK(contains(e, "vertex index 99 out of range"));
    Bin c{false, "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
                 "property float y\nproperty float z\nelement face 1\n"
                 "property list char int vertex_indices\nend_header\n"};
    for (int i = 0; i < 9; ++i)
        c.put<float>(float(i));
    c.put<int8_t>(-3);
    c.put<int32_t>(0);
    e = plyError(c.out);
    CHECK(contains(e, "negative list length"));
}

TEST_CASE("ply: malformed headers are rejected with the header line") {
    CHECK(contains(plyError("PLY\nformat ascii 1.0\n"), "mem.ply:1:1: not a PLY file"));
    CHECK(contains(plyError("ply\nformat ascii 2.0\nend_header\n"), "mem.ply:2:1:"));
    CHECK(contains(plyError("ply\nformat binary_middle_endian 1.0\nend_header\n"),
                   "mem.ply:2:1: unknown PLY format"));
    CHECK(contains(plyError("ply\nelement vertex 3\n"), "mem.ply:2:1: expected 'format'"));
    CHECK(contains(plyError("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                            "bogus line\nend_header\n"),
                   "mem.ply:5:1: unknown header keyword 'bogus'"));
    CHECK(contains(plyError("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"),
                   "missing end_header"));
    CHECK(contains(plyError("ply\nformat ascii 1.0\nproperty float x\nend_header\n"),
                   "mem.ply:3:1: property before any element"));
    CHECK(contains(plyError("ply\nformat ascii 1.0\nelement vertex -3\nend_header\n"),
                   "mem.ply:3:1: bad element count"));
    CHECK(contains(plyError("ply\nformat ascii 1.0\nelement vertex 3\nproperty float128 x\n"
                            "end_header\n"),
                   "mem.ply:4:1: unknown property type 'float128'"));
    CHECK(contains(plyError("ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\n"
                            "property float y\nend_header\n"),
                   "no 'element face'"));
    CHECK(contains(plyError("ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\n"
                            "property float y\nelement face 0\nproperty list uchar int "
                            "vertex_indices\nend_header\n"),
                   "mem.ply:3:1: vertex element lacks x, y or z"));
    CHECK(contains(plyError("ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\n"
                            "property float y\nproperty float z\nelement face 0\n"
                            "property list uchar float vertex_indices\nend_header\n"),
                   "mem.ply:8:1: vertex indices must have an integer type"));
    CHECK(contains(plyError("ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\n"
                            "property float y\nproperty float z\nelement face 0\n"
                            "property int flags\nend_header\n"),
                   "mem.ply:7:1: face element lacks"));
    CHECK(contains(plyError("", "empty.ply"), "empty.ply: missing end_header"));
    CHECK(contains(plyError("ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\n"
                            "property float y\nproperty float z\nelement face 0\n"
                            "property list uchar int vertex_indices\nend_header\n"),
                   "<no error>"));
    CHECK_THROWS_WITH_AS(cb::readPly("/nonexistent/dir/x.ply"),
                         "/nonexistent/dir/x.ply: cannot read the PLY file: no such file",
                         cb::SceneError);
}

TEST_CASE("ply: the Stanford models load with the counts and bounding boxes of docs/scenes.md") {
    if (!cbtest::stanfordModelsOrSkip()) return;
    const fs::path dir = cbtest::stanfordModelDir();
    struct Expect {
        const char* file;
        size_t vertices, triangles;
        float lo[3], hi[3];
    };
    const Expect models[] = {
        {"bunny.ply",
         17524,
         34831,
         {-0.0946795f, 0.0329870f, -0.0618740f},
         {0.0610090f, 0.1872865f, 0.0587955f}},
        {"dragon.ply",
         15025,
         29999,
         {-0.1080830f, 0.0527261f, -0.0504403f},
         {0.0964762f, 0.1972240f, 0.0412496f}},
        {"buddha.ply",
         14989,
         29998,
         {-0.0461908f, 0.0497653f, -0.0474474f},
         {0.0352328f, 0.2477987f, 0.0340584f}},
    };
    for (const Expect& x : models) {
        INFO(x.file);
        const cb::PlyMesh m = cb::readPly((dir / x.file).string());
        CHECK(m.positions.size() == x.vertices);
        CHECK(m.triangles.size() == x.triangles);
        float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
        for (const auto& p : m.positions)
            for (int k = 0; k < 3; ++k) {
                lo[k] = std::min(lo[k], p[k]);
                hi[k] = std::max(hi[k], p[k]);
            }
        for (int k = 0; k < 3; ++k) {
            CHECK(lo[k] == doctest::Approx(x.lo[k]).epsilon(1e-5));
            CHECK(hi[k] == doctest::Approx(x.hi[k]).epsilon(1e-5));
        }
    }
}
