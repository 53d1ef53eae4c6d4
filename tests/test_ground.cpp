// The ground's occlusion of low lights (ShadowOptions::groundVisibility, kernels/render/ground.cl):
// the kernel against a plain C++ loop on awkward image sizes, the directions it reads, a wall
// standing on the ground under a light on the horizon matched to exact visibility (with its
// negative control), and the kernel under oclgrind.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "common.hpp"
#include "render/ground.hpp"
#include "support/scoped_env.hpp"

using namespace penumbra;
using namespace penumbra::test;
using namespace penumbra::test::dvec;

namespace {

// The ground of the synthetic frames: x in [-1.5, 1.5], z in [-1, 2], at y = 0.2; positions
// lifted 1e-3 along their geometric normals, as the G-buffer lifts them (GroundRect::lift).
detail::GroundRect testGround() {
  detail::GroundRect g;
  g.present = true;
  g.plane = {0.2f, -1.5f, 1.5f, -1.0f, 2.0f};
  g.eps = 1e-5f;
  g.lift = 1e-3f;
  return g;
}

// A synthetic frame: positions over and beyond the ground, a fifth of them on it, some background
// pixels; random unit normals (shading and geometric alike), each position lifted along its normal
// by the ground's `lift`; lights from 40 degrees below to 40 above the horizontal with half-angles
// of 3-40 degrees (most reach below it); random visibility. onGround: the pixels on the ground.
using Synthetic = SyntheticFrame;
std::vector<char> onGroundOf;

Synthetic synthetic(int w, int h, unsigned seed, int nl = 12) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  Synthetic s;
  s.w = w;
  s.h = h;
  onGroundOf.clear();
  const float lift = testGround().lift;
  for (int p = 0; p < w * h; ++p) {
    const bool background = u(rng) < 0.1f, onGround = u(rng) < 0.2f;
    const float y = onGround ? 0.2f : 0.2f + 1.5f * u(rng);
    const float x = 4 * u(rng) - 2, z = 4 * u(rng) - 1.5f;
    std::array<float, 3> n = randomUnit(rng);
    if (onGround) n = {0.0f, n[1] < 0 ? -1.0f : 1.0f, 0.0f};  // the ground's, facing the camera
    s.gpos.push_back({{x + lift * n[0], y + lift * n[1], z + lift * n[2],
                       background ? 0.0f : 1.0f}});
    s.gnrm.push_back({{n[0], n[1], n[2], 0.0f}});
    onGroundOf.push_back(onGround);
  }
  for (int l = 0; l < nl; ++l) {
    pb_light L{};
    const double az = 2 * M_PI * u(rng), el = (80 * u(rng) - 40) * M_PI / 180;
    L.dir[0] = float(std::cos(el) * std::cos(az));
    L.dir[1] = float(std::sin(el));
    L.dir[2] = float(std::cos(el) * std::sin(az));
    L.dir[3] = float(std::cos((3.0 + 37.0 * u(rng)) * M_PI / 180));
    s.lights.push_back(L);
  }
  for (int i = 0; i < w * h * nl; ++i) s.vis.push_back(u(rng));
  return s;
}

// Whether the ray from p along d meets the rectangle, in double; `near` is set where the hit
// point is within 1e-4 of the rectangle's edge (float rounding may go either way there).
bool hitsGround(const GroundPlane& g, const D3& p, const D3& d, bool& near) {
  if (!(d[1] < 0)) return false;
  const double t = (p[1] - g.y) / -d[1];
  const double x = p[0] + t * d[0], z = p[2] + t * d[2];
  const double edge = std::min({std::fabs(x - g.x0), std::fabs(x - g.x1), std::fabs(z - g.z0),
                                std::fabs(z - g.z1)});
  if (edge < 1e-4) near = true;
  return x >= g.x0 && x <= g.x1 && z >= g.z0 && z <= g.z1;
}

// The rule in double precision over the host's directions. `clear` is false where a test is
// within 1e-4 of its threshold.
void reference(const Synthetic& s, const std::vector<cl_uchar>& mask, std::vector<float>& out,
               std::vector<char>& clear) {
  const detail::GroundRect rect = testGround();
  const GroundPlane& g = rect.plane;
  std::vector<cl_float4> dirs;
  std::vector<int> idx;
  detail::groundDirections(s.lights, dirs, idx);
  const int np = s.w * s.h, per = detail::kGroundDirs + 1;
  out = s.vis;
  clear.assign(out.size(), 1);
  for (int p = 0; p < np; ++p) {
    const cl_float4& q = s.gpos[std::size_t(p)];
    if (q.s[3] == 0.0f) continue;
    const double h = double(q.s[1]) - g.y;
    // the surface point's own height: the position less its lift along the geometric normal
    if (!(h - double(rect.lift) * s.gnrm[std::size_t(p)].s[1] > rect.eps)) continue;
    const D3 pos{q.s[0], q.s[1], q.s[2]};
    const D3 n{s.gnrm[std::size_t(p)].s[0], s.gnrm[std::size_t(p)].s[1],
               s.gnrm[std::size_t(p)].s[2]};
    for (int k = 0; k < int(idx.size()); ++k) {
      const int l = idx[std::size_t(k)];
      if (!mask[std::size_t(l)]) continue;
      const std::size_t o = std::size_t(l) * np + std::size_t(p);
      bool near = false;
      // the kernel's shortcut: no direction goes down steeply enough to reach the rectangle
      const double fx = std::max(std::fabs(pos[0] - g.x0), std::fabs(pos[0] - g.x1));
      const double fz = std::max(std::fabs(pos[2] - g.z0), std::fabs(pos[2] - g.z1));
      const double reach = std::sqrt(fx * fx + fz * fz);
      const pb_light& L = s.lights[std::size_t(l)];
      const double below = std::acos(double(L.dir[3])) - std::asin(double(L.dir[1]));
      if (below < M_PI / 2 && std::tan(below) * reach <= h) {
        if (std::fabs(std::tan(below) * reach - h) < 1e-4) clear[o] = 0;
        continue;
      }
      double total = 0, blocked = 0;
      for (int i = 1; i < per; ++i) {
        const cl_float4& di = dirs[std::size_t(k * per + i)];
        const D3 d{di.s[0], di.s[1], di.s[2]};
        const double c = dot(n, d);
        if (std::fabs(c) < 1e-5) near = true;
        if (!(c > 0)) continue;
        total += c;
        if (hitsGround(g, pos, d, near)) blocked += c;
      }
      if (near) clear[o] = 0;
      if (!(blocked > 0)) continue;
      const cl_float4& w = dirs[std::size_t(k * per)];
      const double keep = 1 - blocked / total;
      out[o] = hitsGround(g, pos, {w.s[0], w.s[1], w.s[2]}, near) ? float(keep)
                                                                   : float(s.vis[o] * keep);
      if (near) clear[o] = 0;
    }
  }
}

struct KernelRun {
  int mismatches = 0, changed = 0, maskedChanged = 0, groundChanged = 0;
  std::vector<float> vis;
};

// Runs one kernel form (batched: the CPU form, ground_visibility_batch) on a synthetic frame with
// light 2 masked off.
KernelRun runKernel(int w, int h, unsigned seed, bool batched = false) {
  const Synthetic s = synthetic(w, h, seed);
  RenderOptions ro;
  detail::BufferPool pool(ctx());
  detail::ShadowFrame f(ctx(), pool, ro, s.lights);
  f.width = w;
  f.height = h;
  f.pixels = w * h;
  f.gpos = pool.upload("gpos", s.gpos);
  f.gnrm = pool.upload("gnrm", s.gnrm);
  f.ggeo = f.gnrm;
  f.vis = pool.upload("vis", s.vis);
  f.ground = testGround();
  std::vector<cl_uchar> mask(s.lights.size(), 1);
  mask[2] = 0;  // a light whose visibility is exact: left alone
  {
    const test::ScopedEnv env("PENUMBRA_CPU_BATCHING", std::string(batched ? "on" : "off"));
    detail::GroundOcclusion ground(pool);
    ground.run(f, pool.upload("mask", mask));
  }
  const std::vector<float> vis = ctx().download<float>(f.vis, s.vis.size(), "vis");
  std::vector<float> want;
  std::vector<char> clear;
  reference(s, mask, want, clear);
  const std::size_t np = std::size_t(w) * h;
  KernelRun r;
  for (std::size_t i = 0; i < vis.size(); ++i) {
    if (clear[i] && std::fabs(vis[i] - want[i]) > 1e-5f) ++r.mismatches;
    if (vis[i] != s.vis[i]) {
      ++r.changed;
      r.maskedChanged += i / np == 2;
      r.groundChanged += onGroundOf[i % np] != 0;
    }
  }
  r.vis = vis;
  return r;
}

}  // namespace

// 1x1, a row, a column, odd sizes and one larger than the CPU form's 64 pixels a work-item; both
// forms against the reference, and against each other bit for bit (on PoCL: the CPU form forms
// each pixel's sums from the same operands in the same order).
TEST(Ground, KernelMatchesHostReference) {
  int changed = 0;
  for (auto [w, h] : std::vector<std::array<int, 2>>{{1, 1}, {1, 9}, {9, 1}, {7, 5}, {67, 33}}) {
    const KernelRun one = runKernel(w, h, unsigned(w * 131 + h), false);
    const KernelRun batched = runKernel(w, h, unsigned(w * 131 + h), true);
    for (const KernelRun* r : {&one, &batched}) {
      EXPECT_EQ(r->mismatches, 0) << w << "x" << h << (r == &one ? " per pixel" : " batched");
      EXPECT_EQ(r->maskedChanged, 0) << w << "x" << h;
      EXPECT_EQ(r->groundChanged, 0) << w << "x" << h;
    }
    ASSERT_EQ(one.vis.size(), batched.vis.size());
    // bit for bit on PoCL; another driver may fuse the products otherwise in one form
    const bool pocl =
        ctx().info().platform.find("Portable Computing Language") != std::string::npos;
    std::size_t differ = 0;
    for (std::size_t i = 0; i < one.vis.size(); ++i)
      differ += pocl ? std::memcmp(&one.vis[i], &batched.vis[i], sizeof(float)) != 0
                     : !(std::fabs(one.vis[i] - batched.vis[i]) <= 1e-5f);
    EXPECT_EQ(differ, 0u) << w << "x" << h << ": the two forms";
    changed += one.changed;
  }
  std::printf("[ penumbra ] %d pairs changed\n", changed);
  EXPECT_GT(changed, 1000);
}

TEST(OclgrindGround, Kernel) {
  for (bool batched : {false, true}) {
    const KernelRun r = runKernel(67, 3, 5u, batched);
    EXPECT_EQ(r.mismatches, 0) << batched;
    EXPECT_GT(r.changed, 0) << batched;
  }
}

// Each light that reaches below the horizontal gets its axis and kGroundDirs directions inside its
// cap whose mean is along the axis (uniform in solid angle: the mean of cos theta is the cap's,
// (1 + cos a) / 2; opposite pairs: nothing off the axis); a light wholly above the horizontal gets
// none.
TEST(Ground, DirectionsFillEachLowCap) {
  auto light = [](double elevationDeg, double alphaDeg) {
    pb_light L{};
    const double el = elevationDeg * M_PI / 180;
    L.dir[0] = float(std::cos(el));
    L.dir[1] = float(std::sin(el));
    L.dir[3] = float(std::cos(alphaDeg * M_PI / 180));
    return L;
  };
  const std::vector<pb_light> lights = {light(30, 20), light(10, 20), light(-50, 5), light(19, 20)};
  std::vector<cl_float4> dirs;
  std::vector<int> idx;
  detail::groundDirections(lights, dirs, idx);
  EXPECT_EQ(idx, (std::vector<int>{1, 2, 3}));
  const int per = detail::kGroundDirs + 1;
  ASSERT_EQ(dirs.size(), idx.size() * per);
  for (std::size_t k = 0; k < idx.size(); ++k) {
    const pb_light& L = lights[std::size_t(idx[k])];
    const D3 w{L.dir[0], L.dir[1], L.dir[2]};
    D3 mean{0, 0, 0};
    for (int i = 1; i < per; ++i) {
      const cl_float4& d = dirs[k * per + std::size_t(i)];
      const D3 di{d.s[0], d.s[1], d.s[2]};
      EXPECT_NEAR(dot(di, di), 1.0, 1e-6);
      EXPECT_GE(dot(di, w), double(L.dir[3]) - 1e-6) << "outside the cap";
      for (int c = 0; c < 3; ++c) mean[c] += di[c] / detail::kGroundDirs;
    }
    EXPECT_NEAR(dot(mean, w), (1 + double(L.dir[3])) / 2, 1e-6);
    const double along = dot(mean, w);
    const D3 side{mean[0] - along * w[0], mean[1] - along * w[1], mean[2] - along * w[2]};
    EXPECT_LT(std::sqrt(dot(side, side)), 1e-5) << "the directions lean to one side";
  }
}

namespace {

// A 6 x 6 ground at y = 0, a wall 1 high across x = 0 (|z| < 1) facing +x, and one light on the
// horizon towards +x with a 20-degree half-angle: from a point of the wall at height y the ground
// (it ends at x = 3) hides the cap's directions more than atan(y / 3) below the horizontal. A
// camera at (3, 0.5, 0) looks at the wall. Returns the visibility of the wall's pixels (inside
// 0.05 of its edges).
std::vector<float> wallVisibility(ShadowTechnique t, bool ground) {
  Scene scene;
  scene.meshes.push_back(planarQuad("ground", -3, 3, -3, 3, 0));
  Mesh wall;
  wall.name = "wall";
  wall.positions = {{0, 0, -1}, {0, 0, 1}, {0, 1, 1}, {0, 1, -1}};
  wall.normals = {{1, 0, 0}, {1, 0, 0}, {1, 0, 0}, {1, 0, 0}};
  wall.triangles = {{0, 1, 2}, {0, 2, 3}};
  scene.meshes.push_back(wall);
  LightSet set;
  AreaLight L;
  L.direction = {1, 0, 0};
  L.cosAlpha = float(std::cos(20 * M_PI / 180));
  L.radiance = {1, 1, 1};
  set.lights.push_back(L);
  RenderOptions ro;
  ro.shadows = t;
  ro.width = 64;
  ro.height = 64;
  ro.environmentBackground = false;
  ro.shadow.groundVisibility = ground;
  Camera cam;
  cam.eye = {3, 0.5f, 0};
  cam.target = {0, 0.5f, 0};
  cam.fovyDeg = 30;
  Renderer r(ctx());
  r.render(scene, cam, set, builtinEnvironment(), ro);
  const std::vector<float> vis = r.lastVisibility();
  const CameraBasis b = cameraBasis(cam, ro.width, ro.height);
  std::vector<float> wallVis;
  for (int y = 0; y < ro.height; ++y)
    for (int x = 0; x < ro.width; ++x) {
      const Vec3 d = cameraRayDirection(b, ro.width, ro.height, x + 0.5f, y + 0.5f);
      const float s = -cam.eye[0] / d[0];
      const float wy = cam.eye[1] + s * d[1], wz = cam.eye[2] + s * d[2];
      if (wy > 0.05f && wy < 0.95f && std::fabs(wz) < 0.95f)
        wallVis.push_back(vis[std::size_t(y * ro.width + x)]);
    }
  return wallVis;
}

double mean(const std::vector<float>& v) {
  double s = 0;
  for (float x : v) s += x;
  return s / std::max<std::size_t>(v.size(), 1);
}

}  // namespace

// The wall under a light on the horizon: exact visibility (the bitmask technique) finds the ground
// hiding from half of the light (at the wall's foot) to a tenth (at its top, where only what is more
// than 17.6 degrees down hits the ground: 0.09 of the cosine-weighted cap); a map, looking along
// the horizontal axis, sees the ground edge-on and none of it (the negative control: V = 1); with
// the ground step the map techniques match exact visibility on average (measured: 0.768 against
// 0.778).
TEST(Ground, AWallOnTheGroundUnderALightOnTheHorizon) {
  const std::vector<float> exact = wallVisibility(ShadowTechnique::Bitmask, true);
  ASSERT_GT(exact.size(), 1000u);
  const double e = mean(exact);
  EXPECT_GT(e, 0.5);
  EXPECT_LT(e, 0.91);
  for (ShadowTechnique t : {ShadowTechnique::Hard, ShadowTechnique::MSSM4}) {
    const double on = mean(wallVisibility(t, true)), off = mean(wallVisibility(t, false));
    std::printf("[ penumbra ] %s: wall's mean V %.3f with the ground step, %.3f without, exact %.3f\n",
                toString(t), on, off, e);
    EXPECT_NEAR(on, e, 0.03) << toString(t);
    EXPECT_GT(off - e, 0.15) << toString(t);
  }
}
