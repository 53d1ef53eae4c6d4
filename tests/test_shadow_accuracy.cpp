// The two failure modes that made the filtered techniques worse than hard shadows over whole frames
// (issue 13), pinned on a scene whose answer is known without a reference: a unit cube standing on
// the ground under a small cap light 45 degrees off the vertical. The ground is tilted against that
// light (depth slope 1 per unit of map), so a filter that compares every texel of its box with the
// receiver's own depth sees the near half of the ground as blockers (self-shadowing of open, lit
// receivers); and the cube touches the ground, so the shadow it casts starts at the contact line,
// where a bias or a blocker search that misses small, close blockers leaks light.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <string>

#include "common.hpp"
#include "support/planar_penumbra.hpp"

using namespace penumbra;
using namespace penumbra::test;

namespace {

// The cube [-0.5, 0.5] x [0, 1] x [-0.5, 0.5] without its bottom, flat shaded.
Mesh cube() {
  Mesh m;
  m.name = "cube";
  m.positions = {{-0.5f, 0, -0.5f}, {0.5f, 0, -0.5f}, {0.5f, 0, 0.5f}, {-0.5f, 0, 0.5f},
                 {-0.5f, 1, -0.5f}, {0.5f, 1, -0.5f}, {0.5f, 1, 0.5f}, {-0.5f, 1, 0.5f}};
  m.triangles = {{4, 6, 5}, {4, 7, 6},   // top
                 {0, 1, 5}, {0, 5, 4},   // -z
                 {2, 3, 7}, {2, 7, 6},   // +z
                 {1, 2, 6}, {1, 6, 5},   // +x
                 {3, 0, 4}, {3, 4, 7}};  // -x
  return m;
}

// The light: a cap of half-angle 20 degrees (a median-cut light's typical size) towards
// (-1, 1, 0) / sqrt 2. The cube's shadow falls towards +x, out to x = 0.5 + tan(65 deg) = 2.64.
AreaLight tiltedLight() {
  AreaLight light;
  const float s = float(std::sqrt(0.5));
  light.direction = {-s, s, 0};
  light.cosAlpha = float(std::cos(20.0 * M_PI / 180));
  light.radiance = {1, 1, 1};
  return light;
}

struct Regions {
  double litMin = 1, umbraMax = 0;  // over the open ground, over the contact umbra
  int lit = 0, umbra = 0;
  double litX = 0, litZ = 0;  // where litMin is
  double litMean = 0;         // mean V over the open ground
  int litDark = 0;            // open-ground pixels with V < 0.98
};

// Visibility over two ground regions. Lit: ground the cube cannot shadow from any direction of
// the cap (beside the shadow, |z| > 1.15 > 0.5 + sqrt(2) tan 20 deg; before the cube, x < -0.7;
// past the shadow, x > 2.75). Umbra: in front of the cube's +x face, 0.52 < x < 0.75, |z| < 0.2,
// where every direction of the cap meets the cube (the top edge's penumbra starts at x = 0.5 +
// tan(25 deg) = 0.97; the side faces' at |z| = 0.5 - sqrt(2) 0.25 tan 20 deg = 0.37).
// The camera at +x, above, sees both; pixels that see the cube itself project to x < 0.5 and are
// left out.
Regions measure(RenderOptions ro) {
  PlanarPenumbra s;
  s.blockers.clear();
  s.extraMeshes = {cube()};
  s.light = tiltedLight();
  s.eye = {2.4f, 1.9f, 0.6f};
  s.target = {0.2f, 0.0f, 0.0f};
  s.fovyDeg = 70;
  s.imageWidth = 256;
  s.imageHeight = 192;
  s.keep = [](double x, double z) { return x > 0.52 || x < -0.5 || std::fabs(z) > 0.52; };
  PlanarFrame f = renderPlanar(s, ro);
  Regions r;
  for (const ReceiverPixel& p : f.receivers) {
    if (std::fabs(p.z) > 1.15 || p.x < -0.7 || p.x > 2.75) {
      if (p.vis < r.litMin) { r.litX = p.x; r.litZ = p.z; }
      r.litMin = std::min(r.litMin, p.vis);
      r.litMean += p.vis;
      r.litDark += p.vis < 0.98;
      ++r.lit;
    } else if (p.x > 0.52 && p.x < 0.75 && std::fabs(p.z) < 0.2) {
      r.umbraMax = std::max(r.umbraMax, p.vis);
      ++r.umbra;
    }
  }
  r.litMean /= std::max(r.lit, 1);
  std::printf("[ penumbra ] %s: open tilted ground mean V %.4f, min %.4f (at x %.2f, z %.2f), %d of "
              "%d pixels under 0.98; contact umbra max V %.4f over %d pixels\n",
              toString(ro.shadows), r.litMean, r.litMin, r.litX, r.litZ, r.litDark, r.lit,
              r.umbraMax, r.umbra);
  return r;
}

// The technique alone: contact shadows (tests/test_contact_shadows.cpp) would zero the strip at
// the contact line where a technique's own small-blocker check leaks, and hide its regressions.
RenderOptions withTechnique(ShadowTechnique t) {
  RenderOptions ro;
  ro.shadows = t;
  ro.shadow.contactShadows = false;
  return ro;
}

}  // namespace

// At their defaults: the open ground stays lit (mean V >= 0.995, and at most 2% of its pixels
// under 0.98: MSSM4 measured 0.7%, MSSM6 1.1%, their eq. 7 alone 67%; the few dark ones are the
// ground right in front of the cube's lit face, where the search box holds the face) and the
// contact stays dark (max V 0.05; measured 0.0002 MSSM4, 0.044 MSSM6, 0.17 with eq. 7 alone).
// PCSS keeps the ground lit but leaks 0.14 at this contact (its receiver plane reaches through
// the cube's foot); that is PCSS's own open problem, so only its open ground is asserted here.
TEST(ShadowAccuracy, TiltedOpenGroundStaysLitAndContactStaysDark) {
  for (ShadowTechnique t : {ShadowTechnique::Hard, ShadowTechnique::PCSS, ShadowTechnique::MSSM4,
                            ShadowTechnique::MSSM6}) {
    Regions r = measure(withTechnique(t));
    ASSERT_GT(r.lit, 10000) << toString(t);
    ASSERT_GT(r.umbra, 150) << toString(t);
    EXPECT_GE(r.litMean, 0.995) << toString(t);
    EXPECT_LE(r.litDark, 0.02 * r.lit) << toString(t);
    if (t != ShadowTechnique::PCSS) EXPECT_LE(r.umbraMax, 0.05) << toString(t);
  }
}

// The negative control: the same scene with MSSM4's blocker depth by eq. 7 alone (Peters et al.
// 2016's average blocker depth, the default before issue 13) darkens the open tilted ground, so
// the test above can fail and the fix is what passes it.
// The cosine centroid and the leak reduction (later fixes) are off: the control is of eq. 19 alone
// (with both on, eq. 7's contact measures 0.091 instead of 0.17).
TEST(ShadowAccuracy, AverageBlockerDepthAloneDarkensTiltedGround) {
  RenderOptions ro = withTechnique(ShadowTechnique::MSSM4);
  ro.mssm.upperBoundBlocker = false;
  ro.mssm.cosineCentroid = false;
  ro.mssm.leakReduction = 0.0f;
  Regions r = measure(ro);
  ASSERT_GT(r.lit, 10000);
  EXPECT_GT(r.litDark, 0.2 * r.lit);
  EXPECT_GT(r.umbraMax, 0.1);
}

namespace {

// Each bad value of an MSSM option is refused with Error(BadInput) naming the field.
void expectRejected(const char* field, void (*set)(RenderOptions&, float),
                    std::initializer_list<float> bad) {
  for (float v : bad) {
    RenderOptions ro = withTechnique(ShadowTechnique::MSSM4);
    set(ro, v);
    try {
      measure(ro);
      ADD_FAILURE() << field << " " << v << " was accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::BadInput);
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  }
}

}  // namespace

TEST(ShadowAccuracy, UpperBoundTiltIsChecked) {
  expectRejected("upperBoundTilt", [](RenderOptions& ro, float v) { ro.mssm.upperBoundTilt = v; },
                 {-1.0f, std::nanf(""), INFINITY});
}

TEST(ShadowAccuracy, LeakReductionIsChecked) {
  expectRejected("leakReduction", [](RenderOptions& ro, float v) { ro.mssm.leakReduction = v; },
                 {-0.1f, 1.0f, std::nanf(""), INFINITY});
}
