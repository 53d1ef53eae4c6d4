// The light model (lights.hpp): area lights at infinity, caps and convex spherical polygons (rects,
// ellipses), their solid angles and unshadowed irradiance, their textures, and their samples
// (drawn from lights/sampling.hpp's point sets). Extraction from a map lives in
// src/environment/, light-set files in light_set_json.cpp, the overlay in overlay.cpp.
#include "penumbra/lights.hpp"
#include "core/number_text.hpp"

#include <algorithm>
#include <cmath>

#include "penumbra/environment.hpp"
#include "penumbra/error.hpp"
#include "common/shared.h"
#include "core/vec3.hpp"
#include "lights/sampling.hpp"

static_assert(penumbra::kMaxLights == PB_MAX_LIGHTS, "lights.hpp kMaxLights and shared.h PB_MAX_LIGHTS differ");

namespace penumbra {

namespace {
constexpr double kPi = 3.14159265358979323846;
}  // namespace

const char* toString(LightShape s) { return s == LightShape::Polygon ? "polygon" : "cap"; }

namespace {
using detail::cross;
using detail::D3;
using detail::dot;
using detail::frameRectSolidAngle;
using detail::normalize;
using detail::triangleSolidAngle;
using detail::vec3Cast;
D3 d3(const std::array<float, 3>& a) { return detail::vec3Cast<double>(a); }
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
// The default frame about w (ex = normalize(ref x w)), as lightSampleDirections and renderer.cpp's
// lightFrame build it.
D3 defaultAxisU(const D3& w) {
  const D3 ref = std::fabs(w[1]) < 0.99 ? D3{0, 1, 0} : D3{1, 0, 0};
  return normalize(cross(ref, w));
}
float luminanceOf(const float* rgb) { return PB_LUM_R * rgb[0] + PB_LUM_G * rgb[1] + PB_LUM_B * rgb[2]; }
}  // namespace

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
    const double len = std::sqrt(dot(a, a));
    if (!std::isfinite(len) || !(len > 0))
      badInput("polygon light vertex " + std::to_string(i) + " is not a finite non-zero direction");
    v[i] = {a[0] / len, a[1] / len, a[2] / len};
    for (int c = 0; c < 3; ++c) sum[c] += v[i][c];
  }
  const double slen = std::sqrt(dot(sum, sum));
  if (!(slen > 1e-6)) badInput("polygon light is degenerate or wider than a hemisphere");
  const D3 d = {sum[0] / slen, sum[1] / slen, sum[2] / slen};
  // Winding: the sign of the edges' triple products with the centroid; reversed to make it
  // counter-clockwise about d ((v_i x v_i+1) . d > 0).
  double turn = 0;
  for (int i = 0; i < n; ++i) turn += dot(cross(v[i], v[(i + 1) % n]), d);
  if (turn < 0) std::reverse(v.begin(), v.end());
  // Convex and simple: every vertex strictly inside every other edge's great-circle half-space
  // (a collinear or repeated vertex fails, so does a reflex one), and the vertices go round d
  // exactly once (a pentagram passes the first test and fails this one).
  const double eps = 1e-7;
  for (int i = 0; i < n; ++i) {
    D3 g = cross(v[i], v[(i + 1) % n]);
    const double gl = std::sqrt(dot(g, g));
    if (!(gl > 1e-7))
      badInput("polygon light has coincident vertices " + std::to_string(i) + " and " +
               std::to_string((i + 1) % n));
    for (int j = 0; j < n; ++j)
      if (j != i && j != (i + 1) % n && !(dot(g, v[j]) / gl > eps))
        badInput("polygon light is not convex (vertex " + std::to_string(j) +
                 " is not inside edge " + std::to_string(i) + ")");
  }
  const D3 ex = defaultAxisU(d), ey = cross(d, ex);
  double wind = 0;
  for (int i = 0; i < n; ++i) {
    const D3 &a = v[i], &b = v[(i + 1) % n];
    double pa = std::atan2(dot(a, ey), dot(a, ex)), pb = std::atan2(dot(b, ey), dot(b, ex));
    double dp = pb - pa;
    while (dp <= -kPi) dp += 2 * kPi;
    while (dp > kPi) dp -= 2 * kPi;
    wind += dp;
  }
  if (std::fabs(wind - 2 * kPi) > 1e-3)
    badInput("polygon light is not a simple convex polygon (its vertices wind " +
             detail::numberText(wind / (2 * kPi)) + " times around its centre)");
  double cosA = 1;
  for (auto& a : v) cosA = std::min(cosA, dot(a, d));
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
  const double dl = std::sqrt(dot(d, d));
  if (!std::isfinite(dl) || !(dl > 0)) badInput("light direction must be a finite non-zero vector");
  d = {d[0] / dl, d[1] / dl, d[2] / dl};
  D3 u = d3(up);
  const double du = dot(d, u);
  for (int c = 0; c < 3; ++c) u[c] -= du * d[c];
  const double ul = std::sqrt(dot(u, u));
  if (!std::isfinite(ul) || !(ul > 1e-6)) badInput("\"up\" must not be parallel to \"direction\"");
  upT = {u[0] / ul, u[1] / ul, u[2] / ul};
  right = cross(d, upT);
}
// The frame of a rect or ellipse light: its tangent frame and the tangents of its half-angles,
// each in (0, pi/2) (Error(BadInput) otherwise).
struct OutlineFrame {
  D3 d, right, up;
  double ta, tb;
};
OutlineFrame outlineFrame(const std::array<float, 3>& direction, const std::array<float, 3>& up,
                      const std::array<double, 2>& h) {
  for (int k = 0; k < 2; ++k)
    if (!(h[k] > 0 && h[k] < kPi / 2))
      badInput("half-angles must be in (0, 90) degrees, got " + detail::numberText(h[k] * 180 / kPi));
  OutlineFrame f;
  tangentFrame(direction, up, f.d, f.right, f.up);
  f.ta = std::tan(h[0]);
  f.tb = std::tan(h[1]);
  return f;
}
// A polygon light made from the frame's outline keeps the frame itself: its direction exactly
// (not the polygon's vertex centroid), the axis and the tangents.
void keepFrame(AreaLight& l, AreaLight::Outline outline, const OutlineFrame& f) {
  l.outline = outline;
  l.direction = vec3Cast<float>(f.d);
  l.axisU = vec3Cast<float>(f.right);
  l.tanHalf = {float(f.ta), float(f.tb)};
}
}  // namespace

AreaLight makeRectLight(const std::array<float, 3>& direction, const std::array<float, 3>& up,
                        const std::array<double, 2>& halfAngles,
                        const std::array<float, 3>& radiance) {
  const OutlineFrame f = outlineFrame(direction, up, halfAngles);
  const D3 &d = f.d, &rt = f.right, &u = f.up;
  std::vector<std::array<float, 3>> verts;
  const double sx[4] = {-1, 1, 1, -1}, sy[4] = {-1, -1, 1, 1};
  for (int k = 0; k < 4; ++k) {
    double p[3];
    for (int c = 0; c < 3; ++c) p[c] = d[c] + sx[k] * f.ta * rt[c] + sy[k] * f.tb * u[c];
    verts.push_back({float(p[0]), float(p[1]), float(p[2])});
  }
  AreaLight l = makePolygonLight(verts, radiance);
  keepFrame(l, AreaLight::Outline::Rect, f);
  return l;
}

AreaLight makeEllipseLight(const std::array<float, 3>& direction, const std::array<float, 3>& up,
                           const std::array<double, 2>& halfAngles,
                           const std::array<float, 3>& radiance) {
  const OutlineFrame f = outlineFrame(direction, up, halfAngles);
  const D3 &d = f.d, &rt = f.right, &u = f.up;
  // The affine image of the regular M-gon whose area is the unit disk's: circumradius s with
  // M/2 s^2 sin(2 pi / M) = pi. Its edges are great circles (straight lines of the gnomonic
  // plane), so it is a spherical polygon; its boundary stays within s - 1 = 0.32% (vertices) and
  // 1 - s cos(pi / M) = 0.16% (edge midpoints) of the ellipse's radius at M = 32.
  const int M = PB_ELLIPSE_VERTS;
  const double s = std::sqrt(2 * kPi / (M * std::sin(2 * kPi / M)));
  std::vector<std::array<float, 3>> verts;
  for (int k = 0; k < M; ++k) {
    const double t = 2 * kPi * k / M, x = s * f.ta * std::cos(t), y = s * f.tb * std::sin(t);
    verts.push_back({float(d[0] + x * rt[0] + y * u[0]), float(d[1] + x * rt[1] + y * u[1]),
                     float(d[2] + x * rt[2] + y * u[2])});
  }
  AreaLight l = makePolygonLight(verts, radiance);
  // the centroid of a centrally symmetric polygon is d up to rounding; keep d exactly
  keepFrame(l, AreaLight::Outline::Ellipse, f);
  const float omega = l.solidAngle();
  for (int c = 0; c < 3; ++c) l.power[c] = radiance[c] * omega;
  return l;
}

std::array<float, 3> AreaLight::axisV() const {
  const D3 v = cross(d3(axisU), d3(direction));
  return {float(v[0]), float(v[1]), float(v[2])};
}

std::array<float, 2> AreaLight::frameCoords(const std::array<float, 3>& d) const {
  const D3 w = d3(direction), a = d3(d), u = d3(axisU), v = cross(u, w);
  const double z = dot(a, w);
  if (!(z > 0) || !(tanHalf[0] > 0) || !(tanHalf[1] > 0)) return {2.0f, 2.0f};  // outside
  return {float(dot(a, u) / (z * tanHalf[0])), float(dot(a, v) / (z * tanHalf[1]))};
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
               " is " + detail::numberText(t.radiance[i]));
  if (!(maxTexelLuminance(t) > 0)) badInput("light texture is black (no texel has a positive luminance)");
  const bool ellipse = l.shape == LightShape::Polygon && l.outline == AreaLight::Outline::Ellipse;
  const bool rect = l.shape == LightShape::Polygon && l.outline == AreaLight::Outline::Rect;
  if (l.shape == LightShape::Polygon && !ellipse && !rect)
    badInput("a light texture needs a cap, rect or ellipse light (a plain polygon has no frame)");
  if (l.shape == LightShape::Cap) {
    if (!(l.cosAlpha > 0 && l.cosAlpha < 1)) badInput("a textured cap needs a half-angle in (0, 90) degrees");
    const D3 w = normalize(d3(l.direction));
    D3 u = d3(l.axisU);
    u = std::sqrt(dot(u, u)) > 0.5 ? u : defaultAxisU(w);
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
    const D3 w = normalize(d3(l.direction)), u = defaultAxisU(w), v = cross(u, w);
    const double ta = std::sqrt(1.0 - double(l.cosAlpha) * l.cosAlpha) / l.cosAlpha;
    LightTexture t{size, size, std::vector<float>(std::size_t(size) * size * 3, 0.0f)};
    const int q = supersample;
    for (int j = 0; j < size; ++j)
      for (int i = 0; i < size; ++i) {
        double sum[3] = {0, 0, 0};
        for (int b = 0; b < q; ++b)
          for (int a = 0; a < q; ++a) {
            const double x = -1 + 2 * (i + (a + 0.5) / q) / size, y = 1 - 2 * (j + (b + 0.5) / q) / size;
            const D3 d = normalize(D3{w[0] + ta * (x * u[0] + y * v[0]),
                                      w[1] + ta * (x * u[1] + y * v[1]),
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
    const D3 w = d3(light.direction), u = d3(light.axisU), v = cross(u, w);
    const double ta = light.tanHalf[0], tb = light.tanHalf[1];
    std::vector<std::array<float, 3>> dirs;
    std::vector<double> area;
    for (int k = 0; k < n; ++k) {
      const auto p = detail::fibonacciDiskPoint(k, n, rotation);
      const double x = p[0] * ta, y = p[1] * tb, q = 1 + x * x + y * y;
      const D3 d = normalize(D3{w[0] + x * u[0] + y * v[0], w[1] + x * u[1] + y * v[1],
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

// Cap: lights/sampling.hpp's spherical Fibonacci set, in the frame renderer.cpp's lightFrame
// builds (ex = normalize(ref x w)), so brute force samples what it always did. Polygon: its
// stratified set (Arvo 1995 over the fan of triangles); `rotation` turns a cap's set about its
// axis and shifts a polygon's lattice (sphericalPolygonSamples).
std::vector<std::array<float, 3>> lightSampleDirections(const AreaLight& light, int n,
                                                        float rotation) {
  if (light.shape != LightShape::Polygon)
    return detail::sphericalFibonacciCap(light.direction, light.cosAlpha, n, rotation);
  return detail::sphericalPolygonSamples(light.vertices, n, rotation);
}

// lightsPower, ambientPower and ambientIrradiance live in src/environment/ambient.cpp.
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

}  // namespace penumbra

namespace penumbra {

namespace {

bool finite3(const std::array<float, 3>& v) {
  return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
}

std::string text3(const std::array<float, 3>& v) {
  return "(" + detail::numberText(v[0]) + ", " + detail::numberText(v[1]) + ", " + detail::numberText(v[2]) +
         ")";
}

// A unit vector within single-precision rounding of what normalizing gives.
bool unit3(const std::array<float, 3>& v) {
  if (!finite3(v)) return false;
  const double l = std::sqrt(double(v[0]) * v[0] + double(v[1]) * v[1] + double(v[2]) * v[2]);
  return std::abs(l - 1.0) < 1e-3;
}

}  // namespace

void validateLightSet(const LightSet& set) {
  if (set.lights.size() > PB_MAX_LIGHTS)
    badInput("LightSet: " + std::to_string(set.lights.size()) + " lights, at most " +
             std::to_string(PB_MAX_LIGHTS));
  for (std::size_t i = 0; i < set.lights.size(); ++i) {
    const AreaLight& l = set.lights[i];
    const std::string at = "LightSet: light " + std::to_string(i) + ": ";
    if (!unit3(l.direction))
      badInput(at + "direction " + text3(l.direction) + " must be a finite unit vector");
    // Any cap from a direction (1: a hard light) to the whole sphere (-1) has a defined solid
    // angle and finite shading (the kernels' degenerate-input tests); the file format is stricter.
    if (!(l.cosAlpha >= -1 && l.cosAlpha <= 1))
      badInput(at + "cosAlpha " + detail::numberText(l.cosAlpha) + " must be in [-1, 1]");
    for (const auto* v : {&l.radiance, &l.power})
      for (float c : *v)
        if (!std::isfinite(c) || c < 0)
          badInput(at + (v == &l.radiance ? "radiance " : "power ") + text3(*v) +
                   " must be finite and >= 0");
    if (l.shape == LightShape::Polygon) {
      if (l.vertices.size() < 3 || l.vertices.size() > PB_MAX_POLY_VERTS)
        badInput(at + "a polygon needs 3.." + std::to_string(PB_MAX_POLY_VERTS) +
                 " vertices, got " + std::to_string(l.vertices.size()));
      for (std::size_t k = 0; k < l.vertices.size(); ++k)
        if (!unit3(l.vertices[k]))
          badInput(at + "polygon vertex " + std::to_string(k) + " " + text3(l.vertices[k]) +
                   " must be a finite unit vector");
    }
    if (!finite3(l.axisU) || !std::isfinite(l.tanHalf[0]) || !std::isfinite(l.tanHalf[1]) ||
        l.tanHalf[0] < 0 || l.tanHalf[1] < 0)
      badInput(at + "its frame (axisU, tanHalf) must be finite, tanHalf >= 0");
    if (!l.texture.empty()) {
      const std::size_t want = std::size_t(3) * std::size_t(l.texture.width) * l.texture.height;
      if (l.texture.radiance.size() != want)
        badInput(at + "texture of " + std::to_string(l.texture.width) + " x " +
                 std::to_string(l.texture.height) + " needs " + std::to_string(want) +
                 " values, has " + std::to_string(l.texture.radiance.size()));
      for (std::size_t k = 0; k < want; ++k)
        if (!std::isfinite(l.texture.radiance[k]) || l.texture.radiance[k] < 0)
          badInput(at + "texture radiance value " + std::to_string(k) +
                   " must be finite and >= 0");
    }
  }
  for (const auto& c : set.ambientSH)
    if (!finite3(c)) badInput("LightSet: ambientSH holds a non-finite coefficient");
  if (!set.ambientMap.empty()) {
    const AmbientMap& m = set.ambientMap;
    const std::size_t want = std::size_t(3) * std::size_t(m.width) * m.height;
    if (m.rgb.size() != want)
      badInput("LightSet: ambientMap of " + std::to_string(m.width) + " x " +
               std::to_string(m.height) + " needs " + std::to_string(want) + " values, has " +
               std::to_string(m.rgb.size()));
    for (float v : m.rgb)
      if (!std::isfinite(v)) badInput("LightSet: ambientMap holds a non-finite value");
  }
}

}  // namespace penumbra
