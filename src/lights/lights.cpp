// Area lights and their extraction from an environment map (median cut on the device).
#include "penumbra/lights.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "penumbra/context.hpp"
#include "penumbra/environment.hpp"
#include "penumbra/error.hpp"
#include "penumbra/scan.hpp"
#include "common/shared.h"

static_assert(penumbra::kMaxLights == PB_MAX_LIGHTS, "lights.hpp kMaxLights and shared.h PB_MAX_LIGHTS differ");
#include "shadows/bitmask.hpp"
#include "environment/cubemap.hpp"

namespace penumbra {

namespace {
constexpr double kPi = 3.14159265358979323846;
constexpr float kDeg = float(kPi / 180.0);
}  // namespace

const char* toString(LightShape s) { return s == LightShape::Polygon ? "polygon" : "cap"; }

namespace {
using D3 = std::array<double, 3>;
D3 d3(const std::array<float, 3>& a) { return {a[0], a[1], a[2]}; }
double dot3(const D3& a, const D3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
D3 cross3(const D3& a, const D3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
D3 unit3(const D3& a) {
  const double l = std::sqrt(dot3(a, a));
  return {a[0] / l, a[1] / l, a[2] / l};
}
// Solid angle of the spherical triangle (a, b, c), unit vertices counter-clockwise about its
// inside: Van Oosterom & Strackee (1983), tan(Omega / 2) = a.(b x c) / (1 + a.b + b.c + c.a).
double triangleSolidAngle(const D3& a, const D3& b, const D3& c) {
  return 2.0 * std::atan2(dot3(a, cross3(b, c)), 1.0 + dot3(a, b) + dot3(b, c) + dot3(c, a));
}
// Solid angle of the cone over the frame ellipse (x/ta)^2 + (y/tb)^2 <= 1 at unit distance. In
// polar coordinates of the unit disk, x = ta r cos(phi), y = tb r sin(phi), the gnomonic area
// element (1 + x^2 + y^2)^(-3/2) dx dy integrates in r in closed form:
// Omega = ta tb int_0^2pi (1 - (1 + k)^(-1/2)) / k dphi, k = ta^2 cos^2(phi) + tb^2 sin^2(phi).
// The integrand is smooth and periodic, so the trapezoid rule converges geometrically (512 points:
// at double rounding for half-angles up to 85 degrees, tests/test_textured_lights.cpp).
double ellipseSolidAngle(double ta, double tb) {
  const int n = 512;
  double sum = 0;
  for (int i = 0; i < n; ++i) {
    const double ph = 2 * kPi * (i + 0.5) / n, c = std::cos(ph), s = std::sin(ph);
    const double k = ta * ta * c * c + tb * tb * s * s;
    sum += k > 0 ? (1 - 1 / std::sqrt(1 + k)) / k : 0.5;
  }
  return ta * tb * sum * 2 * kPi / n;
}
// Solid angle of the frame rectangle [x0, x1] x [y0, y1] at unit distance (gnomonic plane):
// F(x1, y1) - F(x0, y1) - F(x1, y0) + F(x0, y0), F(x, y) = atan(x y / sqrt(1 + x^2 + y^2)),
// the antiderivative of (1 + x^2 + y^2)^(-3/2) in x and y.
double frameRectSolidAngle(double x0, double x1, double y0, double y1) {
  auto F = [](double x, double y) { return std::atan(x * y / std::sqrt(1 + x * x + y * y)); };
  return F(x1, y1) - F(x0, y1) - F(x1, y0) + F(x0, y0);
}
// The default frame about w (ex = normalize(ref x w)), as lightSampleDirections and renderer.cpp's
// lightFrame build it.
D3 defaultAxisU(const D3& w) {
  const D3 ref = std::fabs(w[1]) < 0.99 ? D3{0, 1, 0} : D3{1, 0, 0};
  return unit3(cross3(ref, w));
}
float luminanceOf(const float* rgb) { return PB_LUM_R * rgb[0] + PB_LUM_G * rgb[1] + PB_LUM_B * rgb[2]; }
}  // namespace

namespace detail {
// Fibonacci disk points: radius sqrt((k + 1/2) / n), golden-angle turns, turned by `rotation`
// (the bitmask technique's disk samples and the ellipse's samples here; src/bitmask.hpp).
std::array<double, 2> fibonacciDiskPoint(int k, int n, double rotation) {
  const double kGoldenAngle = 2.39996322972865332;  // pi (3 - sqrt 5)
  const double r = std::sqrt((k + 0.5) / n), a = kGoldenAngle * k + rotation;
  return {r * std::cos(a), r * std::sin(a)};
}
}  // namespace detail

float AreaLight::halfAngle() const { return std::acos(std::clamp(cosAlpha, -1.0f, 1.0f)); }
float AreaLight::solidAngle() const {
  if (shape == LightShape::Polygon && outline == Outline::Ellipse)
    return float(ellipseSolidAngle(tanHalf[0], tanHalf[1]));
  if (shape == LightShape::Polygon) {
    // fan from vertex 0: the triangles of a convex polygon, each counter-clockwise
    double omega = 0;
    for (std::size_t i = 1; i + 1 < vertices.size(); ++i)
      omega += triangleSolidAngle(d3(vertices[0]), d3(vertices[i]), d3(vertices[i + 1]));
    return float(omega);
  }
  return float(2.0 * kPi * (1.0 - double(cosAlpha)));
}

void AreaLight::setPower(const std::array<float, 3>& m) {
  power = m;
  const float omega = solidAngle();
  for (int c = 0; c < 3; ++c) radiance[c] = omega > 0 ? power[c] / omega : 0.0f;
}

std::array<float, 3> AreaLight::irradiance(const std::array<float, 3>& n) const {
  float e;
  if (shape == LightShape::Polygon) {
    float v[3 * PB_MAX_POLY_VERTS];
    const int nv = int(std::min<std::size_t>(vertices.size(), PB_MAX_POLY_VERTS));
    for (int i = 0; i < nv; ++i)
      for (int c = 0; c < 3; ++c) v[3 * i + c] = vertices[i][c];
    e = pb_polygon_irradiance(v, nv, n[0], n[1], n[2]);
  } else {
    float cb = n[0] * direction[0] + n[1] * direction[1] + n[2] * direction[2];
    e = pb_cap_irradiance(cosAlpha, cb);
  }
  return {e * radiance[0], e * radiance[1], e * radiance[2]};
}

AreaLight makePolygonLight(const std::vector<std::array<float, 3>>& vertices,
                           const std::array<float, 3>& radiance) {
  const int n = int(vertices.size());
  if (n < 3 || n > PB_MAX_POLY_VERTS)
    badInput("a polygon light needs 3 to " + std::to_string(PB_MAX_POLY_VERTS) +
             " vertices, got " + std::to_string(n));
  for (int c = 0; c < 3; ++c)
    if (!std::isfinite(radiance[c]) || radiance[c] < 0)
      badInput("polygon light radiance must be finite and >= 0");
  std::vector<D3> v(n);
  D3 sum{0, 0, 0};
  for (int i = 0; i < n; ++i) {
    D3 a = d3(vertices[i]);
    const double len = std::sqrt(dot3(a, a));
    if (!std::isfinite(len) || !(len > 0))
      badInput("polygon light vertex " + std::to_string(i) + " is not a finite non-zero direction");
    v[i] = {a[0] / len, a[1] / len, a[2] / len};
    for (int c = 0; c < 3; ++c) sum[c] += v[i][c];
  }
  const double slen = std::sqrt(dot3(sum, sum));
  if (!(slen > 1e-6)) badInput("polygon light is degenerate or wider than a hemisphere");
  const D3 d = {sum[0] / slen, sum[1] / slen, sum[2] / slen};
  // Winding: the sign of the edges' triple products with the centroid; reversed to make it
  // counter-clockwise about d ((v_i x v_i+1) . d > 0).
  double turn = 0;
  for (int i = 0; i < n; ++i) turn += dot3(cross3(v[i], v[(i + 1) % n]), d);
  if (turn < 0) std::reverse(v.begin(), v.end());
  // Convex and simple: every vertex strictly inside every other edge's great-circle half-space
  // (a collinear or repeated vertex fails, so does a reflex one), and the vertices go round d
  // exactly once (a pentagram passes the first test and fails this one).
  const double eps = 1e-7;
  for (int i = 0; i < n; ++i) {
    D3 g = cross3(v[i], v[(i + 1) % n]);
    const double gl = std::sqrt(dot3(g, g));
    if (!(gl > 1e-7))
      badInput("polygon light has coincident vertices " + std::to_string(i) + " and " +
               std::to_string((i + 1) % n));
    for (int j = 0; j < n; ++j)
      if (j != i && j != (i + 1) % n && !(dot3(g, v[j]) / gl > eps))
        badInput("polygon light is not convex (vertex " + std::to_string(j) +
                 " is not inside edge " + std::to_string(i) + ")");
  }
  D3 ref = std::fabs(d[1]) < 0.99 ? D3{0, 1, 0} : D3{1, 0, 0};
  const D3 ex = unit3(cross3(ref, d)), ey = cross3(d, ex);
  double wind = 0;
  for (int i = 0; i < n; ++i) {
    const D3 &a = v[i], &b = v[(i + 1) % n];
    double pa = std::atan2(dot3(a, ey), dot3(a, ex)), pb = std::atan2(dot3(b, ey), dot3(b, ex));
    double dp = pb - pa;
    while (dp <= -kPi) dp += 2 * kPi;
    while (dp > kPi) dp -= 2 * kPi;
    wind += dp;
  }
  if (std::fabs(wind - 2 * kPi) > 1e-3)
    badInput("polygon light is not a simple convex polygon (its vertices wind " +
             std::to_string(wind / (2 * kPi)) + " times around its centre)");
  double cosA = 1;
  for (auto& a : v) cosA = std::min(cosA, dot3(a, d));
  // The bounding cap must stay below 90 degrees: the filtered techniques size their filters by
  // its tangent.
  if (!(cosA > 1e-3)) badInput("polygon light is wider than a hemisphere (bounding half-angle >= 90 degrees)");
  AreaLight l;
  l.shape = LightShape::Polygon;
  for (auto& a : v) l.vertices.push_back({float(a[0]), float(a[1]), float(a[2])});
  l.direction = {float(d[0]), float(d[1]), float(d[2])};
  // rounded down a hair so that float vertices stay inside the float cap
  l.cosAlpha = float(cosA * (1 - 1e-6));
  l.radiance = radiance;
  const float omega = l.solidAngle();
  for (int c = 0; c < 3; ++c) l.power[c] = radiance[c] * omega;
  return l;
}

namespace {
// The tangent frame of rect and ellipse lights: up made orthogonal to d, right = d x up (the
// right of a viewer facing the light with `up` up, so a texture reads as written).
void tangentFrame(const std::array<float, 3>& direction, const std::array<float, 3>& up, D3& d,
                  D3& right, D3& upT) {
  d = d3(direction);
  const double dl = std::sqrt(dot3(d, d));
  if (!std::isfinite(dl) || !(dl > 0)) badInput("light direction must be a finite non-zero vector");
  d = {d[0] / dl, d[1] / dl, d[2] / dl};
  D3 u = d3(up);
  const double du = dot3(d, u);
  for (int c = 0; c < 3; ++c) u[c] -= du * d[c];
  const double ul = std::sqrt(dot3(u, u));
  if (!std::isfinite(ul) || !(ul > 1e-6)) badInput("\"up\" must not be parallel to \"direction\"");
  upT = {u[0] / ul, u[1] / ul, u[2] / ul};
  right = cross3(d, upT);
}
void checkHalfAngles(const std::array<double, 2>& h) {
  for (int k = 0; k < 2; ++k)
    if (!(h[k] > 0 && h[k] < kPi / 2))
      badInput("half-angles must be in (0, 90) degrees, got " + std::to_string(h[k] * 180 / kPi));
}
}  // namespace

AreaLight makeRectLight(const std::array<float, 3>& direction, const std::array<float, 3>& up,
                        const std::array<double, 2>& halfAngles,
                        const std::array<float, 3>& radiance) {
  checkHalfAngles(halfAngles);
  D3 d, rt, u;
  tangentFrame(direction, up, d, rt, u);
  const double ta = std::tan(halfAngles[0]), tb = std::tan(halfAngles[1]);
  std::vector<std::array<float, 3>> verts;
  const double sx[4] = {-1, 1, 1, -1}, sy[4] = {-1, -1, 1, 1};
  for (int k = 0; k < 4; ++k) {
    double p[3];
    for (int c = 0; c < 3; ++c) p[c] = d[c] + sx[k] * ta * rt[c] + sy[k] * tb * u[c];
    verts.push_back({float(p[0]), float(p[1]), float(p[2])});
  }
  AreaLight l = makePolygonLight(verts, radiance);
  l.outline = AreaLight::Outline::Rect;
  l.direction = {float(d[0]), float(d[1]), float(d[2])};
  l.axisU = {float(rt[0]), float(rt[1]), float(rt[2])};
  l.tanHalf = {float(ta), float(tb)};
  return l;
}

AreaLight makeEllipseLight(const std::array<float, 3>& direction, const std::array<float, 3>& up,
                           const std::array<double, 2>& halfAngles,
                           const std::array<float, 3>& radiance) {
  checkHalfAngles(halfAngles);
  D3 d, rt, u;
  tangentFrame(direction, up, d, rt, u);
  const double ta = std::tan(halfAngles[0]), tb = std::tan(halfAngles[1]);
  // The affine image of the regular M-gon whose area is the unit disk's: circumradius s with
  // M/2 s^2 sin(2 pi / M) = pi. Its edges are great circles (straight lines of the gnomonic
  // plane), so it is a spherical polygon; its boundary stays within s - 1 = 0.32% (vertices) and
  // 1 - s cos(pi / M) = 0.16% (edge midpoints) of the ellipse's radius at M = 32.
  const int M = PB_ELLIPSE_VERTS;
  const double s = std::sqrt(2 * kPi / (M * std::sin(2 * kPi / M)));
  std::vector<std::array<float, 3>> verts;
  for (int k = 0; k < M; ++k) {
    const double t = 2 * kPi * k / M, x = s * ta * std::cos(t), y = s * tb * std::sin(t);
    verts.push_back({float(d[0] + x * rt[0] + y * u[0]), float(d[1] + x * rt[1] + y * u[1]),
                     float(d[2] + x * rt[2] + y * u[2])});
  }
  AreaLight l = makePolygonLight(verts, radiance);
  l.outline = AreaLight::Outline::Ellipse;
  // the centroid of a centrally symmetric polygon is d up to rounding; keep d exactly
  l.direction = {float(d[0]), float(d[1]), float(d[2])};
  l.axisU = {float(rt[0]), float(rt[1]), float(rt[2])};
  l.tanHalf = {float(ta), float(tb)};
  const float omega = l.solidAngle();
  for (int c = 0; c < 3; ++c) l.power[c] = radiance[c] * omega;
  return l;
}

std::array<float, 3> AreaLight::axisV() const {
  const D3 v = cross3(d3(axisU), d3(direction));
  return {float(v[0]), float(v[1]), float(v[2])};
}

std::array<float, 2> AreaLight::frameCoords(const std::array<float, 3>& d) const {
  const D3 w = d3(direction), a = d3(d), u = d3(axisU), v = cross3(u, w);
  const double z = dot3(a, w);
  if (!(z > 0) || !(tanHalf[0] > 0) || !(tanHalf[1] > 0)) return {2.0f, 2.0f};  // outside
  return {float(dot3(a, u) / (z * tanHalf[0])), float(dot3(a, v) / (z * tanHalf[1]))};
}

namespace {
const float* texelAt(const LightTexture& t, double x, double y) {
  int i = int(std::floor((x + 1) * 0.5 * t.width)), j = int(std::floor((1 - y) * 0.5 * t.height));
  i = std::clamp(i, 0, t.width - 1);
  j = std::clamp(j, 0, t.height - 1);
  return &t.radiance[(std::size_t(j) * t.width + i) * 3];
}
float maxTexelLuminance(const LightTexture& t) {
  float m = 0;
  for (std::size_t i = 0; i + 2 < t.radiance.size(); i += 3) m = std::max(m, luminanceOf(&t.radiance[i]));
  return m;
}
}  // namespace

std::array<float, 3> AreaLight::radianceAt(const std::array<float, 3>& d) const {
  if (texture.empty()) return radiance;
  const auto xy = frameCoords(d);
  const float* t = texelAt(texture, xy[0], xy[1]);
  return {t[0], t[1], t[2]};
}

float AreaLight::sampleWeight(const std::array<float, 3>& d) const { return lightSampleWeights(*this, {d})[0]; }

std::vector<float> lightSampleWeights(const AreaLight& l, const std::vector<std::array<float, 3>>& dirs) {
  std::vector<float> w(dirs.size(), 1.0f);
  if (l.texture.empty()) return w;
  const float m = maxTexelLuminance(l.texture);
  if (!(m > 0)) return w;
  for (std::size_t k = 0; k < dirs.size(); ++k) {
    const auto xy = l.frameCoords(dirs[k]);
    // m / m == 1 exactly: a uniform texture weighs every sample 1, as no texture does
    w[k] = luminanceOf(texelAt(l.texture, xy[0], xy[1])) / m;
  }
  return w;
}

void setLightTexture(AreaLight& l, LightTexture t) {
  if (t.width < 1 || t.width > 4096 || t.height < 1 || t.height > 4096)
    badInput("light texture size must be in [1, 4096] x [1, 4096], got " + std::to_string(t.width) +
             " x " + std::to_string(t.height));
  const std::size_t want = std::size_t(t.width) * t.height * 3;
  if (t.radiance.size() != want)
    badInput("light texture of " + std::to_string(t.width) + " x " + std::to_string(t.height) +
             " needs " + std::to_string(want) + " radiance values (RGB per texel), got " +
             std::to_string(t.radiance.size()));
  for (std::size_t i = 0; i < want; ++i)
    if (!std::isfinite(t.radiance[i]) || t.radiance[i] < 0)
      badInput("light texture radiance must be finite and >= 0, value " + std::to_string(i) +
               " is " + std::to_string(t.radiance[i]));
  if (!(maxTexelLuminance(t) > 0)) badInput("light texture is black (no texel has a positive luminance)");
  const bool ellipse = l.shape == LightShape::Polygon && l.outline == AreaLight::Outline::Ellipse;
  const bool rect = l.shape == LightShape::Polygon && l.outline == AreaLight::Outline::Rect;
  if (l.shape == LightShape::Polygon && !ellipse && !rect)
    badInput("a light texture needs a cap, rect or ellipse light (a plain polygon has no frame)");
  if (l.shape == LightShape::Cap) {
    if (!(l.cosAlpha > 0 && l.cosAlpha < 1)) badInput("a textured cap needs a half-angle in (0, 90) degrees");
    const D3 w = unit3(d3(l.direction));
    D3 u = d3(l.axisU);
    u = std::sqrt(dot3(u, u)) > 0.5 ? u : defaultAxisU(w);
    l.axisU = {float(u[0]), float(u[1]), float(u[2])};
    const double ta = std::sqrt(1.0 - double(l.cosAlpha) * l.cosAlpha) / l.cosAlpha;
    l.tanHalf = {float(ta), float(ta)};
  }
  l.texture = std::move(t);
  const LightTexture& tx = l.texture;
  bool uniform = true;
  for (std::size_t i = 3; i < want && uniform; ++i) uniform = tx.radiance[i] == tx.radiance[i % 3];
  const float omega = l.solidAngle();
  if (uniform) {
    for (int c = 0; c < 3; ++c) {
      l.radiance[c] = tx.radiance[c];
      l.power[c] = tx.radiance[c] * omega;
    }
    return;
  }
  // Integral of the textured radiance: texel cells in the frame, scaled by tanHalf. A rect's cells
  // are whole (exact solid angles); a disk's or ellipse's are whole where all four corners are
  // inside (convex), empty where the nearest point is outside, and on the rim integrated exactly
  // in y over 64 midpoint columns in x.
  const double ta = l.tanHalf[0], tb = l.tanHalf[1];
  double sum[3] = {0, 0, 0};
  for (int j = 0; j < tx.height; ++j)
    for (int i = 0; i < tx.width; ++i) {
      const double x0 = -1 + 2.0 * i / tx.width, x1 = -1 + 2.0 * (i + 1) / tx.width;
      const double y0 = 1 - 2.0 * (j + 1) / tx.height, y1 = 1 - 2.0 * j / tx.height;
      double om;
      auto in = [](double x, double y) { return x * x + y * y <= 1; };
      const double nx = std::clamp(0.0, x0, x1), ny = std::clamp(0.0, y0, y1);
      if (rect || (in(x0, y0) && in(x0, y1) && in(x1, y0) && in(x1, y1))) {
        om = frameRectSolidAngle(x0 * ta, x1 * ta, y0 * tb, y1 * tb);
      } else if (!in(nx, ny)) {
        om = 0;
      } else {
        // 64 columns, each exact in y over its part inside the disk: with X = x ta, c^2 =
        // 1 + X^2, the integral of (c^2 + Y^2)^(-3/2) dY is Y / (c^2 sqrt(c^2 + Y^2)). The
        // columns are midpoints in t, x = sin(t), so the disk's edge h = cos(t) stays smooth at
        // x = +-1 where its slope in x is infinite.
        const int q = 64;
        om = 0;
        const double t0 = std::asin(std::max(x0, -1.0)), t1 = std::asin(std::min(x1, 1.0));
        const double dt = (t1 - t0) / q;
        for (int a = 0; a < q; ++a) {
          const double t = t0 + (a + 0.5) * dt, x = std::sin(t), h = std::cos(t);
          const double lo = std::max(y0, -h) * tb, hi = std::min(y1, h) * tb;
          if (!(hi > lo)) continue;
          const double c2 = 1 + x * x * ta * ta;
          om += dt * h * ta *
                (hi / (c2 * std::sqrt(c2 + hi * hi)) - lo / (c2 * std::sqrt(c2 + lo * lo)));
        }
      }
      const float* rgb = &tx.radiance[(std::size_t(j) * tx.width + i) * 3];
      for (int c = 0; c < 3; ++c) sum[c] += rgb[c] * om;
    }
  if (!(PB_LUM_R * sum[0] + PB_LUM_G * sum[1] + PB_LUM_B * sum[2] > 0)) {
    l.texture = LightTexture{};  // leave the light as it was given
    badInput("light texture is black over the light (its bright texels lie outside the " +
             std::string(ellipse ? "ellipse" : "disk") + "): the light would carry no power");
  }
  for (int c = 0; c < 3; ++c) {
    l.power[c] = float(sum[c]);
    l.radiance[c] = omega > 0 ? float(sum[c] / omega) : 0.0f;
  }
}

void scaleLightTexture(AreaLight& l, const std::array<float, 3>& power) {
  const float omega = l.solidAngle();
  for (int c = 0; c < 3; ++c) {
    const bool lit = l.power[c] > 0;
    const double f = lit ? double(power[c]) / l.power[c] : 0.0;
    const float uniform = omega > 0 ? power[c] / omega : 0.0f;
    for (std::size_t k = c; k < l.texture.radiance.size(); k += 3)
      l.texture.radiance[k] = lit ? float(l.texture.radiance[k] * f) : uniform;
    l.radiance[c] = uniform;
    l.power[c] = power[c];
  }
}

void textureLightsFromMap(const Environment& env, LightSet& set, int size, int supersample) {
  if (size < 1 || size > 64) badInput("light texture size must be in [1, 64], got " + std::to_string(size));
  if (supersample < 1 || supersample > 16)
    badInput("light texture supersampling must be in [1, 16], got " + std::to_string(supersample));
  for (AreaLight& l : set.lights) {
    if (l.shape != LightShape::Cap || !(l.cosAlpha > 0 && l.cosAlpha < 1)) continue;
    const D3 w = unit3(d3(l.direction)), u = defaultAxisU(w), v = cross3(u, w);
    const double ta = std::sqrt(1.0 - double(l.cosAlpha) * l.cosAlpha) / l.cosAlpha;
    LightTexture t{size, size, std::vector<float>(std::size_t(size) * size * 3, 0.0f)};
    const int q = supersample;
    for (int j = 0; j < size; ++j)
      for (int i = 0; i < size; ++i) {
        double sum[3] = {0, 0, 0};
        for (int b = 0; b < q; ++b)
          for (int a = 0; a < q; ++a) {
            const double x = -1 + 2 * (i + (a + 0.5) / q) / size, y = 1 - 2 * (j + (b + 0.5) / q) / size;
            const D3 d = unit3({w[0] + ta * (x * u[0] + y * v[0]), w[1] + ta * (x * u[1] + y * v[1]),
                                w[2] + ta * (x * u[2] + y * v[2])});
            float rgb[3];
            env.lookup(float(d[0]), float(d[1]), float(d[2]), rgb);
            for (int c = 0; c < 3; ++c) sum[c] += rgb[c];
          }
        for (int c = 0; c < 3; ++c) t.radiance[(std::size_t(j) * size + i) * 3 + c] = float(sum[c] / (q * q));
      }
    if (!(maxTexelLuminance(t) > 0)) continue;
    // the raw texture over the cap, then scaled to the light's power (which extraction keeps)
    AreaLight textured = l;
    textured.axisU = {float(u[0]), float(u[1]), float(u[2])};
    try {
      setLightTexture(textured, std::move(t));
    } catch (const Error& e) {
      if (e.kind() != ErrorKind::BadInput) throw;
      continue;  // the map is black over the cap itself: the light stays uniform
    }
    scaleLightTexture(textured, l.power);
    if (!(maxTexelLuminance(textured.texture) > 0)) continue;  // a light of zero power
    l = std::move(textured);
  }
}

std::vector<LightSample> lightSamples(const AreaLight& light, int n, float rotation) {
  std::vector<LightSample> out;
  if (n < 1) return out;
  out.reserve(n);
  if (light.shape == LightShape::Polygon && light.outline == AreaLight::Outline::Ellipse) {
    const D3 w = d3(light.direction), u = d3(light.axisU), v = cross3(u, w);
    const double ta = light.tanHalf[0], tb = light.tanHalf[1];
    std::vector<std::array<float, 3>> dirs;
    std::vector<double> area;
    for (int k = 0; k < n; ++k) {
      const auto p = detail::fibonacciDiskPoint(k, n, rotation);
      const double x = p[0] * ta, y = p[1] * tb, q = 1 + x * x + y * y;
      const D3 d = unit3({w[0] + x * u[0] + y * v[0], w[1] + x * u[1] + y * v[1],
                          w[2] + x * u[2] + y * v[2]});
      dirs.push_back({float(d[0]), float(d[1]), float(d[2])});
      area.push_back(1 / (q * std::sqrt(q)));
    }
    const auto tw = lightSampleWeights(light, dirs);
    for (int k = 0; k < n; ++k) out.push_back({dirs[k], float(tw[k] * area[k])});
    return out;
  }
  const auto dirs = lightSampleDirections(light, n, rotation);
  const auto tw = lightSampleWeights(light, dirs);
  for (int k = 0; k < n; ++k) out.push_back({dirs[k], tw[k]});
  return out;
}

// Cap: spherical Fibonacci set (moved here from the brute-force pass). cos(theta_k) =
// 1 - (1 - cos alpha)(k + 1/2)/K splits the cap into K rings of equal solid angle
// (d omega = d cos(theta) d phi), and the golden angle turns each sample away from its
// neighbours in phi: a deterministic low-discrepancy set, uniform in solid angle. The frame about
// the axis is the one renderer.cpp's lightFrame builds (ex = normalize(ref x w)), so brute force
// samples what it always did.
// Polygon: the fan triangles from vertex 0, each mapped from the unit square by Arvo's
// area-preserving map (Arvo 1995, "Stratified sampling of spherical triangles", SIGGRAPH, Fig. 2):
// u1 picks the sub-triangle of area u1 * Omega (and, over the fan's cumulative areas, the fan
// triangle), u2 the point along the arc from B. The unit-square points are a Fibonacci lattice
// ((k + 1/2) / K, frac(k / golden ratio)), so the directions are stratified and uniform in solid
// angle. `rotation` turns the cap's set about its axis; a polygon is not symmetric about its
// direction, so there it shifts the lattice's second coordinate by rotation / (2 pi) (mod 1), which
// moves every sample inside the light as a turn moves a cap's.
std::vector<std::array<float, 3>> lightSampleDirections(const AreaLight& light, int n,
                                                        float rotation) {
  std::vector<std::array<float, 3>> out;
  if (n < 1) return out;
  out.reserve(n);
  if (light.shape != LightShape::Polygon) {
    const float kGoldenAngle = 2.39996322972865332f;  // pi (3 - sqrt 5)
    using V = std::array<float, 3>;
    auto dotf = [](V a, V b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; };
    auto normf = [&](V a) {
      float l = std::sqrt(dotf(a, a));
      return V{a[0] / l, a[1] / l, a[2] / l};
    };
    auto crossf = [](V a, V b) {
      return V{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
    };
    V w = normf(light.direction);
    V ref = std::fabs(w[1]) < 0.99f ? V{0, 1, 0} : V{1, 0, 0};
    V ex = normf(crossf(ref, w)), ey = crossf(w, ex);
    float cosA = std::clamp(light.cosAlpha, -1.0f, 1.0f);
    for (int k = 0; k < n; ++k) {
      float ct = 1.0f - (1.0f - cosA) * (k + 0.5f) / n;
      float st = std::sqrt(std::max(0.0f, 1.0f - ct * ct));
      float ph = kGoldenAngle * k + rotation;
      V d;
      for (int i = 0; i < 3; ++i)
        d[i] = ct * w[i] + st * (std::cos(ph) * ex[i] + std::sin(ph) * ey[i]);
      out.push_back(normf(d));
    }
    return out;
  }
  const int nv = int(light.vertices.size());
  if (nv < 3) return out;
  std::vector<D3> v(nv);
  for (int i = 0; i < nv; ++i) v[i] = unit3(d3(light.vertices[i]));
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
    const D3 &A = v[0], &B = v[t + 1], &C = v[t + 2];
    // Arvo 1995: alpha = the triangle's angle at A, c = arc AB.
    const D3 nab = unit3(cross3(A, B)), nac = unit3(cross3(A, C));
    const double alpha = std::acos(std::clamp(dot3(nab, nac), -1.0, 1.0));
    const double cosc = dot3(A, B);
    const double ah = u1 * area[t];  // area of the sub-triangle (A, B, C^)
    const double s = std::sin(ah - alpha), tt = std::cos(ah - alpha);
    const double uu = tt - std::cos(alpha), vv = s + std::sin(alpha) * cosc;
    double q = ((vv * tt - uu * s) * std::cos(alpha) - vv) / ((vv * s + uu * tt) * std::sin(alpha));
    q = std::clamp(q, -1.0, 1.0);
    D3 perp = {C[0] - dot3(C, A) * A[0], C[1] - dot3(C, A) * A[1], C[2] - dot3(C, A) * A[2]};
    perp = unit3(perp);
    const double sq = std::sqrt(std::max(0.0, 1 - q * q));
    const D3 Ch = {q * A[0] + sq * perp[0], q * A[1] + sq * perp[1], q * A[2] + sq * perp[2]};
    const double z = 1 - u2 * (1 - dot3(Ch, B));
    D3 p2 = {Ch[0] - dot3(Ch, B) * B[0], Ch[1] - dot3(Ch, B) * B[1], Ch[2] - dot3(Ch, B) * B[2]};
    const double pl = std::sqrt(dot3(p2, p2));
    const double sz = std::sqrt(std::max(0.0, 1 - z * z));
    D3 P = B;
    if (pl > 0)
      for (int c = 0; c < 3; ++c) P[c] = z * B[c] + sz * p2[c] / pl;
    P = unit3(P);
    out.push_back({float(P[0]), float(P[1]), float(P[2])});
  }
  return out;
}

// lightsPower, ambientPower and ambientIrradiance live in src/ambient.cpp.
std::array<double, 3> LightSet::power() const {
  std::array<double, 3> p = lightsPower(), a = ambientPower();
  for (int c = 0; c < 3; ++c) p[c] += a[c];
  return p;
}

std::array<double, 3> LightSet::irradiance(const std::array<float, 3>& n) const {
  std::array<double, 3> e = ambientIrradiance(n);  // zero without an ambient
  for (auto& l : lights) {
    auto li = l.irradiance(n);
    for (int c = 0; c < 3; ++c) e[c] += li[c];
  }
  return e;
}

std::string LightSet::toJson() const {
  std::ostringstream o;
  o.precision(9);
  o << "{\n  \"method\": \"" << method << "\",\n  \"face_size\": " << faceSize
    << ",\n  \"count\": " << lights.size() << ",\n  \"lights\": [";
  for (std::size_t i = 0; i < lights.size(); ++i) {
    auto& l = lights[i];
    const bool framed = l.shape == LightShape::Polygon && l.outline != AreaLight::Outline::Vertices;
    const char* shape = !framed ? toString(l.shape) : l.outline == AreaLight::Outline::Rect ? "rect" : "ellipse";
    o << (i ? ",\n" : "\n") << "    {\"shape\": \"" << shape << "\", ";
    if (framed || !l.texture.empty()) {
      // the frame: rects and ellipses load from it; a textured cap keeps its texture's orientation
      const auto up = l.axisV();
      o << "\"up\": [" << up[0] << ", " << up[1] << ", " << up[2] << "], ";
      if (framed)
        o << "\"half_angles_deg\": [" << std::atan(double(l.tanHalf[0])) / kDeg << ", "
          << std::atan(double(l.tanHalf[1])) / kDeg << "], ";
    }
    if (!l.texture.empty()) {
      o << "\"texture\": {\"width\": " << l.texture.width << ", \"height\": " << l.texture.height
        << ", \"radiance\": [";
      for (std::size_t k = 0; k < l.texture.radiance.size(); ++k) o << (k ? ", " : "") << l.texture.radiance[k];
      o << "]}, ";
    }
    if (l.shape == LightShape::Polygon) {
      o << "\"vertices\": [";
      for (std::size_t k = 0; k < l.vertices.size(); ++k)
        o << (k ? ", " : "") << "[" << l.vertices[k][0] << ", " << l.vertices[k][1] << ", "
          << l.vertices[k][2] << "]";
      o << "], ";
    }
    o << "\"direction\": [" << l.direction[0] << ", " << l.direction[1]
      << ", " << l.direction[2] << "], \"half_angle_deg\": " << l.halfAngle() / kDeg
      << ", \"cos_alpha\": " << l.cosAlpha << ", \"solid_angle_sr\": " << l.solidAngle()
      << ", \"radiance\": [" << l.radiance[0] << ", " << l.radiance[1] << ", " << l.radiance[2]
      << "], \"power\": [" << l.power[0] << ", " << l.power[1] << ", " << l.power[2]
      << "], \"regions\": [";
    for (std::size_t r = 0; r < l.regions.size(); ++r) {
      auto& g = l.regions[r];
      o << (r ? ", " : "") << "[" << g[0] << ", " << g[1] << ", " << g[2] << ", " << g[3] << ", "
        << g[4] << "]";
    }
    o << "]}";
  }
  // The ambient residual: 9 RGB SH coefficients of radiance (order in lights.hpp), and its power.
  auto ap = ambientPower();
  o << "\n  ],\n  \"ambient\": " << (hasAmbient ? "true" : "false") << ",\n  \"ambient_sh\": [";
  for (int i = 0; i < 9; ++i)
    o << (i ? ", " : "") << "[" << ambientSH[i][0] << ", " << ambientSH[i][1] << ", "
      << ambientSH[i][2] << "]";
  o << "],\n  \"ambient_power\": [" << ap[0] << ", " << ap[1] << ", " << ap[2] << "]";
  // The pre-integrated irradiance map (lights.hpp AmbientMap), when the set has one.
  if (!ambientMap.empty()) {
    o << ",\n  \"ambient_map\": {\"width\": " << ambientMap.width
      << ", \"height\": " << ambientMap.height << ", \"irradiance\": [";
    for (std::size_t i = 0; i < ambientMap.rgb.size(); ++i)
      o << (i ? (i % 3 ? ", " : ",\n    ") : "") << ambientMap.rgb[i];
    o << "]}";
  }
  o << "\n}\n";
  return o.str();
}

namespace {

// Fixed-point CIE XYZ sums (X and Z in 1/10000 units, Y in the energy's units; kernels/envmap.cl
// env_sat_inputs) -> linear RGB with Rec. 709 primaries and D65 white (sRGB), in the energy's
// units. The matrix is the exact inverse of IEC 61966-2-1's RGB -> XYZ matrix as shared.h states
// it (4 decimals), adjugate over determinant of its integer form: the standard's printed inverse
// (3.2406, -1.5372, ...) is rounded and would not give back the RGB sums (errors ~1e-4).
// Integer products below 2^53 keep the adjugate and determinant exact in double.
struct XyzToRgb {
  double inv[3][3];
  XyzToRgb() {
    const double a[3][3] = {{PB_X_R_I, PB_X_G_I, PB_X_B_I},
                            {PB_LUM_R_I, PB_LUM_G_I, PB_LUM_B_I},
                            {PB_Z_R_I, PB_Z_G_I, PB_Z_B_I}};
    auto cof = [&](int i, int j) {
      int i0 = (i + 1) % 3, i1 = (i + 2) % 3, j0 = (j + 1) % 3, j1 = (j + 2) % 3;
      return a[i0][j0] * a[i1][j1] - a[i0][j1] * a[i1][j0];  // cyclic order carries the sign
    };
    double det = a[0][0] * cof(0, 0) + a[0][1] * cof(0, 1) + a[0][2] * cof(0, 2);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) inv[i][j] = cof(j, i) / det;
  }
  // x4, z4: X and Z times 10^4; y: Y summed over `texels` texels. Y was truncated to whole units
  // per texel (env_sat_inputs; kept so for the median-cut splits), which loses half a unit per
  // texel on average: put it back, or dim regions of maps whose brightest texel sets a coarse
  // fixed-point scale lose up to 1e-3 of their green (1.88 x the loss, from the inverse). Tiny
  // negatives (a channel the region lacks) are clamped to zero.
  std::array<double, 3> operator()(long long x4, long long y, long long z4, long long texels) const {
    const double yc = y > 0 ? double(y) + 0.5 * double(texels) : 0.0;
    const double v[3] = {double(x4), yc * 1e4, double(z4)};
    std::array<double, 3> rgb{};
    for (int i = 0; i < 3; ++i)
      rgb[i] = std::max(0.0, inv[i][0] * v[0] + inv[i][1] * v[1] + inv[i][2] * v[2]);
    return rgb;
  }
};

// Lights straddling cube faces (issue 4): a source on a face edge falls into regions of two faces
// (three at a corner), and each region becomes its own light, so its shadow is drawn twice with a
// seam between the copies. Lights whose regions share a stretch of a face edge and whose caps
// overlap (angle between directions < sum of half-angles) are joined, transitively, into one
// light whose moments are the sum of theirs: power adds, direction and extent come from the
// summed luminance moments (kernels/extract.cl resolve_lights), so power and first moment are
// conserved as for any region. This runs on the host: it needs only the regions (downloaded
// anyway for the lights' outlines) and one float4 per light, at most PB_MAX_LIGHTS of them, and is
// a serial union-find over at most 24 m face-border texels: a device kernel would be one
// work-item's worth of work behind a launch and a download. The transitive closure does not
// depend on the order pairs are found in, and groups are numbered by their lowest light, so the
// result is deterministic. Lights with no luminance (black regions) are never merged: their
// fallback caps are wide and say nothing about a source.
//
// Overlapping caps alone do not tell a cut source from two pieces of a smooth sky: the cap of a
// uniformly bright square region (cos a = 2R - 1) is wider than the square, so the caps of any two
// uniform neighbours overlap, and on the test maps 32 lights became 20 and 5 became one clamped
// 85-degree cap (which then no longer conserves the first moment). So a light takes part only
// when it is compact, its cap covering at most `compactness` of its regions' solid angle: a
// source brighter than its surroundings (uniform square: cap/region = 1.05; a half-disc on a whole
// face: ~0.01). Seams matter exactly there: two wide diffuse lights cast soft, overlapping
// shadows, a cut compact source casts two sharp ones.
// Returns every light's new group, numbered densely by lowest member.
std::vector<int> mergeAcrossFaceEdges(int m, const std::vector<pb_region>& regs,
                                      const std::vector<cl_float4>& dirs,
                                      const std::vector<cl_long4>& sums, float compactness) {
  const int n = int(dirs.size());
  // Solid angle of each light's regions: a rectangle [u0,u1] x [v0,v1] on a face at unit distance
  // subtends F(u1,v1) - F(u0,v1) - F(u1,v0) + F(u0,v0), F(u,v) = atan(uv / sqrt(1 + u^2 + v^2)).
  std::vector<double> regionOmega(n, 0.0);
  auto F = [](double u, double v) { return std::atan(u * v / std::sqrt(1 + u * u + v * v)); };
  for (auto& r : regs) {
    double u0 = 2.0 * r.x0 / m - 1, u1 = 2.0 * r.x1 / m - 1, v0 = 2.0 * r.y0 / m - 1,
           v1 = 2.0 * r.y1 / m - 1;
    regionOmega[r.group] += F(u1, v1) - F(u0, v1) - F(u1, v0) + F(u0, v0);
  }
  auto compact = [&](int i) {
    double capOmega = 2 * kPi * (1 - double(dirs[i].s[3]));
    return sums[i].s[1] > 0 && capOmega <= compactness * regionOmega[i];
  };
  // The light owning each face-border texel, per face and side (0: x = 0, 1: x = m-1,
  // 2: y = 0, 3: y = m-1), indexed along the side.
  std::vector<int> border(std::size_t(6) * 4 * m, -1);
  auto at = [&](int face, int side, int k) -> int& { return border[(std::size_t(face) * 4 + side) * m + k]; };
  for (auto& r : regs) {
    for (int k = r.y0; k < r.y1; ++k) {
      if (r.x0 == 0) at(r.face, 0, k) = r.group;
      if (r.x1 == m) at(r.face, 1, k) = r.group;
    }
    for (int k = r.x0; k < r.x1; ++k) {
      if (r.y0 == 0) at(r.face, 2, k) = r.group;
      if (r.y1 == m) at(r.face, 3, k) = r.group;
    }
  }
  std::vector<int> parent(n);
  for (int i = 0; i < n; ++i) parent[i] = i;
  auto find = [&](int i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  auto overlap = [&](int a, int b) {
    if (!compact(a) || !compact(b)) return false;
    double dot = 0;
    for (int c = 0; c < 3; ++c) dot += double(dirs[a].s[c]) * dirs[b].s[c];
    double angle = std::acos(std::clamp(dot, -1.0, 1.0));
    return angle < std::acos(std::clamp(double(dirs[a].s[3]), -1.0, 1.0)) +
                       std::acos(std::clamp(double(dirs[b].s[3]), -1.0, 1.0));
  };
  // Step a quarter texel off the face across each border texel's outer edge and find the texel
  // of the neighbouring face it lands in (pb_cube_face decides which face, so no adjacency table
  // is kept by hand); the quarter texel keeps it clear of the neighbour's texel boundaries.
  const float eps = 0.5f / float(m);
  for (int face = 0; face < 6; ++face)
    for (int side = 0; side < 4; ++side)
      for (int k = 0; k < m; ++k) {
        int a = at(face, side, k);
        if (a < 0) continue;
        float c = 2.0f * (float(k) + 0.5f) / float(m) - 1.0f;  // texel centre along the side
        float u = side == 0 ? -1.0f - eps : side == 1 ? 1.0f + eps : c;
        float v = side == 2 ? -1.0f - eps : side == 3 ? 1.0f + eps : c;
        float x, y, z, u2, v2;
        pb_cube_dir(face, u, v, &x, &y, &z);
        int f2 = pb_cube_face(x, y, z, &u2, &v2);
        int x2 = std::clamp(int(std::floor((u2 + 1.0f) * 0.5f * float(m))), 0, m - 1);
        int y2 = std::clamp(int(std::floor((v2 + 1.0f) * 0.5f * float(m))), 0, m - 1);
        if (f2 == face) continue;
        int b = x2 == 0 ? at(f2, 0, y2) : x2 == m - 1 ? at(f2, 1, y2)
              : y2 == 0 ? at(f2, 2, x2) : y2 == m - 1 ? at(f2, 3, x2) : -1;
        if (b < 0) continue;
        int ra = find(a), rb = find(b);
        if (ra != rb && overlap(a, b)) parent[std::max(ra, rb)] = std::min(ra, rb);
      }
  std::vector<int> group(n), label(n, -1);
  int next = 0;
  for (int i = 0; i < n; ++i) {
    int r = find(i);
    if (label[r] < 0) label[r] = next++;
    group[i] = label[r];
  }
  return group;
}

}  // namespace

LightSet extractMedianCut(Context& ctx, const Environment& env, const MedianCutOptions& opt) {
  const int m = opt.faceSize;
  if (m < 1 || m > 4096)
    badInput("--face-size must be in [1, 4096], got " + std::to_string(m));
  if (opt.lights < 1) badInput("--lights must be >= 1, got " + std::to_string(opt.lights));
  if (opt.lights > PB_MAX_LIGHTS)
    badInput("--lights must be <= " + std::to_string(PB_MAX_LIGHTS) + ", got " +
             std::to_string(opt.lights));
  if (std::int64_t(opt.lights) > 6LL * m * m)
    badInput("--lights " + std::to_string(opt.lights) + " exceeds the " +
             std::to_string(6LL * m * m) + " texels of a " + std::to_string(m) + "^2 cube map");
  if (!(opt.maxHalfAngleDeg > 0 && opt.maxHalfAngleDeg < 90))
    badInput("max half-angle must be in (0, 90) degrees");
  if (!(opt.mergeCompactness > 0 && opt.mergeCompactness <= 1))
    badInput("mergeCompactness must be in (0, 1], got " + std::to_string(opt.mergeCompactness));

  detail::DeviceCube cube = detail::resampleToCube(ctx, env, m, opt.supersample);
  const double scale = cube.scale;
  const std::size_t cubeTexels = 6ull * m * m;
  cl::Buffer& energy = cube.energy;
  // Colour as CIE XYZ (seed 003 §5): the luminance SAT's Y is shared, X and Z of two faces share
  // a long4 (kernels/envmap.cl env_sat_inputs): 9 long4 images to scan instead of 12.
  // Context scratch buffers: kept across extractions (an animation runs one per frame).
  cl::Buffer lum = ctx.scratch("luminance SAT", cubeTexels * sizeof(cl_long4));
  cl::Buffer xz = ctx.scratch("colour (X, Z) SAT", cubeTexels / 2 * sizeof(cl_long4));
  {
    cl::Kernel k = ctx.kernel("envmap.cl", "env_sat_inputs");
    k.setArg(0, energy);
    k.setArg(1, cl_int(m));
    k.setArg(2, lum);
    k.setArg(3, xz);
    ctx.launch("env/sat-inputs", k, cl::NDRange(m, m, 6));
  }
  summedAreaTable(ctx, lum, ScanType::Long4, m, m, 6, "env/sat");
  summedAreaTable(ctx, xz, ScanType::Long4, m, m, 3, "env/sat");

  const int target = opt.lights;
  const int maxRegions = std::max(6, target);
  cl::Buffer regions = ctx.buffer(maxRegions * sizeof(pb_region), "median-cut regions");
  cl::Buffer count = ctx.buffer(sizeof(cl_int), "median-cut region count");
  {
    cl::Kernel k = ctx.kernel("extract.cl", "median_cut");
    std::size_t wg = ctx.workGroupSize(k, 256);
    k.setArg(0, lum);
    k.setArg(1, cl_int(m));
    k.setArg(2, cl_int(target));
    k.setArg(3, regions);
    k.setArg(4, count);
    k.setArg(5, cl::Local(sizeof(cl_float) * maxRegions));
    ctx.launch("extract/median-cut", k, cl::NDRange(wg), cl::NDRange(wg));
  }
  int regionCount = ctx.download<cl_int>(count, 1, "region count")[0];
  int lightCount = target < 6 ? target : regionCount;
  const std::size_t lightSlots = std::max(6, target);  // enough for every later light count
  cl::Buffer dirs = ctx.buffer(lightSlots * sizeof(cl_float4), "light directions");
  cl::Buffer sums = ctx.buffer(lightSlots * sizeof(cl_long4), "light XYZ sums");
  auto resolve = [&](int lights) {
    cl::Kernel k = ctx.kernel("extract.cl", "resolve_lights");
    std::size_t wg = ctx.workGroupSize(k, 64);
    std::size_t global = (lights + wg - 1) / wg * wg;
    k.setArg(0, lum);
    k.setArg(1, xz);
    k.setArg(2, cl_int(m));
    k.setArg(3, regions);
    k.setArg(4, cl_int(regionCount));
    k.setArg(5, cl_int(lights));
    k.setArg(6, cl_float(std::cos(opt.maxHalfAngleDeg * kDeg)));
    k.setArg(7, cl_float(opt.minHalfAngleDeg * kDeg));
    k.setArg(8, dirs);
    k.setArg(9, sums);
    ctx.launch("extract/resolve", k, cl::NDRange(global), cl::NDRange(wg));
  };
  resolve(lightCount);
  auto regs = ctx.download<pb_region>(regions, regionCount, "regions");
  auto d = ctx.download<cl_float4>(dirs, lightCount, "light directions");
  auto xyz = ctx.download<cl_long4>(sums, lightCount, "light XYZ sums");
  if (opt.mergeAcrossFaces) {
    std::vector<int> group = mergeAcrossFaceEdges(m, regs, d, xyz, opt.mergeCompactness);
    int merged = group.empty() ? lightCount : *std::max_element(group.begin(), group.end()) + 1;
    if (merged < lightCount) {
      // Same regions, fewer groups: resolve again, the merged lights' moments summed exactly
      // from the SATs.
      for (auto& r : regs) r.group = group[r.group];
      ctx.write(regions, regs.data(), regs.size() * sizeof(pb_region), "merged regions");
      lightCount = merged;
      resolve(lightCount);
      d = ctx.download<cl_float4>(dirs, lightCount, "light directions");
      xyz = ctx.download<cl_long4>(sums, lightCount, "light XYZ sums");
    }
  }

  LightSet set;
  set.faceSize = m;
  set.method = "median-cut";
  const XyzToRgb toRgb;
  for (int i = 0; i < lightCount; ++i) {
    AreaLight l;
    l.direction = {d[i].s[0], d[i].s[1], d[i].s[2]};
    l.cosAlpha = d[i].s[3];
    auto rgb = toRgb(xyz[i].s[0], xyz[i].s[1], xyz[i].s[2], xyz[i].s[3]);
    l.setPower({float(rgb[0] / scale), float(rgb[1] / scale), float(rgb[2] / scale)});
    for (auto& r : regs)
      if (r.group == i) l.regions.push_back({r.face, r.x0, r.y0, r.x1, r.y1});
    if (opt.shape == LightShape::Polygon && l.regions.size() == 1) {
      // The region's own shape (MedianCutOptions::shape): its four corners on the cube face. The
      // power stays the region's integral (exact, from the SATs); the radiance spreads it over the
      // polygon's solid angle, which is the exact sum of the region's texel solid angles.
      const auto& g = l.regions[0];
      std::vector<std::array<float, 3>> corners;
      const int cx[4] = {g[1], g[3], g[3], g[1]}, cy[4] = {g[2], g[2], g[4], g[4]};
      for (int k = 0; k < 4; ++k) {
        float x, y, z;
        pb_cube_dir(g[0], 2.0f * cx[k] / m - 1.0f, 2.0f * cy[k] / m - 1.0f, &x, &y, &z);
        const float len = std::sqrt(x * x + y * y + z * z);
        corners.push_back({x / len, y / len, z / len});
      }
      AreaLight p = makePolygonLight(corners, {0, 0, 0});
      p.regions = l.regions;
      p.setPower(l.power);
      l = p;
    }
    set.lights.push_back(l);
  }
  return set;
}

void writeLightOverlay(const std::string& path, const Environment& rotated, const LightSet& set) {
  // Drawn in world directions, like the lights: the map with its rotation baked in.
  const Environment env = rotated.withRotationApplied();
  // Small maps are enlarged (nearest texel) so the outlines stay legible.
  const int k = std::max(1, (1024 + env.equirect.width - 1) / env.equirect.width);
  Image img(env.equirect.width * k, env.equirect.height * k, 3);
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x)
      for (int c = 0; c < 3; ++c) img.at(x, y, c) = env.equirect.at(x / k, y / k, c);
  const int W = img.width, H = img.height;
  auto mark = [&](float x, float y, float z, const float col[3]) {
    float s, t;
    pb_dir_equirect(x, y, z, float(W), float(H), &s, &t);
    int si = std::clamp(int(s), 0, W - 1), ti = std::clamp(int(t), 0, H - 1);
    for (int c = 0; c < 3; ++c) img.at(si, ti, c) = col[c];
  };
  // Display values: outlines must stay visible after tone mapping whatever the map's range.
  const float outline[3] = {1e4f, 0.0f, 1e4f}, centre[3] = {1e4f, 1e4f, 0.0f};
  const int m = std::max(1, set.faceSize);
  for (auto& l : set.lights) {
    for (auto& r : l.regions) {
      // walk the region's border on the cube face, densely enough to be continuous on the map
      int steps = 4 * std::max(W, m);
      for (int side = 0; side < 4; ++side)
        for (int i = 0; i <= steps; ++i) {
          float f = float(i) / steps;
          float px, py;
          switch (side) {
            case 0: px = r[1] + f * (r[3] - r[1]); py = r[2]; break;
            case 1: px = r[1] + f * (r[3] - r[1]); py = r[4]; break;
            case 2: px = r[1]; py = r[2] + f * (r[4] - r[2]); break;
            default: px = r[3]; py = r[2] + f * (r[4] - r[2]); break;
          }
          float x, y, z;
          pb_cube_dir(r[0], 2.0f * px / m - 1.0f, 2.0f * py / m - 1.0f, &x, &y, &z);
          mark(x, y, z, outline);
        }
    }
    if (l.regions.empty()) {
      // No cube regions (center-surround, user lights): the cap's own outline, the circle at the
      // half-angle around the direction, walked densely enough to be continuous on the map.
      float d[3] = {l.direction[0], l.direction[1], l.direction[2]};
      float len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
      if (len > 0) {
        for (float& v : d) v /= len;
        // any unit t1 perpendicular to d, then t2 = d x t1
        const bool nearX = std::fabs(d[0]) >= 0.9f;
        float a[3] = {nearX ? 0.0f : 1.0f, nearX ? 1.0f : 0.0f, 0.0f};
        float dot = a[0] * d[0] + a[1] * d[1];
        float t1[3] = {a[0] - dot * d[0], a[1] - dot * d[1], -dot * d[2]};
        float n1 = std::sqrt(t1[0] * t1[0] + t1[1] * t1[1] + t1[2] * t1[2]);
        for (float& v : t1) v /= n1;
        float t2[3] = {d[1] * t1[2] - d[2] * t1[1], d[2] * t1[0] - d[0] * t1[2],
                       d[0] * t1[1] - d[1] * t1[0]};
        float ca = std::clamp(l.cosAlpha, -1.0f, 1.0f), sa = std::sqrt(1.0f - ca * ca);
        int steps = 8 * W;
        for (int i = 0; i < steps; ++i) {
          float ph = 2.0f * float(kPi) * float(i) / float(steps);
          float cp = std::cos(ph) * sa, sp = std::sin(ph) * sa;
          mark(ca * d[0] + cp * t1[0] + sp * t2[0], ca * d[1] + cp * t1[1] + sp * t2[1],
               ca * d[2] + cp * t1[2] + sp * t2[2], outline);
        }
      }
    }
    // centre: a small cross
    for (int k = -3; k <= 3; ++k) {
      float s, t;
      pb_dir_equirect(l.direction[0], l.direction[1], l.direction[2], float(W), float(H), &s, &t);
      int si = std::clamp(int(s) + k, 0, W - 1), ti = std::clamp(int(t), 0, H - 1);
      for (int c = 0; c < 3; ++c) img.at(si, ti, c) = centre[c];
      si = std::clamp(int(s), 0, W - 1);
      ti = std::clamp(int(t) + k, 0, H - 1);
      for (int c = 0; c < 3; ++c) img.at(si, ti, c) = centre[c];
    }
  }
  writeImage(path, img, autoExposure(env.equirect));
}

}  // namespace penumbra
