// Point sets on the disk and the sphere (sampling.hpp): Fibonacci disk points, spherical
// Fibonacci caps, and Arvo's spherical-triangle map over a polygon's fan.
#include "lights/sampling.hpp"

#include <algorithm>
#include <cmath>

namespace penumbra::detail {

namespace {
constexpr double kPi = 3.14159265358979323846;
}  // namespace

std::array<double, 2> fibonacciDiskPoint(int k, int n, double rotation) {
  const double kGoldenAngle = 2.39996322972865332;  // pi (3 - sqrt 5)
  const double r = std::sqrt((k + 0.5) / n), a = kGoldenAngle * k + rotation;
  return {r * std::cos(a), r * std::sin(a)};
}

// tan(Omega / 2) = a.(b x c) / (1 + a.b + b.c + c.a).
double triangleSolidAngle(const D3& a, const D3& b, const D3& c) {
  return 2.0 * std::atan2(dot(a, cross(b, c)), 1.0 + dot(a, b) + dot(b, c) + dot(c, a));
}

// F(x1, y1) - F(x0, y1) - F(x1, y0) + F(x0, y0), F(x, y) = atan(x y / sqrt(1 + x^2 + y^2)), the
// antiderivative of (1 + x^2 + y^2)^(-3/2) in x and y.
double frameRectSolidAngle(double x0, double x1, double y0, double y1) {
  auto F = [](double x, double y) { return std::atan(x * y / std::sqrt(1 + x * x + y * y)); };
  return F(x1, y1) - F(x0, y1) - F(x1, y0) + F(x0, y0);
}

// cos(theta_k) = 1 - (1 - cos alpha)(k + 1/2)/n splits the cap into n rings of equal solid angle
// (d omega = d cos(theta) d phi), and the golden angle turns each sample away from its neighbours
// in phi: a deterministic low-discrepancy set, uniform in solid angle.
std::vector<std::array<float, 3>> sphericalFibonacciCap(const std::array<float, 3>& direction,
                                                        float cosAlpha, int n, float rotation) {
  std::vector<std::array<float, 3>> out;
  if (n < 1) return out;
  out.reserve(n);
  const float kGoldenAngle = 2.39996322972865332f;  // pi (3 - sqrt 5)
  const V3 w = normalize(direction);
  const V3 ref = std::fabs(w[1]) < 0.99f ? V3{0, 1, 0} : V3{1, 0, 0};
  const V3 ex = normalize(cross(ref, w)), ey = cross(w, ex);
  const float cosA = std::clamp(cosAlpha, -1.0f, 1.0f);
  for (int k = 0; k < n; ++k) {
    const float ct = 1.0f - (1.0f - cosA) * (k + 0.5f) / n;
    const float st = std::sqrt(std::max(0.0f, 1.0f - ct * ct));
    const float ph = kGoldenAngle * k + rotation;
    V3 d;
    for (int i = 0; i < 3; ++i)
      d[i] = ct * w[i] + st * (std::cos(ph) * ex[i] + std::sin(ph) * ey[i]);
    out.push_back(normalize(d));
  }
  return out;
}

D3 arvoTrianglePoint(const D3& A, const D3& B, const D3& C, double area, double u1, double u2) {
  // alpha = the triangle's angle at A, c = arc AB.
  const D3 nab = normalize(cross(A, B)), nac = normalize(cross(A, C));
  const double alpha = std::acos(std::clamp(dot(nab, nac), -1.0, 1.0));
  const double cosc = dot(A, B);
  const double ah = u1 * area;  // area of the sub-triangle (A, B, C^)
  const double s = std::sin(ah - alpha), tt = std::cos(ah - alpha);
  const double uu = tt - std::cos(alpha), vv = s + std::sin(alpha) * cosc;
  // q = cos of the arc A C^ (Arvo's eq. for the new vertex C^ on the arc A C)
  double q = ((vv * tt - uu * s) * std::cos(alpha) - vv) / ((vv * s + uu * tt) * std::sin(alpha));
  q = std::clamp(q, -1.0, 1.0);
  D3 perp = {C[0] - dot(C, A) * A[0], C[1] - dot(C, A) * A[1], C[2] - dot(C, A) * A[2]};
  perp = normalize(perp);
  const double sq = std::sqrt(std::max(0.0, 1 - q * q));
  const D3 Ch = {q * A[0] + sq * perp[0], q * A[1] + sq * perp[1], q * A[2] + sq * perp[2]};
  const double z = 1 - u2 * (1 - dot(Ch, B));
  D3 p2 = {Ch[0] - dot(Ch, B) * B[0], Ch[1] - dot(Ch, B) * B[1], Ch[2] - dot(Ch, B) * B[2]};
  const double pl = std::sqrt(dot(p2, p2));
  const double sz = std::sqrt(std::max(0.0, 1 - z * z));
  D3 P = B;
  if (pl > 0)
    for (int c = 0; c < 3; ++c) P[c] = z * B[c] + sz * p2[c] / pl;
  return normalize(P);
}

std::vector<std::array<float, 3>> sphericalPolygonSamples(
    const std::vector<std::array<float, 3>>& vertices, int n, float rotation) {
  std::vector<std::array<float, 3>> out;
  const int nv = int(vertices.size());
  if (n < 1 || nv < 3) return out;
  out.reserve(n);
  std::vector<D3> v(nv);
  for (int i = 0; i < nv; ++i) v[i] = normalize(vec3Cast<double>(vertices[i]));
  std::vector<double> area(nv - 2), cum(nv - 1, 0.0);
  for (int t = 0; t < nv - 2; ++t) {
    area[t] = std::max(0.0, triangleSolidAngle(v[0], v[t + 1], v[t + 2]));
    cum[t + 1] = cum[t] + area[t];
  }
  const double total = cum[nv - 2];
  const double invGolden = 0.61803398874989484820;
  const double shift = double(rotation) / (2 * kPi);
  for (int k = 0; k < n; ++k) {
    const double u = (k + 0.5) / n;
    double u2 = std::fmod(k * invGolden + shift, 1.0);
    if (u2 < 0) u2 += 1.0;
    // the fan triangle holding area u * total, and u1 within it
    const double target = u * total;
    int t = 0;
    while (t + 1 < nv - 2 && cum[t + 1] <= target) ++t;
    const double u1 = area[t] > 0 ? std::clamp((target - cum[t]) / area[t], 0.0, 1.0) : 0.5;
    const D3 P = arvoTrianglePoint(v[0], v[t + 1], v[t + 2], area[t], u1, u2);
    out.push_back(vec3Cast<float>(P));
  }
  return out;
}

}  // namespace penumbra::detail
