// Polygon lights (lights.hpp LightShape::Polygon; shared.h pb_polygon_irradiance): irradiance on
// the host and the device against numerical integration, solid angle, light sample directions,
// median cut with the regions' own shapes (issue 4's 2% irradiance criterion), the light-set JSON
// file, and rendering / the Embree reference on a user's polygon light.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "common.hpp"
#include "support/extraction_checks.hpp"

using namespace penumbra;
using namespace penumbra::test;

namespace {

using namespace penumbra::test::dvec;

// Inside test of a convex spherical polygon with counter-clockwise unit vertices (lights.hpp):
// on the inner side of every edge's great circle.
bool inside(const std::vector<V3>& v, const D3& w) {
  const int n = int(v.size());
  for (int i = 0; i < n; ++i) {
    D3 a{v[i][0], v[i][1], v[i][2]}, b{v[(i + 1) % n][0], v[(i + 1) % n][1], v[(i + 1) % n][2]};
    if (dot(cross(a, b), w) < 0) return false;
  }
  return true;
}

// Plain numerical reference: midpoint quadrature over a fine lat-long grid about the polygon's
// direction (theta from the axis up to the bounding cap, phi all round), counting the cells whose
// centre is inside. Returns the solid angle and the irradiance on n (clamped cosine). Cells of
// ~0.05 degrees: the boundary cells' error is ~1e-4 relative for the polygons used.
struct Quad {
  double omega = 0, e = 0;
  D3 moment{0, 0, 0};
};
std::vector<Quad> integrate(const AreaLight& l, const std::vector<V3>& normals, int nt = 1000,
                            int np = 2000) {
  D3 d{l.direction[0], l.direction[1], l.direction[2]};
  D3 ref = std::fabs(d[1]) < 0.9 ? D3{0, 1, 0} : D3{1, 0, 0};
  D3 ex = cross(ref, d);
  double le = std::sqrt(dot(ex, ex));
  for (auto& c : ex) c /= le;
  D3 ey = cross(d, ex);
  double amax = std::acos(std::max(-1.0, double(l.cosAlpha) - 1e-4));
  std::vector<Quad> q(normals.size());
  for (int i = 0; i < nt; ++i) {
    double t0 = amax * i / nt, t1 = amax * (i + 1) / nt, th = 0.5 * (t0 + t1);
    double dw = (std::cos(t0) - std::cos(t1)) * 2 * M_PI / np;
    for (int j = 0; j < np; ++j) {
      double ph = 2 * M_PI * (j + 0.5) / np;
      D3 w;
      for (int c = 0; c < 3; ++c)
        w[c] = std::cos(th) * d[c] + std::sin(th) * (std::cos(ph) * ex[c] + std::sin(ph) * ey[c]);
      if (!inside(l.vertices, w)) continue;
      for (std::size_t k = 0; k < normals.size(); ++k) {
        const V3& n = normals[k];
        q[k].omega += dw;
        q[k].e += dw * std::max(0.0, n[0] * w[0] + n[1] * w[1] + n[2] * w[2]);
        for (int c = 0; c < 3; ++c) q[k].moment[c] += dw * w[c];
      }
    }
  }
  return q;
}

// A quadrilateral of angular half-widths (a, b) degrees about direction `dir`, turned by `roll`.
AreaLight rectLight(V3 dir, float a, float b, float roll = 0) {
  D3 d{dir[0], dir[1], dir[2]};
  D3 ref = std::fabs(d[1]) < 0.9 ? D3{0, 1, 0} : D3{1, 0, 0};
  D3 ex = cross(ref, d);
  double le = std::sqrt(dot(ex, ex));
  for (auto& c : ex) c /= le;
  D3 ey = cross(d, ex);
  double ta = std::tan(a * M_PI / 180), tb = std::tan(b * M_PI / 180);
  std::vector<V3> v;
  const double sx[4] = {-1, 1, 1, -1}, sy[4] = {-1, -1, 1, 1};
  for (int k = 0; k < 4; ++k) {
    double x = sx[k] * ta, y = sy[k] * tb;
    double xr = std::cos(roll) * x - std::sin(roll) * y, yr = std::sin(roll) * x + std::cos(roll) * y;
    v.push_back(unit(d[0] + xr * ex[0] + yr * ey[0], d[1] + xr * ex[1] + yr * ey[1],
                     d[2] + xr * ex[2] + yr * ey[2]));
  }
  return makePolygonLight(v, {1, 1, 1});
}

}  // namespace

// Lambert's formula with horizon clipping against quadrature: polygons fully above, crossing and
// fully below the horizon, a triangle and a pentagon. Tolerance 2e-3 of the polygon's solid angle
// (the quadrature's boundary cells) plus float rounding.
TEST(PolygonLights, IrradianceMatchesQuadrature) {
  std::vector<AreaLight> lights;
  lights.push_back(rectLight(unit(0, 1, 0), 20, 10));
  lights.push_back(rectLight(unit(1, 0.3, 0.2), 30, 15, 0.4f));
  lights.push_back(makePolygonLight({unit(0, 1, 0.2), unit(0.3, 1, -0.1), unit(-0.2, 1, -0.3)},
                                    {1, 1, 1}));
  std::vector<V3> penta;
  for (int k = 0; k < 5; ++k)
    penta.push_back(unit(0.5 * std::cos(2 * M_PI * k / 5), 0.5 * std::sin(2 * M_PI * k / 5), 1));
  lights.push_back(makePolygonLight(penta, {1, 1, 1}));
  const std::vector<V3> normals = {unit(0, 1, 0), unit(1, 0, 0), unit(0, 0, 1), unit(1, 1, 1),
                                   unit(0, -1, 0), unit(0.2, -0.1, 0.9), unit(-1, 0.1, 0),
                                   unit(0.9, 0.05, -0.3), unit(-0.3, -1, -0.2)};
  int crossing = 0, below = 0;
  for (auto& l : lights) {
    // solid angle: spherical excess vs quadrature
    std::vector<Quad> qs = integrate(l, normals);
    EXPECT_NEAR(l.solidAngle(), qs[0].omega, 2e-3 * qs[0].omega);
    for (std::size_t k = 0; k < normals.size(); ++k) {
      const V3& n = normals[k];
      const Quad& q = qs[k];
      float e = l.irradiance(n)[0];
      EXPECT_NEAR(e, q.e, 2e-3 * q.omega + 1e-6) << "normal " << n[0] << " " << n[1] << " " << n[2];
      int up = 0;
      for (auto& v : l.vertices) up += (v[0] * n[0] + v[1] * n[1] + v[2] * n[2]) > 0;
      crossing += up > 0 && up < int(l.vertices.size());
      below += up == 0;
      if (up == 0) EXPECT_EQ(e, 0.0f);
    }
  }
  // the cases the test is about are all present
  EXPECT_GE(crossing, 4);
  EXPECT_GE(below, 4);
}

// Solid angle of cube-face regions against the sum of their texels' solid angles (shared.h's
// texel formula at texel centres, summed in double on a fine face).
TEST(PolygonLights, CubeRegionSolidAngle) {
  const int m = 256;
  const int regions[][5] = {{0, 0, 0, 256, 256}, {2, 10, 30, 90, 31}, {5, 200, 0, 256, 130},
                            {3, 127, 127, 129, 129}};
  for (auto& g : regions) {
    std::vector<V3> corners;
    const int cx[4] = {g[1], g[3], g[3], g[1]}, cy[4] = {g[2], g[2], g[4], g[4]};
    for (int k = 0; k < 4; ++k) {
      float x, y, z;
      pb_cube_dir(g[0], 2.0f * cx[k] / m - 1, 2.0f * cy[k] / m - 1, &x, &y, &z);
      corners.push_back(unit(x, y, z));
    }
    AreaLight l = makePolygonLight(corners, {1, 1, 1});
    double sum = 0;
    const int sub = 4;  // sub-texels: the centre rule's error is ~1e-5 relative
    for (int y = g[2] * sub; y < g[4] * sub; ++y)
      for (int x = g[1] * sub; x < g[3] * sub; ++x)
        sum += pb_cube_texel_solid_angle(2.0f * (x + 0.5f) / (m * sub) - 1,
                                         2.0f * (y + 0.5f) / (m * sub) - 1, m * sub);
    EXPECT_NEAR(l.solidAngle(), sum, 1e-4 * sum) << g[0] << " " << g[1] << " " << g[2];
  }
  // a whole face is 4 pi / 6
  std::vector<V3> face;
  for (auto uv : {std::array<int, 2>{-1, -1}, {1, -1}, {1, 1}, {-1, 1}}) {
    float x, y, z;
    pb_cube_dir(4, float(uv[0]), float(uv[1]), &x, &y, &z);
    face.push_back(unit(x, y, z));
  }
  EXPECT_NEAR(makePolygonLight(face, {1, 1, 1}).solidAngle(), 4 * M_PI / 6, 1e-5);
}

// lightSampleDirections on a polygon: n distinct directions, all inside, their mean close to the
// polygon's normalized first moment, deterministic; rotating the polygon rotates the samples.
TEST(PolygonLights, SampleDirections) {
  AreaLight l = rectLight(unit(0.3, 1, -0.2), 25, 8, 0.3f);
  for (int n : {1, 7, 128, 1000}) {
    auto s = lightSampleDirections(l, n);
    ASSERT_EQ(int(s.size()), n);
    D3 mean{0, 0, 0};
    for (int i = 0; i < n; ++i) {
      D3 w{s[i][0], s[i][1], s[i][2]};
      EXPECT_NEAR(dot(w, w), 1.0, 1e-5);
      // inside, with float slack on the edge planes
      for (std::size_t k = 0; k < l.vertices.size(); ++k) {
        auto& a = l.vertices[k];
        auto& b = l.vertices[(k + 1) % l.vertices.size()];
        D3 g = cross({a[0], a[1], a[2]}, {b[0], b[1], b[2]});
        EXPECT_GT(dot(g, w), -1e-6) << n << " " << i;
      }
      for (int j = 0; j < i; ++j) EXPECT_NE(s[i], s[j]) << n << " " << i << " " << j;
      for (int c = 0; c < 3; ++c) mean[c] += w[c] / n;
    }
    EXPECT_EQ(s, lightSampleDirections(l, n));  // deterministic
    if (n >= 128) {
      Quad q = integrate(l, {{0, 1, 0}}, 600, 1200)[0];
      double ml = std::sqrt(dot(q.moment, q.moment)), sl = std::sqrt(dot(mean, mean));
      double cosang = dot(q.moment, mean) / (ml * sl);
      std::printf("[ measured ] %d samples: mean direction %.4f degrees from the first moment\n",
                  n, std::acos(std::min(1.0, cosang)) * 180 / M_PI);
      // The light is ~50 x 16 degrees: one stratum of n samples is ~sqrt(800 / n) degrees wide
      // (2.5 at n = 128, 0.9 at 1000); the mean must sit well inside a stratum of the moment
      // (measured 0.42 and 0.02 degrees).
      const double bound = n >= 1000 ? 0.1 : 1.0;
      EXPECT_GT(cosang, std::cos(bound * M_PI / 180)) << n;
    }
  }
  // rotation: the polygon turned by 90 degrees about +y gives the turned samples
  AreaLight r = l;
  for (auto& v : r.vertices) v = {v[2], v[1], -v[0]};
  r.direction = {l.direction[2], l.direction[1], -l.direction[0]};
  auto a = lightSampleDirections(l, 64), b = lightSampleDirections(r, 64);
  for (int i = 0; i < 64; ++i) {
    EXPECT_NEAR(b[i][0], a[i][2], 1e-5);
    EXPECT_NEAR(b[i][1], a[i][1], 1e-5);
    EXPECT_NEAR(b[i][2], -a[i][0], 1e-5);
  }
  // the rotation argument moves the samples and keeps them inside
  auto c = lightSampleDirections(l, 64, 1.0f);
  EXPECT_NE(a, c);
  for (auto& w : c) {
    for (std::size_t k = 0; k < l.vertices.size(); ++k) {
      auto& p = l.vertices[k];
      auto& q = l.vertices[(k + 1) % l.vertices.size()];
      EXPECT_GT(dot(cross({p[0], p[1], p[2]}, {q[0], q[1], q[2]}), {w[0], w[1], w[2]}), -1e-6);
    }
  }
}

namespace {

// The 26 normals of issue 4: 6 axes, 12 edge and 8 corner directions of a cube.
std::vector<V3> normals26() {
  std::vector<V3> out;
  for (int x = -1; x <= 1; ++x)
    for (int y = -1; y <= 1; ++y)
      for (int z = -1; z <= 1; ++z)
        if (x || y || z) out.push_back(unit(x, y, z));
  return out;
}

std::vector<Environment> everyMap() {
  std::vector<Environment> envs;
  for (const char* rel : kMaps) envs.push_back(loadEnvironment(data(rel)));
  envs.push_back(builtinEnvironment());
  return envs;
}

// Worst relative error of lights + ambient against the map's irradiance on the 26 normals, over
// the RGB channels and for luminance.
struct IrrError {
  double rgb = 0, lum = 0;
};
IrrError irradianceError(const Environment& env, const LightSet& set) {
  IrrError r;
  for (auto& n : normals26()) {
    double e[3];
    env.irradiance(n.data(), e);
    auto s = set.irradiance(n);
    for (int c = 0; c < 3; ++c) r.rgb = std::max(r.rgb, std::fabs(s[c] / e[c] - 1));
    r.lum = std::max(r.lum, std::fabs(double(luminance(s.data())) / luminance(e) - 1));
  }
  return r;
}

}  // namespace

// Median cut with polygon shape where its premise holds: a map of constant radiance per cube face
// (six colours), so every region is uniform and each polygon light is exactly its region. Lights
// alone (no ambient) then give the map's irradiance on the 26 normals to the cube resampling's
// error at the face edges (the equirect texels there mix two faces), while caps replacing the
// same regions are wrong where they straddle a normal's horizon. Asserted: polygons within 1%;
// caps measured beside.
TEST(PolygonLights, MedianCutExactOnRegionUniformMap) {
  Environment env;
  env.source = "six-face map";
  env.equirect = Image(256, 128, 3);
  const float faceRadiance[6][3] = {{1, 2, 3}, {4, 1, 1}, {8, 8, 6}, {0.5f, 0.5f, 0.4f},
                                    {2, 1, 2}, {1, 3, 1}};
  for (int t = 0; t < 128; ++t)
    for (int x = 0; x < 256; ++x) {
      float d[3], u, v;
      pb_equirect_dir(x + 0.5f, t + 0.5f, 256, 128, &d[0], &d[1], &d[2]);
      int f = pb_cube_face(d[0], d[1], d[2], &u, &v);
      for (int c = 0; c < 3; ++c) env.equirect.at(x, t, c) = faceRadiance[f][c];
    }
  for (int n : {8, 32}) {
    ExtractOptions eo;
    eo.ambient = false;
    eo.medianCut.lights = n;
    eo.medianCut.faceSize = 64;
    eo.medianCut.shape = LightShape::Polygon;
    IrrError poly = irradianceError(env, extractLights(ctx(), env, eo));
    eo.medianCut.shape = LightShape::Cap;
    IrrError cap = irradianceError(env, extractLights(ctx(), env, eo));
    std::printf("[ measured ] six-face map, median cut %d, lights only: worst irradiance error on "
                "26 normals (RGB): cap %.2f%%, polygon %.2f%%\n", n, 100 * cap.rgb, 100 * poly.rgb);
    EXPECT_LT(poly.rgb, 0.01) << n;
    EXPECT_LT(poly.rgb, cap.rgb) << n;
  }
}

namespace {

// Median cut with polygon shape on every map and the builtin, at 32 lights (8 and 64 were measured
// too, see the report; left out to keep the suite short): every single-region light is a polygon
// and every merged light a cap. Judged in parts, none of which holds by construction ("lights +
// ambient give the map's power" holds for any lights, the ambient being the map minus them):
//   - the lights alone carry the map's power within 1% (issue 4), against the test's own
//     quadrature (tests/support/extraction_checks.hpp);
//   - the lights alone against the map's irradiance on the 26 normals: issue 4's 2% is not met
//     (KnownGap below): median-cut regions are not uniform (cut at the energy median, a bright
//     source shares its region with dark texels), a uniform polygon moves the region's first
//     moment to the polygon's centroid, and on a normal that sees part of a region the error is
//     large (lights.hpp MedianCutOptions::shape). Measured worst luminance 80 / 35 / 104 / 49%
//     (courtyard, interior, studio, builtin: dim normals), mean over the 26 normals 11.5 / 11.3 /
//     13.4 / 10.4%. The worst does not separate the set from its controls (no lights is 100%),
//     so the RegressionBound is on the mean: 17% (the 13.4% + 3.6 points); the controls' means:
//     no lights 100%, directions negated 39-164%, power halved 47-48%;
//   - the ambient (the default irradiance map) alone against the map minus the polygons, the
//     polygons' irradiance by the test's quadrature over their own shape: within 2% (measured
//     0.14-0.59%; a residual that subtracted caps for the polygons would miss by their
//     difference). Controls (ambient made for no lights / negated / halved, beside the real
//     lights): 160-215% / 63-1025% / 80-107%.
// Negative controls, each asserted to fail its part.
constexpr double kIssue4Bound = 0.02;
constexpr double kPolygonLightsRegressionBound = 0.17;

// Per map: the lights' worst (first) and mean (second) luminance error; with `controls`, the
// other parts and the controls asserted.
std::pair<double, double> polygonMedianCutErrors(const std::vector<Environment>& envs,
                                                 bool controls) {
  std::pair<double, double> worst{0, 0};
  for (auto& env : envs) {
    ExtractOptions eo;
    eo.medianCut.lights = 32;
    eo.medianCut.shape = LightShape::Polygon;
    LightSet set = extractLights(ctx(), env, eo);
    int polygons = 0;
    for (auto& l : set.lights) {
      polygons += l.shape == LightShape::Polygon;
      EXPECT_EQ(l.shape == LightShape::Polygon, l.regions.size() == 1) << env.source;
    }
    EXPECT_GT(polygons, 0) << env.source;
    const xref::Target t = xref::mapTarget(xref::mapSamples(env), xref::testNormals());
    const xref::LightsError e = xref::lightsError(set, t);
    worst = {std::max(worst.first, e.worstLum), std::max(worst.second, e.meanLum)};
    EXPECT_LT(e.power, 0.01) << env.source;
    if (!controls) continue;
    const double amb = xref::ambientError(set, t);
    const auto ctlAmb = xref::ambientControls(ctx(), env, set, eo.ambientOptions, t);
    const xref::LightsError c[3] = {xref::lightsError(xref::withoutLights(set), t),
                                    xref::lightsError(xref::negated(set), t),
                                    xref::lightsError(xref::halved(set), t)};
    std::printf("[ measured ] %s median cut 32 (%d polygons of %zu lights), lights alone: power "
                "%.3f%%, irradiance error on 26 normals (luminance) worst %.2f%% mean %.2f%%; "
                "controls (no lights / negated / halved): mean %.1f%% / %.1f%% / %.1f%%. Ambient "
                "vs map - polygons: %.2f%%; controls %.1f%% / %.1f%% / %.1f%%\n",
                env.source.c_str(), polygons, set.lights.size(), 100 * e.power,
                100 * e.worstLum, 100 * e.meanLum, 100 * c[0].meanLum, 100 * c[1].meanLum,
                100 * c[2].meanLum, 100 * amb, 100 * ctlAmb[0], 100 * ctlAmb[1],
                100 * ctlAmb[2]);
    for (auto& k : c) EXPECT_GT(k.meanLum, kPolygonLightsRegressionBound) << env.source;
    EXPECT_LT(amb, kIssue4Bound) << env.source;
    for (double k : ctlAmb) EXPECT_GT(k, kIssue4Bound) << env.source;
  }
  return worst;
}

}  // namespace

TEST(PolygonLights, RegressionBoundMedianCutOnEveryMap) {
  EXPECT_LT(polygonMedianCutErrors(everyMap(), true).second, kPolygonLightsRegressionBound);
}

// Issue 4's 2% for the polygon lights alone: not met (above; checked on studio, the map whose
// regions are furthest from uniform: measured worst 104%). Fails the day it is met: then assert it
// above.
TEST(PolygonLights, MedianCutKnownGapToIssue4Bound) {
  EXPECT_GT(polygonMedianCutErrors({loadEnvironment(data("envmaps/studio.exr"))}, false).first,
            kIssue4Bound);
}

// Polygon median cut is deterministic (bit-identical JSON) and follows the map under a
// cube-face-aligned 90-degree rotation: every light of the turned map on a side face is a light
// of the original with its vertices turned (within 1e-4) and the same power (within 1%). Lights on
// the +-Y faces are left out: a turn about y turns those faces in their own plane, and median cut's
// split of a square region (the face itself) then need not turn with it (measured: the -Y face is
// cut at x = 32 in both maps): a property of the cut, not of the polygons.
TEST(PolygonLights, MedianCutDeterministicAndRotates) {
  Environment env = builtinEnvironment(128);
  MedianCutOptions mc;
  mc.lights = 16;
  mc.faceSize = 64;
  mc.shape = LightShape::Polygon;
  LightSet a = extractMedianCut(ctx(), env, mc);
  EXPECT_EQ(a.toJson(), extractMedianCut(ctx(), env, mc).toJson());
  Environment rot = env;
  rot.rotationYDeg = 90.0f;
  LightSet r = extractMedianCut(ctx(), rot, mc);
  ASSERT_EQ(r.lights.size(), a.lights.size());
  // R: +x turns towards -z (Environment::rotationYDeg): (x, y, z) -> (z, y, -x)... either sense
  // is tried once for the whole set, the better kept, and then every light must match.
  int bestMatched = -1;
  for (float sgn : {1.0f, -1.0f}) {
    int matched = 0;
    for (auto& lr : r.lights) {
      if (lr.shape != LightShape::Polygon || lr.regions[0][0] == 2 || lr.regions[0][0] == 3)
        continue;
      for (auto& la : a.lights) {
        if (la.shape != LightShape::Polygon || la.vertices.size() != lr.vertices.size()) continue;
        // same vertex set, turned
        bool all = true;
        for (auto& v : la.vertices) {
          V3 t = {sgn * v[2], v[1], -sgn * v[0]};
          bool found = false;
          for (auto& w : lr.vertices)
            found |= std::fabs(w[0] - t[0]) < 1e-4f && std::fabs(w[1] - t[1]) < 1e-4f &&
                     std::fabs(w[2] - t[2]) < 1e-4f;
          all &= found;
        }
        if (all && std::fabs(lr.power[1] / la.power[1] - 1) < 0.01f) {
          ++matched;
          break;
        }
      }
    }
    bestMatched = std::max(bestMatched, matched);
  }
  int polys = 0;
  for (auto& l : r.lights)
    polys += l.shape == LightShape::Polygon && l.regions[0][0] != 2 && l.regions[0][0] != 3;
  EXPECT_GE(polys, 8);
  EXPECT_EQ(bestMatched, polys);
}

// Light-set JSON: what toJson writes loads back (caps and polygons, the ambient), and every bad
// input is refused with a message naming the source and the light.
TEST(PolygonLights, LightSetJsonRoundTripAndBadInput) {
  LightSet set;
  AreaLight cap;
  cap.direction = unit(0.2, 1, 0.1);
  cap.cosAlpha = std::cos(0.1f);
  cap.setPower({1, 2, 3});
  set.lights.push_back(cap);
  set.lights.push_back(rectLight(unit(1, 0.5, 0), 10, 20, 0.2f));
  set.ambientSH[0] = {0.5f, 0.25f, 0.125f};
  set.hasAmbient = true;
  LightSet back = lightSetFromJson(set.toJson(), "roundtrip");
  ASSERT_EQ(back.lights.size(), 2u);
  EXPECT_TRUE(back.hasAmbient);
  EXPECT_EQ(back.ambientSH[0][1], 0.25f);
  for (int i = 0; i < 2; ++i) {
    EXPECT_EQ(back.lights[i].shape, set.lights[i].shape);
    EXPECT_NEAR(back.lights[i].solidAngle(), set.lights[i].solidAngle(),
                1e-5 * set.lights[i].solidAngle());
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(back.lights[i].power[c], set.lights[i].power[c], 1e-5 * set.lights[i].power[c]);
      EXPECT_NEAR(back.lights[i].direction[c], set.lights[i].direction[c], 1e-6);
    }
    auto n = unit(0.3, 1, 0.2);
    EXPECT_NEAR(back.lights[i].irradiance(n)[1], set.lights[i].irradiance(n)[1],
                1e-5 * set.lights[i].irradiance(n)[1] + 1e-9);
  }
  // a rectangle written by hand
  LightSet rect = lightSetFromJson(R"({"lights": [{"shape": "rect", "direction": [0, 1, 0],
      "up": [0, 0, 1], "half_angles_deg": [10, 20], "radiance": [1, 1, 1]}]})", "rect");
  ASSERT_EQ(rect.lights.size(), 1u);
  EXPECT_EQ(rect.lights[0].shape, LightShape::Polygon);
  EXPECT_EQ(rect.lights[0].vertices.size(), 4u);
  const char* bad[] = {
      R"({"lights": [{"direction": [0, 1, 0], "radiance": [1, 1, 1]}]})",              // no angle
      R"({"lights": [{"direction": [0, 1, 0], "half_angle_deg": 5}]})",                 // no
                                                                                        // radiance
      R"({"lights": [{"direction": [0, 1, 0], "half_angle_deg": 5, "radiance": [1, -1, 1]}]})",
      R"({"lights": [{"direction": [0, 0, 0], "half_angle_deg": 5, "radiance": [1, 1, 1]}]})",
      R"({"lights": [{"direction": [0, 1, 0], "half_angle_deg": 95, "radiance": [1, 1, 1]}]})",
      R"({"lights": [{"direction": [0, 1, 0], "half_angle_deg": NaN, "radiance": [1, 1, 1]}]})",
      R"({"lights": [{"shape": "polygon", "vertices": [[0,1,0],[0.1,1,0]], "radiance": [1,1,1]}]})",
      R"({"lights": [{"shape": "polygon", "vertices": [[0,1,0],[0.2,1,0],[0.05,1,0.05],[0,1,0.2]],
          "radiance": [1,1,1]}]})",  // non-convex (reflex vertex 2)
      R"({"lights": [{"shape": "star", "radiance": [1,1,1]}]})",
      R"({"lights": [{"direction": [0, 1, 0], "half_angle_deg": 5, "radiance": [1, 1, 1]})",
      R"({"no_lights": []})",
  };
  // too many vertices: a convex (PB_MAX_POLY_VERTS + 1)-gon
  std::string many = R"({"lights": [{"shape": "polygon", "radiance": [1,1,1], "vertices": [)";
  for (int k = 0; k <= PB_MAX_POLY_VERTS; ++k) {
    const double t = 2 * M_PI * k / (PB_MAX_POLY_VERTS + 1);
    many += (k ? ", [" : "[") + std::to_string(std::cos(t)) + ", 3, " + std::to_string(std::sin(t)) + "]";
  }
  many += "]}]}";
  std::vector<std::string> texts(std::begin(bad), std::end(bad));
  texts.push_back(many);
  for (const std::string& text : texts) {
    try {
      lightSetFromJson(text, "user.json");
      ADD_FAILURE() << "accepted: " << text;
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::BadInput);
      EXPECT_NE(std::string(e.what()).find("user.json"), std::string::npos) << e.what();
    }
  }
  try {
    loadLightSet("/nonexistent/lights.json");
    ADD_FAILURE() << "missing file accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/lights.json"), std::string::npos);
  }
}

// The device shading of a polygon light (kernels/render/shade.cl, shared.h's
// pb_polygon_irradiance): a quad facing +y lit by a rectangle light that crosses its horizon, no
// shadows, equals albedo / pi times the host's irradiance; every technique runs on the same light
// and gives finite pixels no brighter than the unshadowed frame.
TEST(PolygonLights, RenderShadesPolygonExactlyAndEveryTechniqueRuns) {
  Scene scene;
  scene.meshes.push_back(planarQuad("floor", -1, 1, -1, 1, 0));
  const Camera cam = topDownCamera(30);
  LightSet set;
  set.lights.push_back(rectLight(unit(1, 0.15, 0), 30, 12));
  Environment env = builtinEnvironment(64);
  Renderer r(ctx());
  RenderOptions opt;
  opt.width = 17;
  opt.height = 9;
  opt.shadowMapSize = 64;
  opt.shadows = ShadowTechnique::None;
  Image a = r.render(scene, cam, set, env, opt).image;
  const float e = set.lights[0].irradiance({0, 1, 0})[0];
  ASSERT_GT(e, 0);
  const auto& albedo = scene.meshes[0].albedo;
  int geometry = 0;
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) {
      if (a.at(x, y, 3) == 0) continue;
      ++geometry;
      EXPECT_NEAR(a.at(x, y, 0), albedo[0] * e / M_PI, 1e-4 * e);
    }
  EXPECT_GT(geometry, 0);
  for (ShadowTechnique t : {ShadowTechnique::Hard, ShadowTechnique::PCSS, ShadowTechnique::CSSM,
                            ShadowTechnique::MSSM4, ShadowTechnique::MSSM6,
                            ShadowTechnique::Brute, ShadowTechnique::Bitmask,
                            ShadowTechnique::AreaApprox}) {
    opt.shadows = t;
    Image b = r.render(scene, cam, set, env, opt).image;
    for (int y = 0; y < b.height; ++y)
      for (int x = 0; x < b.width; ++x) {
        EXPECT_TRUE(std::isfinite(b.at(x, y, 0)));
        EXPECT_LE(b.at(x, y, 0), a.at(x, y, 0) * 1.0001f + 1e-6f);
      }
  }
}

TEST(PolygonLights, EmbreeReferenceAgreesWithBruteForceOnAPolygonLight) {
  // A tilted rectangle light over a floor with a small blocker: the Embree light-set reference
  // samples the polygon by rejection from its bounding cap (src/reference/reference.cpp), brute
  // force takes lightSampleDirections' stratified polygon samples, so the two share only the
  // light's shape. Measured 0.23% relative RMSE (4096 spp reference noise plus brute force's map
  // texels). The bound, 1%, leaves room for other devices' rounding; the same light as its bounding
  // cap (same radiance over the cap's larger solid angle; measured 121%) must miss it by far, so
  // the test sees a polygon mistaken for a cap.
  Scene scene;
  scene.meshes.push_back(planarQuad("floor", -1, 1, -1, 1, 0));
  scene.meshes.push_back(planarQuad("blocker", -0.25f, 0.25f, -0.25f, 0.25f, 0.3f));
  const Camera cam = topDownCamera(40);
  LightSet set;
  set.lights.push_back(rectLight(unit(0.3, 1, 0.2), 25, 10, 0.4f));
  Environment env = builtinEnvironment(64);
  Renderer r(ctx());
  RenderOptions opt;
  opt.width = 48;
  opt.height = 48;
  opt.shadowMapSize = 256;
  opt.shadows = ShadowTechnique::Brute;
  opt.brute.samples = 1024;
  Image b = r.render(scene, cam, set, env, opt).image;
  ReferenceOptions ro;
  ro.width = opt.width;
  ro.height = opt.height;
  ro.spp = 4096;
  Image ref = referenceLights(scene, cam, set, env, ro);
  const ImageMetrics m = compareImages(b, ref);
  std::printf("polygon light: brute 1024 vs Embree light-set reference: relative RMSE %.4f\n",
              m.relativeRmse);
  EXPECT_LT(m.relativeRmse, 0.01);
  // The bitmask technique keeps the disk samples of the bounding cap that fall inside the polygon
  // (kernels/shadows/bitmask.cl, bitmask_resolve): 4 tan25 tan10 / (pi (tan^2 25 + tan^2 10)) = 42%
  // of 1024 here. The same bound holds.
  RenderOptions bo = opt;
  bo.shadows = ShadowTechnique::Bitmask;
  bo.bitmask.lightSamples = 1024;
  const ImageMetrics mb = compareImages(r.render(scene, cam, set, env, bo).image, ref);
  std::printf("polygon light: bitmask 1024 vs Embree light-set reference: relative RMSE %.4f\n",
              mb.relativeRmse);
  EXPECT_LT(mb.relativeRmse, 0.01);
  LightSet capSet = set;
  capSet.lights[0].shape = LightShape::Cap;
  capSet.lights[0].vertices.clear();
  const ImageMetrics mc = compareImages(r.render(scene, cam, capSet, env, opt).image, ref);
  std::printf("bounding cap in place of the polygon: relative RMSE %.4f\n", mc.relativeRmse);
  EXPECT_GT(mc.relativeRmse, 0.05);
  // The blocker's shadow is in both: some floor pixel is darker than the unshadowed value.
  const float e = set.lights[0].irradiance({0, 1, 0})[0];
  float darkest = 1e30f;
  for (int y = 0; y < ref.height; ++y)
    for (int x = 0; x < ref.width; ++x)
      if (ref.at(x, y, 3) > 0) darkest = std::min(darkest, ref.at(x, y, 0));
  EXPECT_LT(darkest, 0.5f * scene.meshes[0].albedo[0] * e / float(M_PI));
}
