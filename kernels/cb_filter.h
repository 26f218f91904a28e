/* cb_filter.h - pbrt-v4's pixel filters "box", "triangle", "gaussian", "mitchell" and "sinc"
 * (its filters.h). Pixel (x, y) measures the radiance weighted by h(p) = f(p - c) / (integral of
 * f) around its centre c = (x + 1/2, y + 1/2), f(dx, dy) = f1(dx) f1(dy) zero beyond the radii.
 * Eye paths draw their raster position from h itself where h >= 0 (filter importance sampling by
 * the inverse of its distribution function, so every sample weighs 1). Mitchell's and the
 * Lanczos sinc's h has negative lobes: their offsets are drawn from a piecewise-constant density
 * proportional to |f1| per bin (filterTableSample1) and weigh h / that density, negative in the
 * lobes, so each pixel's mean is still an unbiased estimate of the filtered radiance (pbrt-v4
 * draws from its tabulated filter too, but divides each pixel's weighted sum by its weights' sum).
 * Light-tracing splats at raster point p add h(p) of their value to every pixel that p reaches
 * (pbrt-v4's RGBFilm::AddSplat over the filter's integral). The box of radius 0.5 is one pixel's
 * area: the code without CB_FEATURE_PIXEL_FILTER. */
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

/* Mitchell and Netravali's cubic at t in [0, 2] (pbrt-v4's MitchellFilter::Mitchell1D): f1(x)
 * is it at t = 2 |x| / r, and its integral over [-2, 2] is 1 for every B and C. */
CB_FN real mitchell1(real b, real c, real t) {
    if (t <= 1.0f)
        return ((12.0f - 9.0f * b - 6.0f * c) * t * t * t +
                (-18.0f + 12.0f * b + 6.0f * c) * t * t + (6.0f - 2.0f * b)) *
               (1.0f / 6.0f);
    return ((-b - 6.0f * c) * t * t * t + (6.0f * b + 30.0f * c) * t * t +
            (-12.0f * b - 48.0f * c) * t + (8.0f * b + 24.0f * c)) *
           (1.0f / 6.0f);
}

/* sin(pi x) / (pi x), 1 where that rounds to 1 (pbrt-v4's Sinc). */
CB_FN real sincPi(real x) {
    const real px = CB_PI * x;
    return 1.0f - px * px == 1.0f ? 1.0f : sin(px) / px;
}

/* One axis's filter f1: its type, radius and the constants its evaluation needs (the gaussian's,
 * Mitchell's B and C, the Lanczos window's tau; each read by its own type only). */
typedef struct FilterAxis {
    int type;
    real radius;
    GaussianFilter1 gaussian;
    real mitchellB, mitchellC;
    real sincTau;
} FilterAxis;

/* f1 at offset x from a pixel centre. The box takes [-r, r), the others (-r, r). */
CB_FN real filterEval1(const FilterAxis* f, real x) {
    const real radius = f->radius;
    if (f->type == CB_FILTER_BOX) return x >= -radius && x < radius ? 1.0f : 0.0f;
    const real a = fabs(x);
    if (!(a < radius)) return 0.0f;
    if (f->type == CB_FILTER_TRIANGLE) return radius - a;
    if (f->type == CB_FILTER_MITCHELL)
        return mitchell1(f->mitchellB, f->mitchellC, 2.0f * a / radius);
    /* pbrt-v4's WindowedSinc: the window sinc(x / tau) does not scale with the radius. */
    if (f->type == CB_FILTER_SINC) return sincPi(a) * sincPi(a / f->sincTau);
    return gaussianEval1(&f->gaussian, a);
}

/* Whether the filter's samples come from a table of |f1| and weigh h / their density. */
CB_FN bool filterHasNegativeLobes(int type) {
    return type == CB_FILTER_MITCHELL || type == CB_FILTER_SINC;
}

/* The integral of f1 over [0, x], 0 <= x <= r, for the box, the triangle and the gaussian. */
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

#if CB_HAS(CB_FEATURE_PIXEL_FILTER)
/* The camera's filter on one axis (0: x, 1: y). */
CB_FN FilterAxis filterAxisOf(const Camera* camera, int axis) {
    FilterAxis f;
    f.type = camera->filterType;
    f.radius = axis == 0 ? camera->filterRadiusX : camera->filterRadiusY;
    f.gaussian.k = f.gaussian.tail = f.gaussian.scale = f.gaussian.toErf = 0.0f;
    if (f.type == CB_FILTER_GAUSSIAN) f.gaussian = gaussianFilter1(f.radius, camera->filterSigma);
    f.mitchellB = camera->filterMitchellB;
    f.mitchellC = camera->filterMitchellC;
    f.sincTau = camera->filterSincTau;
    return f;
}

/* An offset in (-r, r) for a filter with negative lobes, drawn by u: |2u - 1| picks a bin of
 * [0, r) by the table's shares of |f1| (Camera.filterAbsCdf) and a uniform point in it, the sign
 * of 2u - 1 the side. Its weight h / density, f1(x) (r / bins) / (the integral of f1 over [0, r]
 * times the bin's share), goes to *weight: |weight| is about the integral of |f1| over that of
 * f1, and its sign f1's. */
CB_FN real filterTableSample1(const Camera* camera, int axis, real u, real* weight) {
    const real v = 2.0f * u - 1.0f;
    const real share = fabs(v);
    int lo = 0, hi = CB_FILTER_TABLE_BINS - 1; /* the last bin whose start is <= share */
    while (lo < hi) {
        const int mid = (lo + hi + 1) / 2;
        if (camera->filterAbsCdf[axis][mid] <= share)
            lo = mid;
        else
            hi = mid - 1;
    }
    const real below = camera->filterAbsCdf[axis][lo];
    const real binShare = camera->filterAbsCdf[axis][lo + 1] - below;
    const FilterAxis f = filterAxisOf(camera, axis);
    const real within = binShare > 0.0f ? fmin((share - below) / binShare, 1.0f) : 0.0f;
    const real x = ((real)lo + within) * (f.radius / (real)CB_FILTER_TABLE_BINS);
    *weight =
        binShare > 0.0f ? filterEval1(&f, x) * camera->filterSampleScale[axis] / binShare : 0.0f;
    return copysign(x, v);
}
#endif

/* The raster position of pixel `pixel`'s sample on one axis, drawn from its filter by u, and its
 * weight on that axis in *weight: 1 but for filters with negative lobes (filterTableSample1).
 * The box keeps the pixel corner plus (0.5 - r) + 2 r u, which is pixel + u for radius 0.5. */
CB_FN real filterPixelSample(const Camera* camera, int axis, int pixel, real u, real* weight) {
    *weight = 1.0f;
#if CB_HAS(CB_FEATURE_PIXEL_FILTER)
    const real radius = axis == 0 ? camera->filterRadiusX : camera->filterRadiusY;
    if (filterHasNegativeLobes(camera->filterType))
        return ((real)pixel + 0.5f) + filterTableSample1(camera, axis, u, weight);
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

/* 1 / the integral of f over the plane: pbrt-v4's Filter::Integral, inverted, for the filters
 * sampled exactly (the host integrates those with negative lobes, tabulateLobedFilter). */
CB_FN real filterNormalization(int type, real radiusX, real radiusY, real sigma) {
    return 1.0f / (4.0f * filterHalfIntegral1(type, radiusX, sigma, radiusX) *
                   filterHalfIntegral1(type, radiusY, sigma, radiusY));
}

/* A splat at raster point (rx, ry): the pixels it reaches, x in [x0, x1] and y in [y0, y1]
 * (filterFootprint), and the filter on each axis, so that its pixels' weights cost one f1 per
 * row (filterSplatRow, the normalisation included) and one per pixel (filterSplatColumn). Pixel
 * (x, y)'s share h is their product, 1 for the box of radius 0.5. */
typedef struct FilterSplat {
    int x0, x1, y0, y1;
    real rx, ry;
#if CB_HAS(CB_FEATURE_PIXEL_FILTER)
    FilterAxis axisX, axisY;
#endif
} FilterSplat;

CB_FN FilterSplat filterSplatAt(const Camera* camera, real rx, real ry) {
    FilterSplat s;
    filterFootprint(camera, rx, ry, &s.x0, &s.x1, &s.y0, &s.y1);
    s.rx = rx;
    s.ry = ry;
#if CB_HAS(CB_FEATURE_PIXEL_FILTER)
    s.axisX = filterAxisOf(camera, 0);
    s.axisY = filterAxisOf(camera, 1);
#endif
    return s;
}

CB_FN real filterSplatRow(const Camera* camera, const FilterSplat* s, int y) {
#if CB_HAS(CB_FEATURE_PIXEL_FILTER)
    return filterEval1(&s->axisY, s->ry - ((real)y + 0.5f)) * camera->filterNormalization;
#else
    (void)camera;
    (void)s;
    (void)y;
    return 1.0f;
#endif
}

CB_FN real filterSplatColumn(const Camera* camera, const FilterSplat* s, int x) {
#if CB_HAS(CB_FEATURE_PIXEL_FILTER)
    (void)camera;
    return filterEval1(&s->axisX, s->rx - ((real)x + 0.5f));
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
