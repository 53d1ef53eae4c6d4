// Moment soft shadow mapping with four and six moments (MSSM4: Kneiphof 2017 §3.2.1, MSSM6: §4.2.1;
// Peters et al. 2016 for MSSM, Peters & Klein 2015 for the Hamburger moment reconstruction), and
// the upper-bound blocker depth of Kneiphof 2017 §4.2.2 for both.
//
// Per light: depth map -> fixed-point moments -> prefilter (SAT: kernels/common/scan.cl, exact
// 64-bit sums; or the mip pyramid) -> per pixel: blocker search box, average blocker depth (seed
// 003 eq. 7, or eq. 19), penumbra width (Kneiphof 2017 eq. 5 for a directional light), filtered
// visibility (eq. 6) bounded from the box-filtered moments.
#include "shared.h"
#include "filter.clh"
#include "shadow_params.h"

// Depth map (ray distances from the light's near plane, uint bit patterns) -> normalized depth.
// Empty texels see nothing: depth 1 (the far plane), which never shadows.
static float map_depth(uint bits, float range) {
  return bits == PB_DEPTH_EMPTY ? 1.0f : clamp(as_float(bits) / range, 0.0f, 1.0f);
}

// MSSM4 moments (z, z^2, z^3, z^4) in fixed point. Map l's texels start at element l * stride of
// `moments` (room for the prefilter's levels).
kernel void depth_to_moments(global const uint* depth, global const pb_light* lights, int size,
                             ulong stride, global long4* moments) {
  int x = get_global_id(0), y = get_global_id(1), l = get_global_id(2);
  if (x >= size || y >= size) return;
  size_t i = ((size_t)l * size + y) * size + x;
  float z = map_depth(depth[i], lights[l].origin[3]);
  float z2 = z * z;
  // z is a float, so float products carry all its precision; 2^32 is exact in float.
  moments[l * stride + (size_t)y * size + x] = convert_long4_rte((float4)(z, z2, z2 * z, z2 * z2) * (float)PB_MOMENT_SCALE);
}

// The CPU form of depth_to_moments (src/shadows/mssm4.cpp picks it where the CPU forms run,
// src/core/device_kind.hpp): the float4 and long4 values above make PoCL run depth_to_moments one
// texel at a time; here a work-item takes one row of one map in a SIMD loop over scalars. The same
// products, and rint() then a truncating conversion (exact: rint's result is an integer, under
// 2^33) round as convert_long4_rte does: the same moments, bit for bit (tests/test_mssm.cpp).
// moments_row is that loop for one row (depth_to_moments_sat below runs it too).
static inline __attribute__((always_inline)) void moments_row(global const uint* in,
                                                              global long* out, int size,
                                                              float range) {
  const float scale = (float)PB_MOMENT_SCALE;
PB_SIMD_LOOP(16)
  for (int x = 0; x < size; ++x) {
    const float z = map_depth(in[x], range);
    const float z2 = z * z;
    out[4 * x] = (long)rint(z * scale);
    out[4 * x + 1] = (long)rint(z2 * scale);
    out[4 * x + 2] = (long)rint((z2 * z) * scale);
    out[4 * x + 3] = (long)rint((z2 * z2) * scale);
  }
}

// Global size (size, lights).
kernel void depth_to_moments_rows(global const uint* depth, global const pb_light* lights,
                                  int size, ulong stride, global long* moments) {
  const int y = get_global_id(0), l = get_global_id(1);
  if (y >= size) return;
  moments_row(depth + ((size_t)l * size + y) * size, moments + 4 * (l * stride + (size_t)y * size),
              size, lights[l].origin[3]);
}

// depth_to_moments_rows and the summed-area table in one sweep down each map (CPU devices, SAT
// prefilter): one work-item per light takes its rows in order, writes a row's moments as
// depth_to_moments_rows does, then turns the row into the table's row in place while it is in
// cache, S(x, y) = sum_{x' <= x} m(x', y) + S(x, y - 1), as kernels/common/scan.cl's banded sweep
// with one band an image. The sums are exact 64-bit integer sums, so the table is the one the two
// kernels give, bit for bit (tests/test_mssm.cpp); the moments never make a round trip through
// memory (they were 113 MiB written, read and written again on the 32-light frame).
// Light l's depth map is map rows[l] of `depth` (auto's subsets read the frame's own maps).
// Global size (lights).
kernel void depth_to_moments_sat(global const uint* depth, global const pb_light* lights,
                                 int size, ulong stride, global long* moments,
                                 global const int* rows) {
  const int l = get_global_id(0);
  global long* img = moments + 4 * (l * stride);
  for (int y = 0; y < size; ++y) {
    global long* out = img + 4 * (size_t)y * size;
    moments_row(depth + ((size_t)rows[l] * size + y) * size, out, size, lights[l].origin[3]);
    long a0 = 0, a1 = 0, a2 = 0, a3 = 0;
    if (y == 0) {
      for (int x = 0; x < size; ++x) {
        a0 += out[4 * x];
        a1 += out[4 * x + 1];
        a2 += out[4 * x + 2];
        a3 += out[4 * x + 3];
        out[4 * x] = a0;
        out[4 * x + 1] = a1;
        out[4 * x + 2] = a2;
        out[4 * x + 3] = a3;
      }
    } else {
      global const long* prev = out - 4 * (size_t)size;
      for (int x = 0; x < size; ++x) {
        a0 += out[4 * x];
        a1 += out[4 * x + 1];
        a2 += out[4 * x + 2];
        a3 += out[4 * x + 3];
        out[4 * x] = a0 + prev[4 * x];
        out[4 * x + 1] = a1 + prev[4 * x + 1];
        out[4 * x + 2] = a2 + prev[4 * x + 2];
        out[4 * x + 3] = a3 + prev[4 * x + 3];
      }
    }
  }
}

// Scalar helpers: written without vector types, so that the batched CPU kernel below
// (mssm4_visibility_batch) vectorizes, and used by the per-pixel kernels too. mix_s and dot3_s
// (filter.clh) round as PoCL's library mix() and dot() do (products rounded before the sums: no
// fused multiply-add), so code written with either gives the same bits there.
#define M4S static inline __attribute__((always_inline))

typedef struct {
  float x, y, z, w;
} m4s;

// mix(x, y, a) as the library computes it: (y - x) * a + x, the product rounded.
M4S float mix_s(float x, float y, float a) {
  float d = y - x;
  float m = d * a;
  return m + x;
}

// The biased moments b1..b4 and the Hankel matrix's LDL^T factors d22, l32, d33 (d11 = 1).
// Moment bias (MSM §4) towards the moments of the uniform distribution on [0,1]. Peters & Klein
// blend towards (0.5, 0.5, 0.5, 0.5), the moments of atoms at 0 and 1; penumbra fits each map's
// depth range to the scene, so blockers at ~0 and receivers at ~1 are the common case, and the
// blend then stays a two-atom distribution with a singular Hankel matrix (d33 = 0: NaN, or a
// wrong bound). A blend with a continuous distribution keeps B positive definite for any input
// (d33 >= bias * 1/180). d33 is the variance of z^2 left after its regression on (1, z): 0 for
// depths at one or two values, growing as the filter region holds more distinct depths.
typedef struct {
  float b1, b2, b3, b4, d22, l32, d33;
} hankel4;

M4S hankel4 hankel4_s(m4s b_raw, float moment_bias) {
  hankel4 h;
  h.b1 = mix_s(b_raw.x, 0.5f, moment_bias);
  h.b2 = mix_s(b_raw.y, 1.0f / 3.0f, moment_bias);
  h.b3 = mix_s(b_raw.z, 0.25f, moment_bias);
  h.b4 = mix_s(b_raw.w, 0.2f, moment_bias);
  h.d22 = h.b2 - h.b1 * h.b1;
  h.l32 = (h.b3 - h.b1 * h.b2) / h.d22;
  h.d33 = h.b4 - h.b2 * h.b2 - h.l32 * h.l32 * h.d22;
  return h;
}

// Hamburger four-moment reconstruction (MSM, Peters & Klein 2015, Algorithm 2), written as the
// three-atom distribution it implies. With biased moments b and receiver depth zf: solve the Hankel
// system B c = (1, zf, zf^2), B = [[1,b1,b2],[b1,b2,b3],[b2,b3,b4]] (LDL^T), take the roots z2 <=
// z3 of c3 z^2 + c2 z + c1, and the weights w of atoms {zf, z2, z3} that reproduce (1, b1, b2):
//   w_i = (b2 - b1 (z_j + z_k) + z_j z_k) / ((z_i - z_j)(z_i - z_k)).
// The shadowed fraction's lower bound is the weight of the atoms in front of zf; `blockers`
// returns that weight, `blocker_sum` the weighted depth sum for Kneiphof 2017 eq. 7 and
// `receiver_weight` the weight of the atom at zf for eq. 19.
// The reconstruction on four scalars, its branches as selects (hamburger4 takes a float4; the
// batched CPU kernel calls this directly, vector types would stop its vectorizer). hamburger4_h
// takes the factored matrix, for callers that also read its d33 (mssm_leak_reduction).
M4S float hamburger4_h(const hankel4 h, float zf, float* blockers, float* blocker_sum,
                       float* receiver_weight) {
  const float b1 = h.b1, b2 = h.b2, d22 = h.d22, l32 = h.l32, d33 = h.d33;
  float y2 = zf - b1;
  float y3 = zf * zf - b2 - l32 * y2;
  float c3 = y3 / d33;
  float c2 = y2 / d22 - l32 * c3;
  float c1 = 1.0f - b1 * c2 - b2 * c3;
  float p = c2 / c3, q = c1 / c3;
  float disc = sqrt(fmax(0.25f * p * p - q, 0.0f));
  float z2 = -0.5f * p - disc, z3 = -0.5f * p + disc;
  float w2 = (b2 - b1 * (zf + z3) + zf * z3) / ((z2 - zf) * (z2 - z3));
  float w3 = (b2 - b1 * (zf + z2) + zf * z2) / ((z3 - zf) * (z3 - z2));
  float shadow = 0.0f, zsum = 0.0f;
  // as hamburger4: shadow += w2, zsum += w2 * z2 when z2 < zf, then the same for z3
  float s2 = shadow + w2, zs2 = zsum + w2 * z2;
  shadow = z2 < zf ? s2 : shadow;
  zsum = z2 < zf ? zs2 : zsum;
  float s3 = shadow + w3, zs3 = zsum + w3 * z3;
  shadow = z3 < zf ? s3 : shadow;
  zsum = z3 < zf ? zs3 : zsum;
  float wf = (b2 - b1 * (z2 + z3) + z2 * z3) / ((zf - z2) * (zf - z3));
  bool bad = !(shadow == shadow) || !(zsum == zsum);
  shadow = bad ? 0.0f : shadow;
  zsum = bad ? 0.0f : zsum;
  *blockers = clamp(shadow, 0.0f, 1.0f);
  *blocker_sum = zsum;
  *receiver_weight = wf == wf ? clamp(wf, 0.0f, 1.0f) : 0.0f;
  return 1.0f - *blockers;
}
M4S float hamburger4_s(m4s b_raw, float zf, float moment_bias, float* blockers,
                       float* blocker_sum, float* receiver_weight) {
  return hamburger4_h(hankel4_s(b_raw, moment_bias), zf, blockers, blocker_sum, receiver_weight);
}

static float hamburger4(float4 b_raw, float zf, float moment_bias, float* blockers,
                        float* blocker_sum, float* receiver_weight) {
  m4s b = {b_raw.x, b_raw.y, b_raw.z, b_raw.w};
  return hamburger4_s(b, zf, moment_bias, blockers, blocker_sum, receiver_weight);
}

// ---- MSSM6 (Kneiphof 2017 §4.2.1) ----
//
// Storage. Six moments in the Chebyshev basis of s = 2z - 1: t_k = T_k(s), k = 1..6 (T_0 = 1,
// T_1 = s, T_{k+1} = 2 s T_k - T_{k-1}). T_k(2z - 1) is an invertible triangular combination of
// 1, z, ..., z^k, so the maps hold exactly the information of the power moments z..z^6, in the
// same 64-bit fixed point as MSSM4 (|t_k| <= 1). The reason is precision: the canonical
// representation does not depend on the basis, but its linear algebra does. The 4x4 Hankel matrix
// of power moments on [0,1] has a smallest LDL^T pivot of bias/2800 for the biased two-atom
// distribution (atoms at 0 and 1, the common case in a fitted map): at bias 3e-5 that is 1e-8,
// below float's resolution of its O(1) entries, and a float solve returns garbage (measured on
// 20000 random distributions against an 80-bit solve: shadow errors up to 1 at bias <= 1e-4, and
// over 0.01 in 1% of the cases still at 3e-4). Double would do (3e-3 at bias 3e-5), but runs at
// 1/2 to 1/64 of float's rate on GPUs. In the Chebyshev basis the Gram matrix
// G_ij = E[T_i T_j] = (t_{i+j} + t_{|i-j|}) / 2 has a smallest pivot of bias * 0.37 there, and a
// float solve stays within 0.009 of the 80-bit one at bias 3e-5 (0.018 at 1e-5).
// tests/test_mssm6.cpp checks float against double on the degenerate two-atom cases and against
// an independent long-double reconstruction on random ones.
//
// Packing: two lights share three long4 images, 48 bytes per texel and light with nothing
// padded (two long4 groups per light, (t1..t4) and (t5, t6, 0, 0), would waste a quarter):
//   image 3p     : t1..t4 of light 2p
//   image 3p + 1 : t1..t4 of light 2p + 1 (zeros when the light count is odd)
//   image 3p + 2 : (t5, t6) of light 2p, (t5, t6) of light 2p + 1
// One work-item per (texel, pair) writes all three, so every element is defined.
kernel void depth_to_moments6(global const uint* depth, global const pb_light* lights, int size,
                              int nlights, ulong stride, global long4* maps) {
  int x = get_global_id(0), y = get_global_id(1), p = get_global_id(2);
  if (x >= size || y >= size) return;
  size_t texel = (size_t)y * size + x;
  float t[2][6];
  for (int h = 0; h < 2; ++h) {
    int l = 2 * p + h;
    for (int k = 0; k < 6; ++k) t[h][k] = 0.0f;
    if (l >= nlights) continue;
    float s = 2.0f * map_depth(depth[(size_t)l * size * size + texel], lights[l].origin[3]) - 1.0f;
    float prev = 1.0f, cur = s;
    t[h][0] = s;
    for (int k = 1; k < 6; ++k) {
      float next = 2.0f * s * cur - prev;
      prev = cur;
      cur = next;
      t[h][k] = cur;
    }
  }
  const float scale = (float)PB_MOMENT_SCALE;
  size_t base = (size_t)3 * p * stride + texel;
  maps[base] = convert_long4_rte((float4)(t[0][0], t[0][1], t[0][2], t[0][3]) * scale);
  maps[base + stride] = convert_long4_rte((float4)(t[1][0], t[1][1], t[1][2], t[1][3]) * scale);
  maps[base + 2 * stride] = convert_long4_rte((float4)(t[0][4], t[0][5], t[1][4], t[1][5]) * scale);
}

// The solve runs in float: in the Chebyshev basis it is as good as double (above) and it is what
// GPUs run at full rate. -DMSSM6_DOUBLE (tests only, where the device has fp64) runs it in double.
#if defined(MSSM6_DOUBLE) && defined(PB_HAS_FP64)
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
typedef double m6real;
#else
typedef float m6real;
#endif

// Roots farther out than this (in s = 2z - 1) are clamped: their atoms' weights are below
// 1e-10, and the clamp keeps T_3(s)^2 finite.
#define M6_ROOT_MAX ((m6real)64)

// Three real roots of the cubic a3 s^3 + a2 s^2 + a1 s + a0 (Blinn 2006-07, "How to solve a cubic
// equation"; Peters 2016, "How to solve a cubic equation, revisited"). Derivation, written here
// from the ground up. Homogeneous form A s^3 + 3B s^2 + 3C s + D with A >= 0 (negating every
// coefficient keeps the roots). With the Hessian terms d1 = AC - B^2, d2 = AD - BC, d3 = BD - C^2,
// s = t - B/A depresses it to t^3 + 3 (d1/A^2) t + (A d2 - 2 B d1)/A^3. Put t = 2 R cos(phi),
// R = sqrt(-d1)/A: since 4 cos^3 - 3 cos = cos(3 phi) the cubic becomes
// 2 R^3 cos(3 phi) = -(A d2 - 2 B d1)/A^3, and because (A d2 - 2 B d1)^2 + 4 d1^3 = -A^2 Delta with
// the discriminant Delta = 4 d1 d3 - d2^2 (>= 0 for three real roots),
//   3 phi = atan2(A sqrt(Delta), 2 B d1 - A d2)   in [0, pi]
// (both arguments scaled by 2 sqrt(-d1)^3 > 0; atan2 needs no division and no acos of a clamped
// ratio). The roots are s_k = (2 sqrt(-d1) cos(phi + 2 pi k/3) - B) / A.
// Robustness: -B/A is large whenever A is small (the kernel polynomial degenerates towards a
// quadratic and one root runs off to infinity); subtracting it from t cancels every digit of the
// moderate roots. So only one root is taken from the formula, the one whose two terms share a sign
// (k = 0, cos >= 1/2, when B <= 0; k = 1, cos <= -1/2, when B > 0): x0 = 2 sqrt(-d1) cos - B has
// no cancellation, r0 = x0/A is at least half the largest root in magnitude, and A = 0 gives
// x0 != 0, r0 = infinity (clamped) instead of 0/0. The other two are the roots of the quadratic
// left after deflating by r0, from Vieta's relations of A (s - r0)(s - r1)(s - r2):
//   r1 r2 = -D/x0,   r1 + r2 = (3C + A D/x0) / x0
// (the second form, not -3B/A - r0, which cancels as r0 grows), solved by the stable quadratic
// formula (the larger root first, the smaller as the product over it).
static void cubic_roots(m6real a0, m6real a1, m6real a2, m6real a3, m6real r[3]) {
  m6real A = a3, B = a2 / 3, C = a1 / 3, D = a0;
  if (A < 0) {
    A = -A; B = -B; C = -C; D = -D;
  }
  m6real d1 = A * C - B * B, d2 = A * D - B * C, d3 = B * D - C * C;
  m6real delta = fmax(4 * d1 * d3 - d2 * d2, (m6real)0);  // < 0 only by rounding here
  m6real sq = sqrt(fmax(-d1, (m6real)0));
  m6real phi = atan2(A * sqrt(delta), 2 * B * d1 - A * d2) / 3;
  if (B > 0) phi += (m6real)2.09439510239319549;  // 2 pi / 3
  m6real x0 = 2 * sq * cos(phi) - B;
  if (x0 == 0) {  // d1 = B = 0: a triple root at 0 (or no cubic at all)
    r[0] = r[1] = r[2] = 0;
    return;
  }
  r[0] = fabs(x0) < A * M6_ROOT_MAX ? x0 / A : copysign(M6_ROOT_MAX, x0);
  m6real prod = -D / x0, sum = (3 * C + A * D / x0) / x0;
  m6real m = (m6real)0.5 * sum + copysign(sqrt(fmax((m6real)0.25 * sum * sum - prod, (m6real)0)), sum);
  r[1] = clamp(m, -M6_ROOT_MAX, M6_ROOT_MAX);
  r[2] = m != 0 ? clamp(prod / m, -M6_ROOT_MAX, M6_ROOT_MAX) : (m6real)0;
}

// T_0..T_3 at s.
static void cheb4(m6real s, m6real T[4]) {
  T[0] = 1;
  T[1] = s;
  T[2] = 2 * s * s - 1;
  T[3] = 2 * s * T[2] - s;
}

// sum_k y_k^2 / D_k for y = L^-1 T(s): the Christoffel function's reciprocal K(s, s), where
// K(x, y) = T(x)^T G^-1 T(y) is the kernel polynomial of the biased moments (G = L D L^T).
// Dinv = 1/D.
static m6real kernel_diag(const m6real L[4][4], const m6real Dinv[4], m6real s, m6real y[4]) {
  m6real T[4];
  cheb4(s, T);
  m6real k = 0;
  for (int i = 0; i < 4; ++i) {
    m6real v = T[i];
    for (int j = 0; j < i; ++j) v -= L[i][j] * y[j];
    y[i] = v;
    k += v * v * Dinv[i];
  }
  return k;
}

// Hamburger six-moment reconstruction (Peters & Klein 2015 §3 for any even number of moments;
// Kneiphof 2017 §4.2.1): the four-atom canonical representation through the receiver depth zf of
// the
// biased moments, and the weight of its atoms in front of zf (the shadowed fraction's lower
// bound). tA = (t1..t4), tB = (t5, t6): box-filtered Chebyshev moments.
//  1. Bias towards the uniform distribution on [0,1] as MSSM4 does (moments 1/2, 1/3, ..., 1/7;
//     in this basis E[T_k(2z-1)] = 0, -1/3, 0, -1/15, 0, -1/35): G stays positive definite.
//  2. Kernel polynomial K(s, sf) = sum_k c_k T_k(s) with G c = T(sf) (L D L^T solve of the 4x4
//     system). Its three roots and sf are the atoms: any two of them x != y satisfy K(x, y) = 0
//     (Christoffel-Darboux: they are the zeros of p_4 - c p_3 for the orthonormal p_k), which is
//     what makes them a canonical representation.
//  3. Weights: the 4x4 Vandermonde system sum_i w_i T_k(x_i) = t_k, k = 0..3, has for such mutually
//     K-orthogonal nodes the closed-form solution w_i = 1 / K(x_i, x_i) (Christoffel numbers). One
//     forward substitution per atom with the L D L^T already at hand; every weight is a sum of
//     squares over positive pivots, so no weight is negative and two nearly coincident atoms
//     cannot produce the huge opposite-signed weights of an inverted Vandermonde matrix.
// `blockers`, `blocker_sum`, `receiver_weight` as in hamburger4 (depths z, not s).
static float hamburger6(float4 tA, float2 tB, float zf, float moment_bias, float* blockers,
                        float* blocker_sum, float* receiver_weight) {
  m6real beta = moment_bias;
  m6real t[7] = {1, tA.x, tA.y, tA.z, tA.w, tB.x, tB.y};
  const m6real uniform[7] = {1, 0, (m6real)(-1.0 / 3.0), 0, (m6real)(-1.0 / 15.0), 0, (m6real)(-1.0 / 35.0)};
  for (int k = 1; k < 7; ++k) t[k] = (1 - beta) * t[k] + beta * uniform[k];
  // Gram matrix of T_0..T_3 (T_i T_j = (T_{i+j} + T_{|i-j|}) / 2) and its L D L^T
  // U = L D (row i, column k < i): the unscaled entries, so no pivot is divided more than once
  m6real L[4][4], U[4][4], Dinv[4];
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < i; ++j) {
      m6real v = (t[i + j] + t[i - j]) / 2;
      for (int k = 0; k < j; ++k) v -= U[i][k] * L[j][k];
      U[i][j] = v;
      L[i][j] = v * Dinv[j];
    }
    m6real v = (t[2 * i] + 1) / 2;
    for (int k = 0; k < i; ++k) v -= U[i][k] * L[i][k];
    // > 0 for any bias > 0; the guard only keeps bias 0 finite
    Dinv[i] = 1 / fmax(v, (m6real)1e-30);
    L[i][i] = 1;
  }
  m6real sf = 2 * (m6real)zf - 1;
  m6real y[4], c[4];
  m6real kf = kernel_diag(L, Dinv, sf, y);
  for (int i = 3; i >= 0; --i) {
    m6real v = y[i] * Dinv[i];
    for (int j = i + 1; j < 4; ++j) v -= L[j][i] * c[j];
    c[i] = v;
  }
  // K(s, sf) in the monomial basis: T_2 = 2s^2 - 1, T_3 = 4s^3 - 3s
  m6real r[3];
  cubic_roots(c[0] - c[2], c[1] - 3 * c[3], 2 * c[2], 4 * c[3], r);
  m6real shadow = 0, zsum = 0;
  for (int i = 0; i < 3; ++i) {
    if (!(r[i] < sf)) continue;
    m6real w = 1 / kernel_diag(L, Dinv, r[i], y);
    shadow += w;
    zsum += w * (r[i] + 1) / 2;
  }
  float sh = (float)shadow, zs = (float)zsum, wf = (float)(1 / kf);
  if (!isfinite(sh) || !isfinite(zs)) {  // NaN from a degenerate system: no shadow
    sh = 0.0f;
    zs = 0.0f;
  }
  *blockers = clamp(sh, 0.0f, 1.0f);
  *blocker_sum = zs;
  *receiver_weight = isfinite(wf) ? clamp(wf, 0.0f, 1.0f) : 0.0f;
  return 1.0f - *blockers;
}

// ---- Per pixel: blocker search, z_avg, penumbra width, filtered visibility ----

// Average blocker depth from the reconstructed atoms in front of the receiver (weight `blockers`,
// weighted depth sum `blocker_sum`) and the weight `receiver_weight` of the atom at zf.
// Kneiphof 2017 eq. 7: z_avg = (eps zf + sum w_i z_i) / (eps + sum w_i), eps pulls towards the
// receiver.
// Kneiphof 2017 eq. 19 (upper bound, §4.2.2): the atom at the receiver's depth counts as a blocker
// too
// (z_i <= d), its weight clamped to [delta1, delta2]: under complex depth distributions the
// reconstruction parks weight at zf, which pulls z_avg towards the receiver: smaller filters,
// harder shadows when in doubt. delta1 = delta2 = eps is eq. 7; delta1 >= eps keeps z_avg at or
// above eq. 7's (the receiver's depth is the largest of the averaged depths).
// Blockers lie between the near plane and the receiver: z_avg is clamped to [0, zf] (an atom of
// the reconstruction can fall outside [0, 1]).
//
// Eq. 19 in proportion to the receiver's tilt (upper_bound_tilt > 0): delta2 is scaled by
// min(1, upper_bound_tilt * slope), slope = tan of the angle between the receiver's geometric
// normal and the light. A receiver tilted against the light is a spread of depths across the
// search box, and the half of it in front of the receiver's own depth reconstructs as "blockers"
// just above it: eq. 7 averages those false blockers into z_avg, sizes a wide filter and darkens
// open, lit ground (measured: 1% on the built-in scene's ground, more on the loaded meshes'
// large grounds); eq. 19's receiver atom pulls z_avg back to the receiver, where a small filter
// sees the plane within the depth bias. A receiver facing the light has no such spread, and there
// eq. 7 is exact on a planar penumbra where eq. 19 narrows it (max error against the analytic
// profile 0.03 with eq. 7, 0.21 with eq. 19: tests/test_mssm.cpp), so it keeps eq. 7 there.
static float mssm_blocker_depth(float zf, float blockers, float blocker_sum, float receiver_weight,
                                const mssm_params* P, float slope) {
  float delta2 = P->upper_bound_tilt > 0.0f
                     ? fmax(P->delta1, P->delta2 * clamp(P->upper_bound_tilt * slope, 0.0f, 1.0f))
                     : P->delta2;
  float w0 = P->upper_bound ? clamp(receiver_weight, P->delta1, delta2) : P->blocker_eps;
  return clamp((w0 * zf + blocker_sum) / (w0 + blockers), 0.0f, fmax(zf, 0.0f));
}

// What the filter boxes of one (pixel, light) need.
typedef struct {
  float u, v;                     // shadow-map texel coordinates (row 0 at +ey)
  float d;                        // receiver's normalized depth
  float range;                    // the map's depth range (world)
  float texel, texel_x, texel_y;  // texel sizes (world): the smaller one, along x, along y
  float tan_a;                    // tan of the light's (scaled) half-angle
  float slope;                    // receiver plane's depth slope along the light
} mssm_pixel;

// Fills q for pixel px and light L; returns 0 where the light needs no test (background, or the
// light wholly below the surface's horizon): visibility 1.
static int mssm_pixel_setup(int px, global const float4* gpos, global const float4* gnrm,
                            global const float4* ggeo, const pb_light* L, int size,
                            const mssm_params* P, mssm_pixel* q) {
  float4 p4 = gpos[px];
  if (p4.w == 0.0f) return 0;
  float3 w = (float3)(L->dir[0], L->dir[1], L->dir[2]);
  // For an upward ground, every light of the lower hemisphere is skipped here.
  if (light_below_horizon(gnrm[px].xyz, L)) return 0;
  float3 ex = (float3)(L->ex[0], L->ex[1], L->ex[2]), ey = (float3)(L->ey[0], L->ey[1], L->ey[2]);
  float3 org = (float3)(L->origin[0], L->origin[1], L->origin[2]);
  float hx = L->ex[3], hy = L->ey[3];
  q->range = L->origin[3];
  float3 r = p4.xyz - org;
  // shadow-map texel coordinates and normalized depth, as in raster.cl's ortho view
  q->u = clamp((dot(r, ex) / hx + 1.0f) * 0.5f * size, 0.0f, (float)size);
  q->v = clamp((1.0f - dot(r, ey) / hy) * 0.5f * size, 0.0f, (float)size);
  q->d = dot(r, -w) / q->range;
  q->texel_x = 2.0f * hx / size;
  q->texel_y = 2.0f * hy / size;
  q->texel = fmin(q->texel_x, q->texel_y);
  float cos_a = L->dir[3];
  q->tan_a = sqrt(fmax(1.0f - cos_a * cos_a, 0.0f)) / fmax(cos_a, 1e-4f) * P->light_size_scale;
  // receiver plane's depth slope along the light: tan of the angle between normal and light
  float3 g = ggeo[px].xyz;
  float cn = fabs(dot(g, w));
  q->slope = fmin(sqrt(fmax(1.0f - cn * cn, 0.0f)) / fmax(cn, 1e-3f), 10.0f);
  return 1;
}

// Filter half-width in texels for blockers spreading the light's disc to world radius `world`
// (Kneiphof 2017 eq. 5 for a light at infinity), clamped to the option's limits.
static float mssm_half_width(const mssm_pixel* q, const mssm_params* P, float world) {
  return clamp(BOX_FROM_DISC * world / q->texel, 0.5f * P->min_filter, 0.5f * P->max_filter);
}

// Receiver depth for a filter of half-width h texels (depth bias plus slope bias).
static float mssm_receiver(const mssm_pixel* q, const mssm_params* P, float h) {
  return q->d - (P->depth_bias + P->slope_bias * h * q->texel * q->slope / q->range);
}

// One group's mean over the box of half-width h texels around the pixel.
M4S float4 mssm_box(global const long4* map, int size, const mssm_pixel* q, float h) {
  return FILTER_BOX(map, size, fmax(q->u - h * q->texel / q->texel_x, 0.0f),
                    fmax(q->v - h * q->texel / q->texel_y, 0.0f),
                    fmin(q->u + h * q->texel / q->texel_x, (float)size),
                    fmin(q->v + h * q->texel / q->texel_y, (float)size));
}

// The filter's half-width from the blocker search's result (blocker weight `wb`, and z_avg from
// mssm_blocker_depth, which MSSM4's cosine centroid reads too): Kneiphof 2017 eq. 5 from z_avg. A
// search that finds (almost) nothing, blocker weight under 1e-3, still tests the smallest filter:
// a blocker a few texels wide next to the receiver (a contact) is under 1e-3 of a wide search box,
// and the moments' lower bound underestimates small weights, so returning "fully lit" there
// leaked light at contacts.
static float mssm_filter_half_width(const mssm_pixel* q, const mssm_params* P, float wb,
                                    float z_avg) {
  if (wb < 1e-3f) return 0.5f * P->min_filter;
  return mssm_half_width(q, P, fmax(q->d - z_avg, 0.0f) * q->range * q->tan_a);
}

// acos(x) for x in [-1, 1] within 2e-8 (Abramowitz & Stegun 4.4.46 on [0, 1]; acos(-x) = pi -
// acos(x)), with no library call: PoCL calls acos as a scalar function, which would stop the
// batched kernel's SIMD loop.
M4S float acos_s(float x) {
  float ax = fmin(fabs(x), 1.0f);
  float p = -0.0012624911f;
  p = p * ax + 0.0066700901f;
  p = p * ax - 0.0170881256f;
  p = p * ax + 0.0308918810f;
  p = p * ax - 0.0501743046f;
  p = p * ax + 0.0889789874f;
  p = p * ax - 0.2145988016f;
  p = p * ax + 1.5707963050f;
  float r = sqrt(1.0f - ax) * p;
  return x < 0.0f ? M_PI_F - r : r;
}

// The cosine-weighted light (MSSMOptions::cosineCentroid). A receiver with unit normal n gets
// L (n.d) from each direction d of the cap (Kneiphof 2017 eq. 13's integrand; the shading's
// clipped-cap irradiance integrates it), so its visibility is the cosine-weighted fraction of
// the cap that arrives, not the plain fraction the map's box measures. To first order that is the
// plain fraction of a disc centred on the weighted cap's centroid. In the gnomonic plane of the
// cap (a disc of radius R = tan(alpha) at unit distance along the axis w; x along the tangent
// direction t = (n - c w) / s, c = n.w, s = |n - c w|), n.d is proportional to c + s x, and 0 below
// the pixel's horizon x0 = -c / (s R) (in disc radii). The centroid's offset along t, in disc
// radii, is E[(c + s x) x] / E[c + s x] over the part x > x0 R of the disc:
//   whole disc (x0 <= -1): s E[x^2] / (c R) = s R / (4 c) = 1 / (4 (-x0));
//   cut at x0 (t0 = asin x0, a = acos x0, c = -x0 s R): (-x0 J1 + J2) / (-x0 J0 + J1), with the
//   segment's integrals over R^2, R^3, R^4: J0 = a - sin t0 cos t0, J1 = 2/3 cos^3 t0,
//   J2 = (a + sin(4 t0) / 4) / 4, sin(4 t0) / 4 = sin t0 cos t0 (1 - 2 sin^2 t0).
// (Both are continuous at x0 = -1, where the offset is 1/4.) Blockers `dist` (world) above the
// receiver along w then cast the shadow of the weighted light `dist` times the offset (R times
// the value above) away along t: the box's centre moves there. (du, dv) is that move in texels of
// a map with axes ex, ey of half-sizes hx, hy and `size` texels (v grows towards -ey).
M4S void mssm_centroid_offset(float nx, float ny, float nz, float wx, float wy, float wz,
                              float exx, float exy, float exz, float eyx, float eyy, float eyz,
                              float hx, float hy, int size, float tan_a, float dist, float* du,
                              float* dv) {
  float c = dot3_s(nx, ny, nz, wx, wy, wz);
  float tx = nx - c * wx, ty = ny - c * wy, tz = nz - c * wz;
  float s = sqrt(fmax(1.0f - c * c, 0.0f));
  float sr = s * tan_a;
  float x0 = -c / fmax(sr, 1e-12f);
  float st = clamp(x0, -1.0f, 1.0f), ct = sqrt(fmax(1.0f - st * st, 0.0f)), a = acos_s(st);
  float J0 = a - st * ct, J1 = (2.0f / 3.0f) * ct * ct * ct;
  float J2 = 0.25f * (a + st * ct * (1.0f - 2.0f * st * st));
  float cut = (-x0 * J1 + J2) / fmax(-x0 * J0 + J1, 1e-12f);
  float whole = 0.25f / fmax(-x0, 1.0f);
  float off = x0 <= -1.0f ? whole : cut;
  // world move along t: dist * off * R, and t = (tx, ty, tz) / s
  float k = s > 1e-6f ? dist * off * tan_a / s : 0.0f;
  *du = k * dot3_s(tx, ty, tz, exx, exy, exz) / hx * 0.5f * size;
  *dv = -k * dot3_s(tx, ty, tz, eyx, eyy, eyz) / hy * 0.5f * size;
}

// Light-leak reduction (MSSMOptions::leakReduction). The reconstruction gives the visibility's
// upper bound v (Kneiphof 2017 §3.2: lit surfaces are never shadowed, shadowed ones can leak) and
// its lower bound v - wr (wr, the weight of the atom at the receiver's depth). Where the filter
// region holds more than two distinct depths the upper bound can leak, and v is moved towards the
// lower bound as Lauritzen (2007, GPU Gems 3 ch. 8) does for variance shadow maps,
// v -> clamp((v - r) / (1 - r), 0, 1), never below it. One blocker depth over one receiver depth
// (d33 = 0 but for the moment bias: the reconstruction is exact there, tests/test_mssm.cpp) keeps
// v: r is scaled by min(1, d33 / MSSM_LEAK_D33). A measured choice, not a bound: it pays on the
// scenes with the cosine centroid (README, "The cosine-weighted light"), but on the raised
// receiver of tests/test_mssm6.cpp (three depths, MSSM4 leaking up to 0.21) it takes back only
// 0.003 of a mean 0.16 excess. The scale, measured against the 8192-spp truths, 320x180, built-in /
// courtyard + Wuson / interior + spider / studio + Wuson, relative RMSE with the centroid on (the
// move then skipped where the search found no blocker; the landed default measures
// 2.96/3.48/2.91/5.15%): 1e-7 (r in full almost everywhere) 2.82/3.30/2.93/5.13%, 1e-6
// 2.84/3.33/2.92/5.14%, 1e-5 2.96/3.48/2.92/5.15%, 1e-4 3.01/3.64/2.92/5.16%; the planar
// half-plane of tests/test_mssm.cpp, max |V - V_analytic|: 0.075 at 1e-7 and 1e-6, 0.031 at 1e-5
// and 1e-4. 1e-5 is the smallest that keeps that profile.
#define MSSM_LEAK_D33 1e-5f
M4S float mssm_leak_reduction(float v, float wr, float r, float d33) {
  const float g = clamp(d33 * (1.0f / MSSM_LEAK_D33), 0.0f, 1.0f);
  const float rg = r * (g == g ? g : 0.0f);
  return fmax(v - wr, clamp((v - rg) / (1.0f - rg), 0.0f, 1.0f));
}

// Visibility of each light at each pixel: vis[light][pixel]. One work-item per (pixel, light).
// 1. blocker search over the region that can hold blockers of this light: distance to the near
//    plane times the light's angular size (Kneiphof 2017 §3.2, Fig. 1, directional light);
// 2. z_avg (eq. 7 or 19) and the penumbra width, Kneiphof 2017 eq. 5 for a light at infinity:
//    blockers at distance (d - z_avg) range above the receiver spread the light's disc to radius
//    (d - z_avg) range tan(alpha);
// 3. filtered visibility, Kneiphof 2017 eq. 6, bounded by the moments.
kernel void mssm4_visibility(global const float4* gpos, global const float4* gnrm,
                             global const float4* ggeo, global const pb_light* lights,
                             global const long4* sats, int size, ulong stride, int npixels,
                             mssm_params P, global float* vis) {
  int px = get_global_id(0), l = get_global_id(1);
  if (px >= npixels) return;
  size_t out = (size_t)l * npixels + px;
  pb_light L = lights[l];
  mssm_pixel q;
  if (!mssm_pixel_setup(px, gpos, gnrm, ggeo, &L, size, &P, &q)) { vis[out] = 1.0f; return; }
  if (P.horizon_skip) {
    const float4 n = gnrm[px];
    if (horizon_rewrites(n.x, n.y, n.z, L.dir[0], L.dir[1], L.dir[2], L.dir[3])) {
      vis[out] = 0.0f;
      return;
    }
  }
  const global long4* sat = sats + l * stride;
  float hs = mssm_half_width(&q, &P, q.d * q.range * q.tan_a);
  float zf = mssm_receiver(&q, &P, hs);
  float wb, zb, wr;
  hamburger4(mssm_box(sat, size, &q, hs), zf, P.moment_bias, &wb, &zb, &wr);
  const float z_avg = mssm_blocker_depth(zf, wb, zb, wr, &P, q.slope);
  float hf = mssm_filter_half_width(&q, &P, wb, z_avg);
  // Every pair, also where the search found no blocker: z_avg then tends to the receiver's depth
  // as the blockers' weight goes to 0, and so does the move (no jump where blockers appear).
  if (P.cosine_centroid) {
    float4 n = gnrm[px];
    float dist = fmax(q.d - z_avg, 0.0f) * q.range;
    float du, dv;
    mssm_centroid_offset(n.x, n.y, n.z, L.dir[0], L.dir[1], L.dir[2], L.ex[0], L.ex[1], L.ex[2],
                         L.ey[0], L.ey[1], L.ey[2], L.ex[3], L.ey[3], size, q.tan_a, dist, &du,
                         &dv);
    q.u = clamp(q.u + du, 0.0f, (float)size);
    q.v = clamp(q.v + dv, 0.0f, (float)size);
  }
  float4 fm = mssm_box(sat, size, &q, hf);
  m4s fms = {fm.x, fm.y, fm.z, fm.w};
  const hankel4 h = hankel4_s(fms, P.moment_bias);
  float visibility = hamburger4_h(h, mssm_receiver(&q, &P, hf), &wb, &zb, &wr);
  visibility = mssm_leak_reduction(visibility, wr, P.leak_reduction, h.d33);
  vis[out] = clamp(visibility, 0.0f, 1.0f);
}

// ---- MSSM4 visibility for CPU devices: a batch of pixels per work-item, SIMD across the batch ----
//
// CPU drivers (PoCL) run a work-group as a loop over its work-items and count on LLVM's loop
// vectorizer to run that loop SIMD-wide. Here it cannot: the float4/long4 values above and the
// calls it does not inline make it give up, and mssm4_visibility runs one work-item at a time
// (PoCL 3.1 on AVX-512: not one zmm instruction in its code), each reconstruction waiting on the
// one before. mssm4_visibility_batch takes VIS_GROUP pixels of one light per work-item, lists the
// pixels that need the light (not background, the light not below their horizon), and runs the
// list VIS_BATCH pixels at a time through five loops:
//   1. set-up and the search box's size (SIMD: VIS_BATCH lanes, scalar values only);
//   2. the search box's mean moments (scalar loop: each lattice value one long4 load);
//   3. the blocker reconstruction and the filter's size (SIMD);
//   4. the filter box's mean moments (scalar loop);
//   5. the visibility reconstruction (SIMD).
// The box loops are kept scalar on purpose. Vectorized, each of a box's 16 lattice values costs
// four 64-bit gathers (one per moment); here it costs one 32-byte load (in one alternated
// measurement on 640x360 frames, the visibility stage took 189 ms with the gathers and 139 ms
// without; bench/results/cpu_speed.md). The boxes are
// mssm_box's, the reconstruction hamburger4_s, and the set-up repeats mssm_pixel_setup operation
// for operation, so both kernels give the same bits on PoCL (tests/test_mssm.cpp).
#ifndef VIS_BATCH
#define VIS_BATCH 16
#endif
// What pixel px needs of the light with direction w and cos_a, sin_a = sqrt(max(1 - cos_a^2, 0)):
// 0 nothing (mssm_pixel_setup's early outs: visibility 1), 1 the filter, 2 nothing either, as the
// horizon step rewrites the pair (with skip: visibility 0, as mssm4_visibility writes it).
M4S int mssm_need_s(global const float* gpos, global const float* gnrm, int px, float wx,
                    float wy, float wz, float cos_a, float sin_a, int skip) {
  const float nx = gnrm[4 * px], ny = gnrm[4 * px + 1], nz = gnrm[4 * px + 2];
  if (gpos[4 * px + 3] == 0.0f || dot3_s(nx, ny, nz, wx, wy, wz) <= -sin_a) return 0;
  return skip && horizon_rewrites(nx, ny, nz, wx, wy, wz, cos_a) ? 2 : 1;
}

// Steps 2 and 4 below: the mean moments of each batch pixel's box (texel coordinates u, v,
// half-width h, the light's texel sizes in `light`) into m0..m3. A pixel whose h equals keep[k]
// keeps the moments m0..m3 already hold for it (keep null: every box is read). Two loops:
// box_mean's set-up (the box's edges, its texel runs, the lattice rows and columns, the nine
// weights and the divisor) for every pixel at once in a SIMD loop, then its 16 lattice loads and
// exact sums in a scalar loop, so that each lattice value is one long4 load. Each step is
// box_mean's own operation on the same operands, so the moments have its bits
// (tests/test_mssm.cpp). With the set-up in the SIMD loop, the scalar loop's body went from about
// 200 instructions a box to about 85 (`perf annotate`), and the 32-light frame's visibility stage
// from 109 to 64 ms (bench/results/cpu_speed.md, stop 46).
typedef struct {
  int row[4][VIS_BATCH];     // element offset of lattice row j (clamped) in the table
  int col[4][VIS_BATCH];     // lattice column a (clamped)
  int first_row[VIS_BATCH];  // 1 where lattice row 0 is inside the table (else it reads as 0)
  int first_col[VIS_BATCH];
  float w[9][VIS_BATCH];     // sub-rectangle (a, b)'s weight, at 3 b + a
  float div[VIS_BATCH];      // area * PB_MOMENT_SCALE
} box_plan;

// box_lattice_sum (filter.clh) for pixel k of a plan, with its masks (all ones: inside the table).
M4S float4 batch_box_sum(global const long4* sat, const box_plan* bp, int k, long4 first_column,
                         long4 first_row) {
  return box_lattice_sum(sat, bp->row[0][k], bp->row[1][k], bp->row[2][k], bp->row[3][k],
                         bp->col[0][k], bp->col[1][k], bp->col[2][k], bp->col[3][k], first_column,
                         first_row, bp->w[0][k], bp->w[1][k], bp->w[2][k], bp->w[3][k],
                         bp->w[4][k], bp->w[5][k], bp->w[6][k], bp->w[7][k], bp->w[8][k]);
}

M4S void batch_box_moments(global const long4* sat, int size, const mssm_pixel* light,
                           const float* u, const float* v, const float* h, const float* keep,
                           box_plan* bp, float* m0, float* m1, float* m2, float* m3) {
PB_SIMD_LOOP(VIS_BATCH)
  for (int k = 0; k < VIS_BATCH; ++k) {
    // mssm_box's edges, then box_mean's runs (filter.clh)
    const float x0 = fmax(u[k] - h[k] * light->texel / light->texel_x, 0.0f),
                y0 = fmax(v[k] - h[k] * light->texel / light->texel_y, 0.0f),
                x1 = fmin(u[k] + h[k] * light->texel / light->texel_x, (float)size),
                y1 = fmin(v[k] + h[k] * light->texel / light->texel_y, (float)size);
    box_run X = box_runs(x0, x1, size), Y = box_runs(y0, y1, size);
    bp->col[0][k] = clamp(X.i0 - 1, 0, size - 1);
    bp->col[1][k] = clamp(X.i1 - 1, 0, size - 1);
    bp->col[2][k] = clamp(X.i2 - 1, 0, size - 1);
    bp->col[3][k] = clamp(X.i3 - 1, 0, size - 1);
    bp->row[0][k] = clamp(Y.i0 - 1, 0, size - 1) * size;
    bp->row[1][k] = clamp(Y.i1 - 1, 0, size - 1) * size;
    bp->row[2][k] = clamp(Y.i2 - 1, 0, size - 1) * size;
    bp->row[3][k] = clamp(Y.i3 - 1, 0, size - 1) * size;
    bp->first_col[k] = X.i0 > 0;
    bp->first_row[k] = Y.i0 > 0;
    bp->w[0][k] = X.w0 * Y.w0;
    bp->w[1][k] = X.w1 * Y.w0;
    bp->w[2][k] = X.w2 * Y.w0;
    bp->w[3][k] = X.w0 * Y.w1;
    bp->w[4][k] = X.w1 * Y.w1;
    bp->w[5][k] = X.w2 * Y.w1;
    bp->w[6][k] = X.w0 * Y.w2;
    bp->w[7][k] = X.w1 * Y.w2;
    bp->w[8][k] = X.w2 * Y.w2;
    bp->div[k] = (x1 - x0) * (y1 - y0) * (float)PB_MOMENT_SCALE;
  }
PB_SCALAR_LOOP
  for (int k = 0; k < VIS_BATCH; ++k) {
    if (keep && h[k] == keep[k]) continue;
    // Most boxes are inside the table's first row and column: that path has no masks.
    const float4 acc = bp->first_col[k] & bp->first_row[k]
                           ? batch_box_sum(sat, bp, k, (long4)(-1), (long4)(-1))
                           : batch_box_sum(sat, bp, k, (long4)(-(long)bp->first_col[k]),
                                           (long4)(-(long)bp->first_row[k]));
    float4 m = acc / bp->div[k];
    m0[k] = m.x;
    m1[k] = m.y;
    m2[k] = m.z;
    m3[k] = m.w;
  }
}

// Global size (ceil(npixels / VIS_GROUP), lights): each work-item takes VIS_GROUP consecutive
// pixels of one light, writes 1 where the light is not needed, lists the others, and runs the
// list VIS_BATCH pixels at a time (only the last batch has idle lanes, which repeat the last
// listed pixel and write nothing). Pixels are the float4 G-buffers read as floats. Light l's
// visibility is row rows[l] of `vis` (auto's subsets write the frame's own buffer).
#ifndef VIS_GROUP
#define VIS_GROUP 64
#endif
kernel void mssm4_visibility_batch(global const float* gpos, global const float* gnrm,
                                   global const float* ggeo, global const pb_light* lights,
                                   global const long4* sats, int size, ulong stride, int npixels,
                                   mssm_params P, global float* vis, global const int* rows) {
  const int l = get_global_id(1), px0 = get_global_id(0) * VIS_GROUP;
  global const pb_light* L = lights + l;
  global float* out = vis + (size_t)rows[l] * npixels;
  int list[VIS_GROUP];
  int n = 0;
  // the light's values, read once (the loop's stores to `out` could alias them)
  const float wx = L->dir[0], wy = L->dir[1], wz = L->dir[2], cos_a = L->dir[3];
  const float sin_a = sqrt(fmax(1.0f - cos_a * cos_a, 0.0f));
  for (int k = 0; k < VIS_GROUP && px0 + k < npixels; ++k) {
    const int need = mssm_need_s(gpos, gnrm, px0 + k, wx, wy, wz, cos_a, sin_a, P.horizon_skip);
    if (need == 1)
      list[n++] = px0 + k;
    else
      out[px0 + k] = need == 0 ? 1.0f : 0.0f;
  }
  global const long4* sat = sats + (size_t)l * stride;
  // mssm_pixel_setup's per-light part
  const float hx = L->ex[3], hy = L->ey[3];
  mssm_pixel light;
  light.range = L->origin[3];
  light.texel_x = 2.0f * hx / size;
  light.texel_y = 2.0f * hy / size;
  light.texel = fmin(light.texel_x, light.texel_y);
  light.tan_a = sin_a / fmax(cos_a, 1e-4f) * P.light_size_scale;
  // per pixel of the batch: its texel coordinates, depth and slope; the box's half-width and the
  // receiver depth for it; the box's mean moments
  float u[VIS_BATCH], v[VIS_BATCH], d[VIS_BATCH], slope[VIS_BATCH], h[VIS_BATCH], zr[VIS_BATCH];
  float search_h[VIS_BATCH];  // the search box's half-width, once h holds the filter's
  float m0[VIS_BATCH], m1[VIS_BATCH], m2[VIS_BATCH], m3[VIS_BATCH];
  box_plan plan;
  for (int b = 0; b < n; b += VIS_BATCH) {
    // 1. mssm_pixel_setup's per-pixel part, and the blocker search's box
PB_SIMD_LOOP(VIS_BATCH)
    for (int k = 0; k < VIS_BATCH; ++k) {
      const int px = list[min(b + k, n - 1)];
      const float wx = L->dir[0], wy = L->dir[1], wz = L->dir[2];
      float rx = gpos[4 * px] - L->origin[0], ry = gpos[4 * px + 1] - L->origin[1],
            rz = gpos[4 * px + 2] - L->origin[2];
      mssm_pixel q = light;
      q.u = clamp((dot3_s(rx, ry, rz, L->ex[0], L->ex[1], L->ex[2]) / hx + 1.0f) * 0.5f * size,
                  0.0f, (float)size);
      q.v = clamp((1.0f - dot3_s(rx, ry, rz, L->ey[0], L->ey[1], L->ey[2]) / hy) * 0.5f * size,
                  0.0f, (float)size);
      q.d = dot3_s(rx, ry, rz, -wx, -wy, -wz) / q.range;
      float cn = fabs(dot3_s(ggeo[4 * px], ggeo[4 * px + 1], ggeo[4 * px + 2], wx, wy, wz));
      q.slope = fmin(sqrt(fmax(1.0f - cn * cn, 0.0f)) / fmax(cn, 1e-3f), 10.0f);
      float hs = mssm_half_width(&q, &P, q.d * q.range * q.tan_a);
      u[k] = q.u;
      v[k] = q.v;
      d[k] = q.d;
      slope[k] = q.slope;
      h[k] = hs;
      zr[k] = mssm_receiver(&q, &P, hs);
    }
    // 2. the search box's moments
    batch_box_moments(sat, size, &light, u, v, h, 0, &plan, m0, m1, m2, m3);
    // 3. blockers, and the filter's box
PB_SIMD_LOOP(VIS_BATCH)
    for (int k = 0; k < VIS_BATCH; ++k) {
      mssm_pixel q = light;
      q.u = u[k];
      q.v = v[k];
      q.d = d[k];
      q.slope = slope[k];
      m4s m;
      m.x = m0[k];
      m.y = m1[k];
      m.z = m2[k];
      m.w = m3[k];
      float wb, zb, wr;
      hamburger4_s(m, zr[k], P.moment_bias, &wb, &zb, &wr);
      const float z_avg = mssm_blocker_depth(zr[k], wb, zb, wr, &P, q.slope);
      float hf = mssm_filter_half_width(&q, &P, wb, z_avg);
      search_h[k] = h[k];
      if (P.cosine_centroid) {  // every pair, as mssm4_visibility
        const int px = list[min(b + k, n - 1)];
        float dist = fmax(q.d - z_avg, 0.0f) * light.range;
        float du, dv;
        mssm_centroid_offset(gnrm[4 * px], gnrm[4 * px + 1], gnrm[4 * px + 2], L->dir[0],
                             L->dir[1], L->dir[2], L->ex[0], L->ex[1], L->ex[2], L->ey[0],
                             L->ey[1], L->ey[2], hx, hy, size, light.tan_a, dist, &du, &dv);
        u[k] = clamp(u[k] + du, 0.0f, (float)size);
        v[k] = clamp(v[k] + dv, 0.0f, (float)size);
        search_h[k] = du != 0.0f || dv != 0.0f ? -1.0f : search_h[k];  // a moved box: step 4 reads it
      }
      h[k] = hf;
      zr[k] = mssm_receiver(&q, &P, hf);
    }
    // 4. the filter box's moments. Where the filter has the search box's width (mostly both
    //    clamped to the widest filter: blockers far above the receiver; or both at the narrowest),
    //    it is the same box, and its moments are already in m0..m3: the same bits, and on 640x360
    //    frames the visibility stage went from about 139 to 121 ms (one alternated measurement;
    //    bench/results/cpu_speed.md has the idle-machine figures for the whole change).
    batch_box_moments(sat, size, &light, u, v, h, search_h, &plan, m0, m1, m2, m3);
    // 5. filtered visibility
PB_SIMD_LOOP(VIS_BATCH)
    for (int k = 0; k < VIS_BATCH; ++k) {
      m4s m;
      m.x = m0[k];
      m.y = m1[k];
      m.z = m2[k];
      m.w = m3[k];
      float wb, zb, wr;
      const hankel4 hk = hankel4_s(m, P.moment_bias);
      float visibility = hamburger4_h(hk, zr[k], &wb, &zb, &wr);
      visibility = mssm_leak_reduction(visibility, wr, P.leak_reduction, hk.d33);
      if (b + k < n) out[list[min(b + k, n - 1)]] = clamp(visibility, 0.0f, 1.0f);
    }
  }
}

// MSSM6's visibility, the same three steps with the six-moment reconstruction. Light l's images
// are 3 (l/2) + (l%2) (t1..t4) and 3 (l/2) + 2 (t5, t6 in .xy or .zw), depth_to_moments6's packing.
kernel void mssm6_visibility(global const float4* gpos, global const float4* gnrm,
                             global const float4* ggeo, global const pb_light* lights,
                             global const long4* maps, int size, ulong stride, int npixels,
                             mssm_params P, global float* vis) {
  int px = get_global_id(0), l = get_global_id(1);
  if (px >= npixels) return;
  size_t out = (size_t)l * npixels + px;
  pb_light L = lights[l];
  mssm_pixel q;
  if (!mssm_pixel_setup(px, gpos, gnrm, ggeo, &L, size, &P, &q)) { vis[out] = 1.0f; return; }
  const global long4* mapA = maps + (size_t)(3 * (l / 2) + (l & 1)) * stride;
  const global long4* mapB = maps + (size_t)(3 * (l / 2) + 2) * stride;
  int odd = l & 1;
  float hs = mssm_half_width(&q, &P, q.d * q.range * q.tan_a);
  float zf = mssm_receiver(&q, &P, hs);
  float4 b = mssm_box(mapB, size, &q, hs);
  float wb, zb, wr;
  hamburger6(mssm_box(mapA, size, &q, hs), odd ? b.zw : b.xy, zf, P.moment_bias, &wb, &zb, &wr);
  float hf = mssm_filter_half_width(&q, &P, wb, mssm_blocker_depth(zf, wb, zb, wr, &P, q.slope));
  b = mssm_box(mapB, size, &q, hf);
  float visibility = hamburger6(mssm_box(mapA, size, &q, hf), odd ? b.zw : b.xy,
                                mssm_receiver(&q, &P, hf), P.moment_bias, &wb, &zb, &wr);
  vis[out] = clamp(visibility, 0.0f, 1.0f);
}

// The reconstructions on given filtered moments, for tests: case i reads m[10 i ..]: (b1..b4)
// power moments for MSSM4, then (t1..t6) Chebyshev moments for MSSM6, and zf[i]; writes out[8 i
// ..]: MSSM4's shadowed fraction, z_avg by eq. 7, z_avg by eq. 19, receiver weight; then MSSM6's
// four.
kernel void mssm_reconstruct(global const float* m, global const float* zf, int n, mssm_params P,
                             global float* out) {
  int i = get_global_id(0);
  if (i >= n) return;
  global const float* c = m + 10 * i;
  float z = zf[i], wb, zb, wr;
  mssm_params lower = P, upper = P;
  lower.upper_bound = 0;
  upper.upper_bound = 1;
  upper.upper_bound_tilt = 0.0f;  // eq. 19 as published, whatever the tilt
  global float* o = out + 8 * i;
  hamburger4((float4)(c[0], c[1], c[2], c[3]), z, P.moment_bias, &wb, &zb, &wr);
  o[0] = wb;
  o[1] = mssm_blocker_depth(z, wb, zb, wr, &lower, 0.0f);
  o[2] = mssm_blocker_depth(z, wb, zb, wr, &upper, 0.0f);
  o[3] = wr;
  hamburger6((float4)(c[4], c[5], c[6], c[7]), (float2)(c[8], c[9]), z, P.moment_bias, &wb, &zb, &wr);
  o[4] = wb;
  o[5] = mssm_blocker_depth(z, wb, zb, wr, &lower, 0.0f);
  o[6] = mssm_blocker_depth(z, wb, zb, wr, &upper, 0.0f);
  o[7] = wr;
}

// Test support (tests/test_cosine_centroid.cpp): mssm_centroid_offset for n cases, each 14 floats in `in`
// (normal, light axis, ex, ey, tan(alpha), blocker distance), the map's half-sizes hx, hy and
// `size`; (du, dv) to `out`.
kernel void mssm_centroid_probe(global const float* in, int n, float hx, float hy, int size,
                                global float* out) {
  int i = get_global_id(0);
  if (i >= n) return;
  global const float* c = in + 14 * i;
  float du, dv;
  mssm_centroid_offset(c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7], c[8], c[9], c[10], c[11],
                       hx, hy, size, c[12], c[13], &du, &dv);
  out[2 * i] = du;
  out[2 * i + 1] = dv;
}

// Test support (tests/test_cosine_centroid.cpp): for n cases of (b1..b4, zf, r) in `in` (6 floats
// each), the reconstruction's upper bound v, the receiver atom's weight wr and
// mssm_leak_reduction's result, 3 floats each to `out`.
kernel void mssm_leak_probe(global const float* in, int n, float moment_bias, global float* out) {
  int i = get_global_id(0);
  if (i >= n) return;
  global const float* c = in + 6 * i;
  m4s m = {c[0], c[1], c[2], c[3]};
  float wb, zb, wr;
  const hankel4 h = hankel4_s(m, moment_bias);
  float v = hamburger4_h(h, c[4], &wb, &zb, &wr);
  out[3 * i] = v;
  out[3 * i + 1] = wr;
  out[3 * i + 2] = mssm_leak_reduction(v, wr, c[5], h.d33);
}
