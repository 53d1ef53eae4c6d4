// The orthographic frames shadow maps are rendered in: a light's frame fitted to the scene's box
// (every technique's maps), a light sample's frame fitted to its area light's frame (brute force
// and area approximation), and the rasterizer's view of a frame. Both fits share one rule:
// axes about the light's direction, the extent of the box's projected corners, and a margin of
// 1e-3 of the largest extent so that nothing sits exactly on the near plane or the border.
#include <algorithm>
#include <array>
#include <cmath>

#include "core/vec3.hpp"
#include "shadows/shadow_pass.hpp"

namespace penumbra::detail {
namespace {

// The frame about unit direction w (towards the light) and the bounds of 8 corners in it.
struct OrthoFit {
  V3 w, ex, ey, fwd;
  float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
  float margin = 0;
};

OrthoFit fitOrtho(const V3& w, const std::array<V3, 8>& corners) {
  OrthoFit f;
  f.w = w;
  V3 ref = std::fabs(w[1]) < 0.99f ? V3{0, 1, 0} : V3{1, 0, 0};
  f.ex = normalize(cross(ref, w));
  f.ey = cross(w, f.ex);
  f.fwd = {-w[0], -w[1], -w[2]};
  for (const V3& c : corners) {
    float p[3] = {dot(c, f.ex), dot(c, f.ey), dot(c, f.fwd)};
    for (int k = 0; k < 3; ++k) {
      f.lo[k] = std::min(f.lo[k], p[k]);
      f.hi[k] = std::max(f.hi[k], p[k]);
    }
  }
  f.margin = 1e-3f * std::max({f.hi[0] - f.lo[0], f.hi[1] - f.lo[1], f.hi[2] - f.lo[2], 1e-6f});
  return f;
}

// The map's axes and placement: centre (cx, cy) and half-extents (hx, hy) in the fit's x and y,
// depth from just before the nearest corner to just past the farthest. dir[3] and radiance stay
// the caller's.
void place(pb_light& L, const OrthoFit& f, float cx, float cy, float hx, float hy) {
  const float z0 = f.lo[2] - f.margin;
  for (int k = 0; k < 3; ++k) {
    L.dir[k] = f.w[k];
    L.ex[k] = f.ex[k];
    L.ey[k] = f.ey[k];
    L.origin[k] = cx * f.ex[k] + cy * f.ey[k] + z0 * f.fwd[k];
  }
  L.ex[3] = hx;
  L.ey[3] = hy;
  L.origin[3] = f.hi[2] + f.margin - z0;
}

}  // namespace

// Orthographic shadow-map frame of a directional light, fitted to the scene's bounding box.
pb_light lightFrame(const std::array<float, 3>& direction, float cosAlpha,
                    const std::array<float, 3>& radiance, const Bounds& b) {
  std::array<V3, 8> corners;
  for (int i = 0; i < 8; ++i)
    corners[i] = {i & 1 ? b.hi[0] : b.lo[0], i & 2 ? b.hi[1] : b.lo[1], i & 4 ? b.hi[2] : b.lo[2]};
  const OrthoFit f = fitOrtho(normalize({direction[0], direction[1], direction[2]}), corners);
  pb_light L{};
  place(L, f, 0.5f * (f.lo[0] + f.hi[0]), 0.5f * (f.lo[1] + f.hi[1]),
        0.5f * (f.hi[0] - f.lo[0]) + f.margin, 0.5f * (f.hi[1] - f.lo[1]) + f.margin);
  for (int k = 0; k < 3; ++k) L.radiance[k] = radiance[k];
  L.dir[3] = cosAlpha;
  L.radiance[3] = std::acos(std::clamp(cosAlpha, -1.0f, 1.0f));
  return L;
}

// Orthographic frame of a point light in direction `dir`, fitted (as lightFrame fits the scene's
// box) to the oriented box of the area light's own frame, which holds the whole scene: a sample
// near the cap's axis gets the area light's texel size, not that of a looser world-axis box.
//
// The map's texel grid is shifted by (jx, jy) texels (in [-1/2, 1/2)). Without it every sample's
// grid is anchored at the projection of the box's centre, so a sample's texel rounding of its
// shadow edge moves with the same tilt that moves the edge: on a plane the K edges then fall only
// on every other texel-wide strip and the average is a staircase of two-texel steps (measured:
// 0.086 max error at K = 256 on a 5-degree planar penumbra). Shifts from a Halton sequence make
// the rounding independent of the direction, so it only blurs the profile by about a texel.
pb_light sampleFrame(const pb_light& area, const V3& dir, int size, float jx, float jy) {
  V3 aex = xyz(area.ex), aey = xyz(area.ey), afwd = {-area.dir[0], -area.dir[1], -area.dir[2]};
  std::array<V3, 8> corners;
  for (int i = 0; i < 8; ++i) {
    float sx = i & 1 ? area.ex[3] : -area.ex[3], sy = i & 2 ? area.ey[3] : -area.ey[3];
    float sz = i & 4 ? area.origin[3] : 0.0f;
    for (int a = 0; a < 3; ++a)
      corners[i][a] = area.origin[a] + sx * aex[a] + sy * aey[a] + sz * afwd[a];
  }
  const OrthoFit f = fitOrtho(normalize(dir), corners);
  float hx = 0.5f * (f.hi[0] - f.lo[0]) + f.margin, hy = 0.5f * (f.hi[1] - f.lo[1]) + f.margin;
  float cx = 0.5f * (f.lo[0] + f.hi[0]), cy = 0.5f * (f.lo[1] + f.hi[1]);
  if (size > 0) {
    // one more texel each side, so that the shift keeps the whole box inside the map
    hx *= float(size) / std::max(size - 2, 1);
    hy *= float(size) / std::max(size - 2, 1);
    cx += jx * 2 * hx / size;
    cy += jy * 2 * hy / size;
  }
  pb_light L{};
  place(L, f, cx, cy, hx, hy);
  for (int a = 0; a < 3; ++a) L.radiance[a] = area.radiance[a];
  L.dir[3] = 1.0f;  // a point on the cap
  L.radiance[3] = 0.0f;
  return L;
}

pb_view orthoView(const pb_light& L, int size) {
  pb_view v{};
  for (int k = 0; k < 3; ++k) {
    v.origin[k] = L.origin[k];
    v.forward[k] = -L.dir[k];
    v.right[k] = L.ex[k];
    v.up[k] = L.ey[k];
  }
  v.right[3] = L.ex[3];
  v.up[3] = L.ey[3];
  v.width = v.height = size;
  v.ortho = 1;
  return v;
}

LightFrames lightFrames(const LightSet& lightSet, const Bounds& bounds, int size) {
  LightFrames f;
  for (auto& l : lightSet.lights) {
    f.lights.push_back(lightFrame(l.direction, l.cosAlpha, l.radiance, bounds));
    f.views.push_back(orthoView(f.lights.back(), size));
  }
  return f;
}

}  // namespace penumbra::detail
