/* cb_texture.h - pbrt-v4's image textures ("imagemap") as reflectances: texture coordinates of
 * a hit point and the texture's value there, shared by the kernels and the host.
 *
 * The `textures` buffer holds, per primitive, six values: a triangle's three vertices' (u, v) or
 * a sphere's object frame (sphereTexCoord); then each texture at the offset its materials name:
 * a header of CB_TEXTURE_HEADER values (below) and the texels' linear RGB, row-major, top row
 * first, with the texture's "scale" and "invert" applied (both commute with bilinear
 * interpolation). pbrt-v4's "constant", "scale" and "checkerboard" textures arrive as such
 * images too (src/scene/parser.cpp). */
#ifndef CB_TEXTURE_H
#define CB_TEXTURE_H

#include "cb_noise.h"
#include "cb_rng.h"
#include "cb_spectrum.h"
#include "cb_types.h"

CB_BEGIN_NAMESPACE

#define CB_TEXTURE_WIDTH 0
#define CB_TEXTURE_HEIGHT 1
#define CB_TEXTURE_WRAP 2   /* CB_WRAP_* */
#define CB_TEXTURE_FILTER 3 /* CB_FILTER_* */
#define CB_TEXTURE_USCALE 4 /* pbrt-v4's UVMapping: s = uscale u + udelta */
#define CB_TEXTURE_VSCALE 5 /* t = vscale v + vdelta */
#define CB_TEXTURE_UDELTA 6
#define CB_TEXTURE_VDELTA 7
#define CB_TEXTURE_BASIS 8   /* spectral scenes: the spectra entry of Smits's basis (7 entries) */
#define CB_TEXTURE_MAPPING 9 /* CB_MAPPING_* */
/* Mappings by the hit point: a 3 x 4 row-major affine map from device space (camera-relative)
 * to pbrt-v4's texture space, for "planar" already projected onto its v1, v2 (rows 0, 1). */
#define CB_TEXTURE_MATRIX 10
#define CB_TEXTURE_HEADER 22

#define CB_MAPPING_UV 0
#define CB_MAPPING_SPHERICAL 1
#define CB_MAPPING_CYLINDRICAL 2
#define CB_MAPPING_PLANAR 3
/* Not a mapping: pbrt-v4's "directionmix" of two images, whose unit direction (device space)
 * fills the matrix's first three values and whose parts follow the header, each an image's header
 * and texels (textureReflectance). */
#define CB_MAPPING_DIRECTION_MIX 4
/* Not an image: one of pbrt-v4's procedural float textures, at the hit point in texture space
 * (the matrix, pbrt-v4's PointTransformMapping), with no texels. Its kind (CB_NOISE_*), octaves
 * and omega (pbrt-v4's "roughness") take the header's (u, v) mapping slots. */
#define CB_MAPPING_NOISE 5
#define CB_TEXTURE_NOISE_KIND 4
#define CB_TEXTURE_NOISE_OCTAVES 5
#define CB_TEXTURE_NOISE_OMEGA 6
#define CB_NOISE_FBM 0
#define CB_NOISE_WRINKLED 1
#define CB_NOISE_WINDY 2

#define CB_WRAP_REPEAT 0
#define CB_WRAP_BLACK 1
#define CB_WRAP_CLAMP 2

#define CB_FILTER_BILINEAR 0 /* pbrt-v4's Image::Bilerp at full resolution */
#define CB_FILTER_POINT 1    /* the nearest texel */

/* Texture coordinates at barycentrics (b1, b2) of triangle `primitive`. */
CB_FN TexCoord triangleTexCoord(const SceneView* scene, int primitive, real b1, real b2) {
    CB_GLOBAL const real* uv = scene->textures + 6 * primitive;
    real b0 = 1.0f - b1 - b2;
    TexCoord c;
    c.u = b0 * uv[0] + b1 * uv[2] + b2 * uv[4];
    c.v = b0 * uv[1] + b1 * uv[3] + b2 * uv[5];
    c.hero = -1.0f;
#if CB_HAS(CB_FEATURE_TEXTURE_MAPPING)
    c.p = vec3(0.0f, 0.0f, 0.0f); /* the caller's hit point, where it has one */
#endif
#if CB_HAS(CB_FEATURE_DIRECTION_MIX)
    c.n = vec3(0.0f, 0.0f, 0.0f); /* the caller's normal */
#endif
    return c;
}

/* v rotated by the unit quaternion (axis, w) (v + 2 w (a x v) + 2 a x (a x v)). */
CB_FN Vec3 quaternionRotate(Vec3 axis, real w, Vec3 v) {
    Vec3 t = vscale(vcross(axis, v), 2.0f);
    return vadd(vadd(v, vscale(t, w)), vcross(axis, t));
}

/* A sphere's object frame: the rotation from world to it is the quaternion (x, y, z, w) at
 * textures[6 * primitive], x negated afterwards where the frame is mirrored (entry 4 < 0); entry
 * 5 scales dp/du and dp/dv into dn/du and dn/dv (sphereShadingPartials). A world-space offset
 * from the centre in that frame (same length), with pbrt-v4's nudge off the poles, where phi is
 * undefined. */
CB_FN Vec3 sphereObjectPoint(const SceneView* scene, int primitive, Vec3 pLocal) {
    CB_GLOBAL const real* q = scene->textures + 6 * primitive;
    Vec3 p = quaternionRotate(vec3(q[0], q[1], q[2]), q[3], pLocal);
    if (q[4] < 0.0f) p.x = -p.x;
    if (p.x == 0.0f && p.y == 0.0f) p.x = 1e-5f * vlength(p);
    return p;
}

/* pbrt-v4's sphere (u, v) at pLocal, the hit point minus the centre (world space): phi / 2 pi
 * and 1 - theta / pi of the point in the sphere's object frame (sphereObjectPoint), where u
 * runs from +x toward +y and v = 1 is the +z pole. */
CB_FN TexCoord sphereTexCoord(const SceneView* scene, int primitive, Vec3 pLocal) {
    Vec3 p = sphereObjectPoint(scene, primitive, pLocal);
    real r = vlength(p);
    real phi = atan2(p.y, p.x);
    if (phi < 0.0f) phi += 2.0f * CB_PI;
    TexCoord c;
    c.u = phi * (0.5f * CB_INV_PI);
    c.v = 1.0f - acos(cbClamp(p.z / r, -1.0f, 1.0f)) * CB_INV_PI;
    c.hero = -1.0f;
#if CB_HAS(CB_FEATURE_TEXTURE_MAPPING)
    c.p = vec3(0.0f, 0.0f, 0.0f); /* the caller's hit point */
#endif
#if CB_HAS(CB_FEATURE_DIRECTION_MIX)
    c.n = vec3(0.0f, 0.0f, 0.0f); /* the caller's normal */
#endif
    return c;
}

/* Texel (x, y)'s RGB, x and y at most one image size outside the image: wrapped, or black
 * outside it for CB_WRAP_BLACK (pbrt-v4's RemapPixelCoords). */
CB_FN Vec3 textureTexel(CB_GLOBAL const real* texture, int x, int y) {
    int w = (int)texture[CB_TEXTURE_WIDTH];
    int h = (int)texture[CB_TEXTURE_HEIGHT];
    int wrap = (int)texture[CB_TEXTURE_WRAP];
    if (wrap == CB_WRAP_REPEAT) {
        x = (x + w) % w;
        y = (y + h) % h;
    } else if (wrap == CB_WRAP_CLAMP) {
        x = x < 0 ? 0 : (x >= w ? w - 1 : x);
        y = y < 0 ? 0 : (y >= h ? h - 1 : y);
    } else if (x < 0 || x >= w || y < 0 || y >= h) {
        return vec3(0.0f, 0.0f, 0.0f);
    }
    CB_GLOBAL const real* rgb = texture + CB_TEXTURE_HEADER + 3 * (y * w + x);
    return vec3(rgb[0], rgb[1], rgb[2]);
}

#if CB_HAS(CB_FEATURE_TEXTURE_MAPPING)
/* The hit point of uv in the texture's space: its header's 3 x 4 map of device space. */
CB_FN Vec3 texturePoint(CB_GLOBAL const real* texture, TexCoord uv) {
    CB_GLOBAL const real* m = texture + CB_TEXTURE_MATRIX;
    return vec3(m[0] * uv.p.x + m[1] * uv.p.y + m[2] * uv.p.z + m[3],
                m[4] * uv.p.x + m[5] * uv.p.y + m[6] * uv.p.z + m[7],
                m[8] * uv.p.x + m[9] * uv.p.y + m[10] * uv.p.z + m[11]);
}
#endif

/* The texture's (s, t) at uv, pbrt-v4's TextureMapping2D: the "uv" mapping's (u, v), or the
 * point's in texture space, q, by "spherical" (theta / pi, phi / 2 pi of q's direction),
 * "cylindrical" ((pi + atan2(q.y, q.x)) / 2 pi, q.z) or "planar" (q's first two rows, v1 and v2
 * folded in); then scaled and offset (uscale, vscale, udelta, vdelta, 1 and 0 but for "uv" and
 * the deltas of "planar") and t flipped, as ImageTexture flips it: image rows run down. */
CB_FN void textureST(CB_GLOBAL const real* texture, TexCoord uv, real* s, real* t) {
    real s0 = uv.u, t0 = uv.v;
#if CB_HAS(CB_FEATURE_TEXTURE_MAPPING)
    int mapping = (int)texture[CB_TEXTURE_MAPPING];
    if (mapping != CB_MAPPING_UV) {
        Vec3 q = texturePoint(texture, uv);
        if (mapping == CB_MAPPING_SPHERICAL) {
            real r = vlength(q);
            real phi = atan2(q.y, q.x);
            if (phi < 0.0f) phi += 2.0f * CB_PI;
            s0 = acos(cbClamp(q.z / r, -1.0f, 1.0f)) * CB_INV_PI;
            t0 = phi * (0.5f * CB_INV_PI);
        } else if (mapping == CB_MAPPING_CYLINDRICAL) {
            s0 = (CB_PI + atan2(q.y, q.x)) * (0.5f * CB_INV_PI);
            t0 = q.z;
        } else {
            s0 = q.x;
            t0 = q.y;
        }
    }
#endif
    *s = texture[CB_TEXTURE_USCALE] * s0 + texture[CB_TEXTURE_UDELTA];
    *t = 1.0f - (texture[CB_TEXTURE_VSCALE] * t0 + texture[CB_TEXTURE_VDELTA]);
}

/* The texture's RGB at texture coordinates uv: pbrt-v4's ImageTexture at textureST's (s, t),
 * bilinear between the four nearest texel centres or the nearest texel. Coordinates are first
 * brought into one period (repeat) or just outside the image (black, clamp), which changes no
 * value and keeps texel indices small. */
CB_FN Vec3 textureRgb(const SceneView* scene, int offset, TexCoord uv) {
    CB_GLOBAL const real* texture = scene->textures + offset;
    real w = texture[CB_TEXTURE_WIDTH];
    real h = texture[CB_TEXTURE_HEIGHT];
    real s, t;
    textureST(texture, uv, &s, &t);
    if (!(isfinite(s) && isfinite(t))) return vec3(0.0f, 0.0f, 0.0f);
    if ((int)texture[CB_TEXTURE_WRAP] == CB_WRAP_REPEAT) {
        s -= floor(s);
        t -= floor(t);
    } else {
        s = cbClamp(s, -1.0f, 2.0f);
        t = cbClamp(t, -1.0f, 2.0f);
    }
    if ((int)texture[CB_TEXTURE_FILTER] == CB_FILTER_POINT)
        return textureTexel(texture, (int)floor(s * w), (int)floor(t * h));
    real x = s * w - 0.5f;
    real y = t * h - 0.5f;
    real x0 = floor(x);
    real y0 = floor(y);
    real dx = x - x0;
    real dy = y - y0;
    int xi = (int)x0;
    int yi = (int)y0;
    Vec3 top = vadd(vscale(textureTexel(texture, xi, yi), 1.0f - dx),
                    vscale(textureTexel(texture, xi + 1, yi), dx));
    Vec3 bottom = vadd(vscale(textureTexel(texture, xi, yi + 1), 1.0f - dx),
                       vscale(textureTexel(texture, xi + 1, yi + 1), dx));
    return vadd(vscale(top, 1.0f - dy), vscale(bottom, dy));
}

/* A float texture's value at uv: the mean of its texels' channels (the parser stores a float
 * texture's texels as three equal values: the value pbrt-v4's float lookup reads). */
CB_FN real textureFloat(const SceneView* scene, int offset, TexCoord uv) {
#if CB_HAS(CB_FEATURE_NOISE_TEXTURE) && CB_HAS(CB_FEATURE_TEXTURE_MAPPING)
    CB_GLOBAL const real* texture = scene->textures + offset;
    if ((int)texture[CB_TEXTURE_MAPPING] == CB_MAPPING_NOISE) {
        const Vec3 q = texturePoint(texture, uv);
        const int kind = (int)texture[CB_TEXTURE_NOISE_KIND];
        const int octaves = (int)texture[CB_TEXTURE_NOISE_OCTAVES];
        const real omega = texture[CB_TEXTURE_NOISE_OMEGA];
        if (kind == CB_NOISE_WINDY) return noiseWindy(q);
        return kind == CB_NOISE_WRINKLED ? noiseTurbulence(q, omega, octaves)
                                         : noiseFbm(q, omega, octaves);
    }
#endif
    Vec3 rgb = textureRgb(scene, offset, uv);
    return (rgb.x + rgb.y + rgb.z) * (1.0f / 3.0f);
}

/* pbrt-v4's alpha test (GeometricPrimitive::Intersect) for a hit at barycentrics (b1, b2) of
 * alpha-tested triangle `primitive`: alpha a >= 1 keeps it, a <= 0 skips it, and between, it is
 * kept where a hash of the ray and the primitive, uniform on [0, 1), is below a (stochastic
 * transparency: on average a share a of the surface is there). The hash gives the same answer to
 * the same ray, so a closest-hit and an any-hit query along it agree; the traversal then goes on
 * past a skipped hit (pbrt-v4 traces a new ray from it). */
CB_FN bool alphaKeepsHit(const SceneView* scene, int primitive, Ray ray, real b1, real b2) {
    /* Host views without textures (the BVH choice's, measuring traversal work) keep every hit. */
    if (!scene || !scene->textures) return true;
    int offset = scene->materials[scene->primitives[primitive].material].alphaTexture;
    real a = textureFloat(scene, offset, triangleTexCoord(scene, primitive, b1, b2));
    if (a >= 1.0f) return true;
    if (!(a > 0.0f)) return false;
    uint h = cbHashCombine(cbHash32((uint)primitive), cbFloatBits(ray.o.x));
    h = cbHashCombine(cbHashCombine(h, cbFloatBits(ray.o.y)), cbFloatBits(ray.o.z));
    h = cbHashCombine(cbHashCombine(h, cbFloatBits(ray.d.x)), cbFloatBits(ray.d.y));
    h = cbHashCombine(h, cbFloatBits(ray.d.z));
    return (real)(h >> 8) * (1.0f / 16777216.0f) < a;
}

/* pbrt-v4's CoordinateSystem: a unit vector perpendicular to unit v (the frame's first axis). */
CB_FN Vec3 coordinateSystemFirst(Vec3 v) {
    real sign = v.z >= 0.0f ? 1.0f : -1.0f;
    real a = -1.0f / (sign + v.z);
    return vec3(1.0f + sign * v.x * v.x * a, sign * v.x * v.y * a, -sign * v.x);
}

/* pbrt-v4's CoordinateSystem: the frame's second axis, cross(v, coordinateSystemFirst(v)) for a
 * unit v (pbrt-v4 also calls it on vectors that are not, with the same formula). */
CB_FN Vec3 coordinateSystemSecond(Vec3 v) {
    real sign = v.z >= 0.0f ? 1.0f : -1.0f;
    real a = -1.0f / (sign + v.z);
    return vec3(v.x * v.y * a, sign + v.y * v.y * a, -v.y);
}

/* pbrt-v4's Triangle partial derivatives (Triangle::InteractionFromIntersection): dp/du and
 * dp/dv from the corners' (u, v) (textures[6 * primitive]), or where those are degenerate
 * (|determinant| < 1e-9) or give parallel derivatives, the frame CoordinateSystem builds about
 * cross(p2 - p0, p1 - p0); with the (u, v) differences that dn/du and dn/dv need too. */
typedef struct TriangleUvFrame {
    real du02, dv02, du12, dv12, determinant;
    int degenerate;
    Vec3 dpdu, dpdv;
} TriangleUvFrame;

CB_FN TriangleUvFrame triangleUvFrame(const SceneView* scene, int primitive, Vec3 p0, Vec3 p1,
                                      Vec3 p2) {
    CB_GLOBAL const real* uv = scene->textures + 6 * primitive;
    TriangleUvFrame f;
    f.du02 = uv[0] - uv[4];
    f.dv02 = uv[1] - uv[5];
    f.du12 = uv[2] - uv[4];
    f.dv12 = uv[3] - uv[5];
    f.determinant = f.du02 * f.dv12 - f.dv02 * f.du12;
    f.degenerate = fabs(f.determinant) < 1e-9f;
    f.dpdu = vec3(0.0f, 0.0f, 0.0f);
    f.dpdv = f.dpdu;
    Vec3 dp02 = vsub(p0, p2), dp12 = vsub(p1, p2);
    if (!f.degenerate) {
        real inverse = 1.0f / f.determinant;
        f.dpdu = vscale(vsub(vscale(dp02, f.dv12), vscale(dp12, f.dv02)), inverse);
        f.dpdv = vscale(vsub(vscale(dp12, f.du02), vscale(dp02, f.du12)), inverse);
    }
    if (f.degenerate || vlength2(vcross(f.dpdu, f.dpdv)) == 0.0f) {
        Vec3 ng = vnormalize(vcross(vsub(p2, p0), vsub(p1, p0)));
        f.dpdu = coordinateSystemFirst(ng);
        f.dpdv = coordinateSystemSecond(ng);
    }
    return f;
}

/* A hit's shading partial derivatives as pbrt-v4's shapes hand them to its normal and bump
 * maps: dp/du, dp/dv and the normal's dn/du, dn/dv. */
typedef struct ShadingPartials {
    Vec3 dpdu, dpdv, dndu, dndv;
} ShadingPartials;

/* pbrt-v4's Triangle shading geometry at a hit whose shading normal is ns: dp/du and dp/dv from
 * the corners' (u, v) (a frame about ng where they are degenerate), and with vertex normals, dp/du
 * made perpendicular to ns and ns x dp/du, and dn/du, dn/dv from the vertex normals. */
CB_FN ShadingPartials triangleShadingPartials(const SceneView* scene, int primitive, Vec3 p0,
                                              Vec3 p1, Vec3 p2, Vec3 ns) {
    TriangleUvFrame f = triangleUvFrame(scene, primitive, p0, p1, p2);
    ShadingPartials d;
    d.dpdu = f.dpdu;
    d.dpdv = f.dpdv;
    d.dndu = vec3(0.0f, 0.0f, 0.0f);
    d.dndv = d.dndu;
#if CB_HAS(CB_FEATURE_SHADING_NORMALS)
    CB_GLOBAL const real* vn = scene->shadingNormals ? scene->shadingNormals + 9 * primitive : 0;
    if (vn) {
        Vec3 n0 = vec3FromGlobalArray(vn), n1 = vec3FromGlobalArray(vn + 3);
        Vec3 n2 = vec3FromGlobalArray(vn + 6);
        if (vlength2(n0) + vlength2(n1) + vlength2(n2) > 0.0f) {
            Vec3 ts = vcross(ns, d.dpdu);
            if (vlength2(ts) > 0.0f) {
                d.dpdu = vcross(ts, ns);
                d.dpdv = ts;
            } else {
                d.dpdu = coordinateSystemFirst(ns);
                d.dpdv = coordinateSystemSecond(ns);
            }
            if (f.degenerate) {
                Vec3 dn = vcross(vsub(n2, n0), vsub(n1, n0));
                if (vlength2(dn) != 0.0f) {
                    d.dndu = coordinateSystemFirst(dn);
                    d.dndv = coordinateSystemSecond(dn);
                }
            } else {
                real inverse = 1.0f / f.determinant;
                Vec3 dn1 = vsub(n0, n2), dn2 = vsub(n1, n2);
                d.dndu = vscale(vsub(vscale(dn1, f.dv12), vscale(dn2, f.dv02)), inverse);
                d.dndv = vscale(vsub(vscale(dn2, f.du02), vscale(dn1, f.du12)), inverse);
            }
        }
    }
#else
    (void)ns;
#endif
    return d;
}

/* pbrt-v4's Sphere::InteractionFromIntersection for a full sphere at pLocal, the hit point minus
 * the centre: in the object frame (sphereObjectPoint) dp/du = 2 pi (-y, x, 0) and dp/dv =
 * -pi (z cos phi, z sin phi, -r sin theta), brought back to world space; dn/du and dn/dv are
 * them over the radius (the Weingarten equations on a sphere) as pbrt-v4 transforms them, as
 * normals: over the CTM's scale once more (textures[6 * primitive + 5], device_scene.cpp). The
 * normal's orientation does not enter, as in pbrt-v4. */
CB_FN ShadingPartials sphereShadingPartials(const SceneView* scene, int primitive, Vec3 pLocal) {
    CB_GLOBAL const real* q = scene->textures + 6 * primitive;
    Vec3 p = sphereObjectPoint(scene, primitive, pLocal);
    real r = vlength(p);
    real zRadius = sqrt(p.x * p.x + p.y * p.y);
    real cosTheta = p.z / r;
    real sinTheta = sqrt(fmax(1.0f - cosTheta * cosTheta, 0.0f));
    Vec3 dpdu = vec3(-2.0f * CB_PI * p.y, 2.0f * CB_PI * p.x, 0.0f);
    Vec3 dpdv = vscale(vec3(p.z * (p.x / zRadius), p.z * (p.y / zRadius), -r * sinTheta), -CB_PI);
    if (q[4] < 0.0f) {
        dpdu.x = -dpdu.x;
        dpdv.x = -dpdv.x;
    }
    Vec3 inverseAxis = vec3(-q[0], -q[1], -q[2]);
    ShadingPartials d;
    d.dpdu = quaternionRotate(inverseAxis, q[3], dpdu);
    d.dpdv = quaternionRotate(inverseAxis, q[3], dpdv);
    d.dndu = vscale(d.dpdu, q[5]);
    d.dndv = vscale(d.dpdv, q[5]);
    return d;
}

/* The shading normal of a bump-mapped surface at surface point sp (pbrt-v4's BumpMap and
 * SetShadingGeometry) from its shading partials d: the displacement is looked up at (u, v) and
 * 0.0005 further along u and along v (pbrt-v4's step where a ray has no differentials, as under
 * Option "disabletexturefiltering"); each tangent moves along ns by the displacement's slope and
 * by it times the normal's derivative, and their cross product, turned to ng's side, is the
 * shading normal. */
CB_FN Vec3 bumpMapNormal(const SceneView* scene, int offset, ShadingPartials d, SurfacePoint sp) {
    Vec3 ns = sp.ns;
    const real step = 0.0005f;
    TexCoord alongU = sp.uv, alongV = sp.uv;
    alongU.u += step;
    alongV.v += step;
#if CB_HAS(CB_FEATURE_TEXTURE_MAPPING)
    alongU.p = vadd(sp.p, vscale(d.dpdu, step)); /* BumpMap shifts the point too */
    alongV.p = vadd(sp.p, vscale(d.dpdv, step));
#endif
    real h = textureFloat(scene, offset, sp.uv);
    real hU = textureFloat(scene, offset, alongU);
    real hV = textureFloat(scene, offset, alongV);
    Vec3 bumpedU = vadd(vadd(d.dpdu, vscale(ns, (hU - h) / step)), vscale(d.dndu, h));
    Vec3 bumpedV = vadd(vadd(d.dpdv, vscale(ns, (hV - h) / step)), vscale(d.dndv, h));
    Vec3 n = vcross(bumpedU, bumpedV);
    real length2 = vlength2(n);
    if (!(length2 > 0.0f) || !isfinite(length2)) return sp.ns;
    n = vscale(n, 1.0f / sqrt(length2));
    return vdot(n, sp.ng) < 0.0f ? vneg(n) : n;
}

/* The shading normal of a normal-mapped surface at surface point sp (pbrt-v4's NormalMap and
 * SetShadingGeometry): the texel 2 rgb - 1, normalised, in the frame whose z is sp.ns and whose
 * x is the shape's dp/du (triangleUvFrame's, sphereShadingPartials') made perpendicular to it,
 * then turned to ng's side. The texture is read as pbrt-v4 reads normal maps: linear, bilinear,
 * repeating, v = 1 the top row. */
CB_FN Vec3 normalMapNormal(const SceneView* scene, int offset, Vec3 dpdu, SurfacePoint sp) {
    if (!(vlength2(dpdu) > 0.0f) || !isfinite(vlength2(dpdu)))
        dpdu = coordinateSystemFirst(sp.ng); /* (u, v) beyond the float range: any tangent */
    Vec3 x = vcross(vcross(sp.ns, dpdu), sp.ns);
    x = vlength2(x) > 0.0f ? vnormalize(x) : coordinateSystemFirst(sp.ns);
    Vec3 y = vcross(sp.ns, x);
    Vec3 rgb = textureRgb(scene, offset, sp.uv);
    Vec3 tangent = vec3(2.0f * rgb.x - 1.0f, 2.0f * rgb.y - 1.0f, 2.0f * rgb.z - 1.0f);
    real length2 = vlength2(tangent);
    if (!(length2 > 0.0f) || !isfinite(length2)) return sp.ns;
    tangent = vscale(tangent, 1.0f / sqrt(length2));
    Vec3 n = vnormalize(
        vadd(vadd(vscale(x, tangent.x), vscale(y, tangent.y)), vscale(sp.ns, tangent.z)));
    return vdot(n, sp.ng) < 0.0f ? vneg(n) : n;
}

/* The texture as a reflectance: RGB clamped to [0, 1] as pbrt-v4 clamps an albedo texture; in
 * spectral scenes Smits's spectrum of it, each bin clamped to [0, 1] as the host clamps a
 * constant reflectance's (SpectraTable::addAlbedo). */
CB_FN Spectrum textureImageReflectance(const SceneView* scene, int offset, TexCoord uv) {
    Vec3 rgb = textureRgb(scene, offset, uv);
    real r = cbClamp(rgb.x, 0.0f, 1.0f);
    real g = cbClamp(rgb.y, 0.0f, 1.0f);
    real b = cbClamp(rgb.z, 0.0f, 1.0f);
#if CB_CHANNELS == 3
    Spectrum s;
    s.c[0] = r;
    s.c[1] = g;
    s.c[2] = b;
    return s;
#else
    int basis = (int)scene->textures[offset + CB_TEXTURE_BASIS];
    Spectrum s = smitsSpectrum(scene->spectra, basis, r, g, b);
    for (int i = 0; i < CB_CHANNELS; ++i)
        s.c[i] = cbClamp(s.c[i], 0.0f, 1.0f);
    return s;
#endif
}

/* A spectrum texture's reflectance at uv: an image's (textureImageReflectance), or pbrt-v4's
 * "directionmix" (SpectrumDirectionMixTexture), a |n . dir| tex1 + (1 - a) tex2 at the hit's
 * geometric normal n, each part an image's reflectance (clamped as pbrt-v4 clamps an image's
 * albedo) and looked up only where its weight is not 0. */
CB_FN Spectrum textureReflectance(const SceneView* scene, int offset, TexCoord uv) {
#if CB_HAS(CB_FEATURE_DIRECTION_MIX)
    CB_GLOBAL const real* texture = scene->textures + offset;
    if ((int)texture[CB_TEXTURE_MAPPING] == CB_MAPPING_DIRECTION_MIX) {
        CB_GLOBAL const real* dir = texture + CB_TEXTURE_MATRIX;
        real a = fabs(vdot(uv.n, vec3(dir[0], dir[1], dir[2])));
        int first = offset + CB_TEXTURE_HEADER;
        CB_GLOBAL const real* one = scene->textures + first;
        int second = first + CB_TEXTURE_HEADER +
                     3 * (int)one[CB_TEXTURE_WIDTH] * (int)one[CB_TEXTURE_HEIGHT];
        Spectrum s = specZero();
        if (a != 0.0f) s = specScale(textureImageReflectance(scene, first, uv), a);
        if (a != 1.0f)
            s = specAdd(s, specScale(textureImageReflectance(scene, second, uv), 1.0f - a));
        return s;
    }
#endif
    return textureImageReflectance(scene, offset, uv);
}

CB_END_NAMESPACE

#endif /* CB_TEXTURE_H */
