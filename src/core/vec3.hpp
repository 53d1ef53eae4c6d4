// Internal: the host's three-component vector maths, written once for float (scene data, light
// frames, the Embree reference) and double (light construction and sampling), on std::array so
// that it mixes with the public API's arrays (Vec3, AreaLight::direction) without conversions.
//
// Our own rather than GLM, which is no longer a dependency: images are bit-identical only while
// every formula keeps its exact arithmetic, and GLM's would not (glm::normalize multiplies by
// inversesqrt, which rounds differently from the division every caller here has always done;
// its intrinsics paths may reorder sums). Each function below states its operations, and a
// computation keeps its precision: nothing here converts float to double or back implicitly.
#pragma once
#include <array>
#include <cmath>

namespace penumbra::detail {

template <class T>
using Vec3T = std::array<T, 3>;
using V3 = Vec3T<float>;
using D3 = Vec3T<double>;

// a0 b0 + a1 b1 + a2 b2, summed left to right.
template <class T>
inline T dot(const Vec3T<T>& a, const Vec3T<T>& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
template <class T>
inline Vec3T<T> cross(const Vec3T<T>& a, const Vec3T<T>& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
template <class T>
inline T length(const Vec3T<T>& a) {
  return std::sqrt(dot(a, a));
}
// a / |a|, each component divided by the length (no reciprocal: see the note above).
template <class T>
inline Vec3T<T> normalize(const Vec3T<T>& a) {
  const T l = length(a);
  return {a[0] / l, a[1] / l, a[2] / l};
}
template <class T>
inline Vec3T<T> operator+(const Vec3T<T>& a, const Vec3T<T>& b) {
  return {a[0] + b[0], a[1] + b[1], a[2] + b[2]};
}
template <class T>
inline Vec3T<T> operator-(const Vec3T<T>& a, const Vec3T<T>& b) {
  return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}
template <class T>
inline Vec3T<T> operator*(const Vec3T<T>& a, T s) {
  return {a[0] * s, a[1] * s, a[2] * s};
}
template <class T>
inline bool isFinite(const Vec3T<T>& a) {
  return std::isfinite(a[0]) && std::isfinite(a[1]) && std::isfinite(a[2]);
}
// a * (1 / |a|) (one division, three products: the scene's rule, which rounds differently from
// normalize), or `fallback` where a has no usable direction: a length that is not finite or is
// at most `minLength`.
template <class T>
inline Vec3T<T> normalizeOr(const Vec3T<T>& a, const Vec3T<T>& fallback, T minLength) {
  const T l = length(a);
  if (!std::isfinite(l) || l <= minLength) return fallback;
  return a * (T(1) / l);
}
// The same products for any positive length; a zero vector is returned as it is (the Embree
// reference's rule).
template <class T>
inline Vec3T<T> normalizeNonZero(const Vec3T<T>& a) {
  const T l = length(a);
  return l > 0 ? a * (T(1) / l) : a;
}
// Each component converted (float -> double is exact; double -> float rounds each to nearest).
template <class To, class From>
inline Vec3T<To> vec3Cast(const Vec3T<From>& a) {
  return {To(a[0]), To(a[1]), To(a[2])};
}
inline V3 xyz(const float* v) { return {v[0], v[1], v[2]}; }

// Plain float overloads of the common three, so that a braced list ({x, y, z}), which a template
// cannot deduce from, converts to V3.
inline float dot(const V3& a, const V3& b) { return dot<float>(a, b); }
inline V3 cross(const V3& a, const V3& b) { return cross<float>(a, b); }
inline V3 normalize(const V3& a) { return normalize<float>(a); }

}  // namespace penumbra::detail
