// The scene as parsed from a pbrt-v4-subset file: world-space shapes, materials, lights, camera
// and film. Geometry is already transformed by the current transformation matrix, so later
// stages (BVH, device upload) never see transforms.
#pragma once

#include <array>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace cb {

struct SourceLocation {
    std::string file;
    int line = 0;
    int column = 0;
    std::string str() const; // "file:line:column"; "file" alone when line is 0 (the whole file)
};

// `text` with every byte that is not printable ASCII, a tab, a newline or part of a valid UTF-8
// sequence written as \xNN, so that a message quoting a file never prints raw binary.
std::string printableText(const std::string& text);

// What a file is when its first bytes say it is not text ("an OpenEXR image", "a PLY mesh", "a
// binary file"); empty when it looks like text.
std::string describeNonTextFile(const std::string& bytes);

// Thrown for every malformed input; what() is "file:line:column: message" (or "file: message"
// for the whole file), made printable.
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

enum class MaterialKind {
    Diffuse,
    Conductor,
    Dielectric,
    Mix,
    DiffuseTransmission,
    ThinDielectric,
    CoatedDiffuse,
    CoatedConductor,
    Interface, // pbrt-v4's "interface": a boundary between media that scatters nothing
    Hair       // pbrt-v4's "hair": Chiang et al. 2016's fibre BSDF (cb_bsdf.h, hairEval)
};

struct MaterialDesc {
    std::string name; // the MakeNamedMaterial name, or "" for an anonymous Material
    MaterialKind kind = MaterialKind::Diffuse;
    // diffuse, conductor and diffuse transmission (whose default, pbrt-v4's, is 0.25)
    SpectrumValue reflectance = SpectrumValue::constant(0.5f);
    SpectrumValue transmittance = SpectrumValue::constant(0.25f); // diffuse transmission
    // diffuse transmission: multiplies reflectance and transmittance, each product then clamped
    // to [0, 1] per channel or bin (pbrt-v4's DiffuseTransmissionMaterial, per wavelength)
    float scale = 1.f;
    // conductor given "eta" and "k" instead of "reflectance": its complex index of refraction,
    // with pbrt-v4's Fresnel equations (cb_bsdf.h, fresnelConductor)
    std::optional<SpectrumValue> conductorEta, conductorK;
    float roughness = 0.f; // conductor, dielectric and coats: as written in the file
    // conductor and dielectric: "vroughness" where it differs from "uroughness" (`roughness`,
    // then the roughness along dp/du): an anisotropic lobe
    std::optional<float> vRoughness;
    float baseRoughness = 0.f;  // coated conductor: the conductor's ("conductor.roughness")
    bool remapRoughness = true; // pbrt-v4: alpha = sqrt(roughness) by default
    float eta = 1.5f;           // dielectric, thin dielectric and the coats
    // dielectric and thin dielectric given "spectrum eta": the index per wavelength (dispersion),
    // in place of `eta`
    std::optional<SpectrumValue> etaSpectrum;
    // coated diffuse and coated conductor (pbrt-v4's defaults): the layer between coat and base in
    // mean free paths, the random walk's longest path and its walks per estimate
    float thickness = 0.01f;
    int layerDepth = 10;
    int layerSamples = 1;
    // the layer's single-scattering albedo where not 0, and its Henyey-Greenstein asymmetry
    std::optional<SpectrumValue> layerAlbedo;
    float layerG = 0.f;
    // diffuse, coated diffuse, diffuse transmission and coated conductor: "texture
    // reflectance", an index into SceneDesc::textures that replaces `reflectance`; -1: none
    int reflectanceTexture = -1;
    // diffuse transmission: "texture transmittance", replacing `transmittance`; -1: none
    int transmittanceTexture = -1;
    // pbrt-v4's "string normalmap": an index into SceneDesc::textures (the image read linear);
    // -1: none
    int normalMap = -1;
    // conductor, dielectric and coats: "texture roughness" (or u/v roughness naming one float
    // texture), an index into SceneDesc::textures that replaces `roughness`; -1: none
    int roughnessTexture = -1;
    // coats: "texture thickness", a float texture replacing `thickness`, an index into
    // SceneDesc::textures; -1: none
    int thicknessTexture = -1;
    // pbrt-v4's "displacement" (a bump map): a float texture, 1 x 1 for a constant, an index into
    // SceneDesc::textures; -1: none (also where the material has a normal map, which pbrt-v4 uses
    // instead)
    int displacement = -1;
    // hair (pbrt-v4's HairMaterial; `eta` its index, 1.55 by default): the absorption per unit of
    // the fibre's radius, as given by "sigma_a" or made from "eumelanin" and "pheomelanin" (RGB),
    // or else the "reflectance" it is made from per channel or bin with beta_n
    // (HairBxDF::SigmaAFromReflectance); the roughnesses beta_m and beta_n as written (the device
    // scene clamps them to [0.01, 1] as pbrt-v4), and the scales' tilt alpha in degrees
    std::optional<SpectrumValue> hairSigmaA, hairReflectance;
    float hairBetaM = 0.3f, hairBetaN = 0.3f, hairAlpha = 2.f;
    std::array<int, 2> mix{-1, -1}; // mix: indices into SceneDesc::materials
    float amount = 0.5f;            // mix: probability of choosing mix[1] (pbrt-v4 semantics)
    SourceLocation where;
};

// pbrt-v4's MakeNamedMedium of type "homogeneous": per unit of world length it absorbs
// sigma_a scale and scatters sigma_s scale of the light, by the Henyey-Greenstein phase function
// of asymmetry g.
struct MediumDesc {
    std::string name;
    SpectrumValue sigmaA = SpectrumValue::constant(1.f); // pbrt-v4's defaults
    SpectrumValue sigmaS = SpectrumValue::constant(1.f);
    float scale = 1.f;
    float g = 0.f;
    // pbrt-v4's "uniformgrid" (empty for "homogeneous"): sigma_a and sigma_s times a density
    // trilinear between nx x ny x nz samples (x fastest) over the box p0-p1 of the medium's space,
    // which mediumFromWorld (the inverse of the CTM at MakeNamedMedium, row-major 3 x 4) maps to.
    std::vector<float> density;
    std::array<int, 3> samples{0, 0, 0};
    std::array<double, 3> p0{0, 0, 0}, p1{1, 1, 1};
    std::array<double, 12> mediumFromWorld{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
    // How far inside the box the density ends, in samples on every side: 0 for "uniformgrid",
    // 0.5 for "nanovdb", which pbrt-v4 clips to the grid's bounds, its first and last samples.
    double clipSamples = 0.0;
    bool defined = false; // named by a MediumInterface, not (yet) by a MakeNamedMedium
    // Why cbdpt cannot render it ("" where it can): an error once a shape or the camera sits in
    // it.
    std::string unsupported;
    SourceLocation where;    // the MakeNamedMedium, or the first MediumInterface naming it
    SourceLocation firstUse; // the first shape or camera in it
    std::string firstUser;   // "a shape" or "the camera"
    bool used = false;
};

// Light emission is the value as written times `scale`, which is pbrt-v4's: the file's "scale"
// divided by the spectrum's photometric integral for a `spectrum` value (pbrt-v4's
// SpectrumToPhotometric), times "power" over the unit-scale power where given. An RGB value
// stands for RGB times the colour space's illuminant at luminance 1 (device_scene.cpp).
struct AreaLightDesc {
    SpectrumValue radiance = SpectrumValue::constant(1.f); // "L"
    float scale = 1.f;
    bool twoSided = false;
    // pbrt-v4's "power" (> 0; 0: not given): each shape the light is bound to emits this
    // luminous power, its radiance scaled by power / ((twoSided ? 2 : 1) pi area of that shape).
    double power = 0.0;
    SourceLocation where;
};

// pbrt-v4's (u, v) at a triangle's three corners when its shape gives none.
inline constexpr std::array<float, 6> kDefaultCornerUv{0.f, 0.f, 1.f, 0.f, 1.f, 1.f};

// World-space positions are kept in double: the device scene subtracts the camera position before
// rounding to float (camera-relative rendering), so a scene far from the origin keeps its detail.
struct TriangleMeshDesc {
    std::vector<std::array<double, 3>> positions; // world space
    std::vector<std::array<unsigned, 3>> triangles;
    int material = -1;
    int areaLight = -1; // index into SceneDesc::areaLights, or -1
    // pbrt-v4's MediumInterface at the shape: indices into SceneDesc::media, -1 vacuum; the
    // outside is the side the geometric normal points into
    int mediumInside = -1, mediumOutside = -1;
    // Per triangle, the area of the pbrt-v4 shape it belongs to (its own, a bilinear patch's, a
    // disk's in object space): what a "power" light divides by. Empty: each triangle's own.
    std::vector<double> shapeArea;
    // Per triangle, its corners' texture coordinates (u0 v0 u1 v1 u2 v2). Empty: pbrt-v4's
    // default for a triangle, (0,0) (1,0) (1,1), unless `noTexCoords` says why the shape has none
    // in cbdpt (a disk's polar coordinates are not linear over its triangles).
    std::vector<std::array<float, 6>> cornerUv;
    std::string noTexCoords;
    // Per vertex, as `positions`: pbrt-v4's "N" in world space (the normal transform, negated
    // under ReverseOrientation), which shades the mesh; empty: shaded by geometric normals.
    std::vector<std::array<double, 3>> normals;
    // pbrt-v4's shape "alpha" where below 1: an index into SceneDesc::textures, a float texture
    // (1 x 1 for a constant) whose value at a hit decides whether the hit counts (alpha 0 skips
    // it, 1 keeps it, between at random with that probability); -1: opaque.
    int alphaTexture = -1;
    // An area light's shape of alpha 0 (pbrt-v4's invisible area light): it emits and light
    // sampling reaches it, but no ray finds it.
    bool invisible = false;
    SourceLocation where;

    // Swaps triangle t's corners 1 and 2, so that its other side faces out; their (u, v) go
    // with them (pbrt-v4's default made explicit for every triangle where there was none).
    void reverseTriangle(size_t t) {
        std::swap(triangles[t][1], triangles[t][2]);
        if (cornerUv.empty() && noTexCoords.empty())
            cornerUv.assign(triangles.size(), kDefaultCornerUv);
        if (cornerUv.empty()) return;
        std::swap(cornerUv[t][2], cornerUv[t][4]);
        std::swap(cornerUv[t][3], cornerUv[t][5]);
    }
};

struct SphereDesc {
    std::array<double, 3> center{0.0, 0.0, 0.0}; // world space
    float radius = 1.f;                          // world space (uniform scale applied)
    bool reverseOrientation = false;             // normals point inward
    int material = -1;
    int areaLight = -1;
    int mediumInside = -1, mediumOutside = -1; // as TriangleMeshDesc's
    bool invisible = false; // an area light of alpha 0, as TriangleMeshDesc::invisible
    double shapeArea = 0.0; // pbrt-v4's Sphere::Area(): 4 pi times the object-space radius^2
    double scale = 1.0;     // the CTM's uniform scale: world radius over object radius
    // The CTM's rotation (its uniform scale divided out; a mirror allowed), row-major: the
    // object frame in which pbrt-v4 gives the sphere its (u, v).
    std::array<double, 9> worldFromObject{1, 0, 0, 0, 1, 0, 0, 0, 1};
    SourceLocation where;
};

// One cubic Bezier segment of pbrt-v4's "curve" shape (its CurveCommon), in world space: the
// kernels hit its 2^splitDepth pieces (cb_curve.h).
struct CurveDesc {
    enum class Type { Flat, Ribbon, Cylinder }; // pbrt-v4's CurveType
    std::array<std::array<double, 3>, 4> cp{};  // control points, world space
    float width0 = 1.f, width1 = 1.f;           // at u = 0 and 1, world space
    Type type = Type::Flat;
    std::array<std::array<double, 3>, 2> normals{}; // a ribbon's at u = 0 and 1, unit, world
    int splitDepth = 3;
    bool mirrored = false; // the CTM mirrors
    bool reverseOrientation = false;
    int material = -1;
    int mediumInside = -1, mediumOutside = -1; // as TriangleMeshDesc's
    SourceLocation where;
};

// An image of pbrt-v4's lights ("infinite", "goniometric"): square, in pbrt-v4's equal-area
// octahedral layout, linear RGB, row-major, top row first (pbrt-v4's v = 0).
struct LightImage {
    int size = 0; // pixels per side; 0: no image
    std::vector<float> rgb;
    std::string path;
};

struct PointLightDesc {
    std::array<double, 3> position{0.0, 0.0, 0.0};          // world space
    SpectrumValue intensity = SpectrumValue::constant(1.f); // "I"
    float scale = 1.f;
    // LightSource "spot": intensity falls off from 1 at cos = spotCosStart to 0 at spotCosEnd.
    bool spot = false;
    std::array<double, 3> spotAxis{0.0, 0.0, 1.0}; // world space, unit
    float spotCosStart = 1.f, spotCosEnd = 1.f;
    // LightSource "goniometric": intensity I * scale times the image's pixel (its RGB mean) in
    // each direction of the light's frame (worldFromLight, pbrt-v4's with y and z swapped).
    LightImage image;
    std::array<double, 9> worldFromLight{1, 0, 0, 0, 1, 0, 0, 0, 1};
    SourceLocation where;
};

// LightSource "distant": radiance L * scale arriving from one direction (irradiance L * scale on
// a surface facing it).
struct DistantLightDesc {
    std::array<double, 3> direction{0.0, 0.0, -1.0};       // world space, unit, toward the light
    SpectrumValue radiance = SpectrumValue::constant(1.f); // "L"
    float scale = 1.f;
    SourceLocation where;
};

// LightSource "infinite": radiance L * scale from every direction, or with "string filename"
// pbrt-v4's ImageInfiniteLight: the image's pixel (RGB emission times scale) seen in each
// direction through pbrt-v4's equal-area octahedral map, in the light's frame.
struct InfiniteLightDesc {
    SpectrumValue radiance = SpectrumValue::constant(1.f); // "L"
    float scale = 1.f;
    LightImage image; // size 0 for a constant L
    // The rotation from the light's frame to world, row-major: the CTM at the LightSource with
    // its uniform scale divided out.
    std::array<double, 9> worldFromLight{1, 0, 0, 0, 1, 0, 0, 0, 1};
    // pbrt-v4's "point3 portal": a rectangle in world space (corners p0 p1 p2 p3) through which
    // alone the light arrives (PortalImageInfiniteLight::Le); empty for none.
    std::vector<std::array<double, 3>> portal;
    SourceLocation where;
};

// pbrt-v4's Texture "name" "spectrum" "imagemap": an image of linear RGB texels (its "scale"
// and "invert" applied), looked up at a surface point's texture coordinates (u, v) through
// pbrt-v4's "uv" mapping, s = uscale u + udelta, t = vscale v + vdelta, with t running up the
// image (kernels/cb_texture.h).
struct TextureDesc {
    enum class Wrap { Repeat, Black, Clamp };
    std::string name;
    int width = 0, height = 0;
    std::vector<float> rgb; // row-major, top row first
    std::string path;       // the image file; "" for one made of constants (a checkerboard)
    Wrap wrap = Wrap::Repeat;
    bool nearest = false; // "point" filter: the nearest texel, not bilinear
    std::array<float, 4> mapping{1.f, 1.f, 0.f, 0.f}; // uscale, vscale, udelta, vdelta
    // pbrt-v4's mapping: (u, v), or the hit point's in texture space (the inverse of the CTM at
    // the Texture directive), by direction ("spherical"), about z ("cylindrical") or along v1, v2
    // ("planar", whose projection rows 0 and 1 hold: s = row 0 . (p, 1) + udelta)
    // Point: pbrt-v4's 3D PointTransformMapping of the procedural textures (`noise`)
    enum class Mapping { Uv, Spherical, Cylindrical, Planar, Point };
    Mapping mappingKind = Mapping::Uv;
    std::array<double, 12> textureFromWorld{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0}; // 3 x 4
    // pbrt-v4's "directionmix" (the fields above unused): its parts tex1 and tex2, images, mixed
    // per hit by |n . mixDirection| (world space, unit) at the geometric normal n; empty: an image.
    std::vector<TextureDesc> mixParts;
    std::array<double, 3> mixDirection{0, 1, 0};
    // pbrt-v4's procedural float textures (no texels; mappingKind Point): fractional Brownian
    // motion ("fbm"), turbulence ("wrinkled", both of `octaves` octaves and omega, pbrt-v4's
    // "roughness") and "windy"; None for an image.
    enum class Noise { None, Fbm, Wrinkled, Windy };
    Noise noise = Noise::None;
    int octaves = 8;
    double omega = 0.5;
    SourceLocation where;
};

struct CameraDesc {
    // World-to-camera transform (the CTM at the Camera directive), row-major 4x4, pbrt-v4's
    // left-handed camera space: +z forward, +y up, +x right in the image.
    std::array<double, 16> worldToCamera{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    float fovDegrees = 90.f; // pbrt: the field of view of the shorter image axis
    // pbrt-v4's thin lens, in camera space: radius 0 is the pinhole; in focus at z =
    // focalDistance (pbrt-v4's default 1e6)
    float lensRadius = 0.f;
    float focalDistance = 1e6f;
    // pbrt-v4's screen window, x0 x1 y0 y1 in units of the tangent of half the field of view:
    // "screenwindow", else [-a, a] x [-1, 1] for a frame aspect ratio a > 1 ([-1, 1] x [-1/a, 1/a]
    // otherwise), a the "frameaspectratio" or the film's width / height.
    std::optional<double> frameAspectRatio;
    std::optional<std::array<double, 4>> screenWindow;
    // pbrt-v4's CameraMedium, the outside of the MediumInterface at the Camera directive: an index
    // into SceneDesc::media, -1 vacuum
    int medium = -1;
    SourceLocation where;
};

// pbrt-v4's "rgb" film with its "cie1931" sensor or a camera's (docs/scene-format.md).
struct FilmDesc {
    int width = 1280; // pbrt-v4 defaults
    int height = 720;
    std::string filename = "pbrt.exr";
    double iso = 100.0;
    double whiteBalance = 0.0; // kelvin; 0: no white balance (the cie1931 default)
    // pbrt-v4's "sensor": empty for "cie1931", else a camera of spectral/camera_sensors.h, whose
    // white balance is 6500 K where whiteBalance is 0. The scene then renders spectrally.
    std::string sensor;
    SourceLocation sensorWhere;
    double exposureTime = 1.0; // the camera's shutterclose - shutteropen
    // pbrt-v4's "maxcomponentvalue": each sample's sensor RGB is scaled down to at most this
    // largest component (kernels' filmClampSample); absent: no clamp (pbrt-v4's infinity).
    std::optional<double> maxComponentValue;
    bool saveFp16 = true; // pbrt-v4's default: half-float EXR
    bool saveFp16Given = false;
    // pbrt's pixel bounds x0, x1, y0, y1: only pixels [x0, x1) x [y0, y1) of the film are
    // rendered, into an image of that size (cropWindowPixels). Absent: the whole film.
    std::optional<std::array<int, 4>> pixelBounds;
    // The file's "cropwindow" (or its "pixelbounds" as fractions of its resolution): what the
    // pixel bounds become when the command line changes the resolution.
    std::optional<std::array<double, 4>> cropWindow;
};

// pbrt-v4's crop window: fractions x0, x1, y0, y1 of the film, 0 <= x0 < x1 <= 1 and the same
// for y, as pixel bounds [ceil(W x0), ceil(W x1)) x [ceil(H y0), ceil(H y1)). Throws
// std::invalid_argument, its message starting with `label` (where the window came from), when a
// fraction is outside [0, 1], the window is reversed or it holds no pixel.
std::array<int, 4> cropWindowPixels(int width, int height, const std::array<double, 4>& crop,
                                    const std::string& label = "--cropwindow");

// pbrt-v4's PixelFilter (kernels/cb_filter.h): its type, radii in pixels and the gaussian's
// standard deviation. A scene built in code gets the thesis's one-pixel box; a parsed file
// without PixelFilter gets pbrt-v4's default, pbrtDefault().
struct FilterDesc {
    enum class Type { Box, Triangle, Gaussian, Mitchell, Sinc };
    Type type = Type::Box;
    double radiusX = 0.5;
    double radiusY = 0.5;
    double sigma = 0.5;         // the gaussian's
    double mitchellB = 1.0 / 3; // Mitchell and Netravali's B and C
    double mitchellC = 1.0 / 3;
    double sincTau = 3.0; // the Lanczos window's
    SourceLocation where; // the PixelFilter line; none for a default

    static FilterDesc pbrtDefault() {
        FilterDesc f;
        f.type = Type::Gaussian;
        f.radiusX = f.radiusY = 1.5;
        return f;
    }
};

// pbrt-v4's Sampler and Integrator lines: cbdpt's defaults for the render (the command line
// overrides them).
struct SamplerDesc {
    std::string type;     // "" when the file has no Sampler
    int pixelSamples = 0; // 0 when not given
    SourceLocation where;
};

struct IntegratorDesc {
    std::string type;  // "" when the file has no Integrator; else "pt", "bdpt" or "mlt"
    int maxDepth = -1; // pbrt-v4's "maxdepth" (bounces); -1 when not given
    SourceLocation where;
};

struct SceneDesc {
    std::string path; // the scene file, as given
    // Every file read, in order: the scene file (when parsed from a file), its Includes and
    // plymesh files; their bytes identify the scene's content (render states).
    std::vector<std::string> sourceFiles;
    CameraDesc camera;
    FilmDesc film;
    FilterDesc filter;
    SamplerDesc sampler;
    IntegratorDesc integrator;
    std::vector<std::string> notes; // what was read but not used, each reported once on stderr
    std::vector<MaterialDesc> materials;
    std::vector<AreaLightDesc> areaLights;
    std::vector<TriangleMeshDesc> meshes;
    std::vector<SphereDesc> spheres;
    std::vector<CurveDesc> curves;
    std::vector<PointLightDesc> pointLights;
    std::vector<DistantLightDesc> distantLights;
    std::vector<InfiniteLightDesc> infiniteLights; // at most one
    std::vector<TextureDesc> textures;             // those a material uses
    std::vector<MediumDesc> media;                 // named by MakeNamedMedium or MediumInterface
    bool usesSpectra = false; // any parameter was given as `spectrum` (render spectrally)
    long droppedDegenerateTriangles = 0; // zero-area triangles removed at load
};

// The materials a mix blends, none of them a mix, each with its weight: pbrt-v4's "amount" is
// the second material's probability, nested mixes multiply theirs, and a material reached twice
// has its weights summed. A material that is not a mix is itself, of weight 1. Mixes that
// contain themselves are refused by the parser.
std::vector<std::pair<int, double>> mixLeaves(const SceneDesc& scene, int material);

// Parse a scene file. Relative paths inside it (plymesh filename) are resolved against the
// scene file's folder, then each folder of the CBDPT_MODEL_PATH environment variable.
SceneDesc parseSceneFile(const std::string& path);
// Parse scene text; `virtualPath` names it in error messages and anchors relative paths.
SceneDesc parseSceneString(const std::string& text, const std::string& virtualPath);

} // namespace cb
