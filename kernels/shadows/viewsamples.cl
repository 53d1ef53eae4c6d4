// View samples and their light-space lists (Sintorn et al. 2008 §3.1), for the bitmask technique
// (src/shadows/bitmask.cpp, kernels/shadows/bitmask.cl).
//
// A view sample is a camera-visible G-buffer pixel that the light can reach: geometry, with the
// light's cap not wholly below its shading normal's horizon (Sintorn et al. 2008 Figure 2 keeps
// only
// light-front-facing samples; samples whose irradiance from the light is 0 need no visibility).
// Per light, in the light's orthographic frame (pb_light: ex, ey, dir):
//   vs_bounds   2D bounds and far depth of the light's view samples (work-group reduction, then
//               one atomic per group on order-preserving integer images of the floats)
//   vs_fit      the list grid fitted to those bounds, far plane at the farthest sample (§4.3)
//   vs_count    per texel list length by atomic increment; each sample keeps the value it read,
//               its index inside its texel's list
//   (scan)      exclusive offsets from an inclusive scan of the lengths (src/core/scan.cpp, int64)
//   vs_scatter  each sample's pixel index into one array, lists[light][offset + index] (4 bytes
//               an entry; the triangle stage recomputes the light-frame coordinates from the
//               G-buffer position, as the same pb_light_coords gives them here)
// The order inside a list depends on the atomics, nothing computed from the lists does.
#include "shared.h"

#ifndef VS_WG
#define VS_WG 64
#endif

// Positive floats order like their bit patterns read as int; flipping the 31 low bits of
// negative ones makes the whole float order match signed integer order.
static int ordered_int(float f) {
  int i = as_int(f);
  return i >= 0 ? i : i ^ 0x7fffffff;
}
static float ordered_float(int i) { return as_float(i >= 0 ? i : i ^ 0x7fffffff); }

// Geometry whose shading normal sees part of the light's cap (cap not wholly below the horizon).
static bool is_view_sample(float4 p, float3 n, const pb_light* L) {
  if (p.w == 0.0f) return false;
  float sin_a = sqrt(fmax(1.0f - L->dir[3] * L->dir[3], 0.0f));
  return dot(n, (float3)(L->dir[0], L->dir[1], L->dir[2])) > -sin_a;
}

// bounds[light * 8 + ...]: 0 xmin, 1 xmax, 2 ymin, 3 ymax, 4 zmax (ordered ints), 5 count.
// The host initializes them to (INT_MAX, INT_MIN, INT_MAX, INT_MIN, INT_MIN, 0).
kernel void vs_bounds(global const float4* gpos, global const float4* gnrm,
                      global const pb_light* lights, int npixels, volatile global int* bounds) {
  local int red[6][VS_WG];
  int px = get_global_id(0), l = get_global_id(1), lid = get_local_id(0);
  pb_light L = lights[l];
  int v[6] = {INT_MAX, INT_MIN, INT_MAX, INT_MIN, INT_MIN, 0};
  if (px < npixels && is_view_sample(gpos[px], gnrm[px].xyz, &L)) {
    float3 c = pb_light_coords(&L, gpos[px].xyz);
    v[0] = v[1] = ordered_int(c.x);
    v[2] = v[3] = ordered_int(c.y);
    v[4] = ordered_int(c.z);
    v[5] = 1;
  }
  for (int k = 0; k < 6; ++k) red[k][lid] = v[k];
  barrier(CLK_LOCAL_MEM_FENCE);
  for (int s = VS_WG / 2; s > 0; s >>= 1) {
    if (lid < s) {
      red[0][lid] = min(red[0][lid], red[0][lid + s]);
      red[1][lid] = max(red[1][lid], red[1][lid + s]);
      red[2][lid] = min(red[2][lid], red[2][lid + s]);
      red[3][lid] = max(red[3][lid], red[3][lid + s]);
      red[4][lid] = max(red[4][lid], red[4][lid + s]);
      red[5][lid] += red[5][lid + s];
    }
    barrier(CLK_LOCAL_MEM_FENCE);
  }
  if (lid == 0 && red[5][0] > 0) {
    volatile global int* b = bounds + (size_t)l * 8;
    atomic_min(&b[0], red[0][0]);
    atomic_max(&b[1], red[1][0]);
    atomic_min(&b[2], red[2][0]);
    atomic_max(&b[3], red[3][0]);
    atomic_max(&b[4], red[4][0]);
    atomic_add(&b[5], red[5][0]);
  }
}

// One work-item per light: the grid of Sintorn et al. 2008 §4.3, an axis-aligned box around the
// projected
// view samples (texels need not be square) with a margin of 1e-4 of its size, far plane at the
// farthest sample. hard: the light is its centre (tan_alpha 0).
kernel void vs_fit(global const int* bounds, global const pb_light* lights, int nlights, int size,
                   int hard, global pb_list_grid* grids) {
  int l = get_global_id(0);
  if (l >= nlights) return;
  global const int* b = bounds + (size_t)l * 8;
  pb_list_grid g;
  g.size = size;
  g.samples = b[5];
  float c = lights[l].dir[3];
  g.tan_alpha = hard ? 0.0f : sqrt(fmax(1.0f - c * c, 0.0f)) / fmax(c, 1e-6f);
  if (g.samples == 0) {
    g.x0 = g.y0 = 0.0f;
    g.sx = g.sy = 1.0f;
    g.zmax = 0.0f;
  } else {
    float x0 = ordered_float(b[0]), x1 = ordered_float(b[1]);
    float y0 = ordered_float(b[2]), y1 = ordered_float(b[3]);
    float m = 1e-4f * fmax(fmax(x1 - x0, y1 - y0), 1e-6f);
    g.x0 = x0 - m;
    g.y0 = y0 - m;
    g.sx = size / (x1 - x0 + 2.0f * m);
    g.sy = size / (y1 - y0 + 2.0f * m);
    g.zmax = ordered_float(b[4]);
  }
  grids[l] = g;
}

// Global (pixels, lights). counts[light][texel] must be zero; slot[light][pixel] gets the sample's
// index inside its list, -1 where the pixel is no view sample of that light. zfar[light][texel]
// (INT_MIN before) gets the depth of the texel's farthest sample as an ordered int: the far plane
// of each texel, which bounds the influence regions per texel far tighter than the grid's.
kernel void vs_count(global const float4* gpos, global const float4* gnrm,
                     global const pb_light* lights, global const pb_list_grid* grids, int npixels,
                     volatile global int* counts, global int* slot, volatile global int* zfar) {
  int px = get_global_id(0), l = get_global_id(1);
  if (px >= npixels) return;
  pb_light L = lights[l];
  size_t out = (size_t)l * npixels + px;
  if (!is_view_sample(gpos[px], gnrm[px].xyz, &L)) {
    slot[out] = -1;
    return;
  }
  pb_list_grid g = grids[l];
  float3 c = pb_light_coords(&L, gpos[px].xyz);
  int t = pb_grid_texel(&g, c.x, c.y);
  size_t at = (size_t)l * g.size * g.size + t;
  slot[out] = atomic_inc(&counts[at]);
  atomic_max(&zfar[at], ordered_int(c.z));
}

// The scan's input: list lengths widened to the int64 the exact scan takes.
kernel void vs_widen(global const int* counts, long n, global long* ends) {
  size_t i = get_global_id(0);
  if (i < n) ends[i] = counts[i];
}

// Global (pixels, lights). ends: inclusive scan of counts per light (list t is
// [ends[t] - counts[t], ends[t])). The texel is recomputed exactly as vs_count computed it. Each
// list entry holds the sample's light-frame coordinates and its pixel index (as_float bits), so
// the triangle stage reads a list contiguously and loads the G-buffer only for the few samples
// that survive its region test (kernels/shadows/bitmask.cl).
kernel void vs_scatter(global const float4* gpos, global const pb_light* lights,
                       global const pb_list_grid* grids, int npixels, global const int* counts,
                       global const long* ends, global const int* slot, global int* lists) {
  int px = get_global_id(0), l = get_global_id(1);
  if (px >= npixels) return;
  size_t at = (size_t)l * npixels + px;
  int s = slot[at];
  if (s < 0) return;
  pb_light L = lights[l];
  pb_list_grid g = grids[l];
  float3 c = pb_light_coords(&L, gpos[px].xyz);
  size_t t = (size_t)l * g.size * g.size + pb_grid_texel(&g, c.x, c.y);
  lists[(size_t)l * npixels + (size_t)(ends[t] - counts[t]) + s] = px;
}

// ---- CPU forms (src/core/device_kind.hpp; the same results) ----
// PoCL runs vs_bounds' tree reduction as loops split at each barrier, and vs_count a pixel at a
// time with two locked atomics each (131 thousand view samples on the 32-light frame's exact
// light). Here a work-item takes VS_GROUP consecutive pixels of one light: their tests and light
// coordinates in a SIMD loop (pb_light_coords_s; is_view_sample's test on scalars, dot3_s
// rounding as dot()), then
// - vs_bounds_batch: the run's minima, maxima and count, one atomic each, as one of vs_bounds'
//   work-groups adds its own (minima, maxima and sums of integers: the same in any grouping);
// - vs_count_batch: each run of consecutive samples in one texel takes its slots with one
//   atomic_add of its length and keeps its farthest depth with one atomic_max (consecutive pixels
//   mostly fall in one texel of the 64 x 64 grid). The slots of a texel's samples are again
//   0..n-1 in some order, which is all vs_count promises: nothing computed from the lists
//   depends on their order.
// Global (ceil(npixels / VS_GROUP), lights).
#ifndef VS_GROUP
#define VS_GROUP 64
#endif

// The view sample test and light coordinates of pixels px0 .. px0 + VS_GROUP - 1 (those past
// npixels, and those that are no view sample, get in[k] = 0).
static inline __attribute__((always_inline)) void vs_batch_coords(
    global const float* gpos, global const float* gnrm, const pb_light* L, int px0, int npixels,
    int* in, float* x, float* y, float* z) {
  const float sin_a = sqrt(fmax(1.0f - L->dir[3] * L->dir[3], 0.0f));
PB_SIMD_LOOP(16)
  for (int k = 0; k < VS_GROUP; ++k) {
    const int px = min(px0 + k, npixels - 1);
    const float nw = dot3_s(gnrm[4 * px], gnrm[4 * px + 1], gnrm[4 * px + 2], L->dir[0], L->dir[1],
                            L->dir[2]);
    in[k] = px0 + k < npixels && gpos[4 * px + 3] != 0.0f && nw > -sin_a;
    pb_light_coords_s(L, gpos[4 * px], gpos[4 * px + 1], gpos[4 * px + 2], &x[k], &y[k], &z[k]);
  }
}

kernel void vs_bounds_batch(global const float* gpos, global const float* gnrm,
                            global const pb_light* lights, int npixels,
                            volatile global int* bounds) {
  const int px0 = get_global_id(0) * VS_GROUP, l = get_global_id(1);
  if (px0 >= npixels) return;
  const pb_light L = lights[l];
  int in[VS_GROUP];
  float x[VS_GROUP], y[VS_GROUP], z[VS_GROUP];
  vs_batch_coords(gpos, gnrm, &L, px0, npixels, in, x, y, z);
  int v0 = INT_MAX, v1 = INT_MIN, v2 = INT_MAX, v3 = INT_MIN, v4 = INT_MIN, v5 = 0;
PB_SIMD_LOOP(16)
  for (int k = 0; k < VS_GROUP; ++k) {
    const int ox = ordered_int(x[k]), oy = ordered_int(y[k]), oz = ordered_int(z[k]);
    v0 = min(v0, in[k] ? ox : INT_MAX);
    v1 = max(v1, in[k] ? ox : INT_MIN);
    v2 = min(v2, in[k] ? oy : INT_MAX);
    v3 = max(v3, in[k] ? oy : INT_MIN);
    v4 = max(v4, in[k] ? oz : INT_MIN);
    v5 += in[k];
  }
  if (v5 == 0) return;
  volatile global int* b = bounds + (size_t)l * 8;
  atomic_min(&b[0], v0);
  atomic_max(&b[1], v1);
  atomic_min(&b[2], v2);
  atomic_max(&b[3], v3);
  atomic_max(&b[4], v4);
  atomic_add(&b[5], v5);
}

kernel void vs_count_batch(global const float* gpos, global const float* gnrm,
                           global const pb_light* lights, global const pb_list_grid* grids,
                           int npixels, volatile global int* counts, global int* slot,
                           volatile global int* zfar) {
  const int px0 = get_global_id(0) * VS_GROUP, l = get_global_id(1);
  if (px0 >= npixels) return;
  const pb_light L = lights[l];
  const pb_list_grid g = grids[l];
  int in[VS_GROUP], texel[VS_GROUP], oz[VS_GROUP];
  float x[VS_GROUP], y[VS_GROUP], z[VS_GROUP];
  vs_batch_coords(gpos, gnrm, &L, px0, npixels, in, x, y, z);
PB_SIMD_LOOP(16)
  for (int k = 0; k < VS_GROUP; ++k) {
    texel[k] = in[k] ? pb_grid_texel(&g, x[k], y[k]) : -1;
    oz[k] = ordered_int(z[k]);
  }
  const int cnt = min(VS_GROUP, npixels - px0);
  global int* out = slot + (size_t)l * npixels + px0;
  volatile global int* lc = counts + (size_t)l * g.size * g.size;
  volatile global int* lz = zfar + (size_t)l * g.size * g.size;
  for (int k = 0; k < cnt;) {
    if (texel[k] < 0) {
      out[k++] = -1;
      continue;
    }
    // the run k .. e - 1 of samples in texel t (pixels that are no sample end it)
    const int t = texel[k];
    int e = k + 1, far = oz[k];
    while (e < cnt && texel[e] == t) far = max(far, oz[e++]);
    const int first = atomic_add(&lc[t], e - k);
    atomic_max(&lz[t], far);
    for (int i = k; i < e; ++i) out[i] = first + (i - k);
    k = e;
  }
}

