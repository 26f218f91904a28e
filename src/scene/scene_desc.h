// The scene as parsed from a pbrt-v4-subset file: world-space shapes, materials, lights, camera
// and film. Geometry is already transformed by the current transformation matrix, so later
// stages (BVH, device upload) never see transforms.
#pragma once

#include <array>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace cb {

struct SourceLocation {
    std::string file;
    int line = 0;
    int column = 0;
    std::string str() const; // "file:line:column"
};

// Thrown for every malformed input; what() is "file:line:column: message".
class SceneError : public std::runtime_error {
  public:
    SceneError(const SourceLocation& where, const std::string& message);
    const SourceLocation& where() const { return where_; }

  private:
    SourceLocation where_;
};

// A spectral quantity exactly as written: either an RGB triple or piecewise-linear
// (wavelength in nm, value) pairs sorted by wavelength.
struct SpectrumValue {
    bool isRgb = true;
    std::array<float, 3> rgb{0.f, 0.f, 0.f};
    std::vector<std::pair<float, float>> samples;

    static SpectrumValue constant(float v) { return SpectrumValue{true, {v, v, v}, {}}; }
};

enum class MaterialKind { Diffuse, Conductor, Dielectric, Mix };

struct MaterialDesc {
    std::string name; // the MakeNamedMaterial name, or "" for an anonymous Material
    MaterialKind kind = MaterialKind::Diffuse;
    SpectrumValue reflectance = SpectrumValue::constant(0.5f); // diffuse and conductor
    float roughness = 0.f;       // conductor: as written in the file
    bool remapRoughness = true;  // conductor: pbrt-v4's default maps roughness to alpha=sqrt(r)
    float eta = 1.5f;            // dielectric
    std::array<int, 2> mix{-1, -1}; // mix: indices into SceneDesc::materials
    float amount = 0.5f;            // mix: probability of choosing mix[1] (pbrt-v4 semantics)
    SourceLocation where;
};

struct AreaLightDesc {
    SpectrumValue radiance = SpectrumValue::constant(1.f); // "L"
    float scale = 1.f;
    bool twoSided = false;
    SourceLocation where;
};

// World-space positions are kept in double: the device scene subtracts the camera position before
// rounding to float (camera-relative rendering), so a scene far from the origin keeps its detail.
struct TriangleMeshDesc {
    std::vector<std::array<double, 3>> positions; // world space
    std::vector<std::array<unsigned, 3>> triangles;
    int material = -1;
    int areaLight = -1; // index into SceneDesc::areaLights, or -1
    SourceLocation where;
};

struct SphereDesc {
    std::array<double, 3> center{0.0, 0.0, 0.0}; // world space
    float radius = 1.f;                          // world space (uniform scale applied)
    bool reverseOrientation = false;             // normals point inward
    int material = -1;
    int areaLight = -1;
    SourceLocation where;
};

struct PointLightDesc {
    std::array<double, 3> position{0.0, 0.0, 0.0}; // world space
    SpectrumValue intensity = SpectrumValue::constant(1.f); // "I"
    float scale = 1.f;
    SourceLocation where;
};

struct CameraDesc {
    // World-to-camera transform (the CTM at the Camera directive), row-major 4x4, pbrt-v4's
    // left-handed camera space: +z forward, +y up, +x right in the image.
    std::array<double, 16> worldToCamera{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    float fovDegrees = 90.f; // pbrt: the field of view of the shorter image axis
    SourceLocation where;
};

struct FilmDesc {
    int width = 1280; // pbrt-v4 defaults
    int height = 720;
    std::string filename = "pbrt.exr";
};

struct SceneDesc {
    std::string path; // the scene file, as given
    // Every file read, in order: the scene file (when parsed from a file), its Includes and
    // plymesh files; their bytes identify the scene's content (render states).
    std::vector<std::string> sourceFiles;
    CameraDesc camera;
    FilmDesc film;
    std::vector<MaterialDesc> materials;
    std::vector<AreaLightDesc> areaLights;
    std::vector<TriangleMeshDesc> meshes;
    std::vector<SphereDesc> spheres;
    std::vector<PointLightDesc> pointLights;
    bool usesSpectra = false;        // any parameter was given as `spectrum` (render spectrally)
    long droppedDegenerateTriangles = 0; // zero-area triangles removed at load
};

// Parse a scene file. Relative paths inside it (plymesh filename) are resolved against the
// scene file's folder, then each folder of the CBDPT_MODEL_PATH environment variable.
SceneDesc parseSceneFile(const std::string& path);
// Parse scene text; `virtualPath` names it in error messages and anchors relative paths.
SceneDesc parseSceneString(const std::string& text, const std::string& virtualPath);

} // namespace cb
