// Greedy fitting of square or rectangular area lights to the faces of a cube map (Annen et al. 2008
// §4.2,
// Figure 6), on the fixed-point energies of kernels/environment/envmap.cl. Faces are independent,
// so one work-group fits one face: the loops of the algorithm run inside the kernel, every sum is
// of 64-bit integers (exact, so the result depends on neither the work-group size nor the device).
// src/environment/greedy.cpp turns the fitted rectangles into cap lights; tests/test_greedy.cpp
// holds a plain C++ copy of the same algorithm.
//
// Cost. A face of m^2 texels gets L lights (at t = 0.02 on the built-in sky: about 240 at m = 256;
// at m = 512 the square fit reaches the cap of 16384 lights, see src/environment/greedy.hpp), each
// grown in about its side length of steps. Summing every step's strips and scanning the face for
// every seed costs O(L (m^2 + side^2)) and one work-group reduction per step. Instead, per face:
//   - a luminance plane and per-row and per-column prefix sums of it make each side's sum two
//     reads, so one work-item grows the light alone, without a barrier per step;
//   - the brightest uncovered texel of each row makes the seed an arg-max over m rows;
//   - a texel's energy changes only the first time a light covers it (it keeps min(e, mean), and
//     min(min(e, mean), mean) = min(e, mean)), so the removal visits only uncovered texels (rows
//     without any are skipped by a prefix count of uncovered texels) and only the rows and
//     columns holding newly covered texels have their prefix sums redone.
#include "shared.h"

// Luminance energy of a texel, exact in fixed point (as env_sat_inputs computes it).
static long texel_lum(global const long* energy, size_t plane, size_t i) {
  return PB_LUM_FIXED(energy[i], energy[plane + i], energy[2 * plane + i]);
}

// Annen et al.'s (2008) growth test: a side (or, for squares, an L-shaped rim) is added when the
// energy it
// adds is more than `t` of the energy the enlarged light would hold. Written without a division,
// in float, so the host reference reproduces the decision bit for bit. A light that holds no
// energy yet absorbs empty texels (0/0 counts as "everything it would hold is new"): otherwise
// every texel of a black face would become its own light.
static bool grows(long added, long held, float t) {
  long total = held + added;
  if (total == 0) return true;
  return (float)added > t * (float)total;
}

// Sums of the work-group's `a` and `b` (wg a power of two); every work-item returns them. `red`
// holds 2 * wg long4. The barriers also fence global memory: what work-items wrote before a
// reduction (energies, prefix sums, row seeds) is read by others after it.
static void reduce_sum2(local long4* red, long4* a, long4* b) {
  int lid = get_local_id(0), wg = get_local_size(0);
  red[lid] = *a;
  red[wg + lid] = *b;
  barrier(CLK_LOCAL_MEM_FENCE | CLK_GLOBAL_MEM_FENCE);
  for (int s = wg / 2; s > 0; s >>= 1) {
    if (lid < s) {
      red[lid] += red[lid + s];
      red[wg + lid] += red[wg + lid + s];
    }
    barrier(CLK_LOCAL_MEM_FENCE | CLK_GLOBAL_MEM_FENCE);
  }
  *a = red[0];
  *b = red[wg];
  barrier(CLK_LOCAL_MEM_FENCE | CLK_GLOBAL_MEM_FENCE);  // everyone has read them before the next
                                                        // reduction
}

// The better of two (energy, index) candidates: larger energy, ties to the smaller index; index
// -1 means "none". A total order, so any reduction tree finds the same one.
static long2 better(long2 a, long2 b) {
  bool take_b = b.y >= 0 && (a.y < 0 || b.x > a.x || (b.x == a.x && b.y < a.y));
  return take_b ? b : a;
}

static long2 reduce_argmax(local long4* red, long2 v) {
  int lid = get_local_id(0), wg = get_local_size(0);
  red[lid] = (long4)(v.x, v.y, 0, 0);
  barrier(CLK_LOCAL_MEM_FENCE | CLK_GLOBAL_MEM_FENCE);
  for (int s = wg / 2; s > 0; s >>= 1) {
    if (lid < s) red[lid].xy = better(red[lid].xy, red[lid + s].xy);
    barrier(CLK_LOCAL_MEM_FENCE | CLK_GLOBAL_MEM_FENCE);
  }
  long2 r = red[0].xy;
  barrier(CLK_LOCAL_MEM_FENCE | CLK_GLOBAL_MEM_FENCE);
  return r;
}

// Brightest uncovered texel of row y of a face (`lum` and `covered` start at the face), as
// (luminance, index within the face), or (-1, -1).
static long2 row_seed(global const long* lum, global const uchar* covered, int m, int y) {
  long2 best = (long2)(-1, -1);
  for (int x = 0; x < m; ++x) {
    size_t i = (size_t)y * m + x;
    if (!covered[i] && (best.y < 0 || lum[i] > best.x)) best = (long2)(lum[i], (long)i);
  }
  return best;
}

// energy: 3 planes (R, G, B) of 6*m*m fixed-point energies; on return it holds what the lights
// did not take (the remaining map). covered: 6*m*m bytes, cleared by the host.
// Scratch, per face f: lum (m*m: the luminance of the current energies) and lum_t (the same,
// column by column, so that redoing a column's sums reads contiguous memory), row_sum and col_sum
// (m*(m+1) each: row_sum[y*(m+1) + x] = sum of lum over [0, x) of row y; col_sum[x*(m+1) + y] the
// same down column x), row_open (m*(m+1): prefix counts of uncovered texels per row), row_best
// (m: row_seed of each row), all at offset f times their per-face size.
// Per face f, light k (k < out_count[f] <= capacity) at index f*capacity + k:
//   out_rect = (x0, y0, x1, y1), x1/y1 exclusive;
//   out_power = removed (R, G, B, Y);
//   out_moment = removed sum of Y * (unit texel direction), (x, y, z, 0), rounded per texel.
// Local memory: `red` 2 long4 per work-item (the work-group size must be a power of two),
// `col_dirty` m ints (per column, the first row the removal changed; m: none).
kernel void greedy_fit(global long* energy, global uchar* covered, int m, float t, int square,
                       int capacity, global long* lum_all, global long* lum_t_all,
                       global long* row_sum_all, global long* col_sum_all,
                       global int* row_open_all, global long2* row_best_all,
                       global int4* out_rect, global long4* out_power,
                       global long4* out_moment, global int* out_count, local long4* red,
                       local int* col_dirty) {
  const int f = get_group_id(0), lid = get_local_id(0), wg = get_local_size(0);
  const size_t plane = (size_t)6 * m * m;
  const size_t base = (size_t)f * m * m;
  const size_t pbase = (size_t)f * m * (m + 1);  // a face's prefix arrays
  const int n_texels = m * m;
  global long* lum = lum_all + base;
  global long* lum_t = lum_t_all + base;
  global long* row_sum = row_sum_all + pbase;
  global long* col_sum = col_sum_all + pbase;
  global int* row_open = row_open_all + pbase;
  global long2* row_best = row_best_all + (size_t)f * m;
  local int4 rect_shared[1];

  // The residual a covered texel keeps (Annen et al. 2008 §4.2: "the residual amount equals the
  // average
  // amount of energy adjusted to the size of the area"). Our reading: the face's mean energy per
  // texel, per channel, so an area of k texels keeps k times the mean: the hole a light leaves
  // blends with its surroundings instead of going black, later lights may grow over it (the paper
  // notes lights may overlap), and what every light leaves behind is a map no brighter than the
  // face's mean, which the ambient residual carries. A texel dimmer than the mean keeps all of
  // its energy (it has nothing above the mean to give).
  long4 acc = (long4)(0), none = (long4)(0);  // one sum wanted; reduce_sum2 takes two
  for (int i = lid; i < n_texels; i += wg) {
    acc += (long4)(energy[base + i], energy[plane + base + i], energy[2 * plane + base + i], 0);
    lum[i] = texel_lum(energy, plane, base + i);
    lum_t[(size_t)(i % m) * m + i / m] = lum[i];
  }
  for (int x = lid; x < m; x += wg) col_dirty[x] = m;
  reduce_sum2(red, &acc, &none);
  const long4 face_sum = acc;
  const long avg_r = face_sum.x / n_texels, avg_g = face_sum.y / n_texels,
             avg_b = face_sum.z / n_texels;
  for (int y = lid; y < m; y += wg) {
    long s = 0;
    row_sum[(size_t)y * (m + 1)] = 0;
    row_open[(size_t)y * (m + 1)] = 0;
    for (int x = 0; x < m; ++x) {
      s += lum[(size_t)y * m + x];
      row_sum[(size_t)y * (m + 1) + x + 1] = s;
      row_open[(size_t)y * (m + 1) + x + 1] = x + 1;  // nothing is covered yet
    }
    row_best[y] = row_seed(lum, covered + base, m, y);
  }
  for (int x = lid; x < m; x += wg) {
    long s = 0;
    col_sum[(size_t)x * (m + 1)] = 0;
    for (int y = 0; y < m; ++y) {
      s += lum_t[(size_t)x * m + y];
      col_sum[(size_t)x * (m + 1) + y + 1] = s;
    }
  }
  barrier(CLK_GLOBAL_MEM_FENCE);

  int n_covered = 0, n_lights = 0;
  while (n_covered < n_texels && n_lights < capacity) {
    // 1. Seed: the brightest texel no light covers yet (its energy is still the original).
    long2 best = (long2)(-1, -1);
    for (int y = lid; y < m; y += wg) best = better(best, row_best[y]);
    best = reduce_argmax(red, best);

    // 2. Growth (Annen et al. 2008 Figure 6 b-e), by one work-item: each side's sum (the one-texel
    // strip
    // along it, outside the light) is a difference of two prefix sums; the corners are single
    // texels, read directly.
    if (lid == 0) {
      int x0 = (int)(best.y % m), y0 = (int)(best.y / m), x1 = x0 + 1, y1 = y0 + 1;
      long held = best.x;
      for (;;) {
        if (x0 == 0 && y0 == 0 && x1 == m && y1 == m) break;  // the light covers the face
        const bool can_l = x0 > 0, can_r = x1 < m, can_t = y0 > 0, can_b = y1 < m;
        const long s_l = can_l ? col_sum[(size_t)(x0 - 1) * (m + 1) + y1] - col_sum[(size_t)(x0 - 1) * (m + 1) + y0] : 0;
        const long s_r = can_r ? col_sum[(size_t)x1 * (m + 1) + y1] - col_sum[(size_t)x1 * (m + 1) + y0] : 0;
        const long s_t = can_t ? row_sum[(size_t)(y0 - 1) * (m + 1) + x1] - row_sum[(size_t)(y0 - 1) * (m + 1) + x0] : 0;
        const long s_b = can_b ? row_sum[(size_t)y1 * (m + 1) + x1] - row_sum[(size_t)y1 * (m + 1) + x0] : 0;
        const long c_tl = can_l && can_t ? lum[(size_t)(y0 - 1) * m + x0 - 1] : 0;
        const long c_tr = can_r && can_t ? lum[(size_t)(y0 - 1) * m + x1] : 0;
        const long c_bl = can_l && can_b ? lum[(size_t)y1 * m + x0 - 1] : 0;
        const long c_br = can_r && can_b ? lum[(size_t)y1 * m + x1] : 0;
        bool grew = false;
        if (square) {
          // Squares grow by one texel in both directions at once: the rim added towards corner
          // (dx, dy) is one side strip, one top/bottom strip and the corner between them. The
          // richest of the four rims is tested (ties to the first in the order below).
          long add[4] = {s_l + s_t + c_tl, s_r + s_t + c_tr, s_l + s_b + c_bl, s_r + s_b + c_br};
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
          if (can_l && grows(s_l, held, t)) { held += s_l; --x0; gl = true; }
          if (can_r && grows(s_r, held, t)) { held += s_r; ++x1; gr = true; }
          if (can_t) {
            long a = s_t + (gl ? c_tl : 0) + (gr ? c_tr : 0);
            if (grows(a, held, t)) { held += a; --y0; grew = true; }
          }
          if (can_b) {
            long a = s_b + (gl ? c_bl : 0) + (gr ? c_br : 0);
            if (grows(a, held, t)) { held += a; ++y1; grew = true; }
          }
          grew = grew || gl || gr;
        }
        if (!grew) break;
      }
      rect_shared[0] = (int4)(x0, y0, x1, y1);
    }
    // Also global: the growth read the sums and luminances the removal is about to rewrite.
    barrier(CLK_LOCAL_MEM_FENCE | CLK_GLOBAL_MEM_FENCE);
    const int4 rc = rect_shared[0];
    const int x0 = rc.x, y0 = rc.y, x1 = rc.z, y1 = rc.w;

    // 3. Removal (Figure 6 f): every texel under the light gives up what it holds above the
    // face's mean; the light's power is exactly that, so lights + remaining map = original map.
    // Covered texels hold no more than the mean already and give nothing; rows are shared out
    // among the work-items, and each redoes the prefix sums and seed of the rows it changed.
    long4 p = (long4)(0), mom = (long4)(0);
    for (int y = y0 + lid; y < y1; y += wg) {
      const size_t ro = (size_t)y * (m + 1);
      if (row_open[ro + x1] == row_open[ro + x0]) continue;  // no uncovered texel under the light
      bool best_taken = false;
      int first = x1;  // the first texel of the row that changes
      for (int x = x0; x < x1; ++x) {
        size_t i = base + (size_t)y * m + x;
        if (covered[i]) continue;
        long r = energy[i], g = energy[plane + i], b = energy[2 * plane + i];
        long kr = min(r, avg_r), kg = min(g, avg_g), kb = min(b, avg_b);
        energy[i] = kr;
        energy[plane + i] = kg;
        energy[2 * plane + i] = kb;
        lum[(size_t)y * m + x] = lum_t[(size_t)x * m + y] = PB_LUM_FIXED(kr, kg, kb);
        long dr = r - kr, dg = g - kg, db = b - kb;
        long dy = PB_LUM_FIXED(dr, dg, db);
        p += (long4)(dr, dg, db, dy);
        float dx_, dy_, dz_;
        pb_cube_dir(f, 2.0f * (x + 0.5f) / m - 1.0f, 2.0f * (y + 0.5f) / m - 1.0f, &dx_, &dy_, &dz_);
        float inv = rsqrt(dx_ * dx_ + dy_ * dy_ + dz_ * dz_);
        float fy = (float)dy;
        mom += (long4)((long)rint(fy * dx_ * inv), (long)rint(fy * dy_ * inv),
                       (long)rint(fy * dz_ * inv), 1);
        covered[i] = 1;
        atomic_min(&col_dirty[x], y);
        first = min(first, x);
        best_taken = best_taken || row_best[y].y == (long)y * m + x;
      }
      long s = row_sum[ro + first];
      int open = row_open[ro + first];
      for (int x = first; x < m; ++x) {
        size_t i = (size_t)y * m + x;
        s += lum[i];
        open += covered[base + i] ? 0 : 1;
        row_sum[ro + x + 1] = s;
        row_open[ro + x + 1] = open;
      }
      // Covering takes candidates away and changes no uncovered texel: only a row whose seed was
      // taken needs a new one.
      if (best_taken) row_best[y] = row_seed(lum, covered + base, m, y);
    }
    reduce_sum2(red, &p, &mom);
    for (int x = x0 + lid; x < x1; x += wg) {
      const int first = col_dirty[x];
      if (first == m) continue;
      col_dirty[x] = m;
      const size_t co = (size_t)x * (m + 1);
      long s = col_sum[co + first];
      for (int y = first; y < m; ++y) {
        s += lum_t[(size_t)x * m + y];
        col_sum[co + y + 1] = s;
      }
    }
    if (lid == 0) {
      size_t o = (size_t)f * capacity + n_lights;
      out_rect[o] = (int4)(x0, y0, x1, y1);
      out_power[o] = p;
      out_moment[o] = (long4)(mom.x, mom.y, mom.z, 0);
    }
    n_covered += (int)mom.w;
    ++n_lights;
    // The next seed search and growth read the column sums this pass wrote.
    barrier(CLK_LOCAL_MEM_FENCE | CLK_GLOBAL_MEM_FENCE);
  }
  if (lid == 0) out_count[f] = n_lights;
}
