/* cb_common.h - the common subset of C++ and OpenCL C used by every shared header.
 *
 * Every shared header in kernels/ is written once and compiled twice: by PoCL as OpenCL C for the
 * kernels, and by g++ as C++ for the host (light subpaths for CBDPT, test oracles). On the host
 * the code lives in namespace `cbk`. Shared structs use plain real arrays, never float3
 * (16 bytes in OpenCL, 12 in C++), and are padded to 16-byte multiples explicitly.
 *
 * `real` is float and Spectrum has CB_CHANNELS = 3 floats by default, which is the global host
 * `cbk`. Other real types and channel counts are host instances compiled by
 * src/kernel_host/kernel_instance.h, e.g. real = double: the same geometry, sampling and path
 * code in double precision, the oracle that the float kernels are checked against (src/float64/,
 * tests/test_precision.cpp). Layout asserts hold only for float. */
#ifndef CB_COMMON_H
#define CB_COMMON_H

#ifdef __OPENCL_C_VERSION__
#define CB_KERNEL_SIDE 1
#define CB_GLOBAL __global
#define CB_CONSTANT __constant
#define CB_BEGIN_NAMESPACE
#define CB_END_NAMESPACE
#define CB_STATIC_ASSERT(cond, msg)
/* C99 inline semantics need `static` so that a call the compiler does not inline still links. */
#define CB_FN static inline
#else
#include <cmath>
#include <cstdint>
#include <cstring>
#define CB_GLOBAL
#define CB_CONSTANT
#define CB_BEGIN_NAMESPACE namespace cbk {
#define CB_END_NAMESPACE }
/* Layout asserts: they describe the float layout the device sees. */
#define CB_STATIC_ASSERT(cond, msg) static_assert(sizeof(CB_REAL) != sizeof(float) || (cond), msg)
#define CB_FN inline
#endif

#ifndef CB_REAL
#define CB_REAL float
#endif

CB_BEGIN_NAMESPACE

typedef CB_REAL real;

#ifndef CB_KERNEL_SIDE
typedef std::uint32_t uint;
typedef std::uint64_t ulong;
using std::asin;
using std::atan2;
using std::copysign;
using std::cos;
using std::erf;
using std::exp;
using std::fabs;
using std::floor;
using std::fma;
using std::fmax;
using std::fmin;
using std::hypot;
using std::isfinite;
using std::log;
using std::sin;
using std::sinh;
using std::sqrt;
#endif

#define CB_PI ((CB_REAL)3.14159265358979323846)
#define CB_INV_PI ((CB_REAL)0.31830988618379067154)
#define CB_INV_2PI ((CB_REAL)0.15915494309189533577)
#define CB_INV_4PI ((CB_REAL)0.07957747154594766788)
#define CB_INFINITY 3.402823466e+38f
/* Unit roundoff of float arithmetic (also in the double build: its rays are spawned with the
 * float kernels' offsets, so that both trace the same paths), as in pbrt (Higham's gamma_n =
 * n*u/(1-n*u)). */
#define CB_MACHINE_EPSILON 5.960464477539063e-08f

CB_FN real cbGamma(int n) {
    return ((real)n * CB_MACHINE_EPSILON) / (1.0f - (real)n * CB_MACHINE_EPSILON);
}

CB_FN real cbClamp(real x, real lo, real hi) {
    return fmin(fmax(x, lo), hi);
}
/* pbrt-v4's Lerp: a at t = 0, b at t = 1. */
CB_FN real cbLerp(real t, real a, real b) {
    return (1.0f - t) * a + t * b;
}
CB_FN real cbSqr(real x) {
    return x * x;
}
CB_FN real cbSafeSqrt(real x) {
    return sqrt(fmax(x, 0.0f));
}

/* sin(pi x) and cos(pi x), for sampled angles given as fractions of pi: OpenCL's sinpi/cospi
 * reduce such an argument exactly, where sin and cos of radians run PoCL's general argument
 * reduction (3.6% of CPT's time on the dragon, docs/performance.md). The host rounds from
 * double. */
#ifdef CB_KERNEL_SIDE
CB_FN real cbSinPi(real x) {
    return sinpi(x);
}
CB_FN real cbCosPi(real x) {
    return cospi(x);
}
#else
CB_FN real cbSinPi(real x) {
    return (real)std::sin(3.14159265358979323846 * (double)x);
}
CB_FN real cbCosPi(real x) {
    return (real)std::cos(3.14159265358979323846 * (double)x);
}
#endif

/* Next representable value above / below v (pbrt-v4 NextFloatUp/Down). */
#ifdef CB_KERNEL_SIDE
CB_FN real cbNextFloatUp(real v) {
    if (v == CB_INFINITY) return v;
    if (v == -0.0f) v = 0.0f;
    uint ui = as_uint(v);
    if (v >= 0.0f)
        ++ui;
    else
        --ui;
    return as_float(ui);
}
CB_FN real cbNextFloatDown(real v) {
    if (v == -CB_INFINITY) return v;
    if (v == 0.0f) v = -0.0f;
    uint ui = as_uint(v);
    if (v > 0.0f)
        --ui;
    else
        ++ui;
    return as_float(ui);
}
#else
/* std::nextafter from +0 for -0, as the kernel side does; also correct for real = double. */
CB_FN real cbNextFloatUp(real v) {
    if (v == (real)CB_INFINITY) return v;
    return std::nextafter(v == 0 ? (real)0 : v, (real)INFINITY);
}
CB_FN real cbNextFloatDown(real v) {
    if (v == -(real)CB_INFINITY) return v;
    return std::nextafter(v == 0 ? -(real)0 : v, -(real)INFINITY);
}
#endif

/* The bits of v rounded to float: a hash key that is the same for the kernels' floats and the
 * host's double build. */
#ifdef CB_KERNEL_SIDE
CB_FN uint cbFloatBits(real v) {
    return as_uint((float)v);
}
#else
CB_FN uint cbFloatBits(real v) {
    const float f = (float)v;
    uint bits;
    std::memcpy(&bits, &f, sizeof bits);
    return bits;
}
#endif

/* ---- 3-vectors ---------------------------------------------------------------------------- */

typedef struct Vec3 {
    real x, y, z;
} Vec3;

CB_FN Vec3 vec3(real x, real y, real z) {
    Vec3 v;
    v.x = x;
    v.y = y;
    v.z = z;
    return v;
}
CB_FN Vec3 vec3FromArray(const real* a) {
    return vec3(a[0], a[1], a[2]);
}
CB_FN Vec3 vec3FromGlobalArray(CB_GLOBAL const real* a) {
    return vec3(a[0], a[1], a[2]);
}
CB_FN Vec3 vadd(Vec3 a, Vec3 b) {
    return vec3(a.x + b.x, a.y + b.y, a.z + b.z);
}
CB_FN Vec3 vsub(Vec3 a, Vec3 b) {
    return vec3(a.x - b.x, a.y - b.y, a.z - b.z);
}
CB_FN Vec3 vmul(Vec3 a, Vec3 b) {
    return vec3(a.x * b.x, a.y * b.y, a.z * b.z);
}
CB_FN Vec3 vscale(Vec3 a, real s) {
    return vec3(a.x * s, a.y * s, a.z * s);
}
CB_FN Vec3 vneg(Vec3 a) {
    return vec3(-a.x, -a.y, -a.z);
}
CB_FN Vec3 vabs(Vec3 a) {
    return vec3(fabs(a.x), fabs(a.y), fabs(a.z));
}
CB_FN Vec3 vmin(Vec3 a, Vec3 b) {
    return vec3(fmin(a.x, b.x), fmin(a.y, b.y), fmin(a.z, b.z));
}
CB_FN Vec3 vmax(Vec3 a, Vec3 b) {
    return vec3(fmax(a.x, b.x), fmax(a.y, b.y), fmax(a.z, b.z));
}
CB_FN real vdot(Vec3 a, Vec3 b) {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}
CB_FN real vabsdot(Vec3 a, Vec3 b) {
    return fabs(vdot(a, b));
}
CB_FN Vec3 vcross(Vec3 a, Vec3 b) {
    return vec3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
CB_FN real vlength2(Vec3 a) {
    return vdot(a, a);
}
CB_FN real vlength(Vec3 a) {
    return sqrt(vdot(a, a));
}
CB_FN Vec3 vnormalize(Vec3 a) {
    return vscale(a, 1.0f / vlength(a));
}
CB_FN real vmaxComponent(Vec3 a) {
    return fmax(a.x, fmax(a.y, a.z));
}
CB_FN real vcomponent(Vec3 a, int axis) {
    return axis == 0 ? a.x : (axis == 1 ? a.y : a.z);
}
/* Unit normal along cross(p1 - p0, p2 - p0). Its squared length overflows float for edges
 * above ~4e9 and underflows below ~1e-10, where the cross product itself holds from edges of
 * ~1e-19 to ~1e19: only then is it scaled to a largest component of 1 first (a branch almost
 * never taken). Not finite only for a float cross product of 0 (the host drops those). */
CB_FN Vec3 triangleNormal(Vec3 p0, Vec3 p1, Vec3 p2) {
    Vec3 n = vcross(vsub(p1, p0), vsub(p2, p0));
    real squared = vdot(n, n);
    if (!(squared > 1e-30f && squared < 1e30f)) {
        n = vscale(n, 1.0f / vmaxComponent(vabs(n)));
        squared = vdot(n, n);
    }
    return vscale(n, 1.0f / sqrt(squared));
}
/* a + b*s */
CB_FN Vec3 vmadd(Vec3 a, Vec3 b, real s) {
    return vec3(a.x + b.x * s, a.y + b.y * s, a.z + b.z * s);
}
/* Flip v to the hemisphere of `toward`. */
CB_FN Vec3 vfaceForward(Vec3 v, Vec3 toward) {
    return vdot(v, toward) < 0.0f ? vneg(v) : v;
}

/* Orthonormal frame around a unit normal, continuous in n (docs/method.md, coherence: neighbouring
 * pixels with similar normals must get similar directions).
 *
 * Duff et al. 2017 ("Building an Orthonormal Basis, Revisited") is continuous except across
 * the great circle n.z = 0 - exactly where the normals of floors, ceilings and side walls lie,
 * so rounding noise in n.z (or two triangles of one wall) would flip the frame and scatter
 * paths that should stay coherent. We apply Duff's construction in a fixed rotated basis whose
 * third axis g = (1, sqrt 2, sqrt 3)/sqrt 6 has no integer relation to the coordinate axes:
 * the discontinuity moves to dot(n, g) = 0, which no axis-aligned or 45-degree normal meets. */
CB_FN Vec3 frameRotateIn(Vec3 v) {
    return vec3(-0.816496581f * v.x + 0.577350269f * v.y,
                -0.408248290f * v.x - 0.577350269f * v.y + 0.707106781f * v.z,
                0.408248290f * v.x + 0.577350269f * v.y + 0.707106781f * v.z);
}
CB_FN Vec3 frameRotateOut(Vec3 v) {
    return vec3(-0.816496581f * v.x - 0.408248290f * v.y + 0.408248290f * v.z,
                0.577350269f * v.x - 0.577350269f * v.y + 0.577350269f * v.z,
                0.707106781f * v.y + 0.707106781f * v.z);
}

typedef struct Frame {
    Vec3 s, t, n;
} Frame;

CB_FN Frame frameFromNormal(Vec3 n) {
    Vec3 r = frameRotateIn(n);
    real sign = r.z >= 0.0f ? 1.0f : -1.0f;
    real a = -1.0f / (sign + r.z);
    real b = r.x * r.y * a;
    Frame f;
    f.s = frameRotateOut(vec3(1.0f + sign * r.x * r.x * a, sign * b, -sign * r.x));
    f.t = frameRotateOut(vec3(b, sign + r.y * r.y * a, -r.y));
    f.n = n;
    return f;
}
/* The frame about unit n whose first axis is t made perpendicular to n (pbrt-v4's BSDF frame,
 * Frame::FromXZ of the shading dp/du and ns); frameFromNormal(n) where t has no such part. */
CB_FN Frame frameFromNormalTangent(Vec3 n, Vec3 t) {
    Vec3 s = vsub(t, vscale(n, vdot(n, t)));
    real length2 = vlength2(s);
    if (!(length2 > 0.0f) || !isfinite(length2)) return frameFromNormal(n);
    Frame f;
    f.s = vscale(s, 1.0f / sqrt(length2));
    f.t = vcross(n, f.s);
    f.n = n;
    return f;
}
CB_FN Vec3 frameToLocal(Frame f, Vec3 v) {
    return vec3(vdot(v, f.s), vdot(v, f.t), vdot(v, f.n));
}
CB_FN Vec3 frameToWorld(Frame f, Vec3 v) {
    return vadd(vadd(vscale(f.s, v.x), vscale(f.t, v.y)), vscale(f.n, v.z));
}

CB_END_NAMESPACE

#endif /* CB_COMMON_H */
