// The techniques that sample the depth map texel by texel (kernels/shadows/pcss.cl): hard shadows,
// PCSS and brute force. Each against the analytic penumbra of the planar, parallel configuration
// (Kneiphof 2017 §3.2, the configuration where PCSS-style filtering is exact), on degenerate
// inputs,
// for determinism, and on tiny inputs under oclgrind (suites Oclgrind*).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <vector>

#include "common.hpp"
#include "support/planar_penumbra.hpp"

using namespace penumbra;
using namespace penumbra::test;

namespace {

Mesh quad(const std::string& name, Vec3 a, Vec3 b, Vec3 c, Vec3 d) {
  Mesh m;
  m.name = name;
  m.positions = {a, b, c, d};
  m.triangles = {{0, 2, 1}, {0, 3, 2}};
  return m;
}

// Horizontal quad [x0,x1] x [z0,z1] at height y.
Mesh hquad(const std::string& name, float x0, float x1, float z0, float z1, float y) {
  return quad(name, {x0, y, z0}, {x1, y, z0}, {x1, y, z1}, {x0, y, z1});
}

struct Planar {
  std::vector<ReceiverPixel> pixels;
  double R = 0;        // penumbra half-width h tan(alpha)
  double texel = 0;    // shadow-map texel size (world)
  std::vector<float> image;
};

// tests/support's planar configuration: a half-plane blocker x < 0 at height h over the ground,
// one light straight down with half-angle alphaDeg, the camera on the lit side below the blocker
// (at least 0.2 over the ground), quads without normals. Returns every ground pixel inside the
// border.
Planar planarFrame(RenderOptions ro, double alphaDeg, double h, int mapSize) {
  PlanarPenumbra s;
  s.blockers = {{0.0, h}};
  s.light = capLightAbove(alphaDeg);
  s.vertexNormals = false;
  s.minEyeHeight = 0.2;
  s.mapSize = mapSize;
  Planar p;
  p.R = h * std::tan(alphaDeg * M_PI / 180);
  p.texel = 2 * (3 + 6e-3) / mapSize;  // lightFrame's half-extent 3 plus its 1e-3 margin
  // the analytic blocker is a half-plane: leave out receivers that see past its far edges
  // (brute force's sample maps reach there; the filters stop at the map's border)
  const double R = p.R;
  s.keep = [R](double px, double pz) {
    return !(px < -2.95 + std::fabs(R) || std::fabs(pz) > 2.95 - std::fabs(R));
  };
  PlanarFrame f = renderPlanar(s, ro);
  p.image = f.image.pixels;
  p.pixels = f.receivers;
  return p;
}

using PlanarError = ProfileComparison;

// Per pixel against the analytic profile (tabulated at 1/2000 of the penumbra width).
PlanarError planarError(const Planar& p, double alphaDeg, double h, bool cosWeighted = true) {
  const double alpha = alphaDeg * M_PI / 180, R = p.R;
  return compareWithProfile(p.pixels, PenumbraProfile(-R, R, 2000, [&](double x) {
                              return halfPlaneVisibilityByRings(x, h, alpha, cosWeighted);
                            }));
}

PlanarError planarCase(const char* what, RenderOptions ro, double alphaDeg, double h,
                       int mapSize) {
  Planar p = planarFrame(ro, alphaDeg, h, mapSize);
  PlanarError e = planarError(p, alphaDeg, h);
  std::printf("[ penumbra ] %s planar alpha %.1f deg, h %.1f, map %d: max |V - V_analytic| = "
              "%.4f over %d pixels, rms %.4f over %d penumbra pixels\n",
              what, alphaDeg, h, mapSize, e.maxError, e.samples, e.rmsPenumbra,
              e.penumbraSamples);
  return e;
}

RenderOptions withTechnique(ShadowTechnique t) {
  RenderOptions ro;
  ro.shadows = t;
  return ro;
}

// Every visibility and every pixel finite, visibility in [0, 1].
void expectFiniteFrame(const Planar& p, const std::vector<float>& vis) {
  for (float v : p.image) ASSERT_TRUE(std::isfinite(v));
  for (float v : vis) {
    ASSERT_TRUE(std::isfinite(v));
    ASSERT_GE(v, 0.0f);
    ASSERT_LE(v, 1.0f);
  }
}

// A single quad seen by the light straight down, tilted by `tiltDeg` about z, no blocker: the
// receiver plane test (nothing may shadow a plane but itself, which must not).
std::vector<float> tiltedPlaneVisibility(RenderOptions ro, double tiltDeg) {
  const float c = float(std::cos(tiltDeg * M_PI / 180)), s = float(std::sin(tiltDeg * M_PI / 180));
  Scene scene;
  // rotate the ground [-2,2]^2 about the z axis: x -> (c x, s x)
  scene.meshes.push_back(quad("tilted", {-2 * c, -2 * s, -2}, {2 * c, 2 * s, -2}, {2 * c, 2 * s, 2},
                              {-2 * c, -2 * s, 2}));
  AreaLight light;
  light.direction = {0, 1, 0};
  light.cosAlpha = float(std::cos(10 * M_PI / 180));
  light.radiance = {1, 1, 1};
  LightSet set;
  set.lights.push_back(light);
  Camera cam;
  cam.eye = {-3.0f * s, 4.0f * c, 1.0f};
  cam.target = {0, 0, 0};
  cam.fovyDeg = 60;
  ro.width = 64;
  ro.height = 48;
  ro.shadowMapSize = 128;
  Renderer r(ctx());
  Frame f = r.render(scene, cam, set, builtinEnvironment(16), ro);
  std::vector<float> vis = r.lastVisibility(), out;
  for (int i = 0; i < ro.width * ro.height; ++i)
    if (f.image.pixels[4 * std::size_t(i) + 3] > 0.5f) out.push_back(vis[i]);
  return out;
}

struct SmallFrame {
  Frame frame;
  std::vector<float> vis;
};

// The built-in scene under a few extracted lights, small.
SmallFrame builtinFrame(RenderOptions ro, int lights = 6, int w = 48, int h = 32, int map = 64) {
  Scene scene = builtinScene();
  Environment env = builtinEnvironment(64);
  MedianCutOptions mc;
  mc.lights = lights;
  mc.faceSize = 32;
  LightSet set = extractMedianCut(ctx(), env, mc);
  ro.width = w;
  ro.height = h;
  ro.shadowMapSize = map;
  Renderer r(ctx());
  SmallFrame s;
  s.frame = r.render(scene, frameCamera(scene, float(w) / h), set, env, ro);
  s.vis = r.lastVisibility();
  return s;
}

}  // namespace

// ------------------------------------------------------------------------------------------------
// Hard shadows

// Nearest-texel depth test: visibility is exactly 0 or 1 everywhere, and exactly the half-plane's
// shadow one texel away from its edge (the edge may move by up to one texel: the test reads the
// texel that holds the receiver, whose centre ray decides).
TEST(HardShadows, ExactlyBinaryAwayFromTheEdge) {
  Planar p = planarFrame(withTechnique(ShadowTechnique::Hard), 10.0, 1.0, 256);
  ASSERT_GT(p.pixels.size(), 5000u);
  int shadowed = 0, lit = 0;
  for (const ReceiverPixel& q : p.pixels) {
    ASSERT_TRUE(q.vis == 0.0 || q.vis == 1.0) << "x " << q.x << " vis " << q.vis;
    if (std::fabs(q.x) <= p.texel) continue;
    EXPECT_EQ(q.vis, q.x < 0 ? 0.0 : 1.0) << "x " << q.x;
    (q.x < 0 ? shadowed : lit)++;
  }
  EXPECT_GT(shadowed, 1000);
  EXPECT_GT(lit, 1000);
}

TEST(HardShadows, TiltedPlaneDoesNotShadowItself) {
  for (double tilt : {30.0, 60.0, 75.0}) {
    auto vis = tiltedPlaneVisibility(withTechnique(ShadowTechnique::Hard), tilt);
    ASSERT_GT(vis.size(), 500u);
    for (float v : vis) ASSERT_EQ(v, 1.0f) << "tilt " << tilt;
  }
}

// ------------------------------------------------------------------------------------------------
// PCSS

// Bound 0.035 with every texel of both boxes (blockerTaps = filterTaps = 0). With all blockers at
// one depth, eqs. 4-5 give the exact penumbra width, and the box filter of the binary map (the
// map's step lies exactly at x = 0, a texel boundary) is the linear ramp of a square light: it
// differs from the disc-shaped cap's cos-weighted profile by at most 0.023 on a straight edge
// (the equal-area square, kernels/shadows/pcss.cl's BOX_FROM_DISC). The rest covers the clamp to
// one texel of filter and the bias.
TEST(PCSS, ExplicitNarrowPenumbraMatchesAnalyticProfile) {
  RenderOptions ro = withTechnique(ShadowTechnique::PCSS);
  ro.pcss.blockerTaps = 0;
  PlanarError e = planarCase("PCSS (every texel)", ro, 5.0, 1.0, 256);
  EXPECT_GT(e.samples, 5000);
  EXPECT_GT(e.penumbraSamples, 100);
  EXPECT_LT(e.maxError, 0.035);
}

TEST(PCSS, ExplicitWidePenumbraMatchesAnalyticProfile) {
  RenderOptions ro = withTechnique(ShadowTechnique::PCSS);
  ro.pcss.blockerTaps = 0;
  PlanarError e = planarCase("PCSS (every texel)", ro, 15.0, 1.0, 256);
  EXPECT_GT(e.penumbraSamples, 500);
  EXPECT_LT(e.maxError, 0.035);
}

// Defaults: a 4x4 grid of blocker-search taps, every texel in the filter. Same bound as every
// texel: with all blockers at one depth, the taps give z_avg exactly as long as one of them finds
// a blocker, and the grid spans the search box edge to edge, so it finds any blocker texel on the
// box's border row/column (a cell-centre grid would miss overlaps under 1/8 of the box and call
// the pixel lit: measured 0.107 here).
TEST(PCSS, DefaultNarrowAndWidePenumbra) {
  RenderOptions ro = withTechnique(ShadowTechnique::PCSS);
  PlanarError n = planarCase("PCSS (defaults)", ro, 5.0, 1.0, 256);
  PlanarError w = planarCase("PCSS (defaults)", ro, 15.0, 1.0, 256);
  EXPECT_GT(n.penumbraSamples, 100);
  EXPECT_GT(w.penumbraSamples, 500);
  EXPECT_LT(n.maxError, 0.035);
  EXPECT_LT(w.maxError, 0.035);
}

// Fixed filter taps (filterTaps = 32: a 6x6 grid of bilinear PCF taps, the midpoint rule of the
// same box). Bound 0.11 = 1/(2 g) + 0.023: the 6 tap columns resolve the box's linear ramp in
// steps of 1/6 (each step smoothed over a texel by the bilinear lookups, not over the 3.3-texel
// tap spacing), plus the square-vs-disc difference. Measured 0.084.
TEST(PCSS, FixedTapsWidePenumbra) {
  RenderOptions ro = withTechnique(ShadowTechnique::PCSS);
  ro.pcss.blockerTaps = 0;
  ro.pcss.filterTaps = 32;
  PlanarError w = planarCase("PCSS (every texel / 32 taps)", ro, 15.0, 1.0, 256);
  EXPECT_GT(w.penumbraSamples, 500);
  EXPECT_LT(w.maxError, 0.11);
}

// Up to a light 2 degrees above the plane (tilt 88): PCSS's receiver plane is not clamped
// (kernels/shadows/filter.clh, receiver_slope). Clamped at a slope of tan 84 degrees, as it was,
// the plane was cut short past 84 and the lit plane shadowed itself: at tilt 85 a mean visibility
// of 0.61, down to 0.26.
TEST(PCSS, TiltedPlaneDoesNotShadowItselfWithReceiverPlane) {
  RenderOptions ro = withTechnique(ShadowTechnique::PCSS);
  for (double tilt : {30.0, 60.0, 75.0, 85.0, 88.0}) {
    auto vis = tiltedPlaneVisibility(ro, tilt);
    ASSERT_GT(vis.size(), 500u);
    for (float v : vis) ASSERT_EQ(v, 1.0f) << "tilt " << tilt;
  }
  // and the receiver plane is what keeps it so: compared with the receiver's depth alone, the
  // plane's nearer half of every filter box shadows it
  ro.pcss.receiverPlaneBias = false;
  auto vis = tiltedPlaneVisibility(ro, 60.0);
  EXPECT_LT(*std::min_element(vis.begin(), vis.end()), 0.8f);
}

// The area approximation on the same lone plane, up to a light 2 degrees above it (tilt 88), whose
// 10-degree cap then reaches 8 degrees under the plane's horizon. Two things keep it at 1
// (kernels/shadows/area.cl): the samples under the horizon count as lit and their segments cross
// at the horizon (depth-tested, they read the plane as a blocker now and then, and the chords
// closing the broken runs cut off light above the horizon: a mean of 0.99 at tilt 88, 0.96 with
// the slope unclamped), and the receiver plane's slope is not clamped (at tan 84 degrees: down to
// 0.993 at tilt 75, whose lowest samples are 5 degrees above the plane, and 0.85 at tilt 85).
TEST(AreaApprox, TiltedPlaneDoesNotShadowItself) {
  for (double tilt : {30.0, 60.0, 75.0, 85.0, 88.0}) {
    auto vis = tiltedPlaneVisibility(withTechnique(ShadowTechnique::AreaApprox), tilt);
    ASSERT_GT(vis.size(), 500u);
    for (float v : vis) ASSERT_EQ(v, 1.0f) << "tilt " << tilt;
  }
}

TEST(PCSS, RejectsBadTapCounts) {
  for (int bad : {-1, 4097}) {
    RenderOptions ro = withTechnique(ShadowTechnique::PCSS);
    ro.pcss.blockerTaps = bad;
    EXPECT_THROW(builtinFrame(ro, 2, 8, 8, 8), Error);
    ro.pcss.blockerTaps = 16;
    ro.pcss.filterTaps = bad;
    EXPECT_THROW(builtinFrame(ro, 2, 8, 8, 8), Error);
  }
}

// ------------------------------------------------------------------------------------------------
// Brute force

// Brute force converges to the analytic profile as K grows. Its error has two parts: the K
// directions' quadrature of the cap (a spherical Fibonacci set: the lit share of a half-plane
// changes in steps of ~1/K, and the set's discrepancy for half-planes falls roughly as K^-3/4)
// and each map's texel grid (every sample's edge within half a texel of its true place, shifted
// independently per sample: a blur of about a texel, 0.13 of the narrow penumbra's width, which
// costs ~0.01 where the profile bends). Bound 0.03 at K = 256; measured 0.059 -> 0.025 (narrow)
// and 0.044 -> 0.019 (wide) from K = 64 to 256, rms over the penumbra 0.018 -> 0.0085 and
// 0.013 -> 0.006.
TEST(BruteForce, ConvergesToAnalyticProfile) {
  for (double alpha : {5.0, 15.0}) {
    RenderOptions ro = withTechnique(ShadowTechnique::Brute);
    ro.brute.samples = 64;
    PlanarError e64 = planarCase("brute K=64", ro, alpha, 1.0, 256);
    ro.brute.samples = 256;
    PlanarError e256 = planarCase("brute K=256", ro, alpha, 1.0, 256);
    EXPECT_GT(e256.penumbraSamples, 100);
    EXPECT_LT(e256.rmsPenumbra, e64.rmsPenumbra) << "alpha " << alpha;
    EXPECT_LT(e256.maxError, 0.03) << "alpha " << alpha;
  }
}

// The visibility is irradiance-weighted (each direction by max(0, n.w_k)), as the shading needs:
// on a 75-degree light, where the two weightings differ by up to 0.053, brute force matches the
// cos-weighted profile and not the solid-angle one.
TEST(BruteForce, VisibilityIsIrradianceWeighted) {
  const double alpha = 75.0, h = 0.25;
  RenderOptions ro = withTechnique(ShadowTechnique::Brute);
  ro.brute.samples = 256;
  Planar p = planarFrame(ro, alpha, h, 256);
  PlanarError cosErr = planarError(p, alpha, h, true);
  PlanarError uniErr = planarError(p, alpha, h, false);
  std::printf("[ penumbra ] brute K=256 alpha 75: max error %.4f vs cos-weighted, %.4f vs "
              "solid-angle-weighted profile\n", cosErr.maxError, uniErr.maxError);
  EXPECT_GT(cosErr.penumbraSamples, 500);
  EXPECT_LT(cosErr.maxError, 0.03);
  EXPECT_GT(uniErr.maxError, 2 * cosErr.maxError);
}

TEST(BruteForce, TiltedPlaneDoesNotShadowItself) {
  RenderOptions ro = withTechnique(ShadowTechnique::Brute);
  ro.brute.samples = 16;
  for (double tilt : {30.0, 60.0}) {
    auto vis = tiltedPlaneVisibility(ro, tilt);
    ASSERT_GT(vis.size(), 500u);
    for (float v : vis) ASSERT_GE(v, 0.9999f) << "tilt " << tilt;
  }
}

// Batches (BruteOptions::batchBytes) split a light's samples across launches; the result equals
// the one-batch frame up to the order of float additions, and the memory report follows.
TEST(BruteForce, BatchesGiveTheSameVisibility) {
  RenderOptions ro = withTechnique(ShadowTechnique::Brute);
  ro.brute.samples = 8;
  SmallFrame whole = builtinFrame(ro, 3, 48, 32, 64);
  ro.brute.batchBytes = 3 * 64 * 64 * 4;  // three maps: batches end inside lights
  SmallFrame split = builtinFrame(ro, 3, 48, 32, 64);
  ASSERT_EQ(whole.vis.size(), split.vis.size());
  double maxDiff = 0;
  for (std::size_t i = 0; i < whole.vis.size(); ++i)
    maxDiff = std::max(maxDiff, double(std::fabs(whole.vis[i] - split.vis[i])));
  EXPECT_LT(maxDiff, 1e-6);
  EXPECT_EQ(whole.frame.shadowMapBytes, std::size_t(64) * 64 * 3 * 8 * 4);  // K maps per light
  EXPECT_EQ(split.frame.shadowMapBytes, std::size_t(64) * 64 * 3 * 4);      // 3 maps in all
}

TEST(BruteForce, RejectsBadSampleCounts) {
  for (int bad : {0, -3, 4097}) {
    RenderOptions ro = withTechnique(ShadowTechnique::Brute);
    ro.brute.samples = bad;
    EXPECT_THROW(builtinFrame(ro, 2, 8, 8, 8), Error);
  }
}

// ------------------------------------------------------------------------------------------------
// All three: degenerate inputs, determinism

namespace {

std::vector<std::pair<const char*, RenderOptions>> sampledTechniques() {
  std::vector<std::pair<const char*, RenderOptions>> v;
  v.push_back({"hard", withTechnique(ShadowTechnique::Hard)});
  v.push_back({"pcss", withTechnique(ShadowTechnique::PCSS)});
  RenderOptions taps = withTechnique(ShadowTechnique::PCSS);
  taps.pcss.blockerTaps = 0;
  taps.pcss.filterTaps = 32;
  v.push_back({"pcss taps", taps});
  RenderOptions brute = withTechnique(ShadowTechnique::Brute);
  brute.brute.samples = 8;
  v.push_back({"brute", brute});
  return v;
}

std::vector<float> visOf(RenderOptions ro, double alphaDeg, double h, int mapSize, Planar* out) {
  // planarFrame keeps only the ground pixels; the whole visibility buffer is checked here
  Planar p = planarFrame(ro, alphaDeg, h, mapSize);
  std::vector<float> v;
  for (auto& q : p.pixels) v.push_back(float(q.vis));
  if (out) *out = p;
  return v;
}

}  // namespace

TEST(SampledShadows, DegenerateInputsStayFinite) {
  for (auto& [name, ro] : sampledTechniques()) {
    SCOPED_TRACE(name);
    Planar p;
    // receiver exactly at the blocker's depth: the blocker lies in the ground's plane, so nothing
    // is in front of the receiver anywhere
    auto v = visOf(ro, 10.0, 0.0, 128, &p);
    expectFiniteFrame(p, v);
    for (float x : v) ASSERT_GE(x, 0.9999f);
    // zero-size light: a hard shadow, binary a texel and a half away from the edge
    v = visOf(ro, 0.0, 1.0, 128, &p);
    expectFiniteFrame(p, v);
    for (auto& q : p.pixels)
      if (std::fabs(q.x) > 1.5 * p.texel) ASSERT_EQ(q.vis, q.x < 0 ? 0.0 : 1.0) << q.x;
    // a light wider than 90 degrees (cos alpha < 0)
    v = visOf(ro, 100.0, 1.0, 128, &p);
    expectFiniteFrame(p, v);
    // a one-texel shadow map
    v = visOf(ro, 10.0, 1.0, 1, &p);
    expectFiniteFrame(p, v);
  }
}

// The light sees a single quad edge-on: its depth map holds no caster, and nothing is shadowed.
// Brute force's sample maps are empty only if every sample looks along the wall: a zero-size
// light (any other sample sees the wall at a grazing angle, casting onto nothing but itself).
TEST(SampledShadows, EmptyShadowMapShadowsNothing) {
  Scene scene;
  scene.meshes.push_back(quad("wall", {0, 0, -1}, {0, 2, -1}, {0, 2, 1}, {0, 0, 1}));
  Camera cam;
  cam.eye = {3, 1, 0.5f};
  cam.target = {0, 1, 0};
  for (auto& [name, ro0] : sampledTechniques()) {
    SCOPED_TRACE(name);
    AreaLight light;
    light.direction = {0, 1, 0};
    light.cosAlpha = ro0.shadows == ShadowTechnique::Brute ? 1.0f : float(std::cos(5 * M_PI / 180));
    light.radiance = {1, 1, 1};
    LightSet set;
    set.lights.push_back(light);
    RenderOptions ro = ro0;
    ro.width = 32;
    ro.height = 24;
    ro.shadowMapSize = 32;
    Renderer r(ctx());
    Frame f = r.render(scene, cam, set, builtinEnvironment(16), ro);
    int geometry = 0;
    for (std::size_t i = 0; i < f.image.pixels.size(); ++i) {
      ASSERT_TRUE(std::isfinite(f.image.pixels[i]));
      if (i % 4 == 3) geometry += f.image.pixels[i] > 0.5f;
    }
    EXPECT_GT(geometry, 50);
    for (float v : r.lastVisibility()) ASSERT_EQ(v, 1.0f);
  }
}

TEST(SampledShadows, SameFrameTwiceIsIdentical) {
  for (auto& [name, ro0] : sampledTechniques()) {
    SCOPED_TRACE(name);
    RenderOptions ro = ro0;
    ro.brute.batchBytes = 5 * 64 * 64 * 4;  // brute: several batches
    // Lights on the horizon average several lights' visibility, and the ground's occlusion takes
    // a share of a low light off, which make hard shadows' binary values fractional (README,
    // "Lights on the horizon", "The ground and low lights"): off for hard shadows, whose own
    // values are checked below.
    if (ro.shadows == ShadowTechnique::Hard) {
      ro.shadow.horizonVisibility = false;
      ro.shadow.groundVisibility = false;
    }
    SmallFrame a = builtinFrame(ro), b = builtinFrame(ro);
    EXPECT_EQ(a.frame.image.pixels, b.frame.image.pixels);
    EXPECT_EQ(a.vis, b.vis);
    // and there are shadows, partial ones where the technique is soft
    int zero = 0, partial = 0;
    for (float v : a.vis) {
      zero += v == 0.0f;
      partial += v > 0.0f && v < 1.0f;
    }
    EXPECT_GT(zero + partial, int(a.vis.size() / 50));
    if (ro.shadows == ShadowTechnique::Hard) EXPECT_EQ(partial, 0);
    else EXPECT_GT(partial, int(a.vis.size() / 100));
  }
}

// Depth-map data the techniques report: the standard map (4 bytes a texel) for hard and PCSS.
TEST(SampledShadows, ReportsTheDepthMapBytes) {
  for (ShadowTechnique t : {ShadowTechnique::Hard, ShadowTechnique::PCSS}) {
    SmallFrame s = builtinFrame(withTechnique(t), 3, 16, 16, 32);
    EXPECT_EQ(s.frame.shadowMapBytes, std::size_t(32) * 32 * 3 * 4);
  }
}

// ------------------------------------------------------------------------------------------------
// Every kernel of pcss.cl on tiny inputs; CTest runs these under oclgrind (invalid accesses,
// races, divergence fail the run).

namespace {
// Hand-made lights (no extraction kernels) over three quads (few triangles to rasterize):
// oclgrind simulates every work-item, and a frame of the built-in scene takes minutes.
void tinyFrame(RenderOptions ro) {
  Scene scene;
  scene.meshes.push_back(hquad("ground", -2, 2, -2, 2, 0));
  scene.meshes.push_back(hquad("blocker", -1, 0.5f, -1, 1, 0.6f));
  scene.meshes.push_back(quad("tilted", {0.8f, 0, -1}, {1.6f, 0.8f, -1}, {1.6f, 0.8f, 1}, {0.8f, 0, 1}));
  LightSet set;
  const float dirs[3][3] = {{0.3f, 1.0f, 0.2f}, {-0.5f, 0.8f, 0.1f}, {0.1f, 0.5f, -0.8f}};
  const float cosAlpha[3] = {0.95f, 0.8f, 0.99f};
  for (int i = 0; i < 3; ++i) {
    AreaLight l;
    float n = std::sqrt(dirs[i][0] * dirs[i][0] + dirs[i][1] * dirs[i][1] + dirs[i][2] * dirs[i][2]);
    l.direction = {dirs[i][0] / n, dirs[i][1] / n, dirs[i][2] / n};
    l.cosAlpha = cosAlpha[i];
    l.radiance = {1, 1, 1};
    set.lights.push_back(l);
  }
  ro.width = 12;
  ro.height = 7;
  ro.shadowMapSize = 8;
  Renderer r(ctx());
  Camera cam;
  cam.eye = {0.5f, 3, 3};
  cam.target = {0, 0, 0};
  Frame f = r.render(scene, cam, set, builtinEnvironment(16), ro);
  int geometry = 0;
  for (std::size_t i = 0; i < f.image.pixels.size(); ++i) {
    ASSERT_TRUE(std::isfinite(f.image.pixels[i]));
    if (i % 4 == 3) geometry += f.image.pixels[i] > 0.5f;
  }
  EXPECT_GT(geometry, 40);
  auto vis = r.lastVisibility();
  ASSERT_EQ(vis.size(), std::size_t(12 * 7 * 3));
  int shadowed = 0;
  for (float v : vis) {
    ASSERT_TRUE(v >= 0.0f && v <= 1.0f);
    shadowed += v < 1.0f;
  }
  EXPECT_GT(shadowed, 5);  // the blocker's shadow is in view
}
}  // namespace

TEST(OclgrindHard, TinyFrame) { tinyFrame(withTechnique(ShadowTechnique::Hard)); }

// both scans of each PCSS step: every texel (box_scan) and taps (nearest, bilinear)
TEST(OclgrindPCSS, TinyFrameEveryTexelAndTaps) {
  RenderOptions ro = withTechnique(ShadowTechnique::PCSS);
  ro.pcss.blockerTaps = 0;
  ro.pcss.filterTaps = 9;
  ro.shadow.maxFilterTexels = 64;  // boxes reaching past the map's border
  tinyFrame(ro);
  ro.pcss.blockerTaps = 9;
  ro.pcss.filterTaps = 0;
  tinyFrame(ro);
}

TEST(OclgrindBrute, TinyFrameBatchedFrontBack) {
  RenderOptions ro = withTechnique(ShadowTechnique::Brute);
  ro.brute.samples = 3;
  ro.brute.batchBytes = 2 * 8 * 8 * 4 * 2;  // two front+back map pairs a batch: batches end inside
                                            // lights
  ro.frontBackFaces = true;
  tinyFrame(ro);
}
