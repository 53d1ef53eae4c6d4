// Rasterization on the device by ray casting inside each triangle's screen bounding box.
//
// Each pixel's depth is the exact ray/triangle distance along the same ray the Embree reference
// traces (pb_view, scene.hpp's cameraRayDirection), so camera G-buffers match the ground truth
// pixel for pixel, and triangles crossing the camera's near plane need no special care beyond a
// clipped bounding box. Work is split over (triangle, row stripe, view) so that large triangles
// are shared by several work-items. Depth is resolved with atomic_min on the float's bit pattern
// (positive floats order like unsigned ints), triangle ids in a second pass with atomic_min among
// the triangles that reached the minimum: deterministic whatever the execution order.
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

// Screen-space pixel bounds of a triangle; false if it cannot cover any pixel.
static bool triangle_bounds(const pb_view* v, float3 a, float3 b, float3 c, int* x0, int* y0,
                            int* x1, int* y1) {
  float3 right = f3(v->right), up = f3(v->up), fwd = f3(v->forward), org = f3(v->origin);
  float3 P[3] = {a, b, c};
  float minx = INFINITY, miny = INFINITY, maxx = -INFINITY, maxy = -INFINITY;
  if (v->ortho) {
    for (int i = 0; i < 3; ++i) {
      float3 r = P[i] - org;
      float sx = dot(r, right) / v->right[3], sy = dot(r, up) / v->up[3];
      minx = fmin(minx, sx); maxx = fmax(maxx, sx);
      miny = fmin(miny, sy); maxy = fmax(maxy, sy);
    }
  } else {
    // Clip the triangle against the plane z = near in front of the eye, project what remains.
    const float near_z = 1e-4f;
    float z[3];
    for (int i = 0; i < 3; ++i) z[i] = dot(P[i] - org, fwd);
    if (z[0] < near_z && z[1] < near_z && z[2] < near_z) return false;
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
        minx = fmin(minx, sx); maxx = fmax(maxx, sx);
        miny = fmin(miny, sy); maxy = fmax(maxy, sy);
      }
    }
  }
  // screen [-1,1] -> pixel centres; one pixel of margin, the ray test decides coverage.
  float pminx = (minx + 1.0f) * 0.5f * v->width, pmaxx = (maxx + 1.0f) * 0.5f * v->width;
  float pminy = (1.0f - maxy) * 0.5f * v->height, pmaxy = (1.0f - miny) * 0.5f * v->height;
  if (!(pmaxx >= -1.0f && pminx <= v->width + 1.0f && pmaxy >= -1.0f &&
        pminy <= v->height + 1.0f))
    return false;
  *x0 = max(0, (int)floor(pminx - 0.5f) - 1);
  *x1 = min(v->width - 1, (int)ceil(pmaxx - 0.5f) + 1);
  *y0 = max(0, (int)floor(pminy - 0.5f) - 1);
  *y1 = min(v->height - 1, (int)ceil(pmaxy - 0.5f) + 1);
  return *x0 <= *x1 && *y0 <= *y1;
}

// pass 0: depth[view][y][x] = min t (as uint bits). pass 1: ids[y][x] = min triangle index among
// those whose t equals the stored depth (views must be 1). cull: 0 keeps every triangle, 1 only
// those facing the view (counter-clockwise seen from it), 2 only those facing away (the back
// faces of closed meshes; Kneiphof 2017 §4.2.3).
kernel void raster_triangles(global const float4* pos, global const int4* tris, int ntris,
                             global const pb_view* views, int stripes, int pass,
                             volatile global uint* depth, volatile global uint* ids, int cull) {
  int tri = get_global_id(0), stripe = get_global_id(1), vi = get_global_id(2);
  if (tri >= ntris) return;
  pb_view v = views[vi];
  int4 t = tris[tri];
  float3 a = pos[t.x].xyz, b = pos[t.y].xyz, c = pos[t.z].xyz;
  if (cull != 0) {
    // orthographic views (the only ones culled) look along `forward` everywhere
    float facing = dot(cross(b - a, c - a), (float3)(v.forward[0], v.forward[1], v.forward[2]));
    if ((cull == 1 && facing >= 0.0f) || (cull == 2 && facing <= 0.0f)) return;
  }
  int x0, y0, x1, y1;
  if (!triangle_bounds(&v, a, b, c, &x0, &y0, &x1, &y1)) return;
  size_t base = (size_t)vi * v.width * v.height;
  for (int y = y0 + stripe; y <= y1; y += stripes)
    for (int x = x0; x <= x1; ++x) {
      float3 o, d;
      view_ray(&v, x + 0.5f, y + 0.5f, &o, &d);
      float b1, b2;
      float tt = ray_triangle(o, d, a, b, c, &b1, &b2);
      if (tt == INFINITY) continue;
      size_t i = base + (size_t)y * v.width + x;
      if (pass == 0)
        atomic_min(&depth[i], as_uint(tt));
      else if (as_uint(tt) == depth[i])
        atomic_min(&ids[i], (uint)tri);
    }
}

// Camera G-buffer from the visibility pass: world position (w = 1 on geometry, 0 elsewhere),
// shading normal (interpolated vertex normal, or geometric) facing the camera, geometric normal
// facing the camera, albedo.
kernel void gbuffer_resolve(global const float4* pos, global const float4* nrm,
                            global const int4* tris, global const float4* albedo,
                            global const pb_view* views, global const uint* ids,
                            global float4* gpos, global float4* gnrm, global float4* ggeo,
                            global float4* galb) {
  int x = get_global_id(0), y = get_global_id(1);
  pb_view v = views[0];
  if (x >= v.width || y >= v.height) return;
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
  gpos[i] = (float4)(o + tt * d, 1.0f);
  gnrm[i] = (float4)(n, 0.0f);
  ggeo[i] = (float4)(g, 0.0f);
  galb[i] = albedo[t.w];
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
