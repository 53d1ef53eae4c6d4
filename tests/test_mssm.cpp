// MSSM4 against the analytic penumbra of the planar, parallel configuration (seed 003 §3.2; the
// configuration in which PCSS-style filtering is exact, seed 000 §3), and a tiny whole frame that
// exercises every kernel (also run under oclgrind, label `oclgrind`).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "common.hpp"

using namespace penumbra;
using namespace penumbra::test;

namespace {



struct PlanarResult {
  double maxError = 0;
  int samples = 0;
  int penumbraSamples = 0;
};

PlanarResult planarCase(double alphaDeg, double h, int mapSize) {
  Scene scene;
  scene.meshes.push_back(planarQuad("ground", -3, 3, -3, 3, 0));
  scene.meshes.push_back(planarQuad("blocker", -3, 0, -3, 3, float(h)));
  AreaLight light;
  light.direction = {0, 1, 0};
  light.cosAlpha = float(std::cos(alphaDeg * M_PI / 180));
  light.radiance = {1, 1, 1};
  LightSet set;
  set.lights.push_back(light);
  // The camera stands on the lit side below the blocker's height and looks across the shadow
  // edge at the ground, which faces it and the light.
  Camera cam;
  cam.eye = {2.2f, float(0.45 * h), 0.3f};
  cam.target = {-1.2f, 0, 0};
  cam.up = {0, 1, 0};
  cam.fovyDeg = 50;
  RenderOptions ro;
  ro.width = 128;
  ro.height = 96;
  ro.shadowMapSize = mapSize;
  ro.environmentBackground = false;
  ro.shadow.maxFilterTexels = 64;
  Environment env = builtinEnvironment(16);
  Renderer r(ctx());
  Frame f = r.render(scene, cam, set, env, ro);
  auto vis = r.lastVisibility();
  CameraBasis b = cameraBasis(cam, ro.width, ro.height);
  PlanarResult res;
  const double R = h * std::tan(alphaDeg * M_PI / 180);
  std::vector<double> table(2001);
  for (int k = 0; k <= 2000; ++k)
    table[k] = halfPlaneVisibility(-R + 2 * R * k / 2000.0, h, alphaDeg * M_PI / 180);
  for (int y = 0; y < ro.height; ++y)
    for (int x = 0; x < ro.width; ++x) {
      if (f.image.at(x, y, 3) < 0.5f) continue;
      Vec3 d = cameraRayDirection(b, ro.width, ro.height, x + 0.5f, y + 0.5f);
      if (d[1] >= 0) continue;  // the blocker's underside, not the receiver
      double t = -b.eye[1] / d[1];
      double px = b.eye[0] + t * d[0], pz = b.eye[2] + t * d[2];
      if (std::fabs(px) > 2.9 || std::fabs(pz) > 2.9) continue;  // ground's border
      // the profile is a function of x alone: tabulate it at 1/2000 of the penumbra width
      double u = std::clamp((px + R) / (2 * R), 0.0, 1.0) * 2000;
      int k = std::min(int(u), 1999);
      double expect = table[k] + (u - k) * (table[k + 1] - table[k]);
      double got = vis[std::size_t(y) * ro.width + x];
      res.maxError = std::max(res.maxError, std::fabs(got - expect));
      ++res.samples;
      if (std::fabs(px) < R) ++res.penumbraSamples;
    }
  std::printf("[ penumbra ] MSSM4 planar alpha %.1f deg, h %.1f, map %d: max |V - V_analytic| = %.4f over %d pixels\n",
              alphaDeg, h, mapSize, res.maxError, res.samples);
  return res;
}

}  // namespace

// Bound 0.05 (issue 2). Budget: the box filter standing in for the disc-shaped light (equal-area
// square, kernels/moments.cl) differs from the disc's profile by at most 0.023 on a straight edge;
// the rest covers the moment bias and the shadow map's texel quantization of the edge.
TEST(MSSM4, NarrowPenumbraMatchesAnalyticProfile) {
  PlanarResult r = planarCase(5.0, 1.0, 256);
  EXPECT_GT(r.samples, 5000);
  EXPECT_GT(r.penumbraSamples, 100);
  EXPECT_LT(r.maxError, 0.05);
}

TEST(MSSM4, WidePenumbraMatchesAnalyticProfile) {
  PlanarResult r = planarCase(15.0, 1.0, 256);
  EXPECT_GT(r.penumbraSamples, 500);
  EXPECT_LT(r.maxError, 0.05);
}

TEST(MSSM4, HighBlockerSmallMap) {
  PlanarResult r = planarCase(8.0, 2.0, 128);
  EXPECT_GT(r.penumbraSamples, 300);
  EXPECT_LT(r.maxError, 0.05);
}

TEST(MSSM4, NoShadowsMeansFullVisibilityAndSameLighting) {
  Scene scene = builtinScene();
  Environment env = builtinEnvironment(64);
  MedianCutOptions mc;
  mc.lights = 8;
  mc.faceSize = 32;
  LightSet set = extractMedianCut(ctx(), env, mc);
  RenderOptions ro;
  ro.width = 64;
  ro.height = 36;
  ro.shadowMapSize = 64;
  Renderer r(ctx());
  Camera cam = frameCamera(scene, 64.0f / 36.0f);
  ro.shadows = ShadowTechnique::None;
  Frame none = r.render(scene, cam, set, env, ro);
  for (float v : r.lastVisibility()) ASSERT_EQ(v, 1.0f);
  ro.shadows = ShadowTechnique::MSSM4;
  Frame mssm = r.render(scene, cam, set, env, ro);
  // shadows only remove light
  double sumNone = 0, sumMssm = 0;
  for (std::size_t i = 0; i < none.image.pixels.size(); i += 4) {
    for (int c = 0; c < 3; ++c) {
      ASSERT_TRUE(std::isfinite(mssm.image.pixels[i + c]));
      ASSERT_LE(mssm.image.pixels[i + c], none.image.pixels[i + c] * 1.0001f + 1e-6f);
      if (none.image.pixels[i + 3] < 0.5f) continue;  // background: the environment itself
      sumNone += none.image.pixels[i + c];
      sumMssm += mssm.image.pixels[i + c];
    }
  }
  EXPECT_LT(sumMssm, 0.95 * sumNone);  // and there are shadows in the default scene
}

TEST(MSSM4, SameFrameTwiceIsIdentical) {
  Scene scene = builtinScene();
  Environment env = builtinEnvironment(64);
  MedianCutOptions mc;
  mc.lights = 6;
  mc.faceSize = 32;
  LightSet set = extractMedianCut(ctx(), env, mc);
  RenderOptions ro;
  ro.width = 48;
  ro.height = 32;
  ro.shadowMapSize = 64;
  Renderer r(ctx());
  Camera cam = frameCamera(scene, 1.5f);
  Frame a = r.render(scene, cam, set, env, ro);
  Frame b = r.render(scene, cam, set, env, ro);
  EXPECT_EQ(a.image.pixels, b.image.pixels);
}

// Every kernel of a frame on tiny inputs: env resampling (gather and splat), SATs, median cut,
// light resolve, shadow-map and G-buffer rasterization, moments, visibility, shading. Also run by
// CTest under oclgrind, which fails on any invalid access, race or divergence it reports.
TEST(OclgrindFrame, TinyFrame) {
  Scene scene = builtinScene();
  for (int width : {16, 64}) {  // 16: gather (map coarser than the cube), 64: splat
    Environment env = builtinEnvironment(width);
    MedianCutOptions mc;
    mc.lights = width == 16 ? 3 : 7;
    mc.faceSize = 4;
    mc.supersample = 2;
    LightSet set = extractMedianCut(ctx(), env, mc);
    ASSERT_EQ(int(set.lights.size()), mc.lights);
    RenderOptions ro;
    ro.width = 12;
    ro.height = 7;
    ro.shadowMapSize = 8;
    Renderer r(ctx());
    Frame f = r.render(scene, frameCamera(scene, 12.0f / 7.0f), set, env, ro);
    int geometry = 0;
    for (std::size_t i = 0; i < f.image.pixels.size(); i += 4) {
      for (int c = 0; c < 4; ++c) ASSERT_TRUE(std::isfinite(f.image.pixels[i + c]));
      geometry += f.image.pixels[i + 3] > 0.5f;
    }
    EXPECT_GT(geometry, 20);
  }
}
