// Contact shadows (ShadowOptions::contactShadows): exact short rays towards each light against the
// triangles the camera sees around the pixel.
//
// A shadow map keeps one depth per texel and every technique that reads one subtracts a depth
// bias, so an occluder closer to its receiver than about a texel plus the bias never shadows it:
// a hoof standing on the ground, the strands of a tail's tuft, a sheet lying on another. Embree
// (and the bitmask techniques, which test triangles) find those occluders; on the Wuson scenes
// they are the largest single part of MSSM4's error against the light-set truth (studio: 50
// pixels of the tuft, lit in every map technique and black in the truth, carried 65% of the
// squared error).
//
// Such an occluder is near the receiver, so the camera usually sees it near the pixel too. For
// pixel p the kernel lists the distinct triangles of the G-buffer's id plane within CONTACT_RADIUS
// pixels, drops p's own triangle and every triangle that lies on or below p's tangent plane (the
// ground around a point on it, the neighbours on a convex surface: a ray leaving the plane on its
// normal's side cannot meet them), then casts, for every light whose centre is above that plane,
// one ray from p towards the light's centre, `texels` of that light's map texels long, against
// the list. A hit sets the light's visibility at p to 0; otherwise it stays as the technique left
// it. One ray per light, so a light whose centre is blocked goes dark although a wide cap may
// still partly reach p (8 texels through a 20-degree cap: a penumbra up to 6 texels wide); five
// rays spread over the cap changed the four measured scenes' errors by at most 0.04 points
// (bench/results/accuracy.md), not worth five times the rays.
#include "shared.h"

#ifndef CONTACT_RADIUS
#define CONTACT_RADIUS 2
#endif
#define CONTACT_MAX_IDS ((2 * CONTACT_RADIUS + 1) * (2 * CONTACT_RADIUS + 1))

// Two-sided Moller-Trumbore: the hit distance along d, or +inf.
static float contact_hit(float3 o, float3 d, float3 a, float3 b, float3 c) {
  float3 e1 = b - a, e2 = c - a;
  float3 pv = cross(d, e2);
  float det = dot(e1, pv);
  if (fabs(det) < 1e-20f) return INFINITY;
  float inv = 1.0f / det;
  float3 s = o - a;
  float u = dot(s, pv) * inv;
  if (u < 0.0f || u > 1.0f) return INFINITY;
  float3 q = cross(s, e1);
  float v = dot(d, q) * inv;
  if (v < 0.0f || u + v > 1.0f) return INFINITY;
  float t = dot(e2, q) * inv;
  return t > 0.0f ? t : INFINITY;
}

// Global (width, height). gpos, ggeo, ids: the camera G-buffer (position w = 0 where nothing);
// pos, tris: the scene as the rasterizer reads it; mask: per light, 0 leaves it alone (a light
// whose visibility already tests triangles); vis: light-major [light][pixel], in place.
// map_size: the lights' shadow-map resolution (a texel is 2 * max(half-extents) / map_size).
kernel void contact_shadows(global const float4* gpos, global const float4* ggeo,
                            global const uint* ids, global const float4* pos,
                            global const int4* tris, int ntris, global const pb_light* lights,
                            global const uchar* mask, int nl,
                            int width, int height, global float* vis, float texels,
                            int map_size) {
  int x = get_global_id(0), y = get_global_id(1);
  if (x >= width || y >= height) return;
  int p = y * width + x;
  float4 P4 = gpos[p];
  if (P4.w == 0.0f) return;
  float3 P = P4.xyz, ng = ggeo[p].xyz;
  uint own = ids[p];
  // Rays start `lift` or more above P's tangent plane (below), and a triangle is dropped only when
  // all of it is at most `lift` above that plane, so the rule stays exact although P itself is off
  // its plane by rounding (a few ulps of its coordinates).
  float lift = 4e-7f * (fabs(P.x) + fabs(P.y) + fabs(P.z));
  uint list[CONTACT_MAX_IDS];
  int n = 0;
  for (int j = max(0, y - CONTACT_RADIUS); j <= min(height - 1, y + CONTACT_RADIUS); ++j)
    for (int i = max(0, x - CONTACT_RADIUS); i <= min(width - 1, x + CONTACT_RADIUS); ++i) {
      uint id = ids[j * width + i];
      if (id == PB_ID_EMPTY || id == own || id >= (uint)ntris) continue;
      bool seen = false;
      for (int m = 0; m < n; ++m) seen = seen || list[m] == id;
      if (seen) continue;
      int4 t = tris[id];
      if (dot(pos[t.x].xyz - P, ng) <= lift && dot(pos[t.y].xyz - P, ng) <= lift &&
          dot(pos[t.z].xyz - P, ng) <= lift)
        continue;
      list[n++] = id;
    }
  if (n == 0) return;
  size_t pixels = (size_t)width * height;
  for (int l = 0; l < nl; ++l) {
    size_t vi = (size_t)l * pixels + p;
    if (mask[l] == 0 || vis[vi] == 0.0f) continue;
    pb_light L = lights[l];
    float3 d = (float3)(L.dir[0], L.dir[1], L.dir[2]);
    if (dot(d, ng) <= 0.0f) continue;  // below the receiver's horizon: the shading's zero
    float texel = 2.0f * fmax(L.ex[3], L.ey[3]) / (float)map_size;
    float len = texels * texel;
    // Off the surface by a thousandth of a texel, and at least `lift`: p's own triangle is not
    // in the list, and the neighbours sharing its plane were dropped above.
    float3 o = P + ng * fmax(1e-3f * texel, 2.0f * lift);
    bool hit = false;
    for (int m = 0; m < n && !hit; ++m) {
      int4 t = tris[list[m]];
      hit = contact_hit(o, d, pos[t.x].xyz, pos[t.y].xyz, pos[t.z].xyz) < len;
    }
    if (hit) vis[vi] = 0.0f;
  }
}
