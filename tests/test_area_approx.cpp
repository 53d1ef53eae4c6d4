// Area approximation for polygonal lights (Ying et al. 2002; src/shadows/area.cpp,
// kernels/shadows/area.cl).   - the visible-area estimate (kernels/shadows/area.cl's area_ratio)
// against a plain C++ reference on     awkward case counts, and the reference itself against exact
// polygon clipping;   - whole frames on synthetic planar cases (a straight occluder edge crossing
// the light, a     corner, fully lit, fully blocked) against the exact solid-angle visibility and
// against the     method's own ideal (exact point visibilities and crossing points);
//   - determinism, bad options, every extracted light set (caps), the default scene against brute
//     force with many samples on the same lights, and tiny inputs under oclgrind (Oclgrind*).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <random>
#include <vector>

#include "common.hpp"
#include "support/planar_penumbra.hpp"

using namespace penumbra;
using namespace penumbra::test;

namespace {

using P2 = std::array<double, 2>;

double cross2(P2 a, P2 b) { return a[0] * b[1] - a[1] * b[0]; }

using P3 = std::array<double, 3>;
P3 dirOf(P2 q) { return {q[0], q[1], 1.0}; }  // a gnomonic point as a direction (light's frame)
double dot3(P3 a, P3 b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

// Irradiance (times 2, over unit radiance) a convex polygon of directions sends normal n: clipped
// by the horizon n.w >= 0 (Sutherland-Hodgman), then Lambert's formula sum_i Theta_i n.g_i.
double irradiance(const std::vector<P3>& poly, P3 n) {
  std::vector<P3> c;
  for (std::size_t i = 0; i < poly.size(); ++i) {
    P3 a = poly[i], b = poly[(i + 1) % poly.size()];
    double da = dot3(n, a), db = dot3(n, b);
    if (da >= 0) c.push_back(a);
    if ((da >= 0) != (db >= 0)) {
      double t = da / (da - db);
      c.push_back({a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2])});
    }
  }
  double e = 0;
  for (std::size_t i = 0; c.size() >= 3 && i < c.size(); ++i) {
    P3 a = c[i], b = c[(i + 1) % c.size()];
    P3 g = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
    double len = std::sqrt(dot3(g, g));
    if (len > 0) e += std::atan2(len, dot3(a, b)) * dot3(n, g) / len;
  }
  return e;
}

double irradiance2(const std::vector<P2>& poly, P3 n) {
  std::vector<P3> d;
  for (P2 q : poly) d.push_back(dirOf(q));
  return irradiance(d, n);
}

// Plain C++ reference of kernels/shadows/area.cl's area_ratio: the lit boundary runs, each entered
// and left at its crossing points and closed by the chord between them (Ying et al. 2002 §2, Figure
// 1), as
// explicit polygons; S_e / S_a = their irradiance over the whole light's on normal n (light's
// frame). seg[k] is the lit share of segment k -> k+1, lying next to its lit end.
double refAreaRatio(const std::vector<P2>& q, std::uint64_t lit, const std::vector<double>& seg,
                    P3 n = {0, 0, 1}) {
  const int n_ = int(q.size());
  auto isLit = [&](int k) { return ((lit >> k) & 1) != 0; };
  int litCount = 0;
  for (int k = 0; k < n_; ++k) litCount += isLit(k);
  if (litCount == n_) return 1.0;
  if (litCount == 0) return 0.0;
  double total = irradiance2(q, n);
  if (total == 0) return 1.0;
  auto lerp = [](P2 a, P2 b, double t) { return P2{a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])}; };
  double e = 0;
  int start = 0;
  while (isLit(start)) ++start;  // a blocked sample
  std::vector<P2> run;
  for (int s = 1; s <= n_; ++s) {
    int k = (start + s) % n_, prev = (start + s - 1) % n_;
    if (isLit(k) && !isLit(prev)) run = {lerp(q[prev], q[k], 1 - seg[prev])};
    if (isLit(k)) run.push_back(q[k]);
    if (!isLit(k) && isLit(prev)) {
      run.push_back(lerp(q[prev], q[k], seg[prev]));
      e += irradiance2(run, n);
    }
  }
  return std::clamp(e / total, 0.0, 1.0);
}

// The convex polygon q clipped to the half-plane a.x + b.y + c >= 0 (Sutherland-Hodgman).
std::vector<P2> clipped(const std::vector<P2>& q, double a, double b, double c) {
  std::vector<P2> out;
  const int n = int(q.size());
  for (int i = 0; i < n; ++i) {
    P2 p = q[i], r = q[(i + 1) % n];
    double fp = a * p[0] + b * p[1] + c, fr = a * r[0] + b * r[1] + c;
    if (fp >= 0) out.push_back(p);
    if ((fp >= 0) != (fr >= 0)) {
      double t = fp / (fp - fr);
      out.push_back({p[0] + t * (r[0] - p[0]), p[1] + t * (r[1] - p[1])});
    }
  }
  return out;
}
// The irradiance share of the part of q where a.x + b.y + c >= 0: the exact visibility for one
// straight boundary, computed independently of the run walk.
double clippedShare(const std::vector<P2>& q, double a, double b, double c, P3 n) {
  return irradiance2(clipped(q, a, b, c), n) / irradiance2(q, n);
}

// Boundary samples of a convex outline: each vertex and m evenly spaced points of its edge.
std::vector<P2> boundary(const std::vector<P2>& outline, int m) {
  std::vector<P2> s;
  for (std::size_t i = 0; i < outline.size(); ++i) {
    P2 a = outline[i], b = outline[(i + 1) % outline.size()];
    for (int j = 0; j <= m; ++j) {
      double t = double(j) / (m + 1);
      s.push_back({a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])});
    }
  }
  return s;
}

std::vector<P2> regularPolygon(int n, double radius, double turn) {
  std::vector<P2> q;
  for (int i = 0; i < n; ++i)
    q.push_back({radius * std::cos(turn + 2 * M_PI * i / n), radius * std::sin(turn + 2 * M_PI * i / n)});
  return q;
}

// Point visibilities and exact lit shares of every segment for a boundary `inside` lights.
void exactInputs(const std::vector<P2>& q, const std::function<bool(P2)>& litAt, std::uint64_t& lit,
                 std::vector<double>& seg) {
  const int n = int(q.size());
  lit = 0;
  for (int k = 0; k < n; ++k)
    if (litAt(q[k])) lit |= std::uint64_t(1) << k;
  seg.assign(n, 0.5);
  for (int k = 0; k < n; ++k) {
    int k1 = (k + 1) % n;
    bool a = (lit >> k) & 1, b = (lit >> k1) & 1;
    if (a == b) continue;
    P2 litEnd = a ? q[k] : q[k1], dark = a ? q[k1] : q[k];
    double lo = 0, hi = 1;  // bisection for the crossing, parameter from the lit end
    for (int it = 0; it < 50; ++it) {
      double mid = 0.5 * (lo + hi);
      P2 p{litEnd[0] + mid * (dark[0] - litEnd[0]), litEnd[1] + mid * (dark[1] - litEnd[1])};
      (litAt(p) ? lo : hi) = mid;
    }
    seg[k] = 0.5 * (lo + hi);
  }
}

// Runs kernels/shadows/area.cl's area_ratio_cases on `cases` random inputs over boundary q;
// compares with the reference. Random masks with runs (not only single bits) and random segment
// shares.
void expectRatioKernelMatches(const std::vector<P2>& q, int cases, unsigned seed) {
  const int n = int(q.size());
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(0, 1);
  std::vector<cl_float2> qf;
  for (P2 p : q) qf.push_back(cl_float2{{float(p[0]), float(p[1])}});
  std::vector<cl_ulong> lits(cases);
  std::vector<float> segs(std::size_t(cases) * n);
  std::vector<cl_float4> nrms(cases);
  std::vector<double> expect(cases);
  for (int c = 0; c < cases; ++c) {
    std::uint64_t lit = 0;
    if (c == 0) lit = 0;                                               // fully blocked
    else if (c == 1) lit = n == 64 ? ~std::uint64_t(0) : (std::uint64_t(1) << n) - 1;  // fully lit
    else {
      bool on = U(rng) < 0.5;
      for (int k = 0; k < n; ++k) {
        if (U(rng) < 0.25) on = !on;
        if (on) lit |= std::uint64_t(1) << k;
      }
    }
    std::vector<double> seg(n);
    std::vector<P2> qs(q);
    for (int k = 0; k < n; ++k) {
      seg[k] = double(float(U(rng)));
      segs[std::size_t(c) * n + k] = float(seg[k]);
    }
    lits[c] = lit;
    // normals up to 60 degrees from the light's centre: wide lights then cross the horizon
    double nx = U(rng) - 0.5, ny = U(rng) - 0.5, nz = 0.5 + 0.5 * U(rng);
    double nl = std::sqrt(nx * nx + ny * ny + nz * nz);
    nrms[c] = cl_float4{{float(nx / nl), float(ny / nl), float(nz / nl), 0}};
    // the kernel reads float positions and normals: give the reference the same
    for (auto& p : qs) p = {double(float(p[0])), double(float(p[1]))};
    expect[c] = refAreaRatio(qs, lit, seg, {nrms[c].s[0], nrms[c].s[1], nrms[c].s[2]});
  }
  Context& cx = ctx();
  cl::Buffer qb = cx.upload(qf, "area test q"), lb = cx.upload(lits, "area test lit"),
             sb = cx.upload(segs, "area test seg"), nb = cx.upload(nrms, "area test normals");
  cl::Buffer ob = cx.buffer(std::size_t(cases) * sizeof(float), "area test out");
  cl::Kernel k = cx.kernel("area.cl", "area_ratio_cases");
  k.setArg(0, qb);
  k.setArg(1, cl_int(n));
  k.setArg(2, lb);
  k.setArg(3, sb);
  k.setArg(4, nb);
  k.setArg(5, cl_int(cases));
  k.setArg(6, ob);
  cx.launch("area test", k, cl::NDRange(std::size_t(cases)));
  auto got = cx.download<float>(ob, std::size_t(cases), "area test out");
  for (int c = 0; c < cases; ++c) {
    // float atan2 and cross products per edge: a few ulps of the total per term
    EXPECT_NEAR(got[c], expect[c], 2e-5 * n) << "case " << c << " of " << cases << ", n " << n;
  }
  EXPECT_EQ(got[0], 0.0f);
  if (cases > 1) EXPECT_EQ(got[1], 1.0f);
}

}  // namespace

// The reference is exact for one straight boundary given the exact crossings (the paper's case):
// against polygon clipping, on a triangle, a square and an octagon with 0..3 samples per edge, on
// normals up to 60 degrees off the light (some lights then cross the horizon).
TEST(AreaApprox, ReferenceIsExactForOneStraightBoundary) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> U(-1, 1);
  for (int nv : {3, 4, 8})
    for (int m = 0; m <= 3; ++m) {
      auto q = boundary(regularPolygon(nv, 0.3, 0.2), m);
      for (int trial = 0; trial < 50; ++trial) {
        double th = M_PI * U(rng), a = std::cos(th), b = std::sin(th), c = 0.3 * U(rng);
        double tn = M_PI / 3 * (0.5 + 0.5 * U(rng)), pn = M_PI * U(rng);
        P3 nrm = {std::sin(tn) * std::cos(pn), std::sin(tn) * std::sin(pn), std::cos(tn)};
        std::uint64_t lit;
        std::vector<double> seg;
        exactInputs(q, [&](P2 p) { return a * p[0] + b * p[1] + c >= 0; }, lit, seg);
        EXPECT_NEAR(refAreaRatio(q, lit, seg, nrm), clippedShare(q, a, b, c, nrm), 1e-9)
            << nv << "-gon, " << m << " per edge, line " << a << " " << b << " " << c;
      }
    }
}

// A bar across the light (two straight boundaries, two lit runs): both lit sides are kept. The bar
// holds at least one boundary sample of each edge it crosses (samples 1/5 of the side apart);
// narrower bars between two samples go unseen, as Ying et al.'s (2002) boundary sampling implies.
TEST(AreaApprox, ReferenceKeepsBothSidesOfABar) {
  const double h = 1 / std::sqrt(2.0);
  auto q = boundary(regularPolygon(4, 1.0, M_PI / 4), 4);  // the square [-h, h]^2
  for (double x0 : {-0.55, -0.2, 0.1})
    for (double w : {0.3, 0.45}) {
      std::uint64_t lit;
      std::vector<double> seg;
      exactInputs(q, [&](P2 p) { return p[0] < x0 || p[0] > x0 + w; }, lit, seg);
      auto strip = clipped(clipped(q, 1, 0, -x0), -1, 0, x0 + w);
      P3 up = {0, 0, 1};
      double expect = 1 - irradiance2(strip, up) / irradiance2(q, up);
      EXPECT_NEAR(refAreaRatio(q, lit, seg), expect, 1e-9) << "bar at " << x0 << " width " << w;
    }
}

// kernels/shadows/area.cl against the reference on awkward case counts (1, odd, more than a
// work-group) and boundary sizes (a triangle's 3, an octagon with one sample per edge, the 64
// maximum).
TEST(AreaApprox, RatioKernelMatchesReference) {
  expectRatioKernelMatches(boundary(regularPolygon(3, 0.2, 0.0), 0), 2, 1);
  expectRatioKernelMatches(boundary(regularPolygon(8, 0.2, 0.1), 1), 37, 2);
  expectRatioKernelMatches(boundary(regularPolygon(8, 1.5, 0.3), 7), 1029, 3);
  expectRatioKernelMatches(boundary(regularPolygon(5, 0.05, 0.0), 3), 1, 4);
}

namespace {

Mesh hquad(const std::string& name, float x0, float x1, float z0, float z1, float y) {
  Mesh m;
  m.name = name;
  m.positions = {{x0, y, z0}, {x1, y, z0}, {x1, y, z1}, {x0, y, z1}};
  m.triangles = {{0, 2, 1}, {0, 3, 2}};
  return m;
}

// A square polygon light around +y, gnomonic half-diagonal r, turned by `turn` about y.
AreaLight squareLight(double r, double turn) {
  std::vector<std::array<float, 3>> v;
  for (int i = 0; i < 4; ++i) {
    double a = turn + M_PI / 2 * i;
    double x = r * std::cos(a), z = r * std::sin(a), l = std::sqrt(1 + x * x + z * z);
    v.push_back({float(x / l), float(1 / l), float(z / l)});
  }
  return makePolygonLight(v, {1, 1, 1});
}

// tests/support's planar configuration with the blocker quad [-3,bx1] x [-3,bz1] at height h (bz1 =
// 3: a half-plane), quads without normals, one light; the camera below the blocker looks across
// its shadow. Ground pixels within 2.5 of the origin.
std::vector<ReceiverPixel> planarFrame(const AreaLight& light, RenderOptions ro, double h,
                                       float bx1, float bz1, std::vector<float>* visOut = nullptr) {
  PlanarPenumbra s;
  s.blockers = {{double(bx1), h, -3.0, bz1}};
  s.vertexNormals = false;
  s.light = light;
  s.eye = {1.3f, -1.0f, 1.3f};
  s.target = {bx1 - 0.4f, 0, std::min(bz1, 0.5f) - 0.4f};
  s.fovyDeg = 60;
  s.mapSize = ro.shadowMapSize;
  s.border = 2.5;
  PlanarFrame f = renderPlanar(s, ro);
  if (visOut) *visOut = f.visibility;
  return f.receivers;
}

// Gnomonic outline of a polygon light about +y: (d.x, d.z) / d.y (a light around +y).
std::vector<P2> outlineAboutY(const AreaLight& l) {
  std::vector<P2> q;
  for (auto& v : l.vertices) q.push_back({v[0] / double(v[1]), v[2] / double(v[1])});
  double A = 0;
  for (std::size_t i = 0; i < q.size(); ++i) A += cross2(q[i], q[(i + 1) % q.size()]);
  if (A < 0) std::reverse(q.begin(), q.end());
  return q;
}

bool insideConvex(const std::vector<P2>& q, P2 p) {
  for (std::size_t i = 0; i < q.size(); ++i) {
    P2 a = q[i], b = q[(i + 1) % q.size()];
    if (cross2({b[0] - a[0], b[1] - a[1]}, {p[0] - a[0], p[1] - a[1]}) < 0) return false;
  }
  return true;
}

// Exact irradiance-weighted share of the light a receiver on the ground (normal = the light's
// centre +y) sees: quadrature over the gnomonic plane, the solid-angle density (1 + |q|^2)^(-3/2)
// times the cosine (1 + |q|^2)^(-1/2).
double exactVisibility(const std::vector<P2>& outline, const std::function<bool(P2)>& litAt) {
  double lo[2] = {1e9, 1e9}, hi[2] = {-1e9, -1e9};
  for (P2 p : outline)
    for (int a = 0; a < 2; ++a) lo[a] = std::min(lo[a], p[a]), hi[a] = std::max(hi[a], p[a]);
  const int N = 200;
  double lit = 0, total = 0;
  for (int i = 0; i < N; ++i)
    for (int j = 0; j < N; ++j) {
      P2 p{lo[0] + (hi[0] - lo[0]) * (i + 0.5) / N, lo[1] + (hi[1] - lo[1]) * (j + 0.5) / N};
      if (!insideConvex(outline, p)) continue;
      double w = std::pow(1 + p[0] * p[0] + p[1] * p[1], -2.0);
      total += w;
      if (litAt(p)) lit += w;
    }
  return lit / total;
}

struct PlanarStats {
  double maxVsIdeal = 0, rmsVsIdeal = 0, maxIdealVsExact = 0, maxVsExact = 0, rmsVsExact = 0;
  int pixels = 0, penumbra = 0, lit = 0, dark = 0, litExact = 0, darkExact = 0;
};

// One planar case: the blocker {x' < bx1, z' < bz1} at height h (bz1 = 3: a half-plane).
// Receivers whose every ray to the light stays 2 sample-map texels (world 2 * 2 * 3 sqrt 2 / S at
// most) clear of the blocker's edges must come out exactly lit or exactly blocked.
PlanarStats planarCase(const char* what, const AreaLight& light, RenderOptions ro, double h,
                       float bx1, float bz1) {
  auto px = planarFrame(light, ro, h, bx1, bz1);
  const double margin = 2 * 2 * 3 * std::sqrt(2.0) / ro.shadowMapSize;
  const auto outline = outlineAboutY(light);
  const auto q = boundary(outline, ro.areaApprox.edgeSamples);
  PlanarStats s;
  double sqI = 0, sqE = 0;
  for (const ReceiverPixel& r : px) {
    // direction with gnomonic q reaches the blocker's plane at (x + h q0, z + h q1)
    auto litAt = [&](P2 g) { return !(r.x + h * g[0] < bx1 && r.z + h * g[1] < bz1); };
    // the blocked directions are the convex set {g0 < (bx1 - x) / h, g1 < (bz1 - z) / h}: the light
    // is wholly blocked when every vertex is, wholly lit when its part with g0 below the bound has
    // no point with g1 below the other
    const double gx = (bx1 - r.x) / h, gz = (bz1 - r.z) / h, gm = margin / h;
    bool surelyDark = true;
    for (P2 v : outline) surelyDark = surelyDark && v[0] < gx - gm && v[1] < gz - gm;
    bool surelyLit = true;
    for (P2 v : clipped(outline, -1, 0, gx + gm)) surelyLit = surelyLit && v[1] >= gz + gm;
    std::uint64_t lit;
    std::vector<double> seg;
    exactInputs(q, litAt, lit, seg);
    double ideal = refAreaRatio(q, lit, seg);
    double exact = surelyLit ? 1.0 : surelyDark ? 0.0 : exactVisibility(outline, litAt);
    ++s.pixels;
      s.lit += r.vis == 1.0;
    s.dark += r.vis == 0.0;
    s.litExact += surelyLit;
    s.darkExact += surelyDark;
    if (surelyLit) EXPECT_EQ(r.vis, 1.0) << what << " fully lit at " << r.x << " " << r.z;
    if (surelyDark) EXPECT_EQ(r.vis, 0.0) << what << " fully blocked at " << r.x << " " << r.z;
    double eI = std::fabs(r.vis - ideal), eE = std::fabs(r.vis - exact);
    s.maxVsIdeal = std::max(s.maxVsIdeal, eI);
    s.maxIdealVsExact = std::max(s.maxIdealVsExact, std::fabs(ideal - exact));
    s.maxVsExact = std::max(s.maxVsExact, eE);
    if (exact > 0 && exact < 1) {
      ++s.penumbra;
      sqI += eI * eI;
      sqE += eE * eE;
    }
  }
  s.rmsVsIdeal = std::sqrt(sqI / std::max(1, s.penumbra));
  s.rmsVsExact = std::sqrt(sqE / std::max(1, s.penumbra));
  std::printf("[ penumbra ] %s (%d per edge, %d taps): %d pixels, %d penumbra; vs the method's "
              "ideal max %.4f rms %.4f; ideal vs exact max %.4f; vs exact max %.4f rms %.4f\n",
              what, ro.areaApprox.edgeSamples, ro.areaApprox.taps, s.pixels, s.penumbra,
              s.maxVsIdeal, s.rmsVsIdeal, s.maxIdealVsExact, s.maxVsExact, s.rmsVsExact);
  return s;
}

RenderOptions areaOptions(int edgeSamples, int taps, int mapSize = 256) {
  RenderOptions ro;
  ro.shadows = ShadowTechnique::AreaApprox;
  ro.areaApprox.edgeSamples = edgeSamples;
  ro.areaApprox.taps = taps;
  ro.shadowMapSize = mapSize;
  return ro;
}

}  // namespace

// A straight occluder edge crossing the light (a half-plane blocker x < 0 at height 1) under a
// square light of 10 degrees half-width turned by 30 degrees, so the shadow boundary cuts its
// edges obliquely. With exact crossings the method is exact for one straight boundary (the lit
// part is a polygon of great arcs, measured by Lambert's formula), so:
//   - the ideal (exact point visibilities and crossings) against the quadrature of the exact
//     share differs by the quadrature alone: the cells the boundary line crosses, at most
//     2 (light diameter) / cell of them, each off by at most its area, over the light's weighted
//     area (>= area * w_min, w_min = (1 + r^2)^(-2) the smallest density);
//   - against its ideal only the depth maps' error is left: a crossing misplaced along the
//     light's edge by e (gnomonic) moves the chord's end and changes the lit part by at most
//     e * (light diameter) / 2 per crossing, two crossings, over the weighted area. e is a texel
//     of the sample maps (world 2 * 3 sqrt 2 / S at most, over h) plus half a tap step (segment
//     length / (2 taps)).
TEST(AreaApprox, StraightEdgeAcrossTheLight) {
  const double r = std::tan(10 * M_PI / 180) * std::sqrt(2.0), h = 1;
  AreaLight light = squareLight(r, M_PI / 6);
  const double side = r * std::sqrt(2.0), diameter = 2 * r, area = side * side;
  const double wmin = std::pow(1 + r * r, -2.0);
  const double cell = diameter / 200;  // exactVisibility's grid over the light's bounding box
  const double quadrature = 2 * diameter / cell * cell * cell / (area * wmin);
  for (int m : {0, 1}) {
    RenderOptions ro = areaOptions(m, 4);
    PlanarStats s = planarCase("half-plane", light, ro, h, 0.0f, 3.0f);
    ASSERT_GT(s.penumbra, 300);
    ASSERT_GT(s.litExact, 50);
    ASSERT_GT(s.darkExact, 50);
    const double texel = 2 * 3 * std::sqrt(2.0) / ro.shadowMapSize / h;
    const double e = texel + side / (m + 1) / (2 * ro.areaApprox.taps);
    const double mapBound = 2 * e * diameter / 2 / (area * wmin);
    EXPECT_LT(s.maxIdealVsExact, quadrature);
    EXPECT_LT(s.maxVsIdeal, mapBound);
    EXPECT_LT(s.maxVsExact, mapBound + quadrature);
  }
}

// The crossing estimate (Heidrich's linear-light visibility from one map) against the midpoint
// rule (taps = 0): on the half-plane case the taps place the boundary, the midpoint cannot.
TEST(AreaApprox, TapsPlaceTheBoundaryBetterThanTheMidpoint) {
  AreaLight light = squareLight(std::tan(10 * M_PI / 180) * std::sqrt(2.0), M_PI / 6);
  PlanarStats mid = planarCase("half-plane midpoint", light, areaOptions(0, 0), 1, 0.0f, 3.0f);
  PlanarStats taps = planarCase("half-plane 8 taps", light, areaOptions(0, 8), 1, 0.0f, 3.0f);
  EXPECT_LT(taps.rmsVsExact, 0.5 * mid.rmsVsExact);
}

// A corner of the blocker (x < 0 and z < 0) inside the light: the shadow boundary bends, the
// chord between two crossings cuts the bend off, and more samples per edge shrink that error
// (the paper's claim that few samples suffice, here quantified). Fully lit and fully blocked
// receivers stay exact (checked per pixel in planarCase).
TEST(AreaApprox, BlockerCornerConvergesWithEdgeSamples) {
  AreaLight light = squareLight(std::tan(10 * M_PI / 180) * std::sqrt(2.0), M_PI / 6);
  std::vector<double> err;
  for (int m : {0, 1, 3}) {
    PlanarStats s = planarCase("corner", light, areaOptions(m, 4), 1, 0.0f, 0.0f);
    ASSERT_GT(s.penumbra, 300);
    err.push_back(s.rmsVsExact);
  }
  // A bend inside the light is invisible to boundary samples however many (the chord cuts it
  // off: up to 0.3 of the light here, printed as "ideal vs exact"); samples nearer a bend that
  // lies near the boundary still help, so the rms falls.
  EXPECT_LT(err[2], err[0]);
}

// The same frame twice: identical visibility (no atomics, no races).
TEST(AreaApprox, Deterministic) {
  AreaLight light = squareLight(0.25, 0.3);
  std::vector<float> a, b;
  planarFrame(light, areaOptions(1, 4, 128), 1, 0.0f, 0.5f, &a);
  planarFrame(light, areaOptions(1, 4, 128), 1, 0.0f, 0.5f, &b);
  ASSERT_EQ(a.size(), b.size());
  EXPECT_TRUE(a == b);
  EXPECT_TRUE(std::any_of(a.begin(), a.end(), [](float v) { return v > 0 && v < 1; }));
}

TEST(AreaApprox, BadOptionsNameTheParameter) {
  AreaLight light = squareLight(0.25, 0.3);
  auto expectBad = [&](RenderOptions ro, const std::string& name) {
    try {
      planarFrame(light, ro, 1, 0.0f, 0.5f);
      ADD_FAILURE() << "no error for " << name;
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::BadInput);
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    }
  };
  RenderOptions ro = areaOptions(-1, 4, 32);
  expectBad(ro, "RenderOptions.areaApprox.edgeSamples");
  ro = areaOptions(1, 65, 32);
  expectBad(ro, "RenderOptions.areaApprox.taps");
  ro = areaOptions(1, 4, 32);
  ro.areaApprox.capVertices = 2;
  expectBad(ro, "RenderOptions.areaApprox.capVertices");
  // an octagon with 8 samples per edge would need 72 maps per light (the kernel keeps 64 bits)
  std::vector<std::array<float, 3>> v;
  for (int i = 0; i < 8; ++i) {
    double a = 2 * M_PI * i / 8, x = 0.2 * std::cos(a), z = 0.2 * std::sin(a), l = std::sqrt(1 + x * x + z * z);
    v.push_back({float(x / l), float(1 / l), float(z / l)});
  }
  light = makePolygonLight(v, {1, 1, 1});
  expectBad(areaOptions(8, 4, 32), "RenderOptions.areaApprox.edgeSamples");
}

// Extracted light sets are caps (median cut's default): area-approx runs on them, each cap an
// area-matched octagon, and on the default scene it is closer to brute force with many samples on
// the same lights than hard shadows are (a technique that got the penumbrae wrong would not be).
TEST(AreaApprox, DefaultSceneAgainstBruteForce) {
  Scene scene = builtinScene();
  Environment env = builtinEnvironment();
  ExtractOptions eo;
  eo.medianCut.lights = 8;
  LightSet set = extractLights(ctx(), env, eo);
  Camera cam = frameCamera(scene, 16.0f / 9.0f);
  auto visOf = [&](RenderOptions ro) {
    ro.width = 96;
    ro.height = 54;
    ro.shadowMapSize = 256;
    Renderer r(ctx());
    r.render(scene, cam, set, env, ro);
    return r.lastVisibility();
  };
  RenderOptions bro;
  bro.shadows = ShadowTechnique::Brute;
  bro.brute.samples = 256;
  auto ref = visOf(bro);
  RenderOptions hro;
  hro.shadows = ShadowTechnique::Hard;
  auto hard = visOf(hro);
  auto meanErr = [&](const std::vector<float>& v) {
    double s = 0;
    for (std::size_t i = 0; i < v.size(); ++i) s += std::fabs(v[i] - ref[i]);
    return s / v.size();
  };
  double eHard = meanErr(hard);
  for (int m : {0, 1}) {
    auto v = visOf(areaOptions(m, 4));
    double e = meanErr(v);
    std::printf("[ penumbra ] default scene, 8 median-cut lights, 96x54: mean |V - V_brute256| "
                "area-approx %d per edge %.4f, hard %.4f\n", m, e, eHard);
    EXPECT_LT(e, eHard);
  }
}

// Tiny inputs for oclgrind: a frame with a polygon light and a cap (octagon), both the taps and
// the midpoint, and lights in two batches.
TEST(OclgrindAreaApprox, TinyFrame) {
  Scene scene;
  scene.meshes.push_back(hquad("ground", -2, 2, -2, 2, 0));
  scene.meshes.push_back(hquad("blocker", -1, 0.5f, -1, 1, 0.6f));
  LightSet set;
  set.lights.push_back(squareLight(0.3, 0.2));
  AreaLight cap;
  cap.direction = {0.6f, 0.8f, 0.0f};
  cap.cosAlpha = 0.95f;
  cap.radiance = {1, 1, 1};
  set.lights.push_back(cap);
  Camera cam;
  cam.eye = {0.5f, 3, 3};
  cam.target = {0, 0, 0};
  for (int taps : {0, 3}) {
    RenderOptions ro = areaOptions(1, taps, 8);
    ro.width = 9;
    ro.height = 7;
    ro.areaApprox.capVertices = 5;
    ro.areaApprox.batchBytes = 8 * 8 * 4 * 8;  // 8 maps a batch: one light per batch
    Renderer r(ctx());
    Frame f = r.render(scene, cam, set, builtinEnvironment(16), ro);
    for (float v : f.image.pixels) ASSERT_TRUE(std::isfinite(v));
    auto vis = r.lastVisibility();
    ASSERT_EQ(vis.size(), std::size_t(9 * 7 * 2));
    int shadowed = 0;
    for (float v : vis) {
      ASSERT_TRUE(v >= 0.0f && v <= 1.0f);
      shadowed += v < 1.0f;
    }
    EXPECT_GT(shadowed, 3);
  }
}

TEST(OclgrindAreaApprox, RatioKernel) {
  expectRatioKernelMatches(boundary(regularPolygon(4, 0.2, 0.0), 1), 5, 9);
}
