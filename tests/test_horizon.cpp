// Lights on the horizon (ShadowOptions::horizonVisibility, kernels/render/horizon.cl): both kernel
// forms against a plain C++ loop on awkward image sizes (also with more sources than the kernels'
// list holds), the two forms bit for bit, open ground under a light whose centre is below its
// horizon left lit (with its negative control), an occluder of the lit part found through the
// light above it, and the kernel under oclgrind.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "common.hpp"
#include "render/horizon.hpp"
#include "support/scoped_env.hpp"

using namespace penumbra;
using namespace penumbra::test;
using namespace penumbra::test::dvec;

namespace {

// A synthetic frame: random unit normals (in runs of equal ones, as on flat surfaces), some
// background pixels, random caps (half-angles 3-40 degrees), random visibility.
using Synthetic = SyntheticFrame;

Synthetic synthetic(int w, int h, unsigned seed, int nl = 12) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  Synthetic s;
  s.w = w;
  s.h = h;
  std::array<float, 3> n = randomUnit(rng);
  for (int p = 0; p < w * h; ++p) {
    if (u(rng) < 0.3f) n = randomUnit(rng);  // a new run
    const bool background = u(rng) < 0.1f;
    s.gpos.push_back({{u(rng), u(rng), u(rng), background ? 0.0f : 1.0f}});
    s.gnrm.push_back({{n[0], n[1], n[2], 0.0f}});
  }
  for (int l = 0; l < nl; ++l) {
    pb_light L{};
    const std::array<float, 3> d = randomUnit(rng);
    for (int k = 0; k < 3; ++k) L.dir[k] = d[k];
    L.dir[3] = float(std::cos((3.0 + 37.0 * u(rng)) * M_PI / 180));
    s.lights.push_back(L);
  }
  for (int i = 0; i < w * h * nl; ++i) s.vis.push_back(u(rng));
  return s;
}

// The rule in double precision, with the angles themselves: the lens's middle at the mean of the
// horizon's and the rim's angles from the axis. `clear` is false where a comparison is within
// 1e-4 of its threshold (float rounding may go either way there).
void reference(const Synthetic& s, const std::vector<cl_uchar>& mask, std::vector<float>& out,
               std::vector<char>& clear, int* mostSources = nullptr) {
  const int np = s.w * s.h, nl = int(s.lights.size());
  out = s.vis;
  clear.assign(out.size(), 1);
  for (int p = 0; p < np; ++p) {
    if (s.gpos[std::size_t(p)].s[3] == 0.0f) continue;
    const D3 n{s.gnrm[std::size_t(p)].s[0], s.gnrm[std::size_t(p)].s[1],
               s.gnrm[std::size_t(p)].s[2]};
    for (int l = 0; l < nl; ++l) {
      if (!mask[std::size_t(l)]) continue;
      const pb_light& L = s.lights[std::size_t(l)];
      const D3 w{L.dir[0], L.dir[1], L.dir[2]};
      const double a = std::acos(double(L.dir[3])), c = dot(n, w);
      const std::size_t o = std::size_t(l) * np + std::size_t(p);
      if (std::fabs(c) < 1e-4 || std::fabs(c + std::sin(a)) < 1e-4) clear[o] = 0;
      if (!(c <= 0 && c > -std::sin(a))) continue;
      const D3 perp{n[0] - c * w[0], n[1] - c * w[1], n[2] - c * w[2]};
      const D3 u = unitD(perp);
      const double tm = 0.5 * (std::atan2(-c, std::sqrt(dot(perp, perp))) + a);
      const D3 m{std::cos(tm) * w[0] + std::sin(tm) * u[0], std::cos(tm) * w[1] + std::sin(tm) * u[1],
                 std::cos(tm) * w[2] + std::sin(tm) * u[2]};
      double sum = 0;
      int count = 0;
      for (int k = 0; k < nl; ++k) {
        if (k == l) continue;
        const pb_light& K = s.lights[std::size_t(k)];
        const D3 wk{K.dir[0], K.dir[1], K.dir[2]};
        const double up = dot(n, wk), near = dot(m, wk) - std::cos(2 * a);
        if (std::fabs(up) < 1e-4 || std::fabs(near) < 1e-4) clear[o] = 0;
        if (up > 0 && near > 0) {
          sum += s.vis[std::size_t(k) * np + std::size_t(p)];
          ++count;
        }
      }
      out[o] = count > 0 ? float(sum / count) : 1.0f;
      if (mostSources) *mostSources = std::max(*mostSources, count);
    }
  }
}

struct KernelRun {
  int mismatches = 0, replaced = 0, replacedByOne = 0, maskedChanged = 0;
  std::vector<float> vis;
};

// Runs one kernel form (batched: the CPU form) on a synthetic frame with light 2 masked off;
// mostSources: the most sources any replaced pair has (the reference's count).
KernelRun runKernelOn(const Synthetic& s, bool batched, int* mostSources = nullptr) {
  const int w = s.w, h = s.h;
  RenderOptions ro;
  detail::BufferPool pool(ctx());
  detail::ShadowFrame f(ctx(), pool, ro, s.lights);
  f.width = w;
  f.height = h;
  f.pixels = w * h;
  f.lightBuffer = pool.upload("lights", s.lights);
  f.gpos = pool.upload("gpos", s.gpos);
  f.gnrm = pool.upload("gnrm", s.gnrm);
  f.vis = pool.upload("vis", s.vis);
  std::vector<cl_uchar> mask(s.lights.size(), 1);
  mask[2] = 0;  // a light whose visibility is exact: left alone, still a source
  setenv("PENUMBRA_CPU_BATCHING", batched ? "on" : "off", 1);
  detail::Horizon horizon(pool);
  horizon.run(f, pool.upload("mask", mask));
  unsetenv("PENUMBRA_CPU_BATCHING");
  KernelRun r;
  r.vis = ctx().download<float>(f.vis, s.vis.size(), "vis");
  std::vector<float> want;
  std::vector<char> clear;
  reference(s, mask, want, clear, mostSources);
  const std::size_t np = std::size_t(w) * h;
  for (std::size_t i = 0; i < r.vis.size(); ++i) {
    if (clear[i] && std::fabs(r.vis[i] - want[i]) > 1e-5f) ++r.mismatches;
    if (r.vis[i] != s.vis[i]) {
      ++r.replaced;
      r.replacedByOne += r.vis[i] == 1.0f;
      r.maskedChanged += i / np == 2;
    }
  }
  return r;
}

KernelRun runKernel(int w, int h, unsigned seed, bool batched) {
  return runKernelOn(synthetic(w, h, seed), batched);
}

// Many lights close together, as a median cut gives around a bright sky: nl directions within 12
// degrees of one axis, caps of 20-35 degrees, and normals 0-4 degrees below the axis' horizon
// (in runs; about half the lights are above such a pixel's horizon), so that pairs have more sources than the kernels' list holds (HZ_MAX_SOURCES, 32)
// and the kernels read them all again.
Synthetic crowded(int w, int h, unsigned seed, int nl) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Synthetic s = synthetic(w, h, seed, nl);
  const std::array<float, 3> a = randomUnit(rng);
  const D3 axis{a[0], a[1], a[2]};
  // a unit vector perpendicular to the axis, from a random one
  auto perpendicular = [&]() {
    const std::array<float, 3> r = randomUnit(rng);
    const double c = r[0] * axis[0] + r[1] * axis[1] + r[2] * axis[2];
    return unitD({r[0] - c * axis[0], r[1] - c * axis[1], r[2] - c * axis[2]});
  };
  // the axis turned by t radians towards a random perpendicular
  auto turned = [&](double t) {
    const D3 q = perpendicular();
    return D3{std::cos(t) * axis[0] + std::sin(t) * q[0], std::cos(t) * axis[1] + std::sin(t) * q[1],
              std::cos(t) * axis[2] + std::sin(t) * q[2]};
  };
  for (pb_light& L : s.lights) {
    const D3 d = turned(12.0 * M_PI / 180 * u(rng));
    for (int k = 0; k < 3; ++k) L.dir[k] = float(d[k]);
    L.dir[3] = float(std::cos((20.0 + 15.0 * u(rng)) * M_PI / 180));
  }
  D3 n{};
  for (std::size_t p = 0; p < s.gnrm.size(); ++p) {
    if (p == 0 || u(rng) < 0.3) n = turned(M_PI / 2 + 4.0 * M_PI / 180 * u(rng));
    s.gnrm[p] = {{float(n[0]), float(n[1]), float(n[2]), 0.0f}};
  }
  return s;
}

}  // namespace

// Pairs with more than 32 sources (crowded lights) take the kernels' second way, the sources read
// again: both forms against the reference and each other, on frames narrower and wider than the
// CPU form's 64 pixels.
TEST(Horizon, MoreSourcesThanTheListHolds) {
  for (auto [w, h] : std::vector<std::array<int, 2>>{{1, 1}, {9, 1}, {67, 5}}) {
    const Synthetic s = crowded(w, h, unsigned(w * 7 + h), 80);  // 1x1: bounds only
    int most = 0;
    const KernelRun batched = runKernelOn(s, true, &most);
    const KernelRun plain = runKernelOn(s, false);
    EXPECT_EQ(batched.mismatches, 0) << w << "x" << h;
    EXPECT_EQ(plain.mismatches, 0) << w << "x" << h;
    EXPECT_EQ(batched.maskedChanged, 0) << w << "x" << h;
    EXPECT_EQ(batched.vis, plain.vis) << w << "x" << h;
    std::printf("[ penumbra ] %dx%d: %d pairs replaced, at most %d sources\n", w, h,
                batched.replaced, most);
    if (w * h > 1) EXPECT_GT(most, 32) << w << "x" << h;
  }
}

// 1x1, a row, a column, odd sizes and one larger than the CPU form's 64 pixels a work-item; both
// forms against the reference and against each other, bit for bit.
TEST(Horizon, KernelMatchesHostReference) {
  int replaced = 0, byOne = 0;
  for (auto [w, h] : std::vector<std::array<int, 2>>{{1, 1}, {1, 9}, {9, 1}, {7, 5}, {67, 33}}) {
    const unsigned seed = unsigned(w * 131 + h);
    const KernelRun batched = runKernel(w, h, seed, true);
    const KernelRun plain = runKernel(w, h, seed, false);
    EXPECT_EQ(batched.mismatches, 0) << w << "x" << h;
    EXPECT_EQ(plain.mismatches, 0) << w << "x" << h;
    EXPECT_EQ(batched.maskedChanged, 0) << w << "x" << h;
    EXPECT_EQ(batched.vis, plain.vis) << w << "x" << h;
    replaced += batched.replaced;
    byOne += batched.replacedByOne;
  }
  std::printf("[ penumbra ] %d pairs replaced, %d of them by 1\n", replaced, byOne);
  // The synthetic frames exercise both outcomes (measured: 3,531 of the 27,180 pairs
  // replaced, 1,032 of them by 1 for want of a source).
  EXPECT_GT(replaced, 1000);
  EXPECT_GT(byOne, 100);
  EXPECT_GT(replaced - byOne, 1000);
}

// Each light's candidates hold every light within 3a + 0.01 rad of its axis, in order, never
// itself: for a 15-degree cap (45.6 degrees) the lights 45 and 30 degrees off its axis are, the
// one 47 degrees off is not.
TEST(Horizon, CandidatesReachThreeHalfAngles) {
  auto light = [](double azimuthDeg, double alphaDeg) {
    pb_light L{};
    L.dir[0] = float(std::cos(azimuthDeg * M_PI / 180));
    L.dir[2] = float(std::sin(azimuthDeg * M_PI / 180));
    L.dir[3] = float(std::cos(alphaDeg * M_PI / 180));
    return L;
  };
  const std::vector<pb_light> lights = {light(0, 15), light(45, 1), light(47, 1), light(-30, 1)};
  std::vector<int> off, idx;
  detail::horizonCandidates(lights, off, idx);
  ASSERT_EQ(off.size(), 5u);
  const std::vector<int> first(idx.begin() + off[0], idx.begin() + off[1]);
  EXPECT_EQ(first, (std::vector<int>{1, 3}));
  // light 1 (1 degree): 3 degrees reach light 2, 2 degrees away, and no other
  EXPECT_EQ(std::vector<int>(idx.begin() + off[1], idx.begin() + off[2]), (std::vector<int>{2}));
}

TEST(OclgrindHorizon, Kernel) {
  const KernelRun batched = runKernel(9, 7, 5u, true);
  const KernelRun plain = runKernel(9, 7, 5u, false);
  EXPECT_EQ(batched.mismatches, 0);
  EXPECT_EQ(plain.mismatches, 0);
  EXPECT_EQ(batched.vis, plain.vis);
  EXPECT_GT(batched.replaced, 0);
}

namespace {

AreaLight cap(double azimuthDeg, double elevationDeg, double alphaDeg) {
  AreaLight L;
  const double az = azimuthDeg * M_PI / 180, el = elevationDeg * M_PI / 180;
  L.direction = {float(std::cos(el) * std::cos(az)), float(std::sin(el)),
                 float(std::cos(el) * std::sin(az))};
  L.cosAlpha = float(std::cos(alphaDeg * M_PI / 180));
  L.radiance = {1, 1, 1};
  return L;
}

// A 6 x 6 ground seen from above, a wall 0.6 high across x = -1 (|z| < 1), and lights towards -x:
// `low` 2 degrees below the horizon with a 20-degree half-angle (its upper 18 degrees light the
// ground), and with `above`, a 4-degree cap 10 degrees up, near the low light's lit part (its
// middle is 9 degrees up). Returns the visibility, light-major, and each pixel's ray's ground
// point (x, z), valid where `ground` (on the ground and not within 0.05 of the wall, whose top the
// camera may see instead).
struct HorizonFrame {
  std::vector<float> vis;
  std::vector<std::array<float, 2>> xz;
  std::vector<char> ground;
  int pixels = 0;
};

HorizonFrame horizonFrame(ShadowTechnique t, bool horizon, bool above) {
  Scene scene;
  scene.meshes.push_back(planarQuad("ground", -3, 3, -3, 3, 0));
  Mesh wall;
  wall.name = "wall";
  wall.positions = {{-1, 0, -1}, {-1, 0, 1}, {-1, 0.6f, 1}, {-1, 0.6f, -1}};
  wall.triangles = {{0, 1, 2}, {0, 2, 3}};
  scene.meshes.push_back(wall);
  LightSet set;
  set.lights.push_back(cap(180, -2, 20));
  if (above) set.lights.push_back(cap(180, 10, 4));
  RenderOptions ro;
  ro.shadows = t;
  ro.width = 96;
  ro.height = 96;
  ro.shadowMapSize = 256;
  ro.environmentBackground = false;
  ro.shadow.horizonVisibility = horizon;
  Renderer r(ctx());
  const Camera cam = topDownCamera(100);
  r.render(scene, cam, set, builtinEnvironment(), ro);
  HorizonFrame h;
  h.vis = r.lastVisibility();
  h.pixels = ro.width * ro.height;
  const CameraBasis b = cameraBasis(cam, ro.width, ro.height);
  for (int y = 0; y < ro.height; ++y)
    for (int x = 0; x < ro.width; ++x) {
      const Vec3 d = cameraRayDirection(b, ro.width, ro.height, x + 0.5f, y + 0.5f);
      const float t = -cam.eye[1] / d[1];
      const float gx = cam.eye[0] + t * d[0], gz = cam.eye[2] + t * d[2];
      h.xz.push_back({gx, gz});
      h.ground.push_back(d[1] < 0 && std::fabs(gx) < 2.95f && std::fabs(gz) < 2.95f &&
                         !(std::fabs(gx + 1) < 0.05f && std::fabs(gz) < 1.05f));
    }
  return h;
}

}  // namespace

// Alone, the low light has no source: with the step, every pixel of the open ground on the
// light's side of the wall (x < -1.1) sees it (V = 1, as the Embree truth does: nothing stands
// between that ground and the light); without it, its map, which looks up at the ground from
// below, darkens that ground (the negative control: measured mean V 0.884 for MSSM4 and 0.735
// for hard shadows).
TEST(Horizon, OpenGroundUnderALowLightStaysLit) {
  for (ShadowTechnique t : {ShadowTechnique::MSSM4, ShadowTechnique::Hard}) {
    const HorizonFrame on = horizonFrame(t, true, false), off = horizonFrame(t, false, false);
    double offSum = 0;
    int open = 0, notLit = 0;
    for (int p = 0; p < on.pixels; ++p) {
      if (!on.ground[std::size_t(p)] || on.xz[std::size_t(p)][0] > -1.1f) continue;
      ++open;
      notLit += on.vis[std::size_t(p)] != 1.0f;
      offSum += off.vis[std::size_t(p)];
    }
    std::printf("[ penumbra ] %s: %d open-ground pixels, mean V without the step %.3f\n",
                toString(t), open, offSum / std::max(open, 1));
    ASSERT_GT(open, 1500) << toString(t);
    EXPECT_EQ(notLit, 0) << toString(t);
    EXPECT_LT(offSum / open, 0.95) << toString(t);
  }
}

// With the light above as its source, the low light's visibility at every ground pixel is the
// light above's, so the wall's shadow (-0.8 < x < 1.2, |z| < 0.8: the light above's umbra)
// darkens the low light's lit part too, where the map alone, looking up from below the ground,
// saw nothing of the wall.
TEST(Horizon, AnOccluderOfTheLitPartIsFoundThroughTheLightAbove) {
  for (ShadowTechnique t : {ShadowTechnique::MSSM4, ShadowTechnique::Hard}) {
    const HorizonFrame h = horizonFrame(t, true, true);
    int ground = 0, differ = 0, shadow = 0;
    double shadowSum = 0;
    for (int p = 0; p < h.pixels; ++p) {
      if (!h.ground[std::size_t(p)]) continue;
      const std::array<float, 2> q = h.xz[std::size_t(p)];
      ++ground;
      differ += h.vis[std::size_t(p)] != h.vis[std::size_t(h.pixels + p)];
      if (q[0] > -0.8f && q[0] < 1.2f && std::fabs(q[1]) < 0.8f) {
        ++shadow;
        shadowSum += h.vis[std::size_t(p)];
      }
    }
    ASSERT_GT(ground, 5000) << toString(t);
    ASSERT_GT(shadow, 300) << toString(t);
    EXPECT_EQ(differ, 0) << toString(t);
    EXPECT_LT(shadowSum / shadow, 0.1) << toString(t);
  }
}

// A pass that knows the horizon step follows writes the pairs the step rewrites 0 instead of
// filtering them (ShadowFrame::horizonRewrites; tests/test_mssm.cpp checks the kernels): the final
// visibility has the same bits as with PENUMBRA_HORIZON_SKIP=off, which filters them. On the low
// light's frame above (every ground pixel's pair of it is one the step rewrites) with MSSM4, and
// on the built-in scene with 16 median-cut lights and the default technique (auto: MSSM4, hard
// and an exact light; contact shadows between the pass and the step).
TEST(Horizon, SkippedPairsGiveTheSameVisibility) {
  std::vector<float> low[2];
  for (int off : {0, 1}) {
    const test::ScopedEnv env("PENUMBRA_HORIZON_SKIP",
                              off ? std::optional<std::string>("off") : std::nullopt);
    low[off] = horizonFrame(ShadowTechnique::MSSM4, true, true).vis;
  }
  ASSERT_FALSE(low[0].empty());
  EXPECT_TRUE(low[0] == low[1]) << "the low light's frame";

  Scene scene = builtinScene();
  Environment env = builtinEnvironment(64);
  MedianCutOptions mc;
  mc.lights = 16;
  LightSet lights = extractMedianCut(ctx(), env, mc);
  RenderOptions ro;
  ro.width = 160;
  ro.height = 90;
  ro.shadowMapSize = 128;
  const Camera cam = frameCamera(scene, float(ro.width) / ro.height);
  std::vector<float> vis[2];
  std::vector<float> image[2];
  double mssm4Lights = 0;
  for (int off : {0, 1}) {
    const test::ScopedEnv skip("PENUMBRA_HORIZON_SKIP",
                               off ? std::optional<std::string>("off") : std::nullopt);
    Renderer r(ctx());
    Frame f = r.render(scene, cam, lights, env, ro);
    vis[off] = r.lastVisibility();
    image[off] = f.image.pixels;
    for (const auto& [name, v] : f.stats)
      if (name == "auto/lights_mssm4") mssm4Lights = v;
  }
  // the default technique gave some lights MSSM4, the pass that skips
  ASSERT_GE(mssm4Lights, 1.0);
  ASSERT_EQ(vis[0].size(), std::size_t(16) * ro.width * ro.height);
  std::size_t differ = 0;
  for (std::size_t i = 0; i < vis[0].size(); ++i)
    differ += std::memcmp(&vis[0][i], &vis[1][i], 4) != 0;
  EXPECT_EQ(differ, 0u) << "the built-in scene's visibility";
  EXPECT_TRUE(image[0] == image[1]) << "the built-in scene's image";
}
