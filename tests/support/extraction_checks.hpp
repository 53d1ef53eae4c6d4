// Independent references and criteria for the light-extraction tests (issue 15). The references
// are plain double-precision quadrature written here, sharing no code with src/ or kernels/: an
// equirect map's irradiance and power (texel midpoints, exact texel solid angles), a light's
// irradiance by quadrature over its bounding cap, and the map binned onto cube faces. The
// criteria judge a light set WITHOUT its ambient where the claim is about the lights, and the
// ambient alone against map minus lights where it is about the ambient: "lights + ambient equal
// the map" holds by construction for any lights (the ambient is the map minus the lights), so it
// can never fail. Every criterion is one function, so that the same code judges the real set and
// its negative controls (no lights, directions negated, power halved), which must fail it.
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <vector>

#include <penumbra/penumbra.hpp>

namespace penumbra::test::xref {

using D3 = std::array<double, 3>;
using V3 = std::array<float, 3>;

inline double dot3(const D3& a, const D3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline D3 toD(const V3& v) { return {v[0], v[1], v[2]}; }
inline double lum(const D3& e) { return 0.2126 * e[0] + 0.7152 * e[1] + 0.0722 * e[2]; }

// Direction of equirect position (s, t) in texel units on a W x H map (README, y up): longitude
// phi = 2 pi (s / W - 1/2), colatitude theta = pi t / H from +y; (sin theta sin phi, cos theta,
// -sin theta cos phi).
inline D3 equirectDir(double s, double t, int W, int H) {
  const double ph = 2 * M_PI * (s / W - 0.5), th = M_PI * t / H;
  return {std::sin(th) * std::sin(ph), std::cos(th), -std::sin(th) * std::cos(ph)};
}

// The map as samples: each sub-texel's centre direction and radiance x exact solid angle (the
// band between its colatitudes, 2 pi / (W sub) wide). sub x sub sub-texels per texel. The map
// must be unrotated (rotationYDeg 0): the tests judge extraction, not the rotation.
struct Sample {
  D3 dir;
  D3 energy;
};
inline std::vector<Sample> mapSamples(const Environment& env, int sub = 1) {
  const Image& im = env.equirect;
  const int W = im.width, H = im.height;
  std::vector<Sample> out;
  out.reserve(std::size_t(W) * H * sub * sub);
  for (int t = 0; t < H; ++t)
    for (int j = 0; j < sub; ++j) {
      const double t0 = M_PI * (t + double(j) / sub) / H, t1 = M_PI * (t + double(j + 1) / sub) / H;
      const double dw = 2 * M_PI / (double(W) * sub) * (std::cos(t0) - std::cos(t1));
      for (int s = 0; s < W; ++s)
        for (int i = 0; i < sub; ++i) {
          Sample q;
          q.dir = equirectDir(s + (i + 0.5) / sub, t + (j + 0.5) / sub, W, H);
          for (int c = 0; c < 3; ++c) q.energy[c] = im.at(s, t, c) * dw;
          out.push_back(q);
        }
    }
  return out;
}

inline D3 power(const std::vector<Sample>& q) {
  D3 p{0, 0, 0};
  for (auto& s : q)
    for (int c = 0; c < 3; ++c) p[c] += s.energy[c];
  return p;
}

// Irradiance on unit normal n: sum of energy x max(0, n . dir).
inline D3 irradiance(const std::vector<Sample>& q, const D3& n) {
  D3 e{0, 0, 0};
  for (auto& s : q) {
    const double c = dot3(n, s.dir);
    if (c > 0)
      for (int k = 0; k < 3; ++k) e[k] += s.energy[k] * c;
  }
  return e;
}

// Solid angle of the spherical triangle of unit vectors a, b, c (Van Oosterom and Strackee 1983,
// tan(omega / 2) = |a . (b x c)| / (1 + a.b + b.c + c.a)).
inline double triangleSolidAngle(const D3& a, const D3& b, const D3& c) {
  const D3 bc{b[1] * c[2] - b[2] * c[1], b[2] * c[0] - b[0] * c[2], b[0] * c[1] - b[1] * c[0]};
  return 2 * std::atan2(std::fabs(dot3(a, bc)), 1 + dot3(a, b) + dot3(b, c) + dot3(c, a));
}

inline D3 unitD3(const D3& v) {
  const double l = std::sqrt(dot3(v, v));
  return {v[0] / l, v[1] / l, v[2] / l};
}

// Irradiance of one light of uniform radiance (cap or convex polygon) on unit normal n, by
// quadrature with horizon clipping max(0, n . w) per cell. A cap: midpoint rule over rings equal
// in cos and sectors equal in angle, each cell's exact solid angle. A polygon: its fan of
// triangles (v0, vi, vi+1), each cut into `split`^2 flat sub-triangles whose central projections
// tile the spherical triangle exactly (lines of a plane project to great circles), each weighted
// by its exact solid angle at its projected centroid: slivers as accurate as squares.
inline D3 lightIrradiance(const AreaLight& l, const D3& n, int rings = 48, int sectors = 96,
                          int split = 24) {
  double sum = 0;
  if (l.shape == LightShape::Polygon) {
    const std::size_t nv = l.vertices.size();
    for (std::size_t t = 1; t + 1 < nv; ++t) {
      const D3 a = toD(l.vertices[0]), b = toD(l.vertices[t]), c = toD(l.vertices[t + 1]);
      auto at = [&](int i, int j) {  // grid point a + i/k (b - a) + j/k (c - a), projected
        D3 p;
        for (int k = 0; k < 3; ++k)
          p[k] = a[k] + (b[k] - a[k]) * i / split + (c[k] - a[k]) * j / split;
        return unitD3(p);
      };
      auto add = [&](const D3& p, const D3& q, const D3& r) {
        const D3 m = unitD3({p[0] + q[0] + r[0], p[1] + q[1] + r[1], p[2] + q[2] + r[2]});
        const double cn = dot3(n, m);
        if (cn > 0) sum += cn * triangleSolidAngle(p, q, r);
      };
      for (int i = 0; i < split; ++i)
        for (int j = 0; i + j < split; ++j) {
          add(at(i, j), at(i + 1, j), at(i, j + 1));
          if (i + j + 1 < split) add(at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
        }
    }
    return {sum * l.radiance[0], sum * l.radiance[1], sum * l.radiance[2]};
  }
  const D3 d = toD(l.direction);
  const D3 a = std::fabs(d[0]) < 0.9 ? D3{1, 0, 0} : D3{0, 1, 0};
  const D3 u = unitD3({a[0] - dot3(a, d) * d[0], a[1] - dot3(a, d) * d[1], a[2] - dot3(a, d) * d[2]});
  const D3 v{d[1] * u[2] - d[2] * u[1], d[2] * u[0] - d[0] * u[2], d[0] * u[1] - d[1] * u[0]};
  const double ca = l.cosAlpha, dw = (1 - ca) * 2 * M_PI / (double(rings) * sectors);
  std::vector<D3> around(sectors);  // unit vectors about the axis, one per sector
  for (int k = 0; k < sectors; ++k) {
    const double ph = 2 * M_PI * (k + 0.5) / sectors;
    for (int i = 0; i < 3; ++i) around[k][i] = std::cos(ph) * u[i] + std::sin(ph) * v[i];
  }
  for (int r = 0; r < rings; ++r) {
    const double c = 1 - (1 - ca) * (r + 0.5) / rings, s = std::sqrt(std::max(0.0, 1 - c * c));
    for (int k = 0; k < sectors; ++k) {
      const double cn = c * dot3(n, d) + s * dot3(n, around[k]);
      if (cn > 0) sum += cn * dw;
    }
  }
  return {sum * l.radiance[0], sum * l.radiance[1], sum * l.radiance[2]};
}

// The 26 normals of issue 4 (cube axes, edges, corners) and `extra` uniform random ones.
inline std::vector<D3> testNormals(int extra = 0) {
  std::vector<D3> out;
  for (int x = -1; x <= 1; ++x)
    for (int y = -1; y <= 1; ++y)
      for (int z = -1; z <= 1; ++z)
        if (x || y || z) {
          const double l = std::sqrt(double(x * x + y * y + z * z));
          out.push_back({x / l, y / l, z / l});
        }
  std::mt19937 rng(15);
  std::normal_distribution<double> g;
  for (int i = 0; i < extra; ++i) {
    D3 p{g(rng), g(rng), g(rng)};
    const double l = std::sqrt(dot3(p, p));
    out.push_back({p[0] / l, p[1] / l, p[2] / l});
  }
  return out;
}

// A reference to judge lights against: irradiance on each normal and the power they are meant to
// carry.
struct Target {
  std::vector<D3> normals;
  std::vector<D3> irradiance;
  D3 power{0, 0, 0};
};
inline Target mapTarget(const std::vector<Sample>& q, const std::vector<D3>& normals) {
  Target t;
  t.normals = normals;
  for (auto& n : normals) t.irradiance.push_back(irradiance(q, n));
  t.power = power(q);
  return t;
}

// How far a light set's lights alone (its ambient ignored) are from a target: the worst and mean
// relative luminance error of the irradiance over the normals, the worst over RGB channels, and
// the worst relative power error over channels. The lights' irradiance is AreaLight::irradiance
// (checked against quadrature in tests/test_lights.cpp). Irradiance errors are relative to
// `scale`'s irradiance when given (a target that is zero on some normals: judged as a fraction of
// the whole map's irradiance there), else to the target's.
struct LightsError {
  double worstLum = 0, meanLum = 0, worstRgb = 0, power = 0;
};
inline LightsError lightsError(const LightSet& set, const Target& t, const Target* scale = nullptr) {
  LightsError r;
  for (std::size_t i = 0; i < t.normals.size(); ++i) {
    D3 e{0, 0, 0};
    const V3 n{float(t.normals[i][0]), float(t.normals[i][1]), float(t.normals[i][2])};
    for (const AreaLight& l : set.lights) {
      const auto li = l.irradiance(n);
      for (int c = 0; c < 3; ++c) e[c] += li[c];
    }
    const D3& ref = t.irradiance[i];
    const D3& den = scale ? scale->irradiance[i] : ref;
    const double el = std::fabs(lum(e) - lum(ref)) / lum(den);
    r.worstLum = std::max(r.worstLum, el);
    r.meanLum += el / t.normals.size();
    for (int c = 0; c < 3; ++c)
      if (den[c] > 0) r.worstRgb = std::max(r.worstRgb, std::fabs(e[c] - ref[c]) / den[c]);
  }
  D3 p{0, 0, 0};
  for (const AreaLight& l : set.lights)
    for (int c = 0; c < 3; ++c) p[c] += l.power[c];
  for (int c = 0; c < 3; ++c)
    if (t.power[c] > 0) r.power = std::max(r.power, std::fabs(p[c] / t.power[c] - 1));
  return r;
}

// How far the ambient alone is from what it claims to be, the map minus the lights: worst over
// normals and channels of |A(n) - (E_map(n) - sum of the lights' quadrature irradiance)| /
// E_map(n), with E_map from `map` (mapTarget of the whole map). An ambient made for other lights
// than the set's, or none, fails it by what those lights differ by.
inline double ambientError(const LightSet& set, const Target& map) {
  double worst = 0;
  for (std::size_t i = 0; i < map.normals.size(); ++i) {
    const D3& n = map.normals[i];
    D3 want = map.irradiance[i];
    for (const AreaLight& l : set.lights) {
      const D3 li = lightIrradiance(l, n, 32, 64, 12);
      for (int c = 0; c < 3; ++c) want[c] -= li[c];
    }
    const auto a = set.hasAmbient
                       ? set.ambientIrradiance({float(n[0]), float(n[1]), float(n[2])})
                       : std::array<double, 3>{0, 0, 0};
    for (int c = 0; c < 3; ++c)
      worst = std::max(worst, std::fabs(a[c] - want[c]) / map.irradiance[i][c]);
  }
  return worst;
}

// The negative controls: the same set with no lights, with every light pointing the other way
// (polygons' vertices negated and their order reversed, so they stay counter-clockwise), and with
// every light's power halved. The ambient is left as it is.
inline LightSet withoutLights(LightSet s) {
  s.lights.clear();
  return s;
}
inline LightSet negated(LightSet s) {
  for (AreaLight& l : s.lights) {
    for (float& x : l.direction) x = -x;
    for (auto& v : l.vertices)
      for (float& x : v) x = -x;
    std::reverse(l.vertices.begin(), l.vertices.end());
  }
  return s;
}
inline LightSet halved(LightSet s) {
  for (AreaLight& l : s.lights) l.setPower({0.5f * l.power[0], 0.5f * l.power[1], 0.5f * l.power[2]});
  return s;
}

// The ambient's negative controls: the ambient computed for a wrong light set (no lights, the
// directions negated, the power halved) kept beside the set's real lights, as a residual that
// subtracted the wrong lights would be. Returns ambientError of each on `t`.
inline std::array<double, 3> ambientControls(Context& ctx, const Environment& env,
                                             const LightSet& set, const AmbientOptions& o,
                                             const Target& t) {
  std::array<double, 3> out{};
  const LightSet wrong[3] = {withoutLights(set), negated(set), halved(set)};
  for (int k = 0; k < 3; ++k) {
    LightSet c = wrong[k];
    addAmbientResidual(ctx, env, c, o);
    c.lights = set.lights;
    out[k] = ambientError(c, t);
  }
  return out;
}

}  // namespace penumbra::test::xref
