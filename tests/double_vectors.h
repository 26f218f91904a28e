// Three-vectors in double precision for the tests' own geometry, written apart from the kernels'
// Vec3 so that a test does not check the kernels' arithmetic with itself.
#pragma once

#include <array>
#include <cmath>

namespace cbtest::double_vectors {

using V3 = std::array<double, 3>;

inline V3 sub(V3 a, V3 b) {
    return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}
inline V3 add(V3 a, V3 b) {
    return {a[0] + b[0], a[1] + b[1], a[2] + b[2]};
}
inline V3 mul(V3 a, double s) {
    return {a[0] * s, a[1] * s, a[2] * s};
}
inline double dot(V3 a, V3 b) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
inline V3 cross(V3 a, V3 b) {
    return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
inline V3 unit(V3 a) {
    return mul(a, 1.0 / std::sqrt(dot(a, a)));
}

} // namespace cbtest::double_vectors
