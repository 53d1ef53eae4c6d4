// Animation (issue 4): the environment's rotation about +y wherever the map is read (host lookups
// and integrals, the device cube map and so every extraction, the rendered background, the Embree
// reference), the built-in scene's moving objects, temporal stability of the rendered frame under
// a turning map, and the `render --frames` command line.
#include <gtest/gtest.h>
#include <unistd.h>
#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common.hpp"
#include "support/extraction_checks.hpp"

using namespace penumbra;
using namespace penumbra::test;
namespace fs = std::filesystem;

namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

// The map with its columns shifted so that it shows what a 90-degree turn shows: world column s
// reads map column s + W/4 (shared.h pb_env_column), exact for W divisible by 4.
Environment shiftedQuarter(const Environment& env) {
  Environment out = env;
  const int W = env.equirect.width;
  for (int t = 0; t < env.equirect.height; ++t)
    for (int s = 0; s < W; ++s)
      for (int c = 0; c < 3; ++c) out.equirect.at(s, t, c) = env.equirect.at((s + W / 4) % W, t, c);
  return out;
}

// R_y(a): counter-clockwise seen from above (+x towards -z).
std::array<float, 3> rotY(const std::array<float, 3>& v, double deg) {
  const double c = std::cos(deg * kDeg), s = std::sin(deg * kDeg);
  return {float(c * v[0] + s * v[2]), v[1], float(-s * v[0] + c * v[2])};
}

double angleDeg(const std::array<float, 3>& a, const std::array<float, 3>& b) {
  double d = double(a[0]) * b[0] + double(a[1]) * b[1] + double(a[2]) * b[2];
  double la = std::sqrt(double(a[0]) * a[0] + double(a[1]) * a[1] + double(a[2]) * a[2]);
  double lb = std::sqrt(double(b[0]) * b[0] + double(b[1]) * b[1] + double(b[2]) * b[2]);
  return std::acos(std::clamp(d / (la * lb), -1.0, 1.0)) / kDeg;
}

template <class T>
double lum(const std::array<T, 3>& p) {
  return PB_LUM_R * p[0] + PB_LUM_G * p[1] + PB_LUM_B * p[2];
}

std::vector<Environment> testMaps() {
  std::vector<Environment> maps;
  for (const char* m : kMaps) maps.push_back(loadEnvironment(data(m)));
  maps.push_back(builtinEnvironment(256));
  return maps;
}

// The map's 16 median-cut lights on a 64 cube (what the rotation tests turn).
LightSet sixteenLights(const Environment& env) {
  MedianCutOptions mo;
  mo.lights = 16;
  mo.faceSize = 64;
  return extractMedianCut(ctx(), env, mo);
}

// The 26 unit directions towards a cube's faces, edges and corners (support's testNormals), in
// float.
std::vector<std::array<float, 3>> cubeNormals() {
  std::vector<std::array<float, 3>> normals;
  for (const auto& n : xref::testNormals())
    normals.push_back({float(n[0]), float(n[1]), float(n[2])});
  return normals;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Environment rotation.

TEST(EnvRotation, ShiftIsNormalizedAndWholeTurnsAreZero) {
  Environment env = builtinEnvironment(64);
  for (float deg : {0.0f, 360.0f, -360.0f, 720.0f}) {
    env.rotationYDeg = deg;
    EXPECT_EQ(env.rotationColumns(), 0.0f) << deg;
  }
  env.rotationYDeg = 90.0f;
  EXPECT_EQ(env.rotationColumns(), 16.0f);
  env.rotationYDeg = -90.0f;
  EXPECT_EQ(env.rotationColumns(), 48.0f);
  env.rotationYDeg = 1.0f;
  EXPECT_NEAR(env.rotationColumns(), 64.0 / 360.0, 1e-6);
  env.rotationYDeg = std::nanf("");
  EXPECT_THROW(env.rotationColumns(), Error);
}

// The sun of the built-in sky (azimuth 35 degrees towards +x from -z) turned 90 degrees
// counter-clockwise seen from above ends at azimuth -55 degrees: the documented sense.
TEST(EnvRotation, SenseIsCounterClockwiseFromAbove) {
  Environment env = builtinEnvironment(512);
  const double el = 50 * kDeg, az = 35 * kDeg;
  const std::array<float, 3> sun{float(std::cos(el) * std::sin(az)), float(std::sin(el)),
                                 float(-std::cos(el) * std::cos(az))};
  const std::array<float, 3> turned = rotY(sun, 90);
  float rgb[3];
  env.lookup(sun[0], sun[1], sun[2], rgb);
  EXPECT_GT(rgb[0], 100.0f);
  env.rotationYDeg = 90.0f;
  env.lookup(turned[0], turned[1], turned[2], rgb);
  EXPECT_GT(rgb[0], 100.0f);  // the sun moved with the turn
  env.lookup(sun[0], sun[1], sun[2], rgb);
  EXPECT_LT(rgb[0], 10.0f);   // and is no longer where it was
}

TEST(EnvRotation, HostLookupPowerIrradianceAndBaking) {
  for (const Environment& env : testMaps()) {
    SCOPED_TRACE(env.source);
    Environment rot = env;
    rot.rotationYDeg = 90.0f;
    const Environment shifted = shiftedQuarter(env);
    // Baking the rotation reproduces the column shift exactly.
    const Environment baked = rot.withRotationApplied();
    EXPECT_EQ(baked.rotationYDeg, 0.0f);
    EXPECT_TRUE(baked.equirect.pixels == shifted.equirect.pixels);
    // Lookups at texel centres read the same texel.
    const int W = env.equirect.width, H = env.equirect.height;
    int mismatches = 0;
    for (int t = 0; t < H; t += 3)
      for (int s = 0; s < W; s += 5) {
        float x, y, z, a[3], b[3];
        pb_equirect_dir(s + 0.5f, t + 0.5f, float(W), float(H), &x, &y, &z);
        rot.lookup(x, y, z, a);
        shifted.lookup(x, y, z, b);
        mismatches += a[0] != b[0] || a[1] != b[1] || a[2] != b[2];
      }
    EXPECT_EQ(mismatches, 0);
    // Power does not change; irradiance turns with the map. The sub-sample positions of the two
    // sums are the same up to float rounding of the column, so 1e-4 relative.
    double p0[3], p1[3];
    env.power(p0);
    rot.power(p1);
    for (int c = 0; c < 3; ++c) EXPECT_EQ(p0[c], p1[c]);
    for (const std::array<float, 3>& n : {std::array<float, 3>{1, 0, 0}, {0, 0, -1},
                                         {0.577f, 0.577f, -0.577f}, {0, 1, 0}}) {
      double a[3], b[3];
      rot.irradiance(n.data(), a);
      shifted.irradiance(n.data(), b);
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(a[c], b[c], 1e-4 * std::max(1e-6, b[c]));
    }
  }
}

// The cube of the rotated map is the cube of the column-shifted map. Splatting (cube coarser than
// the map) does the same float operations in the same order on both, and the fixed-point adds are
// associative, so the energies are bit-identical. Gathering (cube finer) adds the whole shift after
// the float column, so a sample a float rounding away from a column edge may pick the neighbour:
// there at most 0.1% of the texels may differ, and the total by 1e-4.
TEST(EnvRotation, CubeOfQuarterTurnIsCubeOfShiftedMap) {
  for (const Environment& env : testMaps()) {
    SCOPED_TRACE(env.source);
    Environment rot = env;
    rot.rotationYDeg = 90.0f;
    const Environment shifted = shiftedQuarter(env);
    const int W = env.equirect.width;
    const int splatFace = std::max(1, W / 8), gatherFace = W;  // W >= 4m splats, else gathers
    Image a = cubeMapEnergy(ctx(), rot, splatFace), b = cubeMapEnergy(ctx(), shifted, splatFace);
    EXPECT_TRUE(a.pixels == b.pixels) << "splat, face " << splatFace;
    a = cubeMapEnergy(ctx(), rot, gatherFace);
    b = cubeMapEnergy(ctx(), shifted, gatherFace);
    std::size_t differ = 0;
    double ta = 0, tb = 0;
    for (std::size_t i = 0; i < a.pixels.size(); ++i) {
      differ += a.pixels[i] != b.pixels[i];
      ta += a.pixels[i];
      tb += b.pixels[i];
    }
    EXPECT_LE(differ, a.pixels.size() / 1000) << "gather, face " << gatherFace;
    EXPECT_NEAR(ta, tb, 1e-4 * tb);
  }
}

TEST(EnvRotation, WholeTurnIsTheIdentity) {
  Environment env = loadEnvironment(data("envmaps/courtyard.exr"));
  const Image base = cubeMapEnergy(ctx(), env, 32);
  const Image baseGather = cubeMapEnergy(ctx(), env, env.equirect.width);
  for (float deg : {360.0f, -360.0f, 1080.0f}) {
    env.rotationYDeg = deg;
    EXPECT_TRUE(cubeMapEnergy(ctx(), env, 32).pixels == base.pixels) << deg;
    EXPECT_TRUE(cubeMapEnergy(ctx(), env, env.equirect.width).pixels == baseGather.pixels) << deg;
  }
}

// Median-cut lights of the map turned 90 degrees are bit for bit the lights of the column-shifted
// map (same cube), carry the same power, and light the turned normals as the original lights
// light the original ones. The turn permutes the four side faces of the cube but spins the top and
// bottom ones, and median cut splits a square region along x (kernels/environment/extract.cl, `w >=
// h`), so the individual cuts there need not turn with the map: that is measured and printed.
TEST(EnvRotation, MedianCutLightsTurnWithTheMap) {
  for (const Environment& env : testMaps()) {
    SCOPED_TRACE(env.source);
    const LightSet base = sixteenLights(env);
    Environment rot = env;
    rot.rotationYDeg = 90.0f;
    const LightSet turned = sixteenLights(rot);
    const LightSet shifted = sixteenLights(shiftedQuarter(env));
    ASSERT_EQ(turned.lights.size(), shifted.lights.size());
    for (std::size_t i = 0; i < turned.lights.size(); ++i) {
      EXPECT_EQ(turned.lights[i].direction, shifted.lights[i].direction);
      EXPECT_EQ(turned.lights[i].power, shifted.lights[i].power);
    }
    // Turning moves energy, it does not create or lose any.
    const auto pb = base.power(), pt = turned.power();
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(pt[c], pb[c], 1e-5 * pb[c]);
    // The cuts turn with the map (issue 4: directions within 1 degree, powers within 1%): square
    // regions choose their cut axis by a rotation-consistent rule (kernels/environment/extract.cl).
    double total = 0;
    for (auto& l : base.lights) total += lum(l.power);
    double worstDeg = 0, worstPow = 0;
    for (auto& l : base.lights) {
      const auto want = rotY(l.direction, 90);
      const AreaLight* best = nullptr;
      double bestDeg = 1e9;
      for (auto& m : turned.lights) {
        double d = angleDeg(want, m.direction);
        if (d < bestDeg) bestDeg = d, best = &m;
      }
      worstDeg = std::max(worstDeg, bestDeg);
      double rel = std::fabs(lum(best->power) - lum(l.power)) / std::max(lum(l.power), 1e-3 * total);
      worstPow = std::max(worstPow, rel);
    }
    // Irradiance of the light sets on the 26 cube directions, turned: within 2% (issue 4's
    // irradiance tolerance) of the sum over all normals' irradiance scale.
    double worstE = 0, scale = 0;
    for (auto& n : cubeNormals()) {
      const auto eb = base.irradiance(n), et = turned.irradiance(rotY(n, 90));
      const double lb = PB_LUM_R * eb[0] + PB_LUM_G * eb[1] + PB_LUM_B * eb[2];
      const double lt = PB_LUM_R * et[0] + PB_LUM_G * et[1] + PB_LUM_B * et[2];
      scale = std::max(scale, lb);
      worstE = std::max(worstE, std::fabs(lt - lb));
    }
    EXPECT_LT(worstE, 0.02 * scale);
    // The built-in sky's zenith face is symmetric under a quarter turn (the sky is a function of
    // elevation there, exactly, in fixed point): the turned map's face is the same face, so any
    // deterministic cut gives the same lights for both, and a two-way cut of a square is not
    // itself symmetric under a quarter turn. No cutting rule can turn those lights; the issue's
    // test is on the maps in ../shared/data/envmaps, which are asserted.
    if (env.source != "builtin") {
      EXPECT_LT(worstDeg, 1.0);
      EXPECT_LT(worstPow, 0.01);
    }
    std::printf("[ rotation ] %s: median cut 90 deg: worst light direction %.3f deg, power %.4f, "
                "irradiance %.4f of max\n",
                env.source.c_str(), worstDeg, worstPow, worstE / scale);
  }
}

// ---------------------------------------------------------------------------------------------
// rotateLightSet: a light set turned with its map (what `render --frames` uses after the first
// frame of each map).

namespace {

// The largest |E_turned(R(a) n) - E_base(n)| over the 26 normals, as a fraction of the largest
// E_base(n): `ambientOnly` compares LightSet::ambientIrradiance, else LightSet::irradiance.
double turnedIrradianceError(const LightSet& base, const LightSet& turned, double deg,
                             bool ambientOnly) {
  double worst = 0, scale = 0;
  for (auto& n : cubeNormals()) {
    const auto eb = ambientOnly ? base.ambientIrradiance(n) : base.irradiance(n);
    const auto m = rotY(n, deg);
    const auto et = ambientOnly ? turned.ambientIrradiance(m) : turned.irradiance(m);
    scale = std::max(scale, std::fabs(lum(eb)));
    worst = std::max(worst, std::fabs(lum(et) - lum(eb)));
  }
  return worst / scale;
}

}  // namespace

// Every light turns by R_y(a) and keeps its size and power; the sense is the environment's: a
// quarter turn of the set matches the lights median cut finds in the map turned by 90 degrees (the
// maps in ../shared/data, where EnvRotation.MedianCutLightsTurnWithTheMap finds those within 1
// degree and 1% of the turned ones; the same bound here; measured 0.000 degrees). Turned the other
// way (-90), the same comparison fails: the test tells the two senses apart.
TEST(LightRotation, LightsTurnInTheEnvironmentsSense) {
  for (const Environment& env : testMaps()) {
    SCOPED_TRACE(env.source);
    const LightSet base = sixteenLights(env);
    for (double deg : {90.0, -90.0, 33.5}) {
      const LightSet t = rotateLightSet(base, float(deg));
      ASSERT_EQ(t.lights.size(), base.lights.size());
      for (std::size_t i = 0; i < t.lights.size(); ++i) {
        const AreaLight &a = base.lights[i], &b = t.lights[i];
        EXPECT_LT(angleDeg(b.direction, rotY(a.direction, deg)), 1e-4) << i;
        EXPECT_EQ(b.cosAlpha, a.cosAlpha);
        EXPECT_EQ(b.power, a.power);
        EXPECT_EQ(b.radiance, a.radiance);
        EXPECT_TRUE(b.regions.empty());  // a separated bright source has none to begin with
      }
      validateLightSet(t);
    }
    Environment turnedMap = env;
    turnedMap.rotationYDeg = 90.0f;
    const LightSet found = sixteenLights(turnedMap);
    // The worst over base's lights of the angle to the nearest light found in the turned map.
    auto worstMatch = [&](const LightSet& turned) {
      double worst = 0;
      for (auto& l : turned.lights) {
        double best = 1e9;
        for (auto& m : found.lights) best = std::min(best, angleDeg(l.direction, m.direction));
        worst = std::max(worst, best);
      }
      return worst;
    };
    const double right = worstMatch(rotateLightSet(base, 90.0f));
    const double wrong = worstMatch(rotateLightSet(base, -90.0f));
    std::printf("[ rotation ] %s: set turned 90 deg vs lights of the turned map: worst %.3f deg "
                "(turned -90: %.1f deg)\n", env.source.c_str(), right, wrong);
    // The built-in sky's zenith face is symmetric under a quarter turn, so median cut finds the
    // same lights there in both maps (EnvRotation.MedianCutLightsTurnWithTheMap): 30.6 degrees
    // from the turned set, measured. That jump is what turning the set avoids; the sense is
    // pinned by the three maps.
    if (env.source == "builtin") continue;
    EXPECT_LT(right, 1.0);
    EXPECT_GT(wrong, 5.0);
  }
}

// The unshadowed irradiance turns with the set: E_turned(R(a) n) = E_base(n) on the 26 cube
// normals. The lights' part is exact to float rounding. The ambient's SH9 rotation is exact (to
// 2e-7 of the largest ambient irradiance, measured; bound 2e-5). Its irradiance map is shifted by a
// / 360 of its width and read linearly between columns, which is exact for whole columns (90
// degrees of the 128-wide map: under 1e-6 measured, the lookup's own rounding) and otherwise
// smooths the residual along each row once more, on top of the lookup's own bilinear reading;
// measured 1.0e-3 to 1.2e-3 of the largest ambient on the built-in sky, up to 7.0e-3 on studio.exr,
// whose residual (the map minus the caps) has sharp edges, so the bound is 1e-2. Against the whole
// irradiance (lights and ambient) that is at most 2.8e-4 (bound 1e-3). Turning the map or the SH
// the wrong way misses the ambient by 3.6% (1 degree) to over 100%: each map's residual has an
// azimuthal structure the test sees.
TEST(LightRotation, IrradianceTurnsWithTheSet) {
  for (const Environment& env : testMaps()) {
    SCOPED_TRACE(env.source);
    for (AmbientModel model : {AmbientModel::IrradianceMap, AmbientModel::SH9}) {
      SCOPED_TRACE(toString(model));
      ExtractOptions eo;
      eo.medianCut.lights = 8;
      eo.medianCut.faceSize = 32;
      // Median cut's lights alone: the residual the bounds below were measured on. With studio's
      // bright sources as lights of their own its residual is smaller, and the same smoothing is
      // 1.1e-2 of its largest ambient irradiance (measured), while the whole irradiance's error
      // stays within its 1e-3 (IrradianceTurnsWithBrightSourcesApart).
      eo.medianCut.peakRatio = 0;
      eo.ambientOptions.model = model;
      const LightSet base = extractLights(ctx(), env, eo);
      ASSERT_TRUE(base.hasAmbient);
      ASSERT_EQ(base.ambientMap.empty(), model == AmbientModel::SH9);
      for (double deg : {1.0, 30.0, -47.3, 90.0, 200.5}) {
        const LightSet t = rotateLightSet(base, float(deg));
        const double total = turnedIrradianceError(base, t, deg, false);
        const double ambient = turnedIrradianceError(base, t, deg, true);
        const double wrong =
            turnedIrradianceError(base, rotateLightSet(base, float(-deg)), deg, true);
        std::printf("[ rotation ] %s, %s, %.1f deg: irradiance off by %.2e (ambient %.2e; turned "
                    "the other way %.2e)\n", env.source.c_str(), toString(model), deg, total,
                    ambient, wrong);
        const bool wholeColumns = model == AmbientModel::IrradianceMap && deg == 90.0;
        EXPECT_LT(ambient, model == AmbientModel::SH9 ? 2e-5 : wholeColumns ? 1e-5 : 1e-2) << deg;
        EXPECT_LT(total, model == AmbientModel::SH9 ? 2e-5 : wholeColumns ? 1e-6 : 1e-3) << deg;
        EXPECT_GT(wrong, 0.03) << deg;
      }
    }
  }
}

// The same with the default extraction (bright sources as lights of their own): the whole
// unshadowed irradiance, lights and ambient, turns within the bounds above.
TEST(LightRotation, IrradianceTurnsWithBrightSourcesApart) {
  for (const Environment& env : testMaps()) {
    SCOPED_TRACE(env.source);
    ExtractOptions eo;
    eo.medianCut.lights = 8;
    eo.medianCut.faceSize = 32;
    const LightSet base = extractLights(ctx(), env, eo);
    for (double deg : {1.0, 30.0, -47.3, 90.0, 200.5}) {
      const LightSet t = rotateLightSet(base, float(deg));
      const double total = turnedIrradianceError(base, t, deg, false);
      EXPECT_LT(total, deg == 90.0 ? 1e-6 : 1e-3) << deg;
      EXPECT_GT(turnedIrradianceError(base, rotateLightSet(base, float(-deg)), deg, false), 1e-3)
          << deg;
    }
  }
}

// Whole turns give the set back bit for bit (the angle is reduced in double, as the environment
// reduces its own): extraction at rotation 360 is extraction at 0, and so is its turned set.
TEST(LightRotation, WholeTurnsAreTheIdentity) {
  ExtractOptions eo;
  eo.medianCut.lights = 8;
  eo.medianCut.faceSize = 32;
  const LightSet base = extractLights(ctx(), loadEnvironment(data("envmaps/studio.exr")), eo);
  for (float deg : {0.0f, 360.0f, -720.0f, 3600.0f}) {
    const LightSet t = rotateLightSet(base, deg);
    ASSERT_EQ(t.lights.size(), base.lights.size());
    for (std::size_t i = 0; i < t.lights.size(); ++i) {
      EXPECT_EQ(t.lights[i].direction, base.lights[i].direction) << deg;
      EXPECT_EQ(t.lights[i].regions, base.lights[i].regions) << deg;
    }
    EXPECT_EQ(t.ambientSH, base.ambientSH) << deg;
    EXPECT_EQ(t.ambientMap.rgb, base.ambientMap.rgb) << deg;
  }
  // Not whole: the smallest turn moves the lights and the map.
  const LightSet t = rotateLightSet(base, 0.5f);
  EXPECT_NE(t.lights[0].direction, base.lights[0].direction);
  EXPECT_NE(t.ambientMap.rgb, base.ambientMap.rgb);
}

// Polygons, rects, ellipses and textured caps turn with their frames: the radiance a turned light
// shows in direction R(a) d is what the light showed in direction d, texel for texel, and its
// vertices are the turned vertices.
TEST(LightRotation, PolygonsFramesAndTexturesTurn) {
  LightTexture tex;
  tex.width = 3;
  tex.height = 2;
  tex.radiance = {1, 0, 0, 0, 1, 0, 0, 0, 1, 2, 2, 2, 3, 1, 0, 0, 1, 3};
  AreaLight rect = makeRectLight({0.3f, 0.8f, -0.52f}, {0, 1, 0}, {0.3, 0.15}, {1, 1, 1});
  setLightTexture(rect, tex);
  AreaLight ellipse = makeEllipseLight({-0.6f, 0.6f, 0.53f}, {0, 1, 0}, {0.2, 0.35}, {2, 1, 1});
  AreaLight cap;
  cap.direction = {0.0f, 0.6f, 0.8f};
  cap.cosAlpha = 0.95f;
  cap.setPower({1, 1, 1});
  setLightTexture(cap, tex);
  AreaLight poly =
      makePolygonLight({{1, 0.2f, 0}, {0.9f, 0.5f, 0.1f}, {0.8f, 0.3f, 0.5f}}, {1, 2, 3});
  LightSet set;
  set.lights = {rect, ellipse, cap, poly};
  const double deg = 77.0;
  const LightSet t = rotateLightSet(set, float(deg));
  validateLightSet(t);
  for (std::size_t i = 0; i < set.lights.size(); ++i) {
    SCOPED_TRACE(i);
    const AreaLight &a = set.lights[i], &b = t.lights[i];
    EXPECT_NEAR(b.solidAngle(), a.solidAngle(), 1e-6 * a.solidAngle());
    ASSERT_EQ(b.vertices.size(), a.vertices.size());
    for (std::size_t k = 0; k < a.vertices.size(); ++k)
      EXPECT_LT(angleDeg(b.vertices[k], rotY(a.vertices[k], deg)), 1e-4);
    // directions over the light (its samples) and just outside it
    for (auto& d : lightSampleDirections(a, 64)) {
      const auto ra = a.radianceAt(d), rb = b.radianceAt(rotY(d, deg));
      for (int c = 0; c < 3; ++c) EXPECT_EQ(rb[c], ra[c]);
    }
    for (auto& n : cubeNormals()) {
      const auto ea = a.irradiance(n), eb = b.irradiance(rotY(n, deg));
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(eb[c], ea[c], 1e-5 * std::max(1.0f, ea[c]));
    }
  }
  // The textured rect's texture is not symmetric: the same test on the unturned light fails.
  bool differs = false;
  for (auto& d : lightSampleDirections(rect, 64)) {
    const auto ra = rect.radianceAt(d), rb = rect.radianceAt(rotY(d, deg));
    differs = differs || ra != rb;
  }
  EXPECT_TRUE(differs);
}

TEST(LightRotation, NonFiniteAngleIsRefused) {
  LightSet set;
  for (float bad : {std::nanf(""), INFINITY, -INFINITY}) {
    try {
      rotateLightSet(set, bad);
      ADD_FAILURE() << bad;
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::BadInput);
      EXPECT_NE(std::string(e.what()).find("rotateLightSet: the angle must be finite"), std::string::npos)
          << e.what();
    }
  }
}

// The rendered background follows the turn: a frame of the turned map equals the frame of the
// column-shifted map (same cube, same lights, same background texels).
TEST(EnvRotation, RenderedFrameOfQuarterTurnIsFrameOfShiftedMap) {
  Environment env = loadEnvironment(data("envmaps/studio.exr"));
  Environment rot = env;
  rot.rotationYDeg = 90.0f;
  const Environment shifted = shiftedQuarter(env);
  Scene scene = builtinScene();
  Camera cam = frameCamera(scene, 2.0f);
  RenderOptions ro;
  ro.width = 96;
  ro.height = 48;
  ro.shadowMapSize = 64;
  ExtractOptions eo;
  eo.medianCut.lights = 8;
  eo.medianCut.faceSize = 32;
  Renderer r(ctx());
  Frame a = r.render(scene, cam, extractLights(ctx(), rot, eo), rot, ro);
  Frame b = r.render(scene, cam, extractLights(ctx(), shifted, eo), shifted, ro);
  EXPECT_TRUE(a.image.pixels == b.image.pixels);
  // ... and differs from the unturned map's background.
  Frame c = r.render(scene, cam, extractLights(ctx(), env, eo), env, ro);
  EXPECT_FALSE(a.image.pixels == c.image.pixels);
}

// The Embree reference reads the turned map: its background equals the shifted map's exactly, and
// its lit pixels agree with the shifted map's within the references' own Monte Carlo noise
// (different samples: the CDFs are the same texels in a different order), while the unturned
// map's reference does not.
//
// Criterion, per pixel over the geometry: relative RMSE(turned, shifted) < kTol x noise, noise the
// relative noise of one reference (its two half-sample estimates, ReferenceImage::relativeNoise).
// Two independent estimates of the same image differ by sqrt(2) x noise in expectation (the two
// share much of their sampling, so less: measured 0.28 x noise at 64 spp); kTol = 1.5 sqrt(2)
// leaves half again for the scatter of both figures over ~1000 pixels. The control: the unturned
// map (the turn ignored) must exceed twice that tolerance. Measured at 1024 spp: see the printout
// (noise 0.030, turned vs shifted 0.008, unturned 0.200). The mean over the lit pixels, which an
// earlier version compared within 5%, moves by only 1.24% under this turn and could not tell
// them apart; per pixel, the sun's shadows move.
TEST(EnvRotation, ReferenceSeesTheTurnedMap) {
  Environment env = builtinEnvironment(256);
  Environment rot = env;
  rot.rotationYDeg = 90.0f;
  const Environment shifted = shiftedQuarter(env);
  Scene scene = builtinScene();
  Camera cam = frameCamera(scene, 2.0f);
  ReferenceOptions ro;
  ro.width = 48;
  ro.height = 24;
  ro.spp = 1024;
  const ReferenceImage a = referenceEnvironmentWithNoise(scene, cam, rot, ro);
  const Image b = referenceEnvironment(scene, cam, shifted, ro);
  const Image c = referenceEnvironment(scene, cam, env, ro);
  for (int i = 0; i < b.width * b.height; ++i)
    if (b.pixels[4 * i + 3] == 0.0f)
      for (int k = 0; k < 3; ++k) ASSERT_EQ(a.image.pixels[4 * i + k], b.pixels[4 * i + k]) << i;
  const double kTol = 1.5 * std::sqrt(2.0);
  const double noise = a.relativeNoise;
  const ImageMetrics same = compareImages(a.image, b), turnIgnored = compareImages(c, b);
  std::printf("[ rotation ] reference per pixel: noise %.4f, turned vs shifted %.4f (tolerance "
              "%.4f), unturned vs shifted %.4f\n",
              noise, same.relativeRmse, kTol * noise, turnIgnored.relativeRmse);
  ASSERT_TRUE(std::isfinite(noise));
  ASSERT_GT(same.pixels, 300u);
  EXPECT_LT(same.relativeRmse, kTol * noise);
  EXPECT_GT(turnIgnored.relativeRmse, 2 * kTol * noise);
}

// Both resampling kernels with a fractional turn on a tiny map whose radiance depends on the row
// only (so the turn must not change it): splatting conserves the map's power up to fixed-point
// rounding, gathering reads the same row values whatever the column, so its cube is the unturned
// one exactly.
TEST(OclgrindEnvRotation, SplatAndGatherWithFractionalTurn) {
  Environment env;
  env.source = "rows";
  env.equirect = Image(16, 8, 3);
  for (int t = 0; t < 8; ++t)
    for (int s = 0; s < 16; ++s)
      for (int c = 0; c < 3; ++c) env.equirect.at(s, t, c) = 1.0f + t + 0.5f * c;
  double p[3];
  env.power(p);
  Environment rot = env;
  rot.rotationYDeg = 37.5f;
  const Image splat = cubeMapEnergy(ctx(), rot, 2, 2);  // 16 >= 4*2: splat
  double sum = 0;
  for (std::size_t i = 1; i < splat.pixels.size(); i += 3) sum += splat.pixels[i];
  EXPECT_NEAR(sum, p[1], 1e-4 * p[1]);
  // 16 < 4*8: gather
  EXPECT_TRUE(cubeMapEnergy(ctx(), rot, 8, 2).pixels == cubeMapEnergy(ctx(), env, 8, 2).pixels);
}

// ---------------------------------------------------------------------------------------------
// The moving built-in scene.

namespace {
const Mesh* meshNamed(const Scene& s, const std::string& name) {
  for (auto& m : s.meshes)
    if (m.name == name) return &m;
  return nullptr;
}
}  // namespace

TEST(AnimatedScene, TimeZeroIsTheStaticScene) {
  const Scene a = builtinScene(), b = builtinScene(0.0f);
  ASSERT_EQ(a.meshes.size(), b.meshes.size());
  for (std::size_t i = 0; i < a.meshes.size(); ++i)
    EXPECT_TRUE(a.meshes[i].positions == b.meshes[i].positions) << a.meshes[i].name;
  EXPECT_THROW(builtinScene(std::nanf("")), Error);
}

TEST(AnimatedScene, SphereBouncesAndSlabTurns) {
  const Scene s0 = builtinScene(0.0f), hop = builtinScene(0.75f), quarter = builtinScene(2.5f);
  auto lowest = [](const Mesh* m) {
    float y = 1e9f;
    for (auto& p : m->positions) y = std::min(y, p[1]);
    return y;
  };
  // Mid-hop (half the 1.5 s period) the sphere is 0.8 m up; on the ground at whole periods.
  EXPECT_NEAR(lowest(meshNamed(hop, "sphere")) - lowest(meshNamed(s0, "sphere")), 0.8f, 1e-4f);
  EXPECT_NEAR(lowest(meshNamed(builtinScene(3.0f), "sphere")), lowest(meshNamed(s0, "sphere")),
              1e-4f);
  // A quarter of the slab's 10 s turn: every vertex turned 90 degrees about the slab's centre.
  const Mesh* a = meshNamed(s0, "slab");
  const Mesh* b = meshNamed(quarter, "slab");
  ASSERT_EQ(a->positions.size(), b->positions.size());
  for (std::size_t i = 0; i < a->positions.size(); ++i) {
    std::array<float, 3> rel{a->positions[i][0] - 1.1f, a->positions[i][1],
                             a->positions[i][2] + 1.2f};
    auto want = rotY(rel, 90);
    EXPECT_NEAR(b->positions[i][0], want[0] + 1.1f, 1e-4f);
    EXPECT_NEAR(b->positions[i][1], want[1], 1e-6f);
    EXPECT_NEAR(b->positions[i][2], want[2] - 1.2f, 1e-4f);
  }
  // Other objects stand still.
  EXPECT_TRUE(meshNamed(s0, "box")->positions == meshNamed(hop, "box")->positions);
}

// The camera framed on the scene at time 0 sees every object vertex at every time of the motion's
// common period (lcm of 1.5 s and 10 s = 30 s), sampled at 24 frames per second.
TEST(AnimatedScene, EverythingStaysInViewOfTheTimeZeroCamera) {
  for (float aspect : {16.0f / 9.0f, 1.0f, 0.5f}) {
    const Camera cam = frameCamera(builtinScene(0.0f), aspect);
    const int W = 1000, H = int(std::lround(1000 / aspect));
    const CameraBasis b = cameraBasis(cam, W, H);
    double worst = 0;
    for (int f = 0; f <= 30 * 24; ++f) {
      const Scene s = builtinScene(f / 24.0f);
      for (auto& m : s.meshes) {
        if (m.name == "ground") continue;
        for (auto& p : m.positions) {
          const Vec3 d{p[0] - b.eye[0], p[1] - b.eye[1], p[2] - b.eye[2]};
          const double z = d[0] * b.forward[0] + d[1] * b.forward[1] + d[2] * b.forward[2];
          ASSERT_GT(z, 0);
          const double x = (d[0] * b.right[0] + d[1] * b.right[1] + d[2] * b.right[2]) / (z * b.tanHalfX);
          const double y = (d[0] * b.up[0] + d[1] * b.up[1] + d[2] * b.up[2]) / (z * b.tanHalfY);
          worst = std::max({worst, std::fabs(x), std::fabs(y)});
        }
      }
    }
    EXPECT_LT(worst, 1.0) << "aspect " << aspect;
  }
}

// Moving objects move their shadows: the ground around them changes between two times.
TEST(AnimatedScene, ShadowsMove) {
  Environment env = builtinEnvironment(256);
  const Camera cam = frameCamera(builtinScene(0.0f), 2.0f);
  RenderOptions ro;
  ro.width = 96;
  ro.height = 48;
  ro.shadowMapSize = 128;
  ExtractOptions eo;
  eo.medianCut.lights = 8;
  eo.medianCut.faceSize = 32;
  eo.ambient = false;
  const LightSet lights = extractLights(ctx(), env, eo);
  Renderer r(ctx());
  const Frame a = r.render(builtinScene(0.0f), cam, lights, env, ro);
  const Frame b = r.render(builtinScene(0.75f), cam, lights, env, ro);
  // Pixels that are ground in both frames (same G-buffer is not checked here: the lit ground is
  // ~0.2..2 in these units) and changed by more than 10%.
  int changed = 0;
  for (int i = 0; i < ro.width * ro.height; ++i)
    if (a.image.pixels[4 * i + 3] > 0 && b.image.pixels[4 * i + 3] > 0 &&
        std::fabs(a.image.pixels[4 * i + 1] - b.image.pixels[4 * i + 1]) >
            0.1f * std::max(a.image.pixels[4 * i + 1], 1e-3f))
      ++changed;
  EXPECT_GT(changed, 20);
}

// ---------------------------------------------------------------------------------------------
// Temporal stability (issue 4, "Done when"): turning the map 1 degree per frame changes the
// rendered default scene's mean radiance (over geometry pixels; the background is the map itself)
// by less than 2% per frame. The full default pipeline: 32 lights on a 256 cube plus the ambient.

class TemporalStability : public ::testing::TestWithParam<const char*> {};

TEST_P(TemporalStability, OneDegreePerFrameChangesMeanRadianceBelowTwoPercent) {
  ExtractOptions eo;
  eo.method = parseExtractionMethod(GetParam());
  const Scene scene = builtinScene();
  const Camera cam = frameCamera(scene, 2.0f);
  RenderOptions ro;
  // Small frames: the mean over ~1000 geometry pixels is what is measured, and the extraction at
  // its default sizes is what is exercised.
  ro.width = 64;
  ro.height = 32;
  ro.shadowMapSize = 64;
  Renderer r(ctx());
  // The default scene under the default sky (its small bright sun is the hardest case: one light
  // carries most of the power); other maps: `penumbra render --frames 91 --env MAP --report`.
  for (const char* map : {"builtin"}) {
    Environment env = std::string(map) == "builtin" ? builtinEnvironment() : loadEnvironment(data(map));
    // 0..90 degrees in 1-degree steps: a quarter turn is a full cycle of the cube's faces, so every
    // way a feature can cross a face edge happens in it.
    double prev = -1, worst = 0;
    int worstFrame = -1;
    std::size_t minLights = 1u << 30, maxLights = 0;
    std::array<float, 3> centroid0{}, centroid90{};
    for (int f = 0; f <= 90; ++f) {
      env.rotationYDeg = float(f);
      const LightSet lights = extractLights(ctx(), env, eo);
      // The lights' power-weighted mean direction, to check that they turn with the map (a
      // method that ignored the rotation would pass the stability bound trivially).
      std::array<float, 3> c{0, 0, 0};
      for (auto& l : lights.lights)
        for (int k = 0; k < 3; ++k) c[k] += float(lum(l.power)) * l.direction[k];
      if (f == 0) centroid0 = c;
      if (f == 90) centroid90 = c;
      minLights = std::min(minLights, lights.lights.size());
      maxLights = std::max(maxLights, lights.lights.size());
      const Frame fr = r.render(scene, cam, lights, env, ro);
      double sum = 0;
      int n = 0;
      for (int i = 0; i < ro.width * ro.height; ++i)
        if (fr.image.pixels[4 * i + 3] > 0) {
          const float* p = &fr.image.pixels[4 * i];
          sum += PB_LUM_R * p[0] + PB_LUM_G * p[1] + PB_LUM_B * p[2];
          ++n;
        }
      ASSERT_GT(n, 0);
      const double mean = sum / n;
      if (prev > 0) {
        const double change = std::fabs(mean - prev) / prev;
        if (change > worst) worst = change, worstFrame = f;
      }
      prev = mean;
    }
    std::printf("[ stability ] %s on %s: max per-frame change of mean radiance %.3f%% (frame %d), "
                "%zu..%zu lights\n",
                GetParam(), map, 100 * worst, worstFrame, minLights, maxLights);
    EXPECT_GT(minLights, 0u);
    // 3 degrees: the cuts themselves may differ after a quarter turn (see
    // EnvRotation.MedianCutLightsTurnWithTheMap), the energy-weighted mean direction barely.
    const double turnErr = angleDeg(rotY(centroid0, 90), centroid90);
    std::printf("[ stability ] %s on %s: lights' mean direction after 90 frames off the turned "
                "one by %.3f deg\n", GetParam(), map, turnErr);
    EXPECT_LT(turnErr, 3.0) << map;
    EXPECT_LT(worst, 0.02) << map;
  }
}

INSTANTIATE_TEST_SUITE_P(Methods, TemporalStability,
                         ::testing::Values("median-cut", "center-surround", "greedy"),
                         [](const auto& info) {
                           std::string n = info.param;
                           n.erase(std::remove(n.begin(), n.end(), '-'), n.end());
                           return n;
                         });

// ---------------------------------------------------------------------------------------------
// `penumbra render --frames` through the command line.

namespace {

struct CliRun {
  int code = -1;
  std::string out, err;
};

std::string slurp(const fs::path& p) {
  std::ifstream f(p);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

// Runs the CLI in `dir` through the shell (arguments single-quoted), default device.
CliRun cli(const fs::path& dir, const std::vector<std::string>& args) {
  std::string cmd = "cd '" + dir.string() + "' && env -u PENUMBRA_DEVICE '" + PENUMBRA_CLI + "'";
  for (auto& a : args) cmd += " '" + a + "'";
  cmd += " > stdout.txt 2> stderr.txt";
  CliRun r;
  int st = std::system(cmd.c_str());
  r.code = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  r.out = slurp(dir / "stdout.txt");
  r.err = slurp(dir / "stderr.txt");
  fs::remove(dir / "stdout.txt");
  fs::remove(dir / "stderr.txt");
  return r;
}

// Named by process too: two test runs at once (two checkouts, or CI beside a developer) must not
// share a directory, or one run's stderr.txt is read by the other.
fs::path freshDir(const std::string& name) {
  fs::path d = fs::path(::testing::TempDir()) /
               ("penumbra_anim_" + std::to_string(::getpid()) + "_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

std::vector<std::string> filesIn(const fs::path& d) {
  std::vector<std::string> names;
  for (auto& e : fs::directory_iterator(d)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

}  // namespace

TEST(CliAnimation, FramesAreNumberedAndReported) {
  const fs::path d = freshDir("frames");
  fs::create_directories(d / "anim");
  CliRun r = cli(d, {"render", "--frames", "3", "--size", "48x27", "--lights", "4", "--face-size",
                     "16", "--shadow-map-size", "32", "--env-rotate", "10", "--rotate-step", "5",
                     "--frame-time", "0.5", "--out", "anim/f.png", "--report", "anim/r.json"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(filesIn(d / "anim"),
            (std::vector<std::string>{"f_0000.png", "f_0001.png", "f_0002.png", "r.json"}));
  Image a = readImage((d / "anim/f_0000.png").string()), b = readImage((d / "anim/f_0002.png").string());
  EXPECT_EQ(a.width, 48);
  EXPECT_FALSE(a.pixels == b.pixels);  // the sky turned and the sphere rose
  const std::string text = slurp(d / "anim/r.json");
  const nlohmann::json json = nlohmann::json::parse(text);
  ASSERT_TRUE(json.is_array()) << text.substr(0, 400);
  ASSERT_EQ(json.size(), 3u) << text.substr(0, 400);
  for (std::size_t k = 0; k < 3; ++k) {
    const nlohmann::json& frame = json[k];
    EXPECT_EQ(frame["frame"], k) << frame.dump(2);
    // --frame-time 0.5, --env-rotate 10 turned by --rotate-step 5 per frame
    EXPECT_DOUBLE_EQ(frame["time_s"].get<double>(), 0.5 * double(k)) << frame.dump(2);
    EXPECT_DOUBLE_EQ(frame["env_rotation_deg"].get<double>(), 10.0 + 5.0 * double(k));
    EXPECT_EQ(frame["out"], "f_000" + std::to_string(k) + ".png");
    EXPECT_EQ(frame["lights"], 4);
    // The lights are extracted on frame 0 and turned with the map after it (rotateLightSet), so
    // extraction's stages are timed on frame 0 only.
    EXPECT_EQ(frame["lights_from"], k == 0 ? "extracted" : "turned") << frame.dump(2);
    bool extractTimes = false;
    for (const auto& [stage, ms] : frame["timings_ms"].items())
      extractTimes = extractTimes || stage.rfind("extract/", 0) == 0;
    EXPECT_EQ(extractTimes, k == 0) << frame["timings_ms"].dump(2);
  }
}

namespace {

// The frame `render --frames` draws in the tests below (studio.exr, 4 lights on a 16 cube, 48x27,
// 32^2 maps, the built-in scene at time 0), in process: the lights extracted from the map turned
// by extractedAtDeg, turned by `turnDeg`, the map turned by envDeg.
Image turnedFrame(float extractedAtDeg, float turnDeg, float envDeg) {
  ExtractOptions eo;
  eo.medianCut.lights = 4;
  eo.medianCut.faceSize = 16;
  RenderOptions ro;
  ro.width = 48;
  ro.height = 27;
  ro.shadowMapSize = 32;
  Environment env = loadEnvironment(data("envmaps/studio.exr"));
  env.rotationYDeg = extractedAtDeg;
  const LightSet first = extractLights(ctx(), env, eo);
  env.rotationYDeg = envDeg;
  const Scene scene = builtinScene();
  Renderer renderer(ctx());
  return renderer.render(scene, frameCamera(scene, 48.0f / 27.0f),
                         rotateLightSet(first, turnDeg), env, ro).image;
}

// Its options on the command line.
std::vector<std::string> turnArgs() {
  return {"--env",    data("envmaps/studio.exr"), "--size", "48x27", "--lights", "4",
          "--face-size", "16", "--shadow-map-size", "32"};
}

}  // namespace

// Frame 0 is extracted, later frames turn its lights with the map. --extract-each-frame extracts
// every frame from the turned map instead, so that each of its frames is the single frame of that
// turn. The turned frame is the in-process render of rotateLightSet's set, and differs from the
// re-extracted one (measured: 0.155 relative RMSE with these 4 lights on studio.exr at 40
// degrees): median cut cuts the turned map differently.
TEST(CliAnimation, LightsTurnWithTheMapUnlessExtractedEachFrame) {
  const fs::path d = freshDir("turn");
  auto run = [&](std::vector<std::string> extra) {
    std::vector<std::string> args = {"render", "--frames", "3", "--rotate-step", "20",
                                     "--frame-time", "0"};
    for (const std::string& x : turnArgs()) args.push_back(x);
    args.insert(args.end(), extra.begin(), extra.end());
    return cli(d, args);
  };
  CliRun a = run({"--out", "a.exr", "--report", "a.json"});
  ASSERT_EQ(a.code, 0) << a.err;
  CliRun b = run({"--extract-each-frame", "--out", "b.exr", "--report", "b.json"});
  ASSERT_EQ(b.code, 0) << b.err;
  std::vector<std::string> single = {"render", "--env-rotate", "40", "--out", "c.exr"};
  for (const std::string& x : turnArgs()) single.push_back(x);
  CliRun c = cli(d, single);
  ASSERT_EQ(c.code, 0) << c.err;
  const nlohmann::json ra = nlohmann::json::parse(slurp(d / "a.json"));
  const nlohmann::json rb = nlohmann::json::parse(slurp(d / "b.json"));
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(ra[k]["lights_from"], k == 0 ? "extracted" : "turned");
    EXPECT_EQ(rb[k]["lights_from"], "extracted");
  }
  auto img = [&](const char* name) { return readImage((d / name).string()); };
  EXPECT_EQ(img("a_0000.exr").pixels, img("b_0000.exr").pixels);
  EXPECT_EQ(img("b_0002.exr").pixels, img("c.exr").pixels);

  // Frame 2 in process: frame 0's lights turned by 40 degrees, the map turned by 40 (--frame-time
  // 0: the scene stands still).
  const ImageMetrics same = compareImages(img("a_0002.exr"), turnedFrame(0.0f, 40.0f, 40.0f));
  const ImageMetrics reextracted = compareImages(img("a_0002.exr"), img("b_0002.exr"));
  std::printf("[ rotation ] CLI frame 2 (turned lights) vs in-process render: %.2e; vs the frame "
              "re-extracted from the turned map: %.4f (relative RMSE)\n", same.relativeRmse,
              reextracted.relativeRmse);
  EXPECT_GT(same.pixels, 100u);
  EXPECT_LT(same.relativeRmse, 1e-6);
  EXPECT_GT(reextracted.relativeRmse, 1e-3);

  // With a given light set there is nothing to extract: refused, nothing written.
  const fs::path e = freshDir("turn_lightset");
  {
    std::ofstream f(e / "set.json");
    f << R"({"lights": [{"direction": [0, 1, 0], "half_angle_deg": 10, "radiance": [1, 1, 1]}]})";
  }
  CliRun bad = cli(e, {"render", "--frames", "2", "--size", "16x9", "--light-set", "set.json",
                       "--extract-each-frame", "--out", "f.png"});
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.err.find("--extract-each-frame"), std::string::npos) << bad.err;
  EXPECT_EQ(filesIn(e), (std::vector<std::string>{"set.json"}));
  fs::remove_all(d);
  fs::remove_all(e);
}

// The turn since the extraction across the wrap at 360 degrees and with a negative step: from 355
// in steps of 7, frame 2 is at 9 degrees, 14 past the extraction; from 10 in steps of -7, at -4,
// 14 before it. Each CLI frame is the in-process frame of the set turned by that much (measured
// 0: the same floats), and not the frame of the set turned the other way.
TEST(CliAnimation, TurnsFollowTheWrapAndNegativeSteps) {
  const fs::path d = freshDir("wrap");
  struct Case {
    const char *start, *step;
    float startDeg, frame2Deg, turnDeg;
  };
  for (const Case& k :
       {Case{"355", "7", 355.0f, 9.0f, 14.0f}, Case{"10", "-7", 10.0f, -4.0f, -14.0f}}) {
    SCOPED_TRACE(std::string(k.start) + " by " + k.step);
    std::vector<std::string> args = {"render", "--frames", "3", "--frame-time", "0",
                                     "--env-rotate", k.start, "--rotate-step", k.step,
                                     "--out", "w.exr", "--report", "w.json"};
    for (const std::string& x : turnArgs()) args.push_back(x);
    CliRun r = cli(d, args);
    ASSERT_EQ(r.code, 0) << r.err;
    const nlohmann::json json = nlohmann::json::parse(slurp(d / "w.json"));
    EXPECT_DOUBLE_EQ(json[2]["env_rotation_deg"].get<double>(), double(k.frame2Deg));
    EXPECT_EQ(json[2]["lights_from"], "turned");
    const Image got = readImage((d / "w_0002.exr").string());
    const ImageMetrics right =
        compareImages(got, turnedFrame(k.startDeg, k.turnDeg, k.frame2Deg));
    const ImageMetrics wrong =
        compareImages(got, turnedFrame(k.startDeg, -k.turnDeg, k.frame2Deg));
    std::printf("[ rotation ] from %s by %s: frame 2 vs the set turned %+.0f: %.2e, turned %+.0f: "
                "%.4f (relative RMSE)\n", k.start, k.step, k.turnDeg, right.relativeRmse,
                -k.turnDeg, wrong.relativeRmse);
    EXPECT_LT(right.relativeRmse, 1e-6);
    EXPECT_GT(wrong.relativeRmse, 1e-3);
  }
  fs::remove_all(d);
}

TEST(CliAnimation, MapListCycles) {
  const fs::path d = freshDir("maps");
  const std::string list = data("envmaps/studio.exr") + "," + data("envmaps/courtyard.exr");
  CliRun r = cli(d, {"render", "--frames", "3", "--env", list, "--size", "32x18", "--lights", "2",
                     "--face-size", "8", "--shadows", "none", "--out", "m.exr", "--report",
                     "r.json"});
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json json = nlohmann::json::parse(slurp(d / "r.json"));
  ASSERT_TRUE(json.is_array());
  ASSERT_EQ(json.size(), 3u) << json.dump(2);
  const char* maps[] = {"studio.exr", "courtyard.exr", "studio.exr"};
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_EQ(json[k]["frame"], k);
    const std::string env = json[k]["environment"].get<std::string>();
    EXPECT_NE(env.find(maps[k]), std::string::npos) << k << ": " << env;
    // With a list the default step is 0: the maps animate, not the rotation.
    EXPECT_EQ(json[k]["env_rotation_deg"].get<double>(), 0.0) << k;
    // Each map's own lights, extracted once: frame 2 shows studio again, unturned.
    EXPECT_EQ(json[k]["lights_from"], k < 2 ? "extracted" : "reused") << k;
    bool extractTimes = false;
    for (const auto& [stage, ms] : json[k]["timings_ms"].items())
      extractTimes = extractTimes || stage.rfind("extract/", 0) == 0;
    EXPECT_EQ(extractTimes, k < 2) << k;
  }
}

// --lights auto with a list of maps: each map gets the count `lights --lights auto` chooses for it
// alone, on the first frame that shows it, and keeps it when shown again. The two maps need
// different counts (26 and 5 at these options, measured), so a render that kept the first map's
// count for both (as it did before 2026-12-04) fails frame 1.
TEST(CliAnimation, LightsAutoChoosesACountForEachMapOfAList) {
  const fs::path d = freshDir("autolist");
  const std::vector<std::string> maps = {"builtin", data("envmaps/courtyard.exr")};
  const std::vector<std::string> autoArgs = {"--lights", "auto", "--target-error", "0.08",
                                             "--face-size", "32"};
  std::vector<std::size_t> counts;
  for (std::size_t k = 0; k < maps.size(); ++k) {
    const std::string file = "l" + std::to_string(k) + ".json";
    std::vector<std::string> args = {"lights", "--env", maps[k], "--out", file};
    args.insert(args.end(), autoArgs.begin(), autoArgs.end());
    CliRun r = cli(d, args);
    ASSERT_EQ(r.code, 0) << r.err;
    counts.push_back(loadLightSet((d / file).string()).lights.size());
  }
  ASSERT_NE(counts[0], counts[1]) << "the maps must need different counts for this test to tell";
  std::vector<std::string> args = {"render", "--frames", "3", "--env", maps[0] + "," + maps[1],
                                   "--size", "16x9", "--shadows", "none", "--out", "a.exr",
                                   "--report", "r.json"};
  args.insert(args.end(), autoArgs.begin(), autoArgs.end());
  CliRun r = cli(d, args);
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json json = nlohmann::json::parse(slurp(d / "r.json"));
  ASSERT_EQ(json.size(), 3u) << json.dump(2);
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_EQ(json[k]["lights"].get<std::size_t>(), counts[k % 2]) << k;
    EXPECT_EQ(json[k]["lights_from"], k < 2 ? "extracted" : "reused") << k;
  }
  // one search per map, each said on stderr with the map it was for
  std::size_t said = 0;
  for (std::size_t at = r.err.find("--lights auto: "); at != std::string::npos;
       at = r.err.find("--lights auto: ", at + 1))
    ++said;
  EXPECT_EQ(said, 2u) << r.err;
  EXPECT_NE(r.err.find(std::to_string(counts[1]) + " lights for " + maps[1]), std::string::npos)
      << r.err;
}

// Without --frames the output keeps its name (no frame number), and the frame is the turned
// scene's: it equals a direct render of the map turned by -45 degrees (same extraction, same
// options) within 1e-4 relative RMSE (measured 0: the EXR holds the floats as rendered, and both
// renders are deterministic, so there is no noise to allow for), and differs from the direct
// render of the unturned map by more than 0.02 (measured 0.045: the two lights and the sky move).
TEST(CliAnimation, SingleFrameKeepsItsNameAndTurns) {
  const fs::path d = freshDir("single");
  CliRun r = cli(d, {"render", "--size", "32x18", "--lights", "2", "--face-size", "8",
                     "--shadows", "none", "--env-rotate", "-45", "--out", "one.exr"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(filesIn(d), (std::vector<std::string>{"one.exr"}));

  ExtractOptions eo;
  eo.medianCut.lights = 2;
  eo.medianCut.faceSize = 8;
  RenderOptions ro;
  ro.width = 32;
  ro.height = 18;
  ro.shadows = ShadowTechnique::None;
  Scene scene = builtinScene();
  Renderer renderer(ctx());
  auto direct = [&](float turnDeg) {
    Environment env = builtinEnvironment();
    env.rotationYDeg = turnDeg;
    return renderer.render(scene, frameCamera(scene, 32.0f / 18.0f), extractLights(ctx(), env, eo), env, ro).image;
  };
  const Image one = readImage((d / "one.exr").string());
  const ImageMetrics turned = compareImages(one, direct(-45.0f)), unturned = compareImages(one, direct(0.0f));
  std::printf("[ rotation ] CLI --env-rotate -45 vs direct render of the turned map: %.2e; vs the "
              "unturned map's: %.4f (relative RMSE over %zu geometry pixels)\n",
              turned.relativeRmse, unturned.relativeRmse, turned.pixels);
  EXPECT_GT(turned.pixels, 100u);
  EXPECT_LT(turned.relativeRmse, 1e-4);
  EXPECT_GT(unturned.relativeRmse, 0.02);
  fs::remove_all(d);
}

TEST(CliAnimation, BadValuesExitTwoAndWriteNothing) {
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{"--frames", "0"}, "--frames"},
      {{"--frames", "x"}, "--frames"},
      {{"--frames", "2", "--frame-time", "-1"}, "--frame-time"},
      {{"--frames", "2", "--frame-time", "inf"}, "--frame-time"},
      {{"--frames", "2", "--rotate-step", "nan"}, "--rotate-step"},
      {{"--env-rotate", "1e40"}, "--env-rotate"},
      {{"--rotate-step", "1"}, "--rotate-step"},
      {{"--extract-each-frame"}, "--extract-each-frame"},
      {{"--env", "builtin,,builtin"}, "--env"},
      {{"--extract", "bogus"}, "--extract"},
      {{"--frames", "2", "--env", "builtin,missing.exr"}, "missing.exr"},
      // strict numbers: no hex, no leading zero, no decimal comma
      {{"--frames", "0x3"}, "--frames"},
      {{"--frames", "03"}, "--frames"},
      {{"--frames", "2", "--frame-time", "0,5"}, "--frame-time"},
      // a stray argument and a misspelt option
      {{"--frames", "2", "stray"}, "stray"},
      {{"--frame", "2"}, "did you mean --frames?"},
  };
  for (auto& [extra, needle] : cases) {
    const fs::path d = freshDir("bad");
    std::vector<std::string> args{"render", "--size", "16x9", "--out", "f.png", "--report", "r.json"};
    args.insert(args.end(), extra.begin(), extra.end());
    CliRun r = cli(d, args);
    EXPECT_EQ(r.code, 2) << needle;
    EXPECT_NE(r.err.find(needle), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_TRUE(filesIn(d).empty()) << needle;
  }
}

TEST(CliAnimation, HelpStatesTheNumberingRule) {
  const fs::path d = freshDir("help");
  CliRun r = cli(d, {"render", "--help"});
  ASSERT_EQ(r.code, 0);
  for (const char* s : {"--frames", "--frame-time", "--rotate-step", "--env-rotate", "_0000",
                        "center-surround"})
    EXPECT_NE(r.out.find(s), std::string::npos) << s;
}
