// Shadow-map techniques that sample the depth map explicitly, texel by texel: hard shadows (one
// depth test at the light's centre), percentage-closer soft shadows (PCSS, Fernando 2005: seed
// 003 eqs. 4-6 evaluated by explicit sampling) and brute force (K point-light shadow maps per area
// light, Annen et al. 2008 Fig. 11d). None of them prefilters: each reads the raw depth maps (uint
// bits of
// the ray distance from the map's near plane, PB_DEPTH_EMPTY = +inf where nothing was hit).
//
// Every depth test compares a texel against the receiver's own plane at that texel's centre
// (receiver-plane depth, Isidoro 2006): the G-buffer's geometric normal gives the plane's depth
// gradient in the map, so a tilted surface never shadows itself whatever the filter width, and
// only opt.shadow.depthBias (normalized depth) is added for the rasterizer's float error.
#include "shared.h"
#include "filter.clh"
#include "shadow_params.h"

// A receiver as one depth map sees it.
typedef struct {
  float u, v;       // continuous texel coordinates (column, row; row 0 at +ey), inside [0, size]
  float d;          // normalized depth (0 at the near plane, 1 at the far plane)
  float du, dv;     // receiver plane: normalized depth per texel along u and along v
  float tx, ty;     // world size of a texel along x and y
  float range;      // world depth range of the map
} map_point;

// Texel coordinates and depth exactly as kernels/shadows/moments.cl's mssm4_visibility computes
// them (the orthographic view of raster.cl), plus the receiver plane of geometric normal g (0: no
// plane), its slope clamped to max_slope (filter.clh, receiver_slope).
static map_point map_point_of(const pb_light* L, float3 p, float3 g, int size, float max_slope) {
  float3 w = (float3)(L->dir[0], L->dir[1], L->dir[2]);
  float3 ex = (float3)(L->ex[0], L->ex[1], L->ex[2]), ey = (float3)(L->ey[0], L->ey[1], L->ey[2]);
  float3 org = (float3)(L->origin[0], L->origin[1], L->origin[2]);
  float hx = L->ex[3], hy = L->ey[3];
  map_point m;
  m.range = L->origin[3];
  float3 r = p - org;
  m.u = clamp((dot(r, ex) / hx + 1.0f) * 0.5f * size, 0.0f, (float)size);
  m.v = clamp((1.0f - dot(r, ey) / hy) * 0.5f * size, 0.0f, (float)size);
  m.d = dot(r, -w) / m.range;
  m.tx = 2.0f * hx / size;
  m.ty = 2.0f * hy / size;
  float2 slope = receiver_slope(g, ex, ey, w, m.tx, m.ty, m.range, max_slope);
  m.du = slope.x;
  m.dv = slope.y;
  return m;
}

// Normalized depth of texel (i, j); +inf where the map is empty (never a blocker).
static float texel_depth(global const uint* map, int size, int i, int j, float range) {
  return as_float(map[(size_t)j * size + i]) / range;
}

// Receiver depth at the centre of texel (i, j), less the bias: what the texel is compared with.
static float receiver_depth(const map_point* m, int i, int j, float bias) {
  return m->d - bias + m->du * (i + 0.5f - m->u) + m->dv * (j + 0.5f - m->v);
}

// One hard depth test at the texel that holds the receiver (nearest texel): 1 lit, 0 shadowed.
static float hard_test(global const uint* map, int size, const map_point* m, float bias) {
  int i = min((int)m->u, size - 1), j = min((int)m->v, size - 1);
  return texel_depth(map, size, i, j, m->range) < receiver_depth(m, i, j, bias) ? 0.0f : 1.0f;
}

// ------------------------------------------------------------------------------------------------
// Hard shadows: visibility 0/1 from the standard map at the light's centre.
kernel void hard_visibility(global const float4* gpos, global const float4* gnrm,
                            global const float4* ggeo, global const pb_light* lights,
                            global const uint* depth, int size, int npixels, float depth_bias,
                            global float* vis) {
  int px = get_global_id(0), l = get_global_id(1);
  if (px >= npixels) return;
  size_t out = (size_t)l * npixels + px;
  float4 p4 = gpos[px];
  if (p4.w == 0.0f) { vis[out] = 1.0f; return; }
  pb_light L = lights[l];
  if (light_below_horizon(gnrm[px].xyz, &L)) { vis[out] = 1.0f; return; }
  map_point m = map_point_of(&L, p4.xyz, ggeo[px].xyz, size, PB_MAX_RECEIVER_SLOPE);
  vis[out] = hard_test(depth + (size_t)l * size * size, size, &m, depth_bias);
}

// Hard shadows for CPU devices (src/shadows/hard.cpp picks it where the CPU forms run,
// src/core/device_kind.hpp). PoCL runs hard_visibility one work-item at a time: its float3 values
// and the copy of the light keep the work-group loop from vectorizing. Here a work-item takes
// HARD_GROUP consecutive pixels and every light: it copies the pixels' G-buffer values into
// arrays once (a scalar loop: in a SIMD loop each float of the float4 G-buffers would be a
// gather, for every light), then runs each light over them in a SIMD loop over scalars (the map's
// texel one gather per lane, the light's row of visibility contiguous stores; lanes past the last
// pixel repeat it and write nothing). The loop repeats map_point_of, receiver_slope and hard_test
// operation for operation (dot3_s rounds as the library's dot()), so both kernels give the same
// bits (tests/test_mssm.cpp, HardShadows.BatchedVisibilityKernelIsBitIdentical). Global size
// ceil(npixels / HARD_GROUP).
#ifndef HARD_GROUP
#define HARD_GROUP 64
#endif
kernel void hard_visibility_batch(global const float* gpos, global const float* gnrm,
                                  global const float* ggeo, global const pb_light* lights,
                                  int nlights, global const uint* depth, int size, int npixels,
                                  float depth_bias, global float* vis) {
  const int px0 = get_global_id(0) * HARD_GROUP;
  const int n = min(HARD_GROUP, npixels - px0);
  float P[3][HARD_GROUP], N[3][HARD_GROUP], G[3][HARD_GROUP];
  bool geometry[HARD_GROUP];
PB_SCALAR_LOOP
  for (int k = 0; k < HARD_GROUP; ++k) {
    const int px = min(px0 + k, npixels - 1);
    for (int c = 0; c < 3; ++c) {
      P[c][k] = gpos[4 * px + c];
      N[c][k] = gnrm[4 * px + c];
      G[c][k] = ggeo[4 * px + c];
    }
    geometry[k] = gpos[4 * px + 3] != 0.0f;
  }
  for (int l = 0; l < nlights; ++l) {
    global const pb_light* L = lights + l;
    global const uint* map = depth + (size_t)l * size * size;
    global float* out = vis + (size_t)l * npixels + px0;
    const float wx = L->dir[0], wy = L->dir[1], wz = L->dir[2];
    const float exx = L->ex[0], exy = L->ex[1], exz = L->ex[2];
    const float eyx = L->ey[0], eyy = L->ey[1], eyz = L->ey[2];
    const float ox = L->origin[0], oy = L->origin[1], oz = L->origin[2];
    const float hx = L->ex[3], hy = L->ey[3], range = L->origin[3];
    const float sin_a = sqrt(fmax(1.0f - L->dir[3] * L->dir[3], 0.0f));
    const float tx = 2.0f * hx / size, ty = 2.0f * hy / size;
PB_SIMD_LOOP(16)
    for (int k = 0; k < HARD_GROUP; ++k) {
      // | and selects, no short-circuit: no branch in the SIMD loop
      const bool dead = !geometry[k] | (dot3_s(N[0][k], N[1][k], N[2][k], wx, wy, wz) <= -sin_a);
      // map_point_of
      const float rx = P[0][k] - ox, ry = P[1][k] - oy, rz = P[2][k] - oz;
      const float u = clamp((dot3_s(rx, ry, rz, exx, exy, exz) / hx + 1.0f) * 0.5f * size, 0.0f,
                            (float)size);
      const float v = clamp((1.0f - dot3_s(rx, ry, rz, eyx, eyy, eyz) / hy) * 0.5f * size, 0.0f,
                            (float)size);
      const float d = dot3_s(rx, ry, rz, -wx, -wy, -wz) / range;
      // receiver_slope
      const float gx = G[0][k], gy = G[1][k], gz = G[2][k];
      const float nz = dot3_s(gx, gy, gz, wx, wy, wz);
      // copysign(fmax(fabs(nz), 1e-6f), nz), on the bits
      const float inv =
          1.0f / as_float(as_int(fmax(fabs(nz), 1e-6f)) | (as_int(nz) & (int)0x80000000));
      float sx = dot3_s(gx, gy, gz, exx, exy, exz) * inv;
      float sy = dot3_s(gx, gy, gz, eyx, eyy, eyz) * inv;
      const float len = sqrt(sx * sx + sy * sy);
      const bool steep = len > PB_MAX_RECEIVER_SLOPE;
      sx = steep ? sx * (PB_MAX_RECEIVER_SLOPE / len) : sx;
      sy = steep ? sy * (PB_MAX_RECEIVER_SLOPE / len) : sy;
      const float du = sx * tx / range, dv = -sy * ty / range;
      // hard_test
      const int i = min((int)u, size - 1), j = min((int)v, size - 1);
      const float z = as_float(map[dead ? 0 : (size_t)j * size + i]) / range;
      const float receiver = d - depth_bias + du * (i + 0.5f - u) + dv * (j + 0.5f - v);
      const float lit = (dead | !(z < receiver)) ? 1.0f : 0.0f;
      if (k < n) out[k] = lit;
    }
  }
}

// ------------------------------------------------------------------------------------------------
// PCSS (Fernando 2005), Kneiphof 2017 §3.2: blocker search (eq. 4), penumbra width (eq. 5 for a
// light
// at infinity), percentage-closer filter (eq. 6), each convolution computed by sampling the map.

// Sums over the box [x0,x1] x [y0,y1] (texel units, inside [0,size]) of the piecewise-constant
// map, each texel weighted by the area of it the box covers (the box filter w of eqs. 4 and 6
// with fractional edges, as kernels/shadows/filter.clh's box_mean: no popping as the box grows):
// x = sum w [z < d], y = sum w z [z < d], z = sum w. Cost: the box's area in texels.
static float3 box_scan(global const uint* map, int size, float x0, float y0, float x1, float y1,
                       const map_point* m, float bias) {
  int i0 = min((int)x0, size - 1), i1 = min((int)ceil(x1) - 1, size - 1);
  int j0 = min((int)y0, size - 1), j1 = min((int)ceil(y1) - 1, size - 1);
  i1 = max(i1, i0);
  j1 = max(j1, j0);
  float3 acc = (float3)(0.0f);
  for (int j = j0; j <= j1; ++j) {
    float wy = fmin(y1, j + 1.0f) - fmax(y0, (float)j);
    if (wy <= 0.0f) continue;
    for (int i = i0; i <= i1; ++i) {
      float wx = fmin(x1, i + 1.0f) - fmax(x0, (float)i);
      if (wx <= 0.0f) continue;
      float w = wx * wy;
      float z = texel_depth(map, size, i, j, m->range);
      if (z < receiver_depth(m, i, j, bias)) {
        acc.x += w;
        acc.y += w * z;
      }
      acc.z += w;
    }
  }
  return acc;
}

// The same sums from a g x g grid of taps over the box. A regular grid rather than Fernando's
// Poisson disc because the filter of eqs. 4-6 here is a box (the disc's equal-area square, as
// MSSM filters), and the grid is deterministic without per-pixel rotation.
// Blocker search (bilinear = 0): nearest-texel taps on a grid that spans the box edge to edge, so
// blockers anywhere along the box's border are found (a cell-centre grid misses those covering
// less than half a cell, 1/(2g) of the box, and calls the pixel lit where the profile is still
// 1/(2g) below 1).
// Filter (bilinear = 1): taps at the g x g cell centres (the midpoint rule of the box filter, which
// converges to box_scan as g grows), each a 2x2 bilinear percentage-closer lookup, the hardware
// PCF of Fernando's shader. Cost: g^2 (x 4 when bilinear) texels whatever the box's size.
static float3 grid_scan(global const uint* map, int size, float x0, float y0, float x1, float y1,
                        int g, int bilinear, const map_point* m, float bias) {
  float3 acc = (float3)(0.0f);
  for (int b = 0; b < g; ++b)
    for (int a = 0; a < g; ++a) {
      if (!bilinear) {
        // edge to edge; one tap: the centre
        float fa = g > 1 ? (float)a / (g - 1) : 0.5f, fb = g > 1 ? (float)b / (g - 1) : 0.5f;
        float x = x0 + fa * (x1 - x0), y = y0 + fb * (y1 - y0);
        // the texel holding the tap, never one past the box's far edge
        int i = min(min((int)x, (int)ceil(x1) - 1), size - 1);
        int j = min(min((int)y, (int)ceil(y1) - 1), size - 1);
        float z = texel_depth(map, size, i, j, m->range);
        if (z < receiver_depth(m, i, j, bias)) {
          acc.x += 1.0f;
          acc.y += z;
        }
        acc.z += 1.0f;
        continue;
      }
      float x = x0 + (a + 0.5f) * (x1 - x0) / g, y = y0 + (b + 0.5f) * (y1 - y0) / g;
      float fx = x - 0.5f, fy = y - 0.5f;
      int i = (int)floor(fx), j = (int)floor(fy);
      float ax = fx - i, ay = fy - j;
      for (int q = 0; q < 4; ++q) {
        int ii = clamp(i + (q & 1), 0, size - 1), jj = clamp(j + (q >> 1), 0, size - 1);
        float w = ((q & 1) ? ax : 1.0f - ax) * ((q >> 1) ? ay : 1.0f - ay);
        float z = texel_depth(map, size, ii, jj, m->range);
        if (z < receiver_depth(m, ii, jj, bias)) {
          acc.x += w;
          acc.y += w * z;
        }
        acc.z += w;
      }
    }
  return acc;
}

static int grid_side(int taps) { return max(1, (int)(sqrt((float)taps) + 0.5f)); }

// Visibility of each light at each pixel: vis[light][pixel]. One work-item per (pixel, light).
kernel void pcss_visibility(global const float4* gpos, global const float4* gnrm,
                            global const float4* ggeo, global const pb_light* lights,
                            global const uint* depth, int size, int npixels, pcss_params P,
                            global float* vis) {
  int px = get_global_id(0), l = get_global_id(1);
  if (px >= npixels) return;
  size_t out = (size_t)l * npixels + px;
  float4 p4 = gpos[px];
  if (p4.w == 0.0f) { vis[out] = 1.0f; return; }
  pb_light L = lights[l];
  if (light_below_horizon(gnrm[px].xyz, &L)) { vis[out] = 1.0f; return; }
  float3 g = P.receiver_plane ? ggeo[px].xyz : (float3)(0.0f);
  map_point m = map_point_of(&L, p4.xyz, g, size, PB_UNCLAMPED_SLOPE);
  global const uint* map = depth + (size_t)l * size * size;
  float texel = fmin(m.tx, m.ty);
  float cos_a = L.dir[3];
  float tan_a = sqrt(fmax(1.0f - cos_a * cos_a, 0.0f)) / fmax(cos_a, 1e-4f) * P.light_size_scale;

  // 1. blocker search (eq. 4) over the region that can hold blockers of this light, the same box
  //    MSSM4 searches: distance to the near plane times the light's angular size.
  float search = BOX_FROM_DISC * m.d * m.range * tan_a;
  float hs = clamp(search / texel, 0.5f * P.min_filter, 0.5f * P.max_filter);
  float ax = hs * texel / m.tx, ay = hs * texel / m.ty;
  float x0 = fmax(m.u - ax, 0.0f), x1 = fmin(m.u + ax, (float)size);
  float y0 = fmax(m.v - ay, 0.0f), y1 = fmin(m.v + ay, (float)size);
  float3 s = P.blocker_taps > 0
                 ? grid_scan(map, size, x0, y0, x1, y1, grid_side(P.blocker_taps), 0, &m, P.depth_bias)
                 : box_scan(map, size, x0, y0, x1, y1, &m, P.depth_bias);
  if (!(s.x > 0.0f)) { vis[out] = 1.0f; return; }  // no blocker in front: fully lit
  float z_avg = s.y / s.x;

  // 2. penumbra width, eq. 5 for a light at infinity: blockers (d - z_avg) range above the
  //    receiver spread the light's disc to radius (d - z_avg) range tan(alpha).
  float pen = BOX_FROM_DISC * fmax(m.d - z_avg, 0.0f) * m.range * tan_a;
  float hf = clamp(pen / texel, 0.5f * P.min_filter, 0.5f * P.max_filter);
  ax = hf * texel / m.tx;
  ay = hf * texel / m.ty;
  x0 = fmax(m.u - ax, 0.0f);
  x1 = fmin(m.u + ax, (float)size);
  y0 = fmax(m.v - ay, 0.0f);
  y1 = fmin(m.v + ay, (float)size);

  // 3. percentage-closer filter, eq. 6: the lit fraction of the box.
  float3 f = P.filter_taps > 0
                 ? grid_scan(map, size, x0, y0, x1, y1, grid_side(P.filter_taps), 1, &m, P.depth_bias)
                 : box_scan(map, size, x0, y0, x1, y1, &m, P.depth_bias);
  vis[out] = f.z > 0.0f ? clamp(1.0f - f.x / f.z, 0.0f, 1.0f) : 1.0f;
}

// ------------------------------------------------------------------------------------------------
// Brute force (Annen et al. 2008 Fig. 11d): K point lights per area light at directions spread
// uniformly
// in solid angle over its cap (samples[l * K + k], each with its own orthographic frame), one hard
// shadow map each. The cap radiates uniformly and the shading multiplies the cap's irradiance by
// the visibility, so the visibility is irradiance-weighted:
//   V = sum_k s_k max(0, n.w_k) V_k / sum_k s_k max(0, n.w_k)
// (the cosine weights make a light clipped by the horizon or tilted against the surface count
// each direction by what it adds to the irradiance; s_k = samples[k].radiance[3] is the sample's
// weight, lights.hpp lightSamples: 1 for the equal solid angles of an untextured cap or polygon,
// the solid angle and texture luminance it stands for otherwise).
//
// The maps come in batches of `count` consecutive samples starting at flat index `first` (they
// hold maps[(f - first) * size^2]); a light's samples may span batches. Work-item (pixel, light
// l0 + id): the batch holding a light's first sample writes its share, later batches add theirs,
// each share divided by the sum of all K weights, so the order of additions is fixed.
kernel void brute_visibility(global const float4* gpos, global const float4* gnrm,
                             global const float4* ggeo, global const pb_light* lights,
                             global const pb_light* samples, global const uint* maps, int size,
                             int K, int first, int count, int l0, int npixels, float depth_bias,
                             global float* vis) {
  int px = get_global_id(0), l = l0 + (int)get_global_id(1);
  if (px >= npixels) return;
  int lo = max(first, l * K), hi = min(first + count, (l + 1) * K);
  if (lo >= hi) return;
  bool opens = lo == l * K;  // this batch holds the light's first sample
  size_t out = (size_t)l * npixels + px;
  float4 p4 = gpos[px];
  if (p4.w == 0.0f) {
    if (opens) vis[out] = 1.0f;
    return;
  }
  pb_light L = lights[l];
  float3 n = gnrm[px].xyz;
  if (light_below_horizon(n, &L)) {
    if (opens) vis[out] = 1.0f;
    return;
  }
  float total = 0.0f;
  for (int k = l * K; k < (l + 1) * K; ++k)
    total += fmax(dot(n, (float3)(samples[k].dir[0], samples[k].dir[1], samples[k].dir[2])), 0.0f) *
             samples[k].radiance[3];
  if (!(total > 0.0f)) {  // the cap's sampled directions all lie below the horizon
    if (opens) vis[out] = 1.0f;
    return;
  }
  float3 g = ggeo[px].xyz;
  float lit = 0.0f;
  for (int k = lo; k < hi; ++k) {
    pb_light S = samples[k];
    float c = dot(n, (float3)(S.dir[0], S.dir[1], S.dir[2]));
    if (c <= 0.0f) continue;
    map_point m = map_point_of(&S, p4.xyz, g, size, PB_MAX_RECEIVER_SLOPE);
    lit += c * S.radiance[3] * hard_test(maps + (size_t)(k - first) * size * size, size, &m, depth_bias);
  }
  float share = lit / total;
  vis[out] = opens ? share : fmin(vis[out] + share, 1.0f);
}
