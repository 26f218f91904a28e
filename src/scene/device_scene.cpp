#include "scene/device_scene.h"
#include "scene/scene_bytes.h"

#include "scene/transform.h"
#include "spectral/spectral.h"

#include "cb_camera.h"
#include "cb_medium.h"
#include "cb_texture.h"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <limits>
#include <map>
#include <numeric>
#include <tuple>

namespace cb {

static_assert(sizeof(cbk::Primitive) == 48, "Primitive must match the OpenCL layout");
static_assert(sizeof(cbk::Material) == 128, "Material must match the OpenCL layout");
static_assert(sizeof(cbk::Light) == 116, "Light must match the OpenCL layout");
static_assert(sizeof(cbk::Camera) == 480, "Camera must match the OpenCL layout");

namespace {

// A triangle's slot in `shadingNormals`: its corners' normals in the mesh's world space (device
// coordinates only translate), unnormalised as pbrt-v4 interpolates them; zeros where the mesh
// has none, or where a normal does not fit a float (the kernel then shades by ng).
std::array<float, 9> cornerNormals(const TriangleMeshDesc& mesh,
                                   const std::array<unsigned, 3>& tri) {
    std::array<float, 9> slot{};
    if (mesh.normals.empty()) return slot;
    for (size_t k = 0; k < 3; ++k)
        for (size_t a = 0; a < 3; ++a)
            slot[3 * k + a] = float(mesh.normals[tri[k]][a]);
    if (!std::all_of(slot.begin(), slot.end(), [](float v) { return std::isfinite(v); })) slot = {};
    return slot;
}

// A sphere's slot in `textures` (cb_texture.h, sphereTexCoord): the quaternion (x, y, z, w) of
// the rotation from world to its object frame, then -1 where that frame is mirrored (x negated
// after the rotation), else 1; entry 5 is the caller's. World from object, W, is orthogonal; a
// mirrored one is a rotation R times diag(-1, 1, 1), so that object = diag(-1, 1, 1) R^T world.
std::array<float, 6> sphereFrameSlot(const std::array<double, 9>& w) {
    const double det = w[0] * (w[4] * w[8] - w[5] * w[7]) - w[1] * (w[3] * w[8] - w[5] * w[6]) +
                       w[2] * (w[3] * w[7] - w[4] * w[6]);
    std::array<double, 9> r = w;
    if (det < 0.0)
        for (int row = 0; row < 3; ++row)
            r[size_t(row * 3)] = -r[size_t(row * 3)];
    // The quaternion of M = R^T (Shepperd 1978: from the largest of the trace and the diagonal).
    auto m = [&](int i, int j) { return r[size_t(j * 3 + i)]; };
    double x, y, z, qw;
    const double trace = m(0, 0) + m(1, 1) + m(2, 2);
    if (trace > 0.0) {
        const double s = 2.0 * std::sqrt(trace + 1.0);
        qw = 0.25 * s, x = (m(2, 1) - m(1, 2)) / s, y = (m(0, 2) - m(2, 0)) / s,
        z = (m(1, 0) - m(0, 1)) / s;
    } else if (m(0, 0) > m(1, 1) && m(0, 0) > m(2, 2)) {
        const double s = 2.0 * std::sqrt(1.0 + m(0, 0) - m(1, 1) - m(2, 2));
        qw = (m(2, 1) - m(1, 2)) / s, x = 0.25 * s, y = (m(0, 1) + m(1, 0)) / s,
        z = (m(0, 2) + m(2, 0)) / s;
    } else if (m(1, 1) > m(2, 2)) {
        const double s = 2.0 * std::sqrt(1.0 + m(1, 1) - m(0, 0) - m(2, 2));
        qw = (m(0, 2) - m(2, 0)) / s, x = (m(0, 1) + m(1, 0)) / s, y = 0.25 * s,
        z = (m(1, 2) + m(2, 1)) / s;
    } else {
        const double s = 2.0 * std::sqrt(1.0 + m(2, 2) - m(0, 0) - m(1, 1));
        qw = (m(1, 0) - m(0, 1)) / s, x = (m(0, 2) + m(2, 0)) / s, y = (m(1, 2) + m(2, 1)) / s,
        z = 0.25 * s;
    }
    return {float(x), float(y), float(z), float(qw), det < 0.0 ? -1.f : 1.f, 0.f};
}

// A medium's grid after its three entries (cb_medium.h, mediumGrid): nx, ny, nz (0 for a
// homogeneous medium), the map from device coordinates (world minus `origin`) to the samples'
// coordinates, pbrt-v4's SampledGrid lookup (the point's offset in the box p0-p1 times n, minus
// 0.5) after the medium's own transform, the clip, and the densities; padded to whole entries of
// `channels` floats.
void addMediumGrid(const MediumDesc& medium, const std::array<double, 3>& origin, int channels,
                   std::vector<float>& spectra) {
    const size_t header = spectra.size();
    spectra.resize(header + CB_GRID_HEADER, 0.f);
    if (!medium.density.empty()) {
        for (size_t axis = 0; axis < 3; ++axis) {
            const double n = medium.samples[axis];
            const double perUnit = n / (medium.p1[axis] - medium.p0[axis]);
            spectra[header + axis] = float(n);
            const double* row = &medium.mediumFromWorld[axis * 4];
            double translation = row[3] + row[0] * origin[0] + row[1] * origin[1] +
                                 row[2] * origin[2] - medium.p0[axis];
            for (size_t col = 0; col < 3; ++col)
                spectra[header + CB_GRID_MAP + axis * 4 + col] = float(row[col] * perUnit);
            spectra[header + CB_GRID_MAP + axis * 4 + 3] = float(translation * perUnit - 0.5);
        }
        spectra[header + CB_GRID_CLIP] = float(medium.clipSamples);
        if (spectra.size() + medium.density.size() + size_t(channels) >
            size_t(std::numeric_limits<int>::max()))
            throw SceneError(medium.where,
                             fmt::format("medium \"{}\": its {} densities, with the scene's other "
                                         "spectra, exceed the 2^31 - 1 floats the kernels index",
                                         medium.name, medium.density.size()));
        spectra.insert(spectra.end(), medium.density.begin(), medium.density.end());
    }
    spectra.resize((spectra.size() + size_t(channels) - 1) / size_t(channels) * size_t(channels),
                   0.f);
}

class SpectraTable {
  public:
    SpectraTable(int channels, std::vector<float>& data) : channels_(channels), data_(data) {}

    // Emission (`emission` true) follows pbrt-v4's illuminant meaning: an RGB value is RGB times
    // the colour space's white illuminant, a spectrum is converted by the film's own CMFs.
    int add(const SpectrumValue& value, float scale, bool emission = false) {
        int index = int(data_.size()) / channels_;
        if (channels_ == kSpectralBins) {
            std::array<float, kSpectralBins> bins =
                value.isRgb
                    ? (emission ? rgbIlluminantSpectrum(value.rgb) : rgbToSpectrum(value.rgb))
                    : binSpectrum(value.samples);
            for (float b : bins)
                data_.push_back(b * scale);
        } else {
            std::array<float, 3> rgb = value.isRgb ? value.rgb
                                                   : (emission ? emissionToRgb(value.samples)
                                                               : spectrumToRgb(value.samples));
            for (float c : rgb)
                data_.push_back(c * scale);
        }
        return index;
    }
    // An entry of `value` in every channel (not a colour: a medium's asymmetry g).
    int addConstant(float value) {
        const int index = int(data_.size()) / channels_;
        data_.insert(data_.end(), size_t(channels_), value);
        return index;
    }
    // A reflectance or transmittance times `scale`, clamped to [0, 1] per channel or bin
    // (pbrt-v4 clamps per wavelength).
    int addAlbedo(const SpectrumValue& value, float scale) {
        const int index = add(value, scale);
        for (int i = 0; i < channels_; ++i) {
            float& v = data_[size_t(index * channels_ + i)];
            v = std::clamp(v, 0.f, 1.f);
        }
        return index;
    }
    // An emission entry: radiance and scale each fit a float, but their product need not
    // ("rgb L" [1e20 ...] with "float scale" 1e20): an infinite emission made every light's pick
    // probability NaN.
    int addEmission(const SpectrumValue& value, float scale, const SourceLocation& where) {
        const int index = add(value, scale, true);
        for (int i = 0; i < channels_; ++i)
            if (!std::isfinite(data_[size_t(index * channels_ + i)]))
                throw SceneError(where, fmt::format("the light's emission times its \"float "
                                                    "scale\" {:g} exceeds the float range "
                                                    "(3.4e38)",
                                                    scale));
        return index;
    }
    // Raw bins (spectral scenes only): the image lights' Smits basis and illuminant.
    int addBins(const std::array<float, kSpectralBins>& bins) {
        if (channels_ != kSpectralBins) throw std::logic_error("SpectraTable::addBins: RGB table");
        const int index = int(data_.size()) / channels_;
        data_.insert(data_.end(), bins.begin(), bins.end());
        return index;
    }
    // Values that are not one spectrum (a dispersive index's knots), padded with zeros to whole
    // entries: the first entry's index.
    int addValues(const std::vector<float>& values) {
        const int index = int(data_.size()) / channels_;
        data_.insert(data_.end(), values.begin(), values.end());
        data_.resize((data_.size() + size_t(channels_) - 1) / size_t(channels_) * size_t(channels_),
                     0.f);
        return index;
    }
    double maxComponent(int index) const {
        double m = 0.0;
        for (int i = 0; i < channels_; ++i)
            m = std::max(m, double(data_[size_t(index * channels_ + i)]));
        return m;
    }
    double average(int index) const {
        double sum = 0.0; // in double: entries near the float maximum must not sum to +Inf
        for (int i = 0; i < channels_; ++i)
            sum += data_[size_t(index * channels_ + i)];
        return sum / double(channels_);
    }

  private:
    int channels_;
    std::vector<float>& data_;
};

// An image light's sampling tables and pixel values, appended to `tables` at the returned
// offset (cb_lights.h, imageLightPixelPdf, imageLightPixelEmission): the CDF over rows, then each
// row's CDF over its pixels, by `weight` (each pixel's mean emission), accumulated in double,
// then `pixels`, the values the kernels read.
int appendImageTables(int size, const std::vector<double>& weight, const std::vector<float>& pixels,
                      std::vector<float>& tables) {
    const size_t n = size_t(size);
    // A CDF of `count` weights, rounded to float with its last value exactly 1; uniform when
    // every weight is zero (those intervals are then never chosen through the row CDF).
    auto appendCdf = [&](const double* w, size_t count) {
        const double total = std::accumulate(w, w + count, 0.0);
        double running = 0.0;
        tables.push_back(0.f);
        for (size_t i = 0; i < count; ++i) {
            running += total > 0.0 ? w[i] : 1.0;
            tables.push_back(float(running / (total > 0.0 ? total : double(count))));
        }
        tables.back() = 1.f;
    };
    std::vector<double> rowSums(n);
    for (size_t y = 0; y < n; ++y)
        rowSums[y] = std::accumulate(&weight[y * n], &weight[y * n] + n, 0.0);
    const int offset = int(tables.size());
    tables.reserve(tables.size() + (n + 1) * (n + 1) + pixels.size());
    appendCdf(rowSums.data(), n);
    for (size_t y = 0; y < n; ++y)
        appendCdf(&weight[y * n], n);
    tables.insert(tables.end(), pixels.begin(), pixels.end());
    return offset;
}

// An image light's pixel value (clamped to zero, as pbrt-v4's ImageLe clamps it) times what its
// light multiplies it by (`factor`, named by `what`), which must stay a float.
float scaledPixel(double value, double factor, const char* what, const LightImage& image,
                  size_t pixel, const SourceLocation& where) {
    const float v = float(std::max(value, 0.0) * factor);
    if (!std::isfinite(v))
        throw SceneError(where, fmt::format("the light's image {} at pixel ({}, {}), {:g}, times "
                                            "{} {:g} exceeds the float range (3.4e38)",
                                            image.path, pixel % size_t(image.size),
                                            pixel / size_t(image.size), value, what, factor));
    return v;
}

// The light's image fields: its size, tables and frame.
void setLightImage(cbk::Light& light, int size, int table, const std::array<double, 9>& frame) {
    light.imageSize = size;
    light.imageTable = table;
    for (size_t i = 0; i < 9; ++i)
        light.worldFromLight[i] = float(frame[i]);
}

// The camera position in world space (double), used as the origin of the device scene.
std::array<double, 3> cameraPosition(const SceneDesc& desc) {
    Mat4 worldToCamera;
    worldToCamera.m = desc.camera.worldToCamera;
    std::optional<Mat4> cameraToWorld = inverse(worldToCamera);
    if (!cameraToWorld)
        throw SceneError(desc.camera.where, "the camera transform is singular (check "
                                            "LookAt/Scale before Camera)");
    return {(*cameraToWorld)(0, 3), (*cameraToWorld)(1, 3), (*cameraToWorld)(2, 3)};
}

// The origin of device coordinates: the camera position clamped to the world bounds of the
// geometry and point lights. With the camera among the geometry this is the camera itself
// (float is finest where the image needs it); with a camera far outside (a telephoto view from
// 1e4 away, say) it is the nearest point of the scene, so that the vertices, hit points and every
// secondary ray keep coordinates of the scene's own size instead of the camera distance.
std::array<double, 3> deviceOrigin(const SceneDesc& desc) {
    std::array<double, 3> lo{HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi{-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    auto grow = [&](const std::array<double, 3>& p, double r) {
        for (size_t a = 0; a < 3; ++a) {
            lo[a] = std::min(lo[a], p[a] - r);
            hi[a] = std::max(hi[a], p[a] + r);
        }
    };
    for (const auto& mesh : desc.meshes)
        for (const auto& p : mesh.positions)
            grow(p, 0.0);
    for (const auto& sphere : desc.spheres)
        grow(sphere.center, double(sphere.radius));
    for (const auto& curve : desc.curves)
        for (const auto& p : curve.cp)
            grow(p, 0.5 * std::max(curve.width0, curve.width1));
    for (const auto& light : desc.pointLights)
        grow(light.position, 0.0);
    std::array<double, 3> origin = cameraPosition(desc);
    if (lo[0] > hi[0]) return origin; // nothing placed: buildDeviceScene reports it
    for (size_t a = 0; a < 3; ++a)
        origin[a] = std::clamp(origin[a], lo[a], hi[a]);
    return origin;
}

// Narrows the camera to pixels [x0, x1) x [y0, y1) of its film: a screen window that is that part
// of the full one, so rays, projections and importance (per pixel area) are the full film's.
void cropCamera(cbk::Camera& camera, const std::array<int, 4>& bounds,
                const SourceLocation& where) {
    const auto [x0, x1, y0, y1] = bounds;
    if (!(0 <= x0 && x0 < x1 && x1 <= camera.width && 0 <= y0 && y0 < y1 && y1 <= camera.height))
        throw SceneError(where,
                         fmt::format("pixel bounds {} {} {} {} are not inside the {}x{} film", x0,
                                     x1, y0, y1, camera.width, camera.height));
    const double w = camera.width, h = camera.height;
    const double tanX = camera.tanHalfFovX, tanY = camera.tanHalfFovY;
    camera.screenCenterX = float(camera.screenCenterX + (double(x0 + x1) / w - 1.0) * tanX);
    camera.screenCenterY = float(camera.screenCenterY + (1.0 - double(y0 + y1) / h) * tanY);
    camera.tanHalfFovX = float(tanX * double(x1 - x0) / w);
    camera.tanHalfFovY = float(tanY * double(y1 - y0) / h);
    camera.width = x1 - x0;
    camera.height = y1 - y0;
}

// A filter with negative lobes (cb_filter.h, filterTableSample1): per axis, the share of the
// integral of |f1| over [0, r] below each bin's start and (r / bins) / the integral of f1 over
// [0, r], and the normalisation 1 / (4 Ix Iy), from cb_filter.h's own f1 by Simpson's rule on 64
// panels per bin, in double. Ix and Iy are positive for the parameters the parser accepts:
// Mitchell's r / 4 for every B and C, the sinc's above min(r, 0.04) / 2 (a scan of tau and r).
void tabulateLobedFilter(cbk::Camera& camera) {
    constexpr int kBins = CB_FILTER_TABLE_BINS, kPanels = 64;
    double halfIntegral[2];
    for (int axis = 0; axis < 2; ++axis) {
        const cbk::FilterAxis f = cbk::filterAxisOf(&camera, axis);
        const double binWidth = double(f.radius) / kBins, h = binWidth / (2 * kPanels);
        std::array<double, kBins + 1> absBelow{};
        double signedSum = 0.0;
        for (int bin = 0; bin < kBins; ++bin) {
            double absSum = 0.0;
            for (int i = 0; i <= 2 * kPanels; ++i) {
                const double weight = i == 0 || i == 2 * kPanels ? 1.0 : i % 2 ? 4.0 : 2.0;
                // f1 at the bin's end is its value from inside, (-r, r) being open.
                const double x = std::min(bin * binWidth + i * h, double(f.radius) * (1 - 1e-7));
                const double value = cbk::filterEval1(&f, float(x));
                absSum += weight * std::fabs(value);
                signedSum += weight * value;
            }
            absBelow[size_t(bin + 1)] = absBelow[size_t(bin)] + absSum * h / 3.0;
        }
        halfIntegral[axis] = signedSum * h / 3.0;
        for (int i = 0; i <= kBins; ++i)
            camera.filterAbsCdf[axis][i] = float(absBelow[size_t(i)] / absBelow[kBins]);
        camera.filterAbsCdf[axis][kBins] = 1.0f;
        camera.filterSampleScale[axis] = float(binWidth / halfIntegral[axis]);
    }
    camera.filterNormalization = float(1.0 / (4.0 * halfIntegral[0] * halfIntegral[1]));
}

cbk::Camera makeCamera(const SceneDesc& desc, const std::array<double, 3>& origin) {
    const FilmDesc& film = desc.film;
    SourceLocation where = desc.camera.where;
    if (film.width <= 0 || film.height <= 0)
        throw SceneError(
            where, fmt::format("film resolution {}x{} must be positive", film.width, film.height));
    float fov = desc.camera.fovDegrees;
    if (!(fov > 0.f && fov < 180.f))
        throw SceneError(where, fmt::format("field of view {} must be in (0, 180) degrees", fov));
    cbk::Camera camera{};
    camera.medium = -1; // set with the scene's other media (buildDeviceScene)
    // Device coordinates are world coordinates minus `origin`: worldToCamera * Translate(origin).
    Mat4 worldToCamera;
    worldToCamera.m = desc.camera.worldToCamera;
    worldToCamera = worldToCamera * translateMatrix(origin[0], origin[1], origin[2]);
    const auto& w2c = worldToCamera.m;
    std::optional<Mat4> cameraToWorld = inverse(worldToCamera);
    if (!cameraToWorld)
        throw SceneError(where, "the camera transform is singular (check LookAt/Scale before "
                                "Camera)");
    const auto& c2w = cameraToWorld->m;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c) {
            camera.worldToCamera[r * 4 + c] = float(w2c[size_t(r * 4 + c)]);
            camera.cameraToWorld[r * 4 + c] = float(c2w[size_t(r * 4 + c)]);
        }
    // pbrt-v4: the field of view spans the shorter side of the screen window, which is the frame
    // aspect ratio's (the film's unless "frameaspectratio" is given) or "screenwindow".
    double tanHalf = std::tan(double(fov) * M_PI / 360.0);
    double aspect = desc.camera.frameAspectRatio.value_or(double(film.width) / double(film.height));
    camera.tanHalfFovX = float(aspect >= 1.0 ? tanHalf * aspect : tanHalf);
    camera.tanHalfFovY = float(aspect >= 1.0 ? tanHalf : tanHalf / aspect);
    if (const auto& s = desc.camera.screenWindow) {
        camera.tanHalfFovX = float(tanHalf * ((*s)[1] - (*s)[0]) / 2.0);
        camera.tanHalfFovY = float(tanHalf * ((*s)[3] - (*s)[2]) / 2.0);
        camera.screenCenterX = float(tanHalf * ((*s)[0] + (*s)[1]) / 2.0);
        camera.screenCenterY = float(tanHalf * ((*s)[2] + (*s)[3]) / 2.0);
    }
    camera.width = film.width;
    camera.height = film.height;
    camera.lensRadius = desc.camera.lensRadius;
    camera.focalDistance = desc.camera.focalDistance;
    const FilterDesc& filter = desc.filter;
    switch (filter.type) {
    case FilterDesc::Type::Box:
        camera.filterType = CB_FILTER_BOX;
        break;
    case FilterDesc::Type::Triangle:
        camera.filterType = CB_FILTER_TRIANGLE;
        break;
    case FilterDesc::Type::Gaussian:
        camera.filterType = CB_FILTER_GAUSSIAN;
        break;
    case FilterDesc::Type::Mitchell:
        camera.filterType = CB_FILTER_MITCHELL;
        break;
    case FilterDesc::Type::Sinc:
        camera.filterType = CB_FILTER_SINC;
        break;
    }
    camera.filterRadiusX = float(filter.radiusX);
    camera.filterRadiusY = float(filter.radiusY);
    camera.filterSigma = float(filter.sigma);
    camera.filterMitchellB = float(filter.mitchellB);
    camera.filterMitchellC = float(filter.mitchellC);
    camera.filterSincTau = float(filter.sincTau);
    if (cbk::filterHasNegativeLobes(camera.filterType))
        tabulateLobedFilter(camera);
    else
        camera.filterNormalization = cbk::filterNormalization(
            camera.filterType, camera.filterRadiusX, camera.filterRadiusY, camera.filterSigma);
    if (film.pixelBounds) cropCamera(camera, *film.pixelBounds, where);
    return camera;
}

// The kernels' watertight triangle test multiplies three sheared coordinates (edge functions
// times z), about 200 c^3 for coordinates up to c from the device origin: beyond ~1.2e12 that
// overflows float and the geometry silently vanishes (a sphere's c^2 terms go later, its area at
// 1e19). Below the limit a scene renders like the same scene at unit size.
constexpr double kMaxDeviceCoordinate = 1e12;

void requireInFloatRange(const std::array<double, 3>& p, double radius,
                         const std::array<double, 3>& origin, const SourceLocation& where,
                         const char* what) {
    double far = 0.0;
    for (size_t a = 0; a < 3; ++a)
        far = std::max(far, std::fabs(p[a] - origin[a]) + radius);
    if (!(far <= kMaxDeviceCoordinate))
        throw SceneError(where, fmt::format("{} reaches {:g} from the camera (or the scene point "
                                            "nearest to it) along an axis; cbdpt's float "
                                            "intersection supports up to {:g}: scale the scene "
                                            "down or drop far geometry",
                                            what, far, kMaxDeviceCoordinate));
}

std::uint64_t materialFeature(MaterialKind kind) {
    switch (kind) {
    case MaterialKind::Diffuse:
        return CB_FEATURE_DIFFUSE;
    case MaterialKind::Conductor:
        return CB_FEATURE_CONDUCTOR;
    case MaterialKind::Dielectric:
        return CB_FEATURE_DIELECTRIC;
    case MaterialKind::Mix:
        return CB_FEATURE_MIX;
    case MaterialKind::DiffuseTransmission:
        return CB_FEATURE_DIFFUSE_TRANSMISSION;
    case MaterialKind::ThinDielectric:
        return CB_FEATURE_THIN_DIELECTRIC;
    case MaterialKind::CoatedDiffuse:
        return CB_FEATURE_COATED_DIFFUSE;
    case MaterialKind::CoatedConductor:
        return CB_FEATURE_COATED_CONDUCTOR;
    case MaterialKind::Interface:
        return CB_FEATURE_INTERFACE;
    case MaterialKind::Hair:
        return CB_FEATURE_HAIR;
    }
    return 0;
}

// Whether a mix picks one part per surface point (CB_MAT_MIX_AT_POINT) rather than mixing its
// parts' f and pdfs: where a part is a coat (whose pdf is an estimate), has its own shading
// normal (a normal or bump map) or follows one wavelength (a dispersive dielectric).
bool mixPicksPerPoint(const SceneDesc& desc, const std::vector<std::pair<int, double>>& leaves) {
    return std::any_of(leaves.begin(), leaves.end(), [&](const auto& leaf) {
        const MaterialDesc& m = desc.materials[size_t(leaf.first)];
        return m.kind == MaterialKind::CoatedDiffuse || m.kind == MaterialKind::CoatedConductor ||
               m.normalMap >= 0 || m.displacement >= 0 || m.etaSpectrum;
    });
}

} // namespace

DeviceScene buildDeviceScene(const SceneDesc& desc, ChannelMode mode) {
    DeviceScene scene;
    bool spectral =
        mode == ChannelMode::Spectral || (mode == ChannelMode::Auto && desc.usesSpectra);
    scene.channels = spectral ? kSpectralBins : 3;
    if (!desc.film.sensor.empty() && !spectral)
        throw SceneError(desc.film.sensorWhere,
                         "the camera sensor \"" + desc.film.sensor +
                             "\" responds to spectra: render it spectrally (--channels "
                             "spectral or auto), not in RGB");
    const FilmColour filmColour{desc.film.whiteBalance,
                                desc.film.exposureTime * desc.film.iso / 100.0, desc.film.sensor};
    scene.toRgb = filmMatrix(scene.channels, filmColour);
    // Camera-relative rendering: positions are made relative to the camera (or, for a camera
    // outside the scene, to the scene point nearest to it: deviceOrigin) in double, then rounded
    // to float, so precision is finest where the image needs it and a scene far from the world
    // origin renders like the same scene at the origin.
    scene.origin = deviceOrigin(desc);
    scene.camera = makeCamera(desc, scene.origin);
    if (desc.film.maxComponentValue) {
        scene.camera.sampleClamp = float(*desc.film.maxComponentValue);
        const auto sensor = sensorFromFilmRgb(filmColour);
        std::copy(sensor.begin(), sensor.end(), scene.camera.sensorFromRgb);
        scene.features |= CB_FEATURE_SAMPLE_CLAMP;
    }
    if (scene.camera.lensRadius > 0.f) scene.features |= CB_FEATURE_THIN_LENS;
    if (!(scene.camera.filterType == CB_FILTER_BOX && scene.camera.filterRadiusX == 0.5f &&
          scene.camera.filterRadiusY == 0.5f))
        scene.features |= CB_FEATURE_PIXEL_FILTER;
    auto toDevice = [&](const std::array<double, 3>& p, float* out) {
        for (int a = 0; a < 3; ++a)
            out[a] = float(p[size_t(a)] - scene.origin[size_t(a)]);
    };
    SpectraTable spectra(scene.channels, scene.spectra);

    // Materials: the scene's, plus a constant-one entry used by kinds without a reflectance.
    std::vector<bool> materialUsed(desc.materials.size(), false);
    // Each used mix's leaves, expanded once, when a shape first uses it: texture coordinates,
    // refusals and the chain below ask for them again, and a mix may have up to 100000.
    std::vector<std::vector<std::pair<int, double>>> leavesOf(desc.materials.size());
    auto markUsed = [&](int m) {
        if (m >= 0 && size_t(m) < materialUsed.size() && !materialUsed[size_t(m)]) {
            materialUsed[size_t(m)] = true;
            if (desc.materials[size_t(m)].kind != MaterialKind::Mix) return;
            leavesOf[size_t(m)] = mixLeaves(desc, m);
            for (const auto& [leaf, weight] : leavesOf[size_t(m)])
                materialUsed[size_t(leaf)] = true;
        }
    };
    for (const auto& mesh : desc.meshes)
        markUsed(mesh.material);
    for (const auto& sphere : desc.spheres)
        markUsed(sphere.material);
    for (const auto& curve : desc.curves)
        markUsed(curve.material);

    // Image textures (cb_texture.h): each one a material uses, once, at an offset into the
    // images that follow the primitives' texture coordinates in `textures` (fixed up below).
    // Whether material m (or a mix's part) looks a texture up by (u, v): every texture but one
    // mapped by the hit point, and normal and bump maps (their tangents follow (u, v)).
    auto needsTexCoords = [&](int m) {
        if (m < 0) return false;
        const MaterialDesc& md = desc.materials[size_t(m)];
        auto byUv = [&](int texture) {
            if (texture < 0) return false;
            const TextureDesc& t = desc.textures[size_t(texture)];
            auto uv = [](const TextureDesc& image) {
                return image.mappingKind == TextureDesc::Mapping::Uv;
            };
            return t.mixParts.empty() ? uv(t)
                                      : std::any_of(t.mixParts.begin(), t.mixParts.end(), uv);
        };
        auto uses = [&](const MaterialDesc& d) {
            return byUv(d.reflectanceTexture) || byUv(d.transmittanceTexture) ||
                   byUv(d.roughnessTexture) || byUv(d.thicknessTexture) || d.normalMap >= 0 ||
                   d.displacement >= 0 || d.vRoughness.has_value() || d.kind == MaterialKind::Hair;
        };
        if (md.kind != MaterialKind::Mix) return uses(md);
        const auto& leaves = leavesOf[size_t(m)];
        return std::any_of(leaves.begin(), leaves.end(), [&](const auto& leaf) {
            return uses(desc.materials[size_t(leaf.first)]);
        });
    };
    std::vector<float> images;
    std::map<int, int> imageOffset; // SceneDesc::textures index -> offset in `images`
    int smitsBasisEntry = -1;
    // An image's header and texels, appended to `images`.
    auto appendImage = [&](const TextureDesc& t) {
        if (scene.channels == kSpectralBins && smitsBasisEntry < 0) {
            const auto& basis = smitsBasis();
            smitsBasisEntry = spectra.addBins(basis[0]);
            for (size_t k = 1; k < basis.size(); ++k)
                spectra.addBins(basis[k]);
        }
        float header[CB_TEXTURE_HEADER] = {};
        header[CB_TEXTURE_WIDTH] = float(t.width);
        header[CB_TEXTURE_HEIGHT] = float(t.height);
        header[CB_TEXTURE_WRAP] = float(t.wrap == TextureDesc::Wrap::Black   ? CB_WRAP_BLACK
                                        : t.wrap == TextureDesc::Wrap::Clamp ? CB_WRAP_CLAMP
                                                                             : CB_WRAP_REPEAT);
        header[CB_TEXTURE_FILTER] = float(t.nearest ? CB_FILTER_POINT : CB_FILTER_BILINEAR);
        header[CB_TEXTURE_USCALE] = t.mapping[0];
        header[CB_TEXTURE_VSCALE] = t.mapping[1];
        header[CB_TEXTURE_UDELTA] = t.mapping[2];
        header[CB_TEXTURE_VDELTA] = t.mapping[3];
        header[CB_TEXTURE_BASIS] = float(smitsBasisEntry);
        header[CB_TEXTURE_MAPPING] =
            float(t.mappingKind == TextureDesc::Mapping::Spherical     ? CB_MAPPING_SPHERICAL
                  : t.mappingKind == TextureDesc::Mapping::Cylindrical ? CB_MAPPING_CYLINDRICAL
                  : t.mappingKind == TextureDesc::Mapping::Planar      ? CB_MAPPING_PLANAR
                  : t.mappingKind == TextureDesc::Mapping::Point       ? CB_MAPPING_NOISE
                                                                       : CB_MAPPING_UV);
        if (t.noise != TextureDesc::Noise::None) {
            header[CB_TEXTURE_NOISE_KIND] =
                float(t.noise == TextureDesc::Noise::Wrinkled ? CB_NOISE_WRINKLED
                      : t.noise == TextureDesc::Noise::Windy  ? CB_NOISE_WINDY
                                                              : CB_NOISE_FBM);
            header[CB_TEXTURE_NOISE_OCTAVES] = float(t.octaves);
            header[CB_TEXTURE_NOISE_OMEGA] = float(t.omega);
            scene.features |= CB_FEATURE_NOISE_TEXTURE;
        }
        if (t.mappingKind != TextureDesc::Mapping::Uv) {
            // The kernels' points are relative to the device origin: world = device + origin.
            for (size_t row = 0; row < 3; ++row) {
                double translation = t.textureFromWorld[4 * row + 3];
                for (size_t k = 0; k < 3; ++k) {
                    header[CB_TEXTURE_MATRIX + 4 * row + k] =
                        float(t.textureFromWorld[4 * row + k]);
                    translation += t.textureFromWorld[4 * row + k] * scene.origin[k];
                }
                header[CB_TEXTURE_MATRIX + 4 * row + 3] = float(translation);
            }
            scene.features |= CB_FEATURE_TEXTURE_MAPPING;
        }
        images.insert(images.end(), header, header + CB_TEXTURE_HEADER);
        images.insert(images.end(), t.rgb.begin(), t.rgb.end());
    };
    // Texture `index` once: an image, or a "directionmix": a header of its direction, then its
    // two parts' images one after the other (textureReflectance finds them there).
    auto addTexture = [&](int index) {
        if (auto it = imageOffset.find(index); it != imageOffset.end()) return it->second;
        const TextureDesc& t = desc.textures[size_t(index)];
        const int offset = int(images.size());
        if (t.mixParts.empty()) {
            appendImage(t);
        } else {
            float header[CB_TEXTURE_HEADER] = {};
            header[CB_TEXTURE_MAPPING] = float(CB_MAPPING_DIRECTION_MIX);
            for (size_t k = 0; k < 3; ++k)
                header[CB_TEXTURE_MATRIX + k] = float(t.mixDirection[k]);
            images.insert(images.end(), header, header + CB_TEXTURE_HEADER);
            for (const TextureDesc& part : t.mixParts)
                appendImage(part);
            scene.features |= CB_FEATURE_DIRECTION_MIX;
        }
        imageOffset[index] = offset;
        return offset;
    };

    int oneSpectrum = spectra.add(SpectrumValue::constant(1.f), 1.f);
    for (size_t i = 0; i < desc.materials.size(); ++i) {
        const MaterialDesc& m = desc.materials[i];
        cbk::Material out{};
        out.reflectance = oneSpectrum;
        out.mixFirst = out.mixSecond = -1;
        out.secondSpectrum = -1;
        out.layerAlbedo = -1;
        out.reflectanceTexture = -1;
        out.transmittanceTexture = -1;
        out.textureScale = 1.f;
        out.normalMap = -1;
        out.roughnessTexture = -1;
        out.thicknessTexture = -1;
        out.alphaTexture = -1;
        out.displacement = -1;
        out.dispersion = -1;
        out.mediumInside = out.mediumOutside = -1;
        out.remapRoughness = m.remapRoughness ? 1 : 0;
        // GGX alpha of conductors, dielectrics and coats; pbrt-v4 maps roughness r to sqrt(r).
        auto ggxAlpha = [&m](float roughness) {
            return m.remapRoughness ? std::sqrt(std::max(roughness, 0.f)) : roughness;
        };
        float alpha = ggxAlpha(m.roughness);
        // An anisotropic lobe's alpha along dp/dv (a roughness texture's lobe is isotropic); both
        // at least GGX's smallest where either is above it, as pbrt-v4's
        // TrowbridgeReitzDistribution keeps them.
        float alphaV = alpha;
        if (m.vRoughness && m.roughnessTexture < 0) {
            alphaV = std::max(ggxAlpha(*m.vRoughness), CB_GGX_MIN_ALPHA);
            alpha = std::max(alpha, CB_GGX_MIN_ALPHA);
        }
        if (m.roughnessTexture >= 0) {
            // The lobe is rough: the kernels look alpha up per hit (materialRoughnessAt), at
            // least 1e-3, which is what alpha holds here.
            alpha = 1e-3f;
            alphaV = alpha;
            if (materialUsed[i]) {
                out.roughnessTexture = addTexture(m.roughnessTexture);
                scene.features |= CB_FEATURE_TEXTURE | CB_FEATURE_ROUGHNESS_TEXTURE;
            }
        }
        // A (thin) dielectric's index per wavelength: its knots (Material.dispersion) where it
        // varies, `eta` their mean.
        auto addDispersion = [&]() {
            if (!m.etaSpectrum) return;
            if (scene.channels != kSpectralBins)
                throw SceneError(m.where, "\"spectrum eta\" varies with wavelength, which needs "
                                          "spectral rendering (not --channels rgb)");
            std::vector<float> knots;
            constexpr int kKnots = CB_DISPERSION_KNOTS_PER_BIN * kSpectralBins + 1;
            double sum = 0.0;
            for (int k = 0; k < kKnots; ++k) {
                const double nm = kLambdaMin + kBinWidth * k / CB_DISPERSION_KNOTS_PER_BIN;
                knots.push_back(float(evalPiecewiseLinear(m.etaSpectrum->samples, nm)));
                sum += (k == 0 || k == kKnots - 1 ? 0.5 : 1.0) * knots.back();
            }
            out.eta = float(sum / (kKnots - 1));
            if (std::all_of(knots.begin(), knots.end(), [&](float k) { return k == knots[0]; }))
                return; // a constant spectrum: the same expectation without the one wavelength
            if (materialUsed[i]) {
                out.dispersion = spectra.addValues(knots);
                scene.features |= CB_FEATURE_DISPERSION;
            }
        };
        switch (m.kind) {
        case MaterialKind::Diffuse:
            out.kind = CB_MAT_DIFFUSE;
            out.reflectance = spectra.add(m.reflectance, 1.f);
            break;
        case MaterialKind::Conductor:
            out.kind = CB_MAT_CONDUCTOR;
            if (m.conductorEta && m.conductorK) {
                // Bins hold each spectrum's bin means (RGB: its linear projection), and the
                // kernels evaluate Fresnel from those, not Fresnel's mean over the bin.
                out.reflectance = spectra.add(*m.conductorEta, 1.f);
                out.secondSpectrum = spectra.add(*m.conductorK, 1.f);
            } else {
                out.reflectance = spectra.add(m.reflectance, 1.f);
            }
            out.alpha = alpha;
            out.alphaV = alphaV;
            break;
        case MaterialKind::Dielectric:
            out.kind = CB_MAT_DIELECTRIC;
            out.eta = m.eta;
            addDispersion();
            // pbrt-v4 takes eta 1 as no interface, smooth at any roughness: a rough one's
            // transmission (wi = -wo) has no half vector
            out.alpha = out.eta == 1.f ? 0.f : alpha;
            out.alphaV = out.eta == 1.f ? 0.f : alphaV;
            break;
        case MaterialKind::Mix:
            out.kind = materialUsed[i] && mixPicksPerPoint(desc, leavesOf[i]) ? CB_MAT_MIX_AT_POINT
                                                                              : CB_MAT_MIX;
            out.mixFirst = m.mix[0];
            out.mixSecond = m.mix[1];
            out.mixAmount = m.amount;
            break;
        case MaterialKind::DiffuseTransmission:
            out.kind = CB_MAT_DIFFUSE_TRANSMISSION;
            out.reflectance = spectra.addAlbedo(m.reflectance, m.scale);
            out.secondSpectrum = spectra.addAlbedo(m.transmittance, m.scale);
            out.textureScale = m.scale;
            break;
        case MaterialKind::ThinDielectric:
            out.kind = CB_MAT_THIN_DIELECTRIC;
            out.eta = m.eta;
            addDispersion();
            break;
        case MaterialKind::Interface:
            out.kind = CB_MAT_INTERFACE;
            break;
        case MaterialKind::Hair: {
            out.kind = CB_MAT_HAIR;
            out.eta = m.eta;
            // pbrt-v4's HairMaterial::GetBxDF keeps both roughnesses in [0.01, 1].
            const double betaM = std::clamp(double(m.hairBetaM), 0.01, 1.0);
            const double betaN = std::clamp(double(m.hairBetaN), 0.01, 1.0);
            if (m.hairReflectance) {
                // HairBxDF::SigmaAFromReflectance (Chiang et al. 2016, eq. 9), per channel or
                // bin: the absorption whose multiple scattering gives that colour.
                out.reflectance = spectra.addAlbedo(*m.hairReflectance, 1.f);
                const double d = 5.969 - 0.215 * betaN + 2.532 * std::pow(betaN, 2) -
                                 10.73 * std::pow(betaN, 3) + 5.574 * std::pow(betaN, 4) +
                                 0.245 * std::pow(betaN, 5);
                for (int c = 0; c < scene.channels; ++c) {
                    float& v = scene.spectra[size_t(out.reflectance * scene.channels + c)];
                    const double sigma = std::pow(std::log(double(v)) / d, 2);
                    v = float(std::min(sigma, double(std::numeric_limits<float>::max())));
                }
            } else {
                out.reflectance = spectra.add(*m.hairSigmaA, 1.f);
                for (int c = 0; c < scene.channels; ++c) {
                    // Smits's RGB basis can dip a hair below 0 between its bins.
                    float& v = scene.spectra[size_t(out.reflectance * scene.channels + c)];
                    v = std::max(v, 0.f);
                }
            }
            // Chiang et al. 2016, eqs. 7 and 8: the longitudinal variance of R and the azimuthal
            // logistic scale that match their path-traced fibres' roughness.
            out.hairV = float(
                std::pow(0.726 * betaM + 0.812 * betaM * betaM + 3.7 * std::pow(betaM, 20), 2));
            out.hairS = float(0.626657069 * (0.265 * betaN + 1.194 * betaN * betaN +
                                             5.372 * std::pow(betaN, 22)));
            const double sinAlpha = std::sin(double(m.hairAlpha) * M_PI / 180.0);
            out.hairSinAlpha = float(sinAlpha);
            out.hairCosAlpha = float(std::sqrt(std::max(0.0, 1.0 - sinAlpha * sinAlpha)));
            break;
        }
        case MaterialKind::CoatedDiffuse:
        case MaterialKind::CoatedConductor: {
            const bool conductor = m.kind == MaterialKind::CoatedConductor;
            out.kind = conductor ? CB_MAT_COATED_CONDUCTOR : CB_MAT_COATED_DIFFUSE;
            if (conductor && m.conductorEta && m.conductorK) {
                out.reflectance = spectra.add(*m.conductorEta, 1.f);
                out.secondSpectrum = spectra.add(*m.conductorK, 1.f);
            } else {
                out.reflectance = spectra.addAlbedo(m.reflectance, 1.f);
            }
            out.eta = m.eta;
            // pbrt-v4 treats a coat of alpha below 1e-3 as smooth (EffectivelySmooth), and one
            // of eta 1 as no interface at all, which the smooth coat's Fresnel gives; the kernels
            // take a rough coat's alpha >= 1e-3 as given. The conductor's alpha alike.
            out.alpha = alpha < 1e-3f || m.eta == 1.f ? 0.f : alpha;
            const float baseAlpha = ggxAlpha(m.baseRoughness);
            out.baseAlpha = baseAlpha < 1e-3f ? 0.f : baseAlpha;
            // pbrt-v4 keeps the thickness at least the smallest normal float (the kernels keep a
            // texture's so per hit: materialThicknessAt)
            out.thickness = std::max(m.thickness, std::numeric_limits<float>::min());
            if (m.thicknessTexture >= 0 && materialUsed[i]) {
                out.thicknessTexture = addTexture(m.thicknessTexture);
                scene.features |= CB_FEATURE_TEXTURE | CB_FEATURE_THICKNESS_TEXTURE;
            }
            out.layerDepth = m.layerDepth;
            out.layerSamples = m.layerSamples;
            if (m.layerAlbedo) out.layerAlbedo = spectra.addAlbedo(*m.layerAlbedo, 1.f);
            out.layerG = m.layerG;
            break;
        }
        }
        if (materialUsed[i] && m.reflectanceTexture >= 0) {
            out.reflectanceTexture = addTexture(m.reflectanceTexture);
            scene.features |= CB_FEATURE_TEXTURE;
        }
        if (materialUsed[i] && m.transmittanceTexture >= 0) {
            out.transmittanceTexture = addTexture(m.transmittanceTexture);
            scene.features |= CB_FEATURE_TEXTURE;
        }
        if (materialUsed[i] && m.normalMap >= 0) {
            // The map is looked up at the hit's (u, v), which the texture buffer holds.
            out.normalMap = addTexture(m.normalMap);
            scene.features |= CB_FEATURE_TEXTURE | CB_FEATURE_NORMAL_MAP;
        }
        if (materialUsed[i] && m.displacement >= 0) {
            // A bump map: the displacement's slopes at the hit's (u, v) tilt the shading normal.
            out.displacement = addTexture(m.displacement);
            scene.features |= CB_FEATURE_TEXTURE | CB_FEATURE_BUMP_MAP;
        }
        if (m.kind != MaterialKind::Conductor && m.kind != MaterialKind::Dielectric)
            out.alphaV = out.alpha;
        if (materialUsed[i] && out.kind == CB_MAT_HAIR) {
            // Shaded in frames along dp/du at h = -1 + 2 v: the texture buffer's (u, v) give both.
            scene.features |= CB_FEATURE_TEXTURE | CB_FEATURE_ANISOTROPIC;
        }
        if (materialUsed[i] && out.alphaV != out.alpha) {
            // Shaded in frames along dp/du, which the texture buffer's (u, v) give.
            if (m.normalMap >= 0 || m.displacement >= 0)
                throw SceneError(m.where, "an anisotropic roughness with a \"normalmap\" or a "
                                          "\"displacement\" is not supported (pbrt-v4 turns the "
                                          "lobe with the bumped dp/du)");
            scene.features |= CB_FEATURE_TEXTURE | CB_FEATURE_ANISOTROPIC;
        }
        scene.materials.push_back(out);
        if (materialUsed[i]) {
            scene.features |=
                out.kind == CB_MAT_MIX_AT_POINT ? CB_FEATURE_MIX_AT_POINT : materialFeature(m.kind);
            if (out.kind == CB_MAT_CONDUCTOR && out.secondSpectrum >= 0)
                scene.features |= CB_FEATURE_CONDUCTOR_FRESNEL;
            // a rough coat scatters as a rough dielectric interface
            if ((out.kind == CB_MAT_DIELECTRIC || out.kind == CB_MAT_COATED_DIFFUSE ||
                 out.kind == CB_MAT_COATED_CONDUCTOR) &&
                out.alpha > 0.f)
                scene.features |= CB_FEATURE_ROUGH_DIELECTRIC;
        }
    }

    // A mix of mixes becomes a chain that the kernels walk (cb_bsdf.h, cbMixEval): each link's
    // first material is one of the mix's leaves (mixLeaves), its second the next link (the last
    // one's the last leaf), its amount the share of the leaves after its first. The mix's own
    // entry is the first link; the others follow the scene's materials.
    for (size_t i = 0; i < desc.materials.size(); ++i) {
        const MaterialDesc& m = desc.materials[i];
        if (m.kind != MaterialKind::Mix || !materialUsed[i] ||
            (desc.materials[size_t(m.mix[0])].kind != MaterialKind::Mix &&
             desc.materials[size_t(m.mix[1])].kind != MaterialKind::Mix))
            continue;
        auto leaves = leavesOf[i];
        std::erase_if(leaves, [](const auto& leaf) { return !(leaf.second > 0.0); });
        if (leaves.size() == 1) leaves.push_back({leaves[0].first, 0.0});
        int link = int(i);
        for (size_t k = 0; k + 1 < leaves.size(); ++k) {
            double rest = 0.0; // the weight of leaves k, k + 1, ...
            for (size_t j = k; j < leaves.size(); ++j)
                rest += leaves[j].second;
            int next = leaves[k + 1].first;
            if (k + 2 < leaves.size()) {
                scene.materials.push_back(scene.materials[i]);
                next = int(scene.materials.size()) - 1;
            }
            cbk::Material& l = scene.materials[size_t(link)];
            l.mixFirst = leaves[k].first;
            l.mixSecond = next;
            l.mixAmount = float(1.0 - leaves[k].second / rest);
            link = next;
        }
    }

    // Primitives. Area lights get one Light per emitting primitive.
    std::vector<cbk::Primitive> primitives;
    // In double: a bright, large light's power can pass the float range while its radiance and
    // area fit, and an infinite power made every pick probability NaN (a black image).
    std::vector<double> lightPower;
    // One spectrum per AreaLightSource, and per shape area where "power" sets the radiance.
    std::map<std::pair<int, double>, int> emissionEntry;
    auto addAreaLight = [&](int areaLight, float area, double shapeArea, bool invisible) {
        const AreaLightDesc& al = desc.areaLights[size_t(areaLight)];
        // pbrt-v4's DiffuseAreaLight::Create: power / (pi area of the shape, both sides if so).
        const double powerScale =
            al.power > 0.0 ? al.power / ((al.twoSided ? 2.0 : 1.0) * M_PI * shapeArea) : 1.0;
        int& entry = emissionEntry.try_emplace({areaLight, al.power > 0.0 ? shapeArea : 0.0}, -1)
                         .first->second;
        if (entry < 0)
            entry = spectra.addEmission(al.radiance, float(al.scale * powerScale), al.where);
        cbk::Light light{};
        light.kind = CB_LIGHT_AREA;
        light.primitive = -1; // set once the BVH has placed the primitive
        light.emission = entry;
        light.twoSided = al.twoSided ? 1 : 0;
        light.area = area;
        light.invisible = invisible ? 1 : 0;
        if (invisible) scene.features |= CB_FEATURE_INVISIBLE_LIGHT;
        lightPower.push_back(spectra.average(light.emission) * area * M_PI *
                             (al.twoSided ? 2.0 : 1.0));
        scene.lights.push_back(light);
        scene.features |= CB_FEATURE_AREA_LIGHT;
        return int(scene.lights.size()) - 1;
    };

    std::array<double, 3> lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
    auto grow = [&](const std::array<double, 3>& p, double r) {
        for (int a = 0; a < 3; ++a) {
            lo[size_t(a)] = std::min(lo[size_t(a)], p[size_t(a)] - r);
            hi[size_t(a)] = std::max(hi[size_t(a)], p[size_t(a)] + r);
        }
    };

    // pbrt-v4's shape "alpha": an alpha-tested mesh's triangles get a material of their own, the
    // mesh's with `alphaTexture` set (one per material and alpha texture), which the traversal's
    // alpha test reads (alphaKeepsHit); the test looks the texture up at the hit's (u, v).
    std::map<std::pair<int, int>, int> alphaMaterials;
    auto alphaTestedMaterial = [&](const TriangleMeshDesc& mesh) {
        auto [it, added] = alphaMaterials.try_emplace({mesh.material, mesh.alphaTexture}, -1);
        if (added) {
            cbk::Material m = scene.materials[size_t(mesh.material)];
            m.alphaTexture = addTexture(mesh.alphaTexture);
            scene.materials.push_back(m);
            it->second = int(scene.materials.size()) - 1;
        }
        return it->second;
    };
    // pbrt-v4's MediumInterface: a shape between media gets a material of its own, its material
    // with the two media set (one per material and pair), which the kernels read where a ray
    // leaves the surface (mediumLeaving, cb_medium.h). A medium is three entries: sigma_t and
    // sigma_s, each times its scale, and g (cb_medium.h); where a grid medium is used, every
    // medium's are followed by its grid (mediumGrid).
    std::vector<int> mediumSpectrum(desc.media.size(), -1);
    const bool gridMedia = std::any_of(desc.media.begin(), desc.media.end(),
                                       [](const auto& m) { return m.used && !m.density.empty(); });
    if (gridMedia) scene.features |= CB_FEATURE_GRID_MEDIUM;
    auto mediumEntry = [&](int medium) {
        if (medium < 0) return -1;
        int& entry = mediumSpectrum[size_t(medium)];
        if (entry < 0) {
            const MediumDesc& md = desc.media[size_t(medium)];
            entry = spectra.add(md.sigmaA, md.scale);
            const int sigmaS = spectra.add(md.sigmaS, md.scale);
            spectra.addConstant(md.g);
            static_assert(CB_MEDIUM_SIGMA_S == 1 && CB_MEDIUM_ENTRIES == 3);
            bool scatters = false;
            for (int i = 0; i < scene.channels; ++i) {
                float& a = scene.spectra[size_t(entry * scene.channels + i)];
                float& s = scene.spectra[size_t(sigmaS * scene.channels + i)];
                // Smits's RGB basis can dip a hair below 0 between its bins.
                a = std::max(a, 0.f);
                s = std::max(s, 0.f);
                scatters = scatters || s > 0.f;
                a += s; // sigma_t
                if (!std::isfinite(a))
                    throw SceneError(md.where, fmt::format("medium \"{}\": \"sigma_a\" plus "
                                                           "\"sigma_s\", times \"float scale\" "
                                                           "{:g}, exceeds the float range (3.4e38)",
                                                           md.name, md.scale));
            }
            if (scatters) scene.features |= CB_FEATURE_SCATTERING;
            if (gridMedia) addMediumGrid(md, scene.origin, scene.channels, scene.spectra);
        }
        return entry;
    };
    scene.camera.medium = mediumEntry(desc.camera.medium);
    if (scene.camera.medium >= 0) scene.features |= CB_FEATURE_MEDIUM;
    std::map<std::tuple<int, int, int>, int> mediumMaterials;
    auto withMedia = [&](int material, int inside, int outside, const SourceLocation& where) {
        if (inside < 0 && outside < 0) return material;
        if (material < 0) throw SceneError(where, "a shape in a medium needs a material");
        auto [it, added] = mediumMaterials.try_emplace({material, inside, outside}, -1);
        if (added) {
            // A mix picked per point hands the hit its part (mixPartAtPoint), so its chain's
            // links and parts are copied with the media too.
            auto copyWithMedia = [&](auto& self, int index) -> int {
                cbk::Material m = scene.materials[size_t(index)];
                m.mediumInside = mediumEntry(inside);
                m.mediumOutside = mediumEntry(outside);
                if (m.kind == CB_MAT_MIX_AT_POINT) {
                    m.mixFirst = self(self, m.mixFirst);
                    m.mixSecond = self(self, m.mixSecond);
                }
                scene.materials.push_back(m);
                return int(scene.materials.size()) - 1;
            };
            it->second = copyWithMedia(copyWithMedia, material);
            scene.features |= CB_FEATURE_MEDIUM;
        }
        return it->second;
    };

    for (const auto& mesh : desc.meshes) {
        if (mesh.alphaTexture < 0 || mesh.triangles.empty()) continue;
        if (mesh.areaLight >= 0)
            throw SceneError(mesh.where, "an area light's shape with an \"alpha\" below 1 is not "
                                         "supported (pbrt-v4 masks its emission where alpha "
                                         "skips its hits); cbdpt's emitters are opaque");
        if (mesh.material < 0)
            throw SceneError(mesh.where, "a shape with an \"alpha\" needs a material");
        const TextureDesc& alpha = desc.textures[size_t(mesh.alphaTexture)];
        if (!mesh.noTexCoords.empty() && (alpha.width > 1 || alpha.height > 1))
            throw SceneError(mesh.where, "this shape's \"alpha\" is a texture, which needs "
                                         "texture coordinates, and cbdpt gives none to " +
                                             mesh.noTexCoords);
        // The traversal's alpha test has the hit's (u, v), not its point.
        if (alpha.mappingKind != TextureDesc::Mapping::Uv &&
            (alpha.width > 1 || alpha.height > 1 || alpha.noise != TextureDesc::Noise::None))
            throw SceneError(mesh.where, "this shape's \"alpha\" texture is mapped by the hit "
                                         "point (" +
                                             alpha.where.str() +
                                             "), which cbdpt's alpha test does not have: only "
                                             "\"uv\" mappings there");
        scene.features |= CB_FEATURE_TEXTURE | CB_FEATURE_ALPHA;
    }
    const bool texturing = (scene.features & CB_FEATURE_TEXTURE) != 0;
    const bool shading = std::any_of(desc.meshes.begin(), desc.meshes.end(), [](const auto& m) {
        return !m.normals.empty() && !m.triangles.empty();
    });
    if (shading) scene.features |= CB_FEATURE_SHADING_NORMALS;
    std::vector<std::array<float, 9>> primitiveNormals; // shading: per primitive, as `primitives`
    std::vector<std::array<float, 6>> primitiveUv;      // texturing: per primitive, as `primitives`
    auto requireTexCoords = [&](int material, const std::string& none,
                                const SourceLocation& where) {
        if (!texturing || !needsTexCoords(material) || none.empty()) return;
        throw SceneError(where, "this shape's material has a texture mapped by (u, v) (its "
                                "reflectance, its transmittance, its roughness, a \"normalmap\" "
                                "or a \"displacement\"), hair (along dp/du, across v) or an "
                                "anisotropic roughness (turned by dp/du), which needs texture "
                                "coordinates, and cbdpt gives none "
                                "to " +
                                    none);
    };
    for (const auto& mesh : desc.meshes) {
        requireTexCoords(mesh.material, mesh.noTexCoords, mesh.where);
        scene.vertexCount += long(mesh.positions.size());
        for (const auto& p : mesh.positions) {
            grow(p, 0.f);
            requireInFloatRange(p, 0.0, scene.origin, mesh.where, "a vertex");
        }
        for (const auto& tri : mesh.triangles) {
            cbk::Primitive prim{};
            const bool alphaTested = mesh.alphaTexture >= 0;
            prim.kind = alphaTested ? CB_PRIM_ALPHA_TRIANGLE : CB_PRIM_TRIANGLE;
            prim.material = withMedia(alphaTested ? alphaTestedMaterial(mesh) : mesh.material,
                                      mesh.mediumInside, mesh.mediumOutside, mesh.where);
            prim.light = -1;
            toDevice(mesh.positions[tri[0]], prim.p0);
            toDevice(mesh.positions[tri[1]], prim.p1);
            toDevice(mesh.positions[tri[2]], prim.p2);
            // Area of the triangle as the kernels see it (float vertices).
            double e1[3], e2[3];
            for (int a = 0; a < 3; ++a) {
                e1[a] = double(prim.p1[a]) - prim.p0[a];
                e2[a] = double(prim.p2[a]) - prim.p0[a];
            }
            double cx = e1[1] * e2[2] - e1[2] * e2[1], cy = e1[2] * e2[0] - e1[0] * e2[2],
                   cz = e1[0] * e2[1] - e1[1] * e2[0];
            double area = 0.5 * std::sqrt(cx * cx + cy * cy + cz * cz);
            // The kernels' float normal: a sliver with area > 0 can still have a float cross
            // product of 0 (its two products round equal), a NaN normal at every hit on it.
            const cbk::Vec3 n = cbk::triangleNormal(cbk::vec3(prim.p0[0], prim.p0[1], prim.p0[2]),
                                                    cbk::vec3(prim.p1[0], prim.p1[1], prim.p1[2]),
                                                    cbk::vec3(prim.p2[0], prim.p2[1], prim.p2[2]));
            if (!(area > 0.0) || !std::isfinite(n.x + n.y + n.z)) {
                ++scene.droppedDegenerateTriangles; // zero area once rounded to float
                continue;
            }
            if (mesh.areaLight >= 0) {
                const size_t index = size_t(&tri - mesh.triangles.data());
                const double shapeArea = mesh.shapeArea.empty() ? area : mesh.shapeArea[index];
                prim.light = addAreaLight(mesh.areaLight, float(area), shapeArea, mesh.invisible);
            }
            primitives.push_back(prim);
            if (texturing) {
                const size_t index = size_t(&tri - mesh.triangles.data());
                primitiveUv.push_back(mesh.cornerUv.empty() ? kDefaultCornerUv
                                                            : mesh.cornerUv[index]);
            }
            if (shading) primitiveNormals.push_back(cornerNormals(mesh, tri));
            ++scene.triangleCount;
        }
    }
    for (const auto& sphere : desc.spheres) {
        cbk::Primitive prim{};
        prim.kind = CB_PRIM_SPHERE;
        prim.material =
            withMedia(sphere.material, sphere.mediumInside, sphere.mediumOutside, sphere.where);
        prim.light = -1;
        toDevice(sphere.center, prim.p0);
        prim.p1[0] = sphere.radius;
        prim.p1[1] = sphere.reverseOrientation ? -1.f : 1.f;
        grow(sphere.center, sphere.radius);
        requireInFloatRange(sphere.center, sphere.radius, scene.origin, sphere.where, "a sphere");
        if (sphere.areaLight >= 0) {
            float area = float(4.0 * M_PI * double(sphere.radius) * sphere.radius);
            prim.light = addAreaLight(sphere.areaLight, area, sphere.shapeArea, sphere.invisible);
        }
        primitives.push_back(prim);
        if (texturing) {
            // Entry 5: dn/du over dp/du as pbrt-v4 has them in world space, 1 / (scale radius)
            // (cb_texture.h, sphereShadingPartials).
            std::array<float, 6> slot = sphereFrameSlot(sphere.worldFromObject);
            slot[5] = float(1.0 / (sphere.scale * double(sphere.radius)));
            primitiveUv.push_back(slot);
        }
        if (shading) primitiveNormals.push_back({}); // the kernel shades spheres by ng
        scene.features |= CB_FEATURE_SPHERES;
        ++scene.sphereCount;
    }
    for (const auto& curve : desc.curves) {
        // pbrt-v4's Curve pieces: the segment's [i, i + 1] / 2^splitDepth, each its own
        // primitive with the blossomed control points and a box grown by half its widest.
        if (curve.material >= 0) {
            const cbk::Material& m = scene.materials[size_t(curve.material)];
            if (m.normalMap >= 0 || m.displacement >= 0)
                throw SceneError(curve.where, "a curve's material has a \"normalmap\" or a "
                                              "\"displacement\", which cbdpt applies on "
                                              "triangles and spheres only");
        }
        const int material =
            withMedia(curve.material, curve.mediumInside, curve.mediumOutside, curve.where);
        for (const auto& p : curve.cp) {
            grow(p, 0.5 * std::max(curve.width0, curve.width1));
            requireInFloatRange(p, 0.5 * std::max(curve.width0, curve.width1), scene.origin,
                                curve.where, "a curve control point");
        }
        const int pieces = 1 << curve.splitDepth;
        auto blossom = [&](double a, double b, double c) {
            std::array<double, 3> out{};
            for (int k = 0; k < 3; ++k) {
                auto at = [&](int i) { return curve.cp[size_t(i)][size_t(k)]; };
                const double a0 = at(0) + a * (at(1) - at(0)), a1 = at(1) + a * (at(2) - at(1)),
                             a2 = at(2) + a * (at(3) - at(2));
                const double b0 = a0 + b * (a1 - a0), b1 = a1 + b * (a2 - a1);
                out[size_t(k)] = b0 + c * (b1 - b0);
            }
            return out;
        };
        double normalAngle = 0.0;
        if (curve.type == CurveDesc::Type::Ribbon) {
            // pbrt-v4's AngleBetween: accurate for nearly equal and nearly opposite normals.
            const auto& n0 = curve.normals[0];
            const auto& n1 = curve.normals[1];
            const double dot = n0[0] * n1[0] + n0[1] * n1[1] + n0[2] * n1[2];
            auto halfChord = [&](double sign) {
                const double x = n1[0] + sign * n0[0], y = n1[1] + sign * n0[1],
                             z = n1[2] + sign * n0[2];
                return 2.0 * std::asin(std::min(1.0, 0.5 * std::sqrt(x * x + y * y + z * z)));
            };
            normalAngle = dot < 0.0 ? M_PI - halfChord(1.0) : halfChord(-1.0);
        }
        for (int piece = 0; piece < pieces; ++piece) {
            const double u0 = double(piece) / pieces, u1 = double(piece + 1) / pieces;
            cbk::CurveSegment seg{};
            const std::array<std::array<double, 3>, 4> cp{blossom(u0, u0, u0), blossom(u0, u0, u1),
                                                          blossom(u0, u1, u1), blossom(u1, u1, u1)};
            for (int i = 0; i < 4; ++i)
                toDevice(cp[size_t(i)], seg.cp[i]);
            for (int i = 0; i < 2; ++i)
                for (int a = 0; a < 3; ++a)
                    seg.n[i][a] = float(curve.normals[size_t(i)][size_t(a)]);
            seg.width[0] = curve.width0;
            seg.width[1] = curve.width1;
            seg.uMin = float(u0);
            seg.uMax = float(u1);
            seg.normalAngle = float(normalAngle);
            seg.invSinNormalAngle = normalAngle > 0.0 ? float(1.0 / std::sin(normalAngle)) : 0.f;
            seg.type = curve.type == CurveDesc::Type::Ribbon     ? CB_CURVE_RIBBON
                       : curve.type == CurveDesc::Type::Cylinder ? CB_CURVE_CYLINDER
                                                                 : CB_CURVE_FLAT;
            seg.mirrored = curve.mirrored ? 1 : 0;
            seg.reverse = curve.reverseOrientation ? 1 : 0;
            cbk::Primitive prim{};
            prim.kind = CB_PRIM_CURVE;
            prim.material = material;
            prim.light = -1;
            const float halfWidth =
                0.5f * std::max(curve.width0 + float(u0) * (curve.width1 - curve.width0),
                                curve.width0 + float(u1) * (curve.width1 - curve.width0));
            for (int a = 0; a < 3; ++a) {
                float least = seg.cp[0][a], most = seg.cp[0][a];
                for (int i = 1; i < 4; ++i) {
                    least = std::min(least, seg.cp[i][a]);
                    most = std::max(most, seg.cp[i][a]);
                }
                // Rounded outwards, so that the box holds the piece the kernels test.
                prim.p0[a] = std::nextafter(least - halfWidth, -INFINITY);
                prim.p1[a] = std::nextafter(most + halfWidth, INFINITY);
            }
            if (scene.curves.size() >= (size_t(1) << 24))
                throw SceneError(curve.where, "more than 2^24 curve pieces (the kernels index "
                                              "them by a float); lower \"splitdepth\"");
            prim.p2[0] = float(scene.curves.size());
            scene.curves.push_back(seg);
            primitives.push_back(prim);
            if (texturing) primitiveUv.push_back({});    // a curve's (u, v) comes from its hit
            if (shading) primitiveNormals.push_back({}); // shaded by its normal
        }
        scene.features |= CB_FEATURE_CURVES;
        ++scene.curveCount;
    }
    for (const auto& pl : desc.pointLights) {
        cbk::Light light{};
        light.kind = CB_LIGHT_POINT;
        light.primitive = -1;
        toDevice(pl.position, light.position);
        light.spotCosEnd = -2.f;
        // A unit-intensity point light emits 4 pi; a spot 2 pi (1 - (cosStart + cosEnd) / 2)
        // (pbrt-v4's SpotLight::Phi).
        float solidAngle = 4.f * float(M_PI);
        if (pl.spot) {
            light.spotCosStart = pl.spotCosStart;
            light.spotCosEnd = pl.spotCosEnd;
            for (int a = 0; a < 3; ++a)
                light.axis[a] = float(pl.spotAxis[size_t(a)]);
            solidAngle = 2.f * float(M_PI) * (1.f - 0.5f * (pl.spotCosStart + pl.spotCosEnd));
            scene.features |= CB_FEATURE_SPOT_LIGHT;
        }
        double meanIntensity = 0.0;
        if (pl.image.size > 0) {
            // A goniometric light: its intensity entry times each pixel's mean of R, G, B
            // (clamped to zero), one float per pixel.
            light.emission = spectra.addEmission(pl.intensity, pl.scale, pl.where);
            const double unitMean = spectra.average(light.emission);
            const double unitMax = spectra.maxComponent(light.emission);
            const size_t count = size_t(pl.image.size) * size_t(pl.image.size);
            std::vector<double> weight(count);
            std::vector<float> pixels(count);
            for (size_t p = 0; p < count; ++p) {
                const float* rgb = &pl.image.rgb[3 * p];
                const double grey = (double(rgb[0]) + rgb[1] + rgb[2]) / 3.0;
                // The kernels multiply the intensity entry by it: the product must be a float.
                scaledPixel(grey, unitMax, "its intensity", pl.image, p, pl.where);
                pixels[p] = float(std::max(grey, 0.0));
                weight[p] = unitMean * pixels[p];
                meanIntensity += weight[p] / double(count);
            }
            const int table = appendImageTables(pl.image.size, weight, pixels, scene.lightTables);
            setLightImage(light, pl.image.size, table, pl.worldFromLight);
            scene.features |= CB_FEATURE_IMAGE_LIGHT;
        } else {
            light.emission = spectra.addEmission(pl.intensity, pl.scale, pl.where);
            meanIntensity = spectra.average(light.emission);
        }
        lightPower.push_back(meanIntensity * solidAngle);
        scene.lights.push_back(light);
        scene.features |= CB_FEATURE_POINT_LIGHT;
    }
    // Distant lights: their subpaths start on a disk of the bounding sphere of the geometry
    // (pbrt-v4's sceneBounds.BoundingSphere), whose area also gives their power, pi R^2 L.
    // A light at infinity (distant, infinite): kind, emission and the bounding sphere.
    auto lightAtInfinity = [&](int kind, int emission, const SourceLocation& where) {
        if (!(lo[0] <= hi[0]))
            throw SceneError(where, "a distant or infinite light needs geometry to light (the "
                                    "scene has no shapes)");
        std::array<double, 3> centre{};
        double radius2 = 0.0;
        for (size_t a = 0; a < 3; ++a) {
            centre[a] = 0.5 * (lo[a] + hi[a]);
            radius2 += (hi[a] - centre[a]) * (hi[a] - centre[a]);
        }
        cbk::Light light{};
        light.kind = kind;
        light.primitive = -1;
        light.emission = emission;
        light.portal = -1;
        toDevice(centre, light.position);
        // Rounded up, so that the float sphere still holds the geometry; never 0 (a flat scene
        // seen edge-on still needs a disk).
        light.sceneRadius = std::nextafter(float(std::sqrt(radius2)), INFINITY);
        if (!(light.sceneRadius > 0.f)) light.sceneRadius = 1e-6f;
        return light;
    };
    for (const auto& dl : desc.distantLights) {
        cbk::Light light = lightAtInfinity(
            CB_LIGHT_DISTANT, spectra.addEmission(dl.radiance, dl.scale, dl.where), dl.where);
        for (size_t a = 0; a < 3; ++a)
            light.axis[a] = float(dl.direction[a]);
        lightPower.push_back(spectra.average(light.emission) * M_PI * double(light.sceneRadius) *
                             light.sceneRadius);
        scene.lights.push_back(light);
        scene.features |= CB_FEATURE_DISTANT_LIGHT;
    }
    // The infinite light is the last light (the kernels find it there, cb_types.h); its power
    // is pbrt-v4's UniformInfiniteLight::Phi and ImageInfiniteLight::Phi, 4 pi^2 R^2 times the
    // mean radiance over directions.
    if (desc.infiniteLights.size() > 1)
        throw SceneError(desc.infiniteLights[1].where, "cbdpt supports one infinite light");
    for (const auto& il : desc.infiniteLights) {
        double meanRadiance = 0.0;
        int emission = 0, table = 0;
        if (il.image.size > 0) {
            // Each pixel's RGB times scale, negative components clamped to zero as pbrt-v4's
            // ImageLe clamps them, emitted as "rgb L": in spectral scenes the kernels make its
            // spectrum from Smits's basis and the white illuminant, 8 entries (rgbToSpectrum
            // and rgbIlluminantSpectrum), so that a pixel costs 3 floats, not 16.
            const size_t count = size_t(il.image.size) * size_t(il.image.size);
            std::vector<double> weight(count);
            std::vector<float> pixels(3 * count);
            for (size_t p = 0; p < count; ++p) {
                std::array<float, 3> rgb{};
                for (size_t c = 0; c < 3; ++c)
                    rgb[c] = pixels[3 * p + c] =
                        scaledPixel(il.image.rgb[3 * p + c], il.scale, "its \"float scale\"",
                                    il.image, p, il.where);
                if (scene.channels == kSpectralBins) {
                    const auto bins = rgbIlluminantSpectrum(rgb);
                    weight[p] = std::accumulate(bins.begin(), bins.end(), 0.0) / kSpectralBins;
                } else {
                    weight[p] = (double(rgb[0]) + rgb[1] + rgb[2]) / 3.0;
                }
                meanRadiance += weight[p] / double(count);
            }
            emission = -1; // RGB scenes read the pixels alone
            if (scene.channels == kSpectralBins) {
                const auto& basis = smitsBasis();
                emission = spectra.addBins(basis[0]);
                for (size_t k = 1; k < basis.size(); ++k)
                    spectra.addBins(basis[k]);
                spectra.addBins(whiteIlluminantBins()); // entry emission + 7
            }
            table = appendImageTables(il.image.size, weight, pixels, scene.lightTables);
            scene.features |= CB_FEATURE_IMAGE_LIGHT;
        } else {
            emission = spectra.addEmission(il.radiance, il.scale, il.where);
            meanRadiance = spectra.average(emission);
        }
        cbk::Light light = lightAtInfinity(CB_LIGHT_INFINITE, emission, il.where);
        if (il.image.size > 0) setLightImage(light, il.image.size, table, il.worldFromLight);
        if (!il.portal.empty()) {
            // cb_lights.h, lightSeenThroughPortal: p0, x (to p3), y (to p1), z = x cross y, the
            // two edges' lengths; pbrt-v4's Frame::FromXY(p03, p01).
            const auto& c = il.portal;
            const Vec3d e03 = vecSub(c[3], c[0]), e01 = vecSub(c[1], c[0]);
            const double lengthX = std::sqrt(vecDot(e03, e03)),
                         lengthY = std::sqrt(vecDot(e01, e01));
            const Vec3d x{e03[0] / lengthX, e03[1] / lengthX, e03[2] / lengthX};
            const Vec3d y{e01[0] / lengthY, e01[1] / lengthY, e01[2] / lengthY};
            light.portal = int(scene.lightTables.size());
            float corner[3];
            toDevice(c[0], corner);
            scene.lightTables.insert(scene.lightTables.end(), corner, corner + 3);
            for (const Vec3d& axis : {x, y, vecCross(x, y)})
                for (double v : axis)
                    scene.lightTables.push_back(float(v));
            scene.lightTables.push_back(float(lengthX));
            scene.lightTables.push_back(float(lengthY));
        }
        lightPower.push_back(meanRadiance * 4.0 * M_PI * M_PI * double(light.sceneRadius) *
                             light.sceneRadius);
        scene.lights.push_back(light);
        scene.features |= CB_FEATURE_INFINITE_LIGHT;
    }
    if (scene.lights.empty())
        throw SceneError(SourceLocation{desc.path, 0, 0},
                         "the scene has no lights (add an AreaLightSource before a Shape, or a "
                         "LightSource \"point\", \"spot\", \"distant\" or \"infinite\")");
    if (scene.triangleCount + scene.sphereCount > 0) {
        scene.boundsMin = lo;
        scene.boundsMax = hi;
    }
    if (scene.droppedDegenerateTriangles > 0) {
        fmt::print(stderr,
                   "warning: {}: dropped {} triangles that are degenerate in float "
                   "precision (zero area, or a cross product that rounds to zero)\n",
                   desc.path, scene.droppedDegenerateTriangles);
    }

    // Choose lights in proportion to power; fall back to uniform if every light is black.
    double totalPower = std::accumulate(lightPower.begin(), lightPower.end(), 0.0);
    double running = 0.0;
    for (size_t i = 0; i < scene.lights.size(); ++i) {
        double p = totalPower > 0.0 ? lightPower[i] / totalPower : 1.0 / double(lightPower.size());
        scene.lights[i].pickProbability = float(p);
        running += p;
        scene.lights[i].cdf = float(running);
    }
    scene.lights.back().cdf = 1.0f; // rounding must not leave a gap at the top

    // The BVH settings are chosen by the traversal work of rays from this camera (bvh_choice.h):
    // a grid of 32 x 32 pixel centres, through the lens centre.
    std::vector<cbk::Ray> cameraRays;
    constexpr int kSampleGrid = 32;
    const cbk::Vec3 lensCentre = cbk::vec3(0.f, 0.f, 0.f); // camera space
    for (int y = 0; y < kSampleGrid; ++y)
        for (int x = 0; x < kSampleGrid; ++x)
            cameraRays.push_back(cbk::cameraGenerateRay(
                &scene.camera, (float(x) + 0.5f) * float(scene.camera.width) / kSampleGrid,
                (float(y) + 0.5f) * float(scene.camera.height) / kSampleGrid, lensCentre));
    // Invisible lights' primitives stay out of the BVH, after its primitives: their lights
    // reach them, no ray does.
    std::vector<int> tracedIndex, invisibleIndex;
    for (size_t i = 0; i < primitives.size(); ++i) {
        const int light = primitives[i].light;
        (light >= 0 && scene.lights[size_t(light)].invisible ? invisibleIndex : tracedIndex)
            .push_back(int(i));
    }
    std::vector<cbk::Primitive> traced;
    if (!invisibleIndex.empty())
        for (int i : tracedIndex)
            traced.push_back(primitives[size_t(i)]);
    WideBvhChoice choice =
        buildWideBvhForRays(invisibleIndex.empty() ? primitives : traced, cameraRays,
                            wideBvhCandidates(), scene.curves.data());
    scene.wideSettings = choice.settings;
    scene.wideSettingsWhy = describeChoice(choice);
    scene.bvh = std::move(choice.bvh);
    scene.wide = std::move(choice.wide);
    if (!invisibleIndex.empty()) {
        for (int& original : scene.bvh.originalIndex)
            original = tracedIndex[size_t(original)];
        for (int i : invisibleIndex) {
            scene.bvh.primitives.push_back(primitives[size_t(i)]);
            scene.bvh.originalIndex.push_back(i);
        }
    }
    // After the BVH reorders primitives, point each area light at its primitive's new slot.
    for (size_t i = 0; i < scene.bvh.primitives.size(); ++i) {
        int light = scene.bvh.primitives[i].light;
        if (light >= 0) scene.lights[size_t(light)].primitive = int(i);
    }
    for (size_t i = 0; i < scene.lights.size(); ++i)
        if (scene.lights[i].kind == CB_LIGHT_AREA && scene.lights[i].primitive < 0)
            throw std::logic_error("area light lost its primitive in the BVH build");
    if (shading) {
        if (9 * scene.bvh.primitives.size() > size_t(std::numeric_limits<int>::max()))
            throw SceneError(SourceLocation{desc.path, 0, 0},
                             fmt::format("the vertex normals take {} floats; the kernels index "
                                         "at most 2^31 - 1",
                                         9 * scene.bvh.primitives.size()));
        scene.shadingNormals.reserve(9 * scene.bvh.primitives.size());
        for (int original : scene.bvh.originalIndex) {
            const auto& n = primitiveNormals[size_t(original)];
            scene.shadingNormals.insert(scene.shadingNormals.end(), n.begin(), n.end());
        }
    }
    if (texturing) {
        // The primitives' texture coordinates in leaf order, then the images, whose offsets
        // the materials held relative to the images' start.
        const size_t uvCount = 6 * scene.bvh.primitives.size();
        if (uvCount + images.size() > size_t(std::numeric_limits<int>::max()))
            throw SceneError(SourceLocation{desc.path, 0, 0},
                             fmt::format("the textures and texture coordinates take {} floats; "
                                         "the kernels index at most 2^31 - 1",
                                         uvCount + images.size()));
        scene.textures.reserve(uvCount + images.size());
        for (int original : scene.bvh.originalIndex) {
            const auto& uv = primitiveUv[size_t(original)];
            scene.textures.insert(scene.textures.end(), uv.begin(), uv.end());
        }
        scene.textures.insert(scene.textures.end(), images.begin(), images.end());
        for (cbk::Material& m : scene.materials) {
            if (m.reflectanceTexture >= 0) m.reflectanceTexture += int(uvCount);
            if (m.transmittanceTexture >= 0) m.transmittanceTexture += int(uvCount);
            if (m.normalMap >= 0) m.normalMap += int(uvCount);
            if (m.roughnessTexture >= 0) m.roughnessTexture += int(uvCount);
            if (m.thicknessTexture >= 0) m.thicknessTexture += int(uvCount);
            if (m.alphaTexture >= 0) m.alphaTexture += int(uvCount);
            if (m.displacement >= 0) m.displacement += int(uvCount);
        }
    }
    return scene;
}

std::vector<std::string> DeviceScene::kernelDefines() const {
    return {fmt::format("CB_CHANNELS={}", channels), fmt::format("CB_FEATURES={}u", features)};
}

std::string DeviceScene::featureNames() const {
    std::string names;
    auto add = [&](std::uint64_t bit, const char* name) {
        if (!(features & bit)) return;
        if (!names.empty()) names += ' ';
        names += name;
    };
    add(CB_FEATURE_DIFFUSE, "diffuse");
    add(CB_FEATURE_CONDUCTOR, "conductor");
    add(CB_FEATURE_CONDUCTOR_FRESNEL, "conductor-fresnel");
    add(CB_FEATURE_DIELECTRIC, "dielectric");
    add(CB_FEATURE_ROUGH_DIELECTRIC, "rough-dielectric");
    add(CB_FEATURE_MIX, "mix");
    add(CB_FEATURE_DIFFUSE_TRANSMISSION, "diffuse-transmission");
    add(CB_FEATURE_THIN_DIELECTRIC, "thin-dielectric");
    add(CB_FEATURE_COATED_DIFFUSE, "coated-diffuse");
    add(CB_FEATURE_COATED_CONDUCTOR, "coated-conductor");
    add(CB_FEATURE_AREA_LIGHT, "area-light");
    add(CB_FEATURE_POINT_LIGHT, "point-light");
    add(CB_FEATURE_SPHERES, "spheres");
    add(CB_FEATURE_SPOT_LIGHT, "spot-light");
    add(CB_FEATURE_DISTANT_LIGHT, "distant-light");
    add(CB_FEATURE_INFINITE_LIGHT, "infinite-light");
    add(CB_FEATURE_IMAGE_LIGHT, "image-light");
    add(CB_FEATURE_TEXTURE, "texture");
    add(CB_FEATURE_SHADING_NORMALS, "shading-normals");
    add(CB_FEATURE_NORMAL_MAP, "normal-map");
    add(CB_FEATURE_ROUGHNESS_TEXTURE, "roughness-texture");
    add(CB_FEATURE_THICKNESS_TEXTURE, "thickness-texture");
    add(CB_FEATURE_DIRECTION_MIX, "direction-mix");
    add(CB_FEATURE_THIN_LENS, "thin-lens");
    add(CB_FEATURE_PIXEL_FILTER, "pixel-filter");
    add(CB_FEATURE_DISPERSION, "dispersion");
    add(CB_FEATURE_ALPHA, "alpha");
    add(CB_FEATURE_BUMP_MAP, "bump-map");
    add(CB_FEATURE_TEXTURE_MAPPING, "texture-mapping");
    add(CB_FEATURE_INVISIBLE_LIGHT, "invisible-light");
    add(CB_FEATURE_ANISOTROPIC, "anisotropic");
    add(CB_FEATURE_MEDIUM, "medium");
    add(CB_FEATURE_SAMPLE_CLAMP, "sample-clamp");
    add(CB_FEATURE_NOISE_TEXTURE, "noise-texture");
    add(CB_FEATURE_MIX_AT_POINT, "mix-at-point");
    add(CB_FEATURE_SCATTERING, "scattering");
    add(CB_FEATURE_INTERFACE, "interface");
    add(CB_FEATURE_GRID_MEDIUM, "grid-medium");
    add(CB_FEATURE_HAIR, "hair");
    add(CB_FEATURE_CURVES, "curves");
    names += channels == 16 ? " spectral-16" : " rgb";
    return names;
}

SceneBytes sceneBytes(const DeviceScene& scene) {
    SceneBytes raw{};
    raw.nodes = scene.wide.nodes.data();
    raw.nodeCount = scene.wide.nodes.size();
    raw.nodeBytes = sizeof(cbk::BvhNodeWide);
    raw.packs = scene.wide.packs.data();
    raw.packCount = scene.wide.packs.size();
    raw.packBytes = sizeof(cbk::TrianglePack);
    raw.primitives = scene.bvh.primitives.data();
    raw.primitiveCount = scene.bvh.primitives.size();
    raw.primitiveBytes = sizeof(cbk::Primitive);
    raw.materials = scene.materials.data();
    raw.materialCount = scene.materials.size();
    raw.materialBytes = sizeof(cbk::Material);
    raw.lights = scene.lights.data();
    raw.lightCount = scene.lights.size();
    raw.lightBytes = sizeof(cbk::Light);
    raw.spectra = scene.spectra.data();
    raw.lightTables = scene.lightTables.data();
    raw.lightTableCount = scene.lightTables.size();
    raw.textures = scene.textures.data();
    raw.textureCount = scene.textures.size();
    raw.shadingNormals = scene.shadingNormals.data();
    raw.shadingNormalCount = scene.shadingNormals.size();
    raw.curves = scene.curves.data();
    raw.curveCount = scene.curves.size();
    raw.curveBytes = sizeof(cbk::CurveSegment);
    raw.spectraCount = scene.spectra.size();
    raw.toRgb = scene.toRgb.data();
    raw.camera = &scene.camera;
    raw.cameraBytes = sizeof(cbk::Camera);
    raw.channels = scene.channels;
    raw.features = scene.features;
    return raw;
}

} // namespace cb
