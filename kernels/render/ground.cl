// The ground's occlusion of low lights (ShadowOptions::groundVisibility): the part of a cap below
// the ground's plane, seen from a receiver above the ground.
//
// A cap that reaches below the horizontal lights a receiver standing on the ground only through
// the directions that miss the ground. A shadow map cannot show that: it looks along the cap's
// axis, from which the ground is seen edge-on (axis just above the horizontal: the map finds the
// receiver lit) or from below (axis just below it: the map finds the receiver behind the ground),
// so a map technique's visibility there is right only for the axis, and wrong for the cap. Measured
// on studio.exr + WusonOBJ.obj (bench/results/accuracy.md, "The ground and low lights"), the
// Wuson's body came out 4.8-5.6% too bright against exact visibility of the same 62 lights with
// hard shadows, MSSM4 and the default mix, and 0.3-1.0% without the ground in the scene.
//
// The ground is the scene's axis-aligned rectangle x0..x1, z0..z1 at height gy (y up). For a
// receiver p at height h = p.y - gy > eps with shading normal n, and a light whose cap reaches
// below the horizontal, the blocked share of what the cap gives p is estimated from the light's
// directions d_i (uniform in solid angle over the cap, built by the host, src/render/ground.cpp):
//   B = sum_i [d_i hits the rectangle] max(n.d_i, 0) / sum_i max(n.d_i, 0),
// a ray p + t d_i (d_i.y < 0) meeting the plane at t = h / -d_i.y: the cosine-weighted share of the
// cap above p's tangent plane that the ground hides (the irradiance the shading gives the pair is
// the same clipped, cosine-weighted cap: Snyder 1996's closed form, kernels/common/shared.h).
// Then, where the axis itself misses the rectangle, the map's visibility v (the occluders other
// than the ground, as seen along the axis) becomes v (1 - B); where the axis hits it, the map saw
// the ground and nothing behind it, and the pair takes 1 - B (nothing else is known to occlude
// the part above the ground).
#include "shared.h"

// Whether the ray p + t d (t > 0) from height h above the plane meets the rectangle.
static inline bool ground_hit(float px, float pz, float h, float dx, float dy, float dz, float x0,
                              float x1, float z0, float z1) {
  if (!(dy < 0.0f)) return false;
  const float t = h / -dy;
  const float qx = px + t * dx, qz = pz + t * dz;
  return qx >= x0 && qx <= x1 && qz >= z0 && qz <= z1;
}

// One work-item per pixel. dirs: for each of the ngl lights in glights (the lights whose cap
// reaches below the horizontal, in increasing index), GR_DIRS + 1 float4: its axis (w: the
// tangent of how far below the horizontal the cap reaches), then its GR_DIRS directions. rect:
// (gy, x0, x1, z0); rect2: (z1, eps, the G-buffer's lift, unused). mask: uchar per light, the
// lights whose visibility came from a map (others are left alone). vis: float [light][pixel].
kernel void ground_visibility(global const float4* gpos, global const float4* gnrm,
                              global const float4* ggeo, global const float4* dirs,
                              global const int* glights, int ngl, int npixels, float4 rect,
                              float4 rect2, global const uchar* mask, global float* vis) {
  const int px = get_global_id(0);
  if (px >= npixels) return;
  const float4 p = gpos[px];
  if (p.w == 0.0f) return;
  const float gy = rect.x, x0 = rect.y, x1 = rect.z, z0 = rect.w, z1 = rect2.x, eps = rect2.y;
  const float h = p.y - gy;
  // The surface point's own height (the G-buffer lifted it by rect2.z along its geometric normal,
  // where its shadow rays start): the ground's pixels stand on it, whatever the lift.
  if (!(h - rect2.z * ggeo[px].y > eps)) return;
  const float3 n = gnrm[px].xyz;
  // the horizontal distance from p to the rectangle's farthest corner: a ray whose slope below
  // the horizontal is under h / reach meets the plane beyond every point of the rectangle
  const float fx = fmax(fabs(p.x - x0), fabs(p.x - x1)), fz = fmax(fabs(p.z - z0), fabs(p.z - z1));
  const float reach = sqrt(fx * fx + fz * fz);
  for (int k = 0; k < ngl; ++k) {
    const int l = glights[k];
    if (!mask[l]) continue;
    global const float4* d = dirs + (size_t)k * (GR_DIRS + 1);
    // d[0].w: the slope below the horizontal of the cap's steepest direction down; none of the
    // cap's rays can meet the rectangle unless it exceeds h / reach
    if (!(d[0].w * reach > h)) continue;
    float total = 0.0f, blocked = 0.0f;
    for (int i = 1; i <= GR_DIRS; ++i) {
      const float4 di = d[i];
      const float c = n.x * di.x + n.y * di.y + n.z * di.z;
      if (!(c > 0.0f)) continue;
      total += c;
      if (ground_hit(p.x, p.z, h, di.x, di.y, di.z, x0, x1, z0, z1)) blocked += c;
    }
    if (!(blocked > 0.0f)) continue;
    const float keep = 1.0f - blocked / total;
    const float4 w = d[0];
    const size_t o = (size_t)l * npixels + px;
    vis[o] = ground_hit(p.x, p.z, h, w.x, w.y, w.z, x0, x1, z0, z1) ? keep : vis[o] * keep;
  }
}

// The CPU form (src/core/device_kind.hpp; the same bits): PoCL runs ground_visibility one
// work-item at a time (`perf annotate`: no zmm instruction), each pixel's direction loop scalar.
// Here a work-item takes GR_GROUP consecutive pixels: a scalar loop reads them (and decides
// which stand above the ground), then each light's directions run in order, each over the pixels
// in a SIMD loop, every pixel's sums formed as ground_visibility forms them (a direction that does
// not count for a pixel leaves its sums as they are, where the per-pixel loop skips it). Global
// size ceil(npixels / GR_GROUP).
#ifndef GR_GROUP
#define GR_GROUP 64
#endif
kernel void ground_visibility_batch(global const float4* gpos, global const float4* gnrm,
                                    global const float4* ggeo, global const float4* dirs,
                                    global const int* glights, int ngl, int npixels, float4 rect,
                                    float4 rect2, global const uchar* mask, global float* vis) {
  const int px0 = get_global_id(0) * GR_GROUP;
  if (px0 >= npixels) return;
  const int cnt = min(GR_GROUP, npixels - px0);
  const float gy = rect.x, x0 = rect.y, x1 = rect.z, z0 = rect.w, z1 = rect2.x, eps = rect2.y;
  float Px[GR_GROUP], Pz[GR_GROUP], H[GR_GROUP], Nx[GR_GROUP], Ny[GR_GROUP], Nz[GR_GROUP],
      reach[GR_GROUP], total[GR_GROUP], blocked[GR_GROUP];
  bool above[GR_GROUP], reached[GR_GROUP];  // reached: above, and the light's cap can meet the ground
  int any = 0;
  for (int k = 0; k < GR_GROUP; ++k) {
    const int px = px0 + min(k, cnt - 1);
    const float4 p = gpos[px];
    const float h = p.y - gy;
    above[k] = k < cnt && p.w != 0.0f && h - rect2.z * ggeo[px].y > eps;
    any += above[k];
    const float3 n = gnrm[px].xyz;
    Px[k] = p.x;
    Pz[k] = p.z;
    H[k] = h;
    Nx[k] = n.x;
    Ny[k] = n.y;
    Nz[k] = n.z;
    const float fx = fmax(fabs(p.x - x0), fabs(p.x - x1)), fz = fmax(fabs(p.z - z0), fabs(p.z - z1));
    reach[k] = sqrt(fx * fx + fz * fz);
  }
  if (any == 0) return;
  for (int k = 0; k < ngl; ++k) {
    const int l = glights[k];
    if (!mask[l]) continue;
    global const float4* d = dirs + (size_t)k * (GR_DIRS + 1);
    const float4 w = d[0];
    int live = 0;
    for (int j = 0; j < GR_GROUP; ++j) {
      total[j] = 0.0f;
      blocked[j] = 0.0f;
      reached[j] = above[j] && w.w * reach[j] > H[j];
      live += reached[j];
    }
    if (live == 0) continue;
    for (int i = 1; i <= GR_DIRS; ++i) {
      const float4 di = d[i];
PB_SIMD_LOOP(16)
      for (int j = 0; j < GR_GROUP; ++j) {
        const float c = Nx[j] * di.x + Ny[j] * di.y + Nz[j] * di.z;
        const bool counts = c > 0.0f;
        const bool hit = ground_hit(Px[j], Pz[j], H[j], di.x, di.y, di.z, x0, x1, z0, z1);
        const float t = total[j] + c, b = blocked[j] + c;
        total[j] = counts ? t : total[j];
        blocked[j] = counts && hit ? b : blocked[j];
      }
    }
    global float* row = vis + (size_t)l * npixels + px0;
PB_SIMD_LOOP(16)
    for (int j = 0; j < GR_GROUP; ++j) {
      if (reached[j] && blocked[j] > 0.0f) {
        const float keep = 1.0f - blocked[j] / total[j];
        row[j] = ground_hit(Px[j], Pz[j], H[j], w.x, w.y, w.z, x0, x1, z0, z1) ? keep
                                                                                : row[j] * keep;
      }
    }
  }
}
