// Bent normals at light silhouettes (Sintorn et al. 2008 §4.3, RenderOptions::bentNormals).
//
// Exact shadows (the bitmask techniques) make every triangle that faces away from a light shadow
// itself, while the interpolated vertex normal still sees the light up to the shading normal's own
// terminator: on a smooth mesh the shading jumps to black along the triangle edges of the light's
// silhouette. Sintorn et al. 2008 §4.3 bends the shading there: per vertex v and light l,
//   I_bend(v) = min over the faces F adjacent to v of n_F . l       (l: the light's centre),
// interpolated over each triangle; kernels/render/shade.cl blends back to the normal illumination
// with it. Every light-back-facing triangle has all three vertices at I_bend <= n_F . l < 0, so it
// is black everywhere; the blend is continuous because I_bend is (one value per vertex).
//
// Faces count as adjacent to v when they share its welded index (src/render/bent_normals.cpp:
// vertices with the same position and normal are one), and each face normal is oriented to the
// vertex normal's side, so inconsistently wound meshes bend like consistent ones. Both the minimum
// and the maximum are kept: a surface seen from behind (an open mesh; the G-buffer flips the
// shading normal to the camera) shades with -n_F, whose minimum over the faces is -max(n_F . l).
#include "shared.h"

// Global (triangles, lights). bend: per (vertex, light), vertex-major so that a pixel's three
// vertices hold every light's values together, two ints (pb_float_to_ordered): the minimum then
// the maximum of the oriented n_F . l, filled with INT_MAX / INT_MIN beforehand.
kernel void bent_vertices(global const float4* pos, global const float4* nrm,
                          global const int4* tris, int ntris, int nlights,
                          global const pb_light* lights, volatile global int* bend) {
  int t = get_global_id(0), l = get_global_id(1);
  if (t >= ntris) return;
  int4 tri = tris[t];
  float3 a = pos[tri.x].xyz, b = pos[tri.y].xyz, c = pos[tri.z].xyz;
  float3 n = cross(b - a, c - a);
  float len = length(n);
  if (!(len > 0.0f) || !isfinite(len)) return;  // degenerate: no plane, nothing to bend by
  n /= len;
  pb_light L = lights[l];
  float d = dot(n, (float3)(L.dir[0], L.dir[1], L.dir[2]));
  int v[3] = {tri.x, tri.y, tri.z};
  for (int k = 0; k < 3; ++k) {
    float4 nv = nrm[v[k]];
    // Flat vertices (w = 0) have no side of their own: the winding's.
    float s = nv.w > 0.0f && dot(n, nv.xyz) < 0.0f ? -d : d;
    int o = pb_float_to_ordered(s);
    volatile global int* slot = bend + 2 * ((size_t)v[k] * nlights + l);
    atomic_min(slot, o);
    atomic_max(slot + 1, o);
  }
}

// Global (pixels): what kernels/render/shade.cl needs to interpolate I_bend at each pixel, for
// every light: the pixel's triangle's three welded vertices (vert.xyz; w = 1 where the pixel shows
// the surface's back side, whose I_bend is minus the maximum) and their barycentric weights at the
// G-buffer position (weight.xyz). vert.x = -1: no bending (the blend keeps the normal shading)
// on the background and on triangles shaded by their geometric normal (a vertex without a
// normal, w = 0): those have no interpolated normal, so no silhouette mismatch.
kernel void bent_pixels(global const float4* pos, global const float4* nrm,
                        global const int4* tris, global const uint* gids,
                        global const float4* gpos, global const float4* gnrm, int npixels,
                        global int4* vert, global float4* weight) {
  int px = get_global_id(0);
  if (px >= npixels) return;
  uint id = gids[px];
  int4 tri = id == PB_ID_EMPTY ? (int4)(0) : tris[id];
  float4 na = nrm[tri.x], nb = nrm[tri.y], nc = nrm[tri.z];
  if (id == PB_ID_EMPTY || !(na.w > 0.0f && nb.w > 0.0f && nc.w > 0.0f)) {
    vert[px] = (int4)(-1, 0, 0, 0);
    weight[px] = (float4)(0.0f);
    return;
  }
  float3 a = pos[tri.x].xyz, b = pos[tri.y].xyz, c = pos[tri.z].xyz, p = gpos[px].xyz;
  // p - a = w1 (b - a) + w2 (c - a): w1 = ((p - a) x e2) . n / |n|^2, w2 = (e1 x (p - a)) . n /
  // |n|^2.
  float3 e1 = b - a, e2 = c - a, q = p - a, n = cross(e1, e2);
  float nn = dot(n, n);
  float w1 = nn > 0.0f ? dot(cross(q, e2), n) / nn : 0.0f;
  float w2 = nn > 0.0f ? dot(cross(e1, q), n) / nn : 0.0f;
  // The rasterizer accepts hits a hair outside the triangle (RASTER_EPS): clamp onto it.
  w1 = clamp(w1, 0.0f, 1.0f);
  w2 = clamp(w2, 0.0f, 1.0f - w1);
  // The G-buffer's shading normal is the interpolated vertex normal turned to the camera: the
  // pixel shows the surface's back side where the two disagree.
  float w0 = 1.0f - w1 - w2;
  float3 s = w0 * na.xyz + w1 * nb.xyz + w2 * nc.xyz;
  vert[px] = (int4)(tri.x, tri.y, tri.z, dot(s, gnrm[px].xyz) < 0.0f ? 1 : 0);
  weight[px] = (float4)(w0, w1, w2, 0.0f);
}
