// The whole frame against Embree: the default scene, built-in sky and 32 median-cut lights,
// rendered with MSSM4 at 256^2 and judged against the Embree reference of the SAME light set with
// exactly traced visibility (referenceLightsWithNoise). Both shade the lights and the ambient
// residual alike, so their difference is the shadow technique's alone, and the reference's noise
// is half the environment truth's at the same samples (1.35% against 2.8% at 1024 spp). The error is measured where the technique matters, the penumbra pixels, with the
// reference's own noise (its two half-sample estimates) stated beside every figure, and the test
// must tell the default technique from hard shadows, from a light size shrunk tenfold and from a
// depth bias raised 25-fold.
#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>
#include <cstdio>
#include <vector>

#include "common.hpp"

using namespace penumbra;
using namespace penumbra::test;

namespace {

// A frame's difference from the light-set reference: relative RMSE over the geometry pixels and
// over the penumbra pixels (reference visibility strictly inside (0.02, 0.98), as `penumbra
// evaluate` counts them), each divided by the reference's mean over the same pixels, RGB.
struct TechniqueError {
  double whole = 0, penumbra = 0;
};

// The pixels a figure is taken over and the reference's noise there: RMSE(A - B) / 2 of its two
// independent half-sample images over the mean (reference.hpp, relativeNoiseOfHalves).
struct Truth {
  ReferenceImage ref;
  std::vector<std::size_t> geometry, penumbra;  // pixel indices
  double noiseWhole = 0, noisePenumbra = 0;
};

// RMSE of a - b over the pixels and RGB, and the mean of an image over them (RGBA images).
double rmseOver(const Image& a, const Image& b, const std::vector<std::size_t>& px) {
  double sq = 0;
  for (std::size_t i : px)
    for (int c = 0; c < 3; ++c) {
      const double d = double(a.pixels[4 * i + c]) - b.pixels[4 * i + c];
      sq += d * d;
    }
  return std::sqrt(sq / (3.0 * px.size()));
}
double meanOver(const Image& a, const std::vector<std::size_t>& px) {
  double s = 0;
  for (std::size_t i : px)
    for (int c = 0; c < 3; ++c) s += a.pixels[4 * i + c];
  return s / (3.0 * px.size());
}

Truth makeTruth(const Scene& scene, const Camera& cam, const LightSet& lights,
                const Environment& env, int w, int h, int spp) {
  ReferenceOptions rf;
  rf.width = w;
  rf.height = h;
  rf.spp = spp;
  rf.environmentBackground = false;
  Truth t;
  t.ref = referenceLightsWithNoise(scene, cam, lights, env, rf);
  for (std::size_t i = 0; i < std::size_t(w) * h; ++i) {
    if (t.ref.image.pixels[4 * i + 3] <= 0.5f) continue;
    t.geometry.push_back(i);
    const float v = t.ref.visibility.pixels[i];
    if (v > 0.02f && v < 0.98f) t.penumbra.push_back(i);
  }
  auto noise = [&](const std::vector<std::size_t>& px) {
    return rmseOver(t.ref.halfA, t.ref.halfB, px) / 2 / meanOver(t.ref.image, px);
  };
  t.noiseWhole = noise(t.geometry);
  t.noisePenumbra = noise(t.penumbra);
  return t;
}

TechniqueError techniqueError(const Image& frame, const Truth& t) {
  return {rmseOver(frame, t.ref.image, t.geometry) / meanOver(t.ref.image, t.geometry),
          rmseOver(frame, t.ref.image, t.penumbra) / meanOver(t.ref.image, t.penumbra)};
}

}  // namespace

// MSSM4 on 32 lights (the default technique until stop 36; the default now gives it to the 24
// lights brightest on screen and hard shadows to the rest, which this test also checks).
// Bound: relative RMSE over the penumbra pixels < 0.05 against the light-set reference at 8192
// spp, 96x54 (1284 penumbra pixels of 3086). Measured (this test's printout, PoCL, stop 36):
// MSSM4 0.0431, the default 0.0437; the controls hard shadows 0.0672, light size x0.1 0.0592,
// depth bias x25 0.0904, no shadows 0.3202; the reference's own noise over the same pixels 0.0060
// (0.0048 over the whole frame), so the bound stands 0.006 above MSSM4 and 0.009 below the
// nearest control, each margin at or above the noise (asserted: noise < 0.01), and hard shadows
// lose to MSSM4 by 0.0241, four times the noise (asserted: more than twice). At 1024 spp and
// 128x72 the noise was 0.0174, too close to the 0.02 gap between MSSM4 and the light size x0.1
// control; at 4096 spp 0.0086. At 64x36 (8192 spp) the pixels are wider than the penumbrae and
// MSSM4's lead shrinks to 0.012 (MSSM4 0.054, hard 0.066). The environment truth cannot do this at any
// affordable sample count (issue 15: 2.8% noise at 1024 spp, and the extraction's own 3.2% in
// every figure).
// What MSSM4's 4% is made of: the square filter standing in for the disc-shaped cap (up to 0.023
// in visibility on a straight edge, test_mssm.cpp), moment reconstruction in overlapping
// penumbrae, and the 256^2 map's texels at contacts.
TEST(Frame, MSSM4BeatsHardShadowsAgainstLightSetReference) {
  Scene scene = builtinScene();
  Environment env = builtinEnvironment();
  const int W = 96, H = 54, kSpp = 8192;
  Camera cam = frameCamera(scene, float(W) / H);
  MedianCutOptions mc;
  mc.lights = 32;
  LightSet lights = extractMedianCut(ctx(), env, mc);
  ASSERT_EQ(lights.lights.size(), 32u);
  const Truth truth = makeTruth(scene, cam, lights, env, W, H, kSpp);
  std::printf("[ penumbra ] light-set reference %dx%d, %d spp: %zu geometry pixels, %zu penumbra; "
              "noise %.4f whole, %.4f penumbra (library estimate %.4f)\n",
              W, H, kSpp, truth.geometry.size(), truth.penumbra.size(), truth.noiseWhole,
              truth.noisePenumbra, truth.ref.relativeNoise);
  ASSERT_GT(truth.geometry.size(), std::size_t(W * H / 2));
  // the noise figure here is the library's own over the same pixels
  EXPECT_NEAR(truth.noiseWhole, truth.ref.relativeNoise, 1e-4);
  ASSERT_GT(truth.penumbra.size(), std::size_t(W * H / 10));

  Renderer renderer(ctx());
  auto run = [&](const char* what, RenderOptions ro) {
    ro.width = W;
    ro.height = H;
    ro.environmentBackground = false;
    const TechniqueError e = techniqueError(renderer.render(scene, cam, lights, env, ro).image, truth);
    std::printf("[ penumbra ] %-22s relative RMSE vs light-set reference: whole %.4f, penumbra %.4f\n",
                what, e.whole, e.penumbra);
    return e;
  };
  RenderOptions mssm4;
  mssm4.shadows = ShadowTechnique::MSSM4;
  const TechniqueError def = run("mssm4", mssm4);
  RenderOptions hardRo;
  hardRo.shadows = ShadowTechnique::Hard;
  const TechniqueError hard = run("hard", hardRo);
  RenderOptions smallRo = mssm4;
  smallRo.shadow.lightSizeScale = 0.1f;
  const TechniqueError small = run("light size x0.1", smallRo);
  RenderOptions biasRo = mssm4;
  biasRo.shadow.depthBias = 25 * RenderOptions{}.shadow.depthBias;
  const TechniqueError bias = run("depth bias x25", biasRo);
  // the default (auto: of these 32 lights the 24 brightest on screen MSSM4, the rest hard)
  const TechniqueError autoDefault = run("default (auto)", RenderOptions{});
  RenderOptions noneRo;
  noneRo.shadows = ShadowTechnique::None;
  const TechniqueError none = run("no shadows", noneRo);

  const double kBound = 0.05;
  EXPECT_LT(truth.noisePenumbra, 0.01);  // below both margins of the bound
  EXPECT_LT(def.penumbra, kBound);
  EXPECT_GT(hard.penumbra - def.penumbra, 2 * truth.noisePenumbra);
  // The negative controls: each is a technique broken in one way, and each must fail the bound.
  EXPECT_GT(hard.penumbra, kBound);
  EXPECT_GT(small.penumbra, kBound);  // penumbrae a tenth as wide: near-hard shadows
  EXPECT_GT(bias.penumbra, kBound);   // light leaks at contacts and under near blockers
  EXPECT_GT(none.penumbra, kBound);
  // Over the whole frame too MSSM4 is closest (0.0244; hard 0.0376, x0.1 0.0333, bias 0.0496),
  // by more than twice the noise there (0.0048) against hard shadows.
  EXPECT_GT(hard.whole - def.whole, 2 * truth.noiseWhole);
  // The default on the same lights: within the bound, and ahead of hard shadows by the same
  // margins (measured 0.0437 penumbra, 0.0248 whole at stop 36; 0.0168 and 0.0113 at stop 45,
  // with contact shadows and the budget ranked by irradiance on screen).
  EXPECT_LT(autoDefault.penumbra, kBound);
  EXPECT_GT(hard.penumbra - autoDefault.penumbra, 2 * truth.noisePenumbra);
  EXPECT_GT(hard.whole - autoDefault.whole, 2 * truth.noiseWhole);
}

// The frame end to end (extraction and technique together) against the environment map's truth.
// This bound cannot tell techniques apart (issue 15: hard shadows, light size x0.1 and depth bias
// x25 all pass it; the reference's noise is as large as the techniques' differences): that is the
// test above's job. It stays as the end-to-end regression bound it is.
// Bound: relative RMSE < 0.08 against a 1024-spp reference at 160x90. What it is made of, measured
// with the CLI (README, "Measuring"): the 32-light set itself differs from the map by 3.2% (light-set
// reference vs environment reference, both 2048 spp); MSSM4 differs from the light-set reference by
// 2.9% (weak shadows of large lights, Kneiphof 2017 Fig. 7, and texel-sized contact detail); the
// reference's own Monte Carlo noise is 2.8% at 1024 spp (two seeds at 256 spp differ by 8.4%, i.e.
// 5.9% each). Measured total: 4.9% (4.1% at 12d159c; 3.6% with stop 36's default, 64 lights, the
// 24 brightest MSSM4; 3.1% at stop 45, the 24 brightest on screen); the bound leaves room for
// other seeds' noise and for float differences between OpenCL devices, while a broken shadow pass
// (no shadows: 18.9%) fails it.
TEST(Frame, DefaultSceneAgainstEmbreeEnvironmentReference) {
  Scene scene = builtinScene();
  Environment env = builtinEnvironment();
  const int W = 160, H = 90;
  Camera cam = frameCamera(scene, float(W) / H);
  LightSet lights = extractMedianCut(ctx(), env, {});
  ASSERT_EQ(lights.lights.size(), 64u);
  RenderOptions ro;
  ro.width = W;
  ro.height = H;
  Renderer renderer(ctx());
  Frame frame = renderer.render(scene, cam, lights, env, ro);
  ReferenceOptions rf;
  rf.width = W;
  rf.height = H;
  rf.spp = 1024;
  Image ref = referenceEnvironment(scene, cam, env, rf);
  ImageMetrics m = compareImages(frame.image, ref);
  std::printf("[ penumbra ] default scene and frame (64 lights, auto) vs Embree (1024 spp): "
              "relative RMSE %.4f, PSNR %.2f dB\n",
              m.relativeRmse, m.psnr);
  EXPECT_GT(m.pixels, std::size_t(W * H / 2));
  EXPECT_LT(m.relativeRmse, 0.08);

  // The same frame without shadows is far off: the test can tell shadows from no shadows.
  ro.shadows = ShadowTechnique::None;
  ImageMetrics none = compareImages(renderer.render(scene, cam, lights, env, ro).image, ref);
  EXPECT_GT(none.relativeRmse, 0.15);
}
