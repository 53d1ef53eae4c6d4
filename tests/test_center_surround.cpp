// Center-surround light extraction (Arbree et al. §3): the device's filter responses against a
// brute-force loop on the sphere, synthetic maps with known discs, the 2% stopping rule, the lights
// alone against the map in their caps (independent quadrature, negative controls), the issue's
// rotation / determinism requirements, option validation and the oclgrind run of every kernel.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <vector>

#include "environment/center_surround.hpp"
#include "common.hpp"
#include "support/extraction_checks.hpp"

namespace penumbra {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

Environment makeEnv(int w, int h) {
  Environment env;
  env.source = "synthetic";
  env.equirect = Image(w, h, 3, 0.0f);
  return env;
}

void texelDir(int s, int t, int w, int h, double d[3]) {
  double th = (t + 0.5) * kPi / h, ph = ((s + 0.5) / w - 0.5) * 2 * kPi;
  d[0] = std::sin(th) * std::sin(ph);
  d[1] = std::cos(th);
  d[2] = -std::sin(th) * std::cos(ph);
}

std::array<float, 3> dirOf(double thetaDeg, double phiDeg) {
  double th = thetaDeg * kDeg, ph = phiDeg * kDeg;
  return {float(std::sin(th) * std::sin(ph)), float(std::cos(th)),
          float(-std::sin(th) * std::cos(ph))};
}

double angleDeg(const std::array<float, 3>& a, const std::array<float, 3>& b) {
  double d = double(a[0]) * b[0] + double(a[1]) * b[1] + double(a[2]) * b[2];
  return std::acos(std::clamp(d, -1.0, 1.0)) / kDeg;
}

// Adds a grey disc of angular radius r (radians) and radiance L around unit direction c,
// antialiased with 4x4 sub-samples per texel so its energy is L * 2 pi (1 - cos r) to well under
// 1% at the resolutions used here.
void addDisc(Environment& env, const std::array<float, 3>& c, double r, float L) {
  Image& img = env.equirect;
  const int ss = 4;
  const double cr = std::cos(r);
  for (int t = 0; t < img.height; ++t)
    for (int s = 0; s < img.width; ++s) {
      int in = 0;
      for (int j = 0; j < ss; ++j)
        for (int i = 0; i < ss; ++i) {
          float x, y, z;
          pb_equirect_dir(s + (i + 0.5f) / ss, t + (j + 0.5f) / ss, float(img.width),
                          float(img.height), &x, &y, &z);
          in += double(x) * c[0] + double(y) * c[1] + double(z) * c[2] >= cr;
        }
      if (!in) continue;
      float cover = float(in) / (ss * ss);
      for (int k = 0; k < 3; ++k) img.at(s, t, k) = (1 - cover) * img.at(s, t, k) + cover * L;
    }
}

// Outer diameter (degrees) of filter size k of the default bank: 4.5 * 10^(k/19).
double outerDiamDeg(const CenterSurroundOptions& o, int k) {
  return o.minDeg * std::pow(double(o.maxDeg) / o.minDeg, double(k) / (o.sizes - 1));
}

// A map with pseudo-random texels (deterministic LCG) and hot texels on both poles and on both
// sides of the seam phi = +-pi, so that the caps there wrap and cover whole rows.
Environment awkwardMap(int w, int h) {
  Environment env = makeEnv(w, h);
  std::uint32_t state = 12345;
  auto rnd = [&] {
    state = state * 1664525u + 1013904223u;
    return float(state >> 8) / float(1 << 24);
  };
  for (int t = 0; t < h; ++t)
    for (int s = 0; s < w; ++s) {
      float v = 0.05f + rnd() * rnd();
      for (int c = 0; c < 3; ++c) env.equirect.at(s, t, c) = v * (0.6f + 0.4f * c * rnd());
    }
  const int hot[][2] = {{0, 0}, {w / 3, 0}, {0, h - 1}, {w - 1, h - 1}, {w - 1, h / 2},
                        {0, h / 2 + 1}, {w / 2, h / 3}};
  float L = 20;
  for (auto& p : hot) {
    for (int c = 0; c < 3; ++c) env.equirect.at(p[0], p[1], c) = L;
    L *= 0.8f;
  }
  return env;
}

// Brute force on the sphere: every candidate, every texel, every size, in double with 3D dot
// products (independent of the device's law-of-cosines tables and its histogram).
void checkResponsesAgainstBruteForce(const Environment& env, const CenterSurroundOptions& opt) {
  detail::CenterSurroundProbe p = detail::centerSurroundProbe(test::ctx(), env, opt);
  const int W = p.width, H = p.height, S = opt.sizes;
  ASSERT_EQ(W, opt.width);
  ASSERT_EQ(int(p.candidates.size()), W * H);  // candidateFraction 1: every texel, in order
  for (int i = 0; i < W * H; ++i) ASSERT_EQ(p.candidates[i], i);
  // The working grid equals the map here: energy = luminance radiance x exact texel solid angle.
  for (int t = 0; t < H; ++t)
    for (int s = 0; s < W; ++s) {
      const float* px = &env.equirect.pixels[(std::size_t(t) * W + s) * 3];
      double e = (PB_LUM_R * px[0] + PB_LUM_G * px[1] + PB_LUM_B * px[2]) * env.texelSolidAngle(t);
      // float row solid angles: the band width (b - a) / 2 of a float theta carries ~1e-6.
      ASSERT_NEAR(p.lumEnergy[t * W + s], e, 1e-5 * e) << s << "," << t;
    }
  std::vector<std::array<double, 3>> dirs(W * H);
  for (int t = 0; t < H; ++t)
    for (int s = 0; s < W; ++s) texelDir(s, t, W, H, dirs[t * W + s].data());
  std::vector<double> cin(S), cout(S);
  for (int k = 0; k < S; ++k) {
    cin[k] = std::cos(p.innerRadius[k]);
    cout[k] = std::cos(p.outerRadius[k]);
  }
  double worst = 0;  // largest |error| / tolerance
  int checked = 0;
  for (int c = 0; c < W * H; ++c) {
    std::vector<double> in(S, 0), ring(S, 0), mag(S, 0), amb(S, 0);
    for (int x = 0; x < W * H; ++x) {
      const auto& a = dirs[c];
      const auto& b = dirs[x];
      double cosd = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
      double e = p.lumEnergy[x];
      for (int k = 0; k < S; ++k) {
        double ci = cin[k], co = cout[k];
        if (cosd >= ci) in[k] += e;
        else if (cosd >= co) ring[k] += e;
        // Texels within rounding of a boundary may fall either way on the device (float).
        if (std::abs(cosd - ci) < 1e-5 || std::abs(cosd - co) < 1e-5) amb[k] += e;
      }
    }
    for (int k = 0; k < S; ++k) {
      double ext = 2 * p.outerRadius[k];
      double ref = (in[k] + opt.surroundWeight * ring[k]) / ext;
      double got = p.responses[std::size_t(c) * S + k];
      // float accumulation of up to W*H terms: 1e-5 of the magnitude summed, plus any
      // boundary-ambiguous texel counted with the larger weight.
      double tol = (1e-5 * (in[k] - opt.surroundWeight * ring[k]) +
                    (1 - opt.surroundWeight) * amb[k]) / ext + 1e-12;
      ASSERT_NEAR(got, ref, tol) << "candidate texel " << c % W << "," << c / W << " size " << k;
      worst = std::max(worst, std::abs(got - ref) / tol);
      ++checked;
    }
  }
  EXPECT_EQ(checked, W * H * S);
  std::printf("[ cs ] %dx%d, %d sizes: worst error / tolerance %.3f\n", W, H, S, worst);
}

TEST(CenterSurround, ResponsesMatchBruteForceOnTheSphere) {
  CenterSurroundOptions opt;
  opt.width = 64;
  opt.candidateFraction = 1.0f;
  checkResponsesAgainstBruteForce(awkwardMap(64, 32), opt);
}

TEST(CenterSurround, ResponsesMatchBruteForceWithCapsOverThePoles) {
  // An awkward grid (not a power of two) and filters up to 120 degrees: caps contain the poles
  // and cover whole rows, and the surround ring wraps around the seam.
  CenterSurroundOptions opt;
  opt.width = 24;
  opt.sizes = 7;
  opt.minDeg = 10;
  opt.maxDeg = 120;
  opt.innerRatio = 0.6f;
  opt.candidateFraction = 1.0f;
  checkResponsesAgainstBruteForce(awkwardMap(24, 12), opt);
}

TEST(CenterSurround, ResamplingConservesEnergy) {
  // A 96x48 map on a 64x32 working grid (a non-integer ratio) and a 256x128 map on it (4:1).
  for (int mw : {96, 256}) {
    Environment env = awkwardMap(mw, mw / 2);
    CenterSurroundOptions opt;
    opt.width = 64;
    detail::CenterSurroundProbe p = detail::centerSurroundProbe(test::ctx(), env, opt);
    double rgb[3];
    env.power(rgb);
    double want = PB_LUM_R * rgb[0] + PB_LUM_G * rgb[1] + PB_LUM_B * rgb[2], got = 0;
    for (float e : p.lumEnergy) got += e;
    EXPECT_NEAR(got, want, 1e-5 * want) << mw;  // float overlap weights: ~1e-6 per texel
    EXPECT_EQ(p.candidates.size(), std::size_t(std::ceil(0.1 * 64 * 32)));
  }
}

TEST(CenterSurround, CandidatesAreTheBrightestTexels) {
  Environment env = awkwardMap(128, 64);
  CenterSurroundOptions opt;
  opt.width = 128;
  opt.candidateFraction = 0.13f;
  detail::CenterSurroundProbe p = detail::centerSurroundProbe(test::ctx(), env, opt);
  const int W = 128, H = 64;
  std::vector<std::pair<float, int>> rad;  // (-radiance, index): sorted = brightest, lowest index
  for (int t = 0; t < H; ++t)
    for (int s = 0; s < W; ++s)
      rad.push_back({-float(p.lumEnergy[t * W + s] / (2 * kPi / W * 2 *
                                                          std::sin((t + 0.5) * kPi / H) *
                                                          std::sin(0.5 * kPi / H))),
                     t * W + s});
  std::sort(rad.begin(), rad.end());
  const std::size_t K = std::size_t(std::ceil(0.13 * W * H));
  ASSERT_EQ(p.candidates.size(), K);
  ASSERT_TRUE(std::is_sorted(p.candidates.begin(), p.candidates.end()));
  // Radiance here is recomputed in double, the device's key in float: allow the ranks at the
  // threshold to differ by a relative 1e-6 of radiance.
  const float thresh = -rad[K - 1].first;
  for (int c : p.candidates) {
    auto it = std::find_if(rad.begin(), rad.end(), [&](auto& r) { return r.second == c; });
    EXPECT_GE(-it->first, thresh * (1 - 1e-6f)) << c;
  }
}

struct Disc {
  double thetaDeg, phiDeg;
  int size;  // filter size whose centre radius equals the disc's radius
  float L;
};

// Three discs of known size and power on a dim background. The disc radii are the centre
// (inner) radii of filter sizes 4, 10 and 15: that filter then covers the disc exactly with its
// centre and sees only background in its ring, so it is the strongest, its light's cap is the
// disc and its power the disc's; a radius between two sizes would be matched only up to one
// size step (the ratio 10^(1/19) = 1.13), blurring what the test checks. The discs lie more than
// 60 degrees apart, beyond each other's largest filters (22.5 degrees) plus radius.
Environment discMap(const CenterSurroundOptions& opt, const std::vector<Disc>& discs, int w,
                    float background, std::vector<double>* powers = nullptr) {
  Environment env = makeEnv(w, w / 2);
  std::fill(env.equirect.pixels.begin(), env.equirect.pixels.end(), background);
  for (const Disc& d : discs) {
    double r = 0.5 * outerDiamDeg(opt, d.size) * opt.innerRatio * kDeg;
    addDisc(env, dirOf(d.thetaDeg, d.phiDeg), r, d.L);
    if (powers) powers->push_back(d.L * 2 * kPi * (1 - std::cos(r)));
  }
  return env;
}

const std::vector<Disc> kThreeDiscs = {
    {62, 172, 4, 400.0f},   // near the seam phi = +-pi
    {105, -45, 10, 60.0f},  // below the horizon
    {30, 55, 15, 12.0f},    // high up, its largest filters reach within 8 degrees of the pole
};

TEST(CenterSurround, ThreeDiscsBecomeThreeLights) {
  CenterSurroundOptions opt;  // the paper's bank, working grid 512 x 256
  std::vector<double> powers;
  Environment env = discMap(opt, kThreeDiscs, 1024, 0.01f, &powers);
  LightSet set = extractCenterSurround(test::ctx(), env, opt);
  ASSERT_EQ(set.lights.size(), 3u);
  EXPECT_EQ(set.method, "center-surround");
  const double texelDeg = 360.0 / opt.width;
  for (std::size_t i = 0; i < kThreeDiscs.size(); ++i) {
    const Disc& d = kThreeDiscs[i];
    auto want = dirOf(d.thetaDeg, d.phiDeg);
    const AreaLight* best = nullptr;
    for (const AreaLight& l : set.lights)
      if (!best || angleDeg(l.direction, want) < angleDeg(best->direction, want)) best = &l;
    // Position within one filter step: the filters are evaluated on the working grid, one texel
    // (360/width degrees) apart.
    EXPECT_LT(angleDeg(best->direction, want), texelDeg) << i;
    // Size within one step of the bank (ratio 10^(1/19)): the disc's own size, or the next one
    // when the rim texels the antialiased disc only partly covers, just outside its radius, cost
    // the disc's own filter more in its -10 ring than the next filter loses by its larger extent.
    double wantAlpha = 0.5 * outerDiamDeg(opt, d.size) * opt.innerRatio;
    EXPECT_LE(std::abs(std::log(best->halfAngle() / kDeg / wantAlpha)), std::log(10.0) / 19 + 1e-3)
        << i;
    // Power within 5% (the issue): texels on the rim are taken or left whole.
    EXPECT_NEAR(best->power[1], powers[i], 0.05 * powers[i]) << i;
    for (int c = 0; c < 3; ++c)
      EXPECT_FLOAT_EQ(best->radiance[c] * best->solidAngle(), best->power[c]);
    EXPECT_TRUE(best->regions.empty());
  }
}

// The 2% rule (Arbree et al. §3, Weber's law): a fourth disc carrying 1.5% of the three others' power
// is not extracted, one carrying 3% is. It has the smallest response of the four, so it would be
// the fourth light found, when the lights so far are the three discs.
TEST(CenterSurround, TwoPercentStopRule) {
  CenterSurroundOptions opt;
  std::vector<double> powers;
  discMap(opt, kThreeDiscs, 128, 0.0f, &powers);  // only for the powers
  const double three = powers[0] + powers[1] + powers[2];
  for (double frac : {0.015, 0.03}) {
    std::vector<Disc> discs = kThreeDiscs;
    const int size = 4;
    double r = 0.5 * outerDiamDeg(opt, size) * opt.innerRatio * kDeg;
    float L = float(frac * three / (2 * kPi * (1 - std::cos(r))));
    discs.push_back({150, 100, size, L});
    Environment env = discMap(opt, discs, 1024, 0.01f);
    LightSet set = extractCenterSurround(test::ctx(), env, opt);
    const bool found = set.lights.size() == 4;
    EXPECT_EQ(set.lights.size(), frac < 0.02 ? 3u : 4u) << frac;
    if (found)
      EXPECT_LT(angleDeg(set.lights[3].direction, dirOf(150, 100)), 360.0 / opt.width);
  }
}

// The issue's common requirements, on every test map and the built-in sky.
std::vector<Environment> allMaps() {
  std::vector<Environment> maps;
  for (const char* m : test::kMaps) maps.push_back(loadEnvironment(test::data(m)));
  maps.push_back(environmentFrom("builtin"));
  return maps;
}


namespace xref = penumbra::test::xref;

// What center-surround's lights are meant to carry (Arbree et al. §3): each light takes the map's
// energy inside its centre cap, less what an earlier light took. By the test's own quadrature
// (tests/support/extraction_checks.hpp), each cap taken about the light's own direction with its
// own half-angle (the direction is the luminance-weighted mean of the cap it took: at the cap's
// centre for a compact source, off it by part of the radius where the cap holds a gradient).
xref::Target capsTarget(const std::vector<xref::Sample>& q, const LightSet& set,
                        const std::vector<xref::D3>& normals) {
  std::vector<xref::Sample> in;
  for (const xref::Sample& s : q)
    for (const AreaLight& l : set.lights)
      if (xref::dot3(s.dir, xref::toD(l.direction)) >= l.cosAlpha) {
        in.push_back(s);
        break;
      }
  return xref::mapTarget(in, normals);
}

// The lights judged alone (their ambient ignored) against capsTarget, the irradiance error as a
// fraction of the whole map's (`map`): power and worst luminance error on the 26 normals. An empty
// set takes nothing and so differs from its empty target by nothing: `meets` requires a light.
xref::LightsError judgeCenterSurround(const std::vector<xref::Sample>& q, const xref::Target& map,
                                      const LightSet& set) {
  return xref::lightsError(set, capsTarget(q, set, map.normals), &map);
}

// Bounds. Power: each light carries exactly the texels it took, so what differs is the test's
// cap (about the light's direction) from the cap taken (about the filter's centre): measured
// 1.69% on courtyard (2 lights on no compact source, 1.7% of the map's power, their directions
// off their caps' centres), 0.12 / 0.11 / 0.00% elsewhere; bound 3%. Irradiance: the uniform cap
// in place of what its texels held; measured worst 2.89% of the map's (studio; 0.14 / 0.34 /
// 0.02% elsewhere, means <= 0.24%); RegressionBound 4% (+1.1 points); issue 4's 2% is not met on
// studio (KnownGap below). The controls: no lights (refused by the count), directions negated
// (power 21000-268000% off: the caps then hold the dim opposite side), power halved (50-51% off in
// power; in irradiance 3.0% on courtyard, 35-49% elsewhere): each fails.
constexpr double kIssue4Bound = 0.02;
constexpr double kCsPowerBound = 0.03;
constexpr double kCsRegressionIrradiance = 0.04;

bool meets(const LightSet& set, const xref::LightsError& e, double irradianceBound) {
  return !set.lights.empty() && e.power < kCsPowerBound && e.worstLum < irradianceBound;
}

// Per map: the worst luminance error; with `controls`, the controls asserted to fail.
double centerSurroundWorst(const std::vector<Environment>& envs, bool controls) {
  double worst = 0;
  for (const Environment& env : envs) {
    LightSet set = extractCenterSurround(test::ctx(), env, {});
    const auto q = xref::mapSamples(env);
    const xref::Target map = xref::mapTarget(q, xref::testNormals());
    const xref::LightsError j = judgeCenterSurround(q, map, set);
    worst = std::max(worst, j.worstLum);
    std::printf("[ measured ] %s: center-surround %zu lights carry %.1f%% of the map's power; vs "
                "the map in their caps: power %.2f%%, irradiance worst %.2f%% mean %.2f%% of the "
                "map's\n",
                env.source.c_str(), set.lights.size(), 100 * set.lightsPower()[1] / map.power[1],
                100 * j.power, 100 * j.worstLum, 100 * j.meanLum);
    EXPECT_TRUE(meets(set, j, 1.0)) << env.source;  // the count and the power
    if (!controls) continue;
    const LightSet c[3] = {xref::withoutLights(set), xref::negated(set), xref::halved(set)};
    for (int k = 0; k < 3; ++k) {
      const xref::LightsError e = judgeCenterSurround(q, map, c[k]);
      std::printf("[ control ] %s: %s: power %.1f%%, irradiance %.1f%%\n", env.source.c_str(),
                  k == 0 ? "no lights" : k == 1 ? "negated" : "halved", 100 * e.power,
                  100 * e.worstLum);
      EXPECT_FALSE(meets(c[k], e, kCsRegressionIrradiance)) << env.source << " control " << k;
    }
  }
  return worst;
}

// Replaces "lights + SH9 ambient within 22% worst / 6% mean of the map's irradiance", which an
// empty light set passes too (the ambient is then the whole map).
TEST(CenterSurround, RegressionBoundLightsCarryTheirCaps) {
  EXPECT_LT(centerSurroundWorst(allMaps(), true), kCsRegressionIrradiance);
}

// Issue 4's 2% for center-surround's lights against their caps: not met on studio (above: measured
// 2.89%). Fails the day it is met: then assert the 2% above.
TEST(CenterSurround, LightsKnownGapToIssue4Bound) {
  EXPECT_GT(centerSurroundWorst({loadEnvironment(test::data("envmaps/studio.exr"))}, false),
            kIssue4Bound);
}

TEST(CenterSurround, RotatingTheMapRotatesTheLights) {
  for (const Environment& env : allMaps()) {
    Environment rot = env;
    const Image& a = env.equirect;
    ASSERT_EQ(a.width % 4, 0);
    for (int t = 0; t < a.height; ++t)
      for (int s = 0; s < a.width; ++s)
        for (int c = 0; c < 3; ++c)
          rot.equirect.at((s + a.width / 4) % a.width, t, c) = a.at(s, t, c);
    LightSet l0 = extractCenterSurround(test::ctx(), env, {});
    LightSet l1 = extractCenterSurround(test::ctx(), rot, {});
    ASSERT_EQ(l0.lights.size(), l1.lights.size()) << env.source;
    for (const AreaLight& l : l0.lights) {
      std::array<float, 3> d = {-l.direction[2], l.direction[1], l.direction[0]};
      const AreaLight* m = &l1.lights[0];
      for (const AreaLight& o : l1.lights)
        if (angleDeg(o.direction, d) < angleDeg(m->direction, d)) m = &o;
      EXPECT_LT(angleDeg(m->direction, d), 1.0) << env.source;
      for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(m->power[c], l.power[c], 0.01 * l.power[c] + 1e-12) << env.source;
    }
  }
}

// Environment::rotationYDeg is honoured exactly: -90 degrees (the map's content moved by +90
// degrees of azimuth) gives the very lights of the map with its columns shifted by width / 4.
TEST(CenterSurround, RotationYDegIsTheShiftedMap) {
  Environment env = loadEnvironment(test::data("envmaps/interior.exr"));
  Environment shifted = env;
  const Image& a = env.equirect;
  for (int t = 0; t < a.height; ++t)
    for (int s = 0; s < a.width; ++s)
      for (int c = 0; c < 3; ++c)
        shifted.equirect.at((s + a.width / 4) % a.width, t, c) = a.at(s, t, c);
  env.rotationYDeg = -90;
  LightSet l0 = extractCenterSurround(test::ctx(), env, {});
  LightSet l1 = extractCenterSurround(test::ctx(), shifted, {});
  ASSERT_EQ(l0.lights.size(), l1.lights.size());
  ASSERT_GE(l0.lights.size(), 1u);
  for (std::size_t i = 0; i < l0.lights.size(); ++i) {
    EXPECT_EQ(std::memcmp(l0.lights[i].direction.data(), l1.lights[i].direction.data(), 12), 0);
    EXPECT_EQ(std::memcmp(l0.lights[i].power.data(), l1.lights[i].power.data(), 12), 0);
  }
}

TEST(CenterSurround, BitIdenticalOnRepeat) {
  Environment env = loadEnvironment(test::data(test::kMaps[0]));
  LightSet a = extractCenterSurround(test::ctx(), env, {});
  LightSet b = extractCenterSurround(test::ctx(), env, {});
  ASSERT_EQ(a.lights.size(), b.lights.size());
  for (std::size_t i = 0; i < a.lights.size(); ++i) {
    EXPECT_EQ(std::memcmp(a.lights[i].direction.data(), b.lights[i].direction.data(), 12), 0);
    EXPECT_EQ(std::memcmp(a.lights[i].power.data(), b.lights[i].power.data(), 12), 0);
    EXPECT_EQ(std::memcmp(a.lights[i].radiance.data(), b.lights[i].radiance.data(), 12), 0);
    EXPECT_EQ(std::memcmp(&a.lights[i].cosAlpha, &b.lights[i].cosAlpha, 4), 0);
  }
}

// Issue 4: "the center-surround decomposition of a 1024x512 map takes under one second". Timed
// after a warm-up (kernel builds), wall clock around the whole call; the maps are 1024x512.
TEST(CenterSurround, DecomposesA1024x512MapInUnderASecond) {
  double worst = 0;
  for (const Environment& env : allMaps()) {
    LightSet warm = extractCenterSurround(test::ctx(), env, {});
    test::ctx().resetTimings();
    auto t0 = std::chrono::steady_clock::now();
    LightSet set = extractCenterSurround(test::ctx(), env, {});
    double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    std::printf("[ cs ] %s (%dx%d): %zu lights, %.1f ms;", env.source.c_str(), env.equirect.width,
                env.equirect.height, set.lights.size(), ms);
    for (auto& [stage, t] : test::ctx().stageTimesMs()) std::printf(" %s %.1f", stage.c_str(), t);
    std::printf("\n");
    if (env.equirect.width == 1024) worst = std::max(worst, ms);
  }
  // The issue's bound, with no margin: the CPU is shared with other jobs, so a failure here
  // says so.
  EXPECT_LT(worst, 1000.0);
}

TEST(CenterSurround, RejectsBadOptionsNamingTheField) {
  Environment env = awkwardMap(32, 16);
  auto expectBad = [&](CenterSurroundOptions o, const char* field) {
    try {
      extractCenterSurround(test::ctx(), env, o);
      ADD_FAILURE() << "no error for " << field;
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::BadInput) << field;
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  CenterSurroundOptions o;
  o = {}; o.width = 7; expectBad(o, "width");
  o = {}; o.width = 0; expectBad(o, "width");
  o = {}; o.sizes = 0; expectBad(o, "sizes");
  o = {}; o.sizes = 33; expectBad(o, "sizes");
  o = {}; o.minDeg = 0; expectBad(o, "minDeg");
  o = {}; o.maxDeg = 200; expectBad(o, "maxDeg");
  o = {}; o.maxDeg = 2; expectBad(o, "maxDeg");
  o = {}; o.innerRatio = 1; expectBad(o, "innerRatio");
  o = {}; o.surroundWeight = 1; expectBad(o, "surroundWeight");
  o = {}; o.candidateFraction = 0; expectBad(o, "candidateFraction");
  o = {}; o.stopFraction = 1; expectBad(o, "stopFraction");
  o = {}; o.maxLights = 0; expectBad(o, "maxLights");
  o = {}; o.maxLights = PB_MAX_LIGHTS + 1; expectBad(o, "maxLights");
}

TEST(CenterSurround, MaxLightsCapsTheCount) {
  CenterSurroundOptions opt;
  opt.maxLights = 2;
  Environment env = discMap(opt, kThreeDiscs, 512, 0.01f);
  EXPECT_EQ(extractCenterSurround(test::ctx(), env, opt).lights.size(), 2u);
}

// Every kernel (resample, radix select, candidates, responses, take, incremental update) under
// oclgrind on a tiny map: two discs, so the update path runs between the two takes. The discs are
// drawn in whole working texels (2x2 map texels, the map being twice the grid) of radius equal
// to a filter's centre radius, so each light removes its disc entirely and nothing is left to
// become a third light.
TEST(OclgrindCenterSurround, TinyMap) {
  CenterSurroundOptions opt;
  opt.width = 32;
  opt.sizes = 4;
  opt.minDeg = 15;
  opt.maxDeg = 60;
  opt.candidateFraction = 0.25f;
  const int W = 32, H = 16;
  Environment env = makeEnv(2 * W, 2 * H);
  // Centre radius of size 2: 0.75 * 0.5 * 15 * 4^(2/3) degrees; the discs' centres are texel
  // centres of the working grid.
  const double r = 0.75 * 0.5 * 15 * std::pow(4.0, 2.0 / 3.0) * kDeg;
  const int centres[2][2] = {{8, 5}, {25, 10}};
  const float Ls[2] = {50.0f, 30.0f};
  double c[2][3], d[3];
  for (int i = 0; i < 2; ++i) texelDir(centres[i][0], centres[i][1], W, H, c[i]);
  for (int t = 0; t < 2 * H; ++t)
    for (int s = 0; s < 2 * W; ++s) {
      texelDir(s / 2, t / 2, W, H, d);
      float v = 0.02f;
      for (int i = 0; i < 2; ++i)
        if (d[0] * c[i][0] + d[1] * c[i][1] + d[2] * c[i][2] >= std::cos(r)) v = Ls[i];
      for (int k = 0; k < 3; ++k) env.equirect.at(s, t, k) = v;
    }
  LightSet set = extractCenterSurround(test::ctx(), env, opt);
  ASSERT_EQ(set.lights.size(), 2u);
  for (int i = 0; i < 2; ++i) {
    std::array<float, 3> want = {float(c[i][0]), float(c[i][1]), float(c[i][2])};
    EXPECT_LT(angleDeg(set.lights[i].direction, want), 360.0 / W) << i;
    EXPECT_NEAR(set.lights[i].halfAngle(), r, 1e-4) << i;
  }
}

}  // namespace
}  // namespace penumbra
