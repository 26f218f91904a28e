/* cb_filter.h - pbrt-v4's pixel filters "box", "triangle" and "gaussian" (its filters.h). Pixel
 * (x, y) measures the radiance weighted by h(p) = f(p - c) / (integral of f) around its centre
 * c = (x + 1/2, y + 1/2), f(dx, dy) = f1(dx) f1(dy) zero beyond the radii. Eye paths draw their
 * raster position from h itself (filter importance sampling by the inverse of its distribution
 * function, so every sample weighs 1); light-tracing splats at raster point p add h(p) of their
 * value to every pixel that p reaches (pbrt-v4's RGBFilm::AddSplat over the filter's integral).
 * The box of radius 0.5 is one pixel's area: the code without CB_FEATURE_PIXEL_FILTER. */
#ifndef CB_FILTER_H
#define CB_FILTER_H

#include "cb_types.h"

CB_BEGIN_NAMESPACE

/* The gaussian's f1 is pbrt-v4's, g(x) - g(r) for g(x) = exp(-x^2 / (2 sigma^2)) (pbrt-v4's
 * normalisation of g cancels in h): its constants for one radius and sigma. */
typedef struct GaussianFilter1 {
    real k;     /* -1 / (2 sigma^2) */
    real tail;  /* g(r) */
    real scale; /* sqrt(pi / 2) sigma: g's integral over [0, x] is scale erf(x toErf) */
    real toErf; /* 1 / (sqrt(2) sigma) */
} GaussianFilter1;

CB_FN GaussianFilter1 gaussianFilter1(real radius, real sigma) {
    GaussianFilter1 g;
    g.k = -0.5f / (sigma * sigma);
    g.tail = exp(g.k * radius * radius);
    g.scale = sigma * 1.2533141373155003f;
    g.toErf = 0.70710678118654752f / sigma;
    return g;
}

/* erf(z) for z >= 0 given exp(-z^2), within 1.5e-7 (Abramowitz and Stegun 1964, 7.1.26): the
 * sampling's Newton steps need exp(-z^2) = g(x) anyway, and OpenCL's erf costs several times
 * more on the CPU (pixel sampling under the gaussian took half again PT's time with it). */
CB_FN real erfGivenExp(real z, real expMinusZ2) {
    const real t = 1.0f / (1.0f + 0.3275911f * z);
    const real poly =
        t * (0.254829592f +
             t * (-0.284496736f + t * (1.421413741f + t * (-1.453152027f + t * 1.061405429f))));
    return 1.0f - poly * expMinusZ2;
}

/* g(x), then f1 at |x| = a < r, and the integral of f1 over [0, x] for 0 <= x <= r given
 * gx = g(x). Both lose precision as sigma grows past r (g(x) - g(r) cancels; the filter tends
 * to a parabola): filterSample1's distribution function is within 1e-6 of exact for sigma <= r
 * (4e-7 at pbrt-v4's 0.5 and 1.5), 7e-6 at sigma = 2 r, 2.5e-4 at 7 r. */
CB_FN real gaussianG(const GaussianFilter1* g, real x) {
    return exp(g->k * x * x);
}
CB_FN real gaussianEval1(const GaussianFilter1* g, real a) {
    return gaussianG(g, a) - g->tail;
}
CB_FN real gaussianHalfIntegral1(const GaussianFilter1* g, real x, real gx) {
    return g->scale * erfGivenExp(x * g->toErf, gx) - x * g->tail;
}

/* f1 at offset x from a pixel centre, radius r, the gaussian's constants given (unread for the
 * box and the triangle). The box takes [-r, r). */
CB_FN real filterEval1(int type, real radius, const GaussianFilter1* g, real x) {
    if (type == CB_FILTER_BOX) return x >= -radius && x < radius ? 1.0f : 0.0f;
    const real a = fabs(x);
    if (!(a < radius)) return 0.0f;
    if (type == CB_FILTER_TRIANGLE) return radius - a;
    return gaussianEval1(g, a);
}

/* The integral of f1 over [0, x], 0 <= x <= r. */
CB_FN real filterHalfIntegral1(int type, real radius, real sigma, real x) {
    if (type == CB_FILTER_BOX) return x;
    if (type == CB_FILTER_TRIANGLE) return x * (radius - 0.5f * x);
    const GaussianFilter1 g = gaussianFilter1(radius, sigma);
    return gaussianHalfIntegral1(&g, x, gaussianG(&g, x));
}

/* An offset in (-r, r) with density f1 / (its integral), from u in [0, 1): the inverse of the
 * distribution function, |offset| the root of filterHalfIntegral1(|offset|) = |2u - 1| times
 * the half integral. The triangle's is closed-form. The gaussian's is found by Newton's method:
 * the half integral H is concave (f1 falls with |x|), so from below the root every step lands
 * below it again and climbs to it without overshooting, and a start above it is brought below
 * by one step (the tangent lies above H). The start inverts the logistic approximation of the
 * normal distribution function, Phi(z) ~ 1 / (1 + exp(-1.702 z)) (truncation and offset
 * ignored), from which about two steps reach float precision. */
CB_FN real filterSample1(int type, real radius, real sigma, real u) {
    const real v = 2.0f * u - 1.0f;
    const real share = fabs(v);
    real x;
    if (type == CB_FILTER_BOX) {
        x = share * radius;
    } else if (type == CB_FILTER_TRIANGLE) {
        x = radius * (1.0f - sqrt(1.0f - share));
    } else {
        const GaussianFilter1 g = gaussianFilter1(radius, sigma);
        const real erfRadius = erfGivenExp(radius * g.toErf, g.tail);
        const real target = share * (g.scale * erfRadius - radius * g.tail);
        const real phi = 0.5f + 0.5f * share * erfRadius; /* Phi(x / sigma), untruncated */
        x = fmin(sigma * (1.0f / 1.702f) * log(phi / (1.0f - phi)), radius);
        real gx = gaussianG(&g, x);
        real h = gaussianHalfIntegral1(&g, x, gx);
        if (h > target) {
            const real fx = gx - g.tail;
            x = fx > 0.0f ? fmax(x - (h - target) / fx, 0.0f) : 0.0f;
            gx = gaussianG(&g, x);
            h = gaussianHalfIntegral1(&g, x, gx);
        }
        for (int i = 0; i < 32; ++i) {
            const real fx = gx - g.tail;
            if (!(fx > 0.0f)) break;
            const real step = (target - h) / fx;
            if (!(step > 1e-7f * radius)) break; /* converged (or rounding turned the sign) */
            x += step;
            gx = gaussianG(&g, x);
            h = gaussianHalfIntegral1(&g, x, gx);
        }
        x = fmin(x, radius);
    }
    return copysign(x, v);
}

/* The filter's radii, (0.5, 0.5) without CB_FEATURE_PIXEL_FILTER. */
CB_FN void filterRadii(const Camera* camera, real* radiusX, real* radiusY) {
#if CB_HAS(CB_FEATURE_PIXEL_FILTER)
    *radiusX = camera->filterRadiusX;
    *radiusY = camera->filterRadiusY;
#else
    (void)camera;
    *radiusX = 0.5f;
    *radiusY = 0.5f;
#endif
}

/* The raster position of pixel `pixel`'s sample on one axis, drawn from its filter by u. The box
 * keeps the pixel corner plus (0.5 - r) + 2 r u, which is pixel + u for radius 0.5. */
CB_FN real filterPixelSample(const Camera* camera, int axis, int pixel, real u) {
#if CB_HAS(CB_FEATURE_PIXEL_FILTER)
    const real radius = axis == 0 ? camera->filterRadiusX : camera->filterRadiusY;
    if (camera->filterType != CB_FILTER_BOX)
        return ((real)pixel + 0.5f) +
               filterSample1(camera->filterType, radius, camera->filterSigma, u);
    return (real)pixel + ((0.5f - radius) + 2.0f * radius * u);
#else
    (void)camera;
    (void)axis;
    return (real)pixel + u;
#endif
}

/* Whether the filter of some pixel reaches raster point (rx, ry): both coordinates within
 * [0.5 - r, size - 0.5 + r), the image [0, size) for the box of radius 0.5. */
CB_FN bool filterReaches(const Camera* camera, real rx, real ry) {
    real radiusX, radiusY;
    filterRadii(camera, &radiusX, &radiusY);
    return rx >= 0.5f - radiusX && rx < (real)camera->width - 0.5f + radiusX &&
           ry >= 0.5f - radiusY && ry < (real)camera->height - 0.5f + radiusY;
}

/* The pixels a splat at raster point (rx, ry) reaches: x in [*x0, *x1], y in [*y0, *y1] (empty
 * when x0 > x1), within the image. Pixel x's filter holds p when c - r <= p < c + r, so the box
 * of radius 0.5 gives pixel floor(p) alone. */
CB_FN void filterFootprint(const Camera* camera, real rx, real ry, int* x0, int* x1, int* y0,
                           int* y1) {
    real radiusX, radiusY;
    filterRadii(camera, &radiusX, &radiusY);
    const int left = (int)floor(rx - (0.5f + radiusX)) + 1;
    const int right = (int)floor(rx + (radiusX - 0.5f));
    const int top = (int)floor(ry - (0.5f + radiusY)) + 1;
    const int bottom = (int)floor(ry + (radiusY - 0.5f));
    *x0 = left > 0 ? left : 0;
    *x1 = right < camera->width - 1 ? right : camera->width - 1;
    *y0 = top > 0 ? top : 0;
    *y1 = bottom < camera->height - 1 ? bottom : camera->height - 1;
}

/* 1 / the integral of f over the plane: pbrt-v4's Filter::Integral, inverted. */
CB_FN real filterNormalization(int type, real radiusX, real radiusY, real sigma) {
    return 1.0f / (4.0f * filterHalfIntegral1(type, radiusX, sigma, radiusX) *
                   filterHalfIntegral1(type, radiusY, sigma, radiusY));
}

/* A splat at raster point (rx, ry): the pixels it reaches, x in [x0, x1] and y in [y0, y1]
 * (filterFootprint), and the gaussian's constants on each axis, so that its pixels' weights
 * cost one f1 per row (filterSplatRow, the normalisation included) and one per pixel
 * (filterSplatColumn). Pixel (x, y)'s share h is their product, 1 for the box of radius 0.5. */
typedef struct FilterSplat {
    int x0, x1, y0, y1;
    real rx, ry;
    GaussianFilter1 gaussianX, gaussianY;
} FilterSplat;

CB_FN FilterSplat filterSplatAt(const Camera* camera, real rx, real ry) {
    FilterSplat s;
    filterFootprint(camera, rx, ry, &s.x0, &s.x1, &s.y0, &s.y1);
    s.rx = rx;
    s.ry = ry;
    s.gaussianX.k = s.gaussianX.tail = s.gaussianX.scale = s.gaussianX.toErf = 0.0f;
    s.gaussianY = s.gaussianX;
#if CB_HAS(CB_FEATURE_PIXEL_FILTER)
    if (camera->filterType == CB_FILTER_GAUSSIAN) {
        s.gaussianX = gaussianFilter1(camera->filterRadiusX, camera->filterSigma);
        s.gaussianY = gaussianFilter1(camera->filterRadiusY, camera->filterSigma);
    }
#endif
    return s;
}

CB_FN real filterSplatRow(const Camera* camera, const FilterSplat* s, int y) {
#if CB_HAS(CB_FEATURE_PIXEL_FILTER)
    return filterEval1(camera->filterType, camera->filterRadiusY, &s->gaussianY,
                       s->ry - ((real)y + 0.5f)) *
           camera->filterNormalization;
#else
    (void)camera;
    (void)s;
    (void)y;
    return 1.0f;
#endif
}

CB_FN real filterSplatColumn(const Camera* camera, const FilterSplat* s, int x) {
#if CB_HAS(CB_FEATURE_PIXEL_FILTER)
    return filterEval1(camera->filterType, camera->filterRadiusX, &s->gaussianX,
                       s->rx - ((real)x + 0.5f));
#else
    (void)camera;
    (void)s;
    (void)x;
    return 1.0f;
#endif
}

/* Pixel (x, y)'s share h of a splat at raster point (rx, ry) alone. */
CB_FN real filterSplatWeight(const Camera* camera, int x, int y, real rx, real ry) {
    const FilterSplat s = filterSplatAt(camera, rx, ry);
    return filterSplatRow(camera, &s, y) * filterSplatColumn(camera, &s, x);
}

CB_END_NAMESPACE

#endif /* CB_FILTER_H */
