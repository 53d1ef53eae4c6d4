// Spherical-harmonic projection (order <= 2, RGB) of an equirectangular radiance map, for the
// ambient residual (src/environment/ambient.cpp; Ramamoorthi & Hanrahan 2001).
//
// The map is taken as what it is everywhere else in penumbra (cube resampling, Environment::power
// and irradiance): constant radiance over each lat-long texel. Every basis function is a
// polynomial of degree <= 2 in x = sin(theta) sin(phi), y = cos(theta), z = -sin(theta) cos(phi)
// (shared.h's pb_equirect_dir), so its integral over a texel [theta0,theta1] x [phi0,phi1] with
// d_omega = sin(theta) d_theta d_phi separates into a row factor times a column factor. The host
// tabulates the six row integrals (of sin, sin^2, cos sin, sin^3, cos^2 sin, sin^2 cos) and the six
// column integrals (of 1, sin, cos, sin^2, cos^2, sin cos) in double; the projection is then exact
// for any map size (a 1x1 map is a constant environment: only the l = 0 term survives) with no
// texel-centre sampling error. Float per work-item and work-group sums stay within ~1e-6 relative
// for the sizes used; the host adds the per-group partial sums in double.
#include "shared.h"

#define SH_COEFFS 27  // 9 coefficients x RGB

// Integrals of the 9 basis functions over one texel (row factors T, column factors P).
static void texel_sh9(float8 T, float8 P, float* b) {
  // T: s0 = int sin, s1 = int sin^2, s2 = int cos sin, s3 = int sin^3, s4 = int cos^2 sin,
  //    s5 = int sin^2 cos (over theta, the sin of d_omega included)
  // P: s0 = int 1, s1 = int sin, s2 = int cos, s3 = int sin^2, s4 = int cos^2, s5 = int sin cos
  float area = T.s0 * P.s0;
  b[0] = PB_SH_K00 * area;
  b[1] = PB_SH_K1 * T.s2 * P.s0;                        // y
  b[2] = -PB_SH_K1 * T.s1 * P.s2;                       // z
  b[3] = PB_SH_K1 * T.s1 * P.s1;                        // x
  b[4] = PB_SH_K2 * T.s5 * P.s1;                        // x y
  b[5] = -PB_SH_K2 * T.s5 * P.s2;                       // y z
  b[6] = PB_SH_K20 * (3.0f * T.s3 * P.s4 - area);       // 3 z^2 - 1
  b[7] = -PB_SH_K2 * T.s3 * P.s5;                       // x z
  b[8] = PB_SH_K22 * (T.s3 * P.s3 - T.s4 * P.s0);       // x^2 - y^2
}

// One partial sum of the 27 coefficients per work-group: work-items stride over the texels
// (coalesced reads), accumulate privately, then reduce in local memory one coefficient at a time
// (local memory of one float per work-item, whatever the device's limit). Local size: a power of
// two. partial[group * 27 + 3 * k + c] is coefficient k, channel c.
kernel void sh_project(global const float* equirect, int W, int H, global const float8* rows,
                       global const float8* cols, local float* scratch, global float* partial) {
  const int lid = get_local_id(0), wg = get_local_size(0);
  const long n = (long)W * H;
  float acc[SH_COEFFS];
  for (int k = 0; k < SH_COEFFS; ++k) acc[k] = 0.0f;
  for (long i = get_global_id(0); i < n; i += get_global_size(0)) {
    const int r = (int)(i / W), c = (int)(i - (long)r * W);
    float b[9];
    texel_sh9(rows[r], cols[c], b);
    const float3 L = vload3(i, equirect);
    for (int k = 0; k < 9; ++k) {
      acc[3 * k + 0] += b[k] * L.x;
      acc[3 * k + 1] += b[k] * L.y;
      acc[3 * k + 2] += b[k] * L.z;
    }
  }
  for (int k = 0; k < SH_COEFFS; ++k) {
    scratch[lid] = acc[k];
    barrier(CLK_LOCAL_MEM_FENCE);
    for (int s = wg / 2; s > 0; s >>= 1) {
      if (lid < s) scratch[lid] += scratch[lid + s];
      barrier(CLK_LOCAL_MEM_FENCE);
    }
    if (lid == 0) partial[(size_t)get_group_id(0) * SH_COEFFS + k] = scratch[0];
    barrier(CLK_LOCAL_MEM_FENCE);
  }
}
