// MSSM4 against the analytic penumbra of the planar, parallel configuration (Kneiphof 2017 §3.2;
// the
// configuration in which PCSS-style filtering is exact, Annen et al. 2008 §3), and a tiny whole
// frame that
// exercises every kernel (also run under oclgrind, label `oclgrind`).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "common.hpp"
#include "support/planar_penumbra.hpp"

using namespace penumbra;
using namespace penumbra::test;

namespace {

ProfileComparison planarCase(double alphaDeg, double h, int mapSize) {
  PlanarPenumbra s;
  s.blockers = {{0.0, h}};
  s.light = capLightAbove(alphaDeg);
  s.mapSize = mapSize;
  PlanarFrame f = renderPlanar(s, RenderOptions{});
  ProfileComparison res = compareWithProfile(f.receivers, halfPlaneProfile(h, alphaDeg * M_PI / 180));
  std::printf("[ penumbra ] MSSM4 planar alpha %.1f deg, h %.1f, map %d: max |V - V_analytic| = %.4f over %d pixels\n",
              alphaDeg, h, mapSize, res.maxError, res.samples);
  return res;
}

}  // namespace

// Bound 0.05 (issue 2). Budget: the box filter standing in for the disc-shaped light (equal-area
// square, kernels/shadows/moments.cl) differs from the disc's profile by at most 0.023 on a
// straight edge; the rest covers the moment bias and the shadow map's texel quantization of the
// edge.
TEST(MSSM4, NarrowPenumbraMatchesAnalyticProfile) {
  ProfileComparison r = planarCase(5.0, 1.0, 256);
  EXPECT_GT(r.samples, 5000);
  EXPECT_GT(r.penumbraSamples, 100);
  EXPECT_LT(r.maxError, 0.05);
}

TEST(MSSM4, WidePenumbraMatchesAnalyticProfile) {
  ProfileComparison r = planarCase(15.0, 1.0, 256);
  EXPECT_GT(r.penumbraSamples, 500);
  EXPECT_LT(r.maxError, 0.05);
}

TEST(MSSM4, HighBlockerSmallMap) {
  ProfileComparison r = planarCase(8.0, 2.0, 128);
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
