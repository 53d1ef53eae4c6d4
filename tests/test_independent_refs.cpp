// Whole-frame visibility of the exact-visibility techniques (bitmask, Sintorn et al. 2008; area
// approximation, Ying et al.) against a reference that shares no code with them: the cosine-weighted
// unblocked share of an OBLIQUE cap light over a half-plane blocker, integrated in double precision
// in this file (rings of the cap, each ring's lit arc in closed form). (The bitmask's check against
// Embree rays along directions the test draws itself is in test_bitmask.cpp.) The other tests of these
// techniques check them against Embree rays along the kernels' own sample directions
// (test_bitmask.cpp) or against quadratures of lights straight overhead; here the light's
// direction, frame and cap all come from this file, so a wrong light frame, a mis-tilted sample
// set or a shifted shadow edge cannot cancel out. Negative controls: the same frame against the
// reference with the edge shifted, and against the light straight overhead, must fail.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <vector>

#include "common.hpp"
#include "support/planar_penumbra.hpp"

using namespace penumbra;
using namespace penumbra::test;

namespace {

using dvec::D3;
using dvec::unitD;

// A cap of half-angle alpha around the unit direction c over the ground (normal +y), and the
// half-plane blocker {x < edge} at height h. Visibility at ground point x (independent of z):
//   V(x) = int_cap d_y [x + h d_x / d_y >= edge] dw / int_cap d_y dw.
// On the ring at angle t from c, d = cos t c + sin t (cos p e1 + sin p e2); the lit condition
// (x - edge) d_y + h d_x >= 0 reads P + Q cos p + R sin p >= 0, an arc |p - psi| <= beta with
// M cos(p - psi) = Q cos p + R sin p and cos beta = -P / M, over which the weight
// d_y = cos t c_y + sin t (e1_y cos p + e2_y sin p) integrates in closed form. Rings by the
// midpoint rule in t (dw = sin t dt dp).
struct ObliqueHalfPlane {
  D3 c, e1, e2;
  double alpha, h, edge;
  ObliqueHalfPlane(D3 dir, double alphaRad, double height, double edgeX)
      : c(unitD(dir)), alpha(alphaRad), h(height), edge(edgeX) {
    e1 = unitD(dvec::cross(c, std::fabs(c[2]) < 0.9 ? D3{0, 0, 1} : D3{1, 0, 0}));
    e2 = dvec::cross(c, e1);
  }
  double visibility(double x, int rings = 1000) const {
    const double xr = x - edge;
    double lit = 0, total = 0;
    for (int i = 0; i < rings; ++i) {
      const double t = alpha * (i + 0.5) / rings, ct = std::cos(t), st = std::sin(t);
      const double P = ct * (xr * c[1] + h * c[0]);
      const double Q = st * (xr * e1[1] + h * e1[0]), R = st * (xr * e2[1] + h * e2[0]);
      const double M = std::hypot(Q, R), psi = std::atan2(R, Q);
      double beta;  // half-width of the lit arc
      if (M <= std::fabs(P))
        beta = P >= 0 ? M_PI : 0.0;
      else
        beta = std::acos(std::clamp(-P / M, -1.0, 1.0));
      const double ringLit =
          2 * beta * ct * c[1] + st * 2 * std::sin(beta) * (e1[1] * std::cos(psi) + e2[1] * std::sin(psi));
      lit += st * ringLit;
      total += st * 2 * M_PI * ct * c[1];
    }
    return lit / total;
  }
};

// A light 8 degrees wide, tilted 25 degrees from the zenith towards +x and turned 30 degrees about
// the vertical (so its direction is oblique to the blocker's edge and its frame's axes are not the
// world's): the shadow edge moves to x = -h tan(25) cos(30) = -0.40 and the penumbra is ~0.36 wide.
const D3 kDir = {std::sin(25 * M_PI / 180) * std::cos(30 * M_PI / 180), std::cos(25 * M_PI / 180),
                 std::sin(25 * M_PI / 180) * std::sin(30 * M_PI / 180)};
const double kAlpha = 8 * M_PI / 180, kH = 1;

PlanarPenumbra obliqueScene(int mapSize = 256) {
  PlanarPenumbra s;
  const D3 u = unitD(kDir);
  s.light.direction = {float(u[0]), float(u[1]), float(u[2])};
  s.light.cosAlpha = float(std::cos(kAlpha));
  s.light.radiance = {1, 1, 1};
  s.imageWidth = 96;
  s.imageHeight = 72;
  // on the lit side, below the blocker, looking down across the penumbra around x = -0.4
  s.eye = {0.5f, 0.6f, 0.2f};
  s.target = {-0.45f, 0.0f, 0.0f};
  s.fovyDeg = 60;
  s.mapSize = mapSize;
  // a blocker shadow that leaves the ground past |z| = 3 is not the half-plane's: the rays from
  // |z| < 2.2 meet the blocker's plane within |z| < 2.2 + h tan(33) < 3
  s.border = 2.2;
  return s;
}

struct Fit {
  double rms = 0, maxErr = 0;  // over the pixels whose reference lies strictly inside (0.02, 0.98)
  int penumbra = 0, pixels = 0;
  double maxOutside = 0;       // max error over the rest (umbra and lit)
};

Fit compare(const PlanarFrame& f, const ObliqueHalfPlane& ref) {
  Fit r;
  double sq = 0;
  for (const ReceiverPixel& p : f.receivers) {
    const double v = ref.visibility(p.x, 400), e = std::fabs(p.vis - v);
    ++r.pixels;
    if (v > 0.02 && v < 0.98) {
      ++r.penumbra;
      sq += e * e;
      r.maxErr = std::max(r.maxErr, e);
    } else {
      r.maxOutside = std::max(r.maxOutside, e);
    }
  }
  r.rms = std::sqrt(sq / std::max(1, r.penumbra));
  return r;
}

// The reference's own error: the midpoint rule in t converges as 1/rings^2 except where a ring is
// tangent to the lit boundary (a square-root edge), so the difference between 400 and 4000 rings
// bounds it. Measured: at most 2.0e-5 across the penumbra (bound 1e-4).
// Also checked: the ring integral equals the straight-overhead closed form's limits (V = 1/2 at
// the edge's projection when the light is overhead, by symmetry).
TEST(IndependentRefs, ObliqueHalfPlaneQuadratureConverges) {
  ObliqueHalfPlane ref(kDir, kAlpha, kH, 0);
  double worst = 0;
  for (int i = 0; i <= 200; ++i) {
    const double x = -0.8 + 0.8 * i / 200;
    worst = std::max(worst, std::fabs(ref.visibility(x, 400) - ref.visibility(x, 4000)));
  }
  std::printf("[ indep    ] oblique half-plane quadrature: max |400 - 4000 rings| %.2e\n", worst);
  EXPECT_LT(worst, 1e-4);
  ObliqueHalfPlane overhead({0, 1, 0}, kAlpha, kH, 0);
  EXPECT_NEAR(overhead.visibility(0.0), 0.5, 1e-9);
  EXPECT_NEAR(overhead.visibility(-0.5), 0.0, 1e-12);  // beyond h tan(alpha) = 0.14: umbra
  EXPECT_NEAR(overhead.visibility(0.5), 1.0, 1e-12);
  // and it agrees with the fixture's own overhead quadrature (a different ring decomposition)
  for (double x : {-0.1, -0.05, 0.02, 0.09})
    EXPECT_NEAR(overhead.visibility(x, 4000), halfPlaneVisibilityByRings(x, kH, kAlpha), 2e-4) << x;
  // the oblique edge sits where the light's centre ray grazes it: V(-h d_x / d_y) ~ 1/2
  const D3 u = unitD(kDir);
  EXPECT_NEAR(ref.visibility(-kH * u[0] / u[1]), 0.5, 0.02);
}

// Bitmask (1024 light samples) on the oblique half-plane. Its error is the sample set's: 1024
// points of the light's disk, weighted, approximate the lit share; the visibility itself is exact
// (no map texels). Measured (96x72, 909 penumbra pixels): rms 0.0015, max 0.0050; outside the
// penumbra max 0.0022. Bounds: rms 0.005, max 0.02 (3-4x). Negative controls: the same frame
// against the reference with the edge shifted by 0.005 (a fifth of a 256-map texel, 1/70 of the
// penumbra) and by 0.03, and against the light straight overhead, must fail them.
TEST(IndependentRefs, BitmaskMatchesObliqueHalfPlaneQuadrature) {
  RenderOptions ro;
  ro.shadows = ShadowTechnique::Bitmask;
  ro.bitmask.lightSamples = 1024;
  const PlanarFrame f = renderPlanar(obliqueScene(), ro);
  const Fit fit = compare(f, ObliqueHalfPlane(kDir, kAlpha, kH, 0));
  const Fit nudged = compare(f, ObliqueHalfPlane(kDir, kAlpha, kH, 0.005));
  const Fit shifted = compare(f, ObliqueHalfPlane(kDir, kAlpha, kH, 0.03));
  const Fit overhead = compare(f, ObliqueHalfPlane({0, 1, 0}, kAlpha, kH, 0));
  std::printf("[ indep    ] bitmask 1024 on the oblique half-plane: %d pixels, %d penumbra; rms "
              "%.4f max %.4f, outside %.4f; edge shifted 0.005: rms %.4f, 0.03: rms %.4f; "
              "overhead light: rms %.4f\n",
              fit.pixels, fit.penumbra, fit.rms, fit.maxErr, fit.maxOutside, nudged.rms,
              shifted.rms, overhead.rms);
  ASSERT_GT(fit.penumbra, 300);
  EXPECT_LT(fit.rms, 0.005);
  EXPECT_LT(fit.maxErr, 0.02);
  EXPECT_LT(fit.maxOutside, 0.02);
  // negative controls: a wrong reference must fail the same criterion
  EXPECT_GT(nudged.rms, 0.005);
  EXPECT_GT(shifted.rms, 0.005);
  EXPECT_GT(std::max(overhead.rms, overhead.maxOutside), 0.02);
}

// Area approximation on the same configuration. Unlike the bitmask it reads its crossings from
// depth maps, so its error is first order in the map's texel: a crossing misplaced by a texel tau
// (world, at most 6 sqrt 2 / S across the light's view of the ground) over the blocker height h
// moves a chord of the light's disk (gnomonic radius r = tan 8 deg) by tau / h, changing the lit
// share by at most 2 (tau / h) / (pi r): 0.15 at S = 256, 0.075 at 512. Measured: rms 0.0273 /
// 0.0145, max 0.084 / 0.045 at 256 / 512 (0.060 / 0.0075 rms at 128 / 1024: halving with the
// texel). Bounds: max within the derived budget at both sizes, rms at 512 below 0.03 (2x), and
// the error must fall with the texel (rms at 512 <= 0.7 of that at 256; a systematic error, such
// as a mis-tilted light frame or a wrong polygon, would not fall). The cap is stood in for by an
// area-matched 16-gon (capVertices), within 1.3% of the cap's radius. Negative controls: the 512
// frame against the edge shifted by 0.03 (1.8 texels) and against the overhead light must fail.
TEST(IndependentRefs, AreaApproxMatchesObliqueHalfPlaneQuadrature) {
  RenderOptions ro;
  ro.shadows = ShadowTechnique::AreaApprox;
  ro.areaApprox.capVertices = 16;
  ro.areaApprox.edgeSamples = 1;
  ro.areaApprox.taps = 8;
  const ObliqueHalfPlane ref(kDir, kAlpha, kH, 0);
  const Fit coarse = compare(renderPlanar(obliqueScene(256), ro), ref);
  const PlanarFrame f = renderPlanar(obliqueScene(512), ro);
  const Fit fit = compare(f, ref);
  const Fit shifted = compare(f, ObliqueHalfPlane(kDir, kAlpha, kH, 0.03));
  const Fit overhead = compare(f, ObliqueHalfPlane({0, 1, 0}, kAlpha, kH, 0));
  std::printf("[ indep    ] area-approx (16-gon, 1 per edge, 8 taps) on the oblique half-plane: "
              "%d penumbra pixels; map 256: rms %.4f max %.4f, outside %.4f; map 512: rms %.4f "
              "max %.4f, outside %.4f; edge shifted 0.03: rms %.4f; overhead light: rms %.4f\n",
              fit.penumbra, coarse.rms, coarse.maxErr, coarse.maxOutside, fit.rms, fit.maxErr,
              fit.maxOutside, shifted.rms, overhead.rms);
  auto budget = [](int S) {
    return 2 * (6 * std::sqrt(2.0) / S / kH) / (M_PI * std::tan(kAlpha));
  };
  ASSERT_GT(fit.penumbra, 300);
  EXPECT_LT(std::max(coarse.maxErr, coarse.maxOutside), budget(256));
  EXPECT_LT(std::max(fit.maxErr, fit.maxOutside), budget(512));
  EXPECT_LT(fit.rms, 0.03);
  EXPECT_LE(fit.rms, 0.7 * coarse.rms);
  EXPECT_GT(shifted.rms, 0.03);
  EXPECT_GT(std::max(overhead.rms, overhead.maxOutside), budget(512));
}

}  // namespace
