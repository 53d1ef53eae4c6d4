// Area lights: the cap irradiance formula, and median-cut extraction on the device (its lights
// judged against the test's own quadrature of the map, with negative controls).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cmath>
#include <vector>

#include "common.hpp"
#include "support/extraction_checks.hpp"

using namespace penumbra;
using namespace penumbra::test;

namespace {

// Irradiance from a unit-radiance cap by brute-force quadrature over the cap (cosine clamped).
double capIrradianceNumeric(double alpha, double beta) {
  const int nt = 400, np = 800;
  double sum = 0;
  // axis in the x-z plane at angle beta from the normal (z)
  double ax = std::sin(beta), az = std::cos(beta);
  for (int i = 0; i < nt; ++i) {
    double th0 = alpha * i / nt, th1 = alpha * (i + 1) / nt, th = 0.5 * (th0 + th1);
    double dw_ring = (std::cos(th0) - std::cos(th1)) * 2 * M_PI / np;
    for (int j = 0; j < np; ++j) {
      double ph = 2 * M_PI * (j + 0.5) / np;
      // direction around the axis: local (sin th cos ph, sin th sin ph, cos th), rotate about y
      double lx = std::sin(th) * std::cos(ph), ly = std::sin(th) * std::sin(ph), lz = std::cos(th);
      double z = -lx * ax + lz * az;  // component along the normal after rotating by beta
      (void)ly;
      if (z > 0) sum += z * dw_ring;
    }
  }
  return sum;
}

}  // namespace

TEST(Lights, CapIrradianceMatchesQuadrature) {
  for (double alphaDeg : {2.0, 15.0, 40.0, 75.0})
    for (double betaDeg : {0.0, 30.0, 60.0, 85.0, 100.0, 120.0, 160.0}) {
      double a = alphaDeg * M_PI / 180, b = betaDeg * M_PI / 180;
      double exact = capIrradianceNumeric(a, b);
      double got = pb_cap_irradiance(float(std::cos(a)), float(std::cos(b)));
      double scale = M_PI * std::sin(a) * std::sin(a);  // irradiance at normal incidence
      EXPECT_NEAR(got / scale, exact / scale, 2e-3) << "alpha " << alphaDeg << " beta " << betaDeg;
    }
}

TEST(Lights, FullyAboveHorizonIsKneiphofEq15) {
  double a = 10 * M_PI / 180, b = 30 * M_PI / 180;
  EXPECT_NEAR(pb_cap_irradiance(float(std::cos(a)), float(std::cos(b))),
              M_PI * std::sin(a) * std::sin(a) * std::cos(b), 1e-6);
}

namespace {

const float kNormals[8][3] = {{0, 1, 0},  {0, -1, 0}, {1, 0, 0},           {-1, 0, 0},
                              {0, 0, 1},  {0, 0, -1}, {0.577f, 0.577f, 0.577f}, {-0.6f, 0.0f, 0.8f}};

double lum3(const std::array<double, 3>& e) {
  double a[3] = {e[0], e[1], e[2]};
  return luminance(a);
}

// Power (exact up to fixed-point rounding) and, for every normal, the part of the irradiance that
// the cap model must reproduce exactly: E(n) - E(-n) = n . integral of L w dw, the region's first
// moment, which cos(alpha) = 2R - 1 preserves (kernels/environment/extract.cl).
void expectConserves(const Environment& env, const LightSet& set, const std::string& what) {
  double p[3];
  env.power(p);
  auto lp = set.power();
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(lp[c] / p[c], 1.0, 0.01) << what << " power channel " << c;
  for (auto& n : kNormals) {
    float m[3] = {-n[0], -n[1], -n[2]};
    double ep[3], em[3];
    env.irradiance(n, ep);
    env.irradiance(m, em);
    double envDiff = luminance(ep) - luminance(em), envSum = luminance(ep) + luminance(em);
    double lightDiff = lum3(set.irradiance({n[0], n[1], n[2]})) - lum3(set.irradiance({m[0], m[1], m[2]}));
    EXPECT_NEAR(lightDiff, envDiff, 0.01 * envSum) << what << " normal " << n[0] << "," << n[1] << "," << n[2];
  }
}

}  // namespace

TEST(MedianCut, ConservesPowerAndFirstMomentOnEveryMap) {
  for (const char* rel : kMaps) {
    Environment env = loadEnvironment(data(rel));
    MedianCutOptions mc;
    mc.lights = 32;
    LightSet set = extractMedianCut(ctx(), env, mc);
    ASSERT_EQ(set.lights.size(), 32u) << rel;
    expectConserves(env, set, rel);
  }
  Environment sky = builtinEnvironment();
  expectConserves(sky, extractMedianCut(ctx(), sky, {}), "builtin");
}

namespace {

// Median cut's lights alone (no ambient), against the test's own quadrature of the map
// (tests/support/extraction_checks.hpp), on the 26 normals of issue 4: the worst relative
// luminance error. A cap light is exact for every normal that sees all of it (previous test);
// only regions straddling the normal's horizon, clipped as caps instead of as their real shapes,
// differ. Issue 2's bound is 1%: met at 256 lights (asserted; measured worst 0.94%, studio), not
// at 32, where the large regions of real maps straddle the horizon of axis-aligned normals
// (measured worst 5.6% studio, 5.0% builtin, 3.1% courtyard and interior: KnownGap below).
// RegressionBound at 32 lights: the measured 5.6% + 1.4 points (7%). Power: 1% (issue 4),
// measured 0.02% worst. The negative controls (no lights, directions negated, power halved) miss
// by 100%, 91-850% and 50-51% (see [ control ]) and are asserted to fail each bound.
constexpr double kIssue2Bound = 0.01;
constexpr double kMedianCut32RegressionBound = 0.07;

// The worst error over every map and the built-in sky at `lights` lights; with `controls`, each
// control is asserted to fail `bound`.
double medianCutWorstError(int lights, bool controls, double bound) {
  std::vector<Environment> envs;
  for (const char* rel : kMaps) envs.push_back(loadEnvironment(data(rel)));
  envs.push_back(builtinEnvironment());
  double worst = 0;
  for (auto& env : envs) {
    MedianCutOptions mc;
    mc.lights = lights;
    const LightSet set = extractMedianCut(ctx(), env, mc);
    const xref::Target t = xref::mapTarget(xref::mapSamples(env), xref::testNormals());
    const xref::LightsError e = xref::lightsError(set, t);
    std::printf("[ measured ] %s median cut %d, lights alone vs quadrature: power %.3f%%, worst "
                "luminance irradiance error %.2f%%\n",
                env.source.c_str(), lights, 100 * e.power, 100 * e.worstLum);
    EXPECT_LT(e.power, 0.01) << env.source;
    worst = std::max(worst, e.worstLum);
    if (!controls) continue;
    const double c[3] = {xref::lightsError(xref::withoutLights(set), t).worstLum,
                         xref::lightsError(xref::negated(set), t).worstLum,
                         xref::lightsError(xref::halved(set), t).worstLum};
    std::printf("[ control ] %s median cut %d: no lights / negated / halved: %.1f%% / %.1f%% / "
                "%.1f%%\n",
                env.source.c_str(), lights, 100 * c[0], 100 * c[1], 100 * c[2]);
    for (double v : c) EXPECT_GT(v, bound) << env.source << " control";
  }
  return worst;
}

}  // namespace

TEST(MedianCut, IrradianceOnNormalsAt256LightsMeetsIssue2) {
  EXPECT_LT(medianCutWorstError(256, true, kIssue2Bound), kIssue2Bound);
}

TEST(MedianCut, RegressionBoundIrradianceOnNormalsAt32Lights) {
  EXPECT_LT(medianCutWorstError(32, true, kMedianCut32RegressionBound), kMedianCut32RegressionBound);
}

// Issue 2's 1% at 32 lights: not met (above: measured worst 5.6%, studio). Fails the day it is:
// then assert the 1% there.
TEST(MedianCut, IrradianceOnNormalsAt32LightsKnownGapToIssue2Bound) {
  EXPECT_GT(medianCutWorstError(32, false, 0), kIssue2Bound);
}

TEST(MedianCut, AnyLightCount) {
  Environment env = loadEnvironment(data("envmaps/studio.exr"));
  double p[3];
  env.power(p);
  for (int n : {1, 2, 5, 6, 7, 33, 100}) {
    MedianCutOptions mc;
    mc.lights = n;
    mc.faceSize = 64;
    mc.mergeAcrossFaces = false;  // the cut's count: merging joins studio's edge lamps (99 of 100)
    mc.peakRatio = 0;  // every light from a region (PeakLights: bright sources apart)
    LightSet set = extractMedianCut(ctx(), env, mc);
    EXPECT_EQ(int(set.lights.size()), n);
    auto lp = set.power();
    EXPECT_NEAR(lp[1] / p[1], 1.0, 0.01) << n << " lights";
    for (auto& l : set.lights) {
      float len = std::sqrt(l.direction[0] * l.direction[0] + l.direction[1] * l.direction[1] +
                            l.direction[2] * l.direction[2]);
      EXPECT_NEAR(len, 1.0f, 1e-4f);
      EXPECT_GT(l.cosAlpha, 0.0f);  // alpha < 90 degrees
      EXPECT_LT(l.cosAlpha, 1.0f);
      EXPECT_FALSE(l.regions.empty());
    }
  }
}

TEST(MedianCut, SingleBrightDiscBecomesOneSmallLight) {
  // A black map with one disc of radius 3 degrees: the brightest light points at it, its
  // half-angle is about the disc's (uniform disc: cos a = 2R - 1 recovers the radius exactly).
  Environment env;
  env.source = "disc";
  env.equirect = Image(1024, 512, 3, 0.0f);
  const float dir[3] = {0.3f, 0.8f, -0.52f};
  float len = std::sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
  const float cosR = std::cos(3.0f * float(M_PI) / 180);
  for (int t = 0; t < 512; ++t)
    for (int s = 0; s < 1024; ++s) {
      float x, y, z;
      pb_equirect_dir(s + 0.5f, t + 0.5f, 1024, 512, &x, &y, &z);
      if ((x * dir[0] + y * dir[1] + z * dir[2]) / len > cosR)
        for (int c = 0; c < 3; ++c) env.equirect.at(s, t, c) = 100.0f;
    }
  MedianCutOptions mc;
  mc.lights = 8;
  LightSet set = extractMedianCut(ctx(), env, mc);
  const AreaLight* best = &set.lights[0];
  for (auto& l : set.lights)
    if (l.power[1] > best->power[1]) best = &l;
  // a median cut splits the disc itself, so compare the union: the power-weighted mean direction
  double m[3] = {0, 0, 0}, tot = 0;
  for (auto& l : set.lights)
    for (int k = 0; k < 3; ++k) m[k] += l.power[1] * l.direction[k], tot += k == 0 ? l.power[1] : 0;
  double ml = std::sqrt(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]);
  double cosErr = (m[0] * dir[0] + m[1] * dir[1] + m[2] * dir[2]) / (ml * len);
  EXPECT_GT(cosErr, std::cos(0.5 * M_PI / 180));
  double p[3];
  env.power(p);
  EXPECT_NEAR(tot / p[1], 1.0, 0.005);
  EXPECT_LT(best->halfAngle() * 180 / M_PI, 3.5);
}

TEST(MedianCut, Deterministic) {
  Environment env = loadEnvironment(data("envmaps/interior.exr"));
  LightSet a = extractMedianCut(ctx(), env, {});
  LightSet b = extractMedianCut(ctx(), env, {});
  EXPECT_EQ(a.toJson(), b.toJson());
}

TEST(MedianCut, RefusesImpossibleSizes) {
  Environment env = builtinEnvironment(64);
  for (auto bad : {std::make_pair(0, 64), std::make_pair(-3, 64), std::make_pair(32, 0),
                   std::make_pair(32, 5000), std::make_pair(7, 1), std::make_pair(5000, 256)}) {
    MedianCutOptions mc;
    mc.lights = bad.first;
    mc.faceSize = bad.second;
    try {
      extractMedianCut(ctx(), env, mc);
      FAIL() << bad.first << " lights, face " << bad.second << " accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::BadInput);
    }
  }
}

TEST(MedianCut, NanInfNegativeMapGivesFiniteLights) {
  Environment env = loadEnvironment(data("envmaps/bad/nan_inf_negative.exr"));
  LightSet set = extractMedianCut(ctx(), env, {});
  for (auto& l : set.lights)
    for (int c = 0; c < 3; ++c) {
      EXPECT_TRUE(std::isfinite(l.radiance[c]));
      EXPECT_GE(l.radiance[c], 0.0f);
    }
}
