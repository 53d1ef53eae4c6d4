// The ambient residual (src/ambient.cpp, kernels/sh.cl): the map's SH projection against host
// quadrature, the caps' analytic projection against quadrature, irradiance of a constant map,
// median cut + ambient on every map, and the ambient in rendered frames and in the reference.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "common.hpp"

using namespace penumbra;
using namespace penumbra::test;

namespace {

using SH9 = std::array<std::array<double, 3>, 9>;

void sh9d(double x, double y, double z, double b[9]) {
  float f[9];
  pb_sh9(float(x), float(y), float(z), f);
  for (int i = 0; i < 9; ++i) b[i] = f[i];
}

// Plain host reference: midpoint quadrature over sub-texels of each lat-long texel, each with its
// exact solid angle, directions from shared.h's pb_equirect_dir convention (in double here).
// Sub-texels are at most ~0.25 degrees, so the quadrature error on these degree-2 polynomials is
// ~(0.0044 rad)^2 / 24 ~ 1e-6 relative.
SH9 hostProjection(const Environment& env) {
  const Image& im = env.equirect;
  const int W = im.width, H = im.height;
  const int sx = std::max(1, int(std::ceil(1440.0 / W)));
  const int sy = std::max(1, int(std::ceil(720.0 / H)));
  SH9 sh{};
  for (int t = 0; t < H; ++t)
    for (int j = 0; j < sy; ++j) {
      const double t0 = M_PI * (t + double(j) / sy) / H, t1 = M_PI * (t + double(j + 1) / sy) / H;
      const double dw = 2 * M_PI / (double(W) * sx) * (std::cos(t0) - std::cos(t1));
      const double th = 0.5 * (t0 + t1);
      for (int s = 0; s < W; ++s)
        for (int i = 0; i < sx; ++i) {
          const double ph = ((s + (i + 0.5) / sx) / W - 0.5) * 2 * M_PI;
          double b[9];
          sh9d(std::sin(th) * std::sin(ph), std::cos(th), -std::sin(th) * std::cos(ph), b);
          for (int k = 0; k < 9; ++k)
            for (int c = 0; c < 3; ++c) sh[k][c] += b[k] * im.at(s, t, c) * dw;
        }
    }
  return sh;
}

Environment synthetic(int W, int H, unsigned seed) {
  Environment env;
  env.source = "synthetic";
  env.equirect = Image(W, H, 3);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (float& v : env.equirect.pixels) v = u(rng) < 0.02f ? 50.0f * u(rng) : u(rng);
  return env;
}

// The 26 normals of the issue: 6 axes, 12 edge and 8 corner directions of a cube.
std::vector<std::array<float, 3>> normals26() {
  std::vector<std::array<float, 3>> out;
  for (int x = -1; x <= 1; ++x)
    for (int y = -1; y <= 1; ++y)
      for (int z = -1; z <= 1; ++z) {
        if (!x && !y && !z) continue;
        float l = std::sqrt(float(x * x + y * y + z * z));
        out.push_back({x / l, y / l, z / l});
      }
  return out;
}

SH9 ambientOf(const Environment& env, LightSet set = {}) {
  addAmbientResidual(ctx(), env, set);
  EXPECT_TRUE(set.hasAmbient);
  SH9 sh{};
  for (int k = 0; k < 9; ++k)
    for (int c = 0; c < 3; ++c) sh[k][c] = set.ambientSH[k][c];
  return sh;
}

// The device projection against the host one. Scale: the channel's power; every |Y_lm| <= 1.1,
// so |c_lm| <= 1.1 P. The device sums float products (relative rounding ~1e-7 each) in groups
// of ~4096 then in double: the error stays ~1e-6 P; 2e-5 P leaves margin for the quadrature.
void expectProjectionMatches(const Environment& env, const std::string& what) {
  SH9 dev = ambientOf(env), host = hostProjection(env);
  double p[3];
  env.power(p);
  for (int k = 0; k < 9; ++k)
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(dev[k][c], host[k][c], 2e-5 * p[c] + 1e-30)
          << what << " coefficient " << k << " channel " << c;
}

}  // namespace

TEST(Ambient, ProjectionMatchesHostQuadratureOnEveryMap) {
  for (const char* rel : kMaps) expectProjectionMatches(loadEnvironment(data(rel)), rel);
  expectProjectionMatches(builtinEnvironment(), "builtin");
}

TEST(Ambient, ProjectionMatchesHostQuadratureOnAwkwardSizes) {
  // 1x1, a single row, a single column, sizes that are not multiples of any work-group, and one
  // larger than the 1024 work-groups' first stride.
  const int sizes[][2] = {{1, 1},   {3, 2},     {7, 1},     {1, 9},
                          {37, 19}, {1000, 3}, {257, 129}, {2051, 1031}};
  unsigned seed = 1;
  for (auto& s : sizes)
    expectProjectionMatches(synthetic(s[0], s[1], seed++),
                            std::to_string(s[0]) + "x" + std::to_string(s[1]));
}

TEST(Ambient, ConstantMapIrradianceIsPiL) {
  // Exact per-texel integration: a constant map of any size projects onto Y_00 alone, and its
  // irradiance is pi L on every normal. 1e-5: float sums of the texel integrals.
  const float L[3] = {0.5f, 1.0f, 2.0f};
  for (auto& s : std::vector<std::array<int, 2>>{{1, 1}, {4, 2}, {37, 19}, {512, 256}}) {
    Environment env;
    env.source = "constant";
    env.equirect = Image(s[0], s[1], 3);
    for (std::size_t i = 0; i < env.equirect.pixels.size(); ++i) env.equirect.pixels[i] = L[i % 3];
    LightSet set;
    addAmbientResidual(ctx(), env, set);
    const std::string what = std::to_string(s[0]) + "x" + std::to_string(s[1]);
    auto ap = set.ambientPower();
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(ap[c], 4 * M_PI * L[c], 1e-5 * 4 * M_PI * L[c]) << what;
    for (auto& n : normals26()) {
      auto e = set.irradiance(n);
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(e[c], M_PI * L[c], 1e-5 * M_PI * L[c]) << what;
    }
  }
}

TEST(Ambient, CapProjectionMatchesQuadrature) {
  // On a black map the residual is minus the caps' projection: check the analytic zonal form
  // against direct quadrature of Y_lm over the cap, for small to hemispherical caps.
  Environment black;
  black.source = "black";
  black.equirect = Image(8, 4, 3);
  const std::array<float, 3> dirs[] = {{0, 1, 0}, {0.6f, 0.0f, 0.8f}, {-0.3f, -0.5f, 0.81240384f}};
  for (double alphaDeg : {1.0, 10.0, 45.0, 80.0, 90.0}) {
    for (auto& d : dirs) {
      AreaLight l;
      l.direction = d;
      l.cosAlpha = float(std::cos(alphaDeg * M_PI / 180));
      l.radiance = {1.0f, 2.0f, 0.5f};
      LightSet set;
      set.lights.push_back(l);
      SH9 got = ambientOf(black, set);
      // quadrature in the cap's own frame: theta from its axis, phi around it
      double t1[3], t2[3], dd[3] = {d[0], d[1], d[2]};
      double a[3] = {std::fabs(d[0]) < 0.9 ? 1.0 : 0.0, std::fabs(d[0]) < 0.9 ? 0.0 : 1.0, 0};
      double dot = a[0] * dd[0] + a[1] * dd[1];
      for (int i = 0; i < 3; ++i) t1[i] = a[i] - dot * dd[i];
      double n1 = std::sqrt(t1[0] * t1[0] + t1[1] * t1[1] + t1[2] * t1[2]);
      for (double& v : t1) v /= n1;
      t2[0] = dd[1] * t1[2] - dd[2] * t1[1];
      t2[1] = dd[2] * t1[0] - dd[0] * t1[2];
      t2[2] = dd[0] * t1[1] - dd[1] * t1[0];
      const double alpha = alphaDeg * M_PI / 180;
      const int nt = 400, np = 400;
      double ref[9] = {0};
      for (int i = 0; i < nt; ++i) {
        double a0 = alpha * i / nt, a1 = alpha * (i + 1) / nt, th = 0.5 * (a0 + a1);
        double dw = (std::cos(a0) - std::cos(a1)) * 2 * M_PI / np;
        for (int j = 0; j < np; ++j) {
          double ph = 2 * M_PI * (j + 0.5) / np;
          double w[3];
          for (int k = 0; k < 3; ++k)
            w[k] = std::cos(th) * dd[k] +
                   std::sin(th) * (std::cos(ph) * t1[k] + std::sin(ph) * t2[k]);
          double b[9];
          sh9d(w[0], w[1], w[2], b);
          for (int k = 0; k < 9; ++k) ref[k] += b[k] * dw;
        }
      }
      // tolerance relative to the cap's solid angle (|Y| <= 1.1): midpoint quadrature error
      // ~(alpha/400)^2 and float storage of the result.
      const double omega = 2 * M_PI * (1 - std::cos(alpha));
      for (int k = 0; k < 9; ++k)
        for (int c = 0; c < 3; ++c)
          EXPECT_NEAR(-got[k][c], ref[k] * l.radiance[c], 1e-5 * omega * l.radiance[c] + 1e-7)
              << "alpha " << alphaDeg << " coefficient " << k << " channel " << c;
    }
  }
}

TEST(Ambient, Deterministic) {
  Environment env = loadEnvironment(data(kMaps[0]));
  ExtractOptions eo;
  LightSet a = extractLights(ctx(), env, eo), b = extractLights(ctx(), env, eo);
  EXPECT_TRUE(a.hasAmbient);
  for (int k = 0; k < 9; ++k)
    for (int c = 0; c < 3; ++c) EXPECT_EQ(a.ambientSH[k][c], b.ambientSH[k][c]);
}

TEST(Ambient, RotationIsTheRotatedMapsProjection) {
  // A map turned by 90 degrees about y projects exactly as its columns shifted by width/4 do.
  Environment env = loadEnvironment(data(kMaps[1]));
  ASSERT_EQ(env.equirect.width % 4, 0);
  for (float deg : {90.0f, -90.0f, 33.0f}) {
    Environment rot = env;
    rot.rotationYDeg = deg;
    SH9 a = ambientOf(rot), b = ambientOf(rot.withRotationApplied());
    double p[3];
    env.power(p);
    // 90 degrees: the same texels at the same places, different summation order only. 33
    // degrees: withRotationApplied resamples by nearest column, a shift of < half a texel.
    const double tol = deg == 33.0f ? 2e-3 : 2e-6;
    for (int k = 0; k < 9; ++k)
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(a[k][c], b[k][c], tol * p[c]) << deg << " " << k;
  }
}

// Median cut at 32 lights plus the ambient on every map. Power: within 1% (issue 4; exact up to
// fixed point, as the lights conserve it and the residual's l = 0 term is then ~0).
// Irradiance on the 26 normals: issue 4 asks for 2%, which order-2 SH cannot give here. Without the
// ambient the error comes from caps that straddle a normal's horizon: clipped as caps, not as the
// regions' real shapes, they differ by up to ~2.6% of E each (measured on studio's -y and the
// sky's (1,-1,-1) normals). That difference is sharp in the normal (the clamped cosine's kink), so
// most of it lies in bands l >= 4, which 9 coefficients drop: host quadrature of the residual's
// bands (report of issue 4) leaves a worst luminance error of 3.3-4.3% at l <= 2 and still 2.4-3%
// at l <= 8. What the ambient does give, and what is asserted: it never makes the worst luminance
// error larger at 32 lights (measured 3.1/3.1/5.6/5.0% -> 1.6/2.9/4.1/3.8% for courtyard, interior,
// studio, builtin), and the result stays under 5.5% luminance and 10% per RGB channel (measured
// worst 4.1% and 8.6%, the latter courtyard's blue on a dim normal), bounds with margin that flag
// any regression of the residual. (The per-channel bound was 8% before median cut's square
// regions chose their cut axis by a rotation-consistent rule: the light set changed, courtyard's
// worst channel went from 6.7% to 8.6% while its luminance error fell from 1.9% to 1.6%.)
TEST(Ambient, MedianCut32WithAmbientOnEveryMap) {
  std::vector<Environment> envs;
  for (const char* rel : kMaps) envs.push_back(loadEnvironment(data(rel)));
  envs.push_back(builtinEnvironment());
  auto lum = [](const double* e) { return PB_LUM_R * e[0] + PB_LUM_G * e[1] + PB_LUM_B * e[2]; };
  for (auto& env : envs) {
    ExtractOptions eo;
    eo.medianCut.lights = 32;
    LightSet set = extractLights(ctx(), env, eo);
    ASSERT_TRUE(set.hasAmbient);
    double p[3];
    env.power(p);
    auto sp = set.power();
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(sp[c] / p[c], 1.0, 0.01) << env.source << " power " << c;
    LightSet bare = set;
    bare.hasAmbient = false;
    double worst = 0, worstBare = 0, worstLum = 0, worstLumBare = 0;
    for (auto& n : normals26()) {
      double e[3];
      env.irradiance(n.data(), e);
      auto with = set.irradiance(n), without = bare.irradiance(n);
      for (int c = 0; c < 3; ++c) {
        worst = std::max(worst, std::fabs(with[c] / e[c] - 1));
        worstBare = std::max(worstBare, std::fabs(without[c] / e[c] - 1));
      }
      worstLum = std::max(worstLum, std::fabs(lum(with.data()) / lum(e) - 1));
      worstLumBare = std::max(worstLumBare, std::fabs(lum(without.data()) / lum(e) - 1));
    }
    std::printf("[ measured ] %s: median cut 32, worst irradiance error on 26 normals: "
                "luminance %.2f%% without ambient, %.2f%% with; RGB %.2f%% -> %.2f%%\n",
                env.source.c_str(), 100 * worstLumBare, 100 * worstLum, 100 * worstBare,
                100 * worst);
    EXPECT_LE(worstLum, worstLumBare) << env.source;
    EXPECT_LT(worstLum, 0.055) << env.source;
    EXPECT_LT(worst, 0.10) << env.source;
  }
}

// A rendered frame with the ambient differs from the same frame without it by exactly the
// ambient's irradiance times albedo / pi on a surface nothing occludes: one quad facing +y.
TEST(Ambient, FrameAddsTheAmbientUnshadowed) {
  Scene scene;
  scene.meshes.push_back(planarQuad("floor", -1, 1, -1, 1, 0));
  const Camera cam = topDownCamera(30);
  Environment env = loadEnvironment(data(kMaps[2]));
  ExtractOptions eo;
  eo.medianCut.lights = 8;
  eo.medianCut.faceSize = 32;
  LightSet with = extractLights(ctx(), env, eo);
  LightSet without = with;
  without.hasAmbient = false;
  Renderer r(ctx());
  RenderOptions opt;
  opt.width = 32;
  opt.height = 24;
  opt.shadowMapSize = 64;
  Image a = r.render(scene, cam, with, env, opt).image;
  Image b = r.render(scene, cam, without, env, opt).image;
  auto amb = with.ambientIrradiance({0, 1, 0});
  const auto& albedo = scene.meshes[0].albedo;
  int geometry = 0;
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) {
      if (a.at(x, y, 3) == 0.0f) continue;
      ++geometry;
      for (int c = 0; c < 3; ++c) {
        double want = albedo[c] / M_PI * amb[c];
        // float shading: a few ulps of the pixel value
        EXPECT_NEAR(a.at(x, y, c) - b.at(x, y, c), want, 1e-5 * std::fabs(a.at(x, y, c)) + 1e-7)
            << x << "," << y << " channel " << c;
      }
    }
  EXPECT_GT(geometry, a.width * a.height / 2);

  // The Embree light-set reference adds the same ambient: with the same seed the samples are
  // the same, so the difference is the ambient alone there too.
  ReferenceOptions ro;
  ro.width = 16;
  ro.height = 12;
  ro.spp = 4;
  ro.threads = 1;
  Image ra = referenceLights(scene, cam, with, env, ro);
  Image rb = referenceLights(scene, cam, without, env, ro);
  for (int y = 0; y < ra.height; ++y)
    for (int x = 0; x < ra.width; ++x) {
      if (ra.at(x, y, 3) == 0.0f) continue;
      for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(ra.at(x, y, c) - rb.at(x, y, c), albedo[c] / M_PI * amb[c],
                    1e-5 * std::fabs(ra.at(x, y, c)) + 1e-7);
    }
}

TEST(Ambient, ExtractionMethodNames) {
  for (auto m : {ExtractionMethod::MedianCut, ExtractionMethod::Greedy,
                 ExtractionMethod::CenterSurround})
    EXPECT_EQ(parseExtractionMethod(toString(m)), m);
  try {
    parseExtractionMethod("median_cut");
    ADD_FAILURE() << "accepted a bad name";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::BadInput);
    std::string msg = e.what();
    for (const char* s : {"median_cut", "median-cut", "greedy", "center-surround"})
      EXPECT_NE(msg.find(s), std::string::npos) << s << ": " << msg;
  }
}

TEST(Ambient, JsonHasTheCoefficients) {
  LightSet set;
  set.ambientSH[0] = {1.0f, 2.0f, 3.0f};
  set.hasAmbient = true;
  std::string j = set.toJson();
  EXPECT_NE(j.find("\"ambient_sh\": [[1, 2, 3], [0, 0, 0]"), std::string::npos) << j;
  EXPECT_NE(j.find("\"ambient_power\""), std::string::npos) << j;
  auto p = set.ambientPower();
  EXPECT_NEAR(p[1], 2.0 * std::sqrt(4 * M_PI), 1e-6);
}

// Under oclgrind (CTest oclgrind_kernels): the projection kernel on a small awkward map.
TEST(OclgrindAmbient, Projection) { expectProjectionMatches(synthetic(13, 7, 5), "13x7"); }

// Under oclgrind: the shading kernel reading the ambient coefficients, on a tiny frame.
TEST(OclgrindAmbient, TinyFrameWithAmbient) {
  Scene scene;
  scene.meshes.push_back(planarQuad("floor", -1, 1, -1, 1, 0));
  const Camera cam = topDownCamera(40);
  Environment env = synthetic(16, 8, 3);
  ExtractOptions eo;
  eo.medianCut.lights = 2;
  eo.medianCut.faceSize = 4;
  eo.medianCut.supersample = 1;
  LightSet set = extractLights(ctx(), env, eo);
  RenderOptions ro;
  ro.width = 8;
  ro.height = 6;
  ro.shadowMapSize = 8;
  ro.shadows = ShadowTechnique::None;
  Renderer r(ctx());
  Image img = r.render(scene, cam, set, env, ro).image;
  auto e = set.irradiance({0, 1, 0});  // nothing occludes the quad: lights + ambient, unshadowed
  int geometry = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      if (img.at(x, y, 3) == 0.0f) continue;
      ++geometry;
      for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(img.at(x, y, c), scene.meshes[0].albedo[c] / M_PI * e[c],
                    1e-4 * img.at(x, y, c));
    }
  EXPECT_GT(geometry, 0);
}
