/* cb_curve.h - pbrt-v4's curves: cubic Bezier pieces of a width that varies linearly along them,
 * hit as pbrt-v4's Curve hits them (pbrt-v4's shapes.cpp, Curve::IntersectRay; pbrt 3rd ed.
 * sec. 3.7). The ray is taken to a frame where it runs along +z from the origin; the piece is
 * subdivided in halves to a depth set by its flatness, boxes that miss the ray pruned, and
 * each leaf tested as a line of the width, the hit being the curve's point nearest the ray.
 * Every test in that frame is a dot product in its xy plane, so only the pruning boxes, never
 * a hit, depend on the frame's turn about the ray. */
#ifndef CB_CURVE_H
#define CB_CURVE_H

#include "cb_types.h"

CB_BEGIN_NAMESPACE

/* cp[0..3] as the cubic a + b s + c s^2 + d s^3 (power[0..3]), the one form in which the
 * kernels evaluate a piece: its nodes' control points, its leaves' points and dp/du. */
CB_FN void curvePowerBasis(const Vec3* cp, Vec3* power) {
    power[0] = cp[0];
    power[1] = vscale(vsub(cp[1], cp[0]), 3.0f);
    power[2] = vscale(vadd(vsub(cp[0], vscale(cp[1], 2.0f)), cp[2]), 3.0f);
    power[3] = vadd(vsub(vscale(vsub(cp[1], cp[2]), 3.0f), cp[0]), cp[3]);
}

/* The point at s of the cubic a + b s + c s^2 + d s^3 (power[0..3]) and its derivative. */
CB_FN Vec3 curvePower(const Vec3* power, real s, Vec3* deriv) {
    *deriv = vmadd(power[1], vmadd(vscale(power[2], 2.0f), power[3], 3.0f * s), s);
    return vmadd(power[0], vmadd(power[1], vmadd(power[2], power[3], s), s), s);
}

/* round(log2 v) as pbrt-v4's Log2Int(float) rounds it: the float's exponent, plus 1 where its
 * significand is at least sqrt(2)'s; v > 0. From the bits: a logarithm per curve test (or
 * PoCL's ilogb) took a tenth of a hair scene's time. */
CB_FN int curveRoundLog2(real v) {
    uint bits = cbFloatBits(v);
    int e = (int)((bits >> 23) & 255u) - 127;
    return (bits & 0x7fffffu) >= 0x3504f3u ? e + 1 : e;
}

/* The ribbon's normal at u: n[0] and n[1] interpolated spherically (pbrt-v4's Curve). */
CB_FN Vec3 curveRibbonNormal(CB_GLOBAL const CurveSegment* c, real u) {
    Vec3 n0 = vec3FromGlobalArray(c->n[0]);
    if (c->normalAngle == 0.0f) return n0;
    real s0 = sin((1.0f - u) * c->normalAngle) * c->invSinNormalAngle;
    real s1 = sin(u * c->normalAngle) * c->invSinNormalAngle;
    return vadd(vscale(n0, s0), vscale(vec3FromGlobalArray(c->n[1]), s1));
}

CB_FN real curveWidthAt(CB_GLOBAL const CurveSegment* c, real u) {
    return (1.0f - u) * c->width[0] + u * c->width[1];
}

/* The ray's frame: origin at ray.o, z along the ray, y across the piece's chord (pbrt-v4's
 * LookAt(o, o + d, cross(d, cp[3] - cp[0]))), so that the pruning boxes are narrow. */
typedef struct CurveRayFrame {
    Vec3 o, x, y, z;
} CurveRayFrame;

CB_FN CurveRayFrame curveRayFrame(Ray ray, Vec3 chord) {
    CurveRayFrame f;
    f.o = ray.o;
    f.z = vnormalize(ray.d);
    Vec3 up = vcross(ray.d, chord);
    if (!(vlength2(up) > 0.0f)) up = frameFromNormal(f.z).s;
    f.x = vnormalize(vcross(vnormalize(up), f.z));
    f.y = vcross(f.z, f.x);
    return f;
}

CB_FN Vec3 curveToRay(CurveRayFrame f, Vec3 p) {
    Vec3 q = vsub(p, f.o);
    return vec3(vdot(q, f.x), vdot(q, f.y), vdot(q, f.z));
}

/* Whether the box of cp[0..3] grown by half of maxWidth meets the ray's segment [0, zMax] on
 * the z axis (pbrt-v4's Overlaps of the two boxes). */
CB_FN bool curveBoxMeetsRay(const Vec3* cp, real maxWidth, real zMax) {
    Vec3 lo = vmin(vmin(cp[0], cp[1]), vmin(cp[2], cp[3]));
    Vec3 hi = vmax(vmax(cp[0], cp[1]), vmax(cp[2], cp[3]));
    real r = 0.5f * maxWidth;
    return lo.x - r <= 0.0f && hi.x + r >= 0.0f && lo.y - r <= 0.0f && hi.y + r >= 0.0f &&
           lo.z - r <= zMax && hi.z + r >= 0.0f;
}

/* Hits the piece c with t in (0, tMax): hit->t, and the curve's (u, v) at the hit in hit->b1,
 * hit->b2 (v across the width, 1/2 on the curve; as pbrt-v4 finds it in object space). With
 * !closestHit the first hit found returns. */
CB_FN bool intersectCurve(CB_GLOBAL const CurveSegment* c, Ray ray, real tMax, bool closestHit,
                          Hit* hit) {
    Vec3 world[4];
    for (int i = 0; i < 4; ++i)
        world[i] = vec3FromGlobalArray(c->cp[i]);
    CurveRayFrame f = curveRayFrame(ray, vsub(world[3], world[0]));
    Vec3 cp[4];
    for (int i = 0; i < 4; ++i)
        cp[i] = curveToRay(f, world[i]);
    Vec3 power[4];
    curvePowerBasis(cp, power);
    real rayLength = vlength(ray.d);
    real zMax = rayLength * tMax;
    /* Subdivision depth (pbrt-v4): pieces flat to within a twentieth of the width. */
    real l0 = 0.0f;
    for (int i = 0; i < 2; ++i) {
        Vec3 second = vabs(vadd(vsub(cp[i], vscale(cp[i + 1], 2.0f)), cp[i + 2]));
        l0 = fmax(l0, vmaxComponent(second));
    }
    int maxDepth = 0;
    if (l0 > 0.0f) {
        real eps = fmax(c->width[0], c->width[1]) * 0.05f;
        int r0 = curveRoundLog2(1.41421356237f * 6.0f * l0 / (8.0f * eps)) / 2;
        maxDepth = r0 < 0 ? 0 : (r0 > 10 ? 10 : r0);
    }
    real uMin = c->uMin, uSpan = c->uMax - c->uMin;
    bool found = false;
    real bestT = tMax;
    /* pbrt-v4's recursion as a walk over the subdivision tree, node (level, index) covering
     * s in [index, index + 1] / 2^level of the piece, depth first, first half first. */
    int level = 0;
    uint index = 0u;
    for (;;) {
        real scale = 1.0f / (real)(1u << level);
        real s0 = (real)index * scale, s1 = (real)(index + 1u) * scale;
        /* The node's control points from the piece's power basis: its ends and, a third of
         * the span along the tangents, the inner two (cheaper than four blossoms). */
        Vec3 node[4];
        Vec3 d0, d1;
        node[0] = curvePower(power, s0, &d0);
        node[3] = curvePower(power, s1, &d1);
        node[1] = vmadd(node[0], d0, scale * (1.0f / 3.0f));
        node[2] = vmadd(node[3], d1, -scale * (1.0f / 3.0f));
        real u0 = uMin + s0 * uSpan, u1 = uMin + s1 * uSpan;
        real maxWidth = fmax(curveWidthAt(c, u0), curveWidthAt(c, u1));
        if (curveBoxMeetsRay(node, maxWidth, zMax)) {
            if (level < maxDepth) {
                ++level;
                index *= 2u;
                continue;
            }
            /* The leaf as a line: the ray must pass between the perpendiculars to the tangents
             * at its ends, then within half the width of the curve's point nearest it. */
            bool inside =
                (node[1].y - node[0].y) * -node[0].y + node[0].x * (node[0].x - node[1].x) >=
                    0.0f &&
                (node[2].y - node[3].y) * -node[3].y + node[3].x * (node[3].x - node[2].x) >= 0.0f;
            real dx = node[3].x - node[0].x, dy = node[3].y - node[0].y;
            real denom = dx * dx + dy * dy;
            if (inside && denom != 0.0f) {
                real w = (-node[0].x * dx - node[0].y * dy) / denom;
                real u = fmin(fmax(u0 + w * (u1 - u0), u0), u1);
                real hitWidth = curveWidthAt(c, u);
                if (c->type == CB_CURVE_RIBBON)
                    hitWidth *= vabsdot(curveRibbonNormal(c, u), ray.d) / rayLength;
                /* The node's point at w (its tangent's direction is all the side needs). */
                Vec3 dpc;
                Vec3 pc = curvePower(power, s0 + fmin(fmax(w, 0.0f), 1.0f) * scale, &dpc);
                real dist2 = pc.x * pc.x + pc.y * pc.y;
                real t = pc.z / rayLength;
                if (dist2 <= hitWidth * hitWidth * 0.25f && pc.z >= 0.0f && pc.z <= zMax &&
                    t > 0.0f && t < tMax && !(found && t > bestT)) {
                    if (!closestHit) return true;
                    real dist = sqrt(dist2);
                    real edge = dpc.x * -pc.y + pc.x * dpc.y;
                    real v = edge > 0.0f ? 0.5f + dist / hitWidth : 0.5f - dist / hitWidth;
                    found = true;
                    bestT = t;
                    hit->t = t;
                    hit->b1 = u;
                    hit->b2 = c->mirrored ? 1.0f - v : v;
                }
            }
        }
        while ((index & 1u) != 0u) {
            index >>= 1;
            --level;
        }
        if (level == 0) break;
        ++index;
    }
    return found;
}

/* The geometry at a hit of intersectCurve (pbrt-v4's SurfaceInteraction of a curve): the point
 * on the ray, dp/du along the curve, the normal cross(dp/du, dp/dv), which faces the ray (flat),
 * is the ribbon's, or turns across the width by v as a cylinder's would (from -90 to 90
 * degrees), and the width there, which is pbrt-v4's error bound of the point. */
CB_FN void curveSurface(CB_GLOBAL const CurveSegment* c, Ray ray, Hit hit, Vec3* p, Vec3* ng,
                        Vec3* dpdu, real* hitWidth) {
    real u = hit.b1, v = c->mirrored ? 1.0f - hit.b2 : hit.b2;
    Vec3 cp[4], power[4];
    for (int i = 0; i < 4; ++i)
        cp[i] = vec3FromGlobalArray(c->cp[i]);
    curvePowerBasis(cp, power);
    real span = c->uMax - c->uMin;
    Vec3 deriv;
    curvePower(power, span > 0.0f ? (u - c->uMin) / span : 0.0f, &deriv);
    /* pbrt-v4's EvaluateCubicBezier: the chord where the derivative vanishes. */
    if (!(vlength2(deriv) > 0.0f)) deriv = vsub(cp[3], cp[0]);
    *dpdu = deriv;
    *p = vmadd(ray.o, ray.d, hit.t);
    real width = curveWidthAt(c, u);
    Vec3 dpdv;
    if (c->type == CB_CURVE_RIBBON) {
        Vec3 n = curveRibbonNormal(c, u);
        width *= vabsdot(n, ray.d) / vlength(ray.d);
        dpdv = vnormalize(vcross(n, deriv));
    } else {
        /* Across the curve in the plane that faces the ray. */
        dpdv = vnormalize(vcross(ray.d, deriv));
        if (c->type == CB_CURVE_CYLINDER) {
            real theta = CB_PI * (v - 0.5f);
            Vec3 axis = vnormalize(deriv);
            dpdv = vsub(vscale(dpdv, cos(theta)), vscale(vcross(axis, dpdv), sin(theta)));
        }
    }
    /* A mirroring CTM turns object space's dp/dv to the opposite of the one found here. */
    if (c->mirrored) dpdv = vneg(dpdv);
    Vec3 n = vnormalize(vcross(deriv, dpdv));
    *ng = c->reverse ? vneg(n) : n;
    *hitWidth = width;
}

CB_END_NAMESPACE

#endif /* CB_CURVE_H */
