// MSSM4's cosine-weighted light (MSSMOptions::cosineCentroid) and light-leak reduction
// (MSSMOptions::leakReduction), kernels/shadows/moments.cl:
// 1. mssm_centroid_offset's closed form against a numerical quadrature of the same planar model
//    (the cap as a disc of radius tan(alpha) in its gnomonic plane, weight max(0, n.d)), on caps
//    wholly above the receiver's horizon, cut by it, and with their axis below it; and to first
//    order against the centroid of the cap itself on the sphere;
// 2. mssm_leak_reduction on given moments: off is the reconstruction itself, bit for bit; one
//    blocker depth over one receiver depth (the planar tests' case) is nearly untouched; a spread of
//    depths gets the documented map, and never goes below the moments' lower bound;
// 3. a frame: a light straight above flat ground moves nothing (n along the axis), a slanted one
//    moves the shadow towards the receiver's normal.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "common.hpp"
#include "shadows/mssm.hpp"
#include "support/planar_penumbra.hpp"

using namespace penumbra;
using namespace penumbra::test;

namespace {

constexpr double kPi = 3.14159265358979323846;
using V3 = dvec::D3;  // tests/common.hpp's double vectors
using dvec::cross;
using dvec::dot;
const auto unit = dvec::unitD;

struct Case {
  V3 n, w, ex, ey;
  double tanA, dist;
};

// The planar model's centroid offset along t = (n - c w) / s, in world units per unit of blocker
// distance: tan(alpha) times the weighted mean of x over the unit disc, weight max(0, c + s R x),
// by the midpoint rule over x with the chord 2 sqrt(1 - x^2) (200000 steps).
double offsetByQuadrature(double c, double s, double R) {
  const int n = 200000;
  double num = 0, den = 0;
  for (int i = 0; i < n; ++i) {
    const double x = -1 + (i + 0.5) * 2.0 / n;
    const double w = std::max(0.0, c + s * R * x) * 2 * std::sqrt(1 - x * x);
    num += w * x;
    den += w;
  }
  return den > 0 ? R * num / den : 0.0;
}

// The expected (du, dv) in texels of a map with axes ex, ey, half-sizes hx, hy and `size` texels.
std::array<double, 2> expectedMove(const Case& k, double hx, double hy, int size) {
  const double c = dot(k.n, k.w);
  const V3 t{k.n[0] - c * k.w[0], k.n[1] - c * k.w[1], k.n[2] - c * k.w[2]};
  const double s = std::sqrt(std::max(0.0, 1 - c * c));
  if (s < 1e-6) return {0, 0};
  const double off = offsetByQuadrature(c, s, k.tanA) * k.dist / s;
  return {off * dot(t, k.ex) / hx * 0.5 * size, -off * dot(t, k.ey) / hy * 0.5 * size};
}

std::vector<std::array<float, 2>> probe(const std::vector<Case>& cases, float hx, float hy,
                                        int size) {
  std::vector<float> in;
  for (const Case& k : cases) {
    for (const V3* v : {&k.n, &k.w, &k.ex, &k.ey})
      for (double x : *v) in.push_back(float(x));
    in.push_back(float(k.tanA));
    in.push_back(float(k.dist));
  }
  Context& c = ctx();
  cl::Buffer bi = c.upload(in, "test centroid cases");
  cl::Buffer bo = c.buffer(cases.size() * 2 * sizeof(float), "test centroid moves");
  cl::Kernel k = c.kernel("moments.cl", "mssm_centroid_probe", detail::prefilterOption(Prefilter::SAT));
  c.launchWith("test/mssm_centroid_probe", k, cl::NDRange(cases.size()), cl::NullRange, bi,
               cl_int(cases.size()), hx, hy, cl_int(size), bo);
  std::vector<std::array<float, 2>> out(cases.size());
  c.read(bo, out.data(), out.size() * 2 * sizeof(float), "test centroid moves");
  return out;
}

// A light frame around axis w (ex, ey orthonormal, ey = w x ex up to sign: any orientation does).
Case frameAround(V3 w, V3 n, double alphaDeg, double dist, double spin) {
  w = unit(w);
  V3 a = std::fabs(w[1]) < 0.9 ? V3{0, 1, 0} : V3{1, 0, 0};
  V3 e1 = unit(cross(a, w)), e2 = cross(w, e1);
  V3 ex{std::cos(spin) * e1[0] + std::sin(spin) * e2[0], std::cos(spin) * e1[1] + std::sin(spin) * e2[1],
        std::cos(spin) * e1[2] + std::sin(spin) * e2[2]};
  V3 ey = cross(w, ex);
  return {unit(n), w, ex, ey, std::tan(alphaDeg * kPi / 180), dist};
}

}  // namespace

// Cases: the normal from the cap's axis (0 degrees: no move) to 40 degrees past the point where
// the horizon first cuts the cap (axis below the horizon), caps of 2 to 40 degrees, random frames.
// Bounds: 2e-3 texels plus 2e-3 of the move, for float rounding of the closed form (near the cap's
// rim the segment's integrals are differences of close numbers) and its acos polynomial (2e-8).
// Measured: max 1.9e-5 texels (256-texel map). Negative control: the axis's own box (no move) misses every case
// whose expected move exceeds 0.05 texels.
TEST(CosineCentroid, OffsetMatchesQuadrature) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Case> cases;
  for (double alpha : {2.0, 10.0, 25.0, 40.0})
    for (double tiltDeg : {0.0, 20.0, 60.0, 85.0, 89.0, 95.0, 100.0, 120.0}) {
      if (tiltDeg > 90 + 0.9 * alpha) continue;  // the light wholly below: never asked
      const V3 w = unit({u(rng) - 0.5, u(rng) + 0.2, u(rng) - 0.5});
      const Case base = frameAround(w, w, alpha, 1, 0);
      const double t = tiltDeg * kPi / 180, phi = 2 * kPi * u(rng);
      const V3 side{std::cos(phi) * base.ex[0] + std::sin(phi) * base.ey[0],
                    std::cos(phi) * base.ex[1] + std::sin(phi) * base.ey[1],
                    std::cos(phi) * base.ex[2] + std::sin(phi) * base.ey[2]};
      const V3 n{std::cos(t) * w[0] + std::sin(t) * side[0], std::cos(t) * w[1] + std::sin(t) * side[1],
                 std::cos(t) * w[2] + std::sin(t) * side[2]};
      cases.push_back(frameAround(w, n, alpha, 0.3 + 2 * u(rng), 2 * kPi * u(rng)));
    }
  ASSERT_GT(cases.size(), 20u);
  for (int size : {1, 7, 256}) {
    const float hx = 1.7f, hy = 0.9f;
    const auto got = probe(cases, hx, hy, size);
    double worst = 0;
    int moved = 0;
    for (std::size_t i = 0; i < cases.size(); ++i) {
      const auto e = expectedMove(cases[i], hx, hy, size);
      const double err = std::hypot(got[i][0] - e[0], got[i][1] - e[1]);
      const double move = std::hypot(e[0], e[1]);
      worst = std::max(worst, err);
      EXPECT_LT(err, 2e-3 + 2e-3 * move) << "case " << i << " size " << size;
      if (move > 0.05) {
        ++moved;
        EXPECT_GT(move, 2e-3 + 2e-3 * move) << "control, case " << i;
      }
    }
    std::printf("[ penumbra ] centroid offset, map %d: %zu cases, %d moved > 0.05 texels, max "
                "|closed form - quadrature| %.2e texels\n",
                size, cases.size(), moved, worst);
    if (size == 256) EXPECT_GT(moved, 20);
  }
}

// The normal along the axis: no move (c = 1, s = 0), up to the float rounding of a unit normal
// (s ~ 3e-4 from c = 1 - 6e-8: measured moves of 1e-13 texels and less).
TEST(CosineCentroid, NormalAlongTheAxisDoesNotMove) {
  std::vector<Case> cases;
  for (double alpha : {1.0, 20.0, 60.0})
    cases.push_back(frameAround({0.3, 1, -0.2}, {0.3, 1, -0.2}, alpha, 5, 0.4));
  const auto got = probe(cases, 1, 1, 64);
  for (const auto& g : got) {
    EXPECT_LT(std::fabs(g[0]), 1e-6f);
    EXPECT_LT(std::fabs(g[1]), 1e-6f);
  }
}

// To first order, the planar model is the cap's own cosine-weighted centroid on the sphere
// (quadrature over the cap in solid angle, projected back to the gnomonic plane). For a 3-degree
// cap the two agree within 3% of the move (measured within 0.1%); the planar model leaves out the
// gnomonic plane's own weighting, which grows with the cap, hence "first order".
TEST(CosineCentroid, FirstOrderOfTheCapsOwnCentroid) {
  for (double alphaDeg : {3.0}) {
    const double a = alphaDeg * kPi / 180, R = std::tan(a);
    for (double tiltDeg : {30.0, 60.0, 80.0}) {
      const double t = tiltDeg * kPi / 180, c = std::cos(t), s = std::sin(t);
      // axis z, normal (s, 0, c): the sphere's weighted centroid over the cap
      double mx = 0, mz = 0, den = 0;
      const int nt = 400, np = 800;
      for (int i = 0; i < nt; ++i) {
        const double th = (i + 0.5) * a / nt;
        for (int j = 0; j < np; ++j) {
          const double ph = (j + 0.5) * 2 * kPi / np;
          const double dx = std::sin(th) * std::cos(ph), dz = std::cos(th);
          const double wgt = std::max(0.0, s * dx + c * dz) * std::sin(th);
          mx += wgt * dx;
          mz += wgt * dz;
          den += wgt;
        }
      }
      const double sphere = (mx / den) / (mz / den);  // tan of the centroid's angle from the axis
      const double planar = offsetByQuadrature(c, s, R);
      const Case k{{s, 0, c}, {0, 0, 1}, {1, 0, 0}, {0, 1, 0}, R, 1};
      const auto got = probe({k}, 1, 1, 2);  // 1 texel = 1 world unit
      std::printf("[ penumbra ] %.0f-degree cap, normal %.0f degrees off its axis: centroid move "
                  "sphere %.6f, planar model %.6f, kernel %.6f\n",
                  alphaDeg, tiltDeg, sphere, planar, double(got[0][0]));
      EXPECT_NEAR(planar, sphere, 0.03 * sphere);
      EXPECT_NEAR(got[0][0], planar, 1e-3 * planar + 1e-7);
    }
  }
}

namespace {

struct LeakOut {
  float v, wr, reduced;
};

std::vector<LeakOut> leakProbe(const std::vector<std::array<float, 6>>& cases, float bias) {
  std::vector<float> in;
  for (const auto& c : cases) in.insert(in.end(), c.begin(), c.end());
  Context& c = ctx();
  cl::Buffer bi = c.upload(in, "test leak cases");
  cl::Buffer bo = c.buffer(cases.size() * sizeof(LeakOut), "test leak results");
  cl::Kernel k = c.kernel("moments.cl", "mssm_leak_probe", detail::prefilterOption(Prefilter::SAT));
  c.launchWith("test/mssm_leak_probe", k, cl::NDRange(cases.size()), cl::NullRange, bi,
               cl_int(cases.size()), bias, bo);
  std::vector<LeakOut> out(cases.size());
  c.read(bo, out.data(), out.size() * sizeof(LeakOut), "test leak results");
  return out;
}

// Power moments (z, z^2, z^3, z^4) of atoms (depth, weight), the receiver depth and r.
std::array<float, 6> momentsCase(const std::vector<std::array<double, 2>>& atoms, double zf,
                                 double r) {
  double m[4] = {0, 0, 0, 0};
  for (const auto& a : atoms)
    for (int k = 0; k < 4; ++k) m[k] += a[1] * std::pow(a[0], k + 1);
  return {float(m[0]), float(m[1]), float(m[2]), float(m[3]), float(zf), float(r)};
}

}  // namespace

TEST(LeakReduction, OffIsTheReconstructionItself) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<std::array<float, 6>> cases;
  for (int i = 0; i < 500; ++i) {
    std::vector<std::array<double, 2>> atoms;
    double left = 1;
    const int n = 1 + i % 5;
    for (int k = 0; k < n; ++k) {
      const double w = k + 1 == n ? left : left * u(rng);
      atoms.push_back({u(rng), w});
      left -= w;
    }
    cases.push_back(momentsCase(atoms, u(rng), 0.0));
  }
  const auto out = leakProbe(cases, MSSMOptions{}.momentBias);
  int shadowed = 0;
  for (std::size_t i = 0; i < out.size(); ++i) {
    EXPECT_EQ(out[i].reduced, std::clamp(out[i].v, 0.0f, 1.0f)) << i;
    shadowed += out[i].v < 0.9f;
  }
  EXPECT_GT(shadowed, 100);  // the cases do reach into shadow
}

// One blocker depth over one receiver depth: the moments of two atoms, which the reconstruction
// gets exactly (the planar tests); the reduction scales r by d33 / 1e-5, and there d33 is mostly
// the moment bias's (~bias / 180 = 1.7e-7), so v moves by under 0.015 (measured up to 0.0085).
// A spread of depths (four atoms over [0.1, 0.95]) gets the full map,
// max(v - wr, clamp((v - r) / (1 - r))), and is darker than v wherever v < 1 - r/2.
TEST(LeakReduction, TwoDepthsKeptSpreadDepthsReduced) {
  const float r = MSSMOptions{}.leakReduction;
  ASSERT_GT(r, 0.0f);
  std::vector<std::array<float, 6>> two, spread;
  for (double w : {0.1, 0.3, 0.5, 0.7, 0.9})
    for (double zb : {0.05, 0.3, 0.6}) two.push_back(momentsCase({{zb, w}, {0.8, 1 - w}}, 0.798, r));
  for (double w : {0.1, 0.2, 0.3, 0.4})
    for (double zf : {0.5, 0.7, 0.92})
      spread.push_back(momentsCase({{0.1, w}, {0.4, w / 2}, {0.65, 0.5 - 1.5 * w / 2 + 0.05}, {0.95, 0.45 - w}}, zf, r));
  const float bias = MSSMOptions{}.momentBias;
  const auto a = leakProbe(two, bias), b = leakProbe(spread, bias);
  double worstTwo = 0;
  for (const LeakOut& o : a) worstTwo = std::max(worstTwo, double(std::fabs(o.reduced - o.v)));
  int darker = 0;
  for (std::size_t i = 0; i < b.size(); ++i) {
    const LeakOut& o = b[i];
    const float full = std::max(o.v - o.wr, std::clamp((o.v - r) / (1.0f - r), 0.0f, 1.0f));
    EXPECT_NEAR(o.reduced, full, 1e-6) << i;
    EXPECT_GE(o.reduced, o.v - o.wr - 1e-6f) << i;
    EXPECT_LE(o.reduced, o.v + 1e-6f) << i;
    if (o.v < 1 - r / 2) {
      EXPECT_LT(o.reduced, o.v) << i;
      ++darker;
    }
  }
  std::printf("[ penumbra ] leak reduction r = %.2f: two depths move by at most %.4f; %d of %zu "
              "spread cases darker\n",
              r, worstTwo, darker, b.size());
  EXPECT_LT(worstTwo, 0.015);
  EXPECT_GT(darker, 6);
}

// A frame: the planar half-plane under a light straight above (n along the axis) is the same with
// and without the centroid, bit for bit; under a 10-degree cap 50 degrees off the normal, the
// shadow's edge moves towards the point under the blocker's edge (the weighted light is higher):
// the mean visibility over the receiver rises, by about the move times the profile's slope.
TEST(CosineCentroid, FrameMovesOnlySlantedShadowsAndTowardsTheNormal) {
  PlanarPenumbra s;
  s.blockers = {{0.0, 1.0}};
  s.light = capLightAbove(15.0);
  RenderOptions on, off;
  off.mssm.cosineCentroid = false;
  on.mssm.leakReduction = off.mssm.leakReduction = 0.0f;
  const PlanarFrame a = renderPlanar(s, on), b = renderPlanar(s, off);
  ASSERT_EQ(a.receivers.size(), b.receivers.size());
  ASSERT_GT(a.receivers.size(), 1000u);
  for (std::size_t i = 0; i < a.receivers.size(); ++i)
    ASSERT_EQ(a.receivers[i].vis, b.receivers[i].vis) << i;

  // slanted: the light's axis tilted 50 degrees towards -x (the blocker covers x < 0, so the
  // shadow falls towards +x and the weighted light, higher, shortens it)
  const double t = 50 * kPi / 180;
  s.light = capLightAbove(10.0);
  s.light.direction = {float(-std::sin(t)), float(std::cos(t)), 0.0f};
  const PlanarFrame c = renderPlanar(s, on), d = renderPlanar(s, off);
  ASSERT_EQ(c.receivers.size(), d.receivers.size());
  double sumOn = 0, sumOff = 0;
  int changed = 0;
  for (std::size_t i = 0; i < c.receivers.size(); ++i) {
    sumOn += c.receivers[i].vis;
    sumOff += d.receivers[i].vis;
    changed += c.receivers[i].vis != d.receivers[i].vis;
  }
  std::printf("[ penumbra ] 10-degree cap 50 degrees off the normal: mean V %.5f with the "
              "centroid, %.5f on the axis; %d of %zu pixels changed\n",
              sumOn / c.receivers.size(), sumOff / c.receivers.size(), changed,
              c.receivers.size());
  EXPECT_GT(changed, 100);
  EXPECT_GT(sumOn, sumOff);
}
