// The planar-penumbra fixture's scene, its render driver, the analytic profiles and the per-pixel
// comparison (declared and explained in planar_penumbra.hpp).
#include "planar_penumbra.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "../common.hpp"

namespace penumbra::test {

AreaLight capLightAbove(double alphaDeg) {
  AreaLight light;
  light.direction = {0, 1, 0};
  light.cosAlpha = float(std::cos(alphaDeg * M_PI / 180));
  light.radiance = {1, 1, 1};
  return light;
}

Scene PlanarPenumbra::scene() const {
  Scene scene;
  scene.meshes.push_back(planarQuad("ground", -3, 3, -3, 3, 0));
  if (receiverHeight > 0)
    scene.meshes.push_back(planarQuad("platform", -3, float(receiverEdge), -3, 3, float(receiverHeight)));
  for (std::size_t i = 0; i < blockers.size(); ++i) {
    const PlanarBlocker& b = blockers[i];
    const std::string name = blockers.size() == 1 ? "blocker" : "blocker" + std::to_string(i);
    scene.meshes.push_back(planarQuad(name, float(b.start), float(b.edge), -3, b.zEnd, float(b.height)));
  }
  if (!vertexNormals)
    for (Mesh& m : scene.meshes) m.normals.clear();
  for (const Mesh& m : extraMeshes) scene.meshes.push_back(m);
  return scene;
}

Camera PlanarPenumbra::camera() const {
  Camera cam;
  cam.eye = eye;
  if (cam.eye[1] < 0) {
    double lowest = blockers.empty() ? 0 : blockers[0].height - receiverHeight;
    for (const PlanarBlocker& b : blockers) lowest = std::min(lowest, b.height - receiverHeight);
    cam.eye[1] = float(receiverHeight + std::max(0.45 * lowest, minEyeHeight));
  }
  cam.target = target;
  cam.up = {0, 1, 0};
  cam.fovyDeg = fovyDeg;
  return cam;
}

PlanarFrame renderPlanar(const PlanarPenumbra& s, RenderOptions ro) {
  ro.width = s.imageWidth;
  ro.height = s.imageHeight;
  ro.shadowMapSize = s.mapSize;
  ro.environmentBackground = false;
  ro.shadow.maxFilterTexels = 64;
  const Camera cam = s.camera();
  LightSet set;
  set.lights.push_back(s.light);
  Renderer r(ctx());
  PlanarFrame out;
  out.image = r.render(s.scene(), cam, set, builtinEnvironment(16), ro).image;
  out.visibility = r.lastVisibility();
  const CameraBasis b = cameraBasis(cam, ro.width, ro.height);
  const double yR = s.receiverHeight;
  for (int y = 0; y < ro.height; ++y)
    for (int x = 0; x < ro.width; ++x) {
      if (out.image.at(x, y, 3) < 0.5f) continue;
      Vec3 d = cameraRayDirection(b, ro.width, ro.height, x + 0.5f, y + 0.5f);
      if (d[1] >= 0) continue;  // a blocker's underside, not the receiver
      double t = s.layered ? (yR - b.eye[1]) / d[1] : -b.eye[1] / d[1];
      double px = b.eye[0] + t * d[0], pz = b.eye[2] + t * d[2];
      if (s.layered) {
        if (t <= 0 || px > s.receiverEdge - 0.02) continue;  // not the platform (or its edge)
        bool hidden = false;  // a blocker's top face first (cameras above a blocker)
        for (const PlanarBlocker& h : s.blockers) {
          double th = (h.height - b.eye[1]) / d[1];
          double xh = b.eye[0] + th * d[0];
          hidden = hidden || (th > 0 && th < t && xh < h.edge && xh > h.start);
        }
        if (hidden) continue;
      }
      if (std::fabs(px) > s.border || std::fabs(pz) > s.border) continue;  // ground's border
      if (s.keep && !s.keep(px, pz)) continue;
      out.receivers.push_back({x, y, px, pz, double(out.visibility[std::size_t(y) * ro.width + x])});
    }
  return out;
}

PenumbraProfile::PenumbraProfile(double lo_, double hi_, int n,
                                 const std::function<double(double)>& visibility)
    : lo(lo_), hi(hi_), table(n + 1) {
  for (int k = 0; k <= n; ++k) table[k] = visibility(lo + (hi - lo) * k / n);
}

double PenumbraProfile::operator()(double x) const {
  const int n = int(table.size()) - 1;
  double u = std::clamp((x - lo) / (hi - lo), 0.0, 1.0) * n;
  int k = std::min(int(u), n - 1);
  return table[k] + (u - k) * (table[k + 1] - table[k]);
}

PenumbraProfile halfPlaneProfile(double h, double alpha, int n) {
  const int nt = 200, np = 400;
  // every quadrature direction: where it meets the blocker's plane (offset from the receiver's x)
  // and its weight, the ring's solid angle times cos theta
  std::vector<std::pair<double, double>> rays;
  double total = 0;
  for (int i = 0; i < nt; ++i) {
    double t0 = alpha * i / nt, t1 = alpha * (i + 1) / nt, th = 0.5 * (t0 + t1);
    double dw = (std::cos(t0) - std::cos(t1)) * std::cos(th);
    for (int j = 0; j < np; ++j) {
      rays.push_back({h * std::tan(th) * std::cos(2 * M_PI * (j + 0.5) / np), dw});
      total += dw;
    }
  }
  const double R = h * std::tan(alpha);
  return PenumbraProfile(-R, R, n, [&](double x) {
    double lit = 0;
    for (const auto& [off, dw] : rays)
      if (x + off >= 0) lit += dw;  // the ray passes the blocker's edge
    return lit / total;
  });
}

double halfPlaneVisibilityByRings(double x, double h, double alpha, bool cosWeighted) {
  const int nt = 2000;
  double lit = 0, total = 0;
  for (int i = 0; i < nt; ++i) {
    double t0 = alpha * i / nt, t1 = alpha * (i + 1) / nt, th = 0.5 * (t0 + t1);
    double dw = (std::cos(t0) - std::cos(t1)) * (cosWeighted ? std::cos(th) : 1.0);
    double r = h * std::tan(th);
    double share = x >= r ? 1.0 : x <= -r ? 0.0 : std::acos(-x / r) / M_PI;
    total += dw;
    lit += dw * share;
  }
  return lit / total;
}

ProfileComparison compareWithProfile(const std::vector<ReceiverPixel>& receivers,
                                     const PenumbraProfile& profile, double edge) {
  ProfileComparison c;
  double sq = 0;
  for (const ReceiverPixel& r : receivers) {
    const double x = r.x - edge, expect = profile(x), err = std::fabs(r.vis - expect);
    c.pixels.push_back({r.col, r.row, x, r.vis, expect});
    c.maxError = std::max(c.maxError, err);
    ++c.samples;
    if (x > profile.lo && x < profile.hi) {
      ++c.penumbraSamples;
      sq += err * err;
    }
  }
  c.rmsPenumbra = std::sqrt(sq / std::max(1, c.penumbraSamples));
  return c;
}

}  // namespace penumbra::test
