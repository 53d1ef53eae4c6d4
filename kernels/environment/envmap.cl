// Environment map -> cube map of per-texel radiant energy (radiance x solid angle), in 64-bit fixed
// point so that resampling conserves energy exactly and the median-cut SATs are exact.
//
// Two resampling directions, chosen by the host by relative resolution:
//  - env_splat: the equirect is finer than the cube. Every equirect texel is cut into SS x SS
//    sub-texels, each carrying L x (its exact solid angle) to the cube texel its centre falls in.
//    Every joule lands somewhere: the cube's total equals the map's integral up to rounding.
//  - env_gather: the cube is finer. Each cube texel averages SS x SS nearest-texel lookups, times
//    its own solid angle (Kneiphof 2017 eq. 8, DESIGN.md: dw = 4/m^2 (1+u^2+v^2)^(-3/2)).
// Both compute what a per-sample evaluation computes, bit for bit, faster: trig that depends on
// one coordinate only is tabulated by small kernels with the same float expressions (same bits),
// and the splat merges its adds in integers (same sums). Both honour the map's rotation about +y
// as a column shift (pb_env_column / pb_env_world_column in shared.h), so the cube is the rotated
// map's and every extraction sees the rotated lights.
#include "shared.h"
#pragma OPENCL EXTENSION cl_khr_int64_base_atomics : enable

// Solid angle of sub-row [t0, t1) (in texel rows) of a height-H equirect, per unit of column:
// (2 pi / W) (cos th0 - cos th1), written as 2 sin(mid) sin(half) to avoid cancellation near the
// poles, where th0 and th1 are tiny.
static float row_solid_angle(float t0, float t1, float W, float H) {
  float th0 = t0 / H * M_PI_F, th1 = t1 / H * M_PI_F;
  return 2.0f * M_PI_F / W * 2.0f * sin(0.5f * (th0 + th1)) * sin(0.5f * (th1 - th0));
}

static int cube_texel(float x, float y, float z, int m) {
  float u, v;
  int face = pb_cube_face(x, y, z, &u, &v);
  int cx = clamp((int)floor((u + 1.0f) * 0.5f * m), 0, m - 1);
  int cy = clamp((int)floor((v + 1.0f) * 0.5f * m), 0, m - 1);
  return (face * m + cy) * m + cx;
}

// The splat's sub-texel directions are separable: sub-row r = t SS + j fixes theta, sub-column
// q = s SS + i fixes phi, and pb_equirect_dir's (sin theta sin phi, cos theta, -sin theta cos phi)
// is a product of the two. These two tables hold the sines and cosines (and the sub-row's solid
// angle), computed by the same float expressions as pb_equirect_dir and row_solid_angle, so the
// splat sees the same bits as when it evaluated them per sub-texel, at (W + H) SS trig calls
// instead of 4 W H SS^2 (the trig was nearly all of the splat's time: 4 calls per sub-texel).
// rows[r] = (sin theta, cos theta, solid angle x scale, 0).
kernel void env_splat_rows(int H, int SS, float scale, int W, global float4* rows) {
  int r = get_global_id(0);
  if (r >= H * SS) return;
  int t = r / SS, j = r - t * SS;
  float t0 = t + (float)j / SS, t1 = t + (float)(j + 1) / SS;
  float dw = row_solid_angle(t0, t1, (float)W, (float)H) / SS * scale;
  float theta = 0.5f * (t0 + t1) / (float)H * 3.14159265358979323846f;
  rows[r] = (float4)(sin(theta), cos(theta), dw, 0.0f);
}

// cols[q] = (sin phi, cos phi) of sub-column q = s SS + i of map column s, in world columns (the
// rotation's shift, pb_env_world_column).
kernel void env_splat_columns(int W, int SS, float shift, global float2* cols) {
  int q = get_global_id(0);
  if (q >= W * SS) return;
  int s = q / SS, i = q - s * SS;
  float sw = pb_env_world_column(s, shift, W) + (i + 0.5f) / SS;
  float phi = (sw / (float)W - 0.5f) * 6.28318530717958647692f;
  cols[q] = (float2)(sin(phi), cos(phi));
}

// A few cube texels' energies held in private memory, so that a work-item adds once per texel it
// touches instead of once per sub-texel run: integer sums are exact, so merging runs in longs
// before the atomic add leaves every total bit for bit what one add per run gives.
#define SPLAT_SLOTS 4
typedef struct {
  int texel[SPLAT_SLOTS];
  long e[SPLAT_SLOTS][3];
  int next;  // slot to evict next, round robin
} splat_slots;

static void slot_flush(splat_slots* sl, int k, volatile global long* energy, size_t plane) {
  int t = sl->texel[k];
  if (t < 0) return;
  atom_add(&energy[t], sl->e[k][0]);
  atom_add(&energy[plane + t], sl->e[k][1]);
  atom_add(&energy[2 * plane + t], sl->e[k][2]);
  sl->texel[k] = -1;
}

static void slot_add(splat_slots* sl, int texel, float a0, float a1, float a2,
                     volatile global long* energy, size_t plane) {
  // Each run is rounded on its own, as when every run was one atomic add.
  long r0 = (long)rint(a0), r1 = (long)rint(a1), r2 = (long)rint(a2);
  int k = 0;
  while (k < SPLAT_SLOTS && sl->texel[k] != texel) ++k;
  if (k == SPLAT_SLOTS) {
    k = sl->next;
    sl->next = (k + 1) % SPLAT_SLOTS;
    slot_flush(sl, k, energy, plane);
    sl->texel[k] = texel;
    sl->e[k][0] = sl->e[k][1] = sl->e[k][2] = 0;
  }
  sl->e[k][0] += r0;
  sl->e[k][1] += r1;
  sl->e[k][2] += r2;
}

// energy: 3 planes (R, G, B) of 6*m*m longs, cleared by the host. rows, cols: the tables above.
// One work-item per strip of `strip` equirect texels of one row (neighbouring texels mostly share
// cube texels, so the slots merge their adds).
kernel void env_splat(global const float* equirect, global const float4* rows,
                      global const float2* cols, int W, int H, int SS, int strip, int m,
                      volatile global long* energy) {
  int s0 = get_global_id(0) * strip, t = get_global_id(1);
  if (s0 >= W || t >= H) return;
  int s1 = min(s0 + strip, W);
  size_t plane = (size_t)6 * m * m;
  splat_slots sl;
  for (int k = 0; k < SPLAT_SLOTS; ++k) sl.texel[k] = -1;
  sl.next = 0;
  for (int s = s0; s < s1; ++s) {
    global const float* L = equirect + 3 * ((size_t)t * W + s);
    // Sub-texels of this map texel that land in the same cube texel one after another are summed
    // in float, then rounded once: a run.
    int open_texel = -1;
    float acc0 = 0.0f, acc1 = 0.0f, acc2 = 0.0f;
    for (int j = 0; j < SS; ++j) {
      float4 row = rows[t * SS + j];
      float dw = row.z;
      for (int i = 0; i < SS; ++i) {
        float2 col = cols[s * SS + i];
        // pb_equirect_dir: (st sin phi, cos theta, -st cos phi)
        int texel = cube_texel(row.x * col.x, row.y, -row.x * col.y, m);
        if (texel != open_texel) {
          if (open_texel >= 0) slot_add(&sl, open_texel, acc0, acc1, acc2, energy, plane);
          open_texel = texel;
          acc0 = acc1 = acc2 = 0.0f;
        }
        acc0 += L[0] * dw;
        acc1 += L[1] * dw;
        acc2 += L[2] * dw;
      }
    }
    slot_add(&sl, open_texel, acc0, acc1, acc2, energy, plane);
  }
  for (int k = 0; k < SPLAT_SLOTS; ++k) slot_flush(&sl, k, energy, plane);
}

// pb_dir_equirect's row t alone, by the same expressions.
static float equirect_row(float x, float y, float z, float height) {
  float len = sqrt(x * x + y * y + z * z);
  float cy = y / len;
  cy = cy > 1.0f ? 1.0f : (cy < -1.0f ? -1.0f : cy);
  return acos(cy) / 3.14159265358979323846f * height;
}

// On the four side faces (+X, -X, +Z, -Z) a gather sample's azimuth atan2(x, -z) depends on its
// column u only, so its map column is tabulated once per face and sub-column, by the same
// expressions as pb_dir_equirect and pb_env_column: the gather reads the same texels as when it
// evaluated them per sample, and skips atan2 on two thirds of the cube (atan2 and acos were most
// of its time). cols[(side m + x) SS + i], side 0..3 for faces 0, 1, 4, 5.
kernel void env_gather_columns(int W, float shift, int SS, int m, global int* cols) {
  int q = get_global_id(0);
  if (q >= 4 * m * SS) return;
  int side = q / (m * SS), k = q - side * m * SS;
  int x = k / SS, i = k - x * SS;
  float u = 2.0f * (x + (i + 0.5f) / SS) / m - 1.0f;
  float dx, dy, dz;
  pb_cube_dir(side < 2 ? side : side + 2, u, 0.0f, &dx, &dy, &dz);
  float s = (atan2(dx, -dz) / 6.28318530717958647692f + 0.5f) * (float)W;
  cols[q] = pb_env_column(s, shift, W);
}

static void gather_write(global long* energy, size_t plane, int face, int m, int x, int y,
                         float a0, float a1, float a2) {
  size_t i = ((size_t)face * m + y) * m + x;
  energy[i] = (long)rint(a0);
  energy[plane + i] = (long)rint(a1);
  energy[2 * plane + i] = (long)rint(a2);
}

// One work-item per texel (x, y) of face pair g: g = 0 gathers faces +X and -X, g = 1 faces +Z and
// -Z, g = 2 and 3 the polar faces +Y and -Y alone. The two faces of a side pair see (+-1, -v, -+u)
// and (+-u, -v, +-1): the same squares, so the same length and row t, by the same expressions, and
// each sample's acos and solid angle serve both (their columns come from `cols`,
// env_gather_columns' table). Each face's samples are summed in the same order as one face alone.
kernel void env_gather(global const float* equirect, global const int* cols, int W, int H,
                       float shift, int SS, int m, float scale, global long* energy) {
  int x = get_global_id(0), y = get_global_id(1), g = get_global_id(2);
  if (x >= m || y >= m) return;
  size_t plane = (size_t)6 * m * m;
  const bool polar = g >= 2;
  const int fa = polar ? g : 4 * g;  // first face of the pair: 0, 4, or the polar face
  global const int* ca = cols + (size_t)2 * g * m * SS;  // sides 0, 1 (faces 0, 1); 2, 3 (4, 5)
  global const int* cb = ca + (size_t)m * SS;
  float a0 = 0.0f, a1 = 0.0f, a2 = 0.0f, b0 = 0.0f, b1 = 0.0f, b2 = 0.0f;
  for (int j = 0; j < SS; ++j)
    for (int i = 0; i < SS; ++i) {
      float u = 2.0f * (x + (i + 0.5f) / SS) / m - 1.0f;
      float v = 2.0f * (y + (j + 0.5f) / SS) / m - 1.0f;
      float dx, dy, dz, s, t;
      pb_cube_dir(fa, u, v, &dx, &dy, &dz);
      float dw = pb_cube_texel_solid_angle(u, v, m * SS) * scale;
      if (polar) {
        pb_dir_equirect(dx, dy, dz, (float)W, (float)H, &s, &t);
        int si = pb_env_column(s, shift, W), ti = clamp((int)floor(t), 0, H - 1);
        global const float* L = equirect + 3 * ((size_t)ti * W + si);
        a0 += L[0] * dw;
        a1 += L[1] * dw;
        a2 += L[2] * dw;
      } else {
        t = equirect_row(dx, dy, dz, (float)H);
        size_t row = (size_t)clamp((int)floor(t), 0, H - 1) * W;
        global const float* La = equirect + 3 * (row + ca[x * SS + i]);
        global const float* Lb = equirect + 3 * (row + cb[x * SS + i]);
        a0 += La[0] * dw;
        a1 += La[1] * dw;
        a2 += La[2] * dw;
        b0 += Lb[0] * dw;
        b1 += Lb[1] * dw;
        b2 += Lb[2] * dw;
      }
    }
  gather_write(energy, plane, fa, m, x, y, a0, a1, a2);
  if (!polar) gather_write(energy, plane, fa + 1, m, x, y, b0, b1, b2);
}

// SAT inputs per cube texel: lum = (Y, Y*wx, Y*wy, Y*wz) with w the texel's unit direction (for the
// luminance-weighted mean direction, Kneiphof 2017 eqs. 9-10 taken on the sphere), and colour as
// CIE XYZ
// (Kneiphof 2017 §5: the luminance Y is one of the colour channels, so its SAT is shared and only X
// and Z need their own: 6 channels where (Y, moments) + (R, G, B, padding) took 8).
// Y is computed exactly in fixed point with the Rec. 709 weights, then truncated to the energy's
// units, as before (the median-cut splits depend on it bit for bit). X and Z are kept in 1/10000
// units, exact: every channel of the cube's energy sums to at most 2^48
// (src/environment/cubemap.cpp's scale), so X <= 0.9505e4 * 2^48 < 2^61.3 and
// Z <= 1.089e4 * 2^48 < 2^61.5 for the whole cube, and no SAT entry can overflow. xz: 3 images of m x m long4, image f/2 holding (X, Z) of face f
// in lanes 2(f%2), 2(f%2)+1: the two planes of two faces per long4, so the colour SAT is 3 long4
// images where RGB took 6, and runs in the scan's long4 path (12 scalar Long images take longer
// than 6 long4 ones on the CPU here: per-element overhead, not bytes, limits that scan).
kernel void env_sat_inputs(global const long* energy, int m, global long4* lum, global long* xz) {
  int x = get_global_id(0), y = get_global_id(1), face = get_global_id(2);
  if (x >= m || y >= m) return;
  size_t plane = (size_t)6 * m * m;
  size_t i = ((size_t)face * m + y) * m + x;
  long r = energy[i], g = energy[plane + i], b = energy[2 * plane + i];
  long Y = PB_LUM_FIXED(r, g, b);
  float u = 2.0f * (x + 0.5f) / m - 1.0f, v = 2.0f * (y + 0.5f) / m - 1.0f;
  float dx, dy, dz;
  pb_cube_dir(face, u, v, &dx, &dy, &dz);
  float inv = rsqrt(dx * dx + dy * dy + dz * dz);
  float fy = (float)Y;
  lum[i] = (long4)(Y, (long)rint(fy * dx * inv), (long)rint(fy * dy * inv),
                   (long)rint(fy * dz * inv));
  size_t j = 4 * (((size_t)(face >> 1) * m + y) * m + x) + 2 * (face & 1);
  xz[j] = PB_X_R_I * r + PB_X_G_I * g + PB_X_B_I * b;
  xz[j + 1] = PB_Z_R_I * r + PB_Z_G_I * g + PB_Z_B_I * b;
}
