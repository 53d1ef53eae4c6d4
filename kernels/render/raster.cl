// Rasterization on the device by ray casting, row by row, over each triangle's screen outline (its
// span in each row of its bounding box; -DRASTER_FULL_BOX tests the whole box, for the test that
// the spans change nothing).
//
// Each pixel's depth is the exact ray/triangle distance along the same ray the Embree reference
// traces (pb_view, scene.hpp's cameraRayDirection), so camera G-buffers match the ground truth
// pixel for pixel, and triangles crossing the camera's near plane need no special care beyond a
// clipped bounding box. Work is split over (triangle, row stripe, view) so that large triangles
// are shared by several work-items. Depth is resolved with atomic_min on the float's bit pattern
// (positive floats order like unsigned ints), triangle ids in a second pass with atomic_min among
// the triangles that reached the minimum: deterministic whatever the execution order. (The CPU
// forms give each view (raster_views) or each band of the camera's rows (raster_bands) one
// work-item, which keeps the minimum without atomics.)
#include "shared.h"

#define RASTER_EPS 1e-6f

static float3 f3(const float* v) { return (float3)(v[0], v[1], v[2]); }

// Ray through pixel centre (px, py) (continuous pixel coordinates) of a view.
static void view_ray(const pb_view* v, float px, float py, float3* o, float3* d) {
  float sx = 2.0f * px / v->width - 1.0f;
  float sy = 1.0f - 2.0f * py / v->height;
  float3 right = f3(v->right), up = f3(v->up), fwd = f3(v->forward), org = f3(v->origin);
  if (v->ortho) {
    *o = org + sx * v->right[3] * right + sy * v->up[3] * up;
    *d = fwd;
  } else {
    *o = org;
    *d = normalize(fwd + sx * v->right[3] * right + sy * v->up[3] * up);
  }
}

// Two-sided Moller-Trumbore; returns t > 0 or +inf. Barycentrics (b1, b2) of vertices 1 and 2.
static float ray_triangle(float3 o, float3 d, float3 a, float3 b, float3 c, float* b1, float* b2) {
  float3 e1 = b - a, e2 = c - a;
  float3 p = cross(d, e2);
  float det = dot(e1, p);
  if (fabs(det) < 1e-20f) return INFINITY;
  float inv = 1.0f / det;
  float3 s = o - a;
  float u = dot(s, p) * inv;
  if (u < -RASTER_EPS || u > 1.0f + RASTER_EPS) return INFINITY;
  float3 q = cross(s, e1);
  float v = dot(d, q) * inv;
  if (v < -RASTER_EPS || u + v > 1.0f + RASTER_EPS) return INFINITY;
  float t = dot(e2, q) * inv;
  *b1 = u;
  *b2 = v;
  return t > 0.0f ? t : INFINITY;
}

// The triangle's outline on screen in continuous pixel coordinates (x right, y down; pixel (i, j)
// covers [i, i+1] x [j, j+1]): its 3 projected vertices, or for a perspective view the up to 4
// vertices of its part in front of the plane z = near (a triangle crossing it is clipped;
// *clipped says so). Returns the vertex count, 0 if nothing is in front of the eye.
static int triangle_outline(const pb_view* v, float3 a, float3 b, float3 c, float2 out[4],
                            bool* clipped) {
  float3 right = f3(v->right), up = f3(v->up), fwd = f3(v->forward), org = f3(v->origin);
  float3 P[3] = {a, b, c};
  int n = 0;
  *clipped = false;
  if (v->ortho) {
    for (int i = 0; i < 3; ++i) {
      float3 r = P[i] - org;
      float sx = dot(r, right) / v->right[3], sy = dot(r, up) / v->up[3];
      out[n++] = (float2)((sx + 1.0f) * 0.5f * v->width, (1.0f - sy) * 0.5f * v->height);
    }
    return n;
  }
  // Clip the triangle against the plane z = near in front of the eye, project what remains.
  const float near_z = 1e-4f;
  float z[3];
  for (int i = 0; i < 3; ++i) z[i] = dot(P[i] - org, fwd);
  if (z[0] < near_z && z[1] < near_z && z[2] < near_z) return 0;
  *clipped = z[0] < near_z || z[1] < near_z || z[2] < near_z;
  for (int i = 0; i < 3; ++i) {
    int j = (i + 1) % 3;
    float3 q[2];
    int nq = 0;
    if (z[i] >= near_z) q[nq++] = P[i];
    if ((z[i] < near_z) != (z[j] < near_z)) {
      float f = (near_z - z[i]) / (z[j] - z[i]);
      q[nq++] = P[i] + f * (P[j] - P[i]);
    }
    for (int k = 0; k < nq; ++k) {
      float3 r = q[k] - org;
      float zz = fmax(dot(r, fwd), near_z);
      float sx = dot(r, right) / (zz * v->right[3]), sy = dot(r, up) / (zz * v->up[3]);
      out[n++] = (float2)((sx + 1.0f) * 0.5f * v->width, (1.0f - sy) * 0.5f * v->height);
    }
  }
  return n;
}

// Screen-space pixel bounds of an outline of n points; false if it cannot cover any pixel.
static bool outline_bounds(const pb_view* v, const float2* P, int n, int* x0, int* y0, int* x1,
                           int* y1) {
  if (n == 0) return false;
  float pminx = INFINITY, pminy = INFINITY, pmaxx = -INFINITY, pmaxy = -INFINITY;
  for (int i = 0; i < n; ++i) {
    pminx = fmin(pminx, P[i].x); pmaxx = fmax(pmaxx, P[i].x);
    pminy = fmin(pminy, P[i].y); pmaxy = fmax(pmaxy, P[i].y);
  }
  // one pixel of margin, the ray test decides coverage.
  if (!(pmaxx >= -1.0f && pminx <= v->width + 1.0f && pmaxy >= -1.0f &&
        pminy <= v->height + 1.0f))
    return false;
  *x0 = max(0, (int)floor(pminx - 0.5f) - 1);
  *x1 = min(v->width - 1, (int)ceil(pmaxx - 0.5f) + 1);
  *y0 = max(0, (int)floor(pminy - 0.5f) - 1);
  *y1 = min(v->height - 1, (int)ceil(pmaxy - 0.5f) + 1);
  return *x0 <= *x1 && *y0 <= *y1;
}

// The outline's edges as outline_row_span reads them, set up once a triangle: edge i runs from
// y = ylo[i] to yhi[i] (ylo <= yhi), along x = x0[i] + (y - ylo[i]) * slope[i] with x0 its x at
// ylo; a horizontal edge (ylo = yhi) spans x0[i] to x1[i].
typedef struct {
  float ylo[4], yhi[4], x0[4], x1[4], slope[4];
  int n;
} outline_edges;

static void outline_edges_of(const float2* P, int n, outline_edges* e) {
  e->n = n;
  for (int i = 0; i < n; ++i) {
    float2 p = P[i], q = P[i + 1 < n ? i + 1 : 0];
    if (q.y < p.y) {
      float2 t = p;
      p = q;
      q = t;
    }
    e->ylo[i] = p.y;
    e->yhi[i] = q.y;
    e->x0[i] = p.x;
    e->x1[i] = q.x;
    e->slope[i] = q.y > p.y ? (q.x - p.x) / (q.y - p.y) : 0.0f;
  }
}

// floor(v) - 1 and ceil(v) + 1 as ints for the span's ends, without the library's floor and ceil
// (a call and two branches each on CPU drivers). v is clamped to +-2^30 first, which keeps the
// conversion defined and changes nothing: the span is then cut to the view's [0, width - 1].
static int span_floor_minus1(float v) {
  v = clamp(v, -1073741824.0f, 1073741824.0f);
  int i = (int)v;
  return i - ((float)i > v) - 1;
}
static int span_ceil_plus1(float v) {
  v = clamp(v, -1073741824.0f, 1073741824.0f);
  int i = (int)v;
  return i + ((float)i < v) + 1;
}

// The pixels of row y whose centres the outline (a convex polygon) can cover: the outline's
// extent in x over the row's band [y, y + 1] (each edge's part inside the band, whose ends are
// its crossings of the band's lines or its vertices inside the band), widened by a pixel as
// outline_bounds widens the box, and cut to [*xs, *xe]. Every centre (x + 1/2, y + 1/2) the ray
// test can hit lies in that extent: the test's tolerance (RASTER_EPS in barycentrics) and the
// projection's rounding move an edge by far less than the pixel of margin, as does the rounding
// of the edge's line (tests/test_raster.cpp, Raster.RowSpansChangeNoPixel). An empty span leaves
// *xs > *xe.
static void outline_row_span(const outline_edges* e, int y, int* xs, int* xe) {
  const float lo = (float)y, hi = (float)(y + 1);
  float minx = INFINITY, maxx = -INFINITY;
  for (int i = 0; i < e->n; ++i) {
    if (!(e->yhi[i] >= lo && e->ylo[i] <= hi)) continue;
    float xa, xb;
    if (e->yhi[i] > e->ylo[i]) {
      xa = e->x0[i] + (fmax(lo, e->ylo[i]) - e->ylo[i]) * e->slope[i];
      xb = e->x0[i] + (fmin(hi, e->yhi[i]) - e->ylo[i]) * e->slope[i];
    } else {
      xa = e->x0[i];
      xb = e->x1[i];
    }
    minx = fmin(minx, fmin(xa, xb));
    maxx = fmax(maxx, fmax(xa, xb));
  }
  if (!(minx <= maxx)) {
    *xs = *xe + 1;
    return;
  }
  *xs = max(*xs, span_floor_minus1(minx - 0.5f));
  *xe = min(*xe, span_ceil_plus1(maxx - 0.5f));
}

// ---- CPU form of an orthographic view's rows (-DRASTER_ROW_SIMD) ----
//
// CPU drivers run a work-item's loop one pixel at a time, and a light view's large triangles
// (the ground fills half of each map) cost a whole ray test per texel. Under RASTER_ROW_SIMD a
// row of an orthographic view runs RASTER_CHUNK pixels in one SIMD loop (src/core/device_kind.hpp,
// PB_SIMD_LOOP), then does the atomics of the pixels hit. The loop's operations are
// view_ray's and ray_triangle's in scalars, rounded as they are: the same sums in the same
// expressions (so the same multiply-adds are fused), and cross() and dot() as PoCL's library
// computes them (cross3_s, dot3_s in shared.h: products rounded, then subtracted or added, no
// fused multiply-add). Same bits as
// the per-pixel loop on PoCL (tests/test_raster.cpp, Raster.RowSpansChangeNoPixel).
#ifdef RASTER_ROW_SIMD
#ifndef RASTER_CHUNK
#define RASTER_CHUNK 16
#endif
#define RS static inline __attribute__((always_inline))

// Pixels xs..xe of row y of orthographic view v: depth[row + x] = min(t) over the triangle
// (a, b, c), as the per-pixel loop of raster_triangles writes it. owned: this work-item is the
// view's only writer (raster_views), so a plain load and store keep the minimum; idrow (owned
// only, else null): pass 2, the triangle's index `tri` kept where its depth is the nearer.
RS void raster_row_ortho(const pb_view* v, float3 a, float3 b, float3 c, int y, int xs, int xe,
                         volatile global uint* row, volatile global uint* idrow, uint tri,
                         bool owned) {
  // ray_triangle's per-triangle part: the direction is the view's forward everywhere
  float3 d = f3(v->forward);
  float3 e1 = b - a, e2 = c - a;
  float3 p = cross(d, e2);
  float det = dot(e1, p);
  if (fabs(det) < 1e-20f) return;
  float inv = 1.0f / det;
  // view_ray's per-row part
  float py = y + 0.5f;
  float sy = 1.0f - 2.0f * py / v->height;
  const float sr = v->right[3], su = v->up[3];
  for (int x0 = xs; x0 <= xe; x0 += RASTER_CHUNK) {
    uint hit[RASTER_CHUNK];
PB_SIMD_LOOP(RASTER_CHUNK)
    for (int k = 0; k < RASTER_CHUNK; ++k) {
      float px = (float)(x0 + k) + 0.5f;
      float sx = 2.0f * px / v->width - 1.0f;
      // o = org + sx * right[3] * right + sy * up[3] * up, per component
      float ox = v->origin[0] + sx * sr * v->right[0] + sy * su * v->up[0];
      float oy = v->origin[1] + sx * sr * v->right[1] + sy * su * v->up[1];
      float oz = v->origin[2] + sx * sr * v->right[2] + sy * su * v->up[2];
      float s0 = ox - a.x, s1 = oy - a.y, s2 = oz - a.z;
      float u = dot3_s(s0, s1, s2, p.x, p.y, p.z) * inv;
      float q0, q1, q2;
      cross3_s(s0, s1, s2, e1.x, e1.y, e1.z, &q0, &q1, &q2);
      float w = dot3_s(d.x, d.y, d.z, q0, q1, q2) * inv;
      float t = dot3_s(e2.x, e2.y, e2.z, q0, q1, q2) * inv;
      bool in = !(u < -RASTER_EPS || u > 1.0f + RASTER_EPS) &&
                !(w < -RASTER_EPS || u + w > 1.0f + RASTER_EPS) && t > 0.0f;
      hit[k] = in ? as_uint(t) : PB_DEPTH_EMPTY;
    }
    int n = min(RASTER_CHUNK, xe - x0 + 1);
    if (owned) {
      // The only writer of the row: plain loads and stores (the pointer is volatile for the
      // atomics of the shared case), a whole chunk in one SIMD min, its lanes past the span
      // taking the empty depth (+inf, no less than any stored depth: the texel keeps its value).
      // Scalar, this loop held the most samples of raster_views (`perf annotate`, 12% at one
      // load of hit[]). A chunk that would pass the row's end stays scalar: past it are another
      // view's texels.
      global uint* r = (global uint*)row + x0;
      if (idrow) {
        // pass 2: the id with the nearer depth (an equal depth keeps the earlier, lesser index)
        global uint* ir = (global uint*)idrow + x0;
        if (x0 + RASTER_CHUNK <= v->width) {
PB_SIMD_LOOP(RASTER_CHUNK)
          for (int k = 0; k < RASTER_CHUNK; ++k) {
            const uint h = k < n ? hit[k] : PB_DEPTH_EMPTY;
            const bool nearer = h < r[k];
            ir[k] = nearer ? tri : ir[k];
            r[k] = nearer ? h : r[k];
          }
        } else {
          for (int k = 0; k < n; ++k)
            if (hit[k] < r[k]) {
              r[k] = hit[k];
              ir[k] = tri;
            }
        }
      } else if (x0 + RASTER_CHUNK <= v->width) {
PB_SIMD_LOOP(RASTER_CHUNK)
        for (int k = 0; k < RASTER_CHUNK; ++k) r[k] = min(r[k], k < n ? hit[k] : PB_DEPTH_EMPTY);
      } else {
        for (int k = 0; k < n; ++k) r[k] = min(r[k], hit[k]);
      }
    } else {
      for (int k = 0; k < n; ++k)
        if (hit[k] != PB_DEPTH_EMPTY) atomic_min(&row[x0 + k], hit[k]);
    }
  }
}
#endif

// Triangle `tri` into view vi (v, its copy): stripe `stripe` of `stripes` of its rows, within
// rows ylo..yhi. pass 0: depth[view][y][x] = min t (as uint bits). pass 1: ids[y][x] = min
// triangle index among those whose t equals the stored depth. pass 2 (owned, triangles taken in
// increasing index): both at once, the depth where t is nearer and the id with it, so that the
// id ends as pass 1's, the least index among the triangles at the nearest t. cull: 0 keeps every
// triangle, 1 only those facing the view (counter-clockwise seen from it), 2 only those facing
// away (the back faces of closed meshes; Kneiphof 2017 §4.2.3). owned (passes 0 and 2): the
// work-item is the only writer of the rows it is given, and keeps the minimum without atomics.
static inline __attribute__((always_inline)) void raster_triangle(
    global const float4* pos, global const int4* tris, int tri, const pb_view* vp, int vi,
    int stripe, int stripes, int ylo, int yhi, int pass, volatile global uint* depth,
    volatile global uint* ids, int cull, bool owned) {
  const pb_view v = *vp;
  int4 t = tris[tri];
  float3 a = pos[t.x].xyz, b = pos[t.y].xyz, c = pos[t.z].xyz;
  if (cull != 0) {
    // orthographic views (the only ones culled) look along `forward` everywhere
    float facing = dot(cross(b - a, c - a), (float3)(v.forward[0], v.forward[1], v.forward[2]));
    if ((cull == 1 && facing >= 0.0f) || (cull == 2 && facing <= 0.0f)) return;
  }
  float2 outline[4];
  bool clipped;
  int n = triangle_outline(&v, a, b, c, outline, &clipped);
  int x0, y0, x1, y1;
  if (!outline_bounds(&v, outline, n, &x0, &y0, &x1, &y1)) return;
  size_t base = (size_t)vi * v.width * v.height;
  y0 = max(y0, ylo);
  y1 = min(y1, yhi);
#ifndef RASTER_FULL_BOX
  outline_edges edges;
  if (!clipped) outline_edges_of(outline, n, &edges);
#endif
  for (int y = y0 + stripe; y <= y1; y += stripes) {
    // Only the row's span of the outline is tested, not the whole box (a triangle covers half of
    // its box at most). A triangle clipped at the near plane keeps the box: its sliver between
    // the eye and the plane is not in the outline.
    int xs = x0, xe = x1;
#ifndef RASTER_FULL_BOX
    if (!clipped) outline_row_span(&edges, y, &xs, &xe);
#endif
#ifdef RASTER_ROW_SIMD
    if (v.ortho && (pass == 0 || (pass == 2 && owned))) {
      raster_row_ortho(&v, a, b, c, y, xs, xe, depth + base + (size_t)y * v.width,
                       pass == 2 ? ids + base + (size_t)y * v.width : 0, (uint)tri, owned);
      continue;
    }
#endif
    for (int x = xs; x <= xe; ++x) {
      float3 o, d;
      view_ray(&v, x + 0.5f, y + 0.5f, &o, &d);
      float b1, b2;
      float tt = ray_triangle(o, d, a, b, c, &b1, &b2);
      if (tt == INFINITY) continue;
      size_t i = base + (size_t)y * v.width + x;
      // (a plain read of depth[i] before the atomic_min, to skip it where the texel is already
      // nearer, would race with other work-items' atomics under OpenCL's memory model: oclgrind
      // reports it)
      if (pass == 0) {
        if (owned)
          depth[i] = min(depth[i], as_uint(tt));
        else
          atomic_min(&depth[i], as_uint(tt));
      } else if (pass == 2) {
        // an equal t keeps the id already there: its triangle came first, its index is less
        if (as_uint(tt) < depth[i]) {
          depth[i] = as_uint(tt);
          ids[i] = (uint)tri;
        }
      } else if (as_uint(tt) == depth[i]) {
        atomic_min(&ids[i], (uint)tri);
      }
    }
  }
}

// One work-item per (triangle, row stripe, view): the views' texels are shared between work-items,
// so each keeps its minimum with atomics.
kernel void raster_triangles(global const float4* pos, global const int4* tris, int ntris,
                             global const pb_view* views, int stripes, int pass,
                             volatile global uint* depth, volatile global uint* ids, int cull) {
  int tri = get_global_id(0), stripe = get_global_id(1), vi = get_global_id(2);
  if (tri >= ntris) return;
  pb_view v = views[vi];
  raster_triangle(pos, tris, tri, &v, vi, stripe, stripes, 0, INT_MAX, pass, depth, ids, cull,
                  false);
}

// The CPU form of pass 0 for several views (src/render/rasterizer.cpp: shadow maps on CPU
// devices): one work-item per view takes every triangle in turn. A view's map then has one writer,
// which keeps the nearest depth with a plain load and store: raster_triangles' atomic_min is a
// locked compare-and-swap loop on a CPU (about 30% of that kernel's time on the default frame's
// 32 maps). The minimum of the same depths, so the same bits. Launched one work-item per
// work-group, so that the views spread over the cores.
// keep_ids: pass 2 instead (depth and ids at once, into `ids`: the shadow maps' triangle ids of
// contact shadows from the lights' side, kernels/render/contact.cl).
// clear: the work-item first empties its view (PB_DEPTH_EMPTY, and PB_ID_EMPTY in the ids with
// keep_ids), where the host would otherwise fill the buffers: a fill is one thread's memset of
// every map before the launch (2.9 ms of the 32-light frame's 19 MiB of depth and 19 MiB of
// ids), here each core clears the views it draws, which then start in its cache.
kernel void raster_views(global const float4* pos, global const int4* tris, int ntris,
                         global const pb_view* views, int nviews, volatile global uint* depth,
                         int cull, volatile global uint* ids, int keep_ids, int clear) {
  const int vi = get_global_id(0);
  if (vi >= nviews) return;
  pb_view v = views[vi];
  if (clear) {
    const size_t texels = (size_t)v.width * v.height, base = (size_t)vi * texels;
    global uint* d = (global uint*)depth + base;
PB_SIMD_LOOP(16)
    for (size_t i = 0; i < texels; ++i) d[i] = PB_DEPTH_EMPTY;
    if (keep_ids) {
      global uint* id = (global uint*)ids + base;
PB_SIMD_LOOP(16)
      for (size_t i = 0; i < texels; ++i) id[i] = PB_ID_EMPTY;
    }
  }
  for (int tri = 0; tri < ntris; ++tri)
    raster_triangle(pos, tris, tri, &v, vi, 0, 1, 0, INT_MAX, keep_ids ? 2 : 0, depth,
                    keep_ids ? ids : depth, cull, true);
}

// The CPU form of the camera's two passes (src/render/rasterizer.cpp: the G-buffer on CPU
// devices), in two kernels. triangle_rows: each triangle's first and last row in view 0
// ((INT_MAX, -1) where it covers none, which no band meets). raster_bands: one work-item per
// band of `band` rows takes, in increasing index, every triangle whose rows meet its band, and
// keeps depth and id at once (raster_triangle's pass 2): the rows have one writer, so no
// atomics, and the triangles are tested once instead of once a pass. Pass 1 keeps the least
// index among the triangles at the stored depth; pass 2 keeps the first of them in index order,
// the same one: the same bits. Launched one work-item per work-group, so that the bands spread
// over the cores.
kernel void triangle_rows(global const float4* pos, global const int4* tris, int ntris,
                          global const pb_view* views, global int2* rows) {
  const int tri = get_global_id(0);
  if (tri >= ntris) return;
  const pb_view v = views[0];
  int4 t = tris[tri];
  float2 outline[4];
  bool clipped;
  int n = triangle_outline(&v, pos[t.x].xyz, pos[t.y].xyz, pos[t.z].xyz, outline, &clipped);
  int x0, y0, x1, y1;
  rows[tri] = outline_bounds(&v, outline, n, &x0, &y0, &x1, &y1) ? (int2)(y0, y1)
                                                                  : (int2)(INT_MAX, -1);
}

kernel void raster_bands(global const float4* pos, global const int4* tris, int ntris,
                         global const pb_view* views, global const int2* rows, int band,
                         volatile global uint* depth, volatile global uint* ids) {
  const pb_view v = views[0];
  const int ylo = get_global_id(0) * band, yhi = min(ylo + band, v.height) - 1;
  if (ylo > yhi) return;
  for (int tri = 0; tri < ntris; ++tri) {
    const int2 r = rows[tri];
    if (r.x > yhi || r.y < ylo) continue;
    raster_triangle(pos, tris, tri, &v, 0, 0, 1, ylo, yhi, 2, depth, ids, 0, true);
  }
}

// Camera G-buffer from the visibility pass: world position (w = 1 on geometry, 0 elsewhere),
// shading normal (interpolated vertex normal, or geometric) facing the camera, geometric normal
// facing the camera, albedo. The position is the hit moved by `offset` along that geometric
// normal: where every shadow test starts, as the Embree reference starts its shadow rays
// (src/scene/shadow_offset.hpp says why).
static void gbuffer_pixel(global const float4* pos, global const float4* nrm,
                          global const int4* tris, global const float4* albedo,
                          const pb_view* vp, global const uint* ids, global float4* gpos,
                          global float4* gnrm, global float4* ggeo, global float4* galb,
                          float offset, int x, int y) {
  const pb_view v = *vp;
  size_t i = (size_t)y * v.width + x;
  uint id = ids[i];
  if (id == PB_ID_EMPTY) {
    gpos[i] = (float4)(0.0f);
    gnrm[i] = (float4)(0.0f, 1.0f, 0.0f, 0.0f);
    ggeo[i] = (float4)(0.0f, 1.0f, 0.0f, 0.0f);
    galb[i] = (float4)(0.0f);
    return;
  }
  int4 t = tris[id];
  float3 a = pos[t.x].xyz, b = pos[t.y].xyz, c = pos[t.z].xyz;
  float3 o, d;
  view_ray(&v, x + 0.5f, y + 0.5f, &o, &d);
  float b1 = 0.0f, b2 = 0.0f;
  float tt = ray_triangle(o, d, a, b, c, &b1, &b2);
  if (tt == INFINITY) tt = 0.0f;  // cannot happen: this triangle produced the stored depth
  float3 g = normalize(cross(b - a, c - a));
  if (dot(g, d) > 0.0f) g = -g;
  float4 na = nrm[t.x], nb = nrm[t.y], nc = nrm[t.z];
  float3 n = g;
  if (na.w > 0.0f && nb.w > 0.0f && nc.w > 0.0f) {
    float3 s = (1.0f - b1 - b2) * na.xyz + b1 * nb.xyz + b2 * nc.xyz;
    if (length(s) > 1e-12f) {
      n = normalize(s);
      if (dot(n, g) < 0.0f) n = -n;  // keep the shading normal on the visible side
    }
  }
  gpos[i] = (float4)(o + tt * d + offset * g, 1.0f);
  gnrm[i] = (float4)(n, 0.0f);
  ggeo[i] = (float4)(g, 0.0f);
  galb[i] = albedo[t.w];
}

kernel void gbuffer_resolve(global const float4* pos, global const float4* nrm,
                            global const int4* tris, global const float4* albedo,
                            global const pb_view* views, global const uint* ids,
                            global float4* gpos, global float4* gnrm, global float4* ggeo,
                            global float4* galb, float offset) {
  int x = get_global_id(0), y = get_global_id(1);
  pb_view v = views[0];
  if (x >= v.width || y >= v.height) return;
  gbuffer_pixel(pos, nrm, tris, albedo, &v, ids, gpos, gnrm, ggeo, galb, offset, x, y);
}

// The CPU form of gbuffer_resolve (src/core/device_kind.hpp; the same bits on PoCL): PoCL runs it
// a pixel at a time, its float3 arithmetic scalar. Here a work-item takes GB_GROUP pixels of a
// row and runs gbuffer_resolve's operations on them in a SIMD loop, on scalars: view_ray and
// ray_triangle in their expressions (so the same multiply-adds are fused), cross and dot as the
// library computes them (cross3_s, dot3_s), length(v) as sqrt(dot(v, v)) and normalize(v) as
// v * rsqrt(dot(v, v)), which is how PoCL 3.1 computes them (the same bits on 4 million random
// vectors of magnitudes 2^-20 to 2^20, scalar and in SIMD loops; the library's normalize() in the
// loop would keep it scalar: 2.4 -> 5.9 ms). A pixel whose squared lengths leave
// [GB_LOW, 2^100] (a degenerate triangle, a normal that vanishes), where a library might scale
// first, is resolved again by gbuffer_pixel afterwards, as gbuffer_resolve resolves it (a test
// raises GB_LOW to send every pixel there). On the 32-light frame `gbuffer/resolve` went from 2.4
// to 1.9 ms: the rest is the triangles' vertex reads and the four planes' writes.
// Global (ceil(width / GB_GROUP), height).
#ifndef GB_GROUP
#define GB_GROUP 64
#endif
#ifndef GB_LOW
#define GB_LOW 0x1p-100f
#endif
#define GB_HIGH 0x1p100f
kernel void gbuffer_resolve_batch(global const float4* pos, global const float4* nrm,
                                  global const int4* tris, global const float4* albedo,
                                  global const pb_view* views, global const uint* ids,
                                  global float4* gpos, global float4* gnrm, global float4* ggeo,
                                  global float4* galb, float offset) {
  const pb_view v = views[0];
  const int x0 = get_global_id(0) * GB_GROUP, y = get_global_id(1);
  if (x0 >= v.width || y >= v.height) return;
  const int cnt = min(GB_GROUP, v.width - x0);
  const size_t row = (size_t)y * v.width + x0;
  // each pixel's triangle: its vertices, vertex normals (w > 0: given) and albedo index
  float Ax[GB_GROUP], Ay[GB_GROUP], Az[GB_GROUP], Bx[GB_GROUP], By[GB_GROUP],
      Bz[GB_GROUP], Cx[GB_GROUP], Cy[GB_GROUP], Cz[GB_GROUP];
  float Na[4][GB_GROUP], Nb[4][GB_GROUP], Nc[4][GB_GROUP];
  int hit[GB_GROUP], odd[GB_GROUP];
  float out[9][GB_GROUP];  // position xyz, shading normal xyz, geometric normal xyz
  for (int k = 0; k < GB_GROUP; ++k) {
    const uint id = ids[row + min(k, cnt - 1)];
    hit[k] = k < cnt && id != PB_ID_EMPTY;
    float4 a = (float4)(0.0f), b = a, c = a, na = a, nb = a, nc = a;
    if (hit[k]) {
      const int4 t = tris[id];
      a = pos[t.x];
      b = pos[t.y];
      c = pos[t.z];
      na = nrm[t.x];
      nb = nrm[t.y];
      nc = nrm[t.z];
    }
    Ax[k] = a.x; Ay[k] = a.y; Az[k] = a.z;
    Bx[k] = b.x; By[k] = b.y; Bz[k] = b.z;
    Cx[k] = c.x; Cy[k] = c.y; Cz[k] = c.z;
    Na[0][k] = na.x; Na[1][k] = na.y; Na[2][k] = na.z; Na[3][k] = na.w;
    Nb[0][k] = nb.x; Nb[1][k] = nb.y; Nb[2][k] = nb.z; Nb[3][k] = nb.w;
    Nc[0][k] = nc.x; Nc[1][k] = nc.y; Nc[2][k] = nc.z; Nc[3][k] = nc.w;
  }
  const float sr = v.right[3], su = v.up[3];
  const float py = y + 0.5f;
  const float sy = 1.0f - 2.0f * py / v.height;
PB_SIMD_LOOP(16)
  for (int k = 0; k < GB_GROUP; ++k) {
    // view_ray
    const float px = (float)(x0 + k) + 0.5f;
    const float sx = 2.0f * px / v.width - 1.0f;
    float ox, oy, oz, dx, dy, dz, dd = 1.0f;
    if (v.ortho) {
      ox = v.origin[0] + sx * sr * v.right[0] + sy * su * v.up[0];
      oy = v.origin[1] + sx * sr * v.right[1] + sy * su * v.up[1];
      oz = v.origin[2] + sx * sr * v.right[2] + sy * su * v.up[2];
      dx = v.forward[0];
      dy = v.forward[1];
      dz = v.forward[2];
    } else {
      ox = v.origin[0];
      oy = v.origin[1];
      oz = v.origin[2];
      const float rx = v.forward[0] + sx * sr * v.right[0] + sy * su * v.up[0];
      const float ry = v.forward[1] + sx * sr * v.right[1] + sy * su * v.up[1];
      const float rz = v.forward[2] + sx * sr * v.right[2] + sy * su * v.up[2];
      dd = dot3_s(rx, ry, rz, rx, ry, rz);
      const float r = rsqrt(dd);
      dx = rx * r;
      dy = ry * r;
      dz = rz * r;
    }
    // ray_triangle (two-sided Moller-Trumbore)
    const float e1x = Bx[k] - Ax[k], e1y = By[k] - Ay[k], e1z = Bz[k] - Az[k];
    const float e2x = Cx[k] - Ax[k], e2y = Cy[k] - Ay[k], e2z = Cz[k] - Az[k];
    float pvx, pvy, pvz, qx, qy, qz;
    cross3_s(dx, dy, dz, e2x, e2y, e2z, &pvx, &pvy, &pvz);
    const float det = dot3_s(e1x, e1y, e1z, pvx, pvy, pvz);
    const float inv = 1.0f / det;
    const float s0 = ox - Ax[k], s1 = oy - Ay[k], s2 = oz - Az[k];
    const float u = dot3_s(s0, s1, s2, pvx, pvy, pvz) * inv;
    cross3_s(s0, s1, s2, e1x, e1y, e1z, &qx, &qy, &qz);
    const float w = dot3_s(dx, dy, dz, qx, qy, qz) * inv;
    const float t = dot3_s(e2x, e2y, e2z, qx, qy, qz) * inv;
    const bool in = !(fabs(det) < 1e-20f) && !(u < -RASTER_EPS || u > 1.0f + RASTER_EPS) &&
                    !(w < -RASTER_EPS || u + w > 1.0f + RASTER_EPS);
    const float b1 = in ? u : 0.0f, b2 = in ? w : 0.0f;
    const float tt = in && t > 0.0f && t < INFINITY ? t : 0.0f;
    // the geometric normal, facing the camera
    float gx, gy, gz;
    cross3_s(e1x, e1y, e1z, e2x, e2y, e2z, &gx, &gy, &gz);
    const float gg = dot3_s(gx, gy, gz, gx, gy, gz);
    const float gr = rsqrt(gg);
    gx *= gr;
    gy *= gr;
    gz *= gr;
    const bool flip = dot3_s(gx, gy, gz, dx, dy, dz) > 0.0f;
    gx = flip ? -gx : gx;
    gy = flip ? -gy : gy;
    gz = flip ? -gz : gz;
    // the interpolated vertex normal, on the visible side
    float nx = gx, ny = gy, nz = gz, ss = 1.0f;
    if (Na[3][k] > 0.0f && Nb[3][k] > 0.0f && Nc[3][k] > 0.0f) {
      const float b0 = 1.0f - b1 - b2;
      const float sx3 = b0 * Na[0][k] + b1 * Nb[0][k] + b2 * Nc[0][k];
      const float sy3 = b0 * Na[1][k] + b1 * Nb[1][k] + b2 * Nc[1][k];
      const float sz3 = b0 * Na[2][k] + b1 * Nb[2][k] + b2 * Nc[2][k];
      ss = dot3_s(sx3, sy3, sz3, sx3, sy3, sz3);
      if (sqrt(ss) > 1e-12f) {
        const float r = rsqrt(ss);
        nx = sx3 * r;
        ny = sy3 * r;
        nz = sz3 * r;
        const bool back = dot3_s(nx, ny, nz, gx, gy, gz) < 0.0f;
        nx = back ? -nx : nx;
        ny = back ? -ny : ny;
        nz = back ? -nz : nz;
      }
    }
    odd[k] = !(dd >= GB_LOW && dd <= GB_HIGH) || !(gg >= GB_LOW && gg <= GB_HIGH) ||
             (ss != 1.0f && !(ss >= GB_LOW && ss <= GB_HIGH));
    out[0][k] = ox + tt * dx + offset * gx;
    out[1][k] = oy + tt * dy + offset * gy;
    out[2][k] = oz + tt * dz + offset * gz;
    out[3][k] = nx;
    out[4][k] = ny;
    out[5][k] = nz;
    out[6][k] = gx;
    out[7][k] = gy;
    out[8][k] = gz;
  }
  for (int k = 0; k < cnt; ++k) {
    const size_t i = row + k;
    if (!hit[k]) {
      gpos[i] = (float4)(0.0f);
      gnrm[i] = (float4)(0.0f, 1.0f, 0.0f, 0.0f);
      ggeo[i] = (float4)(0.0f, 1.0f, 0.0f, 0.0f);
      galb[i] = (float4)(0.0f);
    } else if (odd[k]) {
      gbuffer_pixel(pos, nrm, tris, albedo, &v, ids, gpos, gnrm, ggeo, galb, offset, x0 + k, y);
    } else {
      gpos[i] = (float4)(out[0][k], out[1][k], out[2][k], 1.0f);
      gnrm[i] = (float4)(out[3][k], out[4][k], out[5][k], 0.0f);
      ggeo[i] = (float4)(out[6][k], out[7][k], out[8][k], 0.0f);
      galb[i] = albedo[tris[ids[i]].w];
    }
  }
}

// Front + back face depth maps (Kneiphof 2017 §4.2.3): the mean of the nearest front-facing and the
// nearest back-facing surface lies inside a closed caster, so receivers on its surface need no
// depth bias. Where only one of them exists (open geometry, a ground plane), keep it.
kernel void combine_front_back(global uint* front, global const uint* back, int count) {
  int i = get_global_id(0);
  if (i >= count) return;
  uint f = front[i], b = back[i];
  if (f == PB_DEPTH_EMPTY) { front[i] = b; return; }
  if (b == PB_DEPTH_EMPTY) return;
  front[i] = as_uint(0.5f * (as_float(f) + as_float(b)));
}
