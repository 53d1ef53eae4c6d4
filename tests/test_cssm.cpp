// CSSM (convolution soft shadow maps, seed 000 §3) against the analytic penumbra of the planar,
// parallel configuration, in which convolution shadows are exact up to the truncation of the
// Fourier series (seed 000 §3); contact shadows with sharpening (eq. 9); smooth wide penumbrae;
// degenerate inputs; determinism; a tiny frame under oclgrind.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "common.hpp"

using namespace penumbra;
using namespace penumbra::test;

namespace {

Mesh quad(const std::string& name, float x0, float x1, float z0, float z1, float y) {
  Mesh m;
  m.name = name;
  m.positions = {{x0, y, z0}, {x1, y, z0}, {x1, y, z1}, {x0, y, z1}};
  m.normals = {{0, 1, 0}, {0, 1, 0}, {0, 1, 0}, {0, 1, 0}};
  m.triangles = {{0, 2, 1}, {0, 3, 2}};
  return m;
}

// Axis-aligned box (12 triangles, outward normals per face).
Mesh box(const std::string& name, Vec3 lo, Vec3 hi) {
  Mesh m;
  m.name = name;
  auto face = [&](Vec3 a, Vec3 b, Vec3 c, Vec3 d, Vec3 n) {
    int base = int(m.positions.size());
    for (const Vec3& p : {a, b, c, d}) {
      m.positions.push_back(p);
      m.normals.push_back(n);
    }
    m.triangles.push_back({base, base + 1, base + 2});
    m.triangles.push_back({base, base + 2, base + 3});
  };
  float x0 = lo[0], y0 = lo[1], z0 = lo[2], x1 = hi[0], y1 = hi[1], z1 = hi[2];
  face({x0, y1, z0}, {x0, y1, z1}, {x1, y1, z1}, {x1, y1, z0}, {0, 1, 0});
  face({x0, y0, z0}, {x1, y0, z0}, {x1, y0, z1}, {x0, y0, z1}, {0, -1, 0});
  face({x1, y0, z0}, {x1, y1, z0}, {x1, y1, z1}, {x1, y0, z1}, {1, 0, 0});
  face({x0, y0, z0}, {x0, y0, z1}, {x0, y1, z1}, {x0, y1, z0}, {-1, 0, 0});
  face({x0, y0, z1}, {x1, y0, z1}, {x1, y1, z1}, {x0, y1, z1}, {0, 0, 1});
  face({x0, y0, z0}, {x0, y1, z0}, {x1, y1, z0}, {x1, y0, z0}, {0, 0, -1});
  return m;
}

LightSet oneLight(Vec3 dir, float cosAlpha) {
  AreaLight light;
  float l = std::sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
  light.direction = {dir[0] / l, dir[1] / l, dir[2] / l};
  light.cosAlpha = cosAlpha;
  light.radiance = {1, 1, 1};
  LightSet set;
  set.lights.push_back(light);
  return set;
}

// Irradiance-weighted unblocked fraction of a cap of half-angle alpha around +y, seen from a
// receiver at x on the plane y = 0, when the half-plane {x' < 0, y = h} blocks (quadrature).
double analyticVisibility(double x, double h, double alpha) {
  const int nt = 200, np = 400;
  double lit = 0, total = 0;
  for (int i = 0; i < nt; ++i) {
    double t0 = alpha * i / nt, t1 = alpha * (i + 1) / nt, th = 0.5 * (t0 + t1);
    double dw = (std::cos(t0) - std::cos(t1)) * std::cos(th);
    for (int j = 0; j < np; ++j) {
      double ph = 2 * M_PI * (j + 0.5) / np;
      double xh = x + h * std::tan(th) * std::cos(ph);  // where the ray meets the blocker plane
      total += dw;
      if (xh >= 0) lit += dw;
    }
  }
  return lit / total;
}

// The truncated complementary shadow test, seed 000 eq. 10, as a function of t = d - z, and the
// ringing suppression of §3.3 as src/shadows_cssm.cpp derives it for ringingOffset = 0 (written
// again here from the definitions, independently of the library):
//   S_M(t) = 1/2 + 2 sum_k sin(c_k t)/c_k, c_k = pi (2k - 1);
//   s_hi = min of S_M past its first peak, t0 = first t with S_M(t) = s_hi;
//   shadow = clamp((S - 1/2) / (s_hi - 1/2)), evaluated at tau = kappa t, kappa = 1 - t0.
struct Series {
  int M;
  double shi = 0, t0 = 0, kappa = 1, peak = 0;
  explicit Series(int m) : M(m) {
    const int n = 20000;
    int ip = 1;
    while (S(double(ip + 1) / n) > S(double(ip) / n)) ++ip;
    peak = S(double(ip) / n);
    shi = peak;
    for (int i = ip; i <= n - ip; ++i) shi = std::min(shi, S(double(i) / n));
    double lo = 0, hi = double(ip) / n;
    for (int it = 0; it < 60; ++it) ((S(0.5 * (lo + hi)) < shi) ? lo : hi) = 0.5 * (lo + hi);
    t0 = hi;
    kappa = 1 - t0;
  }
  double S(double t) const {
    double s = 0.5;
    for (int k = 1; k <= M; ++k) s += 2 * std::sin(M_PI * (2 * k - 1) * t) / (M_PI * (2 * k - 1));
    return s;
  }
  // scaled and shifted (not clamped) test of a texel whose depth is t above the receiver
  double T(double t) const { return (S(kappa * t) - 0.5) / (shi - 0.5); }
  // Largest error of the reconstructed planar profile, 1 - clamp(phi T_b), against 1 - phi over
  // every blocker height (T_b anywhere between 1 and the Gibbs peak's image): the planar error
  // budget the series' truncation leaves at order M.
  double planarBound() const {
    double Tmax = (peak - 0.5) / (shi - 0.5), e = 0;
    for (int i = 0; i <= 1000; ++i) {
      double phi = i / 1000.0;
      e = std::max(e, std::fabs(std::min(phi * Tmax, 1.0) - phi));
    }
    return e;
  }
};

struct PlanarCase {
  double alphaDeg = 5, h = 1;
  int mapSize = 256, order = 4;
  float sharpenA = 0;
  // Height of a small quad outside the view that sets the map's depth range: the blocker then sits
  // at t = h / range, off the end of the series' plateau where S_M = s_hi exactly.
  double rangeTop = 0;
};

struct PlanarResult {
  double maxError = 0;       // |V - V_analytic|
  double maxModelError = 0;  // |V - (1 - clamp(phi_analytic T_b))|, the series' own prediction
  double Tb = 1;
  int samples = 0, penumbraSamples = 0;
  // one image row across the penumbra: ground x and visibility, for the smoothness test
  std::vector<std::pair<double, double>> row;
};

PlanarResult planar(const PlanarCase& c) {
  Scene scene;
  scene.meshes.push_back(quad("ground", -3, 3, -3, 3, 0));
  scene.meshes.push_back(quad("blocker", -3, 0, -3, 3, float(c.h)));
  if (c.rangeTop > 0) {  // two, so that the map stays centred on the blocker's edge
    scene.meshes.push_back(quad("top", 3.5f, 3.6f, 3.5f, 3.6f, float(c.rangeTop)));
    scene.meshes.push_back(quad("top", -3.6f, -3.5f, -3.6f, -3.5f, float(c.rangeTop)));
  }
  LightSet set = oneLight({0, 1, 0}, float(std::cos(c.alphaDeg * M_PI / 180)));
  Camera cam;
  cam.eye = {2.2f, float(0.45 * c.h), 0.3f};
  cam.target = {-1.2f, 0, 0};
  cam.up = {0, 1, 0};
  cam.fovyDeg = 50;
  RenderOptions ro;
  ro.width = 128;
  ro.height = 96;
  ro.shadowMapSize = c.mapSize;
  ro.environmentBackground = false;
  ro.mssm.maxFilterTexels = 64;
  ro.shadows = ShadowTechnique::CSSM;
  ro.cssm.order = c.order;
  ro.cssm.sharpenA = c.sharpenA;
  Environment env = builtinEnvironment(16);
  Renderer r(ctx());
  Frame f = r.render(scene, cam, set, env, ro);
  auto vis = r.lastVisibility();
  CameraBasis b = cameraBasis(cam, ro.width, ro.height);
  Series ser(c.order);
  // The map's depth range as src/renderer.cpp's lightFrame fits it to the scene's box (margin
  // 1e-3 of the largest extent on both ends), so the blocker's depth above the ground is t_b.
  const double top = std::max(c.h, c.rangeTop), extent = c.rangeTop > 0 ? 7.2 : 6.0;
  const double range = top + 2e-3 * std::max(extent, top);
  PlanarResult res;
  res.Tb = ser.T(c.h / range);
  const double R = c.h * std::tan(c.alphaDeg * M_PI / 180);
  std::vector<double> table(2001);
  for (int k = 0; k <= 2000; ++k)
    table[k] = analyticVisibility(-R + 2 * R * k / 2000.0, c.h, c.alphaDeg * M_PI / 180);
  const int profileRow = ro.height * 3 / 4;
  for (int y = 0; y < ro.height; ++y)
    for (int x = 0; x < ro.width; ++x) {
      if (f.image.at(x, y, 3) < 0.5f) continue;
      Vec3 d = cameraRayDirection(b, ro.width, ro.height, x + 0.5f, y + 0.5f);
      if (d[1] >= 0) continue;  // the blocker's underside, not the receiver
      double t = -b.eye[1] / d[1];
      double px = b.eye[0] + t * d[0], pz = b.eye[2] + t * d[2];
      if (std::fabs(px) > 2.9 || std::fabs(pz) > 2.9) continue;  // ground's border
      // the blocker's other edges (x = -3, z = +-3), which the map sees past its range extenders
      if (px < -3 + 1.2 * R || std::fabs(pz) > 3 - 1.2 * R) continue;
      double u = std::clamp((px + R) / (2 * R), 0.0, 1.0) * 2000;
      int k = std::min(int(u), 1999);
      double expect = table[k] + (u - k) * (table[k + 1] - table[k]);
      double got = vis[std::size_t(y) * ro.width + x];
      double model = 1 - std::clamp((1 - expect) * res.Tb, 0.0, 1.0);
      res.maxError = std::max(res.maxError, std::fabs(got - expect));
      res.maxModelError = std::max(res.maxModelError, std::fabs(got - model));
      ++res.samples;
      if (std::fabs(px) < R) ++res.penumbraSamples;
      if (y == profileRow) res.row.push_back({px, got});
    }
  std::printf("[ penumbra ] CSSM M=%d planar alpha %.1f deg, h %.1f, range top %.1f, map %d, A %.0f: "
              "max |V - V_analytic| = %.4f, |V - V_series| = %.4f (T_b %.3f, bound %.3f) over %d pixels\n",
              c.order, c.alphaDeg, c.h, c.rangeTop, c.mapSize, c.sharpenA, res.maxError,
              res.maxModelError, res.Tb, ser.planarBound(), res.samples);
  return res;
}

}  // namespace

