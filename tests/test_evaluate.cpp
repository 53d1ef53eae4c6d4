// Tests of the references' noise estimate (two half sample sets per pixel), of the shadowed
// ambient residual (ReferenceOptions::shadowAmbient), and of the error budget (evaluate.hpp): its
// parts add up, its figures match a recomputation, its truths come back from the cache unchanged.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "penumbra/environment.hpp"
#include "penumbra/error.hpp"
#include "penumbra/evaluate.hpp"
#include "penumbra/lights.hpp"
#include "penumbra/reference.hpp"
#include "penumbra/scene.hpp"

namespace {

using namespace penumbra;
namespace fs = std::filesystem;

Mesh quad(float y, float h) {
  Mesh m;
  m.name = "quad";
  m.positions = {{-h, y, -h}, {h, y, -h}, {h, y, h}, {-h, y, h}};
  m.triangles = {{0, 2, 1}, {0, 3, 2}};
  m.albedo = {0.5f, 0.5f, 0.5f};
  return m;
}

// A 50 m ground, optionally with a 2 m square blocker 0.5 m above the origin.
Scene ground(bool blocker) {
  Scene s;
  s.meshes.push_back(quad(0.0f, 50.0f));
  if (blocker) s.meshes.push_back(quad(0.5f, 1.0f));
  return s;
}

// Low over the ground, so that it sees under the blocker (rays reach y = 0.5 half-way down); the
// top rows see the sky (background, not compared).
Camera camera() {
  Camera c;
  c.eye = {0, 1.2f, 4};
  c.target = {0, 0, 0.3f};
  c.fovyDeg = 50.0f;
  return c;
}

Environment constantEnv(float v) {
  Environment e;
  e.source = "test";
  e.equirect = Image(8, 4, 3, v);
  return e;
}

ReferenceOptions options(int spp, std::uint64_t seed = 3) {
  ReferenceOptions o;
  o.width = 32;
  o.height = 18;
  o.spp = spp;
  o.seed = seed;
  o.environmentBackground = false;
  return o;
}

// One cap overhead and an ambient residual whose SH9 radiance is the constant c (only L00).
LightSet capAndAmbient(float c) {
  LightSet ls;
  AreaLight l;
  l.direction = {0, 1, 0};
  l.cosAlpha = float(std::cos(25.0 * 3.14159265358979 / 180.0));
  l.radiance = {2.0f, 2.0f, 2.0f};
  ls.lights.push_back(l);
  ls.hasAmbient = true;
  // Y00 = 0.282095: a constant radiance c needs L00 = c / Y00.
  for (int k = 0; k < 3; ++k) ls.ambientSH[0][std::size_t(k)] = float(c / 0.28209479177387814);
  return ls;
}

double meanRgb(const Image& im) {
  double s = 0;
  int n = 0;
  for (int i = 0; i < im.width * im.height; ++i)
    if (im.pixels[std::size_t(i) * 4 + 3] > 0.5f) {
      for (int k = 0; k < 3; ++k) s += im.pixels[std::size_t(i) * 4 + k];
      n += 3;
    }
  return s / n;
}

// ---------------------------------------------------------------------------------------------
// The noise estimate.

TEST(ReferenceNoise, ImageIsUnchangedAndIsTheMeanOfItsHalves) {
  const Scene s = ground(true);
  const Environment env = constantEnv(1.0f);
  const ReferenceOptions o = options(16);
  const Image plain = referenceEnvironment(s, camera(), env, o);
  const ReferenceImage r = referenceEnvironmentWithNoise(s, camera(), env, o);
  ASSERT_EQ(plain.pixels.size(), r.image.pixels.size());
  for (std::size_t i = 0; i < plain.pixels.size(); ++i) {
    ASSERT_EQ(plain.pixels[i], r.image.pixels[i]) << i;
    if (i % 4 == 3) continue;
    EXPECT_NEAR(0.5 * (r.halfA.pixels[i] + r.halfB.pixels[i]), r.image.pixels[i],
                1e-5 * (1.0 + r.image.pixels[i]))
        << i;
  }
  EXPECT_TRUE(r.visibility.empty());
  EXPECT_GT(r.relativeNoise, 0.0);
}

// Without random parts (no lights, the unshadowed residual only) both halves are the image: the
// estimated noise is exactly 0.
TEST(ReferenceNoise, DeterministicImageHasZeroNoise) {
  LightSet ls = capAndAmbient(0.3f);
  ls.lights.clear();
  const ReferenceImage r =
      referenceLightsWithNoise(ground(true), camera(), ls, Environment{}, options(8));
  EXPECT_GT(meanRgb(r.image), 0.0);
  EXPECT_EQ(r.relativeNoise, 0.0);
}

// The estimate agrees with the noise actually seen between two seeds (whose difference has
// sqrt(2) x the noise of each), and halves when spp grows 4x (Monte Carlo's 1/sqrt(N)).
TEST(ReferenceNoise, MatchesSeedToSeedDifferenceAndScalesAsOneOverSqrtSpp) {
  const Scene s = ground(true);
  const Environment env = constantEnv(1.0f);
  const ReferenceImage a = referenceEnvironmentWithNoise(s, camera(), env, options(64, 1));
  const ReferenceImage b = referenceEnvironmentWithNoise(s, camera(), env, options(64, 2));
  const double seen = compareImages(a.image, b.image).relativeRmse / std::sqrt(2.0);
  EXPECT_NEAR(a.relativeNoise, seen, 0.15 * seen);
  EXPECT_NEAR(b.relativeNoise, seen, 0.15 * seen);
  const ReferenceImage c = referenceEnvironmentWithNoise(s, camera(), env, options(256, 1));
  EXPECT_NEAR(c.relativeNoise / a.relativeNoise, 0.5, 0.08);
  // The light-set mode, too.
  const LightSet ls = capAndAmbient(0.1f);
  const ReferenceImage l64 = referenceLightsWithNoise(s, camera(), ls, env, options(64));
  const ReferenceImage l256 = referenceLightsWithNoise(s, camera(), ls, env, options(256));
  EXPECT_GT(l64.relativeNoise, 0.0);
  EXPECT_NEAR(l256.relativeNoise / l64.relativeNoise, 0.5, 0.08);
}

TEST(ReferenceNoise, OneSampleHasNoEstimate) {
  const ReferenceImage r =
      referenceEnvironmentWithNoise(ground(false), camera(), constantEnv(1.0f), options(1));
  EXPECT_TRUE(std::isnan(r.relativeNoise));
}

// The lights' visibility: 1 in the open, 0 under the middle of the blocker, between at its edges.
TEST(ReferenceNoise, VisibilityIsExactInTheOpenAndPartialInPenumbrae) {
  const ReferenceImage r = referenceLightsWithNoise(ground(true), camera(), capAndAmbient(0.0f),
                                                    Environment{}, options(64));
  ASSERT_EQ(r.visibility.channels, 1);
  int open = 0, dark = 0, partial = 0;
  for (float v : r.visibility.pixels) {
    ASSERT_GE(v, 0.0f);
    ASSERT_LE(v, 1.0f);
    open += v == 1.0f;
    dark += v == 0.0f;
    partial += v > 0.02f && v < 0.98f;
  }
  EXPECT_GT(open, 100);
  EXPECT_GT(dark, 0);
  EXPECT_GT(partial, 10);
}

// ---------------------------------------------------------------------------------------------
// The shadowed ambient residual.

TEST(ShadowAmbient, EqualsTheUnshadowedResidualWithoutOccluders) {
  const LightSet ls = capAndAmbient(0.4f);
  ReferenceOptions o = options(32);
  const Image open = referenceLights(ground(false), camera(), ls, Environment{}, o);
  o.shadowAmbient = true;
  const Image shadowed = referenceLights(ground(false), camera(), ls, Environment{}, o);
  // Same light samples, no blocked ambient direction: identical pixels.
  ASSERT_EQ(open.pixels.size(), shadowed.pixels.size());
  for (std::size_t i = 0; i < open.pixels.size(); ++i) ASSERT_EQ(open.pixels[i], shadowed.pixels[i]);
}

TEST(ShadowAmbient, DarkerUnderAnOccluderAndMatchesTheShadowedConstantSky) {
  // No lights: the image is the residual alone. A constant sky c shadowed by the blocker; the
  // blocker's top face sees the whole upper hemisphere, so it keeps pi c exactly.
  LightSet ls = capAndAmbient(0.4f);
  ls.lights.clear();
  ReferenceOptions o = options(256);
  const Image open = referenceLights(ground(true), camera(), ls, Environment{}, o);
  o.shadowAmbient = true;
  const ReferenceImage shadowed =
      referenceLightsWithNoise(ground(true), camera(), ls, Environment{}, o);
  EXPECT_LT(meanRgb(shadowed.image), meanRgb(open) * 0.995);
  int darker = 0;
  for (std::size_t i = 0; i < open.pixels.size(); i += 4) {
    EXPECT_LE(shadowed.image.pixels[i], open.pixels[i] + 1e-6f);
    darker += shadowed.image.pixels[i] < 0.9f * open.pixels[i];
  }
  EXPECT_GT(darker, 10);
  EXPECT_GT(shadowed.relativeNoise, 0.0);
  // Unoccluded pixels keep albedo / pi * pi c = 0.5 * 0.4 exactly.
  int exact = 0;
  for (std::size_t i = 0; i < open.pixels.size(); i += 4) exact += shadowed.image.pixels[i] == open.pixels[i];
  EXPECT_GT(exact, 10);
  EXPECT_NEAR(open.pixels[open.pixels.size() - 4], 0.5 * 0.4, 1e-4);  // the nearest ground
}

// ---------------------------------------------------------------------------------------------
// The error budget.

struct BudgetFixture : testing::Test {
  Scene scene = ground(true);
  Environment env = constantEnv(0.5f);
  LightSet lights = capAndAmbient(0.05f);
  EvaluateOptions opt;
  void SetUp() override {
    opt.truth = options(64);
    opt.cacheDir = (fs::path(testing::TempDir()) / ("penumbra_evaluate_cache_" + std::to_string(::getpid()))).string();
    fs::remove_all(opt.cacheDir);
  }
  // A stand-in frame: the light-set truth made 10% darker on every other row, so the technique
  // error is known and not noise.
  static Image frameFrom(const Image& l) {
    Image f = l;
    for (int y = 0; y < f.height; y += 2)
      for (int x = 0; x < f.width; ++x)
        for (int k = 0; k < 3; ++k) f.at(x, y, k) *= 0.9f;
    return f;
  }
};

TEST_F(BudgetFixture, PartsAddUpAndMatchRecomputation) {
  const EvaluateTruths t = evaluateTruths(scene, camera(), lights, env, opt);
  const Image frame = frameFrom(t.lights.image);
  const ErrorBudget b = errorBudget(frame, t, opt);
  const double T = b.total.relativeRmse, F = b.floor.relativeRmse, Q = b.technique.relativeRmse;
  EXPECT_NEAR(T * T, F * F + Q * Q + 2 * b.cross, 1e-9 * T * T);
  const double Tp = b.total.relativeRmsePenumbra, Fp = b.floor.relativeRmsePenumbra,
               Qp = b.technique.relativeRmsePenumbra;
  ASSERT_GT(b.penumbraPixels, 0u);
  EXPECT_NEAR(Tp * Tp, Fp * Fp + Qp * Qp + 2 * b.crossPenumbra, 1e-9 * Tp * Tp);
  // Total and floor are compareImages' relative RMSE against the environment truth; technique
  // divides the RMSE against the light-set truth by the environment truth's mean.
  const ImageMetrics mt = compareImages(frame, t.environment.image);
  EXPECT_NEAR(T, mt.relativeRmse, 1e-9 * T);
  EXPECT_NEAR(F, compareImages(t.lights.image, t.environment.image).relativeRmse, 1e-9 * F);
  const double meanG = mt.rmse / mt.relativeRmse;
  EXPECT_NEAR(b.truthMean, meanG, 1e-9 * meanG);
  EXPECT_NEAR(Q, compareImages(frame, t.lights.image).rmse / meanG, 1e-9 * Q);
  // The frame is darker than the light-set truth by 5% on average: the bias says so, also over
  // the pixels where the light-set truth is lit (every other row is darkened, lit or not).
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(b.biasTechnique[std::size_t(k)], -0.05, 0.01);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(b.biasTechniqueLit[std::size_t(k)], -0.05, 0.01);
  EXPECT_GT(b.litPixels, 0u);
  EXPECT_LE(b.litPixels + b.penumbraPixels, b.geometryPixels);
  // Noise: the environment truth's for total, the light-set truth's for technique.
  EXPECT_NEAR(b.total.noise, t.environment.relativeNoise, 1e-9);
  EXPECT_NEAR(b.technique.noise * b.truthMean,
              t.lights.relativeNoise * meanRgb(t.lights.image), 1e-6 * b.truthMean);
  EXPECT_TRUE(b.technique.relativeRmse > 0.0 && !b.technique.belowNoise());
  for (const BudgetLine* l : {&b.total, &b.floor, &b.technique, &b.ambient}) {
    EXPECT_TRUE(std::isfinite(l->flip));
    EXPECT_TRUE(std::isfinite(l->flipPenumbra));
  }
  EXPECT_GT(b.ambient.relativeRmse, 0.0);  // the blocker shadows the residual
  const std::string json = toJson(b);
  for (const char* key : {"\"total\"", "\"floor\"", "\"technique\"", "\"ambient\"", "\"cross\"",
                          "\"truth_noise\"", "\"bias_total\"", "\"flip\"", "\"penumbra_pixels\""})
    EXPECT_NE(json.find(key), std::string::npos) << key;
  EXPECT_NE(toText(b).find("technique"), std::string::npos);
}

TEST_F(BudgetFixture, TruthsComeBackFromTheCacheUnchanged) {
  const EvaluateTruths a = evaluateTruths(scene, camera(), lights, env, opt);
  for (bool c : a.fromCache) EXPECT_FALSE(c);
  const EvaluateTruths b = evaluateTruths(scene, camera(), lights, env, opt);
  for (bool c : b.fromCache) EXPECT_TRUE(c);
  EXPECT_EQ(a.environment.image.pixels, b.environment.image.pixels);
  EXPECT_EQ(a.lights.halfA.pixels, b.lights.halfA.pixels);
  EXPECT_EQ(a.lightsShadowedAmbient.halfB.pixels, b.lightsShadowedAmbient.halfB.pixels);
  EXPECT_EQ(a.lights.visibility.pixels, b.lights.visibility.pixels);
  EXPECT_DOUBLE_EQ(a.lights.relativeNoise, b.lights.relativeNoise);
  // Another seed is another key.
  opt.truth.seed = 99;
  const EvaluateTruths c = evaluateTruths(scene, camera(), lights, env, opt);
  for (bool f : c.fromCache) EXPECT_FALSE(f);
  EXPECT_NE(truthKey(scene, camera(), env, &lights, opt.truth),
            truthKey(scene, camera(), env, nullptr, opt.truth));
}

TEST_F(BudgetFixture, HeatMapsAreWritten) {
  const EvaluateTruths t = evaluateTruths(scene, camera(), lights, env, opt);
  const Image frame = frameFrom(t.lights.image);
  const ErrorBudget b = errorBudget(frame, t, opt);
  const std::string dir = opt.cacheDir + "_maps";
  fs::create_directories(dir);
  double scale = 0;
  const auto written = writeHeatMaps(b, frame, t, dir, &scale);
  EXPECT_EQ(written.size(), 5u);
  EXPECT_GT(scale, 0.0);
  for (const std::string& p : written) {
    const Image im = readImage(p);
    EXPECT_EQ(im.width, 32) << p;
    EXPECT_GT(im.height, 18) << p;  // the scale bar under the image
  }
}

TEST_F(BudgetFixture, UncreatableCacheIsBadInputNamingTheField) {
  const fs::path file = fs::path(testing::TempDir()) / ("penumbra_evaluate_file_" + std::to_string(::getpid()));
  { std::ofstream(file.string()) << "x"; }
  opt.cacheDir = (file / "sub").string();
  try {
    evaluateTruths(scene, camera(), lights, env, opt);
    FAIL() << "expected Error(BadInput)";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::BadInput);
    EXPECT_NE(std::string(e.what()).find("EvaluateOptions.cacheDir"), std::string::npos) << e.what();
  }
}

}  // namespace
