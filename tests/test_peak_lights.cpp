// Bright sources apart (MedianCutOptions::peakRatio, src/environment/median_cut.cpp
// separatePeaks): a source far brighter than its sky becomes one light of its own, resolved from
// its own texels, and median cut splits the rest; and auto's exact visibility for compact bright
// lights (AutoOptions::exactShare, src/shadows/auto.cpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "common.hpp"
#include "shadows/auto.hpp"

using namespace penumbra;
using namespace penumbra::test;

namespace {

struct Disc {
  std::array<float, 3> dir;
  float radiusDeg, radiance;
};

// A 1024 x 512 map of radiance `sky` with the discs painted over it (grey radiance); `powers`
// receives each disc's power (any channel), summed from its texels with their exact solid angles.
Environment discsMap(const std::vector<Disc>& discs, float sky, std::vector<double>* powers) {
  Environment env;
  env.source = "discs";
  const int W = 1024, H = 512;
  env.equirect = Image(W, H, 3, sky);
  powers->assign(discs.size(), 0.0);
  for (int t = 0; t < H; ++t) {
    const double dw = 2 * M_PI / W * (std::cos(M_PI * t / H) - std::cos(M_PI * (t + 1) / H));
    for (int s = 0; s < W; ++s) {
      float x, y, z;
      pb_equirect_dir(s + 0.5f, t + 0.5f, W, H, &x, &y, &z);
      for (std::size_t k = 0; k < discs.size(); ++k) {
        const auto& d = discs[k].dir;
        const float len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        const float cosR = std::cos(discs[k].radiusDeg * float(M_PI) / 180);
        if ((x * d[0] + y * d[1] + z * d[2]) / len > cosR) {
          for (int c = 0; c < 3; ++c) env.equirect.at(s, t, c) = discs[k].radiance;
          (*powers)[k] += double(discs[k].radiance) * dw;
          break;
        }
      }
    }
  }
  return env;
}

double angleDeg(const std::array<float, 3>& a, std::array<float, 3> b) {
  const double lb = std::sqrt(double(b[0]) * b[0] + double(b[1]) * b[1] + double(b[2]) * b[2]);
  const double c = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) / lb;
  return std::acos(std::clamp(c, -1.0, 1.0)) * 180 / M_PI;
}

double totalGreen(const LightSet& set) {
  double p = 0;
  for (const AreaLight& l : set.lights) p += l.power[1];
  return p;
}

double mapGreen(const Environment& env) {
  double rgb[3];
  env.power(rgb);
  return rgb[1];
}

// The light whose direction is nearest to d.
const AreaLight& nearest(const LightSet& set, const std::array<float, 3>& d) {
  const AreaLight* best = &set.lights.at(0);
  for (const AreaLight& l : set.lights)
    if (angleDeg(l.direction, d) < angleDeg(best->direction, d)) best = &l;
  return *best;
}

MedianCutOptions cut(int lights, float ratio) {
  MedianCutOptions mc;
  mc.lights = lights;
  mc.faceSize = 64;
  mc.peakRatio = ratio;
  return mc;
}

}  // namespace

// A 2.5-degree sun of radiance 1000 over a sky of 1: one light carries exactly its power, along
// its axis, as wide as the disc, and every other light is sky (radiance about 1). Median cut
// alone (ratio 0), the control, cuts the sun into several lights and leaves some of its power in
// lights wider than the sun. The set's power is the map's either way.
TEST(PeakLights, SunIsOneLightWithItsOwnPower) {
  const Disc sun{{0.4f, 0.8f, -0.45f}, 2.5f, 1000.0f};
  std::vector<double> sunPower;
  const Environment env = discsMap({sun}, 1.0f, &sunPower);
  const LightSet apart = extractMedianCut(ctx(), env, cut(16, 100));
  ASSERT_EQ(apart.lights.size(), 16u);
  const AreaLight& s = nearest(apart, sun.dir);
  EXPECT_NEAR(s.power[1] / sunPower[0], 1.0, 1e-5);
  EXPECT_LT(angleDeg(s.direction, sun.dir), 0.1);
  // a uniform disc's cap from its resultant length is the disc (texels here are 0.35 degrees)
  EXPECT_NEAR(s.halfAngle() * 180 / M_PI, 2.5, 0.2);
  for (const AreaLight& l : apart.lights) {
    if (&l == &s) continue;
    EXPECT_LT(l.radiance[1], 1.2f) << "a sky light took part of the sun";
    EXPECT_LT(l.power[1], 0.2 * sunPower[0]);
  }
  EXPECT_NEAR(totalGreen(apart) / mapGreen(env), 1.0, 1e-4);

  const LightSet alone = extractMedianCut(ctx(), env, cut(16, 0));
  ASSERT_EQ(alone.lights.size(), 16u);
  int sunPieces = 0;
  double inWide = 0;  // sun power (above the sky's radiance) in lights wider than 5 degrees
  for (const AreaLight& l : alone.lights) {
    if (l.radiance[1] > 10.0f) ++sunPieces;
    if (l.halfAngle() * 180 / M_PI > 5.0 && l.radiance[1] > 1.2f)
      inWide += l.power[1] - l.solidAngle() * 1.0;
  }
  EXPECT_GE(sunPieces, 2);
  EXPECT_GT(inWide, 0.01 * sunPower[0]);
  EXPECT_NEAR(totalGreen(alone) / mapGreen(env), 1.0, 1e-4);
}

// A disc across the map's seam (longitude +-180 degrees, direction +z) is one connected set, not
// two; at most lights / 4 sets become lights, the brightest first, each with at least 1 / lights
// of the map's power, and the others stay in the map median cut splits (the power is the map's).
TEST(PeakLights, SeamAndBudget) {
  const std::vector<Disc> discs = {{{0.0f, 0.3f, 1.0f}, 3.0f, 800.0f},
                                   {{1.0f, 0.5f, 0.0f}, 2.0f, 600.0f},
                                   {{-1.0f, 0.2f, -0.3f}, 2.0f, 400.0f},
                                   {{0.3f, -0.6f, -1.0f}, 1.5f, 300.0f}};
  std::vector<double> powers;
  const Environment env = discsMap(discs, 0.5f, &powers);
  const LightSet set = extractMedianCut(ctx(), env, cut(8, 100));  // budget 2
  ASSERT_EQ(set.lights.size(), 8u);
  // the two brightest discs: one light each, with their exact power
  for (int k : {0, 1}) {
    const AreaLight& l = nearest(set, discs[std::size_t(k)].dir);
    EXPECT_NEAR(l.power[1] / powers[std::size_t(k)], 1.0, 1e-5) << "disc " << k;
    EXPECT_LT(angleDeg(l.direction, discs[std::size_t(k)].dir), 0.1) << "disc " << k;
    EXPECT_TRUE(l.regions.empty()) << "disc " << k << " came from median cut";
  }
  int fromPeaks = 0;
  for (const AreaLight& l : set.lights) fromPeaks += l.regions.empty();
  EXPECT_EQ(fromPeaks, 2);
  EXPECT_NEAR(totalGreen(set) / mapGreen(env), 1.0, 1e-4);
  // 16 lights: budget 4, but a set needs one light's share of the map (1/16 of its power, 1.1
  // here): discs 0-2 (6.9, 2.3 and 1.5) become lights, disc 3 (0.65) stays with median cut
  const LightSet all = extractMedianCut(ctx(), env, cut(16, 100));
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_NEAR(nearest(all, discs[k].dir).power[1] / powers[k], 1.0, 1e-5) << "disc " << k;
    EXPECT_TRUE(nearest(all, discs[k].dir).regions.empty()) << "disc " << k;
  }
  EXPECT_LT(powers[3], mapGreen(env) / 16);
  EXPECT_FALSE(nearest(all, discs[3].dir).regions.empty());
  EXPECT_NEAR(totalGreen(all) / mapGreen(env), 1.0, 1e-4);
}

// The map's rotation turns the separated light with it: a rotated map gives the same light as
// the map with its columns moved (Environment::withRotationApplied).
TEST(PeakLights, FollowsTheMapsRotation) {
  std::vector<double> powers;
  Environment env = discsMap({{{0.5f, 0.7f, -0.5f}, 2.0f, 500.0f}}, 1.0f, &powers);
  env.rotationYDeg = 90.0f;
  const Environment moved = env.withRotationApplied();
  const LightSet a = extractMedianCut(ctx(), env, cut(8, 100)),
                 b = extractMedianCut(ctx(), moved, cut(8, 100));
  const AreaLight *pa = nullptr, *pb = nullptr;
  for (const AreaLight& l : a.lights)
    if (l.regions.empty()) pa = &l;
  for (const AreaLight& l : b.lights)
    if (l.regions.empty()) pb = &l;
  ASSERT_TRUE(pa && pb);
  EXPECT_LT(angleDeg(pa->direction, pb->direction), 0.01);
  EXPECT_NEAR(pa->power[1] / pb->power[1], 1.0, 1e-6);
  // and it moved: the unrotated map's light is 90 degrees away
  const LightSet c = extractMedianCut(ctx(), discsMap({{{0.5f, 0.7f, -0.5f}, 2.0f, 500.0f}}, 1.0f,
                                                      &powers),
                                      cut(8, 100));
  for (const AreaLight& l : c.lights)
    if (l.regions.empty()) EXPECT_GT(angleDeg(l.direction, pa->direction), 30.0);
}

// Nothing to separate (a map without a bright source, or fewer than 4 lights): the same set as
// median cut alone, to the byte.
TEST(PeakLights, OffWhenNothingQualifies) {
  const Environment sky = builtinEnvironment(128);
  std::vector<double> powers;
  const Environment uniform = discsMap({}, 2.0f, &powers);
  EXPECT_EQ(extractMedianCut(ctx(), uniform, cut(16, 100)).toJson(),
            extractMedianCut(ctx(), uniform, cut(16, 0)).toJson());
  EXPECT_EQ(extractMedianCut(ctx(), sky, cut(3, 100)).toJson(),
            extractMedianCut(ctx(), sky, cut(3, 0)).toJson());
  // the built-in sky's sun is separated from 4 lights on
  const LightSet four = extractMedianCut(ctx(), sky, cut(4, 100));
  int fromPeaks = 0;
  for (const AreaLight& l : four.lights) fromPeaks += l.regions.empty();
  EXPECT_EQ(fromPeaks, 1);
}

// A bright source wider than peakMaxHalfAngleDeg (default 5 degrees) is a soft one: it stays with
// median cut; with a wider limit it becomes one light.
TEST(PeakLights, WideSourcesStayWithMedianCut) {
  const Disc box{{-0.3f, 0.6f, 0.7f}, 8.0f, 300.0f};
  std::vector<double> powers;
  const Environment env = discsMap({box}, 1.0f, &powers);
  const LightSet dflt = extractMedianCut(ctx(), env, cut(16, 100));
  for (const AreaLight& l : dflt.lights) EXPECT_FALSE(l.regions.empty());
  MedianCutOptions wide = cut(16, 100);
  wide.peakMaxHalfAngleDeg = 10.0f;
  const LightSet apart = extractMedianCut(ctx(), env, wide);
  const AreaLight& b = nearest(apart, box.dir);
  EXPECT_TRUE(b.regions.empty());
  EXPECT_NEAR(b.power[1] / powers[0], 1.0, 1e-5);
  EXPECT_NEAR(b.halfAngle() * 180 / M_PI, 8.0, 0.2);
}

TEST(PeakLights, RefusesABadRatio) {
  const Environment env = builtinEnvironment(64);
  for (float bad : {-1.0f, std::nanf(""), INFINITY}) {
    try {
      extractMedianCut(ctx(), env, cut(8, bad));
      ADD_FAILURE() << "peakRatio " << bad << " accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::BadInput);
      EXPECT_NE(std::string(e.what()).find("MedianCutOptions.peakRatio"), std::string::npos)
          << e.what();
    }
  }
  for (float bad : {0.0f, 90.0f, -3.0f, std::nanf("")}) {
    MedianCutOptions mc = cut(8, 100);
    mc.peakMaxHalfAngleDeg = bad;
    try {
      extractMedianCut(ctx(), env, mc);
      ADD_FAILURE() << "peakMaxHalfAngleDeg " << bad << " accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::BadInput);
      EXPECT_NE(std::string(e.what()).find("MedianCutOptions.peakMaxHalfAngleDeg"),
                std::string::npos)
          << e.what();
    }
  }
}

namespace {
detail::AutoLight light(double power, double halfAngleDeg) {
  detail::AutoLight l;
  l.power = power;
  l.tanAlpha = std::tan(halfAngleDeg * M_PI / 180);
  l.texel = 0.01;
  l.distance = 1.0;
  return l;
}
}  // namespace

// exactShare: every light with that share of the power and a cap within exactHalfAngleDeg is
// exact, besides the exactLights budget; none without triangles.
TEST(PeakLights, AutoMakesCompactBrightLightsExact) {
  // shares of 10: 0.4 (2 degrees), 0.3 (10 degrees: too wide), 0.05 (1 degree: too dim), 0.25
  const std::vector<detail::AutoLight> lights = {light(4, 2), light(3, 10), light(0.5, 1),
                                                 light(2.5, 4.9)};
  AutoOptions o;
  o.exactShare = 0.2f;
  o.exactHalfAngleDeg = 5.0f;
  auto t = detail::chooseShadowTechniques(lights, 0.001, o);
  EXPECT_EQ(t[0], ShadowTechnique::Bitmask);
  EXPECT_NE(t[1], ShadowTechnique::Bitmask);
  EXPECT_NE(t[2], ShadowTechnique::Bitmask);
  EXPECT_EQ(t[3], ShadowTechnique::Bitmask);
  // with the count budget as well: the brightest (light 0, already exact) and no other
  o.exactLights = 1;
  t = detail::chooseShadowTechniques(lights, 0.001, o);
  EXPECT_EQ(std::count(t.begin(), t.end(), ShadowTechnique::Bitmask), 2);
  o.exactLights = 0;
  o.exactShare = 0.0f;
  t = detail::chooseShadowTechniques(lights, 0.001, o);
  EXPECT_EQ(std::count(t.begin(), t.end(), ShadowTechnique::Bitmask), 0);
  o.exactShare = 0.2f;
  t = detail::chooseShadowTechniques(lights, 0.001, o, 27.0f, false);
  EXPECT_EQ(std::count(t.begin(), t.end(), ShadowTechnique::Bitmask), 0);
  // the options are checked, naming the field
  for (auto [share, angle, field] :
       {std::tuple{-0.1f, 5.0f, "exactShare"}, std::tuple{1.5f, 5.0f, "exactShare"},
        std::tuple{std::nanf(""), 5.0f, "exactShare"}, std::tuple{0.1f, -1.0f, "exactHalfAngleDeg"},
        std::tuple{0.1f, 91.0f, "exactHalfAngleDeg"}}) {
    AutoOptions b;
    b.exactShare = share;
    b.exactHalfAngleDeg = angle;
    try {
      detail::chooseShadowTechniques(lights, 0.001, b);
      ADD_FAILURE() << field << " " << share << " " << angle << " accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(std::string("RenderOptions.autoChoice.") + field),
                std::string::npos)
          << e.what();
    }
  }
}
