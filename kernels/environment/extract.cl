// Median-cut light extraction (Kneiphof 2017 §3.1, §4.1; Debevec 2008) on the cube-map SATs made
// from
// kernels/environment/envmap.cl's fixed-point energies. Box sums are exact 64-bit differences.
#include "shared.h"

// Sum over texels [x0,x1) x [y0,y1) of face `face` from an inclusive SAT (Kneiphof 2017 eqs. 2-3).
static long4 box4(global const long4* sat, int m, int face, int x0, int y0, int x1, int y1) {
  global const long4* S = sat + (size_t)face * m * m;
  long4 a = (long4)(0), b = (long4)(0), c = (long4)(0), d = (long4)(0);
  a = S[(size_t)(y1 - 1) * m + (x1 - 1)];
  if (x0 > 0) b = S[(size_t)(y1 - 1) * m + (x0 - 1)];
  if (y0 > 0) c = S[(size_t)(y0 - 1) * m + (x1 - 1)];
  if (x0 > 0 && y0 > 0) d = S[(size_t)(y0 - 1) * m + (x0 - 1)];
  return a - b - c + d;
}

static long region_energy(global const long4* sat, int m, pb_region r) {
  return box4(sat, m, r.face, r.x0, r.y0, r.x1, r.y1).x;
}

// Splits r along its longer edge at the illuminance median: the cut is the position whose left
// part's energy is closest to half the region's. Both halves keep at least one texel row/column.
static void split_region(global const long4* sat, int m, pb_region r, pb_region* lo,
                         pb_region* hi) {
  int w = r.x1 - r.x0, h = r.y1 - r.y0;
  bool along_x = w > h;
  if (w == h) {
    // A square region has no longer edge. A fixed choice (always x) does not turn with the map:
    // a quarter turn about y spins the top and bottom faces in their plane, so the same square
    // would be cut the other way and the lights would not turn with the map (issue 4's rotation
    // test). Cut across the axis along which the energy is less balanced about the region's
    // centre instead: |E(first half) - E(second half)| per axis (the middle row or column of an
    // odd size is left out of both). A quarter turn or a mirror swaps or keeps the two values
    // exactly, so the choice turns with the map; only an exact tie falls back to x.
    int hw = w / 2;
    long ex = box4(sat, m, r.face, r.x0, r.y0, r.x0 + hw, r.y1).x -
              box4(sat, m, r.face, r.x1 - hw, r.y0, r.x1, r.y1).x;
    long ey = box4(sat, m, r.face, r.x0, r.y0, r.x1, r.y0 + hw).x -
              box4(sat, m, r.face, r.x0, r.y1 - hw, r.x1, r.y1).x;
    // compared as floats: an integer |x| becomes llvm.abs, which oclgrind cannot run; float
    // conversion is odd-symmetric, so the comparison still turns with the map
    along_x = fabs((float)ex) >= fabs((float)ey);
  }
  long total = region_energy(sat, m, r);
  int a = along_x ? r.x0 + 1 : r.y0 + 1, b = along_x ? r.x1 - 1 : r.y1 - 1;
  // Smallest cut c in [a, b] with 2 * E(left of c) >= total (binary search on the monotone sum).
  int first = a, last = b;
  while (first < last) {
    int mid = (first + last) / 2;
    long left = along_x ? box4(sat, m, r.face, r.x0, r.y0, mid, r.y1).x
                        : box4(sat, m, r.face, r.x0, r.y0, r.x1, mid).x;
    if (2 * left >= total) last = mid; else first = mid + 1;
  }
  int cut = first;
  if (cut > a) {
    long l1 = along_x ? box4(sat, m, r.face, r.x0, r.y0, cut, r.y1).x
                      : box4(sat, m, r.face, r.x0, r.y0, r.x1, cut).x;
    long l0 = along_x ? box4(sat, m, r.face, r.x0, r.y0, cut - 1, r.y1).x
                      : box4(sat, m, r.face, r.x0, r.y0, r.x1, cut - 1).x;
    if (total - 2 * l0 < 2 * l1 - total) cut = cut - 1;
  }
  *lo = r;
  *hi = r;
  if (along_x) { lo->x1 = cut; hi->x0 = cut; }
  else { lo->y1 = cut; hi->y0 = cut; }
}

// One work-group does the whole partition, as in Kneiphof 2017 §5 (there: 256 threads in one thread
// group). Each round ranks the splittable regions by illuminance (counting, ties broken by index,
// so the result is deterministic) and splits the `need` brightest, so any target count is reached
// in about log2(target/6) rounds. With fewer than six lights the six faces are grouped instead:
// the two dimmest groups are merged until `target` remain.
kernel void median_cut(global const long4* sat, int m, int target, global pb_region* regions,
                       global int* count_out, local float* energy) {
  int lid = get_local_id(0), wg = get_local_size(0);
  local int count_l, splittable_l;
  if (lid < 6) {
    pb_region r;
    r.face = lid; r.x0 = 0; r.y0 = 0; r.x1 = m; r.y1 = m; r.group = lid; r.pad0 = 0; r.pad1 = 0;
    regions[lid] = r;
  }
  if (lid == 0) {
    count_l = 6;
    splittable_l = 0;
  }
  barrier(CLK_LOCAL_MEM_FENCE | CLK_GLOBAL_MEM_FENCE);
  if (target < 6) {
    if (lid == 0) {
      long e[6];
      int g[6];
      for (int i = 0; i < 6; ++i) { e[i] = region_energy(sat, m, regions[i]); g[i] = i; }
      for (int groups = 6; groups > target; --groups) {
        // dimmest two distinct groups (group energy = sum of its faces)
        long ge[6];
        for (int k = 0; k < 6; ++k) ge[k] = -1;
        for (int i = 0; i < 6; ++i) ge[g[i]] = (ge[g[i]] < 0 ? 0 : ge[g[i]]) + e[i];
        int a = -1, b = -1;
        for (int k = 0; k < 6; ++k) {
          if (ge[k] < 0) continue;
          if (a < 0 || ge[k] < ge[a]) { b = a; a = k; }
          else if (b < 0 || ge[k] < ge[b]) b = k;
        }
        int keep = min(a, b), drop = max(a, b);
        for (int i = 0; i < 6; ++i) if (g[i] == drop) g[i] = keep;
      }
      // relabel groups densely 0..target-1 in order of first appearance
      int label[6];
      for (int k = 0; k < 6; ++k) label[k] = -1;
      int next = 0;
      for (int i = 0; i < 6; ++i) {
        if (label[g[i]] < 0) label[g[i]] = next++;
        regions[i].group = label[g[i]];
      }
    }
    barrier(CLK_GLOBAL_MEM_FENCE);
    if (lid == 0) *count_out = 6;
    return;
  }
  for (;;) {
    int count = count_l;
    int need = target - count;
    if (need <= 0) break;
    for (int i = lid; i < count; i += wg) {
      pb_region r = regions[i];
      bool can = (r.x1 - r.x0) > 1 || (r.y1 - r.y0) > 1;
      energy[i] = can ? (float)region_energy(sat, m, r) : -1.0f;
    }
    barrier(CLK_LOCAL_MEM_FENCE);
    int mine = 0;
    for (int i = lid; i < count; i += wg) {
      float ei = energy[i];
      if (ei < 0.0f) continue;
      ++mine;
      int rank = 0;
      for (int j = 0; j < count; ++j) {
        float ej = energy[j];
        rank += (ej > ei || (ej == ei && j < i)) ? 1 : 0;
      }
      if (rank < need) {
        pb_region lo, hi;
        split_region(sat, m, regions[i], &lo, &hi);
        lo.group = i;
        hi.group = count + rank;
        regions[i] = lo;
        regions[count + rank] = hi;
      }
    }
    atomic_add(&splittable_l, mine);
    barrier(CLK_LOCAL_MEM_FENCE | CLK_GLOBAL_MEM_FENCE);
    int splittable = splittable_l;
    barrier(CLK_LOCAL_MEM_FENCE);  // everyone has read it before it is reset
    if (lid == 0) {
      count_l = count + min(need, splittable);
      splittable_l = 0;
    }
    barrier(CLK_LOCAL_MEM_FENCE);
    if (splittable == 0) break;
  }
  if (lid == 0) *count_out = count_l;
}

// One work-item per light (group): integrates its region(s) from the SATs and turns the sums into
// a directional cap light.
//  - direction: luminance-weighted mean direction (Kneiphof 2017 eq. 9, on the sphere);
//  - extent: for a uniform cap of half-angle a, the mean direction's length is (1 + cos a)/2, so
//    cos a = 2R - 1 with R the luminance-weighted mean resultant length (1 - R^2 is the weighted
//    variance of the direction, Kneiphof 2017 eq. 10 on the sphere). Clamped to [min_cos.., max..];
//  - power M: the region's colour integral (Kneiphof 2017 eq. 11) as exact fixed-point CIE XYZ sums
//    (X and Z from the xz SAT in 1/10000 units, packed two faces per long4 as envmap.cl's
//    env_sat_inputs writes them; Y from the luminance SAT); the host converts them
//    to RGB in double (src/environment/median_cut.cpp), and radiance = M / (2 pi (1 - cos a))
//    (eqs. 16-17), so the cap carries exactly the region's energy.
// out_dir: (direction, cos a); out_sums: (X * 10^4, Y, Z * 10^4, region texel count), fixed point.
kernel void resolve_lights(global const long4* lum_sat, global const long4* xz_sat, int m,
                           global const pb_region* regions, int region_count, int light_count,
                           float cos_alpha_max, float min_alpha, global float4* out_dir,
                           global long4* out_sums) {
  int g = get_global_id(0);
  if (g >= light_count) return;
  long4 L = (long4)(0);
  long X = 0, Z = 0;
  int texels = 0;
  float fallback_x = 0.0f, fallback_y = 0.0f, fallback_z = 0.0f;
  float texel_dw = 0.0f;
  for (int r = 0; r < region_count; ++r) {
    pb_region R = regions[r];
    if (R.group != g) continue;
    L += box4(lum_sat, m, R.face, R.x0, R.y0, R.x1, R.y1);
    long4 C = box4(xz_sat, m, R.face >> 1, R.x0, R.y0, R.x1, R.y1);
    X += (R.face & 1) ? C.z : C.x;
    Z += (R.face & 1) ? C.w : C.y;
    texels += (R.x1 - R.x0) * (R.y1 - R.y0);
    float u = (R.x0 + R.x1) / (float)m - 1.0f, v = (R.y0 + R.y1) / (float)m - 1.0f;
    float x, y, z;
    pb_cube_dir(R.face, u, v, &x, &y, &z);
    float inv = rsqrt(x * x + y * y + z * z);
    fallback_x += x * inv; fallback_y += y * inv; fallback_z += z * inv;
    texel_dw = fmax(texel_dw, pb_cube_texel_solid_angle(u, v, m));
  }
  float Y = (float)L.x;
  float3 mean = (float3)((float)L.y, (float)L.z, (float)L.w);
  float len = length(mean);
  float3 dir;
  float cos_a;
  if (Y > 0.0f && len > 0.0f) {
    dir = mean / len;
    float R = clamp(len / Y, 0.0f, 1.0f);
    cos_a = 2.0f * R - 1.0f;
  } else {
    float3 f = (float3)(fallback_x, fallback_y, fallback_z);
    dir = length(f) > 0.0f ? normalize(f) : (float3)(0.0f, 1.0f, 0.0f);
    cos_a = cos_alpha_max;
  }
  // No cap narrower than one texel's (2 pi (1 - cos a) = dw), nor than the user's minimum.
  float cos_min_cap = fmin(1.0f - texel_dw / (2.0f * M_PI_F), cos(min_alpha));
  cos_a = clamp(cos_a, cos_alpha_max, cos_min_cap);
  out_dir[g] = (float4)(dir, cos_a);
  out_sums[g] = (long4)(X, L.x, Z, (long)texels);
}
