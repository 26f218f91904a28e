// 4x4 transforms in double precision with pbrt-v4's conventions (row-major storage, column
// vectors: p' = M p). Used by the scene parser to build the current transformation matrix;
// double precision keeps long chains of Rotate/Scale from drifting before geometry is
// rounded to float.
#pragma once

#include <array>
#include <cmath>
#include <optional>
#include <utility>

namespace cb {

// 3-vectors of the scene description (double precision, as std::array).
using Vec3d = std::array<double, 3>;
inline Vec3d vecSub(const Vec3d& a, const Vec3d& b) {
    return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}
inline Vec3d vecAdd(const Vec3d& a, const Vec3d& b) {
    return {a[0] + b[0], a[1] + b[1], a[2] + b[2]};
}
inline Vec3d vecCross(const Vec3d& a, const Vec3d& b) {
    return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
inline double vecDot(const Vec3d& a, const Vec3d& b) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

struct Mat4 {
    std::array<double, 16> m{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};

    double operator()(int row, int col) const { return m[row * 4 + col]; }
    double& operator()(int row, int col) { return m[row * 4 + col]; }

    static Mat4 identity() { return Mat4{}; }

    friend Mat4 operator*(const Mat4& a, const Mat4& b) {
        Mat4 r;
        for (int i = 0; i < 4; ++i)
            for (int j = 0; j < 4; ++j) {
                double s = 0.0;
                for (int k = 0; k < 4; ++k)
                    s += a(i, k) * b(k, j);
                r(i, j) = s;
            }
        return r;
    }

    Mat4 transposed() const {
        Mat4 r;
        for (int i = 0; i < 4; ++i)
            for (int j = 0; j < 4; ++j)
                r(i, j) = (*this)(j, i);
        return r;
    }

    // True when the bottom row is exactly (0 0 0 1): products of affine matrices keep it exact.
    bool isAffine() const { return m[12] == 0.0 && m[13] == 0.0 && m[14] == 0.0 && m[15] == 1.0; }

    // Affine point transform (the caller checks isAffine()).
    std::array<double, 3> point(const std::array<double, 3>& p) const {
        std::array<double, 3> r{};
        for (int i = 0; i < 3; ++i)
            r[i] = m[i * 4] * p[0] + m[i * 4 + 1] * p[1] + m[i * 4 + 2] * p[2] + m[i * 4 + 3];
        return r;
    }

    // Determinant of the upper-left 3x3 block; negative means the transform swaps handedness.
    double det3() const {
        return m[0] * (m[5] * m[10] - m[6] * m[9]) - m[1] * (m[4] * m[10] - m[6] * m[8]) +
               m[2] * (m[4] * m[9] - m[5] * m[8]);
    }

    // Normals transform by the inverse transpose of the 3x3 block. The cofactor matrix equals
    // det * inverse-transpose, so dividing by det gives the exact normal transform (pbrt-v4's
    // Transform::operator()(Normal3f)).
    std::array<double, 3> normal(const std::array<double, 3>& n) const {
        const double c00 = m[5] * m[10] - m[6] * m[9], c01 = m[6] * m[8] - m[4] * m[10],
                     c02 = m[4] * m[9] - m[5] * m[8];
        const double c10 = m[2] * m[9] - m[1] * m[10], c11 = m[0] * m[10] - m[2] * m[8],
                     c12 = m[1] * m[8] - m[0] * m[9];
        const double c20 = m[1] * m[6] - m[2] * m[5], c21 = m[2] * m[4] - m[0] * m[6],
                     c22 = m[0] * m[5] - m[1] * m[4];
        const double d = det3();
        return {(c00 * n[0] + c01 * n[1] + c02 * n[2]) / d,
                (c10 * n[0] + c11 * n[1] + c12 * n[2]) / d,
                (c20 * n[0] + c21 * n[1] + c22 * n[2]) / d};
    }
};

inline Mat4 translateMatrix(double x, double y, double z) {
    Mat4 r;
    r(0, 3) = x;
    r(1, 3) = y;
    r(2, 3) = z;
    return r;
}

inline Mat4 scaleMatrix(double x, double y, double z) {
    Mat4 r;
    r(0, 0) = x;
    r(1, 1) = y;
    r(2, 2) = z;
    return r;
}

// Rotation by `degrees` about `axis` (normalised here), right-handed in the sense of
// Rodrigues' formula R = cos I + sin [a]x + (1 - cos) a a^T, as pbrt-v4's Rotate().
// Empty when the axis has zero length.
inline std::optional<Mat4> rotateMatrix(double degrees, double ax, double ay, double az) {
    const double len = std::sqrt(ax * ax + ay * ay + az * az);
    if (!(len > 0.0) || !std::isfinite(len)) return std::nullopt;
    ax /= len;
    ay /= len;
    az /= len;
    const double theta = degrees * (3.14159265358979323846 / 180.0);
    const double s = std::sin(theta), c = std::cos(theta);
    Mat4 r;
    r(0, 0) = ax * ax + (1 - ax * ax) * c;
    r(0, 1) = ax * ay * (1 - c) - az * s;
    r(0, 2) = ax * az * (1 - c) + ay * s;
    r(1, 0) = ax * ay * (1 - c) + az * s;
    r(1, 1) = ay * ay + (1 - ay * ay) * c;
    r(1, 2) = ay * az * (1 - c) - ax * s;
    r(2, 0) = ax * az * (1 - c) - ay * s;
    r(2, 1) = ay * az * (1 - c) + ax * s;
    r(2, 2) = az * az + (1 - az * az) * c;
    return r;
}

// pbrt-v4's LookAt(): the camera-from-world matrix of a camera at `eye` looking at `look`.
// Camera space is left-handed: +z towards `look`, +y up, +x = normalize(up) x dir. The
// world-from-camera matrix has orthonormal columns (right, newUp, dir, eye), so its inverse is
// written directly (transpose of the rotation) rather than by general inversion. Empty when
// eye == look or up is parallel to the viewing direction.
inline std::optional<Mat4> lookAtMatrix(const std::array<double, 3>& eye,
                                        const std::array<double, 3>& look,
                                        const std::array<double, 3>& up) {
    auto normalize = [](std::array<double, 3> a) -> std::optional<std::array<double, 3>> {
        const double l = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
        if (!(l > 0.0) || !std::isfinite(l)) return std::nullopt;
        return std::array<double, 3>{a[0] / l, a[1] / l, a[2] / l};
    };
    const auto dir = normalize(vecSub(look, eye));
    const auto upN = normalize(up);
    if (!dir || !upN) return std::nullopt;
    const auto right = normalize(vecCross(*upN, *dir));
    if (!right) return std::nullopt;
    const auto newUp = vecCross(*dir, *right);
    const std::array<std::array<double, 3>, 3> rows{*right, newUp, *dir};
    Mat4 r;
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j)
            r(i, j) = rows[i][j];
        r(i, 3) = -(rows[i][0] * eye[0] + rows[i][1] * eye[1] + rows[i][2] * eye[2]);
    }
    return r;
}

// `Transform [16 values]` / `ConcatTransform`: pbrt-v4 reads the 16 numbers row by row and then
// transposes, so the file lists the matrix column by column (translation in values 13-15).
inline Mat4 matrixFromPbrtFileOrder(const std::array<double, 16>& v) {
    Mat4 r;
    r.m = v;
    return r.transposed();
}

// General inverse by Gauss-Jordan elimination with partial pivoting; empty when singular.
inline std::optional<Mat4> inverse(const Mat4& a) {
    double w[4][8];
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) {
            w[i][j] = a(i, j);
            w[i][j + 4] = (i == j) ? 1.0 : 0.0;
        }
    for (int col = 0; col < 4; ++col) {
        int piv = col;
        for (int r = col + 1; r < 4; ++r)
            if (std::fabs(w[r][col]) > std::fabs(w[piv][col])) piv = r;
        if (w[piv][col] == 0.0) return std::nullopt;
        if (piv != col)
            for (int j = 0; j < 8; ++j)
                std::swap(w[piv][j], w[col][j]);
        const double inv = 1.0 / w[col][col];
        for (int j = 0; j < 8; ++j)
            w[col][j] *= inv;
        for (int r = 0; r < 4; ++r) {
            if (r == col) continue;
            const double f = w[r][col];
            if (f == 0.0) continue;
            for (int j = 0; j < 8; ++j)
                w[r][j] -= f * w[col][j];
        }
    }
    Mat4 r;
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j)
            r(i, j) = w[i][j + 4];
    return r;
}

} // namespace cb
