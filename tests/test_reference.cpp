// Tests of the Embree ground truth against closed forms (furnace tests, cap irradiance, a sun in a
// piecewise-constant map, a hard occluder), its determinism and input checks, and of the image
// metrics on hand-computed images.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <cstring>
#include <functional>
#include <stdexcept>
#include <limits>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "penumbra/environment.hpp"
#include "penumbra/error.hpp"
#include "penumbra/lights.hpp"
#include "penumbra/reference.hpp"
#include "penumbra/scene.hpp"
#include "common/shared.h"
#include "support/expect_error.hpp"

namespace {

using namespace penumbra;
using penumbra::test::expectBadInput;
constexpr double kPi = 3.14159265358979323846;

// A square at height y, half-size h, facing +y (two-sided anyway), optionally with vertex normals.
Mesh quad(float y, float h, Vec3 albedo = {0.5f, 0.5f, 0.5f}, std::vector<Vec3> normals = {}) {
  Mesh m;
  m.name = "quad";
  m.positions = {{-h, y, -h}, {h, y, -h}, {h, y, h}, {-h, y, h}};
  m.triangles = {{0, 2, 1}, {0, 3, 2}};
  m.normals = std::move(normals);
  m.albedo = albedo;
  return m;
}

Scene groundScene(Vec3 albedo = {0.5f, 0.5f, 0.5f}) {
  Scene s;
  s.meshes.push_back(quad(0.0f, 50.0f, albedo));
  return s;
}

// Looking down at the origin at 45 degrees; with a 50 m ground every pixel sees the ground.
Camera obliqueCamera() {
  Camera c;
  c.eye = {0, 3, 3};
  c.target = {0, 0, 0};
  c.up = {0, 1, 0};
  c.fovyDeg = 40.0f;
  return c;
}

Environment constantEnv(int w, int h, float r, float g, float b) {
  Environment e;
  e.source = "test";
  e.equirect = Image(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      e.equirect.at(x, y, 0) = r;
      e.equirect.at(x, y, 1) = g;
      e.equirect.at(x, y, 2) = b;
    }
  return e;
}

ReferenceOptions smallOptions(int spp, int size = 32) {
  ReferenceOptions o;
  o.width = size;
  o.height = size;
  o.spp = spp;
  o.seed = 7;
  o.threads = 0;
  return o;
}

AreaLight capLight(std::array<float, 3> dir, float alphaDeg, float radiance) {
  AreaLight l;
  double n = std::sqrt(double(dir[0]) * dir[0] + double(dir[1]) * dir[1] + double(dir[2]) * dir[2]);
  l.direction = {float(dir[0] / n), float(dir[1] / n), float(dir[2] / n)};
  l.cosAlpha = float(std::cos(alphaDeg * kPi / 180.0));
  l.radiance = {radiance, radiance, radiance};
  const float omega = float(2.0 * kPi * (1.0 - l.cosAlpha));
  l.power = {radiance * omega, radiance * omega, radiance * omega};
  return l;
}

struct Stats {
  double mean = 0, minV = 1e300, maxV = -1e300;
  int count = 0;
};

// Statistics of channel c over the geometry pixels (alpha 1).
Stats geometryStats(const Image& im, int c) {
  Stats s;
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x) {
      if (im.at(x, y, 3) != 1.0f) continue;
      double v = im.at(x, y, c);
      s.mean += v;
      s.minV = std::min(s.minV, v);
      s.maxV = std::max(s.maxV, v);
      ++s.count;
    }
  if (s.count) s.mean /= s.count;
  return s;
}

// Expects every geometry pixel (all channels) within relTol of `expected`, the image mean within
// meanTol, and full coverage.
void expectUniform(const Image& im, const double expected[3], double relTol, double meanTol) {
  ASSERT_EQ(im.channels, 4);
  for (int c = 0; c < 3; ++c) {
    Stats s = geometryStats(im, c);
    ASSERT_EQ(s.count, im.width * im.height) << "every pixel should see the ground";
    char info[160];
    std::snprintf(info, sizeof info, "channel %d: expected %.6g mean %.6g min %.6g max %.6g", c,
                  expected[c], s.mean, s.minV, s.maxV);
    SCOPED_TRACE(info);
    EXPECT_NEAR(s.mean, expected[c], meanTol * expected[c]);
    EXPECT_NEAR(s.minV, expected[c], relTol * expected[c]);
    EXPECT_NEAR(s.maxV, expected[c], relTol * expected[c]);
  }
}

// ---------------------------------------------------------------------------------------------
// Environment mode.

TEST(ReferenceEnvironment, WhiteFurnaceOnePixelMap) {
  // L = 1 everywhere: E = pi on the upward plane (the lower half is hidden by the plane itself),
  // L_o = albedo / pi * pi = 0.5.
  const Image im = referenceEnvironment(groundScene(), obliqueCamera(),
                                        constantEnv(1, 1, 1, 1, 1), smallOptions(4096, 8));
  const double expected[3] = {0.5, 0.5, 0.5};
  expectUniform(im, expected, 0.05, 0.01);
}

TEST(ReferenceEnvironment, WhiteFurnaceTexelMap) {
  const Image im = referenceEnvironment(groundScene(), obliqueCamera(),
                                        constantEnv(16, 8, 1, 1, 1), smallOptions(4096, 8));
  const double expected[3] = {0.5, 0.5, 0.5};
  expectUniform(im, expected, 0.05, 0.01);
}

TEST(ReferenceEnvironment, UpperHemisphereOnly) {
  // Sky 2, ground 0 (the horizon is a row boundary): L_o = 0.5 / pi * 2 pi = 1.
  Environment env = constantEnv(16, 8, 2, 2, 2);
  for (int y = 4; y < 8; ++y)
    for (int x = 0; x < 16; ++x)
      for (int c = 0; c < 3; ++c) env.equirect.at(x, y, c) = 0.0f;
  const Image im = referenceEnvironment(groundScene(), obliqueCamera(), env, smallOptions(4096, 8));
  const double expected[3] = {1.0, 1.0, 1.0};
  expectUniform(im, expected, 0.05, 0.01);
}

// Exact integral of L(texel) max(0, y) dw over an equirect map for the normal +y: within a row
// of the upper hemisphere the cosine integrates to (2 pi / W) (cos^2 theta0 - cos^2 theta1) / 2.
void upwardIrradiance(const Environment& env, double e[3]) {
  const int W = env.equirect.width, H = env.equirect.height;
  e[0] = e[1] = e[2] = 0;
  for (int r = 0; r < H; ++r) {
    double c0 = std::cos(kPi * r / H), c1 = std::cos(kPi * (r + 1) / H);
    c0 = std::max(0.0, c0);
    c1 = std::max(0.0, c1);
    const double w = 2.0 * kPi / W * 0.5 * (c0 * c0 - c1 * c1);
    for (int x = 0; x < W; ++x)
      for (int c = 0; c < 3; ++c) e[c] += env.equirect.at(x, r, c) * w;
  }
}

TEST(ReferenceEnvironment, SmallBrightSunMatchesIntegral) {
  // A 2x2-texel coloured "sun" of ~1e4 in a dim sky of 0.1: the map sampling finds the sun, the
  // cosine lobe the sky; the MIS sum must match the exact integral of the piecewise-constant map.
  Environment env = constantEnv(128, 64, 0.1f, 0.1f, 0.1f);
  for (int y = 18; y < 20; ++y)
    for (int x = 80; x < 82; ++x) {
      env.equirect.at(x, y, 0) = 1.0e4f;
      env.equirect.at(x, y, 1) = 0.8e4f;
      env.equirect.at(x, y, 2) = 0.5e4f;
    }
  double e[3];
  upwardIrradiance(env, e);
  const double albedo[3] = {0.5, 0.7, 0.3};
  double expected[3];
  for (int c = 0; c < 3; ++c) expected[c] = albedo[c] / kPi * e[c];
  ASSERT_GT(expected[0], 10.0 * 0.5 * 0.1);  // the sun dominates

  // Per pixel noise ~0.3% at 4096 spp (mostly the binomial split of map samples between sun and
  // sky), so 2% per pixel is a safe margin.
  const Image im = referenceEnvironment(groundScene({0.5f, 0.7f, 0.3f}), obliqueCamera(), env,
                                        smallOptions(4096, 8));
  expectUniform(im, expected, 0.02, 0.005);
}

TEST(ReferenceEnvironment, OddAndTinySampleCountsStayUnbiased) {
  // spp = 1: no map sample at all (n_e = 0), only the cosine lobe; spp = 3: one map sample and two
  // cosine samples. The average over many pixels must still converge to the integral (the
  // balance heuristic with sample counts is unbiased for any split).
  Environment env = constantEnv(16, 8, 0.5f, 0.5f, 0.5f);
  for (int x = 0; x < 16; ++x)
    for (int c = 0; c < 3; ++c) env.equirect.at(x, 1, c) = 3.0f;
  double e[3];
  upwardIrradiance(env, e);
  const double expected = 0.5 / kPi * e[0];
  for (int spp : {1, 3}) {
    const Image im = referenceEnvironment(groundScene(), obliqueCamera(), env, smallOptions(spp, 128));
    EXPECT_NEAR(geometryStats(im, 0).mean, expected, 0.03 * expected) << spp << " spp";
  }
}

TEST(ReferenceEnvironment, InterpolatedNormalsAreUsed) {
  // A flat plane whose vertex normals lean 30 degrees towards +x, under a sky of 2 (ground 0):
  // E = L pi (1 + cos 30) / 2 for the tilted normal (the part of its hemisphere under the plane
  // is dark, and also shadowed by the plane itself), so L_o = 0.5 * 2 * (1 + cos 30) / 2.
  Environment env = constantEnv(16, 8, 2, 2, 2);
  for (int y = 4; y < 8; ++y)
    for (int x = 0; x < 16; ++x)
      for (int c = 0; c < 3; ++c) env.equirect.at(x, y, c) = 0.0f;
  const float s30 = 0.5f, c30 = float(std::sqrt(3.0) / 2);
  Scene scene;
  scene.meshes.push_back(quad(0.0f, 50.0f, {0.5f, 0.5f, 0.5f},
                              std::vector<Vec3>(4, Vec3{s30, c30, 0.0f})));
  const Image im = referenceEnvironment(scene, obliqueCamera(), env, smallOptions(4096, 8));
  const double v = 0.5 * 2.0 * (1.0 + c30) / 2.0;
  const double expected[3] = {v, v, v};
  expectUniform(im, expected, 0.06, 0.01);
}

TEST(ReferenceEnvironment, BackgroundIsTheMapWithAlphaZero) {
  // A small ground quad seen from the side: pixels above it show the map (nearest texel).
  Environment env = constantEnv(8, 4, 0, 0, 0);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 8; ++x) {
      env.equirect.at(x, y, 0) = float(x);
      env.equirect.at(x, y, 1) = float(y);
      env.equirect.at(x, y, 2) = 1.0f;
    }
  Scene scene;
  scene.meshes.push_back(quad(0.0f, 1.0f));
  Camera cam;
  cam.eye = {0, 1, 4};
  cam.target = {0, 0.5f, 0};
  ReferenceOptions o = smallOptions(4, 24);
  const Image im = referenceEnvironment(scene, cam, env, o);
  o.environmentBackground = false;
  const Image black = referenceEnvironment(scene, cam, env, o);
  const CameraBasis b = cameraBasis(cam, o.width, o.height);
  int background = 0, geometry = 0;
  for (int y = 0; y < o.height; ++y)
    for (int x = 0; x < o.width; ++x) {
      if (im.at(x, y, 3) == 0.0f) {
        ++background;
        const Vec3 d = cameraRayDirection(b, o.width, o.height, x + 0.5f, y + 0.5f);
        float rgb[3];
        env.lookup(d[0], d[1], d[2], rgb);
        for (int c = 0; c < 3; ++c) {
          EXPECT_EQ(im.at(x, y, c), rgb[c]);
          EXPECT_EQ(black.at(x, y, c), 0.0f);
        }
      } else {
        EXPECT_EQ(im.at(x, y, 3), 1.0f);
        ++geometry;
      }
      EXPECT_EQ(im.at(x, y, 3), black.at(x, y, 3));
    }
  EXPECT_GT(background, 0);
  EXPECT_GT(geometry, 0);
}

// ---------------------------------------------------------------------------------------------
// Light mode.

TEST(ReferenceLights, CapStraightUp) {
  // E = L pi sin^2(alpha) for a cap around the normal, L_o = 0.5 sin^2(20 deg).
  LightSet ls;
  ls.lights.push_back(capLight({0, 1, 0}, 20.0f, 1.0f));
  const Image im = referenceLights(groundScene(), obliqueCamera(), ls, constantEnv(1, 1, 0, 0, 0),
                                   smallOptions(64));
  const double s = std::sin(20.0 * kPi / 180.0);
  const double expected[3] = {0.5 * s * s, 0.5 * s * s, 0.5 * s * s};
  expectUniform(im, expected, 0.02, 0.005);
}

TEST(ReferenceLights, SelectionInProportionToIrradianceIsUnbiased) {
  // Three lights: overhead, tilted 60 degrees (partly clipped by the horizon at alpha 35), and one
  // below the horizon that contributes nothing. The pixel is the sum of the closed forms.
  LightSet ls;
  ls.lights.push_back(capLight({0, 1, 0}, 10.0f, 2.0f));
  const float t = float(60.0 * kPi / 180.0);
  ls.lights.push_back(capLight({std::sin(t), std::cos(t), 0}, 35.0f, 0.7f));
  ls.lights.push_back(capLight({0, -1, 0.2f}, 15.0f, 5.0f));
  double e = 0;
  for (const AreaLight& l : ls.lights)
    e += l.radiance[0] * pb_cap_irradiance(l.cosAlpha, l.direction[1]);
  const double v = 0.5 / kPi * e;
  const Image im = referenceLights(groundScene(), obliqueCamera(), ls, constantEnv(1, 1, 0, 0, 0),
                                   smallOptions(8192, 8));
  const double expected[3] = {v, v, v};
  expectUniform(im, expected, 0.04, 0.01);
}

TEST(ReferenceLights, BlockerCastsUmbraAndPenumbra) {
  // A 2 m square blocker 0.5 m above the ground, the light straight up (alpha 20): ground points
  // whose 20-degree cone stays inside the blocker are black, points whose cone misses it are lit
  // as in CapStraightUp. A low camera sees part of the umbra under the blocker's front edge.
  // Pixels are classified analytically from the same camera rays.
  const double hb = 0.5;
  Scene scene = groundScene();
  scene.meshes.push_back(quad(float(hb), 1.0f));
  LightSet ls;
  ls.lights.push_back(capLight({0, 1, 0}, 20.0f, 1.0f));
  Camera cam;
  cam.eye = {0, 2, 5};
  cam.target = {0, 0, 0.3f};
  cam.fovyDeg = 30.0f;
  ReferenceOptions o = smallOptions(64, 48);
  const Image im = referenceLights(scene, cam, ls, constantEnv(1, 1, 0, 0, 0), o);

  const double s = std::sin(20.0 * kPi / 180.0), lit = 0.5 * s * s;
  const double reach = hb * std::tan(20.0 * kPi / 180.0), margin = 0.05;
  const CameraBasis b = cameraBasis(cam, o.width, o.height);
  int umbra = 0, litGround = 0, blocker = 0;
  for (int y = 0; y < o.height; ++y)
    for (int x = 0; x < o.width; ++x) {
      const Vec3 d = cameraRayDirection(b, o.width, o.height, x + 0.5f, y + 0.5f);
      if (d[1] >= -0.05f) continue;  // towards the horizon: far ground or sky
      ASSERT_EQ(im.at(x, y, 3), 1.0f);
      // The blocker (seen from above: its lit top face) first?
      const double t1 = (hb - cam.eye[1]) / d[1];
      const double bx = cam.eye[0] + t1 * d[0], bz = cam.eye[2] + t1 * d[2];
      if (std::fabs(bx) < 1.0 - 0.02 && std::fabs(bz) < 1.0 - 0.02) {
        EXPECT_NEAR(im.at(x, y, 0), lit, 0.02 * lit) << x << "," << y << " (blocker)";
        ++blocker;
        continue;
      }
      if (std::fabs(bx) < 1.0 + 0.02 && std::fabs(bz) < 1.0 + 0.02) continue;  // blocker edge
      const double t0 = -cam.eye[1] / d[1];
      const double gx = cam.eye[0] + t0 * d[0], gz = cam.eye[2] + t0 * d[2];
      if (std::fabs(gx) + reach < 1.0 - margin && std::fabs(gz) + reach < 1.0 - margin) {
        EXPECT_EQ(im.at(x, y, 0), 0.0f) << x << "," << y << " (umbra)";
        ++umbra;
      } else if (std::fabs(gx) > 1.0 + reach + margin || std::fabs(gz) > 1.0 + reach + margin) {
        EXPECT_NEAR(im.at(x, y, 0), lit, 0.02 * lit) << x << "," << y << " (lit)";
        ++litGround;
      }
    }
  EXPECT_GE(umbra, 30);
  EXPECT_GE(litGround, 300);
  EXPECT_GE(blocker, 100);
}

TEST(ReferenceLights, NoLightsIsBlackAndNeedsNoMapWithoutBackground) {
  ReferenceOptions o = smallOptions(4, 8);
  o.environmentBackground = false;
  const Image im = referenceLights(groundScene(), obliqueCamera(), LightSet{}, Environment{}, o);
  ASSERT_EQ(im.channels, 4);
  for (int y = 0; y < o.height; ++y)
    for (int x = 0; x < o.width; ++x) {
      EXPECT_EQ(im.at(x, y, 0), 0.0f);
      EXPECT_EQ(im.at(x, y, 3), 1.0f);
    }
}

// ---------------------------------------------------------------------------------------------
// Shared behaviour: determinism, threads, progress, input checks.

TEST(ReferenceCommon, DeterministicAcrossThreadCounts) {
  Scene scene = groundScene();
  scene.meshes.push_back(quad(0.6f, 0.5f));
  Environment env = constantEnv(32, 16, 0.2f, 0.3f, 0.4f);
  env.equirect.at(20, 4, 0) = 500.0f;
  LightSet ls;
  ls.lights.push_back(capLight({0.3f, 1, 0}, 15.0f, 3.0f));
  ReferenceOptions o = smallOptions(16, 24);
  o.threads = 1;
  const Image a = referenceEnvironment(scene, obliqueCamera(), env, o);
  const Image la = referenceLights(scene, obliqueCamera(), ls, env, o);
  o.threads = 2;
  const Image b = referenceEnvironment(scene, obliqueCamera(), env, o);
  const Image lb = referenceLights(scene, obliqueCamera(), ls, env, o);
  o.threads = 5;
  const Image c = referenceEnvironment(scene, obliqueCamera(), env, o);
  ASSERT_EQ(a.pixels.size(), b.pixels.size());
  EXPECT_EQ(0, std::memcmp(a.pixels.data(), b.pixels.data(), a.pixels.size() * sizeof(float)));
  EXPECT_EQ(0, std::memcmp(a.pixels.data(), c.pixels.data(), a.pixels.size() * sizeof(float)));
  EXPECT_EQ(0, std::memcmp(la.pixels.data(), lb.pixels.data(), la.pixels.size() * sizeof(float)));
  o.seed += 1;
  const Image d = referenceEnvironment(scene, obliqueCamera(), env, o);
  const Image ld = referenceLights(scene, obliqueCamera(), ls, env, o);
  EXPECT_NE(0, std::memcmp(a.pixels.data(), d.pixels.data(), a.pixels.size() * sizeof(float)));
  EXPECT_NE(0, std::memcmp(la.pixels.data(), ld.pixels.data(), la.pixels.size() * sizeof(float)));
}

TEST(ReferenceCommon, ProgressIsMonotonicAndEndsAtOne) {
  // From the calling thread only, increasing, ending at exactly 1.
  for (int threads : {1, 3}) {
    SCOPED_TRACE(threads);
    std::vector<double> seen;
    bool otherThread = false;
    const auto caller = std::this_thread::get_id();
    ReferenceOptions o = smallOptions(8, 40);
    o.threads = threads;
    o.progress = [&](double f) {
      seen.push_back(f);
      otherThread = otherThread || std::this_thread::get_id() != caller;
    };
    referenceEnvironment(groundScene(), obliqueCamera(), constantEnv(1, 1, 1, 1, 1), o);
    ASSERT_GE(seen.size(), threads == 1 ? 40u : 1u);
    // Every poll reports, so a value may repeat when no pixel finished in between.
    for (std::size_t i = 1; i < seen.size(); ++i) EXPECT_GE(seen[i], seen[i - 1]);
    EXPECT_EQ(seen.front(), 0.0);  // the poll before any work
    EXPECT_EQ(seen.back(), 1.0);
    EXPECT_EQ(std::count(seen.begin(), seen.end(), 1.0), 1);
    EXPECT_FALSE(otherThread);
  }
}

TEST(ReferenceCommon, ExceptionFromProgressPropagates) {
  for (int threads : {1, 2}) {
    ReferenceOptions o = smallOptions(2, 40);
    o.threads = threads;
    o.progress = [](double) { throw std::runtime_error("cancelled"); };
    EXPECT_THROW(
        referenceEnvironment(groundScene(), obliqueCamera(), constantEnv(1, 1, 1, 1, 1), o),
        std::runtime_error);
  }
}

// A frame of long pixels (131072 samples, about 17 ms each on an idle core here; two rows of 80,
// each about 1.4 s, the frame 2.8 s on one thread). The stops below come at 15%, early in the
// rows: a stop that waited for the end of a row, not of a pixel, would miss the half-second
// bound, and polls only at the ends of rows would first come at 50%.
struct LongFrame {
  Scene scene = groundScene();
  Environment env = constantEnv(8, 4, 0.5f, 0.5f, 0.5f);
  Camera camera = obliqueCamera();
  ReferenceOptions opt = smallOptions(131072, 2);
  LongFrame() {
    scene.meshes.push_back(quad(0.6f, 0.5f));
    opt.width = 80;
    camera.fovyDeg = 1.0f;  // 40:1, so the whole row still sees the ground and the quad
  }
};

using Clock = std::chrono::steady_clock;

TEST(ReferenceCommon, CancelStopsWithinHalfASecond) {
  for (int threads : {1, 2}) {
    SCOPED_TRACE(threads);
    LongFrame f;
    f.opt.threads = threads;
    double fraction = 0;
    std::vector<Clock::time_point> asked;
    f.opt.progress = [&](double x) { fraction = x; };
    f.opt.cancel = [&] {
      asked.push_back(Clock::now());
      return fraction >= 0.15;
    };
    ErrorKind kind = ErrorKind::Internal;
    std::string what;
    try {
      referenceEnvironment(f.scene, f.camera, f.env, f.opt);
    } catch (const Error& e) {
      kind = e.kind();
      what = e.what();
    }
    const Clock::time_point returned = Clock::now();
    EXPECT_EQ(kind, ErrorKind::Cancelled) << what;
    // "reference: cancelled after P% (...)": P is what was done when the workers stopped, at or
    // past the poll that asked (15%) and short of the bound below.
    const std::string lead = "reference: cancelled after ";
    ASSERT_EQ(what.rfind(lead, 0), 0u) << what;
    const double percent = std::strtod(what.c_str() + lead.size(), nullptr);
    EXPECT_GE(percent, 15.0) << what;
    EXPECT_LT(percent, 30.0) << what;
    EXPECT_STREQ(toString(ErrorKind::Cancelled), "cancelled");
    ASSERT_GE(asked.size(), 2u);
    EXPECT_LT(std::chrono::duration<double>(returned - asked.back()).count(), 0.5);
    // Polled at least every 100 ms (plus a pixel and a loaded machine's slack).
    for (std::size_t i = 1; i < asked.size(); ++i)
      EXPECT_LT(std::chrono::duration<double>(asked[i] - asked[i - 1]).count(), 0.25) << i;
    // Stopped at the first poll past 15%, 100 ms (some 3%) later at most.
    EXPECT_GE(fraction, 0.15);
    EXPECT_LT(fraction, 0.3);
  }
}

TEST(ReferenceCommon, ExceptionFromProgressStopsWithinHalfASecond) {
  for (int threads : {1, 2}) {
    SCOPED_TRACE(threads);
    LongFrame f;
    f.opt.threads = threads;
    Clock::time_point thrown;
    double thrownAt = 1;
    f.opt.progress = [&](double x) {
      if (x < 0.15) return;
      thrown = Clock::now();
      thrownAt = x;
      throw std::domain_error("stop here");
    };
    std::string what;
    try {
      referenceLights(f.scene, f.camera, [] {
        LightSet ls;
        ls.lights.push_back(capLight({0.3f, 1, 0}, 15.0f, 3.0f));
        return ls;
      }(), f.env, f.opt);
    } catch (const std::domain_error& e) {
      what = e.what();
    }
    EXPECT_EQ(what, "stop here");
    EXPECT_LT(thrownAt, 0.3);  // called within 100 ms of passing 15%, not at the end of a row
    EXPECT_LT(std::chrono::duration<double>(Clock::now() - thrown).count(), 0.5);
  }
}

TEST(ReferenceCommon, CallbacksLeavePixelsUnchanged) {
  Scene scene = groundScene();
  scene.meshes.push_back(quad(0.6f, 0.5f));
  Environment env = constantEnv(32, 16, 0.2f, 0.3f, 0.4f);
  env.equirect.at(20, 4, 0) = 500.0f;
  for (int threads : {1, 3}) {
    SCOPED_TRACE(threads);
    ReferenceOptions o = smallOptions(16, 24);
    o.threads = threads;
    const ReferenceImage plain = referenceEnvironmentWithNoise(scene, obliqueCamera(), env, o);
    int polls = 0;
    o.progress = [](double) {};
    o.cancel = [&] { return ++polls < 0; };
    const ReferenceImage watched = referenceEnvironmentWithNoise(scene, obliqueCamera(), env, o);
    EXPECT_GT(polls, 0);
    for (const auto& [a, b] : {std::pair{&plain.image, &watched.image},
                              std::pair{&plain.halfA, &watched.halfA}}) {
      ASSERT_EQ(a->pixels.size(), b->pixels.size());
      EXPECT_EQ(0, std::memcmp(a->pixels.data(), b->pixels.data(), a->pixels.size() * sizeof(float)));
    }
  }
}

TEST(ReferenceCommon, RejectsBadInput) {
  const Scene scene = groundScene();
  const Camera cam = obliqueCamera();
  const Environment env = constantEnv(1, 1, 1, 1, 1);
  auto withOpt = [&](auto edit) {
    ReferenceOptions o = smallOptions(4, 8);
    edit(o);
    return o;
  };
  expectBadInput([&] { referenceEnvironment(scene, cam, env, withOpt([](auto& o) { o.spp = 0; })); },
                 "ReferenceOptions.spp must be >= 1, got 0");
  expectBadInput([&] { referenceEnvironment(scene, cam, env, withOpt([](auto& o) { o.width = 0; })); },
                 "ReferenceOptions.width");
  expectBadInput(
      [&] { referenceEnvironment(scene, cam, env, withOpt([](auto& o) { o.height = 20000; })); },
      "ReferenceOptions.height");
  expectBadInput(
      [&] { referenceLights(scene, cam, LightSet{}, env, withOpt([](auto& o) { o.threads = -1; })); },
      "ReferenceOptions.threads");
  expectBadInput([&] { referenceEnvironment(Scene{}, cam, env, withOpt([](auto&) {})); },
                 "no triangles");
  expectBadInput([&] { referenceEnvironment(scene, cam, Environment{}, withOpt([](auto&) {})); },
                 "environment map");
  expectBadInput([&] { referenceLights(scene, cam, LightSet{}, Environment{}, withOpt([](auto&) {})); },
                 "environment map");
  Scene broken = groundScene();
  broken.meshes[0].triangles.push_back({0, 1, 9});
  expectBadInput([&] { referenceEnvironment(broken, cam, env, withOpt([](auto&) {})); },
                 "out of range");
}

// ---------------------------------------------------------------------------------------------
// Metrics.

Image rgb(int w, int h, std::vector<float> v) {
  Image im(w, h, 3);
  im.pixels = std::move(v);
  return im;
}
Image rgba(int w, int h, std::vector<float> v) {
  Image im(w, h, 4);
  im.pixels = std::move(v);
  return im;
}

TEST(CompareImages, HandComputedRgb) {
  // Differences 1, -1, 0 | 0, 0, 2: MSE = 6/6 = 1, mean(B) = (1+3+2+4+4+4)/6 = 3, max(B) = 4.
  const Image a = rgb(2, 1, {2, 2, 2, 4, 4, 6});
  const Image b = rgb(2, 1, {1, 3, 2, 4, 4, 4});
  const ImageMetrics m = compareImages(a, b);
  EXPECT_EQ(m.pixels, 2u);
  EXPECT_DOUBLE_EQ(m.rmse, 1.0);
  EXPECT_DOUBLE_EQ(m.relativeRmse, 1.0 / 3.0);
  EXPECT_DOUBLE_EQ(m.psnr, 20.0 * std::log10(4.0));
  EXPECT_DOUBLE_EQ(m.maxAbsError, 2.0);
}

TEST(CompareImages, AlphaMasksReferencePixels) {
  // Pixel 1 of B has alpha 0 (background): only pixel 0 counts, and A's NaN there is ignored.
  // Pixel 0: differences 0.5, 0, -0.5 -> MSE 0.5/3 = 1/6, mean(B) = 2.5/3, max(B) = 1.
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const Image a = rgb(2, 1, {1.5f, 1.0f, 0.0f, nan, 100.0f, 7.0f});
  const Image b = rgba(2, 1, {1.0f, 1.0f, 0.5f, 1.0f, 9.0f, 9.0f, 9.0f, 0.0f});
  const ImageMetrics m = compareImages(a, b);
  EXPECT_EQ(m.pixels, 1u);
  EXPECT_NEAR(m.rmse, std::sqrt(1.0 / 6.0), 1e-12);
  EXPECT_NEAR(m.relativeRmse, std::sqrt(1.0 / 6.0) / (2.5 / 3.0), 1e-12);
  EXPECT_NEAR(m.psnr, 20.0 * std::log10(1.0 / std::sqrt(1.0 / 6.0)), 1e-12);
  EXPECT_DOUBLE_EQ(m.maxAbsError, 0.5);
}

TEST(CompareImages, IdenticalImagesAndJson) {
  const Image a = rgba(1, 2, {0.25f, 0.5f, 1.0f, 1.0f, 0.0f, 0.0f, 0.0f, 1.0f});
  const ImageMetrics m = compareImages(a, a);
  EXPECT_EQ(m.rmse, 0.0);
  EXPECT_EQ(m.relativeRmse, 0.0);
  EXPECT_TRUE(std::isinf(m.psnr) && m.psnr > 0);
  // One line of JSON (`penumbra compare` prints it), keys in this order; the infinite PSNR of
  // identical images is null, as JSON has no infinity.
  const std::string text = toJson(m);
  EXPECT_EQ(text.find('\n'), std::string::npos) << text;
  const nlohmann::ordered_json j = nlohmann::ordered_json::parse(text);
  std::vector<std::string> keys;
  for (const auto& [key, value] : j.items()) keys.push_back(key);
  EXPECT_EQ(keys, (std::vector<std::string>{"rmse", "relative_rmse", "psnr", "max_abs_error", "pixels"}));
  EXPECT_EQ(j["rmse"].get<double>(), 0.0);
  EXPECT_EQ(j["relative_rmse"].get<double>(), 0.0);
  EXPECT_TRUE(j["psnr"].is_null()) << text;
  EXPECT_EQ(j["max_abs_error"].get<double>(), 0.0);
  EXPECT_TRUE(j["pixels"].is_number_integer()) << text;
  EXPECT_EQ(j["pixels"], 2);
  ImageMetrics n;
  n.rmse = 0.125;
  n.relativeRmse = 0.5;
  n.psnr = 18.0625;
  n.maxAbsError = 3;
  n.pixels = 12;
  const nlohmann::json k = nlohmann::json::parse(toJson(n));
  EXPECT_EQ(k["rmse"].get<double>(), 0.125);
  EXPECT_EQ(k["relative_rmse"].get<double>(), 0.5);
  EXPECT_EQ(k["psnr"].get<double>(), 18.0625);
  EXPECT_EQ(k["max_abs_error"].get<double>(), 3.0);
  EXPECT_EQ(k["pixels"], 12);
}

TEST(CompareImages, RejectsMismatchEmptyMaskAndNonFinite) {
  const Image a = rgb(2, 1, {1, 1, 1, 1, 1, 1});
  expectBadInput([&] { compareImages(a, rgb(1, 2, {1, 1, 1, 1, 1, 1})); }, "sizes differ");
  expectBadInput([&] { compareImages(a, rgba(2, 1, {1, 1, 1, 0, 1, 1, 1, 0.5f})); },
                 "no geometry pixels to compare");
  const float inf = std::numeric_limits<float>::infinity();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  expectBadInput([&] { compareImages(rgb(2, 1, {1, 1, 1, 1, nan, 1}), a); },
                 "image A contains non-finite values");
  expectBadInput([&] { compareImages(a, rgb(2, 1, {1, inf, 1, 1, 1, 1})); },
                 "image B (reference) contains non-finite values");
  Image gray(2, 1, 1, 1.0f);
  expectBadInput([&] { compareImages(gray, a); }, "channels");
}

}  // namespace
