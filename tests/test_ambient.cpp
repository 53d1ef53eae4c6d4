// The ambient residual (src/environment/ambient.cpp, kernels/environment/sh.cl): the map's SH
// projection against host quadrature, the caps' analytic projection against quadrature, irradiance
// of a constant map, the ambient of every method on every map against map minus lights by the
// test's own quadrature (tests/support/extraction_checks.hpp) with negative controls, and the
// ambient in rendered frames and in the reference.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <nlohmann/json.hpp>

#include "common.hpp"
#include "support/extraction_checks.hpp"

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

AmbientOptions sh9Options() {
  AmbientOptions o;
  o.model = AmbientModel::SH9;
  return o;
}

SH9 ambientOf(const Environment& env, LightSet set = {}) {
  addAmbientResidual(ctx(), env, set, sh9Options());
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

TEST(Ambient, ConstantMapSH9IrradianceIsPiL) {
  // AmbientModel::SH9. Exact per-texel integration: a constant map of any size projects onto Y_00
  // alone, and its irradiance is pi L on every normal. 1e-5: float sums of the texel integrals.
  const float L[3] = {0.5f, 1.0f, 2.0f};
  for (auto& s : std::vector<std::array<int, 2>>{{1, 1}, {4, 2}, {37, 19}, {512, 256}}) {
    Environment env;
    env.source = "constant";
    env.equirect = Image(s[0], s[1], 3);
    for (std::size_t i = 0; i < env.equirect.pixels.size(); ++i) env.equirect.pixels[i] = L[i % 3];
    LightSet set;
    addAmbientResidual(ctx(), env, set, sh9Options());
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
  ASSERT_EQ(a.ambientMap.width, AmbientOptions{}.mapWidth);
  ASSERT_EQ(a.ambientMap.height, AmbientOptions{}.mapHeight);
  EXPECT_EQ(a.ambientMap.rgb, b.ambientMap.rgb);
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

namespace {

// Median cut at 32 lights with the SH9 ambient on every map, judged in two parts; "lights +
// ambient give the map's power and irradiance" is not one of them, as it holds for any lights
// (the ambient is the map minus the lights: an empty light set passes it).
// The lights alone carry the map's whole power (Kneiphof 2017 eqs. 16-17; issue 4's 1%), against the
// power of the test's own quadrature of the map: measured worst 0.017% (builtin).
// The ambient alone against the map minus the lights, both by the test's quadrature, relative to
// the map's irradiance, on the 26 normals: order-2 SH drops the residual's bands l >= 3, sharp in
// the normal where a light's horizon passes (the caps straddling a normal's horizon, see the
// report of issue 4), so issue 4's 2% is not met: KnownGap below. RegressionBound: measured worst
// 8.6% (courtyard's blue on a dim normal; 5.1 / 5.4 / 4.3% interior, studio, builtin) + 1.4
// points of margin (10%); the ambient made for no lights, for the lights turned round or for half
// their power, kept beside the real lights, misses by 121-151% / 108-1114% / 62-78% and is
// asserted to fail it, as the halved lights' power (50% off) fails the 1%.
// This is the SH9 model (AmbientModel::SH9); the default irradiance map meets the 2%:
// IrradianceMapMeetsIssue4OnEveryMethodAndMap below.
constexpr double kSH9AmbientRegressionBound = 0.10;
constexpr double kIssue4Bound = 0.02;

// Per map: the SH9 ambient's error; with `controls`, also the lights' power and the controls,
// asserted.
std::vector<double> medianCutSH9AmbientErrors(const std::vector<Environment>& envs, bool controls) {
  std::vector<double> errors;
  for (auto& env : envs) {
    ExtractOptions eo;
    eo.medianCut.lights = 32;
    eo.ambientOptions = sh9Options();
    LightSet set = extractLights(ctx(), env, eo);
    EXPECT_TRUE(set.hasAmbient && set.ambientMap.empty());
    const xref::Target t = xref::mapTarget(xref::mapSamples(env), xref::testNormals());
    const double amb = xref::ambientError(set, t);
    errors.push_back(amb);
    if (!controls) continue;
    const double lightsPower = xref::lightsError(set, t).power;
    const double halvedPower = xref::lightsError(xref::halved(set), t).power;
    const auto ctl = xref::ambientControls(ctx(), env, set, eo.ambientOptions, t);
    std::printf("[ measured ] %s: median cut 32, lights alone: power error %.3f%%; SH9 ambient vs "
                "map - lights on 26 normals: worst %.2f%%; controls (ambient of no lights / "
                "negated / halved): %.1f%% / %.1f%% / %.1f%%; halved lights' power error "
                "%.1f%%\n",
                env.source.c_str(), 100 * lightsPower, 100 * amb, 100 * ctl[0], 100 * ctl[1],
                100 * ctl[2], 100 * halvedPower);
    EXPECT_LT(lightsPower, 0.01) << env.source;
    EXPECT_GT(halvedPower, 0.01) << env.source << ": the halved control must fail";
    for (double c : ctl) EXPECT_GT(c, kSH9AmbientRegressionBound) << env.source << " control";
  }
  return errors;
}

}  // namespace

TEST(Ambient, RegressionBoundMedianCut32SH9AmbientOnEveryMap) {
  std::vector<Environment> envs;
  for (const char* rel : kMaps) envs.push_back(loadEnvironment(data(rel)));
  envs.push_back(builtinEnvironment());
  for (double e : medianCutSH9AmbientErrors(envs, true)) EXPECT_LT(e, kSH9AmbientRegressionBound);
}

// Issue 4's 2% for the SH9 ambient: not met (above; the worst map, courtyard, alone here: measured
// 8.6%). Fails the day it is met: then assert the 2% in the test above.
TEST(Ambient, MedianCut32SH9AmbientKnownGapToIssue4Bound) {
  const auto e = medianCutSH9AmbientErrors({loadEnvironment(data(kMaps[0]))}, false);
  EXPECT_GT(e.at(0), kIssue4Bound);
}

// A rendered frame with the ambient differs from the same frame without it by exactly the
// ambient's irradiance times albedo / pi on a surface nothing occludes: one quad facing +y.
// Both models: the irradiance map (default) and SH9.
TEST(Ambient, FrameAddsTheAmbientUnshadowed) {
  for (AmbientModel model : {AmbientModel::IrradianceMap, AmbientModel::SH9}) {
  SCOPED_TRACE(toString(model));
  Scene scene;
  scene.meshes.push_back(planarQuad("floor", -1, 1, -1, 1, 0));
  const Camera cam = topDownCamera(30);
  Environment env = loadEnvironment(data(kMaps[2]));
  ExtractOptions eo;
  eo.medianCut.lights = 8;
  eo.medianCut.faceSize = 32;
  eo.ambientOptions.model = model;
  LightSet with = extractLights(ctx(), env, eo);
  ASSERT_EQ(with.ambientMap.empty(), model == AmbientModel::SH9);
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
  const std::string text = set.toJson();
  const nlohmann::json j = nlohmann::json::parse(text);
  EXPECT_EQ(j["ambient_sh"].size(), 9u) << text;
  EXPECT_EQ(j["ambient_sh"][0], nlohmann::json::parse("[1, 2, 3]")) << text;
  for (std::size_t k = 1; k < 9; ++k)
    EXPECT_EQ(j["ambient_sh"][k], nlohmann::json::parse("[0, 0, 0]")) << k << "\n" << text;
  EXPECT_EQ(j["ambient"], true);
  ASSERT_TRUE(j["ambient_power"].is_array()) << text;
  EXPECT_EQ(j["ambient_power"].size(), 3u) << text;
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
  eo.ambientOptions.mapWidth = 6;  // small for the simulator; the table read is what is tested
  eo.ambientOptions.mapHeight = 4;
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

// ---------------------------------------------------------------------------------------------
// The pre-integrated irradiance map (AmbientModel::IrradianceMap,
// kernels/environment/irradiance.cl).

namespace {

struct HostMap {
  std::vector<double> rgb;    // TW x TH x RGB, as AmbientMap
  std::vector<double> scale;  // per texel: sum of the map terms' magnitudes (float tolerances)
  double lightScale = 0;      // sum of the lights' radiance x solid angle (their largest E)
};

// Plain C++ reference of the table: at every table normal (pb_ambient_map_normal), every map
// texel's L_t max(0, n.m_t) with its exact first moment m_t in double, minus each light's
// AreaLight::irradiance (the shading's formulas). Texel by texel: the kernel's runs of columns
// (and antipodes) must give the same sum.
HostMap hostAmbientMap(const Environment& env, const std::vector<AreaLight>& lights, int TW,
                       int TH) {
  const Image& im = env.equirect;
  const int W = im.width, H = im.height;
  const double shift = env.rotationColumns();
  std::vector<std::array<double, 3>> m(std::size_t(W) * H);
  for (int r = 0; r < H; ++r) {
    const double a = M_PI * r / H, b = M_PI * (r + 1) / H;
    const double s2 = 0.5 * (b - a) - 0.25 * (std::sin(2 * b) - std::sin(2 * a));
    const double cs = 0.5 * (std::sin(b) * std::sin(b) - std::sin(a) * std::sin(a));
    for (int c = 0; c < W; ++c) {
      // map column c lies at world column c - shift (modulo W; Environment::rotationColumns)
      const double p = ((c - shift) / W - 0.5) * 2 * M_PI, q = ((c + 1 - shift) / W - 0.5) * 2 * M_PI;
      m[std::size_t(r) * W + c] = {s2 * (std::cos(p) - std::cos(q)), cs * (q - p),
                                   -s2 * (std::sin(q) - std::sin(p))};
    }
  }
  HostMap out;
  out.rgb.assign(std::size_t(TW) * TH * 3, 0.0);
  out.scale.assign(std::size_t(TW) * TH, 0.0);
  for (int j = 0; j < TH; ++j)
    for (int i = 0; i < TW; ++i) {
      float nx, ny, nz;
      pb_ambient_map_normal(i, j, TW, TH, &nx, &ny, &nz);
      const std::size_t o = std::size_t(j) * TW + i;
      for (std::size_t t = 0; t < m.size(); ++t) {
        const double e = nx * m[t][0] + ny * m[t][1] + nz * m[t][2];
        const double lum = im.pixels[3 * t] + im.pixels[3 * t + 1] + im.pixels[3 * t + 2];
        out.scale[o] += lum * std::sqrt(m[t][0] * m[t][0] + m[t][1] * m[t][1] + m[t][2] * m[t][2]);
        if (e > 0)
          for (int c = 0; c < 3; ++c) out.rgb[3 * o + c] += e * im.pixels[3 * t + c];
      }
      for (const AreaLight& l : lights) {
        const auto e = l.irradiance({nx, ny, nz});
        for (int c = 0; c < 3; ++c) out.rgb[3 * o + c] -= e[c];
      }
    }
  for (const AreaLight& l : lights)
    for (int c = 0; c < 3; ++c) out.lightScale += double(l.radiance[c]) * l.solidAngle();
  return out;
}

// A cap and a polygon light somewhere on the sphere, so that the subtraction is tested on both.
std::vector<AreaLight> twoLights() {
  AreaLight cap;
  cap.direction = {0.48f, 0.6f, -0.64f};
  cap.cosAlpha = float(std::cos(12 * M_PI / 180));
  cap.radiance = {3.0f, 2.0f, 1.0f};
  AreaLight poly = makePolygonLight({{0.1f, -0.2f, 1.0f}, {0.5f, -0.2f, 0.9f}, {0.4f, 0.3f, 0.9f}},
                                    {1.0f, 1.5f, 2.0f});
  return {cap, poly};
}

// The device table against the host reference. The kernel sums float terms (compensated running
// sums along each row, differences of two of them per row, then bands of rows), and both sides
// evaluate the lights' float formulas, whose rounding scales with the light's size, not with its
// (possibly tiny, clipped) irradiance. Measured worst |error| / (map scale + light scale) over the
// cases below: see the [ measured ] line (2.7e-7, on the 1x1 map, whose one texel's moment is ~0:
// the lights' rounding alone; 2.6e-7 with the kernel before the runs); 2e-6 leaves margin for
// other devices' rounding. Returns the worst ratio.
double expectMapMatchesHost(const Environment& env, int TW, int TH, const std::string& what) {
  LightSet set;
  set.lights = twoLights();
  AmbientOptions o;
  o.mapWidth = TW;
  o.mapHeight = TH;
  addAmbientResidual(ctx(), env, set, o);
  EXPECT_EQ(set.ambientMap.width, TW) << what;
  EXPECT_EQ(set.ambientMap.height, TH) << what;
  EXPECT_EQ(set.ambientMap.rgb.size(), std::size_t(TW) * TH * 3) << what;
  if (set.ambientMap.rgb.size() != std::size_t(TW) * TH * 3) return 1;
  const HostMap host = hostAmbientMap(env, set.lights, TW, TH);
  double worst = 0;
  for (std::size_t o2 = 0; o2 < host.scale.size(); ++o2)
    for (int c = 0; c < 3; ++c) {
      const double err = std::fabs(set.ambientMap.rgb[3 * o2 + c] - host.rgb[3 * o2 + c]);
      const double scale = host.scale[o2] + host.lightScale;
      const double tol = 2e-6 * scale;
      worst = std::max(worst, err / scale);
      EXPECT_LE(err, tol) << what << " texel " << o2 << " channel " << c << ": device "
                          << set.ambientMap.rgb[3 * o2 + c] << ", host " << host.rgb[3 * o2 + c];
    }
  return worst;
}

// The 26 normals plus `extra` random ones (uniform on the sphere, fixed seed).
std::vector<std::array<float, 3>> testNormals(int extra) {
  auto out = normals26();
  std::mt19937 rng(4);
  std::normal_distribution<float> g;
  for (int i = 0; i < extra; ++i) {
    float x = g(rng), y = g(rng), z = g(rng), l = std::sqrt(x * x + y * y + z * z);
    out.push_back({x / l, y / l, z / l});
  }
  return out;
}

}  // namespace

TEST(AmbientMap, MatchesHostReferenceOnAwkwardSizes) {
  // Maps: 1x1 (a constant sphere), one row, one column, odd sizes, one with many bands of rows
  // (257x129: 17 bands of 8 rows, the last one partial), a rotated one. Tables of odd width
  // (every normal's runs summed): 1x1, 1x3 (one column: the three nodes pole, equator, pole),
  // 5x3, 67x33 (more texels than a work-group); of even width (half of them summed, the other
  // half as their antipodes): 2x1 (one row: the equator, both halves), 4x3 (an odd middle row
  // paired with itself), 6x4, 64x32.
  const int maps[][2] = {{1, 1}, {7, 1}, {1, 9}, {37, 19}, {257, 129}};
  const int tables[][2] = {{1, 1}, {1, 3}, {5, 3}, {67, 33}, {2, 1}, {4, 3}, {6, 4}, {64, 32}};
  unsigned seed = 11;
  double worst = 0;
  for (auto& ms : maps) {
    Environment env = synthetic(ms[0], ms[1], seed++);
    for (auto& ts : tables)
      worst = std::max(worst, expectMapMatchesHost(env, ts[0], ts[1],
                                                   std::to_string(ms[0]) + "x" +
                                                       std::to_string(ms[1]) + " map, " +
                                                       std::to_string(ts[0]) + "x" +
                                                       std::to_string(ts[1]) + " table"));
  }
  Environment rot = synthetic(64, 32, 99);
  rot.rotationYDeg = 33.0f;
  worst = std::max(worst, expectMapMatchesHost(rot, 67, 33, "64x32 map turned 33 degrees"));
  std::printf("[ measured ] irradiance map kernel vs host reference: worst |error| / scale %.2g\n",
              worst);
}

TEST(AmbientMap, MatchesHostReferenceOnAMapWiderThanThePrefixChunk) {
  // 65536 x 64: a row's prefixes take 2.4 MB, so the 64 MiB of prefixes held at once (src/
  // ambient.cpp kMaxPrefixBytes) are 3 bands of 8 rows: 3 chunks (the last of 2 bands), each a
  // prefix and a bands launch.
  Environment env = synthetic(65536, 64, 5);
  double worst = std::max(expectMapMatchesHost(env, 4, 3, "65536x64 map, 4x3 table"),
                          expectMapMatchesHost(env, 5, 3, "65536x64 map, 5x3 table"));
  std::printf("[ measured ] 65536x64 map in chunks: worst |error| / scale %.2g\n", worst);
}

TEST(AmbientMap, MatchesHostReferenceOnARealMap) {
  // A real map (1024x512), turned by a fraction of a column, on an even table (antipodes).
  Environment env = loadEnvironment(data(kMaps[0]));
  env.rotationYDeg = -71.0f;
  const double worst = expectMapMatchesHost(env, 12, 7, "courtyard, 12x7 table");
  std::printf("[ measured ] courtyard 12x7: worst |error| / scale %.2g\n", worst);
}

TEST(AmbientMap, TableHoldsTheMapsIrradianceAtItsNormals) {
  // Without lights the table is E_map itself: against Environment::irradiance (4x4 sub-samples
  // per texel) at the table's own normals. They differ only on the texels a normal's horizon cuts
  // (the kernel clamps each texel's exact first moment, the host sub-samples): measured worst
  // 0.011% on the 1024x512 maps; 0.1% bounds it.
  for (const char* rel : kMaps) {
    Environment env = loadEnvironment(data(rel));
    LightSet set;
    AmbientOptions o;
    o.mapWidth = 6;
    o.mapHeight = 5;
    addAmbientResidual(ctx(), env, set, o);
    double worst = 0;
    for (int j = 0; j < 5; ++j)
      for (int i = 0; i < 6; ++i) {
        float n[3];
        pb_ambient_map_normal(i, j, 6, 5, &n[0], &n[1], &n[2]);
        double e[3];
        env.irradiance(n, e);
        for (int c = 0; c < 3; ++c) {
          const double got = set.ambientMap.rgb[3 * (std::size_t(j) * 6 + i) + c];
          worst = std::max(worst, std::fabs(got / e[c] - 1));
          EXPECT_NEAR(got, e[c], 1e-3 * e[c]) << rel << " texel " << i << "," << j;
        }
        // the lookup at a table normal returns that texel (nodes in latitude, centres in
        // longitude): the same value through LightSet::ambientIrradiance
        auto a = set.ambientIrradiance({n[0], n[1], n[2]});
        for (int c = 0; c < 3; ++c)
          EXPECT_NEAR(a[c], set.ambientMap.rgb[3 * (std::size_t(j) * 6 + i) + c], 1e-4 * e[c]);
      }
    std::printf("[ measured ] %s: table vs host irradiance at its normals, worst %.4f%%\n", rel,
                100 * worst);
  }
}

TEST(AmbientMap, ConstantMapGivesPiL) {
  // Every table normal sees pi L. Exact for texels wholly above or below the horizon; the texels
  // the horizon cuts are clamped whole, an error of about the texel's angular size squared:
  // measured 3e-5 (512x256) and 6e-3 (37x19) relative; bounds 1e-4 and 2e-2.
  const float L[3] = {0.5f, 1.0f, 2.0f};
  for (auto& s : std::vector<std::array<int, 3>>{{512, 256, 1}, {37, 19, 200}}) {
    Environment env;
    env.source = "constant";
    env.equirect = Image(s[0], s[1], 3);
    for (std::size_t i = 0; i < env.equirect.pixels.size(); ++i) env.equirect.pixels[i] = L[i % 3];
    LightSet set;
    addAmbientResidual(ctx(), env, set);
    double worst = 0;
    for (auto& n : testNormals(50)) {
      auto e = set.irradiance(n);
      for (int c = 0; c < 3; ++c) {
        worst = std::max(worst, std::fabs(e[c] / (M_PI * L[c]) - 1));
        EXPECT_NEAR(e[c], M_PI * L[c], 1e-4 * s[2] * M_PI * L[c]) << s[0] << "x" << s[1];
      }
    }
    std::printf("[ measured ] constant %dx%d map: worst relative error %.2g\n", s[0], s[1], worst);
  }
}

TEST(AmbientMap, RotationIsTheRotatedMapsTable) {
  // A quarter turn shifts the map by width/4 columns exactly; the table is in world directions
  // and the kernels sum the columns in world order, so the turned map's table is the shifted
  // map's bit for bit. A 33-degree turn against the nearest-
  // column resampling of withRotationApplied: a shift of under half a texel.
  Environment env = loadEnvironment(data(kMaps[1]));
  ASSERT_EQ(env.equirect.width % 32, 0);
  Environment rot = env;
  rot.rotationYDeg = 90.0f;
  LightSet a, b;
  addAmbientResidual(ctx(), rot, a);
  addAmbientResidual(ctx(), rot.withRotationApplied(), b);
  ASSERT_EQ(a.ambientMap.rgb.size(), b.ambientMap.rgb.size());
  double p[3];
  env.power(p);
  EXPECT_TRUE(a.ambientMap.rgb == b.ambientMap.rgb);
  rot.rotationYDeg = 33.0f;
  LightSet c, d;
  addAmbientResidual(ctx(), rot, c);
  addAmbientResidual(ctx(), rot.withRotationApplied(), d);
  // The half-texel resampling moves bright texels by up to 0.18 degrees: E moves by up to about
  // its gradient (<= the power) times 0.003 rad. Measured 3.3e-4 of the power; bound 2e-3 as in
  // the SH9 test above.
  double worst = 0;
  for (std::size_t i = 0; i < c.ambientMap.rgb.size(); ++i) {
    worst = std::max(worst, std::fabs(c.ambientMap.rgb[i] - d.ambientMap.rgb[i]) / p[i % 3]);
    EXPECT_NEAR(c.ambientMap.rgb[i], d.ambientMap.rgb[i], 2e-3 * p[i % 3]) << i;
  }
  std::printf("[ measured ] 33-degree turn vs resampled map: worst table difference %.2g of the "
              "power\n", worst);
}

TEST(AmbientMap, BadSizesAreRefused) {
  Environment env = synthetic(8, 4, 1);
  for (auto& s : std::vector<std::array<int, 2>>{{0, 32}, {64, 0}, {1025, 8}, {-3, 4}}) {
    LightSet set;
    AmbientOptions o;
    o.mapWidth = s[0];
    o.mapHeight = s[1];
    try {
      addAmbientResidual(ctx(), env, set, o);
      ADD_FAILURE() << "accepted " << s[0] << "x" << s[1];
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::BadInput);
      EXPECT_NE(std::string(e.what()).find(std::to_string(s[0]) + "x" + std::to_string(s[1])),
                std::string::npos)
          << e.what();
    }
  }
  // A table whose values do not fill its size is refused where it is read.
  LightSet wrong;
  wrong.hasAmbient = true;
  wrong.ambientMap.width = 2;
  wrong.ambientMap.height = 2;
  wrong.ambientMap.rgb.assign(3, 0.0f);
  try {
    wrong.ambientIrradiance({0, 1, 0});
    ADD_FAILURE() << "read a 2x2 table of 3 values";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::BadInput);
    EXPECT_NE(std::string(e.what()).find("2x2 texels need 12 values, got 3"), std::string::npos)
        << e.what();
  }
  EXPECT_EQ(parseAmbientModel("map"), AmbientModel::IrradianceMap);
  EXPECT_EQ(parseAmbientModel("sh9"), AmbientModel::SH9);
  EXPECT_THROW(parseAmbientModel("SH"), Error);
}

TEST(AmbientMap, JsonRoundTripAndBadFields) {
  LightSet set;
  set.lights = twoLights();
  set.hasAmbient = true;
  set.ambientSH[0] = {0.5f, 0.25f, 0.125f};
  set.ambientMap.width = 3;
  set.ambientMap.height = 2;
  for (int i = 0; i < 18; ++i) set.ambientMap.rgb.push_back(0.1f * i - 0.35f + 1e-7f * i);
  LightSet back = lightSetFromJson(set.toJson(), "round trip");
  EXPECT_TRUE(back.hasAmbient);
  EXPECT_EQ(back.ambientMap.width, 3);
  EXPECT_EQ(back.ambientMap.height, 2);
  EXPECT_EQ(back.ambientMap.rgb, set.ambientMap.rgb);  // 9 digits: floats come back exactly
  for (auto& n : testNormals(20)) {
    auto a = set.ambientIrradiance(n), b = back.ambientIrradiance(n);
    for (int c = 0; c < 3; ++c) EXPECT_EQ(a[c], b[c]);
  }
  // Without "ambient_map" the file shades with its SH9.
  LightSet sh = set;
  sh.ambientMap = {};
  LightSet shBack = lightSetFromJson(sh.toJson(), "sh9 only");
  EXPECT_TRUE(shBack.ambientMap.empty());
  EXPECT_TRUE(shBack.hasAmbient);
  EXPECT_EQ(sh.toJson().find("ambient_map"), std::string::npos);
  // Bad shapes and values, each named.
  const std::string head = "{\"lights\": [], \"ambient_sh\": [[0,0,0],[0,0,0],[0,0,0],[0,0,0],"
                           "[0,0,0],[0,0,0],[0,0,0],[0,0,0],[0,0,0]], \"ambient_map\": ";
  const std::pair<const char*, const char*> bad[] = {
      {"[1, 2]", "\"ambient_map\""},
      {"{\"height\": 1, \"irradiance\": [0, 0, 0]}", "ambient_map.width"},
      {"{\"width\": 0, \"height\": 1, \"irradiance\": []}", "ambient_map.width"},
      {"{\"width\": 1.5, \"height\": 1, \"irradiance\": [0, 0, 0]}", "ambient_map.width"},
      {"{\"width\": 1, \"height\": 2000, \"irradiance\": [0, 0, 0]}", "ambient_map.height"},
      {"{\"width\": 2, \"height\": 1, \"irradiance\": [0, 0, 0]}", "ambient_map.irradiance"},
      {"{\"width\": 1, \"height\": 1, \"irradiance\": [0, \"x\", 0]}", "ambient_map.irradiance"},
      {"{\"width\": 1, \"height\": 1, \"irradiance\": [0, 1e39, 0]}", "ambient_map.irradiance"},
      {"{\"width\": 1, \"height\": 1}", "ambient_map.irradiance"},
  };
  for (auto& [text, field] : bad) {
    try {
      lightSetFromJson(head + text + "}", "bad.json");
      ADD_FAILURE() << "accepted " << text;
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::BadInput);
      const std::string msg = e.what();
      EXPECT_NE(msg.find("bad.json"), std::string::npos) << msg;
      EXPECT_NE(msg.find(field), std::string::npos) << text << ": " << msg;
    }
  }
}

// Issue 4's criterion with the default ambient, the irradiance map, stated for what it is about:
// the ambient is the map minus the lights. "Lights + ambient give the map's power and irradiance"
// holds for any lights and so is not asserted (an empty light set passes it). For every method
// (median cut at 32 lights, greedy and center-surround at their defaults) and every test map plus
// the built-in sky, the ambient alone is judged against the map's irradiance minus the lights',
// both by the test's own quadrature (tests/support/extraction_checks.hpp), relative to the map's
// irradiance, on the 26 normals and 200 random ones (the table is not tuned to the 26): within
// issue 4's 2% (the table's bilinear interpolation is what remains; measured worst 0.74%,
// interior center-surround; 0.05-0.48% elsewhere). Negative controls, asserted to fail the 2%:
// the ambient made for no lights, for the lights turned round and for half their power, each
// kept beside the real lights (on the 26 normals): measured 76-135% / 50-1116% / 38-58%, least
// on courtyard center-surround, whose 2 lights carry 1.7% of the power: 10.5% / 49.6% / 5.3%.
// The lights themselves are judged per method in test_lights.cpp, test_greedy.cpp and
// test_center_surround.cpp.
TEST(AmbientMap, IrradianceMapMeetsIssue4OnEveryMethodAndMap) {
  std::vector<Environment> envs;
  for (const char* rel : kMaps) envs.push_back(loadEnvironment(data(rel)));
  envs.push_back(builtinEnvironment());
  for (const Environment& env : envs) {
    const auto samples = xref::mapSamples(env);
    const xref::Target all = xref::mapTarget(samples, xref::testNormals(200));
    const xref::Target few = xref::mapTarget(samples, xref::testNormals());
    for (ExtractionMethod method :
         {ExtractionMethod::MedianCut, ExtractionMethod::Greedy, ExtractionMethod::CenterSurround}) {
      ExtractOptions eo;
      eo.method = method;
      eo.medianCut.lights = 32;
      LightSet set = extractLights(ctx(), env, eo);
      ASSERT_FALSE(set.ambientMap.empty());
      const double err = xref::ambientError(set, all);
      const auto ctl = xref::ambientControls(ctx(), env, set, eo.ambientOptions, few);
      std::printf("[ measured ] %s %s (%zu lights), 128x64 irradiance map vs map - lights on 226 "
                  "normals: worst %.2f%%; controls (ambient of no lights / negated / halved): "
                  "%.1f%% / %.1f%% / %.1f%%\n",
                  env.source.c_str(), toString(method), set.lights.size(), 100 * err,
                  100 * ctl[0], 100 * ctl[1], 100 * ctl[2]);
      EXPECT_LT(err, kIssue4Bound) << env.source << " " << toString(method);
      for (int k = 0; k < 3; ++k)
        EXPECT_GT(ctl[k], kIssue4Bound) << env.source << " " << toString(method) << " control " << k;
    }
  }
}

// Under oclgrind (CTest oclgrind_kernels): the irradiance-map kernels on a small awkward map with
// a cap and a polygon light, on an odd table (every normal summed) and an even one (antipodes).
TEST(OclgrindAmbient, IrradianceMap) {
  const Environment env = synthetic(41, 13, 7);
  expectMapMatchesHost(env, 5, 3, "41x13, 5x3 table");
  expectMapMatchesHost(env, 4, 3, "41x13, 4x3 table");
}
