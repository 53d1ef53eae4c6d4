// The light sampling module (src/lights/sampling.hpp) against references that do not share its
// code: closed-form areas, solid angles and moments of the disk, the cap and spherical polygons,
// and the share of samples falling in sub-regions against those regions' share of the area.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "core/vec3.hpp"
#include "lights/sampling.hpp"

using namespace penumbra::detail;

namespace {

constexpr double kPi = 3.14159265358979323846;

D3 unit(double x, double y, double z) {
  const double l = std::sqrt(x * x + y * y + z * z);
  return {x / l, y / l, z / l};
}
D3 toD3(const std::array<float, 3>& a) { return {a[0], a[1], a[2]}; }

// Inside a convex spherical polygon with counter-clockwise unit vertices: on the inner side of
// every edge's great circle, up to `eps`.
bool insidePolygon(const std::vector<D3>& v, const D3& p, double eps) {
  for (std::size_t i = 0; i < v.size(); ++i)
    if (dot(cross(v[i], v[(i + 1) % v.size()]), p) < -eps) return false;
  return true;
}

// First moment of a spherical polygon, the integral of w dw over it, by Stokes' theorem (Arvo
// 1995, "Applications of irradiance tensors to the simulation of non-Lambertian phenomena",
// SIGGRAPH, eq. 8): half the sum over the edges of the edge's arc length times its great circle's
// unit normal (counter-clockwise vertices: the normal points into the polygon's side).
D3 polygonFirstMoment(const std::vector<D3>& v) {
  D3 m{0, 0, 0};
  for (std::size_t i = 0; i < v.size(); ++i) {
    const D3 &a = v[i], &b = v[(i + 1) % v.size()];
    const double arc = std::acos(std::clamp(dot(a, b), -1.0, 1.0));
    const D3 u = normalize(cross(a, b));
    for (int c = 0; c < 3; ++c) m[c] += 0.5 * arc * u[c];
  }
  return m;
}

D3 meanOf(const std::vector<D3>& pts) {
  D3 m{0, 0, 0};
  for (const D3& p : pts)
    for (int c = 0; c < 3; ++c) m[c] += p[c] / double(pts.size());
  return m;
}

// Fraction of pts within angle acos(cosR) of axis.
double fractionInCap(const std::vector<D3>& pts, const D3& axis, double cosR) {
  int in = 0;
  for (const D3& p : pts) in += dot(p, axis) >= cosR;
  return double(in) / double(pts.size());
}

// An orthonormal frame about unit w.
void frameAbout(const D3& w, D3& ex, D3& ey) {
  const D3 ref = std::fabs(w[1]) < 0.9 ? D3{0, 1, 0} : D3{1, 0, 0};
  ex = normalize(cross(ref, w));
  ey = cross(w, ex);
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Fibonacci disk points

TEST(Sampling, DiskPointRadiusAndAngleAreAsDefined) {
  // n = 1: the one point sits at radius sqrt(1/2) (half the disk's area inside it), at angle
  // `rotation`.
  for (double rot : {0.0, 1.0, -2.5}) {
    const auto p = fibonacciDiskPoint(0, 1, rot);
    EXPECT_NEAR(std::hypot(p[0], p[1]), std::sqrt(0.5), 1e-15);
    EXPECT_NEAR(std::atan2(p[1], p[0]), std::remainder(rot, 2 * kPi), 1e-12);
  }
  // a rotation turns the whole set rigidly
  const int n = 37;
  for (int k = 0; k < n; ++k) {
    const auto a = fibonacciDiskPoint(k, n, 0.0), b = fibonacciDiskPoint(k, n, 0.7);
    EXPECT_NEAR(b[0], a[0] * std::cos(0.7) - a[1] * std::sin(0.7), 1e-14);
    EXPECT_NEAR(b[1], a[0] * std::sin(0.7) + a[1] * std::cos(0.7), 1e-14);
  }
}

TEST(Sampling, DiskPointsAreUniformInArea) {
  for (int n : {2, 3, 17, 256, 4096}) {
    std::vector<std::array<double, 2>> pts;
    for (int k = 0; k < n; ++k) pts.push_back(fibonacciDiskPoint(k, n, 0.3));
    for (const auto& p : pts) EXPECT_LT(std::hypot(p[0], p[1]), 1.0);
    // Inside radius r: area fraction r^2. The radii are the quantiles (k + 1/2) / n themselves, so
    // the count is off by at most one point.
    for (double r : {0.2, 0.5, 0.71, 0.9}) {
      int in = 0;
      for (const auto& p : pts) in += std::hypot(p[0], p[1]) < r;
      EXPECT_NEAR(double(in) / n, r * r, 1.0 / n + 1e-12) << "n " << n << " r " << r;
    }
    if (n < 256) continue;
    // A wedge of angle t (a region the radial stratification does not align with): fraction
    // t / (2 pi). Golden-angle turns spread the points' angles with discrepancy O(log n / n);
    // measured 2.0 / n (n 256) and 1.1 / n (n 4096) at worst over these wedges.
    for (double t : {0.5, 1.0, kPi, 5.0}) {
      int in = 0;
      for (const auto& p : pts) {
        double a = std::atan2(p[1], p[0]);
        if (a < 0) a += 2 * kPi;
        in += a < t;
      }
      EXPECT_NEAR(double(in) / n, t / (2 * kPi), 4.0 / n) << "n " << n << " wedge " << t;
    }
    // centroid at the centre, second moment E[x^2] = E[y^2] = 1/4
    double mx = 0, my = 0, xx = 0, yy = 0;
    for (const auto& p : pts) {
      mx += p[0] / n;
      my += p[1] / n;
      xx += p[0] * p[0] / n;
      yy += p[1] * p[1] / n;
    }
    EXPECT_NEAR(mx, 0.0, 2.0 / n);
    EXPECT_NEAR(my, 0.0, 2.0 / n);
    EXPECT_NEAR(xx, 0.25, 2.0 / n);
    EXPECT_NEAR(yy, 0.25, 2.0 / n);
  }
}

// ---------------------------------------------------------------------------------------------
// Spherical triangles

TEST(Sampling, TriangleSolidAngleOfOctantAndSigns) {
  const D3 x{1, 0, 0}, y{0, 1, 0}, z{0, 0, 1};
  EXPECT_NEAR(triangleSolidAngle(x, y, z), kPi / 2, 1e-15);  // one eighth of the sphere
  EXPECT_NEAR(triangleSolidAngle(x, z, y), -kPi / 2, 1e-15);  // clockwise: negative
  // a small triangle: its solid angle tends to its flat area at unit distance
  const D3 a = unit(1e-3, 0, 1), b = unit(0, 1e-3, 1), c = unit(0, 0, 1);
  EXPECT_NEAR(triangleSolidAngle(c, a, b), 0.5e-6, 1e-11);
}

TEST(Sampling, FrameRectSolidAngleOfCubeFaces) {
  // a whole cube face: a sixth of the sphere; a quarter face, a 24th
  EXPECT_NEAR(frameRectSolidAngle(-1, 1, -1, 1), 4 * kPi / 6, 1e-14);
  EXPECT_NEAR(frameRectSolidAngle(0, 1, 0, 1), 4 * kPi / 24, 1e-14);
  // a small cell at (x, y): its area times the gnomonic density (1 + x^2 + y^2)^(-3/2)
  const double x = 0.6, y = -0.3, h = 1e-4;
  EXPECT_NEAR(frameRectSolidAngle(x - h, x + h, y - h, y + h) / (4 * h * h),
              std::pow(1 + x * x + y * y, -1.5), 1e-7);
}

TEST(Sampling, ArvoMapHitsTheTrianglesCornersAndEdges) {
  const D3 A = unit(0.1, 1, 0.2), B = unit(0.3, 0.7, 0.9), C = unit(0.8, 0.9, -0.1);
  const double area = triangleSolidAngle(A, B, C);
  ASSERT_GT(area, 0);
  auto near = [](const D3& p, const D3& q) { return length(p - q) < 1e-9; };
  EXPECT_TRUE(near(arvoTrianglePoint(A, B, C, area, 0.37, 0.0), B));  // u2 = 0: B
  EXPECT_TRUE(near(arvoTrianglePoint(A, B, C, area, 1.0, 1.0), C));   // u1 = u2 = 1: C
  // u1 = 1 walks the edge BC, u1 = 0 the edge AB: on their great circles
  for (double u2 : {0.2, 0.5, 0.9}) {
    EXPECT_NEAR(dot(arvoTrianglePoint(A, B, C, area, 1.0, u2), cross(B, C)), 0.0, 1e-9);
    EXPECT_NEAR(dot(arvoTrianglePoint(A, B, C, area, 0.0, u2), cross(A, B)), 0.0, 1e-9);
  }
}

TEST(Sampling, ArvoMapIsUniformInSolidAngle) {
  // A wide triangle and a thin one. The unit square's midpoint grid pushed through the map; a
  // uniform (area-preserving) map gives every sub-region its share of the solid angle.
  const std::vector<std::vector<D3>> tris = {
      {unit(0, 1, 0), unit(0, 0.3, 1), unit(1, 0.2, 0)},
      {unit(0.05, 1, 0), unit(0.62, 1, 0.12), unit(0.6, 1, 0.05)},
  };
  const int g = 200;
  for (const auto& t : tris) {
    const D3 &A = t[0], &B = t[1], &C = t[2];
    const double area = triangleSolidAngle(A, B, C);
    ASSERT_GT(area, 0);
    std::vector<D3> pts;
    for (int i = 0; i < g; ++i)
      for (int j = 0; j < g; ++j)
        pts.push_back(arvoTrianglePoint(A, B, C, area, (i + 0.5) / g, (j + 0.5) / g));
    for (const D3& p : pts) {
      EXPECT_NEAR(length(p), 1.0, 1e-12);
      EXPECT_TRUE(insidePolygon(t, p, 1e-12));
    }
    // Mean direction: the first moment (closed form) over the solid angle; measured within
    // 1.9e-5 of it with this grid (the arc from B is parametrized by its cosine, whose square-root
    // behaviour at B slows the midpoint rule below its 1 / g^2).
    const D3 m = meanOf(pts), ref = polygonFirstMoment(t);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(m[c], ref[c] / area, 5e-5);
    // Sub-triangles cut by arcs from B and from C to the midpoint of the opposite side (cuts that
    // Arvo's construction, which sweeps arcs from A, does not follow): samples in each, against
    // its solid-angle share. 40000 points, boundary rows of ~200: within 1/200.
    const D3 mAC = normalize(A + C), mAB = normalize(A + B);
    const std::vector<std::vector<D3>> subs = {{A, B, mAC}, {A, mAB, C}};
    for (const auto& s : subs) {
      const double share = triangleSolidAngle(s[0], s[1], s[2]) / area;
      int in = 0;
      for (const D3& p : pts) in += insidePolygon(s, p, 0.0);
      EXPECT_NEAR(double(in) / double(pts.size()), share, 1.0 / g);
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Spherical Fibonacci over a cap

TEST(Sampling, CapSamplesMatchTheCapsMoments) {
  const std::array<float, 3> axisF{0.3f, 0.8f, -0.5f};
  const D3 w = normalize(toD3(axisF));
  D3 ex, ey;
  frameAbout(w, ex, ey);
  for (float cosA : {0.9999f, 0.98f, 0.5f, 0.0f, -1.0f})
    for (int n : {1, 2, 7, 64, 1001, 20000}) {
      const auto s = sphericalFibonacciCap(axisF, cosA, n, 0.4f);
      ASSERT_EQ(int(s.size()), n);
      std::vector<D3> pts;
      for (auto& d : s) pts.push_back(toD3(d));
      for (const D3& p : pts) {
        EXPECT_NEAR(length(p), 1.0, 1e-6);
        EXPECT_GE(dot(p, w), double(cosA) - 1e-5);  // inside the cap
      }
      const double c = cosA;
      // Rings of equal solid angle: ring k at cos(theta) = 1 - (1 - c)(k + 1/2) / n exactly, so
      // E[cos] = (1 + c) / 2 and E[cos^2] is (1 + c + c^2) / 3 up to the midpoint rule's
      // (1 - c)^2 / (12 n^2).
      double m1 = 0, m2 = 0;
      for (const D3& p : pts) {
        m1 += dot(p, w) / n;
        m2 += dot(p, w) * dot(p, w) / n;
      }
      EXPECT_NEAR(m1, (1 + c) / 2, 1e-5) << "cos " << c << " n " << n;
      EXPECT_NEAR(m2, (1 + c + c * c) / 3, (1 - c) * (1 - c) / (12.0 * n * n) + 1e-5)
          << "cos " << c << " n " << n;
      if (n < 1001) continue;
      // Perpendicular mean zero: the golden-angle turns cancel about the axis (measured at most
      // 0.53 / n at n 1001 and 0.48 / n at n 20000 over these caps).
      const D3 m = meanOf(pts);
      EXPECT_NEAR(dot(m, ex), 0.0, 2.0 / n);
      EXPECT_NEAR(dot(m, ey), 0.0, 2.0 / n);
      // A sub-cap about the axis (aligned with the rings: within a ring, two for the float
      // rounding of cos(theta)) and one off the axis, wholly inside the cap and aligned with
      // nothing (measured within 0.0019): each gets its share of the solid angle.
      const double alpha = std::acos(c);
      const double cosB = std::cos(alpha / 2);
      EXPECT_NEAR(fractionInCap(pts, w, cosB), (1 - cosB) / (1 - c), 2.0 / n);
      const double g = alpha / 3;
      const D3 off = normalize(w * std::cos(alpha / 2) + ex * std::sin(alpha / 2));
      EXPECT_NEAR(fractionInCap(pts, off, std::cos(g)), (1 - std::cos(g)) / (1 - c), 0.01)
          << "cos " << c << " n " << n;
    }
}

TEST(Sampling, CapSamplesDegenerateCounts) {
  EXPECT_TRUE(sphericalFibonacciCap({0, 1, 0}, 0.5f, 0, 0.0f).empty());
  EXPECT_TRUE(sphericalFibonacciCap({0, 1, 0}, 0.5f, -3, 0.0f).empty());
  // n = 1: the one ring at the cap's median cos(theta) = (1 + c) / 2
  const auto one = sphericalFibonacciCap({0, 2, 0}, 0.5f, 1, 0.0f);
  ASSERT_EQ(one.size(), 1u);
  EXPECT_NEAR(one[0][1], 0.75f, 1e-6f);
  // an axis along +y and one along +x use different reference vectors; both stay in their caps
  for (std::array<float, 3> a : {std::array<float, 3>{0, 1, 0}, std::array<float, 3>{1, 0, 0}})
    for (auto& d : sphericalFibonacciCap(a, 0.9f, 33, 1.0f))
      EXPECT_GE(d[0] * a[0] + d[1] * a[1] + d[2] * a[2], 0.9f - 1e-6f);
  // a rotation turns the set about the axis: every cos(theta) stays
  const auto r0 = sphericalFibonacciCap({0, 0, 1}, 0.7f, 25, 0.0f);
  const auto r1 = sphericalFibonacciCap({0, 0, 1}, 0.7f, 25, 1.3f);
  for (int k = 0; k < 25; ++k) {
    EXPECT_NEAR(r0[k][2], r1[k][2], 1e-6f);
    EXPECT_NEAR(std::atan2(r1[k][1], r1[k][0]),
                std::remainder(std::atan2(r0[k][1], r0[k][0]) + 1.3, 2 * kPi), 1e-4);
  }
}

// ---------------------------------------------------------------------------------------------
// Spherical polygons

TEST(Sampling, PolygonSamplesAreInsideAndMatchTheFirstMoment) {
  // a convex pentagon (counter-clockwise about +y) and a thin quadrilateral
  const std::vector<std::vector<D3>> polys = {
      {unit(0.15, 1, -0.45), unit(-0.4, 1, -0.3), unit(-0.4, 1, 0.3), unit(0.15, 1, 0.45),
       unit(0.5, 1, 0)},
      {unit(-0.3, 1, 0.01), unit(0.3, 1, 0.01), unit(0.3, 1, -0.01), unit(-0.3, 1, -0.01)},
  };
  for (const auto& poly : polys) {
    // counter-clockwise about the polygon's inside (+y), as the module expects
    for (std::size_t i = 0; i < poly.size(); ++i)
      ASSERT_GT(cross(poly[i], poly[(i + 1) % poly.size()])[1], 0);
    std::vector<std::array<float, 3>> vf;
    for (const D3& v : poly) vf.push_back({float(v[0] * 3), float(v[1] * 3), float(v[2] * 3)});
    double area = 0;
    for (std::size_t i = 1; i + 1 < poly.size(); ++i)
      area += triangleSolidAngle(poly[0], poly[i], poly[i + 1]);
    const D3 ref = polygonFirstMoment(poly);
    for (int n : {1, 2, 3, 7, 128, 4095}) {
      for (float rot : {0.0f, 2.0f, -9.0f}) {
        const auto s = sphericalPolygonSamples(vf, n, rot);
        ASSERT_EQ(int(s.size()), n);
        std::vector<D3> pts;
        for (auto& d : s) pts.push_back(toD3(d));
        for (const D3& p : pts) EXPECT_TRUE(insidePolygon(poly, p, 1e-6));
        if (n < 128) continue;
        // mean direction against the closed form (measured within 0.7 / n)
        const D3 m = meanOf(pts);
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(m[c], ref[c] / area, 4.0 / n) << "n " << n;
        // each fan triangle receives its share of the samples (the lattice's first coordinate
        // walks the cumulative solid angle): within two samples (one at each end; measured 1.5)
        for (std::size_t t = 1; t + 1 < poly.size(); ++t) {
          const std::vector<D3> tri = {poly[0], poly[t], poly[t + 1]};
          int in = 0;
          for (const D3& p : pts) in += insidePolygon(tri, p, -1e-9);
          EXPECT_NEAR(double(in) / n, triangleSolidAngle(tri[0], tri[1], tri[2]) / area,
                      2.0 / n);
        }
      }
    }
  }
}

TEST(Sampling, PolygonSamplesDegenerateInputs) {
  const std::vector<std::array<float, 3>> tri = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  EXPECT_TRUE(sphericalPolygonSamples(tri, 0, 0.0f).empty());
  EXPECT_TRUE(sphericalPolygonSamples({tri[0], tri[1]}, 16, 0.0f).empty());
  // A rotation shifts the lattice: other points, the same triangle. A whole turn is the identity
  // up to the float rounding of 2 pi (a shift of 3e-8), which moves a point next to B by about
  // sqrt(2 x 3e-8) = 2.4e-4: the arc from B is parametrized by its cosine.
  const auto a = sphericalPolygonSamples(tri, 9, 0.0f), b = sphericalPolygonSamples(tri, 9, 1.0f);
  int moved = 0;
  for (int k = 0; k < 9; ++k) moved += length(toD3(a[k]) - toD3(b[k])) > 1e-3;
  EXPECT_GE(moved, 8);
  const auto c = sphericalPolygonSamples(tri, 9, float(2 * kPi));
  for (int k = 0; k < 9; ++k) EXPECT_LT(length(toD3(a[k]) - toD3(c[k])), 1e-3);
}
