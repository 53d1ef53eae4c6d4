// The light count to an error target (issue 13, item 5): lightSetProbeError, the cheap predictor
// of the error a light set leaves under occlusion, and extractToTargetError's search. The
// predictor against the measured floor (Embree) is in bench/results/light_count.md.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "common.hpp"

using namespace penumbra;
using namespace penumbra::test;

namespace {

constexpr double kPi = 3.14159265358979323846;

// A black map with one uniform disc of radiance `radiance` and half-angle `halfDeg` around the
// unit direction `d` (texel centres inside the cone).
Environment discMap(const std::array<float, 3>& d, double halfDeg, float radiance) {
  Environment env;
  env.source = "disc";
  env.equirect = Image(512, 256, 3);
  const double cosA = std::cos(halfDeg * kPi / 180.0);
  for (int t = 0; t < 256; ++t)
    for (int s = 0; s < 512; ++s) {
      const double phi = ((s + 0.5) / 512.0 - 0.5) * 2.0 * kPi, theta = (t + 0.5) / 256.0 * kPi;
      const double x = std::sin(theta) * std::sin(phi), y = std::cos(theta),
                   z = -std::sin(theta) * std::cos(phi);
      if (x * d[0] + y * d[1] + z * d[2] > cosA)
        for (int c = 0; c < 3; ++c) env.equirect.at(s, t, c) = radiance;
    }
  return env;
}

// A light set of one cap of the map's whole power, no ambient.
LightSet oneCap(const Environment& env, const std::array<float, 3>& d, double halfDeg) {
  double p[3];
  env.power(p);
  AreaLight l;
  l.direction = d;
  l.cosAlpha = float(std::cos(halfDeg * kPi / 180.0));
  const double omega = 2.0 * kPi * (1.0 - std::cos(halfDeg * kPi / 180.0));
  for (int c = 0; c < 3; ++c) {
    l.power[c] = float(p[c]);
    l.radiance[c] = float(p[c] / omega);
  }
  LightSet set;
  set.lights.push_back(l);
  set.method = "user";
  return set;
}

double predicted(const Environment& env, int lights) {
  ExtractOptions eo;
  eo.medianCut.lights = lights;
  return lightSetProbeError(env, extractLights(ctx(), env, eo));
}

}  // namespace

// A cap that is the map's disc predicts almost no error; the same cap moved 25 degrees (or made
// three times wider) predicts a large one: the probes see where the light is, not only its power.
// "Almost": the predictor bins the map to 128 x 64 and samples each light 32 times, and where a
// blocking cone's edge cuts the 8-degree disc the two discretisations differ (2.4% here); that is
// its resolution, below which a target means little (README, "--lights auto").
TEST(LightCount, ExactLightPredictsLittleAndAWrongOneMuch) {
  const std::array<float, 3> d = {0.0f, 0.8f, 0.6f};
  const Environment env = discMap(d, 8.0, 50.0f);
  const double exact = lightSetProbeError(env, oneCap(env, d, 8.0));
  const float c = std::cos(25.0f * float(kPi) / 180.0f), s = std::sin(25.0f * float(kPi) / 180.0f);
  const std::array<float, 3> moved = {s, 0.8f * c, 0.6f * c};
  const double wrongPlace = lightSetProbeError(env, oneCap(env, moved, 8.0));
  const double wrongSize = lightSetProbeError(env, oneCap(env, d, 24.0));
  EXPECT_LT(exact, 0.03) << wrongPlace << " " << wrongSize;
  EXPECT_GT(wrongPlace, 10.0 * exact);
  EXPECT_GT(wrongPlace, 0.3);
  EXPECT_GT(wrongSize, 5.0 * exact) << exact << " " << wrongPlace << " " << wrongSize;
}

// The residual is shaded unshadowed, so a set that carries everything as ambient predicts a much
// larger error than the lights that carry the same map, though both match the map's unshadowed
// irradiance on every normal.
TEST(LightCount, UnshadowedAmbientIsWhatOcclusionExposes) {
  const Environment env = builtinEnvironment(256);
  LightSet ambientOnly;
  ambientOnly.method = "user";
  addAmbientResidual(ctx(), env, ambientOnly, AmbientOptions{});
  ASSERT_TRUE(ambientOnly.hasAmbient);
  const double all = lightSetProbeError(env, ambientOnly);
  const double lights32 = predicted(env, 32);
  EXPECT_GT(all, 4.0 * lights32) << all << " vs " << lights32;
  // and the unshadowed irradiance of both matches the map (what the probes add is occlusion)
  const float n[3] = {0.0f, 1.0f, 0.0f};
  double e[3];
  env.irradiance(n, e);
  const auto a = ambientOnly.irradiance({0.0f, 1.0f, 0.0f});
  EXPECT_NEAR(a[1] / e[1], 1.0, 0.02);
}

// More lights, less predicted error, on every test map and the built-in sky (the measured floor
// falls the same way: bench/results/light_count.md).
TEST(LightCount, PredictionFallsWithTheCount) {
  std::vector<Environment> envs;
  for (const char* rel : kMaps) envs.push_back(loadEnvironment(data(rel)));
  envs.push_back(builtinEnvironment(256));
  for (const Environment& env : envs) {
    const double p4 = predicted(env, 4), p16 = predicted(env, 16), p64 = predicted(env, 64);
    EXPECT_GT(p4, p16) << env.source;
    EXPECT_GT(p16, p64) << env.source;
    EXPECT_GT(p64, 0.0) << env.source;
  }
}

// The search returns a set that meets the target, and every smaller count it tried missed it.
TEST(LightCount, SearchMeetsTheTargetWithTheFewestItTried) {
  const Environment env = builtinEnvironment(256);
  ExtractOptions eo;
  eo.medianCut.lights = 256;
  eo.targetError = 0.05;
  LightCountSearch search;
  const LightSet set = extractToTargetError(ctx(), env, eo, &search);
  ASSERT_TRUE(search.reached);
  EXPECT_LE(search.predicted, 0.05);
  EXPECT_DOUBLE_EQ(lightSetProbeError(env, set), search.predicted);
  EXPECT_TRUE(set.hasAmbient);
  ASSERT_GE(search.tried.size(), 2u);
  bool chosenTried = false;
  for (const LightCountTry& t : search.tried) {
    if (t.asked < search.lights) EXPECT_GT(t.predicted, 0.05) << t.asked;
    if (t.asked == search.lights) chosenTried = true;
  }
  EXPECT_TRUE(chosenTried);
  // extractLights with the target set gives the same set
  EXPECT_EQ(extractLights(ctx(), env, eo).lights.size(), set.lights.size());
  // a looser target needs no more lights
  eo.targetError = 0.10;
  LightCountSearch loose;
  extractToTargetError(ctx(), env, eo, &loose);
  EXPECT_LE(loose.lights, search.lights);
}

// A target the most lights cannot meet: the most lights, reported as missed.
TEST(LightCount, AMissedTargetIsReported) {
  const Environment env = builtinEnvironment(256);
  ExtractOptions eo;
  eo.medianCut.lights = 8;
  eo.targetError = 1e-4;
  LightCountSearch search;
  const LightSet set = extractToTargetError(ctx(), env, eo, &search);
  EXPECT_FALSE(search.reached);
  EXPECT_EQ(search.lights, 8);
  EXPECT_EQ(int(set.lights.size()), 8);
  EXPECT_GT(search.predicted, 1e-4);
}

// The search stops at the cube's texels: median cut cannot cut more regions than 6 x face^2.
TEST(LightCount, SearchStopsAtTheCubesTexels) {
  const Environment env = builtinEnvironment(64);
  ExtractOptions eo;
  eo.medianCut.faceSize = 2;
  eo.medianCut.lights = 256;
  eo.targetError = 1e-4;
  LightCountSearch search;
  extractToTargetError(ctx(), env, eo, &search);
  EXPECT_FALSE(search.reached);
  EXPECT_EQ(search.lights, 24);
  EXPECT_EQ(search.tried.back().asked, 24);
}

TEST(LightCount, RefusesBadTargetsAndOtherMethods) {
  const Environment env = builtinEnvironment(64);
  ExtractOptions eo;
  auto expectRefused = [&](const std::string& mention) {
    try {
      extractLights(ctx(), env, eo);
      ADD_FAILURE() << "accepted targetError " << eo.targetError;
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::BadInput);
      EXPECT_NE(std::string(e.what()).find(mention), std::string::npos) << e.what();
    }
  };
  for (double bad : {-0.1, std::numeric_limits<double>::quiet_NaN(),
                     std::numeric_limits<double>::infinity()}) {
    eo.targetError = bad;
    expectRefused("targetError");
  }
  eo.targetError = 0.05;
  eo.method = ExtractionMethod::Greedy;
  expectRefused("median-cut");
}
