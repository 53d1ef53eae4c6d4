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

// The triangles pixel p = (x, y) tests (list, at most CONTACT_MAX_IDS; returns their count, 0
// on the background): the distinct ids of its window other than its own that reach above its
// tangent plane. *P, *ng, *lift: its position, geometric normal and the rays' least lift. gpos,
// ggeo, ids: the camera G-buffer (position w = 0 where nothing); pos, tris: the scene as the
// rasterizer reads it.
static int contact_list(int x, int y, global const float4* gpos, global const float4* ggeo,
                        global const uint* ids, global const float4* pos,
                        global const int4* tris, int ntris, int width, int height, uint* list,
                        float3* P_out, float3* ng_out, float* lift_out) {
  int p = y * width + x;
  float4 P4 = gpos[p];
  if (P4.w == 0.0f) return 0;
  float3 P = P4.xyz, ng = ggeo[p].xyz;
  uint own = ids[p];
  // Rays start `lift` or more above P's tangent plane (below), and a triangle is dropped only when
  // all of it is at most `lift` above that plane, so the rule stays exact although P itself is off
  // its plane by rounding (a few ulps of its coordinates).
  float lift = 4e-7f * (fabs(P.x) + fabs(P.y) + fabs(P.z));
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
  *P_out = P;
  *ng_out = ng;
  *lift_out = lift;
  return n;
}

// Global (width, height): a pixel a work-item. mask: per light, 0 leaves it alone (a light whose
// visibility already tests triangles); vis: light-major [light][pixel], in place. map_size: the
// lights' shadow-map resolution (a texel is 2 * max(half-extents) / map_size).
kernel void contact_shadows(global const float4* gpos, global const float4* ggeo,
                            global const uint* ids, global const float4* pos,
                            global const int4* tris, int ntris, global const pb_light* lights,
                            global const uchar* mask, int nl, int width, int height,
                            global float* vis, float texels, int map_size) {
  int x = get_global_id(0), y = get_global_id(1);
  if (x >= width || y >= height) return;
  int p = y * width + x;
  uint list[CONTACT_MAX_IDS];
  float3 P, ng;
  float lift;
  int n = contact_list(x, y, gpos, ggeo, ids, pos, tris, ntris, width, height, list, &P, &ng,
                       &lift);
  if (n == 0) return;
  size_t pixels = (size_t)width * height;
  for (int l = 0; l < nl; ++l) {
    size_t vi = (size_t)l * pixels + p;
    if (mask[l] == 0 || vis[vi] == 0.0f) continue;
    pb_light L = lights[l];
    float3 d = (float3)(L.dir[0], L.dir[1], L.dir[2]);
    // below the facet's plane: contact_map tests the pixel's own triangle there, where the
    // shading normal still sees the light (the smooth-shaded terminator)
    if (dot(d, ng) <= 0.0f) continue;
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

// contact_hit(o, d, a, a + e1, a + e2) < len on scalars, in its operations and their rounding
// (cross3_s and dot3_s round as the library's cross and dot), for contact_shadows_batch's SIMD
// loop over lights.
static inline __attribute__((always_inline)) bool contact_hit_s(
    float ox, float oy, float oz, float dx, float dy, float dz, float ax, float ay, float az,
    float e1x, float e1y, float e1z, float e2x, float e2y, float e2z, float len) {
  float px, py, pz, qx, qy, qz;
  cross3_s(dx, dy, dz, e2x, e2y, e2z, &px, &py, &pz);
  const float det = dot3_s(e1x, e1y, e1z, px, py, pz);
  const float inv = 1.0f / det;
  const float sx = ox - ax, sy = oy - ay, sz = oz - az;
  const float u = dot3_s(sx, sy, sz, px, py, pz) * inv;
  cross3_s(sx, sy, sz, e1x, e1y, e1z, &qx, &qy, &qz);
  const float v = dot3_s(dx, dy, dz, qx, qy, qz) * inv;
  const float t = dot3_s(e2x, e2y, e2z, qx, qy, qz) * inv;
  return !(fabs(det) < 1e-20f) && !(u < 0.0f || u > 1.0f) &&
         !(v < 0.0f || u + v > 1.0f) && t > 0.0f && t < len;
}

// The CPU form (src/core/device_kind.hpp; the same bits): PoCL runs contact_shadows a pixel at a
// time. Here a work-item takes CS_GROUP pixels of a row, and
// - finds, in SIMD loops over the pixels, those with a triangle other than their own in their
//   window (each window row read once for the whole run, its columns clamped to the image: a
//   clamped column repeats one inside the window). The others (the inside of a triangle, the
//   ground's two above all: 45% of the built-in frame's pixels on geometry) have an empty list
//   and are skipped;
// - lists the rest's triangles with contact_list, as contact_shadows does, and where the list is
//   not empty (one pixel in ten of them) runs contact_shadows' light loop CS_LANES lights at a
//   time: each light's ray in a SIMD loop over the lights, then each listed triangle against every
//   lane's ray in another (contact_hit_s), where contact_shadows casts one ray at a time.
// Global (ceil(width / CS_GROUP), height).
#ifndef CS_GROUP
#define CS_GROUP 64
#endif
#define CS_LANES 16
kernel void contact_shadows_batch(global const float4* gpos, global const float4* ggeo,
                                  global const uint* ids, global const float4* pos,
                                  global const int4* tris, int ntris,
                                  global const pb_light* lights, global const uchar* mask,
                                  int nl, int width, int height, global float* vis, float texels,
                                  int map_size) {
  const int x0 = get_global_id(0) * CS_GROUP, y = get_global_id(1);
  if (x0 >= width || y >= height) return;
  uint own[CS_GROUP];
  int other[CS_GROUP];  // 1 where the window holds a triangle other than the pixel's own
  for (int k = 0; k < CS_GROUP; ++k) {
    own[k] = ids[y * width + min(x0 + k, width - 1)];
    other[k] = 0;
  }
  uint run[CS_GROUP + 2 * CONTACT_RADIUS];  // one window row under the run, columns clamped
  for (int j = max(0, y - CONTACT_RADIUS); j <= min(height - 1, y + CONTACT_RADIUS); ++j) {
    for (int i = 0; i < CS_GROUP + 2 * CONTACT_RADIUS; ++i)
      run[i] = ids[j * width + clamp(x0 - CONTACT_RADIUS + i, 0, width - 1)];
    for (int di = 0; di <= 2 * CONTACT_RADIUS; ++di) {
PB_SIMD_LOOP(16)
      for (int k = 0; k < CS_GROUP; ++k) {
        const uint id = run[k + di];
        other[k] |= id != PB_ID_EMPTY && id != own[k] && id < (uint)ntris;
      }
    }
  }
  const size_t pixels = (size_t)width * height;
  for (int k = 0; k < CS_GROUP && x0 + k < width; ++k) {
    if (!other[k]) continue;
    const int p = y * width + x0 + k;
    uint list[CONTACT_MAX_IDS];
    float3 P, ng;
    float lift;
    const int n = contact_list(x0 + k, y, gpos, ggeo, ids, pos, tris, ntris, width, height, list,
                               &P, &ng, &lift);
    if (n == 0) continue;
    // contact_shadows' light loop, CS_LANES lights at a time in SIMD loops: each light's ray,
    // then each listed triangle against every lane's ray
    for (int l0 = 0; l0 < nl; l0 += CS_LANES) {
      float Ox[CS_LANES], Oy[CS_LANES], Oz[CS_LANES], Dx[CS_LANES], Dy[CS_LANES], Dz[CS_LANES],
          Len[CS_LANES];
      int go[CS_LANES], hit[CS_LANES];
PB_SIMD_LOOP(CS_LANES)
      for (int i = 0; i < CS_LANES; ++i) {
        const int l = min(l0 + i, nl - 1);
        global const pb_light* L = lights + l;
        const float dx = L->dir[0], dy = L->dir[1], dz = L->dir[2];
        const float texel = 2.0f * fmax(L->ex[3], L->ey[3]) / (float)map_size;
        const float off = fmax(1e-3f * texel, 2.0f * lift);
        Ox[i] = P.x + ng.x * off;
        Oy[i] = P.y + ng.y * off;
        Oz[i] = P.z + ng.z * off;
        Dx[i] = dx;
        Dy[i] = dy;
        Dz[i] = dz;
        Len[i] = texels * texel;
        go[i] = l0 + i < nl && mask[l] != 0 && vis[(size_t)l * pixels + p] != 0.0f &&
                dot3_s(dx, dy, dz, ng.x, ng.y, ng.z) > 0.0f;
        hit[i] = 0;
      }
      for (int m = 0; m < n; ++m) {
        const int4 t = tris[list[m]];
        const float3 a = pos[t.x].xyz, e1 = pos[t.y].xyz - a, e2 = pos[t.z].xyz - a;
PB_SIMD_LOOP(CS_LANES)
        for (int i = 0; i < CS_LANES; ++i)
          hit[i] |= contact_hit_s(Ox[i], Oy[i], Oz[i], Dx[i], Dy[i], Dz[i], a.x, a.y, a.z, e1.x,
                                  e1.y, e1.z, e2.x, e2.y, e2.z, Len[i]);
      }
      for (int i = 0; i < CS_LANES && l0 + i < nl; ++i)
        if (go[i] && hit[i]) vis[(size_t)(l0 + i) * pixels + p] = 0.0f;
    }
  }
}

// ---- Contact shadows from the lights' side ----
//
// An occluder the camera does not see near the pixel escapes contact_shadows above: a sheet lying
// a few thousandths above another, whose upper layer is hidden behind the lower at the pixel and
// its neighbours (Wuson's tail tuft on studio.exr: three pixels of it, lit by every map and black
// in the truth, carried three fifths of the default frame's squared technique error). The light's
// own map sees it: rasterized with ids (Rasterizer::depthMapsWithIds), each texel names the
// triangle nearest the light along the texel's ray, and the contact ray from p towards the
// light's centre runs parallel to those rays, a fraction of a texel beside the ray of the texel p
// falls in. So for each pair (p, l) of a map-shadowed light, with t the distance from the map's
// near plane along its rays:
// - up (the centre above p's facet, n_g . w > 0): the texel's surface is a candidate when it is
//   nearer the light than p's tangent plane at the texel's ray, by more than a thousandth of a
//   texel, and not more than the contact length nearer than p. A convex surface (p's own
//   neighbours) lies on or beyond that plane and is no candidate; a farther occluder is the map
//   technique's to find. The candidate's triangle is then tested exactly.
// - down (the centre below p's facet while the shading normal still sees part of the cap: the
//   shadow terminator of smooth-shaded meshes): the ray from p, lifted off its facet by the shadow
//   offset (scene/shadow_offset.hpp), crosses the facet's plane within the contact length; p's own
//   triangle and the texel's are tested exactly, as the Embree reference's ray meets them.
// A hit sets the pair's visibility to 0, as contact_shadows does. Global (ceil(width / CM_TILE),
// ceil(height / CM_TILE)): each work-item takes a CM_TILE x CM_TILE tile of pixels and, for each
// map-shadowed light in turn, finds its candidates in a SIMD loop and tests them one by one (CPUs
// run it with 8 x 8 tiles, GPUs with one pixel). Measured on the 640x360 built-in frame with 32
// lights: 13-16 ms, where a per-light kernel over runs of 64 pixels of a row that re-read the
// G-buffer for each light took 38-47 ms (its gathers), and reading the G-buffer once per run 22-25
// ms (then the depth map's gather: a run's texels span a map's rows; bench/results/cpu_speed.md).
#ifndef CM_TILE
#define CM_TILE 1
#endif
#define CM_GROUP (CM_TILE * CM_TILE)
kernel void contact_map(global const float* gpos, global const float* gnrm,
                        global const float* ggeo, global const uint* ids,
                        global const float4* pos, global const int4* tris, int ntris,
                        global const pb_light* lights, global const uchar* mask, int nl,
                        global const uint* depth, global const uint* map_ids, int map_size,
                        int width, int height, global float* vis, float texels) {
  const int x0 = get_global_id(0) * CM_TILE, y0 = get_global_id(1) * CM_TILE;
  if (x0 >= width || y0 >= height) return;
  const size_t npixels = (size_t)width * height;
  // the tile's G-buffer, once for every light (structure of arrays: the light loop's SIMD lanes
  // read it contiguously); a tile, not a run of one row, so that a light's map texels under it
  // are a compact block, a few cache lines that the tile's rows share
  float Px[CM_GROUP], Py[CM_GROUP], Pz[CM_GROUP], Gx[CM_GROUP], Gy[CM_GROUP], Gz[CM_GROUP],
      Nx[CM_GROUP], Ny[CM_GROUP], Nz[CM_GROUP];
  int pix[CM_GROUP];  // pixel index, -1 outside the image or on the background
  int ngeo = 0;
  for (int k = 0; k < CM_GROUP; ++k) {
    const int x = x0 + k % CM_TILE, y = y0 + k / CM_TILE;
    const bool in = x < width && y < height;
    const int px = in ? y * width + x : y0 * width + x0;
    Px[k] = gpos[4 * px];
    Py[k] = gpos[4 * px + 1];
    Pz[k] = gpos[4 * px + 2];
    pix[k] = in && gpos[4 * px + 3] != 0.0f ? px : -1;
    Gx[k] = ggeo[4 * px];
    Gy[k] = ggeo[4 * px + 1];
    Gz[k] = ggeo[4 * px + 2];
    Nx[k] = gnrm[4 * px];
    Ny[k] = gnrm[4 * px + 1];
    Nz[k] = gnrm[4 * px + 2];
    ngeo += pix[k] >= 0;
  }
  if (ngeo == 0) return;  // a tile of background (sky): no pixel to shadow
  const size_t S2 = (size_t)map_size * map_size;
  for (int l = 0; l < nl; ++l) {
    if (mask[l] == 0) continue;
    global const pb_light* L = lights + l;
    const float wx = L->dir[0], wy = L->dir[1], wz = L->dir[2];
    const float ox = L->origin[0], oy = L->origin[1], oz = L->origin[2];
    const float ex0 = L->ex[0], ex1 = L->ex[1], ex2 = L->ex[2], hx = L->ex[3];
    const float ey0 = L->ey[0], ey1 = L->ey[1], ey2 = L->ey[2], hy = L->ey[3];
    const float texel = 2.0f * fmax(hx, hy) / (float)map_size;
    const float len = texels * texel, tol = 1e-3f * texel;
    const float sx = 0.5f * map_size / hx, sy = 0.5f * map_size / hy;  // texels per world unit
    const float isx = 2.0f * hx / map_size, isy = 2.0f * hy / map_size;  // world units per texel
    global const uint* md = depth + (size_t)l * S2;
    global const uint* mi = map_ids + (size_t)l * S2;
    global float* vl = vis + (size_t)l * npixels;
    int flag[CM_GROUP], tex[CM_GROUP];
    int nflag = 0;
PB_SIMD_LOOP(16)
    for (int k = 0; k < CM_GROUP; ++k) {
      const float c = Gx[k] * wx + Gy[k] * wy + Gz[k] * wz;
      const float cs = Nx[k] * wx + Ny[k] * wy + Nz[k] * wz;
      const float rx = Px[k] - ox, ry = Py[k] - oy, rz = Pz[k] - oz;
      const float xp = rx * ex0 + ry * ex1 + rz * ex2;
      const float yp = rx * ey0 + ry * ey1 + rz * ey2;
      const float tp = -(rx * wx + ry * wy + rz * wz);
      // the texel p falls in (raster.cl's ortho view: row 0 at +ey)
      const float u = xp * sx + 0.5f * map_size, v = 0.5f * map_size - yp * sy;
      const int cx = (int)clamp(u, 0.0f, (float)(map_size - 1));
      const int cy = (int)clamp(v, 0.0f, (float)(map_size - 1));
      // the texel ray's lateral offset from p (world), and its depth
      const float dx = (cx + 0.5f - u) * isx, dy = (v - cy - 0.5f) * isy;
      // read only where `up` can hold (a masked gather: the other lanes load nothing; on the
      // 32-light frame this stage went from 13.6 to 8.5 ms, bench/results/cpu_speed.md)
      const float tm = c > 0.0f ? as_float(md[cy * map_size + cx]) : 0.0f;
      // up: nearer the light than p's tangent plane at the texel's ray by more than tol, and
      // within the contact length: tm < tp + (dx a + dy b) / c - tol, times c > 0
      const float a = Gx[k] * ex0 + Gy[k] * ex1 + Gz[k] * ex2;
      const float b = Gx[k] * ey0 + Gy[k] * ey1 + Gz[k] * ey2;
      const bool up = c > 0.0f && (tm - tp + tol) * c < dx * a + dy * b && tm >= tp - len;
      const bool down = c <= 0.0f && cs > 0.0f;
      flag[k] = pix[k] >= 0 ? (up ? 1 : down ? 2 : 0) : 0;
      tex[k] = cy * map_size + cx;
      nflag += flag[k] != 0;
    }
    if (nflag == 0) continue;  // most tiles of most lights
    const float3 d = (float3)(wx, wy, wz);
    for (int k = 0; k < CM_GROUP; ++k) {
      if (flag[k] == 0 || vl[pix[k]] == 0.0f) continue;
      const float3 P = (float3)(Px[k], Py[k], Pz[k]);
      const uint own = ids[pix[k]], id = mi[tex[k]];
      bool hit = false;
      if (flag[k] == 1) {
        // as contact_shadows: off the surface by a thousandth of a texel, and at least `lift`
        const float lift = 4e-7f * (fabs(P.x) + fabs(P.y) + fabs(P.z));
        const float3 o = P + (float3)(Gx[k], Gy[k], Gz[k]) * fmax(1e-3f * texel, 2.0f * lift);
        if (id != PB_ID_EMPTY && id < (uint)ntris && id != own) {
          const int4 t = tris[id];
          hit = contact_hit(o, d, pos[t.x].xyz, pos[t.y].xyz, pos[t.z].xyz) < len;
        }
      } else {
        if (own != PB_ID_EMPTY && own < (uint)ntris) {
          const int4 t = tris[own];
          hit = contact_hit(P, d, pos[t.x].xyz, pos[t.y].xyz, pos[t.z].xyz) < len;
        }
        if (!hit && id != PB_ID_EMPTY && id < (uint)ntris && id != own) {
          const int4 t = tris[id];
          hit = contact_hit(P, d, pos[t.x].xyz, pos[t.y].xyz, pos[t.z].xyz) < len;
        }
      }
      if (hit) vl[pix[k]] = 0.0f;
    }
  }
}
