// Sample-based visibility (Sintorn et al. 2008): every caster triangle, conservatively rasterized
// over the
// light-space list texels it can shadow, tests the view samples of those lists and ORs what it
// blocks into their bitmasks. Built per technique:
//   -DHARD         alias-free hard shadows (§3.2-3.3): one light sample, the light's centre
//                  direction; one bit per view sample, packed 32 to a word.
//   -DWORDS=W      soft shadows (§4): 32 W light samples on the light's disk, a W-word mask per
//                  view sample, the light-sample half-spaces of each edge plane from a look-up
//                  table (§4.2) of LUT_PHI x LUT_DELTA cells.
//
// Light model. A cap of half-angle alpha around dir is a disk of radius tan(alpha) at unit
// distance along dir, seen from infinitely far (gnomonic projection: the disk maps onto the cap
// exactly). Light sample k sits at (u_k, v_k) in the unit disk; its direction in the light frame
// (ex, ey, dir) is d_k ~ (tan(alpha) u_k, tan(alpha) v_k, 1).
//
// Occlusion. A ray from p along d hits triangle (a, b, c) iff d lies in the cone spanned by
// A = a - p, B = b - p, C = c - p: with det = A.(B x C) and the edge-plane normals
// n_ab = A x B, n_bc = B x C, n_ca = C x A oriented by sign(det), iff n.d >= 0 for all three
// (d = alpha A + beta B + gamma C gives n_ab.d = gamma det, ...). The cone of three independent
// half-spaces has one nappe, so the triangle's own plane needs no test of its own (a light at
// infinity is behind every triangle). A sample on the triangle's plane (det = 0) is never blocked
// by it. View samples are the G-buffer's positions, which sit a small offset off their own
// triangle along its camera-facing normal, where the Embree reference starts its shadow rays
// (src/scene/shadow_offset.hpp): so the sample's own triangle is tested as any other (it blocks
// the directions below its plane whose ray crosses it, as it does the reference's), and no depth
// bias is needed. Closed meshes (mesh_orient != 0) cast from their light-back-facing triangles
// only (Sintorn et al. 2008 §3.3): a ray from outside that hits a closed mesh enters it through a
// triangle
// facing away from the ray's direction, so the triangles that face every light sample can go.
// A ray that starts on a closed mesh and heads below its own triangle's plane is inside at once:
// bitmask_self blocks those samples (src/shadows/bitmask.cpp says why not the back-face rule
// alone, and for open meshes).
//
// Look-up table. For an edge plane with light-frame normal (nx, ny, nz), sample k is behind it iff
// nz + tan(alpha) (u_k nx + v_k ny) >= 0, i.e. u_k cos(phi) + v_k sin(phi) + delta >= 0 with
// phi = atan2(ny, nx) and delta = nz / (tan(alpha) sqrt(nx^2 + ny^2)): two parameters, the
// plane's angle around the light's axis and its distance from the disk's centre in disk radii
// (Sintorn et al.'s (2008) two angles and a distance, reduced by the disk's symmetry: rotations
// about the axis
// are phi, tilts are delta). delta >= 1: every sample; delta < -1: none. Two tables per cell:
// `in`, the samples behind the plane for every (phi, delta) of the cell, and `out`, those behind
// it for some. AND over the edges gives certain and possible blockers; the few possible but not
// certain ones (a band one cell wide along each cut) are tested exactly, so the result is the
// exact test's, at the table's cost. The two masks of a cell lie next to each other (lut[cell]:
// WORDS `in` words, then WORDS `out` words), so a look-up touches one cache line at 128 samples
// instead of two far apart: the tables (2 MiB at 128 samples) do not fit the CPU's L2.
#include "shared.h"

#ifndef LUT_PHI
#define LUT_PHI 128
#endif
#ifndef LUT_DELTA
#define LUT_DELTA 128
#endif
#ifndef WORDS
#define WORDS 1
#endif

static float3 vec3(const float* v) { return (float3)(v[0], v[1], v[2]); }

#ifndef HARD
// atan2 to a few 1e-7 rad (Abramowitz & Stegun 4.4.49 on [-1, 1], |error| <= 2e-8, plus float
// rounding), several times cheaper than the library's on the CPU. The cell only has to hold the
// plane within the tables' 1e-4 margin (src/shadows/bitmask.cpp): the samples it cannot decide
// are tested exactly, so the masks are the exact test's either way.
static float fast_atan2(float y, float x) {
  float ax = fabs(x), ay = fabs(y);
  float mx = fmax(ax, ay), mn = fmin(ax, ay);
  if (mx == 0.0f) return 0.0f;
  float t = mn / mx, t2 = t * t;
  float r = t * (1.0f + t2 * (-0.3333314528f + t2 * (0.1999355085f + t2 * (-0.1420889944f +
            t2 * (0.1065626393f + t2 * (-0.0752896400f + t2 * (0.0429096138f +
            t2 * (-0.0161657367f + t2 * 0.0028662257f))))))));
  if (ay > ax) r = M_PI_2_F - r;
  if (x < 0.0f) r = M_PI_F - r;
  return signbit(y) ? -r : r;
}

// Look-up cell of an edge plane whose delta is in [-1, 1). The tables are those of the unrotated
// sample set; jittered frames (Sintorn et al. 2008 §4.3) rotate every sample by rot in [0, 2 pi)
// about the
// disk's centre, and a sample at angle a + rot is behind a plane at angle phi exactly when the
// unrotated one at a is behind the plane at phi - rot: the same table, looked up at phi - rot.
static int lut_cell(float nx, float ny, float delta, float rot) {
  float phi = fast_atan2(ny, nx) - rot;  // [-pi, pi] - rot
  if (phi < -M_PI_F) phi += 2.0f * M_PI_F;
  int ip = (int)floor((phi + M_PI_F) * (LUT_PHI / (2.0f * M_PI_F)));
  int id = (int)floor((delta + 1.0f) * (0.5f * LUT_DELTA));
  ip = clamp(ip, 0, LUT_PHI - 1);
  id = clamp(id, 0, LUT_DELTA - 1);
  return ip * LUT_DELTA + id;
}
#endif

// Global (triangles, stripes, lights of the batch). Triangle `tri` of light l0 + z: its influence
// region's bounding box (§4.1: the hull of the light's disk projected through each vertex onto
// the far plane; its radius at vertex i is tan(alpha) (zmax - z_i)) in list texels, rows
// stripe, stripe + stripes, ...; each texel that survives the separating-axis test against the
// region is walked list by list.
kernel void bitmask_triangles(global const float4* pos, global const int4* tris, int ntris,
                              global const pb_light* lights, global const pb_list_grid* grids,
                              int l0, global const int* counts, global const long* ends,
                              global const int* lists, global const float4* gpos,
                              int npixels, global const uint* lut,
                              global const float2* disk, int stripes,
                              global const int* zfar, volatile global uint* masks,
                              global const int* mesh_orient, float rot,
                              global const float4* frames) {
  int tri = get_global_id(0), stripe = get_global_id(1), lb = get_global_id(2);
  if (tri >= ntris) return;
  int l = l0 + lb;
  pb_list_grid g = grids[l];
  if (g.samples == 0) return;
  pb_light L = lights[l];
  int4 t = tris[tri];
  float3 V[3] = {pos[t.x].xyz, pos[t.y].xyz, pos[t.z].xyz};
  float3 c[3];
  float R[3];
  float zmin = INFINITY;
  for (int i = 0; i < 3; ++i) {
    c[i] = pb_light_coords(&L, V[i]);
    zmin = fmin(zmin, c[i].z);
    R[i] = g.tan_alpha * fmax(g.zmax - c[i].z, 0.0f);
  }
  if (zmin > g.zmax) return;  // behind every view sample
  const float3 ex = vec3(L.ex), ey = vec3(L.ey), w = vec3(L.dir);
  const float ta = g.tan_alpha;
#ifndef HARD
  // the light's sampling frame (see bitmask_resolve): plane normals in it, scaled by f, meet
  // the unit-disk tables as a cap's do
  const float4 fa = frames[2 * l], fb = frames[2 * l + 1];
  const float3 e1 = fa.xyz, e2 = fb.xyz;
  const float f1 = fa.w, f2 = fb.w;
#endif
  if (mesh_orient[t.w] != 0) {
    // Closed mesh: skip the triangle when it faces every light sample d ~ w + ta (u ex + v ey),
    // |(u, v)| <= 1, i.e. n.w > ta |n - (n.w) w| (with a margin for rounding; keeping a
    // triangle is always safe).
    float3 nt = cross(V[1] - V[0], V[2] - V[0]) * (float)mesh_orient[t.w];  // outward
    float nw = dot(nt, w), nu = dot(nt, ex), nv = dot(nt, ey);
    if (nw - ta * sqrt(nu * nu + nv * nv) > 1e-4f * length(nt)) return;
  }
  float bx0 = INFINITY, bx1 = -INFINITY, by0 = INFINITY, by1 = -INFINITY;
  for (int i = 0; i < 3; ++i) {
    bx0 = fmin(bx0, c[i].x - R[i]);
    bx1 = fmax(bx1, c[i].x + R[i]);
    by0 = fmin(by0, c[i].y - R[i]);
    by1 = fmax(by1, c[i].y + R[i]);
  }
  float fi0 = floor((bx0 - g.x0) * g.sx), fi1 = floor((bx1 - g.x0) * g.sx);
  float fj0 = floor((by0 - g.y0) * g.sy), fj1 = floor((by1 - g.y0) * g.sy);
  if (fi1 < 0.0f || fj1 < 0.0f || fi0 > g.size - 1 || fj0 > g.size - 1) return;
  int i0 = max((int)fi0, 0), i1 = min((int)fi1, g.size - 1);
  int j0 = max((int)fj0, 0), j1 = min((int)fj1, g.size - 1);
  // Separating axes besides x and y: the projected triangle's edge normals. Along unit m the
  // region spans [min_i m.c_i - R_i, max_i m.c_i + R_i] (hull of the vertex disks).
  // Axes 3 and 4 are x and y: with a texel's own far plane the region shrinks below the box.
  float2 ax[5];
  float sc[5][3];  // vertex i's coordinate along axis a
  for (int e = 0; e < 3; ++e) {
    float2 d = c[(e + 1) % 3].xy - c[e].xy;
    float len = length(d);
    ax[e] = len > 0.0f ? (float2)(-d.y, d.x) / len : (float2)(0.0f);
  }
  ax[3] = (float2)(1.0f, 0.0f);
  ax[4] = (float2)(0.0f, 1.0f);
  for (int a = 0; a < 5; ++a)
    for (int i = 0; i < 3; ++i) sc[a][i] = dot(ax[a], c[i].xy);
  // The supporting plane (Sintorn et al. 2008 §4.3: "cut off the influence region based on the
  // triangle's
  // supporting plane"). In the light frame the samples' directions towards the light are
  // (ta u, ta v, -1), |(u, v)| <= 1. If the plane does not cut the light, every ray leaves the
  // plane's side that holds the light, so samples on that side (or on the plane, within float
  // rounding of the light-frame coordinates) cannot be blocked by the triangle: light side
  // lside = sign(-n.z), skipped when lside n.(q - c0) >= -eps. lside 0: the plane cuts the light.
  const float3 pn = cross(c[1] - c[0], c[2] - c[0]);
  const float pnl = length(pn);
  const float pd = dot(pn, c[0]);
  float lside = 0.0f;
  if (fabs(pn.z) > ta * sqrt(pn.x * pn.x + pn.y * pn.y) * 1.0001f + 1e-6f * pnl)
    lside = pn.z < 0.0f ? 1.0f : -1.0f;
  const int S = g.size;
  global const int* cnt = counts + (size_t)l * S * S;
  global const long* end = ends + (size_t)l * S * S;
  global const int* list = lists + (size_t)l * npixels;
  for (int j = j0 + stripe; j <= j1; j += stripes)
    for (int i = i0; i <= i1; ++i) {
      int n = cnt[j * S + i];
      if (n == 0) continue;
      int zi = zfar[(size_t)l * S * S + j * S + i];
      float zt = as_float(zi >= 0 ? zi : zi ^ 0x7fffffff);  // the texel's farthest sample
      if (zt <= zmin) continue;
      // texel box in light-frame coordinates, widened by a relative 1e-5 for rounding
      float tx0 = g.x0 + i / g.sx, tx1 = g.x0 + (i + 1) / g.sx;
      float ty0 = g.y0 + j / g.sy, ty1 = g.y0 + (j + 1) / g.sy;
      float pad = 1e-5f * (fabs(tx0) + fabs(ty0) + (tx1 - tx0) + (ty1 - ty0));
      float Rt[3];
      for (int v = 0; v < 3; ++v) Rt[v] = g.tan_alpha * fmax(zt - c[v].z, 0.0f);
      bool apart = false;
      for (int e = 0; e < 5 && !apart; ++e) {
        float s0 = ax[e].x * (ax[e].x >= 0.0f ? tx0 : tx1) + ax[e].y * (ax[e].y >= 0.0f ? ty0 : ty1);
        float s1 = ax[e].x * (ax[e].x >= 0.0f ? tx1 : tx0) + ax[e].y * (ax[e].y >= 0.0f ? ty1 : ty0);
        float lo = fmin(fmin(sc[e][0] - Rt[0], sc[e][1] - Rt[1]), sc[e][2] - Rt[2]);
        float hi = fmax(fmax(sc[e][0] + Rt[0], sc[e][1] + Rt[1]), sc[e][2] + Rt[2]);
        apart = s0 - pad > hi || s1 + pad < lo;
      }
      if (apart) continue;
      long first = end[j * S + i] - n;
      for (int s = 0; s < n; ++s) {
        // the list holds pixel indices (kernels/shadows/viewsamples.cl, vs_scatter); light-frame
        // coordinates by the same function as there, so the same bits
        int px = list[first + s];
        float3 p = gpos[px].xyz;
        float3 q = pb_light_coords(&L, p);
        // The sample's own depth bounds the region exactly at that depth (radius
        // tan(alpha) (z_p - z_i) at vertex i): most samples of a texel leave here.
        if (q.z <= zmin) continue;
        if (lside != 0.0f &&
            lside * (dot(pn, q) - pd) >= -1e-5f * pnl * (1.0f + fabs(q.x) + fabs(q.y) + fabs(q.z)))
          continue;
        {
          float pad = 1e-5f * (fabs(q.x) + fabs(q.y) + fabs(q.z));
          bool apart = false;
          for (int e = 0; e < 5 && !apart; ++e) {
            float s = dot(ax[e], q.xy), lo = INFINITY, hi = -INFINITY;
            for (int v = 0; v < 3; ++v) {
              float r = g.tan_alpha * fmax(q.z - c[v].z, 0.0f);
              lo = fmin(lo, sc[e][v] - r);
              hi = fmax(hi, sc[e][v] + r);
            }
            apart = s - pad > hi || s + pad < lo;
          }
          if (apart) continue;
        }
        float3 A = V[0] - p, B = V[1] - p, C = V[2] - p;
        float3 nrm[3] = {cross(A, B), cross(B, C), cross(C, A)};
        float det = dot(A, nrm[1]);
        if (det == 0.0f) continue;  // on the triangle's plane: the cone is flat
        float sg = det > 0.0f ? 1.0f : -1.0f;
#ifdef HARD
        // the light's centre direction w: blocked iff w is inside the cone
        if (sg * dot(nrm[0], w) >= 0.0f && sg * dot(nrm[1], w) >= 0.0f &&
            sg * dot(nrm[2], w) >= 0.0f) {
          size_t bit = (size_t)lb * npixels + px;
          atomic_or(&masks[bit >> 5], 1u << (uint)(bit & 31));
        }
#else
        float nx[3], ny[3], nz[3];
        int cell[3];
        bool none = false;
        int partial = 0;  // edges whose plane cuts the disk
        for (int e = 0; e < 3; ++e) {
          float3 m = sg * nrm[e];
          nx[e] = dot(m, e1) * f1;
          ny[e] = dot(m, e2) * f2;
          nz[e] = dot(m, w);
          float tr = ta * sqrt(nx[e] * nx[e] + ny[e] * ny[e]);
          if (nz[e] >= tr) continue;  // the whole disk is behind this edge's plane
          if (nz[e] < -tr) { none = true; break; }
          cell[partial++] = lut_cell(nx[e], ny[e], nz[e] / tr, rot);
        }
        if (none) continue;
        global volatile uint* mask = masks + ((size_t)lb * npixels + px) * WORDS;
        for (int k = 0; k < WORDS; ++k) {
          uint in = 0xffffffffu, out = 0xffffffffu;
          for (int e = 0; e < partial; ++e) {
            global const uint* cl = lut + (size_t)cell[e] * (2 * WORDS);
            in &= cl[k];
            out &= cl[WORDS + k];
          }
          uint bits = in, unsure = out & ~in;
          while (unsure != 0u) {
            uint low = unsure & (~unsure + 1u);
            int b = 31 - (int)clz(low);
            float2 uv = disk[k * 32 + b] * ta;
            if (nz[0] + uv.x * nx[0] + uv.y * ny[0] >= 0.0f &&
                nz[1] + uv.x * nx[1] + uv.y * ny[1] >= 0.0f &&
                nz[2] + uv.x * nx[2] + uv.y * ny[2] >= 0.0f)
              bits |= low;
            unsure &= ~low;
          }
          if (bits != 0u) atomic_or(&mask[k], bits);
        }
#endif
      }
    }
}

// Global (pixels, lights of the batch), before bitmask_triangles. A view sample on the inside of
// a closed mesh (mesh_orient != 0; the camera sees the triangle's inner face, so the G-buffer
// lifted the sample into the mesh) is blocked from every light sample below its own triangle's
// outward plane: that ray crosses the mesh's interior and must leave it through a triangle facing
// the light, which bitmask_triangles skips on closed meshes (Sintorn et al. 2008 §3.3). A sample
// on the outside starts outside the mesh, where the back-face rule is exact: its rays below its
// own plane meet the triangles that face away from them (its own among them), as the reference's
// rays from the same point do.
kernel void bitmask_self(global const float4* pos, global const int4* tris,
                         global const int* mesh_orient, global const uint* gids,
                         global const float4* ggeo, global const pb_light* lights,
                         global const pb_list_grid* grids, int l0, global const int* slot,
                         global const float2* disk, int npixels, volatile global uint* masks,
                         global const float4* frames) {
  int px = get_global_id(0), lb = get_global_id(1);
  if (px >= npixels) return;
  int l = l0 + lb;
  // Whether the sample is inside a closed mesh, and its triangle's outward normal.
  bool inside = slot[(size_t)l * npixels + px] >= 0;
  uint id = gids[px];
  inside = inside && id != PB_ID_EMPTY;
  float3 n = (float3)(0.0f);
  if (inside) {
    int4 t = tris[id];
    int o = mesh_orient[t.w];
    float3 a = pos[t.x].xyz, b = pos[t.y].xyz, c = pos[t.z].xyz;
    n = cross(b - a, c - a) * (float)o;
    inside = o != 0 && dot(n, ggeo[px].xyz) < 0.0f;  // seen from inside
  }
  pb_light L = lights[l];
#ifdef HARD
  if (!inside) return;
  float nz = dot(n, vec3(L.dir));
  if (nz < 0.0f) {
    size_t bit = (size_t)lb * npixels + px;
    atomic_or(&masks[bit >> 5], 1u << (uint)(bit & 31));
  }
#else
  // The pair's WORDS words are this work-item's alone, and it writes every one of them (0 where
  // no sample is below the plane): that empties the masks for bitmask_triangles, where a fill of
  // the whole buffer before the launch took one thread 1.5 ms on the 32-light frame.
  float4 fa = frames[2 * l], fb = frames[2 * l + 1];
  float nx = dot(n, fa.xyz) * fa.w, ny = dot(n, fb.xyz) * fb.w, nz = dot(n, vec3(L.dir));
  float ta = grids[l].tan_alpha;
  inside = inside && nz < ta * sqrt(nx * nx + ny * ny);  // else every sample is above the plane
  global volatile uint* mask = masks + ((size_t)lb * npixels + px) * WORDS;
  for (int k = 0; k < WORDS; ++k) {
    uint bits = 0u;
    if (inside)
      for (int i = 0; i < 32; ++i) {
        float2 uv = disk[k * 32 + i] * ta;
        if (nz + uv.x * nx + uv.y * ny < 0.0f) bits |= 1u << (uint)i;
      }
    mask[k] = bits;
  }
#endif
}

// Global (pixels, lights of the batch): visibility of light l0 + z at each pixel. Soft: the
// irradiance-weighted lit fraction of the light samples, as the shading integrates the cap:
// sample k stands for solid angle ~ cos^3(theta_k) (uniform area on the disk, gnomonic
// projection) and brings cos(theta between n and d_k), so with d'_k = (tan u, tan v, 1) its
// weight is max(0, n'.d'_k) / |d'_k|^4. Pixels that are no view sample of the light get 1 (their
// visibility is never used), as does a sample set wholly below the horizon.
// frames: per light, two float4 (e1, f1), (e2, f2) (src/shadows/bitmask.hpp BitmaskFrame): disk
// sample (u, v) is the direction ~ dir + tan(alpha) (f1 u e1 + f2 v e2). A cap or polygon uses its
// light frame's ex, ey and f = 1; an ellipse its own axes and f = tan(half-angle) / tan(alpha), the
// disk's affine image (Sintorn et al. 2008 §4.1's scaling), so tables and triangle stage stay
// shared by
// every light. weights: per light, one per sample (Sintorn et al. 2008 §4.1, textured sources): 0
// for a
// polygon's disk samples outside it, the texture's relative luminance on textured lights, else 1;
// visibility = sum over lit samples of weight x irradiance factor / the same sum over all.
kernel void bitmask_resolve(global const float4* gnrm, global const pb_light* lights,
                            global const pb_list_grid* grids, int l0, global const int* slot,
                            global const float2* disk, int npixels, global const uint* masks,
                            global float* vis, global const float* weights,
                            global const float4* frames) {
  int px = get_global_id(0), lb = get_global_id(1);
  if (px >= npixels) return;
  int l = l0 + lb;
  size_t out = (size_t)l * npixels + px;
  if (slot[out] < 0) {
    vis[out] = 1.0f;
    return;
  }
#ifdef HARD
  size_t bit = (size_t)lb * npixels + px;
  vis[out] = (masks[bit >> 5] >> (uint)(bit & 31)) & 1u ? 0.0f : 1.0f;
#else
  global const uint* mask = masks + ((size_t)lb * npixels + px) * WORDS;
  uint any = 0u;
  for (int k = 0; k < WORDS; ++k) any |= mask[k];
  if (any == 0u) {
    vis[out] = 1.0f;
    return;
  }
  pb_light L = lights[l];
  float ta = grids[l].tan_alpha;
  float3 n = gnrm[px].xyz;
  float4 fa = frames[2 * l], fb = frames[2 * l + 1];
  float2 f = (float2)(fa.w, fb.w);
  float nx = dot(n, fa.xyz), ny = dot(n, fb.xyz), nz = dot(n, vec3(L.dir));
  global const float* sw = weights + (size_t)l * (WORDS * 32);
  float total = 0.0f, lit = 0.0f;
  for (int k = 0; k < WORDS; ++k) {
    uint m = mask[k];
    for (int b = 0; b < 32; ++b) {
      float s = sw[k * 32 + b];
      if (s == 0.0f) continue;  // outside a polygon light, or black texture
      float2 uv = disk[k * 32 + b] * ta * f;
      float q = 1.0f + dot(uv, uv);
      float wgt = fmax(nz + uv.x * nx + uv.y * ny, 0.0f) / (q * q) * s;
      total += wgt;
      if (((m >> b) & 1u) == 0u) lit += wgt;
    }
  }
  vis[out] = total > 0.0f ? lit / total : 1.0f;
#endif
}

#ifndef HARD
// bitmask_resolve for CPU devices (src/core/device_kind.hpp), where PoCL runs it one work-item at
// a time, each pixel's 256-sample loop scalar (`perf annotate`: no zmm instruction). Here a
// work-item takes RS_GROUP consecutive pixels of one light: a scalar loop reads each pixel's slot,
// mask words and normal (the same dot() as bitmask_resolve), then the samples run in order, each
// over the pixels in a SIMD loop, so that every pixel's two sums are formed in bitmask_resolve's
// order from the same operands: the same bits (tests/test_render_stages.cpp). A sample's weight
// of 0 skips it for every pixel at once, as it does for each one there. Global size
// (ceil(npixels / RS_GROUP), lights of the batch).
#ifndef RS_GROUP
#define RS_GROUP 64
#endif
kernel void bitmask_resolve_batch(global const float4* gnrm, global const pb_light* lights,
                                  global const pb_list_grid* grids, int l0,
                                  global const int* slot, global const float2* disk,
                                  int npixels, global const uint* masks, global float* vis,
                                  global const float* weights, global const float4* frames) {
  const int px0 = get_global_id(0) * RS_GROUP, lb = get_global_id(1);
  if (px0 >= npixels) return;
  const int cnt = min(RS_GROUP, npixels - px0);
  const int l = l0 + lb;
  pb_light L = lights[l];
  const float ta = grids[l].tan_alpha;
  const float4 fa = frames[2 * l], fb = frames[2 * l + 1];
  const float2 f = (float2)(fa.w, fb.w);
  float nx[RS_GROUP], ny[RS_GROUP], nz[RS_GROUP], total[RS_GROUP], lit[RS_GROUP];
  uint mw[WORDS][RS_GROUP];
  bool go[RS_GROUP];  // the pixel's visibility is the sums' ratio
  int todo = 0;
  for (int k = 0; k < RS_GROUP; ++k) {
    const int px = px0 + min(k, cnt - 1);
    const size_t out = (size_t)l * npixels + px;
    global const uint* mask = masks + ((size_t)lb * npixels + px) * WORDS;
    uint any = 0u;
    for (int w = 0; w < WORDS; ++w) {
      mw[w][k] = mask[w];
      any |= mw[w][k];
    }
    // bitmask_resolve's early outs: 1 where the pixel is no view sample of the light, or no
    // sample of it is blocked
    go[k] = k < cnt && slot[out] >= 0 && any != 0u;
    if (k < cnt && !go[k]) vis[out] = 1.0f;
    todo += go[k];
    const float3 n = gnrm[px].xyz;
    nx[k] = dot(n, fa.xyz);
    ny[k] = dot(n, fb.xyz);
    nz[k] = dot(n, vec3(L.dir));
    total[k] = 0.0f;
    lit[k] = 0.0f;
  }
  if (todo == 0) return;
  global const float* sw = weights + (size_t)l * (WORDS * 32);
  for (int w = 0; w < WORDS; ++w)
    for (int b = 0; b < 32; ++b) {
      const float s = sw[w * 32 + b];
      if (s == 0.0f) continue;  // outside a polygon light, or black texture
      const float2 uv = disk[w * 32 + b] * ta * f;
      const float q = 1.0f + dot(uv, uv);
PB_SIMD_LOOP(16)
      for (int k = 0; k < RS_GROUP; ++k) {
        const float wgt = fmax(nz[k] + uv.x * nx[k] + uv.y * ny[k], 0.0f) / (q * q) * s;
        total[k] += wgt;
        lit[k] = ((mw[w][k] >> b) & 1u) == 0u ? lit[k] + wgt : lit[k];
      }
    }
  for (int k = 0; k < cnt; ++k)
    if (go[k]) vis[(size_t)l * npixels + px0 + k] = total[k] > 0.0f ? lit[k] / total[k] : 1.0f;
}
#endif
