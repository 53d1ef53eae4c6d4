// `auto` (src/shadows/auto.cpp): the per-light choice rule on hand-made lights, its inputs (caster
// distance, pixel footprint) on synthetic buffers, the composed visibility against each chosen
// technique run alone, the planar analytic profile, and the option checks.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "common.hpp"
#include "shadows/auto.hpp"
#include "shadows/shadow_pass.hpp"
#include "support/planar_penumbra.hpp"

using namespace penumbra;
using namespace penumbra::test;
using detail::AutoLight;
using detail::CasterSample;
using detail::chooseShadowTechniques;

namespace {

// A light of the given power whose penumbra is `texels` map texels wide (texel 0.01 world units,
// caster distance 1): tan(alpha) = texels * 0.01 / 2.
AutoLight lightWithPenumbra(double power, double texels) {
  AutoLight l;
  l.power = power;
  l.texel = 0.01;
  l.distance = 1.0;
  l.tanAlpha = texels * l.texel / 2;
  return l;
}

// Each light's choice from the frame's statistics ("auto/light_<i>").
std::vector<ShadowTechnique> choices(const Frame& f, int lights) {
  std::vector<ShadowTechnique> out(lights, ShadowTechnique::None);
  for (const auto& [name, v] : f.stats)
    for (int l = 0; l < lights; ++l)
      if (name == "auto/light_" + std::to_string(l)) out[l] = ShadowTechnique(int(v));
  return out;
}

double stat(const Frame& f, const std::string& name) {
  for (const auto& [n, v] : f.stats)
    if (n == name) return v;
  return -1;
}

}  // namespace

TEST(AutoRule, TinyPenumbraGetsHardShadows) {
  AutoOptions o;
  o.exactShare = 0;  // these lights are large shares on small caps: that rule is PeakLights's
  o.exactLights = 0;
  // 0.5 texel of penumbra, pixel finer than the texel: the texel decides
  const auto t = chooseShadowTechniques({lightWithPenumbra(1, 0.5)}, 0.001, o);
  EXPECT_EQ(t[0], ShadowTechnique::Hard);
  // 2 texels of penumbra, but a pixel 4 texels wide: the screen cannot show it
  EXPECT_EQ(chooseShadowTechniques({lightWithPenumbra(1, 2)}, 0.04, o)[0], ShadowTechnique::Hard);
  // a light that shadows nothing on screen (distance 0) gets the cheapest technique
  AutoLight none = lightWithPenumbra(1, 20);
  none.distance = 0;
  EXPECT_EQ(chooseShadowTechniques({none}, 0.001, o)[0], ShadowTechnique::Hard);
}

TEST(AutoRule, FilteredByTheFilterWidthInTexels) {
  AutoOptions o;
  o.exactShare = 0;  // these lights are large shares on small caps: that rule is PeakLights's
  o.exactLights = 0;
  o.pcssTexels = 8;
  const std::vector<AutoLight> lights = {lightWithPenumbra(1, 3), lightWithPenumbra(1, 7.9),
                                         lightWithPenumbra(1, 8.1), lightWithPenumbra(1, 40)};
  auto t = chooseShadowTechniques(lights, 0.001, o, 27.0f);
  EXPECT_EQ(t[0], ShadowTechnique::PCSS);
  EXPECT_EQ(t[1], ShadowTechnique::PCSS);
  EXPECT_EQ(t[2], ShadowTechnique::MSSM4);
  EXPECT_EQ(t[3], ShadowTechnique::MSSM4);
  // the filter PCSS pays for is clamped: at pcssTexels equal to the clamp, every width is PCSS
  o.pcssTexels = 27;
  t = chooseShadowTechniques(lights, 0.001, o, 27.0f);
  EXPECT_EQ(std::count(t.begin(), t.end(), ShadowTechnique::PCSS), 4);
  // a lower clamp, the same threshold: the 40-texel penumbra costs PCSS 20 texels of filter
  o.pcssTexels = 20;
  t = chooseShadowTechniques(lights, 0.001, o, 20.0f);
  EXPECT_EQ(t[3], ShadowTechnique::PCSS);
  t = chooseShadowTechniques(lights, 0.001, o, 21.0f);
  EXPECT_EQ(t[3], ShadowTechnique::MSSM4);
}

// Lights that graze their receivers (the median receiver under pcssMinElevationDeg) keep MSSM4
// whatever their filter width: a light whose cap crosses the receivers' plane does worse with
// PCSS (bench/results/accuracy.md, "PCSS under grazing light").
TEST(AutoRule, GrazingLightsKeepMSSM4) {
  AutoOptions o;
  o.exactShare = 0;  // these lights are large shares on small caps: that rule is PeakLights's
  o.pcssTexels = 16;
  EXPECT_EQ(o.pcssMinElevationDeg, 8.0f);  // the default
  std::vector<AutoLight> lights(4, lightWithPenumbra(1, 6));
  lights[0].receiverSin = 1;  // straight above its receivers (and the value when none face it)
  lights[1].receiverSin = std::sin(8.1 * M_PI / 180);
  lights[2].receiverSin = std::sin(7.9 * M_PI / 180);
  lights[3].receiverSin = 0.01;
  using T = std::vector<ShadowTechnique>;
  constexpr ShadowTechnique M = ShadowTechnique::MSSM4, P = ShadowTechnique::PCSS;
  EXPECT_EQ(chooseShadowTechniques(lights, 0.001, o), (T{P, P, M, M}));
  o.pcssMinElevationDeg = 0;  // off: the width alone decides
  EXPECT_EQ(chooseShadowTechniques(lights, 0.001, o), (T{P, P, P, P}));
  o.pcssMinElevationDeg = 90;  // only a light straight above its receivers
  EXPECT_EQ(chooseShadowTechniques(lights, 0.001, o), (T{P, M, M, M}));
  o.pcssTexels = 0;  // no PCSS at all, as before the cut
  EXPECT_EQ(chooseShadowTechniques(lights, 0.001, o), (T{M, M, M, M}));
}

TEST(AutoRule, ExactGoesToTheBrightestWithinBudget) {
  // powers 1, 3 (brightest, narrow), 2, 0.5 (wide)
  const std::vector<AutoLight> lights = {lightWithPenumbra(1, 10), lightWithPenumbra(3, 2),
                                         lightWithPenumbra(2, 10), lightWithPenumbra(0.5, 40)};
  AutoOptions o;
  o.exactShare = 0;  // these lights are large shares on small caps: that rule is PeakLights's
  o.exactLights = 1;
  auto t = chooseShadowTechniques(lights, 0.001, o);
  EXPECT_EQ(t[1], ShadowTechnique::Bitmask);
  EXPECT_EQ(std::count(t.begin(), t.end(), ShadowTechnique::Bitmask), 1);
  o.exactLights = 2;
  t = chooseShadowTechniques(lights, 0.001, o);
  EXPECT_EQ(t[1], ShadowTechnique::Bitmask);
  EXPECT_EQ(t[2], ShadowTechnique::Bitmask);
  EXPECT_NE(t[0], ShadowTechnique::Bitmask);
  EXPECT_NE(t[3], ShadowTechnique::Bitmask);
  // a budget past the count: every light exact
  o.exactLights = 100;
  t = chooseShadowTechniques(lights, 0.001, o);
  EXPECT_EQ(std::count(t.begin(), t.end(), ShadowTechnique::Bitmask), 4);
  // budget 0, or a frame without triangles: none
  o.exactLights = 0;
  t = chooseShadowTechniques(lights, 0.001, o);
  EXPECT_EQ(std::count(t.begin(), t.end(), ShadowTechnique::Bitmask), 0);
  o.exactLights = 4;
  t = chooseShadowTechniques(lights, 0.001, o, 27.0f, false);
  EXPECT_EQ(std::count(t.begin(), t.end(), ShadowTechnique::Bitmask), 0);
}

TEST(AutoRule, FilteredBudgetGoesToTheBrightestTheRestHard) {
  using T = std::vector<ShadowTechnique>;
  constexpr ShadowTechnique H = ShadowTechnique::Hard, M = ShadowTechnique::MSSM4,
                            P = ShadowTechnique::PCSS, X = ShadowTechnique::Bitmask;
  // powers 1, 3, 2, 0.5, 4 (brightest, its penumbra under a texel: hard whatever the budget)
  const std::vector<AutoLight> lights = {lightWithPenumbra(1, 10), lightWithPenumbra(3, 10),
                                         lightWithPenumbra(2, 40), lightWithPenumbra(0.5, 40),
                                         lightWithPenumbra(4, 0.5)};
  AutoOptions o;
  // the defaults: no exact light by count, 24 filtered (more than these five: every resolved one);
  // the compact bright sources' rule (PeakLights.AutoMakesCompactBrightLightsExact) is off here,
  // since every light of these five is a large share on a small cap
  EXPECT_EQ(o.exactLights, 0);
  EXPECT_EQ(o.filteredLights, 24);
  EXPECT_EQ(o.exactShare, 0.1f);
  EXPECT_EQ(o.exactHalfAngleDeg, 5.0f);
  o.exactShare = 0;
  EXPECT_EQ(chooseShadowTechniques(lights, 0.001, o), (T{M, M, M, M, H}));
  // no limit: the same
  o.filteredLights = -1;
  EXPECT_EQ(chooseShadowTechniques(lights, 0.001, o), (T{M, M, M, M, H}));
  // 2: the two brightest of the resolved ones (powers 3 and 2); the unresolved light 4 does not
  // take a place in the budget
  o.filteredLights = 2;
  EXPECT_EQ(chooseShadowTechniques(lights, 0.001, o), (T{H, M, M, H, H}));
  // the budget counts PCSS lights too (light 1's 10-texel filter is under 20)
  o.pcssTexels = 20;
  EXPECT_EQ(chooseShadowTechniques(lights, 0.001, o, 27.0f), (T{H, P, M, H, H}));
  o.pcssTexels = 0;
  // exact lights are outside the budget: the brightest (light 4) exact, the next two filtered
  o.exactLights = 1;
  EXPECT_EQ(chooseShadowTechniques(lights, 0.001, o), (T{H, M, M, H, X}));
  // 0: none filtered
  o.exactLights = 0;
  o.filteredLights = 0;
  EXPECT_EQ(chooseShadowTechniques(lights, 0.001, o), (T{H, H, H, H, H}));
}

// Both budgets go to the lights that bring the most irradiance to the surfaces on screen (power
// times the mean of max(0, n.w) over the camera's pixels), not the most power: a bright light
// under the ground's horizon, which lights only what faces it, ranks after dimmer ones above.
TEST(AutoRule, BudgetsGoToTheBrightestOnScreen) {
  using T = std::vector<ShadowTechnique>;
  constexpr ShadowTechnique H = ShadowTechnique::Hard, M = ShadowTechnique::MSSM4,
                            X = ShadowTechnique::Bitmask;
  // powers 3, 1, 2; on screen 3 x 0.05 = 0.15, 1 x 0.6 = 0.6, 2 x 0.5 = 1
  std::vector<AutoLight> lights = {lightWithPenumbra(3, 10), lightWithPenumbra(1, 10),
                                   lightWithPenumbra(2, 10)};
  lights[0].screenCos = 0.05;
  lights[1].screenCos = 0.6;
  lights[2].screenCos = 0.5;
  EXPECT_DOUBLE_EQ(detail::autoScreenIrradiance(lights[0]), 0.15);
  AutoOptions o;
  o.exactShare = 0;
  o.filteredLights = 1;
  EXPECT_EQ(chooseShadowTechniques(lights, 0.001, o), (T{H, H, M}));
  o.filteredLights = 2;
  EXPECT_EQ(chooseShadowTechniques(lights, 0.001, o), (T{H, M, M}));
  // one exact and one filtered: the first on screen exact, the second filtered
  o.exactLights = 1;
  o.filteredLights = 1;
  EXPECT_EQ(chooseShadowTechniques(lights, 0.001, o), (T{H, M, X}));
  // unknown shares (1, the default): power alone, the brightest first
  for (AutoLight& l : lights) l.screenCos = 1;
  EXPECT_EQ(chooseShadowTechniques(lights, 0.001, o), (T{X, H, M}));
}

TEST(AutoRule, BadOptionsNameTheField) {
  const std::vector<std::pair<AutoOptions, std::string>> bad = [] {
    std::vector<std::pair<AutoOptions, std::string>> v;
    AutoOptions o;
    o.exactLights = -1;
    v.push_back({o, "RenderOptions.autoChoice.exactLights"});
    o = AutoOptions{};
    o.hardPixels = std::nanf("");
    v.push_back({o, "RenderOptions.autoChoice.hardPixels"});
    o = AutoOptions{};
    o.pcssTexels = -2;
    v.push_back({o, "RenderOptions.autoChoice.pcssTexels"});
    o = AutoOptions{};
    o.filteredLights = -2;
    v.push_back({o, "RenderOptions.autoChoice.filteredLights"});
    o.filteredLights = 4097;
    v.push_back({o, "RenderOptions.autoChoice.filteredLights"});
    o = AutoOptions{};
    o.pcssMinElevationDeg = -1;
    v.push_back({o, "RenderOptions.autoChoice.pcssMinElevationDeg"});
    o.pcssMinElevationDeg = std::nanf("");
    v.push_back({o, "RenderOptions.autoChoice.pcssMinElevationDeg"});
    o.pcssMinElevationDeg = 90.5f;
    v.push_back({o, "RenderOptions.autoChoice.pcssMinElevationDeg"});
    return v;
  }();
  for (const auto& [o, field] : bad) {
    try {
      chooseShadowTechniques({lightWithPenumbra(1, 1)}, 0.001, o);
      ADD_FAILURE() << field << ": no error";
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::BadInput);
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  }
  // and through a frame: the pass checks its options before any work
  PlanarPenumbra s;
  RenderOptions ro;
  ro.shadows = ShadowTechnique::Auto;
  ro.autoChoice.exactLights = -3;
  try {
    renderPlanar(s, ro);
    ADD_FAILURE() << "a frame with exactLights -3 rendered";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("RenderOptions.autoChoice.exactLights"), std::string::npos)
        << e.what();
  }
}

// A light straight above the plane y = 0, its map 1 world unit below the near plane everywhere:
// every receiver at light-space depth 3 has a gap of 2; those nearer than the bias and two
// texels count as their own blocker and are left out.
TEST(AutoInputs, CasterDistanceAndPixelFootprint) {
  Bounds b;
  b.lo = {-2, 0, -2};
  b.hi = {2, 4, 2};
  const int S = 64;
  const pb_light L = detail::lightFrame({0, 1, 0}, 0.99f, {1, 1, 1}, b);
  std::vector<cl_uint> map(std::size_t(S) * S);
  const float one = 1.0f;
  std::memcpy(&map[0], &one, 4);
  for (auto& t : map) t = map[0];
  const int W = 10, H = 4;
  std::vector<cl_float4> gpos(W * H), gnrm(W * H);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      // world point at light-space depth 3 (the near plane is at y = L.origin.y), or 1.001 for
      // the first column (no gap beyond the bias), 0.25 world apart along x
      const float depth = x == 0 ? 1.001f : 3.0f;
      gpos[y * W + x] = {{-1.0f + 0.25f * x, L.origin[1] - depth, 0.1f * y, 1.0f}};
      gnrm[y * W + x] = {{0, 1, 0, 0}};
    }
  const double d = detail::casterDistance(L, map.data(), S, gpos, gnrm, 0.002f);
  EXPECT_NEAR(d, 2.0, 1e-4);
  // the two-step form the pass uses: every 3rd pixel that sees geometry, packed in pixel order
  // (pixels 0, 3, 6, ... of 40, the 4th of those with no geometry), and its median the same
  gpos[9].s[3] = 0;
  const auto samples = detail::casterSamples(gpos, gnrm, 3);
  ASSERT_EQ(samples.size(), 13u);
  EXPECT_EQ(samples[3].position[0], gpos[12].s[0]);
  EXPECT_EQ(samples[3].position[2], gpos[12].s[2]);
  EXPECT_EQ(samples[12].position[1], gpos[39].s[1]);
  std::vector<double> scratch(5, -1.0);
  EXPECT_EQ(detail::casterDistance(L, map.data(), S, samples, 0.002f, scratch),
            detail::casterDistance(L, map.data(), S, gpos, gnrm, 0.002f, 3));
  gpos[9].s[3] = 1;
  // the receivers' height: the median n.w over the samples facing the light. The light is along
  // +y; tilt the normals of a third of the samples away by 80 degrees (n.w = cos 80), turn three
  // away from it (left out), keep the rest up (n.w = 1)
  std::vector<CasterSample> tilted = samples;
  const float c80 = float(std::cos(80 * M_PI / 180)), s80 = float(std::sin(80 * M_PI / 180));
  for (std::size_t i = 0; i < tilted.size(); ++i) {
    float* n = tilted[i].normal;
    if (i % 3 == 0) n[0] = s80, n[1] = c80, n[2] = 0;
    if (i == 1 || i == 2 || i == 4) n[0] = 0, n[1] = -1, n[2] = 0;
  }
  std::vector<double> sines;
  // 10 facing: 5 tilted (0, 3, 6, 9, 12), 5 up; the upper median is 1
  detail::CasterStats cs = detail::casterStats(L, map.data(), S, tilted, 0.002f, scratch, &sines);
  EXPECT_FLOAT_EQ(float(cs.receiverSin), 1.0f);
  tilted[5].normal[0] = s80, tilted[5].normal[1] = c80;  // 6 tilted of 10: the median tilts
  cs = detail::casterStats(L, map.data(), S, tilted, 0.002f, scratch, &sines);
  EXPECT_NEAR(cs.receiverSin, c80, 1e-6);
  // the light's share on screen: the mean of max(0, n.w) over all 13 samples, those facing away
  // counted as 0 (6 tilted, 4 up, 3 away), whether or not the sines are asked for
  EXPECT_NEAR(cs.screenCos, (6 * c80 + 4) / 13.0, 1e-6);
  EXPECT_EQ(detail::casterStats(L, map.data(), S, tilted, 0.002f, scratch, nullptr).screenCos,
            cs.screenCos);
  // not asked for: 1, the distance the same
  EXPECT_EQ(detail::casterStats(L, map.data(), S, tilted, 0.002f, scratch, nullptr).receiverSin,
            1.0);
  EXPECT_EQ(cs.distance, detail::casterDistance(L, map.data(), S, tilted, 0.002f, scratch));
  // facing away from the light: nothing is lit, so nothing is shadowed, and no receiver faces it
  std::vector<cl_float4> down(gnrm.size(), {{0, -1, 0, 0}});
  EXPECT_EQ(detail::casterDistance(L, map.data(), S, gpos, down, 0.002f), 0.0);
  for (CasterSample& t : tilted) t.normal[1] = -1, t.normal[0] = 0;
  cs = detail::casterStats(L, map.data(), S, tilted, 0.002f, scratch, &sines);
  EXPECT_EQ(cs.receiverSin, 1.0);
  EXPECT_EQ(cs.distance, 0.0);
  EXPECT_EQ(cs.screenCos, 0.0);
  // no samples (nothing on screen): unknown, 1, so the rule ranks by power alone
  EXPECT_EQ(detail::casterStats(L, map.data(), S, {}, 0.002f, scratch, &sines).screenCos, 1.0);
  EXPECT_NEAR(detail::pixelFootprint(gpos, W, H), 0.25, 1e-5);
  // no geometry: footprint unknown
  for (auto& p : gpos) p.s[3] = 0;
  EXPECT_EQ(detail::pixelFootprint(gpos, W, H), 0.0);
}

// The pass measures each light's share on screen (AutoInputs.CasterDistanceAndPixelFootprint) and
// the rule ranks by it: on the built-in scene, a light 2 degrees above the ground with three times
// the power of one 45 degrees up brings the ground little (n.w = sin 2 degrees there), so a
// budget of one filtered light goes to the high one and the grazing one gets hard shadows (ranked
// by power alone, the other way round).
TEST(AutoFrame, FilteredBudgetGoesToTheLightBrightestOnScreen) {
  Scene scene = builtinScene();
  Environment env = builtinEnvironment(16);
  LightSet set;
  for (float elev : {2.0f, 45.0f}) {
    AreaLight light;
    const float e = elev * float(M_PI) / 180;
    light.direction = {0.6f * std::cos(e), std::sin(e), 0.8f * std::cos(e)};
    light.cosAlpha = float(std::cos(10 * M_PI / 180));
    const float rad = elev < 10 ? 3.0f : 1.0f;
    light.radiance = {rad, rad, rad};
    set.lights.push_back(light);
  }
  RenderOptions ro;
  ro.width = 96;
  ro.height = 54;
  ro.shadowMapSize = 128;
  ro.shadows = ShadowTechnique::Auto;
  ro.autoChoice.exactShare = 0;
  ro.autoChoice.filteredLights = 1;
  Renderer r(ctx());
  Frame f = r.render(scene, frameCamera(scene, float(ro.width) / ro.height), set, env, ro);
  EXPECT_EQ(choices(f, 2), (std::vector<ShadowTechnique>{ShadowTechnique::Hard,
                                                         ShadowTechnique::MSSM4}));
}

// The composed visibility: each light's row equals that light's row from its chosen technique run
// alone over every light (the techniques treat lights independently), on the built-in scene with
// eight lights of several sizes; and when every light gets the same choice, the whole buffer
// equals that technique's.
TEST(AutoFrame, ComposedRowsEqualEachTechniqueAlone) {
  Scene scene = builtinScene();
  Environment env = builtinEnvironment(64);
  MedianCutOptions mc;
  mc.lights = 8;
  LightSet lights = extractMedianCut(ctx(), env, mc);
  const int nl = int(lights.lights.size());
  ASSERT_EQ(nl, 8);
  RenderOptions ro;
  ro.width = 96;
  ro.height = 54;
  ro.shadowMapSize = 128;
  ro.bitmask.lightSamples = 128;
  ro.shadows = ShadowTechnique::Auto;
  ro.autoChoice.exactLights = 1;
  ro.autoChoice.pcssTexels = 20;  // narrow penumbrae PCSS, wide ones MSSM4
  // the lights narrow enough for PCSS here graze their receivers (the median under 8 degrees),
  // which the elevation cut gives MSSM4 (AutoRule.GrazingLightsKeepMSSM4): off here, for a mix
  ro.autoChoice.pcssMinElevationDeg = 0;
  // Lights on the horizon take other lights' visibility at a pixel by design (README, "Lights on
  // the horizon"; tests/test_horizon.cpp), so a row there depends on the other rows' techniques:
  // off here, where each row is compared with its technique alone.
  ro.shadow.horizonVisibility = false;
  Camera cam = frameCamera(scene, float(ro.width) / ro.height);
  Renderer r(ctx());
  Frame f = r.render(scene, cam, lights, env, ro);
  const std::vector<float> composed = r.lastVisibility();
  const std::vector<ShadowTechnique> chosen = choices(f, nl);
  const std::set<ShadowTechnique> kinds(chosen.begin(), chosen.end());
  std::printf("[ penumbra ] auto on 8 lights:");
  for (ShadowTechnique t : chosen) std::printf(" %s", toString(t));
  std::printf("\n");
  ASSERT_GE(kinds.size(), 3u) << "the scene should give a mixed choice";
  EXPECT_EQ(stat(f, "auto/lights_exact"), 1);
  EXPECT_EQ(std::count(chosen.begin(), chosen.end(), ShadowTechnique::Bitmask), 1);
  double counted = 0;
  for (const char* c : {"auto/lights_hard", "auto/lights_pcss", "auto/lights_mssm4",
                        "auto/lights_exact"})
    counted += stat(f, c);
  EXPECT_EQ(counted, nl);
  const std::size_t px = std::size_t(ro.width) * ro.height;
  for (ShadowTechnique t : kinds) {
    RenderOptions alone = ro;
    alone.shadows = t;
    r.render(scene, cam, lights, env, alone);
    const std::vector<float> v = r.lastVisibility();
    for (int l = 0; l < nl; ++l) {
      if (chosen[l] != t) continue;
      int differ = 0;
      for (std::size_t p = 0; p < px; ++p)
        differ += std::fabs(v[l * px + p] - composed[l * px + p]) > 1e-6f;
      EXPECT_EQ(differ, 0) << "light " << l << " (" << toString(t) << ")";
    }
  }
  // every light hard (a hard threshold no penumbra reaches, no exact budget, no compact-source
  // rule: the map's sun is one light of its own here): the whole buffer
  ro.autoChoice.exactLights = 0;
  ro.autoChoice.exactShare = 0;
  ro.autoChoice.hardPixels = 1e9f;
  Frame all = r.render(scene, cam, lights, env, ro);
  EXPECT_EQ(stat(all, "auto/lights_hard"), nl);
  const std::vector<float> autoHard = r.lastVisibility();
  RenderOptions hard = ro;
  hard.shadows = ShadowTechnique::Hard;
  r.render(scene, cam, lights, env, hard);
  EXPECT_EQ(r.lastVisibility(), autoHard);
}

// The planar penumbra (tests/support): whichever technique the rule picks for the one light, the
// profile stays within the bound its own planar test holds it to: PCSS and MSSM4 (issue 2's 0.05;
// PCSS holds 0.035), the bitmask within the same 0.05.
TEST(AutoFrame, PlanarPenumbraWithinTheAnalyticBound) {
  struct Case {
    double alphaDeg;
    int exact;
    float pcssTexels;
    ShadowTechnique expect;
  };
  // 5 degrees at height 1: ~7.5 texels of penumbra at 256^2 over 6 world units; 15 degrees: ~23
  // texels (MSSM4 past a PCSS threshold of 16); the budget of one exact light takes the light
  for (const Case& c : {Case{5, 0, 27, ShadowTechnique::PCSS},
                        Case{15, 0, 16, ShadowTechnique::MSSM4},
                        Case{5, 1, 27, ShadowTechnique::Bitmask}}) {
    PlanarPenumbra s;
    s.blockers = {{0.0, 1.0}};
    s.light = capLightAbove(c.alphaDeg);
    RenderOptions ro;
    ro.shadows = ShadowTechnique::Auto;
    ro.autoChoice.exactLights = c.exact;
    ro.autoChoice.exactShare = 0;  // the one light is all the power: that rule is PeakLights's
    ro.autoChoice.pcssTexels = c.pcssTexels;
    ro.bitmask.lightSamples = 256;
    PlanarFrame f = renderPlanar(s, ro);
    ProfileComparison e =
        compareWithProfile(f.receivers, halfPlaneProfile(1.0, c.alphaDeg * M_PI / 180));
    std::printf("[ penumbra ] auto planar alpha %.0f deg, exact budget %d: max |V - V_analytic| "
                "= %.4f over %d pixels\n",
                c.alphaDeg, c.exact, e.maxError, e.samples);
    EXPECT_GT(e.penumbraSamples, 100);
    EXPECT_LT(e.maxError, 0.05) << c.alphaDeg << " deg";
    // which technique it took: the light's frame is its whole visibility
    Renderer r(ctx());
    RenderOptions again = ro;
    again.width = 64;
    again.height = 48;
    LightSet one;
    one.lights = {s.light};
    Frame fr = r.render(s.scene(), s.camera(), one, builtinEnvironment(16), again);
    EXPECT_EQ(choices(fr, 1)[0], c.expect) << c.alphaDeg << " deg";
  }
}
