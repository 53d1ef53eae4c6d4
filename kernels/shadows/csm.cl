// Convolution soft shadow maps (CSSM, Annen et al. 2008 §3; Annen et al. 2007 for the CSM basis).
//
// Per light: depth map -> Fourier basis images in 64-bit fixed point (CSM: cos/sin(c_k z~),
// CSM-Z: z cos/sin(c_k z~) and z, Annen et al. 2008 appendix eq. 11) -> prefilter (SAT or mip,
// exact
// integer sums) -> per pixel: initial filter from the light/near-plane cone (§3.2, Fig. 2a),
// average blocker depth (eq. 8 with eq. 11), final filter width from z_avg, filtered
// complementary shadow test (eq. 3 with eq. 10), ringing suppression by scale, shift and clamp
// (§3.3), adaptive sharpening (eq. 9).
//
// Build options: -DCSSM_ORDER=M (terms k = 1..M, c_k = pi (2k - 1)), plus the prefilter's option.
//
// Channel layout of one texel, 4M + 1 values in CSSM_GROUPS = M + 1 long4 groups (3 lanes spare):
//   j = 2(k-1), 2(k-1)+1            cos(c_k z~), sin(c_k z~)      (CSM, j < 2M)
//   j = 2M + 2(k-1), 2M + 2(k-1)+1  z cos(c_k z~), z sin(c_k z~)  (CSM-Z)
//   j = 4M                          z                             (the appendix's plain z image)
// z is the normalized depth in [0,1] (empty texels: 1), z~ = kappa z the depth the series sees
// (kappa < 1 keeps every depth difference on the series' plateau, see src/shadows/cssm.cpp).
// The CSM groups come first so that the final lookup reads only ceil(M/2) of the M + 1 groups.
#include "shared.h"
#include "filter.clh"
#include "shadow_params.h"

#ifndef CSSM_ORDER
#define CSSM_ORDER 4
#endif
#define CSSM_CHANNELS (4 * CSSM_ORDER + 1)
#define CSSM_GROUPS (CSSM_ORDER + 1)
#define CSSM_CSM_GROUPS ((2 * CSSM_ORDER + 3) / 4)

#define CSSM_PI 3.14159265358979323846f

// Below this filtered blocker mass (scaled and shifted complementary test, eq. 8's denominator)
// the search box holds no blocker: the pixel is lit and z_avg is not defined.
#define CSSM_MIN_BLOCKER 1e-3f

// sin(c_k x), cos(c_k x) for k = 1..M by the angle-addition recurrence
// c_{k+1} x = c_k x + 2 pi x, the step's sine and cosine by the double angle. One sincos instead
// of 2M; the rotation's rounding grows by ~1 ulp per step (< 1e-5 at M = 32).
static void fourier_terms(float x, float* s, float* c) {
  float c1, s1 = sincos(CSSM_PI * x, &c1);
  float ss = 2.0f * s1 * c1, cs = c1 * c1 - s1 * s1;
  s[0] = s1;
  c[0] = c1;
  for (int k = 1; k < CSSM_ORDER; ++k) {
    s[k] = s[k - 1] * cs + c[k - 1] * ss;
    c[k] = c[k - 1] * cs - s[k - 1] * ss;
  }
}

// Depth map (ray distances from the light's near plane, uint bit patterns) of lights
// first_light + l -> basis images, fixed point round(v * 2^32) (|v| <= 1: exact sums below 2^56
// for maps up to 4096^2). Image g of batch light l starts at element
// (l * CSSM_GROUPS + g) * stride.
kernel void cssm_basis(global const uint* depth, global const pb_light* lights, int size,
                       ulong stride, int first_light, float kappa, global long4* basis) {
  int x = get_global_id(0), y = get_global_id(1), l = get_global_id(2);
  if (x >= size || y >= size) return;
  int light = first_light + l;
  uint bits = depth[((size_t)light * size + y) * size + x];
  float range = lights[light].origin[3];
  // Empty texels hold the far plane: nothing behind the receiver, never a blocker.
  float z = bits == PB_DEPTH_EMPTY ? 1.0f : clamp(as_float(bits) / range, 0.0f, 1.0f);
  float s[CSSM_ORDER], c[CSSM_ORDER];
  fourier_terms(kappa * z, s, c);
  float v[4 * CSSM_GROUPS];
  for (int k = 0; k < CSSM_ORDER; ++k) {
    v[2 * k] = c[k];
    v[2 * k + 1] = s[k];
    v[2 * CSSM_ORDER + 2 * k] = z * c[k];
    v[2 * CSSM_ORDER + 2 * k + 1] = z * s[k];
  }
  v[4 * CSSM_ORDER] = z;
  for (int j = CSSM_CHANNELS; j < 4 * CSSM_GROUPS; ++j) v[j] = 0.0f;
  global long4* out = basis + (size_t)l * CSSM_GROUPS * stride + (size_t)y * size + x;
  // Rounded half away from zero by hand: PoCL emulates convert_long4_rte (and rint) element by
  // element, half this kernel's time on a CPU; truncation after +-0.5 is a plain conversion.
  for (int g = 0; g < CSSM_GROUPS; ++g) {
    float4 f = (float4)(v[4 * g], v[4 * g + 1], v[4 * g + 2], v[4 * g + 3]) *
               (float)PB_MOMENT_SCALE;
    out[g * stride] = convert_long4(f + copysign((float4)(0.5f), f));
  }
}

// Box-filtered basis images over [x0,x1] x [y0,y1]: m[j] = w * (channel j), the first `groups`
// groups (all of them for z_avg, the CSM ones for the visibility).
static void filtered_basis(global const long4* maps, int size, ulong stride, float x0, float y0,
                           float x1, float y1, int groups, float* m) {
  for (int g = 0; g < groups; ++g) {
    float4 m4 = FILTER_BOX(maps + g * stride, size, x0, y0, x1, y1);
    m[4 * g] = m4.x;
    m[4 * g + 1] = m4.y;
    m[4 * g + 2] = m4.z;
    m[4 * g + 3] = m4.w;
  }
}

// The filtered complementary shadow test from the filtered basis m, scaled and shifted but not
// yet clamped: a * (w * f_bar) + b, f_bar by eq. 10 expanded as in eq. 3 (d~ = the argument dt):
//   w * f_bar = 1/2 + 2 sum_k (1/c_k) [sin(c_k d~) (w * cos(c_k z~))
//                                      - cos(c_k d~) (w * sin(c_k z~))]
// With zsum, also the numerator of eq. 8 by eq. 11 under the SAME expansion and the same affine
// scale/shift (an affine map of the per-texel test commutes with the filter):
//   a * (w * (f_bar z)) + b (w * z),
//   w * (f_bar z) = (w * z)/2
//                   + 2 sum_k (1/c_k) [sin(c_k d~) (w * z cos) - cos(c_k d~) (w * z sin)].
static float series_test(const float* m, float dt, float a, float b, float damping, float* zsum) {
  float s[CSSM_ORDER], c[CSSM_ORDER];
  fourier_terms(dt, s, c);
  float f = 0.5f, fz = 0.0f;
  for (int k = 0; k < CSSM_ORDER; ++k) {
    // sigma_k = exp(-alpha (k/M)^2) (Annen et al. 2007's attenuation; 1 when damping = 0)
    float kk = (float)(k + 1) / (float)CSSM_ORDER;
    float w = exp(-damping * kk * kk) * 2.0f / (CSSM_PI * (float)(2 * k + 1));
    float cc = w * s[k], cs = -w * c[k];  // multiply w * cos(c_k z~) and w * sin(c_k z~)
    f += cc * m[2 * k] + cs * m[2 * k + 1];
    if (zsum) fz += cc * m[2 * CSSM_ORDER + 2 * k] + cs * m[2 * CSSM_ORDER + 2 * k + 1];
  }
  if (zsum) {
    float zbar = m[4 * CSSM_ORDER];
    *zsum = a * (0.5f * zbar + fz) + b * zbar;
  }
  return a * f + b;
}

// Visibility of lights first_light .. first_light + batch - 1 at each pixel: vis[light][pixel].
// One work-item per (pixel, light); texel coordinates, depth and filter sizes as mssm4_visibility.
kernel void cssm_visibility(global const float4* gpos, global const float4* gnrm,
                            global const float4* ggeo, global const pb_light* lights,
                            global const long4* maps, int size, ulong stride, int npixels,
                            int first_light, cssm_params P, global float* vis) {
  int px = get_global_id(0), lb = get_global_id(1), l = first_light + lb;
  if (px >= npixels) return;
  float4 p4 = gpos[px];
  size_t out = (size_t)l * npixels + px;
  if (p4.w == 0.0f) { vis[out] = 1.0f; return; }
  pb_light L = lights[l];
  float3 w = (float3)(L.dir[0], L.dir[1], L.dir[2]);
  if (light_below_horizon(gnrm[px].xyz, &L)) { vis[out] = 1.0f; return; }
  float3 ex = (float3)(L.ex[0], L.ex[1], L.ex[2]), ey = (float3)(L.ey[0], L.ey[1], L.ey[2]);
  float3 org = (float3)(L.origin[0], L.origin[1], L.origin[2]);
  float hx = L.ex[3], hy = L.ey[3], range = L.origin[3];
  float3 r = p4.xyz - org;
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
  const global long4* maps_l = maps + (size_t)lb * CSSM_GROUPS * stride;
  u = clamp(u, 0.0f, (float)size);
  v = clamp(v, 0.0f, (float)size);
  float m[4 * CSSM_GROUPS];

  // 1. Initial filter (Annen et al. 2008 §3.2, Fig. 2a): the cone from the receiver to the light,
  // cut by
  //    the near plane (where the map's depths start). For a light at infinity its radius on the
  //    map is d range tan(alpha): the region that can hold blockers, as MSSM4's blocker search.
  float search = BOX_FROM_DISC * d * range * tan_a;
  float hs = clamp(search / texel, 0.5f * P.min_filter, 0.5f * P.max_filter);
  // The receiver plane's own texels span +-slope hs texel in depth over the search box: the
  // blocker search's test starts beyond them (the visibility's test needs no such bias).
  float bias_s = P.depth_bias + P.slope_bias * hs * texel * slope / range;
  filtered_basis(maps_l, size, stride, fmax(u - hs * texel / texel_x, 0.0f),
                 fmax(v - hs * texel / texel_y, 0.0f), fmin(u + hs * texel / texel_x, (float)size),
                 fmin(v + hs * texel / texel_y, (float)size), CSSM_GROUPS, m);
  // Any blocker at all, by the visibility's own test? If not, the pixel is lit.
  float zsum_any;
  float any = series_test(m, P.kappa * (d - P.depth_bias) - P.tau0, P.scale, P.shift, P.damping,
                          &zsum_any);
  if (!(any >= CSSM_MIN_BLOCKER)) { vis[out] = 1.0f; return; }  // (NaN too)
  // 2. Average blocker depth, eq. 8: numerator and denominator from the same expansion, here
  //    the one shifted by the whole rise. (Not the visibility's test: centred on the receiver,
  //    it weighs a tilted receiver's own texels w(t) with w odd in t = d - z. They cancel in the
  //    denominator but each adds w(t) t > 0 to d - z_avg, which would push z_avg away from the
  //    receiver and blur every shadow on it.)
  float zsum;
  float mass = series_test(m, P.kappa * (d - bias_s) - P.tau0_z, P.scale_z, P.shift_z, P.damping,
                           &zsum);
  // No blocker beyond the contact zone (t < 2 t0/kappa): the blockers found above touch the
  // receiver. Their depth from the visibility's test (same fetch), kept inside the zone.
  float z_avg = mass >= CSSM_MIN_BLOCKER
                    ? clamp(zsum / mass, 0.0f, d)
                    : clamp(zsum_any / any, fmax(d - 2.0f * P.rise, 0.0f), d);
  // 3. Final filter (Fig. 2c): the map moved to z_avg; for a light at infinity the penumbra's
  //    radius is (d - z_avg) range tan(alpha) (as MSSM4, Kneiphof 2017 eq. 5).
  float pen = BOX_FROM_DISC * (d - z_avg) * range * tan_a;
  float hf = clamp(pen / texel, 0.5f * P.min_filter, 0.5f * P.max_filter);
  filtered_basis(maps_l, size, stride, fmax(u - hf * texel / texel_x, 0.0f),
                 fmax(v - hf * texel / texel_y, 0.0f), fmin(u + hf * texel / texel_x, (float)size),
                 fmin(v + hf * texel / texel_y, (float)size), CSSM_CSM_GROUPS, m);
  float shadow =
      series_test(m, P.kappa * (d - P.depth_bias) - P.tau0, P.scale, P.shift, P.damping, 0);
  // 4. Clamp after scale and shift (§3.3): the series' ringing lies outside [0,1] and vanishes.
  float visibility = 1.0f - clamp(shadow, 0.0f, 1.0f);
  // 5. Adaptive sharpening, eq. 9: G(v) = v^p, p = 1 + A exp(-B (d - z_avg)). Darkens only where
  //    the blockers are close (contact), where the truncated series leaks light.
  if (P.sharpen_a > 0.0f) {
    float p = 1.0f + P.sharpen_a * exp(-P.sharpen_b * (d - z_avg));
    visibility = pow(visibility, p);
  }
  vis[out] = (visibility == visibility) ? clamp(visibility, 0.0f, 1.0f) : 1.0f;
}
