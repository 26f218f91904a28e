// BDPT (kernels/cb_bdpt.h, kernels/bdpt.cl): MIS weights against an explicit-ratio oracle, and
// renders against PT. Statistical checks compare image-region means with error bars from the
// per-pixel spread (pixels of PT and BDPT are independent), at 4 standard errors.
#include "scene_builders.h"
#include "test_render_util.h"

#include "cb_bdpt.h"

#include <algorithm>
#include <cmath>
#include <doctest/doctest.h>
#include <string>
#include <vector>

namespace {

using cbk::PathVertex;
using cbk::Vec3;
using cbk::vec3;

// ---- Scenes ------------------------------------------------------------------------------------

// An axis-aligned box with outward normals (a solid block).
cb::TriangleMeshDesc solidBox(std::array<float, 3> lo, std::array<float, 3> hi, int material) {
    cb::TriangleMeshDesc inside = cbtest::insideOutBox(0.f, 1.f, material, -1);
    for (auto& p : inside.positions)
        for (int a = 0; a < 3; ++a)
            p[size_t(a)] = p[size_t(a)] > 0.5f ? hi[size_t(a)] : lo[size_t(a)];
    for (auto& tri : inside.triangles)
        std::swap(tri[1], tri[2]);
    return inside;
}

// A square emitter at height y facing down, half-size a.
cb::TriangleMeshDesc ceilingLight(float y, float a, int material, int areaLight) {
    cb::TriangleMeshDesc m;
    m.positions = {{-a, y, -a + 0.3f}, {a, y, -a + 0.3f}, {a, y, a + 0.3f}, {-a, y, a + 0.3f}};
    m.triangles = {{0, 1, 2}, {0, 2, 3}};
    m.material = material;
    m.areaLight = areaLight;
    return m;
}

cb::MaterialDesc diffuse(float r, float g, float b) {
    cb::MaterialDesc m;
    m.kind = cb::MaterialKind::Diffuse;
    m.reflectance = cb::SpectrumValue{true, {r, g, b}, {}};
    return m;
}

cb::MaterialDesc conductor(float alpha, float r) {
    cb::MaterialDesc m;
    m.kind = cb::MaterialKind::Conductor;
    m.reflectance = cb::SpectrumValue::constant(r);
    m.roughness = alpha;
    m.remapRoughness = false;
    return m;
}

// Cornell-like: a white box seen from inside (camera at the origin looking +z), a reddish block,
// a square ceiling light. lightKind 0: area quad; 1: point light; 2: sphere of radius 1e-3 with
// the point light's intensity.
cb::SceneDesc cornellLike(int size, int lightKind = 0) {
    cb::SceneDesc d;
    d.path = "<cornell-like>";
    d.film.width = size;
    d.film.height = size;
    d.camera.fovDegrees = 70.f;
    d.materials = {diffuse(0.7f, 0.7f, 0.7f), diffuse(0.7f, 0.25f, 0.2f),
                   diffuse(0.4f, 0.4f, 0.4f)};
    d.meshes.push_back(cbtest::insideOutBox(-1.f, 1.f, 0, -1));
    d.meshes.push_back(solidBox({-0.6f, -1.f, 0.2f}, {0.0f, -0.2f, 0.7f}, 1));
    const float intensity = 0.6f;
    const std::array<double, 3> lightPos{0.3f, 0.6f, 0.3f};
    if (lightKind == 0) {
        cb::AreaLightDesc light;
        light.radiance = cb::SpectrumValue::constant(5.f);
        d.areaLights.push_back(light);
        d.meshes.push_back(ceilingLight(0.98f, 0.25f, 2, 0));
    } else if (lightKind == 1) {
        cb::PointLightDesc p;
        p.position = lightPos;
        p.intensity = cb::SpectrumValue::constant(intensity);
        d.pointLights.push_back(p);
    } else {
        // A sphere of radiance L looks like a point of intensity L pi r^2 from afar.
        const float r = 1e-3f;
        cb::AreaLightDesc light;
        light.radiance = cb::SpectrumValue::constant(intensity / (float(M_PI) * r * r));
        d.areaLights.push_back(light);
        cb::SphereDesc s;
        s.center = lightPos;
        s.radius = r;
        s.material = 2;
        s.areaLight = 0;
        d.spheres.push_back(s);
    }
    return d;
}

// The Cornell-like box with a glossy sphere (GGX alpha 0.2) and a mirror sphere (alpha 0:
// perfect mirror, or a near-mirror GGX alpha for strategies that connect at it).
cb::SceneDesc glossyMirrorScene(int size, float mirrorAlpha) {
    cb::SceneDesc d = cornellLike(size, 0);
    d.path = "<glossy-mirror>";
    d.meshes.erase(d.meshes.begin() + 1); // no block
    d.materials.push_back(conductor(0.2f, 0.8f));
    d.materials.push_back(conductor(mirrorAlpha, 0.9f));
    cb::SphereDesc glossy;
    glossy.center = {-0.45f, -0.6f, 0.5f};
    glossy.radius = 0.38f;
    glossy.material = 3;
    cb::SphereDesc mirror;
    mirror.center = {0.45f, -0.6f, 0.35f};
    mirror.radius = 0.35f;
    mirror.material = 4;
    d.spheres = {glossy, mirror};
    return d;
}

// ---- Rendering and region statistics ---------------------------------------------------------

struct Region {
    double mean = 0, se = 0;
};

// Means of `blocks` x `blocks` image regions over all estimates, each with its standard error
// from the spread of its pixel samples.
std::vector<Region> renderRegions(const cb::DeviceScene& scene, cb::ClRuntime& runtime,
                                  const cb::IntegratorSettings& settings, int estimates, int blocks,
                                  long* nonFinite = nullptr) {
    auto integrator = cb::makeIntegrator(settings, scene, runtime);
    const int w = scene.camera.width, h = scene.camera.height;
    std::vector<double> sum(size_t(blocks * blocks)), sumSq(sum.size());
    std::vector<long> count(sum.size());
    std::vector<float> rgb;
    for (int e = 0; e < estimates; ++e) {
        integrator->renderEstimate(std::uint32_t(e), rgb);
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                size_t i = 3 * size_t(y * w + x);
                double v = (double(rgb[i]) + rgb[i + 1] + rgb[i + 2]) / 3.0;
                size_t b = size_t((y * blocks / h) * blocks + x * blocks / w);
                sum[b] += v;
                sumSq[b] += v * v;
                ++count[b];
            }
    }
    std::vector<Region> out(sum.size());
    for (size_t b = 0; b < sum.size(); ++b) {
        double n = double(count[b]);
        out[b].mean = sum[b] / n;
        double var = std::max(0.0, sumSq[b] / n - out[b].mean * out[b].mean) * n / (n - 1);
        out[b].se = std::sqrt(var / n);
    }
    if (nonFinite) *nonFinite = integrator->nonFiniteSamples();
    return out;
}

cb::IntegratorSettings ptSettings(int vertices, std::uint32_t seed) {
    cb::IntegratorSettings s;
    s.name = "pt";
    s.eyeVertices = vertices;
    s.rouletteVertex = 0;
    s.seed = seed;
    return s;
}

cb::IntegratorSettings bdptSettings(int ne, int nl, const char* weights, std::uint32_t seed) {
    cb::IntegratorSettings s;
    s.name = "bdpt";
    s.eyeVertices = ne;
    s.lightVertices = nl;
    s.weights = weights;
    s.seed = seed;
    return s;
}

// |a - b| within 4 combined standard errors (plus a relative float tolerance).
void checkRegionsEqual(const std::vector<Region>& a, const std::vector<Region>& b) {
    for (size_t i = 0; i < a.size(); ++i) {
        CAPTURE(i);
        CAPTURE(a[i].mean);
        CAPTURE(a[i].se);
        CAPTURE(b[i].mean);
        CAPTURE(b[i].se);
        double tol =
            4.0 * std::sqrt(a[i].se * a[i].se + b[i].se * b[i].se) + 1e-5 * std::fabs(b[i].mean);
        CHECK(std::fabs(a[i].mean - b[i].mean) <= tol);
    }
}

std::vector<Region> difference(const std::vector<Region>& a, const std::vector<Region>* b) {
    if (!b) return a;
    std::vector<Region> d(a.size());
    for (size_t i = 0; i < a.size(); ++i) {
        d[i].mean = a[i].mean - (*b)[i].mean;
        d[i].se = std::sqrt(a[i].se * a[i].se + (*b)[i].se * (*b)[i].se);
    }
    return d;
}

// ---- Explicit-ratio MIS oracle (host only) ---------------------------------------------------

// A full path y_0 (on the light) .. y_{k-1} (the camera), with the delta flag of every interior
// vertex (scattered by a delta lobe).
struct FullPath {
    std::vector<PathVertex> y;
    std::vector<int> delta;
};

Vec3 dirTo(const PathVertex& a, const PathVertex& b) {
    return cbk::vnormalize(cbk::vsub(cbk::pvP(&b), cbk::pvP(&a)));
}

// Area density of y[to] when sampled from y[from] (adjacent), given the vertex beyond `from` on
// the side it was reached from; delta scattering counts 1 (both directions cancel).
double oracleStep(const cbk::SceneView& scene, const cbk::Camera& camera, const FullPath& path,
                  int from, int to) {
    const PathVertex& a = path.y[size_t(from)];
    const PathVertex& b = path.y[size_t(to)];
    Vec3 w = dirTo(a, b);
    double pdfW;
    int k = int(path.y.size());
    if (from == k - 1) {
        float pdfDir;
        cbk::cameraImportance(&camera, w, &pdfDir);
        pdfW = pdfDir;
    } else if (from == 0) {
        pdfW = cbk::bdptLightDirectionPdf(&scene, &a, w);
    } else {
        if (path.delta[size_t(from)]) return 1.0;
        int beyond = to > from ? from - 1 : from + 1;
        Vec3 wo = dirTo(a, path.y[size_t(beyond)]);
        float fwd, rev;
        cbk::bsdfEval(&scene, a.material, cbk::pvUv(&a), cbk::frameFromNormal(cbk::pvN(&a)), wo, w,
                      0, &fwd, &rev);
        pdfW = fwd;
    }
    Vec3 d = cbk::vsub(cbk::pvP(&b), cbk::pvP(&a));
    double dist2 = cbk::vlength2(d);
    double cosB = cbk::pvOnSurface(&b) ? std::fabs(cbk::vdot(cbk::pvN(&b), w)) : 1.0;
    return pdfW * cosB / dist2;
}

// Whether strategy s can produce the path: caps, (1,1), delta vertices at the connection, and a
// point light (cannot be hit by s = 0).
bool oracleFeasible(const FullPath& path, int s, int ne, int nl) {
    int k = int(path.y.size()), t = k - s;
    if (!cbk::bdptStrategyAllowed(s, t, ne, nl)) return false;
    if (s == 0) return path.y[0].type != CB_VERTEX_POINT_LIGHT && path.y[0].light >= 0;
    if (s - 1 >= 1 && path.delta[size_t(s - 1)]) return false;
    if (s <= k - 2 && path.delta[size_t(s)]) return false;
    return true;
}

// The pdf of the whole path under strategy s, as an explicit product.
double oraclePdf(const cbk::SceneView& scene, const cbk::Camera& camera, const FullPath& path,
                 int s) {
    int k = int(path.y.size());
    double p = 1.0;
    if (s >= 1) {
        const PathVertex& y0 = path.y[0];
        p *= y0.type == CB_VERTEX_POINT_LIGHT ? scene.lights[y0.light].pickProbability
                                              : cbk::lightPdfArea(&scene, y0.light);
        // s = 1 samples a sphere light seen from outside uniformly in the cone it subtends from
        // y1: 1 / (2 pi (1 - cos theta_max)) in solid angle, |cos y0| / d^2 to area.
        const cbk::Light& light = scene.lights[y0.light];
        const cbk::Primitive* prim =
            y0.type == CB_VERTEX_POINT_LIGHT ? nullptr : &scene.primitives[light.primitive];
        if (s == 1 && prim && prim->kind == CB_PRIM_SPHERE) {
            Vec3 center = cbk::vec3(prim->p0[0], prim->p0[1], prim->p0[2]);
            double r = prim->p1[0];
            const PathVertex& y1 = path.y[1];
            double dc2 = cbk::vlength2(cbk::vsub(cbk::pvP(&y1), center));
            REQUIRE(dc2 > r * r); // y1 on the light itself cannot connect to it
            double cone = 1.0 / (2.0 * M_PI * (1.0 - std::sqrt(1.0 - r * r / dc2)));
            Vec3 d = cbk::vsub(cbk::pvP(&y1), cbk::pvP(&y0));
            double dist2 = cbk::vlength2(d);
            double cosY0 = std::fabs(cbk::vdot(cbk::pvN(&y0), d)) / std::sqrt(dist2);
            p *= cone * cosY0 / dist2 * light.area; // replaces the area density 1/area
        }
        for (int i = 0; i + 1 <= s - 1; ++i)
            p *= oracleStep(scene, camera, path, i, i + 1);
    }
    for (int i = k - 1; i - 1 >= s; --i)
        p *= oracleStep(scene, camera, path, i, i - 1);
    return p;
}

double oraclePowerWeight(const cbk::SceneView& scene, const cbk::Camera& camera,
                         const FullPath& path, int s, int ne, int nl) {
    if (!oracleFeasible(path, s, ne, nl)) return 0.0;
    double sum = 0.0;
    for (int i = 0; i < int(path.y.size()); ++i)
        if (oracleFeasible(path, i, ne, nl)) sum += std::pow(oraclePdf(scene, camera, path, i), 2);
    return std::pow(oraclePdf(scene, camera, path, s), 2) / sum;
}

// Lafortune's weights (docs/method.md) written out directly: eye vertex j is y_{k-1-j}.
double oracleLafortuneWeight(const cbk::SceneView& scene, const FullPath& path, int s, int ne,
                             int nl) {
    int k = int(path.y.size()), t = k - s;
    if (t < 2 || !cbk::bdptStrategyAllowed(s, t, ne, nl)) return 0.0;
    auto W = [&](int j) {
        int yi = k - 1 - j;
        double w = cbk::materialSpecularity(&scene, path.y[size_t(yi)].material);
        if (path.delta[size_t(yi)] || (yi - 1 >= 1 && path.delta[size_t(yi - 1)])) w = 1.0;
        return w;
    };
    int tMin = std::max(2, k - nl);
    int tMax = std::min(ne, k);
    if (path.y[0].type == CB_VERTEX_POINT_LIGHT) tMax = std::min(tMax, k - 1);
    if (t < tMin || t > tMax) return 0.0;
    // Products over the allowed eye vertices only: P[j] = W_{tMin-1} ... W_j.
    std::vector<double> P(size_t(k), 1.0);
    for (int j = tMin - 1; j < k - 1; ++j)
        P[size_t(j)] = (j > tMin - 1 ? P[size_t(j - 1)] : 1.0) * W(j);
    double before = t - 2 >= tMin - 1 ? P[size_t(t - 2)] : 1.0;
    if (t == tMax) return before;
    return before - P[size_t(t - 1)];
}

// The subpaths that strategy s sees for a given full path, with the pdfs a random walk would have
// stored (from the oracle's step densities), so that the shared weights of every strategy of the
// same path can be summed.
void subpathsOf(const cbk::SceneView& scene, const cbk::Camera& camera, const FullPath& path, int s,
                std::vector<PathVertex>& light, std::vector<PathVertex>& eye) {
    int k = int(path.y.size()), t = k - s;
    light.assign(path.y.begin(), path.y.begin() + s);
    eye.clear();
    for (int i = k - 1; i >= s; --i)
        eye.push_back(path.y[size_t(i)]);
    for (int i = 0; i < s; ++i) {
        PathVertex& v = light[size_t(i)];
        v.delta = (i >= 1 && i < s - 1) ? path.delta[size_t(i)] : 0;
        if (i >= 1) cbk::cbStore3(v.wo, dirTo(v, path.y[size_t(i - 1)]));
        if (i == 0)
            v.pdfFwd = v.type == CB_VERTEX_POINT_LIGHT ? scene.lights[v.light].pickProbability
                                                       : cbk::lightPdfArea(&scene, v.light);
        else
            v.pdfFwd = path.delta[size_t(i - 1)] && i - 1 >= 1
                           ? 0.f
                           : float(oracleStep(scene, camera, path, i - 1, i));
        v.pdfRev = (i + 2 <= s - 1 + 1 && i + 1 < s && i + 1 <= k - 2 && path.delta[size_t(i + 1)])
                       ? 0.f
                       : (i + 1 < s ? float(oracleStep(scene, camera, path, i + 1, i)) : 0.f);
    }
    for (int j = 0; j < t; ++j) {
        int yi = k - 1 - j;
        PathVertex& v = eye[size_t(j)];
        v.delta = (j >= 1 && j < t - 1) ? path.delta[size_t(yi)] : 0;
        if (j >= 1) cbk::cbStore3(v.wo, dirTo(v, path.y[size_t(yi + 1)]));
        if (j == 0)
            v.pdfFwd = 1.f;
        else
            v.pdfFwd = (yi + 1 <= k - 2 && path.delta[size_t(yi + 1)])
                           ? 0.f
                           : float(oracleStep(scene, camera, path, yi + 1, yi));
        v.pdfRev = (j + 1 < t) ? ((yi - 1 >= 1 && path.delta[size_t(yi - 1)])
                                      ? 0.f
                                      : float(oracleStep(scene, camera, path, yi - 1, yi)))
                               : 0.f;
    }
}

// Full paths from real subpaths: light[0..s-1] + reversed eye[0..t-1].
FullPath joinPath(const std::vector<PathVertex>& light, int s, const std::vector<PathVertex>& eye,
                  int t) {
    FullPath p;
    for (int i = 0; i < s; ++i)
        p.y.push_back(light[size_t(i)]);
    for (int j = t - 1; j >= 0; --j)
        p.y.push_back(eye[size_t(j)]);
    int k = s + t;
    p.delta.assign(size_t(k), 0);
    for (int i = 1; i < s - 1; ++i)
        p.delta[size_t(i)] = light[size_t(i)].delta;
    for (int j = 1; j < t - 1; ++j)
        p.delta[size_t(k - 1 - j)] = eye[size_t(j)].delta;
    return p;
}

} // namespace

TEST_CASE("BDPT MIS weights equal the explicit-ratio oracle and sum to one") {
    // A mix of diffuse, glossy and perfect-mirror surfaces, and an area quad, a point light or
    // a sphere light (s = 1 samples it by the cone it subtends, s >= 2 by area).
    for (int lightKind : {0, 1, 2}) {
        cb::SceneDesc desc = glossyMirrorScene(16, 0.0f);
        if (lightKind == 1) {
            desc.areaLights.clear();
            desc.meshes.pop_back();
            cb::PointLightDesc p;
            p.position = {0.2f, 0.7f, 0.2f};
            desc.pointLights.push_back(p);
        } else if (lightKind == 2) {
            desc.meshes.pop_back();
            cb::SphereDesc sphere;
            sphere.center = {0.2f, 0.6f, 0.3f};
            sphere.radius = 0.15f;
            sphere.material = 2;
            sphere.areaLight = 0;
            desc.spheres.push_back(sphere);
        }
        cb::DeviceScene scene = cb::buildDeviceScene(desc);
        cbk::SceneView view = cbtest::hostView(scene);
        const cbk::Camera& camera = scene.camera;
        const int ne = 5, nl = 4;
        long compared = 0, uncut = 0, sums = 0;
        // total = 5: the total-length cap with its subpath caps Ne = 5, Nl = 4: paths of up to 5
        // vertices keep every strategy (the oracle's caps then exclude none), longer ones none.
        for (int total : {0, 5})
            for (int weights : {CB_WEIGHTS_POWER, CB_WEIGHTS_LAFORTUNE}) {
                cbk::BdptSettings settings{};
                settings.eyeVertices = ne;
                settings.lightVertices = nl;
                settings.maxPathVertices = total;
                settings.weights = weights;
                settings.debugS = settings.debugT = -1;
                for (unsigned pixel = 0; pixel < 256; ++pixel) {
                    std::vector<PathVertex> light(static_cast<size_t>(nl)),
                        eye(static_cast<size_t>(ne));
                    int rays = 0;
                    int nLight = cbk::bdptLightSubpath(
                        &view,
                        cbk::bdptLightStream(
                            cbk::SamplerSettings{3, CB_SAMPLER_INDEPENDENT, {0, 0}}, 0, pixel, 256),
                        nl, light.data(), &rays);
                    cbk::SampleStream es = cbk::sampleStreamStart(3, 0, pixel);
                    float rx = float(pixel % 16) + cbk::sampleAt(es, 0);
                    float ry = float(pixel / 16) + cbk::sampleAt(es, 1);
                    int nEye = cbk::bdptEyeSubpath(&view, &camera, rx, ry, true, es, ne, eye.data(),
                                                   &rays);
                    for (int t = 1; t <= nEye; ++t)
                        for (int s = 0; s <= nLight; ++s) {
                            if (!cbk::bdptStrategyAllowed(s, t, ne, nl)) continue;
                            cbk::BdptConnection c;
                            if (!cbk::bdptConnectUnoccluded(&view, &camera, light.data(), s,
                                                            eye.data(), t, &c))
                                continue;
                            float w = cbk::bdptMisWeight(&view, light.data(), s, eye.data(), t,
                                                         c.ptPdfRev, c.ptMinusPdfRev, c.qsPdfRev,
                                                         c.qsMinusPdfRev, settings, 1.0f);
                            FullPath path = joinPath(light, s, eye, t);
                            const bool cut = total > 0 && s + t > total;
                            double expected = cut ? 0.0
                                              : weights == CB_WEIGHTS_POWER
                                                  ? oraclePowerWeight(view, camera, path, s, ne, nl)
                                                  : oracleLafortuneWeight(view, path, s, ne, nl);
                            CAPTURE(lightKind);
                            CAPTURE(total);
                            CAPTURE(weights);
                            CAPTURE(s);
                            CAPTURE(t);
                            CHECK(double(w) == doctest::Approx(expected).epsilon(2e-3));
                            ++compared;
                            if (cut) continue;
                            ++uncut;

                            // Every strategy of this same path, through the shared code.
                            double sum = 0.0;
                            int k = s + t;
                            for (int s2 = 0; s2 < k; ++s2) {
                                std::vector<PathVertex> l2, e2;
                                subpathsOf(view, camera, path, s2, l2, e2);
                                cbk::BdptConnection c2;
                                if (!cbk::bdptStrategyAllowed(s2, k - s2, ne, nl)) continue;
                                if (!oracleFeasible(path, s2, ne, nl)) continue;
                                if (!cbk::bdptConnectUnoccluded(&view, &camera, l2.data(), s2,
                                                                e2.data(), k - s2, &c2))
                                    continue;
                                sum +=
                                    cbk::bdptMisWeight(&view, l2.data(), s2, e2.data(), k - s2,
                                                       c2.ptPdfRev, c2.ptMinusPdfRev, c2.qsPdfRev,
                                                       c2.qsMinusPdfRev, settings, 1.0f);
                            }
                            // Lafortune's remainder goes to the last allowed strategy; where that
                            // one cannot make the path (a point light cannot be hit; or k > Ne and
                            // a delta vertex at that connection) the path is lost (docs/bdpt.md).
                            int tMax = std::min(ne, k);
                            if (path.y[0].type == CB_VERTEX_POINT_LIGHT)
                                tMax = std::min(tMax, k - 1);
                            if (weights == CB_WEIGHTS_LAFORTUNE &&
                                !oracleFeasible(path, k - tMax, ne, nl))
                                continue;
                            if (total > 0) {
                                // Under the total cap every s in 0..k-1 passes the caps.
                                for (int s2 = 0; s2 < k; ++s2)
                                    CHECK(cbk::bdptStrategyAllowed(s2, k - s2, ne, nl) ==
                                          !(s2 == 1 && k == 2));
                            }
                            CHECK(sum == doctest::Approx(1.0).epsilon(2e-3));
                            ++sums;
                        }
                }
            }
        CAPTURE(lightKind);
        CHECK(compared > 500);
        CHECK(sums > uncut * 9 / 10); // all but the lost Lafortune paths above
        CHECK(uncut < compared);      // the total cap did cut some
    }
}

TEST_CASE("BDPT single strategies equal PT restricted to the same path length" *
          doctest::test_suite("statistical")) {
    cb::ClRuntime runtime;
    struct SceneCase {
        const char* name;
        cb::SceneDesc desc;
        bool perfectMirror;
    };
    // A sky beside a disk light: light subpaths start on either (by power), and a strategy
    // that misweighs the sky's (its beam origin, pdfs or pick probability) misses PT's image.
    const cb::SceneDesc skyAndDisk = cb::parseSceneString(
        "LookAt 0 2 -3  0 0.3 0  0 1 0\nCamera \"perspective\" \"float fov\" 50\n"
        "Film \"rgb\" \"integer xresolution\" 24 \"integer yresolution\" 24\nWorldBegin\n"
        "LightSource \"infinite\" \"rgb L\" [1 1 1]\n"
        "AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [4 4 4]\n"
        "Translate -0.5 1.5 0\nRotate 90 1 0 0\nShape \"disk\" \"float radius\" 0.3\nAttributeEnd\n"
        "Material \"diffuse\" \"rgb reflectance\" [0.7 0.7 0.7]\n"
        "Shape \"bilinearmesh\" \"point3 P\" [-2 0 -2  2 0 -2  -2 0 2  2 0 2]\n"
        "Shape \"bilinearmesh\" \"point3 P\" [-2 0 1  2 0 1  -2 2 1  2 2 1]\n",
        "sky-and-disk.pbrt");
    const SceneCase scenes[] = {{"cornell-like", cornellLike(24), false},
                                {"glossy + near-mirror", glossyMirrorScene(24, 0.02f), false},
                                {"glossy + mirror", glossyMirrorScene(24, 0.0f), true},
                                {"sky and disk light", skyAndDisk, false}};
    const int maxK = 5;
    for (const SceneCase& sc : scenes) {
        const std::string name = sc.name; // CAPTURE prints a const char* as a pointer
        CAPTURE(name);
        cb::DeviceScene scene = cb::buildDeviceScene(sc.desc);
        std::vector<std::vector<Region>> pt(size_t(maxK + 1));
        for (int n = 2; n <= maxK; ++n)
            pt[size_t(n)] = renderRegions(scene, runtime, ptSettings(n, 100u + unsigned(n)), 96, 2);
        for (int k = 2; k <= maxK; ++k) {
            std::vector<Region> expected =
                difference(pt[size_t(k)], k > 2 ? &pt[size_t(k - 1)] : nullptr);
            for (int s = 0; s < k; ++s) {
                int t = k - s;
                if (!cbk::bdptStrategyAllowed(s, t, maxK, maxK - 1)) continue;
                CAPTURE(s);
                CAPTURE(t);
                cb::IntegratorSettings b = bdptSettings(maxK, maxK - 1, "power", 7);
                b.debugS = s;
                b.debugT = t;
                long nonFinite = 0;
                auto got = renderRegions(scene, runtime, b, 96, 2, &nonFinite);
                CHECK(nonFinite == 0);
                if (!sc.perfectMirror || s == 0) {
                    checkRegionsEqual(got, expected);
                } else {
                    // Strategies that connect at the perfect mirror cannot sample paths through
                    // it, so only s = 0 sees all of them: the others may only fall short.
                    for (size_t i = 0; i < got.size(); ++i)
                        CHECK(got[i].mean <=
                              expected[i].mean + 4.0 * std::sqrt(got[i].se * got[i].se +
                                                                 expected[i].se * expected[i].se));
                }
            }
        }
    }
}

// Under one refracting surface, light subpaths cross one interface that eye subpaths cross in
// the other direction, so radiance's (eta_t / eta_i)^2 and the adjoint BSDF's absence of it do
// not cancel (Veach 1997, sec. 5.2); a closed glass object hides a wrong adjoint. A pool: diffuse
// walls and floor under a glass surface, the light above it. BDPT under the total cap 6
// computes PT 6's paths, among them those connecting two diffuse vertices under the glass.
TEST_CASE("BDPT equals PT under a single refracting surface (the adjoint BSDF)" *
          doctest::test_suite("statistical")) {
    cb::ClRuntime runtime;
    // Smooth, and rough (GGX alpha 0.45: connections at the glass, transmission both ways).
    for (const std::string roughness : {"0", "0.2"}) {
        CAPTURE(roughness);
        const cb::DeviceScene scene = cb::buildDeviceScene(cb::parseSceneString(
            "LookAt 0 2.2 -2.4  0 0.2 0  0 1 0\nCamera \"perspective\" \"float fov\" 45\n"
            "Film \"rgb\" \"integer xresolution\" 24 \"integer yresolution\" 24\nWorldBegin\n"
            "AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [4 4 4] \"bool twosided\" true\n"
            "Shape \"bilinearmesh\" \"point3 P\" [-0.8 2.5 -0.8  0.8 2.5 -0.8  -0.8 2.5 0.8  0.8 "
            "2.5 "
            "0.8]\n"
            "AttributeEnd\n"
            "AttributeBegin\nMaterial \"dielectric\" \"float eta\" 1.5 \"float roughness\" " +
                roughness +
                "\nShape \"bilinearmesh\" \"point3 P\" [-1 1 -1  -1 1 1  1 1 -1  1 1 1]\n"
                "AttributeEnd\n"
                "Material \"diffuse\" \"rgb reflectance\" [0.8 0.8 0.8]\n"
                "Shape \"bilinearmesh\" \"point3 P\" [-1 0 -1  1 0 -1  -1 0 1  1 0 1]\n"
                "Shape \"bilinearmesh\" \"point3 P\" [-1 0 1  1 0 1  -1 1 1  1 1 1]\n"
                "Shape \"bilinearmesh\" \"point3 P\" [-1 0 -1  -1 0 1  -1 1 -1  -1 1 1]\n"
                "Shape \"bilinearmesh\" \"point3 P\" [1 0 -1  1 0 1  1 1 -1  1 1 1]\n",
            "pool.pbrt"));
        CHECK((scene.featureNames().find("rough-dielectric") != std::string::npos) ==
              (roughness != "0"));
        // Estimates enough that the adjoint's error (about 15% here) is 6 standard errors.
        const auto pt = renderRegions(scene, runtime, ptSettings(6, 31), 512, 2);
        for (const std::string weights : {"power", "lafortune"}) {
            CAPTURE(weights);
            cb::IntegratorSettings b = bdptSettings(6, 6, weights.c_str(), 32);
            b.maxPathVertices = 6;
            long nonFinite = 0;
            checkRegionsEqual(renderRegions(scene, runtime, b, 256, 2, &nonFinite), pt);
            CHECK(nonFinite == 0);
        }
    }
}

TEST_CASE("BDPT with both weightings equals PT and the furnace" *
          doctest::test_suite("statistical")) {
    cb::ClRuntime runtime;
    SUBCASE("Cornell-like box: BDPT 3+3 against PT 6") {
        cb::DeviceScene scene = cb::buildDeviceScene(cornellLike(24));
        auto pt = renderRegions(scene, runtime, ptSettings(6, 11), 128, 2);
        for (const char* weights : {"power", "lafortune"}) {
            CAPTURE(weights);
            long nonFinite = 0;
            auto b =
                renderRegions(scene, runtime, bdptSettings(3, 3, weights, 12), 128, 2, &nonFinite);
            checkRegionsEqual(b, pt);
            CHECK(nonFinite == 0);
        }
    }
    SUBCASE("furnace: BDPT 3+2 against Le (1 - a^4) / (1 - a)") {
        const float albedo = 0.6f, emission = 0.25f;
        cb::DeviceScene scene = cb::buildDeviceScene(cbtest::furnaceScene(albedo, emission));
        double expected = emission * (1.0 - std::pow(double(albedo), 4)) / (1.0 - albedo);
        for (const char* weights : {"power", "lafortune"}) {
            CAPTURE(weights);
            auto stats = cbtest::renderPooled(scene, runtime, bdptSettings(3, 2, weights, 5), 16);
            CAPTURE(stats.mean);
            CAPTURE(stats.standardError);
            CHECK(std::fabs(stats.mean - expected) <= 4.0 * stats.standardError + 1e-5 * expected);
            CHECK(stats.nonFinite == 0);
        }
    }
}

TEST_CASE("BDPT point light and tiny sphere light match PT" * doctest::test_suite("statistical")) {
    cb::ClRuntime runtime;
    for (int lightKind : {1, 2}) {
        CAPTURE(lightKind);
        cb::DeviceScene scene = cb::buildDeviceScene(cornellLike(24, lightKind));
        auto pt = renderRegions(scene, runtime, ptSettings(5, 21), 128, 2);
        long nonFinite = 0;
        auto b = renderRegions(scene, runtime, bdptSettings(3, 2, "power", 22), 128, 2, &nonFinite);
        checkRegionsEqual(b, pt);
        CHECK(nonFinite == 0);
    }
}

TEST_CASE("BDPT rejects strategies the caps do not allow") {
    cb::ClRuntime runtime;
    cb::DeviceScene scene = cb::buildDeviceScene(cornellLike(8));
    cb::IntegratorSettings s = bdptSettings(3, 2, "power", 1);
    s.debugS = 1;
    s.debugT = 1;
    CHECK_THROWS(cb::makeIntegrator(s, scene, runtime));
    s.debugS = 3;
    s.debugT = 2;
    CHECK_THROWS(cb::makeIntegrator(s, scene, runtime));
    CHECK(cbk::bdptStrategyAllowed(0, 2, 3, 2));
    CHECK_FALSE(cbk::bdptStrategyAllowed(0, 4, 3, 2));
}
