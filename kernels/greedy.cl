// Greedy fitting of square or rectangular area lights to the faces of a cube map (seed 000 §4.2,
// Figure 6), on the fixed-point energies of kernels/envmap.cl. Faces are independent, so one
// work-group fits one face: the loops of the algorithm run inside the kernel and every sum over
// texels is a local-memory tree reduction of 64-bit integers (exact, so the result does not depend
// on the work-group size or the device). src/extract_greedy.cpp turns the fitted rectangles into
// cap lights; tests/test_greedy.cpp holds a plain C++ copy of the same algorithm.
#include "shared.h"

// Luminance energy of a texel, exact in fixed point (as env_sat_inputs computes it).
static long texel_lum(global const long* energy, size_t plane, size_t i) {
  return PB_LUM_FIXED(energy[i], energy[plane + i], energy[2 * plane + i]);
}

// Seed 000's growth test: a side (or, for squares, an L-shaped rim) is added when the energy it
// adds is more than `t` of the energy the enlarged light would hold. Written without a division,
// in float, so the host reference reproduces the decision bit for bit. A light that holds no
// energy yet absorbs empty texels (0/0 counts as "everything it would hold is new"): otherwise
// every texel of a black face would become its own light.
static bool grows(long added, long held, float t) {
  long total = held + added;
  if (total == 0) return true;
  return (float)added > t * (float)total;
}

// Sum of the work-group's `v` into red[0] (wg a power of two); every work-item returns it. The
// barriers also fence global memory: the energies and flags read before a reduction are written
// by other work-items after it (the removal pass), which needs the ordering.
static long4 reduce_sum(local long4* red, long4 v) {
  int lid = get_local_id(0), wg = get_local_size(0);
  red[lid] = v;
  barrier(CLK_LOCAL_MEM_FENCE | CLK_GLOBAL_MEM_FENCE);
  for (int s = wg / 2; s > 0; s >>= 1) {
    if (lid < s) red[lid] += red[lid + s];
    barrier(CLK_LOCAL_MEM_FENCE | CLK_GLOBAL_MEM_FENCE);
  }
  long4 r = red[0];
  barrier(CLK_LOCAL_MEM_FENCE | CLK_GLOBAL_MEM_FENCE);  // everyone has read it before the next reduction overwrites it
  return r;
}

// Brightest (largest .x) entry, ties to the smallest index (.y); index -1 means "none".
static long2 reduce_argmax(local long4* red, long2 v) {
  int lid = get_local_id(0), wg = get_local_size(0);
  red[lid] = (long4)(v.x, v.y, 0, 0);
  barrier(CLK_LOCAL_MEM_FENCE | CLK_GLOBAL_MEM_FENCE);
  for (int s = wg / 2; s > 0; s >>= 1) {
    if (lid < s) {
      long4 a = red[lid], b = red[lid + s];
      bool take_b = b.y >= 0 && (a.y < 0 || b.x > a.x || (b.x == a.x && b.y < a.y));
      if (take_b) red[lid] = b;
    }
    barrier(CLK_LOCAL_MEM_FENCE | CLK_GLOBAL_MEM_FENCE);
  }
  long2 r = red[0].xy;
  barrier(CLK_LOCAL_MEM_FENCE | CLK_GLOBAL_MEM_FENCE);
  return r;
}

// energy: 3 planes (R, G, B) of 6*m*m fixed-point energies; on return it holds what the lights
// did not take (the remaining map). covered: 6*m*m bytes, cleared by the host.
// Per face f, light k (k < out_count[f] <= capacity) at index f*capacity + k:
//   out_rect = (x0, y0, x1, y1), x1/y1 exclusive;
//   out_power = removed (R, G, B, Y);
//   out_moment = removed sum of Y * (unit texel direction), (x, y, z, 0), rounded per texel.
// Local memory `red`: one long4 per work-item; the work-group size must be a power of two.
kernel void greedy_fit(global long* energy, global uchar* covered, int m, float t, int square,
                       int capacity, global int4* out_rect, global long4* out_power,
                       global long4* out_moment, global int* out_count, local long4* red) {
  const int f = get_group_id(0), lid = get_local_id(0), wg = get_local_size(0);
  const size_t plane = (size_t)6 * m * m;
  const size_t base = (size_t)f * m * m;
  const int n_texels = m * m;

  // The residual a covered texel keeps (seed 000 §4.2: "the residual amount equals the average
  // amount of energy adjusted to the size of the area"). Our reading: the face's mean energy per
  // texel, per channel, so an area of k texels keeps k times the mean: the hole a light leaves
  // blends with its surroundings instead of going black, later lights may grow over it (the paper
  // notes lights may overlap), and what every light leaves behind is a map no brighter than the
  // face's mean, which the ambient residual carries. A texel dimmer than the mean keeps all of
  // its energy (it has nothing above the mean to give).
  long4 acc = (long4)(0);
  for (int i = lid; i < n_texels; i += wg)
    acc += (long4)(energy[base + i], energy[plane + base + i], energy[2 * plane + base + i], 0);
  const long4 face_sum = reduce_sum(red, acc);
  const long avg_r = face_sum.x / n_texels, avg_g = face_sum.y / n_texels,
             avg_b = face_sum.z / n_texels;

  int n_covered = 0, n_lights = 0;
  while (n_covered < n_texels && n_lights < capacity) {
    // 1. Seed: the brightest texel no light covers yet (its energy is still the original).
    long2 best = (long2)(-1, -1);
    for (int i = lid; i < n_texels; i += wg) {
      if (covered[base + i]) continue;
      long y = texel_lum(energy, plane, base + i);
      if (best.y < 0 || y > best.x) best = (long2)(y, i);  // i grows: ties keep the first
    }
    best = reduce_argmax(red, best);
    int x0 = (int)(best.y % m), y0 = (int)(best.y / m), x1 = x0 + 1, y1 = y0 + 1;
    long held = best.x;

    // 2. Growth (seed 000 Figure 6 b-e). One reduction per step sums the four one-texel strips
    // along the current sides (outside the light); the corners are single texels, read directly.
    for (;;) {
      if (x0 == 0 && y0 == 0 && x1 == m && y1 == m) break;  // the light covers the face
      const int w = x1 - x0, h = y1 - y0;
      long4 s = (long4)(0);  // (left, right, top, bottom) strip sums
      for (int j = lid; j < 2 * (w + h); j += wg) {
        int k = j;
        if (k < h) {
          if (x0 > 0) s.x += texel_lum(energy, plane, base + (size_t)(y0 + k) * m + x0 - 1);
          continue;
        }
        k -= h;
        if (k < h) {
          if (x1 < m) s.y += texel_lum(energy, plane, base + (size_t)(y0 + k) * m + x1);
          continue;
        }
        k -= h;
        if (k < w) {
          if (y0 > 0) s.z += texel_lum(energy, plane, base + (size_t)(y0 - 1) * m + x0 + k);
          continue;
        }
        k -= w;
        if (y1 < m) s.w += texel_lum(energy, plane, base + (size_t)y1 * m + x0 + k);
      }
      s = reduce_sum(red, s);
      const bool can_l = x0 > 0, can_r = x1 < m, can_t = y0 > 0, can_b = y1 < m;
      const long c_tl = can_l && can_t ? texel_lum(energy, plane, base + (size_t)(y0 - 1) * m + x0 - 1) : 0;
      const long c_tr = can_r && can_t ? texel_lum(energy, plane, base + (size_t)(y0 - 1) * m + x1) : 0;
      const long c_bl = can_l && can_b ? texel_lum(energy, plane, base + (size_t)y1 * m + x0 - 1) : 0;
      const long c_br = can_r && can_b ? texel_lum(energy, plane, base + (size_t)y1 * m + x1) : 0;
      bool grew = false;
      if (square) {
        // Squares grow by one texel in both directions at once: the rim added towards corner
        // (dx, dy) is one side strip, one top/bottom strip and the corner between them. The
        // richest of the four rims is tested (ties to the first in the order below).
        long add[4] = {s.x + s.z + c_tl, s.y + s.z + c_tr, s.x + s.w + c_bl, s.y + s.w + c_br};
        bool ok[4] = {can_l && can_t, can_r && can_t, can_l && can_b, can_r && can_b};
        int d = -1;
        for (int q = 0; q < 4; ++q)
          if (ok[q] && (d < 0 || add[q] > add[d])) d = q;
        if (d >= 0 && grows(add[d], held, t)) {
          held += add[d];
          if (d & 1) ++x1; else --x0;
          if (d & 2) ++y1; else --y0;
          grew = true;
        }
      } else {
        // Rectangles try the sides in turn (left, right, top, bottom); a side tried after
        // another one grew includes the corner that growth exposed.
        bool gl = false, gr = false;
        if (can_l && grows(s.x, held, t)) { held += s.x; --x0; gl = true; }
        if (can_r && grows(s.y, held, t)) { held += s.y; ++x1; gr = true; }
        if (can_t) {
          long a = s.z + (gl ? c_tl : 0) + (gr ? c_tr : 0);
          if (grows(a, held, t)) { held += a; --y0; grew = true; }
        }
        if (can_b) {
          long a = s.w + (gl ? c_bl : 0) + (gr ? c_br : 0);
          if (grows(a, held, t)) { held += a; ++y1; grew = true; }
        }
        grew = grew || gl || gr;
      }
      if (!grew) break;
    }

    // 3. Removal (Figure 6 f): every texel under the light gives up what it holds above the
    // face's mean; the light's power is exactly that, so lights + remaining map = original map.
    // Every work-item has read the corner texels of the last growth step (a step that made the
    // light cover the face is followed by no reduction) before anyone overwrites them.
    barrier(CLK_GLOBAL_MEM_FENCE);
    const int w = x1 - x0, h = y1 - y0;
    long4 p = (long4)(0), mom = (long4)(0);
    for (int j = lid; j < w * h; j += wg) {
      int x = x0 + j % w, y = y0 + j / w;
      size_t i = base + (size_t)y * m + x;
      long r = energy[i], g = energy[plane + i], b = energy[2 * plane + i];
      long kr = min(r, avg_r), kg = min(g, avg_g), kb = min(b, avg_b);
      energy[i] = kr;
      energy[plane + i] = kg;
      energy[2 * plane + i] = kb;
      long dr = r - kr, dg = g - kg, db = b - kb;
      long dy = PB_LUM_FIXED(dr, dg, db);
      p += (long4)(dr, dg, db, dy);
      float dx_, dy_, dz_;
      pb_cube_dir(f, 2.0f * (x + 0.5f) / m - 1.0f, 2.0f * (y + 0.5f) / m - 1.0f, &dx_, &dy_, &dz_);
      float inv = rsqrt(dx_ * dx_ + dy_ * dy_ + dz_ * dz_);
      float fy = (float)dy;
      mom += (long4)((long)rint(fy * dx_ * inv), (long)rint(fy * dy_ * inv),
                     (long)rint(fy * dz_ * inv), covered[i] ? 0 : 1);
      covered[i] = 1;
    }
    p = reduce_sum(red, p);
    mom = reduce_sum(red, mom);
    if (lid == 0) {
      size_t o = (size_t)f * capacity + n_lights;
      out_rect[o] = (int4)(x0, y0, x1, y1);
      out_power[o] = p;
      out_moment[o] = (long4)(mom.x, mom.y, mom.z, 0);
    }
    n_covered += (int)mom.w;
    ++n_lights;
    // The next seed search reads `covered` and the energies this pass wrote.
    barrier(CLK_GLOBAL_MEM_FENCE);
  }
  if (lid == 0) out_count[f] = n_lights;
}
