// Planar penumbrae away from the straight-overhead case every other planar test uses: a cap light
// 50 degrees off the receiver's normal, and a receiver tilted 25 degrees under an overhead light
// (so that the blocker's distance, and with it the penumbra's width, varies across the
// penumbra). The expected visibility of every receiver pixel is computed here, independently of
// the renderer, by double-precision quadrature over the cap: the share of the cap's irradiance
// (solid angle times the cosine to the receiver's normal) whose rays pass the half-plane blocker.
// The filtered techniques (MSSM4, PCSS, CSSM) and the exact sample-based one (bitmask) are held to
// bounds set from measurement, and the light mirrored about the receiver's normal is the negative
// control that every bound must reject.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <vector>

#include "common.hpp"
#include "support/planar_penumbra.hpp"

using namespace penumbra;
using namespace penumbra::test;
using dvec::D3;

namespace {

constexpr double kPi = 3.14159265358979323846;

// The blocker: the horizontal quad {kBlockerX0 < x < 0, |z| < kBlockerZ} at y = kBlockerH.
constexpr double kBlockerH = 1.0, kBlockerX0 = -3.0, kBlockerZ = 3.0;

struct Config {
  const char* name;
  D3 lightAxis;            // unit, towards the light
  double alphaDeg;         // the cap's half-angle
  double tiltDeg;          // the receiver: the plane through the origin with normal
                           // (sin tilt, cos tilt, 0), i.e. y = -x tan(tilt)
  double xLo, xHi;         // receiver quad's extent along x (and |z| < 3)
  Vec3 eye, target;        // camera on the lit side below the blocker
  double keepXLo, keepXHi; // receiver pixels counted: x in this range, |z| < 1.2
};

D3 normalOf(const Config& c) {
  const double t = c.tiltDeg * kPi / 180;
  return {std::sin(t), std::cos(t), 0};
}

Scene sceneOf(const Config& c) {
  const double t = std::tan(c.tiltDeg * kPi / 180);
  const D3 n = normalOf(c);
  Mesh r;
  r.name = "receiver";
  auto y = [&](double x) { return float(-x * t); };
  r.positions = {{float(c.xLo), y(c.xLo), -3}, {float(c.xHi), y(c.xHi), -3},
                 {float(c.xHi), y(c.xHi), 3}, {float(c.xLo), y(c.xLo), 3}};
  const Vec3 nf{float(n[0]), float(n[1]), float(n[2])};
  r.normals = {nf, nf, nf, nf};
  r.triangles = {{0, 2, 1}, {0, 3, 2}};
  Scene s;
  s.meshes.push_back(r);
  s.meshes.push_back(planarQuad("blocker", float(kBlockerX0), 0, float(-kBlockerZ), float(kBlockerZ),
                                float(kBlockerH)));
  return s;
}

AreaLight lightOf(const D3& axis, double alphaDeg) {
  AreaLight l;
  l.direction = {float(axis[0]), float(axis[1]), float(axis[2])};
  l.cosAlpha = float(std::cos(alphaDeg * kPi / 180));
  l.radiance = {1, 1, 1};
  return l;
}

// The cap's quadrature: directions at the midpoints of nt rings x np sectors, each with its solid
// angle (exact per ring: 2 pi (cos t0 - cos t1) / np).
struct Direction {
  D3 d;
  double dw;
};
std::vector<Direction> capQuadrature(const D3& axis, double alpha, int nt = 120, int np = 240) {
  const D3 helper = std::fabs(axis[1]) < 0.9 ? D3{0, 1, 0} : D3{1, 0, 0};
  const D3 u = dvec::unitD(dvec::cross(helper, axis)), v = dvec::cross(axis, u);
  std::vector<Direction> out;
  for (int i = 0; i < nt; ++i) {
    const double t0 = alpha * i / nt, t1 = alpha * (i + 1) / nt, th = 0.5 * (t0 + t1);
    const double dw = 2 * kPi * (std::cos(t0) - std::cos(t1)) / np;
    for (int j = 0; j < np; ++j) {
      const double ph = 2 * kPi * (j + 0.5) / np;
      const double a = std::cos(th), b = std::sin(th) * std::cos(ph), c = std::sin(th) * std::sin(ph);
      out.push_back({{a * axis[0] + b * u[0] + c * v[0], a * axis[1] + b * u[1] + c * v[1],
                      a * axis[2] + b * u[2] + c * v[2]},
                     dw});
    }
  }
  return out;
}

// The share of the cap's irradiance at receiver point p (normal n) that passes the blocker.
double expectedVisibility(const D3& p, const D3& n, const std::vector<Direction>& dirs) {
  double lit = 0, total = 0;
  for (const Direction& q : dirs) {
    const double w = q.dw * std::max(0.0, dvec::dot(n, q.d));
    total += w;
    bool blocked = false;
    if (q.d[1] > 0 && p[1] < kBlockerH) {
      const double t = (kBlockerH - p[1]) / q.d[1];
      const double x = p[0] + t * q.d[0], z = p[2] + t * q.d[2];
      blocked = x > kBlockerX0 && x < 0 && std::fabs(z) < kBlockerZ;
    }
    if (!blocked) lit += w;
  }
  return total > 0 ? lit / total : 1.0;
}

struct Result {
  double maxError = 0, rmsPenumbra = 0, meanSigned = 0;  // meanSigned: mean V - V_quad, penumbra
  int pixels = 0, penumbraPixels = 0;
};

constexpr int kW = 128, kH = 96;

Camera cameraOf(const Config& c) {
  Camera cam;
  cam.eye = c.eye;
  cam.target = c.target;
  cam.up = {0, 1, 0};
  cam.fovyDeg = 50;
  return cam;
}

// The expected visibility of every counted receiver pixel (index y * kW + x), under the
// configuration's own light: the camera ray meets the receiver plane (solved in double) at a point
// inside the counted region, below the blocker.
struct Expected {
  std::vector<std::pair<std::size_t, double>> pixels;
};
Expected expectedOf(const Config& c) {
  const std::vector<Direction> dirs = capQuadrature(c.lightAxis, c.alphaDeg * kPi / 180);
  const CameraBasis b = cameraBasis(cameraOf(c), kW, kH);
  const D3 n = normalOf(c), e{b.eye[0], b.eye[1], b.eye[2]};
  Expected out;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      const Vec3 d = cameraRayDirection(b, kW, kH, x + 0.5f, y + 0.5f);
      const D3 dd{d[0], d[1], d[2]};
      const double den = dvec::dot(n, dd);
      if (den >= 0) continue;
      const double t = -dvec::dot(n, e) / den;
      const D3 p{e[0] + t * dd[0], e[1] + t * dd[1], e[2] + t * dd[2]};
      if (p[1] >= kBlockerH - 0.05) continue;  // not the receiver (the blocker's underside)
      if (p[0] < c.keepXLo || p[0] > c.keepXHi || std::fabs(p[2]) > 1.2) continue;
      out.pixels.push_back({std::size_t(y) * kW + x, expectedVisibility(p, n, dirs)});
    }
  return out;
}

// Renders the configuration lit by `light` with the options in ro and compares the counted
// receiver pixels with `expect` (the configuration's own light; a different `light` is a negative
// control).
Result measure(const Config& c, const AreaLight& light, RenderOptions ro, const Expected& expect) {
  ro.width = kW;
  ro.height = kH;
  ro.shadowMapSize = 256;
  ro.environmentBackground = false;
  ro.shadow.maxFilterTexels = 64;  // the wide penumbrae exceed the default limit, as in
                                   // support/planar_penumbra.cpp
  LightSet set;
  set.lights.push_back(light);
  Renderer r(ctx());
  const Image img = r.render(sceneOf(c), cameraOf(c), set, builtinEnvironment(16), ro).image;
  const std::vector<float> vis = r.lastVisibility();
  Result res;
  double sq = 0;
  for (const auto& [i, v] : expect.pixels) {
    if (img.pixels[4 * i + 3] < 0.5f) continue;
    const double err = vis[i] - v;
    res.maxError = std::max(res.maxError, std::fabs(err));
    ++res.pixels;
    if (v > 0.02 && v < 0.98) {
      sq += err * err;
      res.meanSigned += err;
      ++res.penumbraPixels;
    }
  }
  res.rmsPenumbra = std::sqrt(sq / std::max(1, res.penumbraPixels));
  res.meanSigned /= std::max(1, res.penumbraPixels);
  return res;
}

// Light 50 degrees off the vertical towards -x over a horizontal receiver: the blocker {x < 0}
// casts its shadow out to x = tan 50 = 1.19, the penumbra from tan 40 = 0.84 to tan 60 = 1.73
// (10-degree cap), twice as wide as overhead and lopsided (steeper towards the umbra).
const Config kOblique{"oblique light 50 deg", dvec::unitD({-std::sin(50 * kPi / 180), std::cos(50 * kPi / 180), 0}),
                      10, 0, -3, 3, {3.2f, 0.45f, 0.3f}, {0.8f, 0, 0}, 0.3, 2.6};
// Receiver tilted 25 degrees (descending towards +x) under an overhead 15-degree cap: the blocker
// stands 1 + x tan 25 = 1 + 0.47 x above it, so the penumbra is narrower on the umbra side (x < 0)
// than on the lit side, and the cosine to the tilted normal weighs the cap's halves unequally.
const Config kTilted{"tilted receiver 25 deg", {0, 1, 0}, 15, 25, -1.5, 3, {2.2f, 0.1f, 0.3f},
                     {-0.3f, -0.2f, 0}, -0.9, 1.2};

// The light's axis mirrored about the receiver's normal (a' = 2 (n.a) n - a): the same angle to
// the receiver, on the other side of it.
D3 mirrored(const Config& c) {
  const D3 n = normalOf(c), a = c.lightAxis;
  const double k = 2 * dvec::dot(n, a);
  return {k * n[0] - a[0], k * n[1] - a[1], k * n[2] - a[2]};
}

RenderOptions with(ShadowTechnique t) {
  RenderOptions ro;
  ro.shadows = t;
  return ro;
}

void report(const Config& c, const char* what, const Result& r) {
  std::printf("[ penumbra ] %s, %-16s max |V - V_quad| %.4f over %d pixels, penumbra RMS %.4f "
              "(mean signed %+.4f) over %d\n",
              c.name, what, r.maxError, r.pixels, r.rmsPenumbra, r.meanSigned, r.penumbraPixels);
}

}  // namespace

// The quadrature itself, against the support code's independent ring formula (each ring's lit
// share acos(-x/r)/pi exactly, tests/support/planar_penumbra.cpp) in the overhead, horizontal case
// both can do: they agree within 0.003 (measured max 0.0003; the sector quadrature's error is
// below 1/240 of the cap per ring, and in practice far less).
TEST(PlanarOblique, QuadratureMatchesRingFormulaOverhead) {
  const double alpha = 15 * kPi / 180;
  const std::vector<Direction> dirs = capQuadrature({0, 1, 0}, alpha);
  double worst = 0;
  for (double x = -0.3; x <= 0.3; x += 0.025) {
    const double q = expectedVisibility({x, 0, 0.1}, {0, 1, 0}, dirs);
    worst = std::max(worst, std::fabs(q - halfPlaneVisibilityByRings(x, kBlockerH, alpha)));
  }
  std::printf("[ penumbra ] cap quadrature vs ring formula, overhead 15 deg: max difference %.5f\n", worst);
  EXPECT_LT(worst, 0.003);
  // ...and it can tell a wrong light: the same points under the 50-degree light differ widely.
  const std::vector<Direction> oblique = capQuadrature(kOblique.lightAxis, alpha);
  // (x = 0.5: lit overhead, in the oblique light's umbra, which reaches out to x = tan 40 = 0.84)
  EXPECT_GT(std::fabs(expectedVisibility({0.5, 0, 0}, {0, 1, 0}, oblique) -
                      halfPlaneVisibilityByRings(0.5, kBlockerH, alpha)),
            0.9);
}

namespace {

// One technique's bound in one configuration: the RMS of V - V_quad over the penumbra pixels
// (0.02 < V_quad < 0.98).
struct Bound {
  ShadowTechnique technique;
  double rms;
};

// Renders every technique with its bound, then the controls: hard shadows must fail every
// filtered technique's bound, and each technique lit by the mirrored light must fail its own.
void checkConfig(const Config& c, const std::vector<Bound>& bounds) {
  const Expected ex = expectedOf(c);
  const AreaLight light = lightOf(c.lightAxis, c.alphaDeg), wrong = lightOf(mirrored(c), c.alphaDeg);
  const Result hard = measure(c, light, with(ShadowTechnique::Hard), ex);
  report(c, "hard", hard);
  for (const Bound& b : bounds) {
    const Result r = measure(c, light, with(b.technique), ex);
    report(c, toString(b.technique), r);
    ASSERT_GT(r.pixels, 4000) << toString(b.technique);
    ASSERT_GT(r.penumbraPixels, 800) << toString(b.technique);
    EXPECT_LT(r.rmsPenumbra, b.rms) << toString(b.technique);
    if (b.technique != ShadowTechnique::Bitmask) EXPECT_GT(hard.rmsPenumbra, b.rms) << toString(b.technique);
    const Result m = measure(c, wrong, with(b.technique), ex);
    report(c, (std::string(toString(b.technique)) + " mirrored").c_str(), m);
    EXPECT_GT(m.rmsPenumbra, b.rms) << toString(b.technique) << " with the light mirrored";
  }
}

}  // namespace

// Bounds (penumbra RMS of V - V_quad), measured (PoCL, 128x96, 256^2 map):
// - bitmask 0.015, measured 0.0044: exact visibility up to its 256 light samples (1/256 = 0.004
//   of the light each; the max error, 0.018, is one pixel where about four samples straddle the
//   edge) and the quadrature's own 0.001;
// - MSSM4 0.08 (measured 0.060), PCSS 0.10 (0.081), CSSM 0.20 (0.159): REGRESSION bounds, the
//   measured value plus about a quarter. With the light 50 degrees off the receiver's normal the
//   receiver and the blocker are no longer parallel to the shadow map's plane, where filtering is
//   exact; no published bound applies. CSSM leaks most (mean signed error +0.133: its receiver
//   depth, tilted by 50 degrees in light space, falls on the series' rise).
//   MSSM4 measures 0.072 since its filter follows the cosine-weighted light
//   (MSSMOptions::cosineCentroid; 0.070 with it alone, 0.075 with the leak reduction alone): the
//   quadrature weighs the cap by the cosine too, and the move (0.53 degrees towards the normal
//   here) is the right one, but MSSM4's penumbra is already too bright in this configuration
//   (mean signed error +0.035 before the move, +0.024 now) and the shorter shadow adds to it. The
//   bound stays: a move the wrong way measures 0.056, and the scenes' own Embree truths measure
//   that way 2x worse on the lights that graze the ground (README, "The cosine-weighted light").
// Controls: hard shadows measure 0.255, above every bound; the mirrored light 0.43 for every
// technique (its shadow falls under the blocker instead, at x < -0.84).
TEST(PlanarOblique, LightFiftyDegreesOffTheNormal) {
  checkConfig(kOblique, {{ShadowTechnique::Bitmask, 0.015},
                         {ShadowTechnique::MSSM4, 0.08},
                         {ShadowTechnique::PCSS, 0.10},
                         {ShadowTechnique::CSSM, 0.20}});
}

// Bounds (penumbra RMS of V - V_quad), measured (PoCL, 128x96, 256^2 map):
// - bitmask 0.015, measured 0.0042 (as above);
// - PCSS 0.05 (measured 0.029: its receiver-plane bias follows the tilt), CSSM 0.07 (0.052),
//   MSSM4 0.12 (0.096; 0.0995 with the cosine centroid and the leak reduction, the defaults
//   since): REGRESSION bounds, measured plus about a quarter. MSSM4 is the worst here
//   by design: at 25 degrees its upper-bound blocker depth (Kneiphof 2017 eq. 19, weight
//   min(1, upperBoundTilt tan 25) = 0.93) narrows the penumbra (mean signed error +0.057); with
//   eq. 7 alone it measures 0.040, but eq. 7 darkens open tilted ground (test_shadow_accuracy.cpp),
//   the trade-off options.hpp documents.
// Controls: hard shadows 0.270; the mirrored light (50 degrees off the vertical, 25 off the
// receiver's normal on the other side) 0.476 for every technique.
TEST(PlanarOblique, ReceiverTiltedTwentyFiveDegrees) {
  checkConfig(kTilted, {{ShadowTechnique::Bitmask, 0.015},
                        {ShadowTechnique::MSSM4, 0.12},
                        {ShadowTechnique::PCSS, 0.05},
                        {ShadowTechnique::CSSM, 0.07}});
}
