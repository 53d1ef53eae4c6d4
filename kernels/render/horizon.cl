// Lights on the horizon (ShadowOptions::horizonVisibility): the visibility of a cap whose axis lies
// below a pixel's horizon while part of the cap is above it.
//
// Such a cap lights the pixel through the part above the tangent plane only (the shading clips it
// there: Snyder 1996's closed form, kernels/common/shared.h). A shadow map looks along the cap's
// axis, which here points into the receiver's own surface: from below the ground, a map sees the
// ground and nothing above it, so whatever a map technique finds there is the receiver shadowing
// itself at a grazing angle, not an occluder of the part that lights the pixel. Measured on the
// four scenes of bench/results/accuracy.md, pixels that the Embree light-set truth shows
// unoccluded (visibility above 0.999) came out 0.5-1.7% too dark on average with MSSM4 and
// 0.7-2.0% with hard shadows, where the unshadowed shading is exact (0.00-0.06%).
//
// So for such a pair (pixel p with shading normal n, light l with axis w and half-angle a,
// -sin a < n.w <= 0) the map's answer is replaced by what the other lights say about that part of
// the sky. The lit part is a lens between the horizon and the cap's rim point farthest above it;
// in the plane of w and n, at angle t from w towards u = (n - (n.w) w) / |...|, the horizon is at
// t_h = atan2(-n.w, |n - (n.w) w|) and the rim at t = a, and the lens's middle m is at
// t_m = (t_h + a) / 2. The pair takes the mean visibility at p of the
// lights k whose axis is above p's horizon (n.w_k > 0: their own maps look from above) and within
// 2a of m; with none, 1 (nothing known occludes the lens). The sources are never rewritten here
// (their n.w_k > 0), so the result does not depend on the order of the lights. Since m is inside
// the cap (within a of w), a source is within 3a of w: the host lists, for each light, the lights
// within 3a + 0.01 rad of its axis in increasing index (cand_off/cand_idx, CSR), and only those are
// tested here.
//
// Measured on the four scenes with MSSM4 (bench/results/accuracy.md, 2026-12-04 stop 33), against
// two other ways tried for these pairs: visibility 1 (nothing occludes the lens) lowered studio's
// error most (5.63 to 5.33%) but raised the built-in scene's (2.94 to 3.04%), whose ground near
// the objects has its low sky blocked; the single nearest source's visibility kept built-in
// (2.95%) but gave up most of studio's gain (5.63%). The mean within 2a: 2.92, 3.67, 2.98, 5.46%.
#include "shared.h"

#ifndef HZ_MAX_SOURCES
#define HZ_MAX_SOURCES 32
#endif

// Whether light K is a source for a pixel with normal n and lit-part middle m (m[3] = cos 2a):
// its centre above the pixel's horizon and within 2a of m.
static bool horizon_is_source(float nx, float ny, float nz, const float* m,
                              global const pb_light* K) {
  const float kx = K->dir[0], ky = K->dir[1], kz = K->dir[2];
  return nx * kx + ny * ky + nz * kz > 0.0f && m[0] * kx + m[1] * ky + m[2] * kz > m[3];
}

// The sources of light l at a pixel with normal n (c = n.w): their indices, in increasing order,
// into src (at most HZ_MAX_SOURCES); returns how many, -1 where there are more (the caller then
// sums them with horizon_mean_all), -2 where n is parallel to w (no lens; cannot happen for
// c > -sin a with a < pi/2: the pair keeps its value).
static int horizon_sources(float nx, float ny, float nz, float c, float wx, float wy, float wz,
                           float ca, float sa, int l, global const pb_light* lights,
                           global const int* cand_off, global const int* cand_idx, int* src,
                           float* m) {
  float ux = nx - c * wx, uy = ny - c * wy, uz = nz - c * wz;
  const float ul = sqrt(ux * ux + uy * uy + uz * uz);
  if (!(ul > 1e-6f)) return -2;
  ux /= ul;
  uy /= ul;
  uz /= ul;
  // Without trigonometry: the horizon's point on the great circle through w and u is
  // h = (ul w - c u) / sqrt(ul^2 + c^2) (its angle from w has tangent -c/ul), the rim's is
  // r = cos a w + sin a u, and the middle of the arc between two unit vectors is along their
  // sum: m = (h + r) / |h + r|. (The same direction as the angles' mean, (t_h + a) / 2; the
  // first form, with atan2, cos and sin per pair, took the 640x360 frame's step 94-105 ms on
  // PoCL.)
  const float hs = 1.0f / sqrt(ul * ul + c * c);
  const float hw = ul * hs + ca, hu = sa - c * hs;  // h + r in the (w, u) basis
  const float ml = 1.0f / sqrt(hw * hw + hu * hu);
  m[0] = (hw * wx + hu * ux) * ml;
  m[1] = (hw * wy + hu * uy) * ml;
  m[2] = (hw * wz + hu * uz) * ml;
  // angle(m, w_k) < 2a <=> m.w_k > cos 2a (for 2a < pi; caps are narrower than a hemisphere)
  m[3] = 2.0f * ca * ca - 1.0f;
  int count = 0;
  for (int i = cand_off[l]; i < cand_off[l + 1]; ++i) {
    const int k = cand_idx[i];
    if (!horizon_is_source(nx, ny, nz, m, lights + k)) continue;
    if (count == HZ_MAX_SOURCES) return -1;
    src[count++] = k;
  }
  return count;
}

// The mean visibility at pixel p over every source, read again (more than HZ_MAX_SOURCES).
static float horizon_mean_all(float nx, float ny, float nz, const float* m, int l, int p,
                              int npixels, global const pb_light* lights,
                              global const int* cand_off, global const int* cand_idx,
                              global const float* vis) {
  float sum = 0.0f;
  int count = 0;
  for (int i = cand_off[l]; i < cand_off[l + 1]; ++i) {
    const int k = cand_idx[i];
    if (!horizon_is_source(nx, ny, nz, m, lights + k)) continue;
    sum += vis[(size_t)k * npixels + p];
    ++count;
  }
  return sum / (float)count;
}

// Pixel p's new visibility of light l from its sources (ns of them in src, or -1: all, again), or
// `keep` (ns -2).
static float horizon_value(int ns, const int* src, float nx, float ny, float nz, const float* m,
                           int l, int p, int npixels, global const pb_light* lights,
                           global const int* cand_off, global const int* cand_idx,
                           global const float* vis, float keep) {
  if (ns == -2) return keep;
  if (ns == -1)
    return horizon_mean_all(nx, ny, nz, m, l, p, npixels, lights, cand_off, cand_idx, vis);
  if (ns == 0) return 1.0f;
  float sum = 0.0f;
  for (int i = 0; i < ns; ++i) sum += vis[(size_t)src[i] * npixels + p];
  return sum / (float)ns;
}

// Global size npixels (GPUs). vis is light-major [light][pixel], in place; mask[l] != 0 for the
// lights whose visibility comes from a map (the others' are exact and left alone; they still
// count as sources).
kernel void horizon_visibility(global const float4* gpos, global const float4* gnrm,
                               global const pb_light* lights, global const uchar* mask, int nl,
                               int npixels, global const int* cand_off,
                               global const int* cand_idx, global float* vis) {
  const int p = get_global_id(0);
  if (p >= npixels || gpos[p].w == 0.0f) return;
  const float4 n = gnrm[p];
  for (int l = 0; l < nl; ++l) {
    if (!mask[l]) continue;
    const float wx = lights[l].dir[0], wy = lights[l].dir[1], wz = lights[l].dir[2];
    const float ca = lights[l].dir[3], sa = sqrt(fmax(1.0f - ca * ca, 0.0f));
    const float c = n.x * wx + n.y * wy + n.z * wz;
    if (!pb_on_horizon(c, sa, 0.0f)) continue;
    const size_t o = (size_t)l * npixels + p;
    int src[HZ_MAX_SOURCES];
    float m[4];
    const int ns = horizon_sources(n.x, n.y, n.z, c, wx, wy, wz, ca, sa, l, lights, cand_off,
                                   cand_idx, src, m);
    vis[o] = horizon_value(ns, src, n.x, n.y, n.z, m, l, p, npixels, lights, cand_off, cand_idx,
                           vis, vis[o]);
  }
}

// The CPU form (src/core/device_kind.hpp; the same bits): HZ_GROUP consecutive pixels per
// work-item, light by light, the horizon test in a SIMD loop over the pixels. Flat surfaces give
// runs of equal normals, whose sources are the same: found once a run (the function is
// deterministic, so the bits are the same), and the run's means taken together, each source's
// row read across the run in a SIMD loop (one pair at a time, each mean's serial sum and its
// division had been most of the step's time: `perf annotate`).
// Global size ceil(npixels / HZ_GROUP).
#ifndef HZ_GROUP
#define HZ_GROUP 64
#endif
kernel void horizon_visibility_batch(global const float4* gpos, global const float4* gnrm,
                                     global const pb_light* lights, global const uchar* mask,
                                     int nl, int npixels, global const int* cand_off,
                                     global const int* cand_idx, global float* vis) {
  const int p0 = get_global_id(0) * HZ_GROUP;
  if (p0 >= npixels) return;
  const int cnt = min(HZ_GROUP, npixels - p0);
  float nx[HZ_GROUP], ny[HZ_GROUP], nz[HZ_GROUP], cs[HZ_GROUP];
  int live[HZ_GROUP], pair[HZ_GROUP];
  global const float* nf = (global const float*)gnrm;
  for (int j = 0; j < HZ_GROUP; ++j) {
    const bool in = j < cnt && gpos[p0 + min(j, cnt - 1)].w != 0.0f;
    const int q = 4 * (p0 + min(j, cnt - 1));
    nx[j] = in ? nf[q] : 0.0f;
    ny[j] = in ? nf[q + 1] : 0.0f;
    nz[j] = in ? nf[q + 2] : 0.0f;
    live[j] = in;
  }
  for (int l = 0; l < nl; ++l) {
    if (!mask[l]) continue;
    const float wx = lights[l].dir[0], wy = lights[l].dir[1], wz = lights[l].dir[2];
    const float ca = lights[l].dir[3], sa = sqrt(fmax(1.0f - ca * ca, 0.0f));
    // the pairs below (the light's centre under the pixel's horizon, part of its cap above),
    // marked and counted: most groups have none for most lights, which then skip the scalar loop
    int pairs = 0;
PB_SIMD_LOOP(16)
    for (int j = 0; j < HZ_GROUP; ++j) {
      const float c = nx[j] * wx + ny[j] * wy + nz[j] * wz;
      cs[j] = c;
      pair[j] = live[j] && pb_on_horizon(c, sa, 0.0f);
      pairs += pair[j];
    }
    if (pairs == 0) continue;
    global float* out = vis + (size_t)l * npixels + p0;
    for (int j = 0; j < cnt; ++j) {
      if (!pair[j]) continue;
      // the run: the pairs from j to e, every one with j's normal
      const float lx = nx[j], ly = ny[j], lz = nz[j];
      int e = j;
      for (int k = j + 1; k < cnt; ++k) {
        if (!pair[k]) continue;
        if (nx[k] != lx || ny[k] != ly || nz[k] != lz) break;
        e = k;
      }
      int src[HZ_MAX_SOURCES];
      float m[4];
      const int ns = horizon_sources(lx, ly, lz, cs[j], wx, wy, wz, ca, sa, l, lights, cand_off,
                                     cand_idx, src, m);
      if (ns > 0) {
        // horizon_value's mean for the whole run: each source's row read across the run in a
        // SIMD loop, every pixel's sum taken in the sources' order
        float sum[HZ_GROUP];
PB_SIMD_LOOP(16)
        for (int k = j; k <= e; ++k) sum[k] = 0.0f;
        for (int i = 0; i < ns; ++i) {
          global const float* row = vis + (size_t)src[i] * npixels + p0;
PB_SIMD_LOOP(16)
          for (int k = j; k <= e; ++k) sum[k] += row[k];
        }
PB_SIMD_LOOP(16)
        for (int k = j; k <= e; ++k)
          if (pair[k]) out[k] = sum[k] / (float)ns;
      } else {
        for (int k = j; k <= e; ++k)
          if (pair[k])
            out[k] = horizon_value(ns, src, lx, ly, lz, m, l, p0 + k, npixels, lights, cand_off,
                                   cand_idx, vis, out[k]);
      }
      j = e;
    }
  }
}
