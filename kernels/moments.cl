// Moment soft shadow mapping with four moments (MSSM4, seed 003 §3.2.1; Peters et al. 2016 for
// MSSM, Peters & Klein 2015 for the Hamburger four-moment reconstruction).
//
// Per light: depth map -> fixed-point moments (z, z^2, z^3, z^4) -> SAT (kernels/scan.cl, exact
// 64-bit sums) -> per pixel: blocker search box, average blocker depth (seed 003 eq. 7),
// penumbra width (seed 003 eq. 5 for a directional light), filtered visibility (eq. 6) bounded
// from the box-filtered moments.
#include "shared.h"
#include "filter.clh"

// Depth map (ray distances from the light's near plane, uint bit patterns) -> moments in fixed
// point. Empty texels see nothing: depth 1 (the far plane), which never shadows.
// Map l's texels start at element l * stride of `moments` (room for the prefilter's levels).
kernel void depth_to_moments(global const uint* depth, global const pb_light* lights, int size,
                             ulong stride, global long4* moments) {
  int x = get_global_id(0), y = get_global_id(1), l = get_global_id(2);
  if (x >= size || y >= size) return;
  size_t i = ((size_t)l * size + y) * size + x;
  uint bits = depth[i];
  float range = lights[l].origin[3];
  float z = bits == PB_DEPTH_EMPTY ? 1.0f : clamp(as_float(bits) / range, 0.0f, 1.0f);
  float z2 = z * z;
  // z is a float, so float products carry all its precision; 2^32 is exact in float.
  moments[l * stride + (size_t)y * size + x] = convert_long4_rte((float4)(z, z2, z2 * z, z2 * z2) * (float)PB_MOMENT_SCALE);
}

// Hamburger four-moment reconstruction (MSM, Peters & Klein 2015, Algorithm 2), written as the three-atom
// distribution it implies. With biased moments b and receiver depth zf: solve the Hankel system
// B c = (1, zf, zf^2), B = [[1,b1,b2],[b1,b2,b3],[b2,b3,b4]] (LDL^T), take the roots z2 <= z3 of
// c3 z^2 + c2 z + c1, and the weights w of atoms {zf, z2, z3} that reproduce (1, b1, b2):
//   w_i = (b2 - b1 (z_j + z_k) + z_j z_k) / ((z_i - z_j)(z_i - z_k)).
// The shadowed fraction's lower bound is the weight of the atoms in front of zf; `blockers`
// returns that weight and `blocker_sum` the weighted depth sum for seed 003 eq. 7.
static float hamburger4(float4 b_raw, float zf, float moment_bias, float* blockers,
                        float* blocker_sum) {
  // Moment bias (MSM §4) towards the moments of the uniform distribution on [0,1]. Peters & Klein
  // blend towards (0.5, 0.5, 0.5, 0.5), the moments of atoms at 0 and 1; penumbra fits each map's
  // depth range to the scene, so blockers at ~0 and receivers at ~1 are the common case, and the
  // blend then stays a two-atom distribution with a singular Hankel matrix (d33 = 0: NaN, or a
  // wrong bound). A blend with a continuous distribution keeps B positive definite for any input
  // (d33 >= bias * 1/180), checked in float against double in tests/test_mssm.cpp.
  float4 b = mix(b_raw, (float4)(0.5f, 1.0f / 3.0f, 0.25f, 0.2f), moment_bias);
  float b1 = b.x, b2 = b.y, b3 = b.z, b4 = b.w;
  float d22 = b2 - b1 * b1;
  float l32 = (b3 - b1 * b2) / d22;
  float d33 = b4 - b2 * b2 - l32 * l32 * d22;
  float y2 = zf - b1;
  float y3 = zf * zf - b2 - l32 * y2;
  float c3 = y3 / d33;
  float c2 = y2 / d22 - l32 * c3;
  float c1 = 1.0f - b1 * c2 - b2 * c3;
  float p = c2 / c3, q = c1 / c3;
  float disc = sqrt(fmax(0.25f * p * p - q, 0.0f));
  float z2 = -0.5f * p - disc, z3 = -0.5f * p + disc;
  float shadow = 0.0f, zsum = 0.0f;
  if (z2 < zf) {
    float w2 = (b2 - b1 * (zf + z3) + zf * z3) / ((z2 - zf) * (z2 - z3));
    shadow += w2;
    zsum += w2 * z2;
  }
  if (z3 < zf) {
    float w3 = (b2 - b1 * (zf + z2) + zf * z2) / ((z3 - zf) * (z3 - z2));
    shadow += w3;
    zsum += w3 * z3;
  }
  if (!(shadow == shadow) || !(zsum == zsum)) {  // NaN from a degenerate system: no shadow
    shadow = 0.0f;
    zsum = 0.0f;
  }
  *blockers = clamp(shadow, 0.0f, 1.0f);
  *blocker_sum = zsum;
  return 1.0f - *blockers;
}

typedef struct {
  float moment_bias, depth_bias, slope_bias, light_size_scale;
  float max_filter, min_filter, blocker_eps, pad;
} mssm_params;

// Width of the equal-area square of a disc of radius r is sqrt(pi) r: the box filter that stands
// in for the disc-shaped light has half-width (sqrt(pi)/2) r.
#define BOX_FROM_DISC 0.88622692545f

// Visibility of each light at each pixel: vis[light][pixel]. One work-item per (pixel, light).
kernel void mssm4_visibility(global const float4* gpos, global const float4* gnrm,
                             global const float4* ggeo, global const pb_light* lights,
                             global const long4* sats, int size, ulong stride, int npixels,
                             mssm_params P, global float* vis) {
  int px = get_global_id(0), l = get_global_id(1);
  if (px >= npixels) return;
  float4 p4 = gpos[px];
  size_t out = (size_t)l * npixels + px;
  if (p4.w == 0.0f) { vis[out] = 1.0f; return; }
  pb_light L = lights[l];
  float3 w = (float3)(L.dir[0], L.dir[1], L.dir[2]);
  // For an upward ground, every light of the lower hemisphere is skipped here.
  if (light_below_horizon(gnrm[px].xyz, &L)) { vis[out] = 1.0f; return; }
  float3 ex = (float3)(L.ex[0], L.ex[1], L.ex[2]), ey = (float3)(L.ey[0], L.ey[1], L.ey[2]);
  float3 org = (float3)(L.origin[0], L.origin[1], L.origin[2]);
  float hx = L.ex[3], hy = L.ey[3], range = L.origin[3];
  float3 r = p4.xyz - org;
  // shadow-map texel coordinates (row 0 at +ey) and normalized depth, as in raster.cl's ortho view
  float u = (dot(r, ex) / hx + 1.0f) * 0.5f * size;
  float v = (1.0f - dot(r, ey) / hy) * 0.5f * size;
  float d = dot(r, -w) / range;
  float texel_x = 2.0f * hx / size, texel_y = 2.0f * hy / size;
  float texel = fmin(texel_x, texel_y);
  float cos_a = L.dir[3];
  float tan_a = sqrt(fmax(1.0f - cos_a * cos_a, 0.0f)) / fmax(cos_a, 1e-4f) * P.light_size_scale;
  // receiver plane's depth slope along the light: tan of the angle between normal and light
  float3 g = ggeo[px].xyz;
  float cn = fabs(dot(g, w));
  float slope = fmin(sqrt(fmax(1.0f - cn * cn, 0.0f)) / fmax(cn, 1e-3f), 10.0f);
  const global long4* sat = sats + l * stride;
  u = clamp(u, 0.0f, (float)size);
  v = clamp(v, 0.0f, (float)size);

  // 1. blocker search over the region that can hold blockers of this light: distance to the
  //    near plane times the light's angular size (seed 003 §3.2, Fig. 1, directional light).
  float search = BOX_FROM_DISC * d * range * tan_a;  // world half-width
  float hs = clamp(search / texel, 0.5f * P.min_filter, 0.5f * P.max_filter);
  float bias_s = P.depth_bias + P.slope_bias * hs * texel * slope / range;
  float zf = d - bias_s;
  float4 m = FILTER_BOX(sat, size, fmax(u - hs * texel / texel_x, 0.0f),
                      fmax(v - hs * texel / texel_y, 0.0f),
                      fmin(u + hs * texel / texel_x, (float)size),
                      fmin(v + hs * texel / texel_y, (float)size));
  float wb, zb;
  hamburger4(m, zf, P.moment_bias, &wb, &zb);
  if (wb < 1e-3f) { vis[out] = 1.0f; return; }  // nothing in front anywhere: fully lit
  // seed 003 eq. 7
  float z_avg = (P.blocker_eps * zf + zb) / (P.blocker_eps + wb);
  // 2. penumbra width, seed 003 eq. 5 for a light at infinity: blockers at distance
  //    (d - z_avg) range above the receiver spread the light's disc to radius (d - z_avg) range
  //    tan(alpha).
  float pen = BOX_FROM_DISC * fmax(d - z_avg, 0.0f) * range * tan_a;
  float hf = clamp(pen / texel, 0.5f * P.min_filter, 0.5f * P.max_filter);
  float bias_f = P.depth_bias + P.slope_bias * hf * texel * slope / range;
  float4 mf = FILTER_BOX(sat, size, fmax(u - hf * texel / texel_x, 0.0f),
                       fmax(v - hf * texel / texel_y, 0.0f),
                       fmin(u + hf * texel / texel_x, (float)size),
                       fmin(v + hf * texel / texel_y, (float)size));
  float wf, zs;
  // 3. filtered visibility, seed 003 eq. 6, bounded by the moments
  float visibility = hamburger4(mf, d - bias_f, P.moment_bias, &wf, &zs);
  vis[out] = clamp(visibility, 0.0f, 1.0f);
}
