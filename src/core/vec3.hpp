// Internal: the few 3-vector helpers the host-side frame code needs (light frames, sample
// frames), on std::array so they mix with the public API's arrays.
#pragma once
#include <array>
#include <cmath>

namespace penumbra::detail {

using V3 = std::array<float, 3>;
inline float dot(V3 a, V3 b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline V3 cross(V3 a, V3 b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
inline V3 normalize(V3 a) {
  float l = std::sqrt(dot(a, a));
  return {a[0] / l, a[1] / l, a[2] / l};
}
inline V3 xyz(const float* v) { return {v[0], v[1], v[2]}; }

}  // namespace penumbra::detail
