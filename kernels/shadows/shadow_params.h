/* The parameter blocks the shadow techniques' kernels take by value (and area.cl's per-light
 * ranges), defined once for both sides. Written in the common subset of C++ and OpenCL C 1.2, as
 * common/shared.h: the kernels get it spliced in at build time (cmake/embed_kernels.cmake), the
 * host includes it as "shadows/shadow_params.h" and fills the blocks field by field
 * (src/shadows/). Only 4-byte scalars, so both compilers lay them out alike; the host checks every
 * size and offset below. Depths are normalized (0 at the map's near plane, 1 at its far plane);
 * filter widths are in shadow-map texels. */
#ifndef PENUMBRA_SHADOW_PARAMS_H
#define PENUMBRA_SHADOW_PARAMS_H

/* MSSM4 and MSSM6 (kernels/shadows/moments.cl): ShadowOptions and MSSMOptions. */
typedef struct {
  float moment_bias, depth_bias, slope_bias, light_size_scale;
  float max_filter, min_filter, blocker_eps;
  int upper_bound;  /* Kneiphof 2017 eq. 19 instead of eq. 7 */
  float delta1, delta2;
  float upper_bound_tilt; /* > 0: eq. 19's delta2 scaled by min(1, this * receiver slope); 0: not */
  float leak_reduction;   /* MSSM4: visibility v -> clamp((v - this) / (1 - this)), in [0, 1) */
  int cosine_centroid;    /* MSSM4: 1: the filter box centred on the cosine-weighted light */
  int horizon_skip;       /* MSSM4: 1: pairs the horizon step rewrites are written 0, not filtered */
  int pad2, pad3;
} mssm_params;

/* CSSM (kernels/shadows/csm.cl): the ringing suppression derived from the order (src/shadows/cssm.cpp),
 * ShadowOptions' light size and filter limits, and CSSMOptions. */
typedef struct {
  /* Ringing suppression (§3.3) of the visibility test: shadow = clamp(scale * f_bar + shift), the
   * series' argument tau = kappa (d - bias - z) - tau0 (tau0 = the shift along depth). */
  float scale, shift, tau0, kappa;
  /* The same for the blocker search (z_avg, eq. 8): the symmetric map of Fig. 3c, shifted by the
   * series' whole rise, so that the receiver's own texels and everything behind it weigh ~0. */
  float scale_z, shift_z, tau0_z;
  float rise; /* t0 / kappa: the series' rise in normalized depth */
  float depth_bias, slope_bias, light_size_scale, max_filter;
  float min_filter, sharpen_a, sharpen_b, damping;
} cssm_params;

/* PCSS (kernels/shadows/pcss.cl): ShadowOptions and PCSSOptions. */
typedef struct {
  float depth_bias, light_size_scale, max_filter, min_filter;
  int blocker_taps;   /* 0: every texel of the search box; n > 0: round(sqrt(n))^2 grid points */
  int filter_taps;    /* 0: every texel of the filter box; n > 0: round(sqrt(n))^2 bilinear taps */
  int receiver_plane; /* 1: compare against the receiver's plane, 0: against its depth alone */
  int pad;
} pcss_params;

/* Area approximation (kernels/shadows/area.cl): one light's boundary samples. */
typedef struct {
  int first; /* index of the light's first boundary sample (samples, q, and the maps from `base`) */
  int count; /* boundary samples, 3..AREA_MAX_SAMPLES */
} area_range;

#ifndef __OPENCL_VERSION__
#include <stddef.h>
/* Field `field` of a block of 4-byte scalars sits at byte 4 i, as the kernels read it; a row is
 * four consecutive fields from index i. */
#define PB_PARAM_AT(type, field, i) \
  static_assert(offsetof(type, field) == 4 * (i), #type "." #field " is not at byte 4 * (" #i ")")
#define PB_PARAM_ROW(type, i, a, b, c, d) \
  PB_PARAM_AT(type, a, i); PB_PARAM_AT(type, b, i + 1); PB_PARAM_AT(type, c, i + 2); \
  PB_PARAM_AT(type, d, i + 3)
static_assert(sizeof(mssm_params) == 64, "mssm_params: 16 four-byte fields");
PB_PARAM_ROW(mssm_params, 0, moment_bias, depth_bias, slope_bias, light_size_scale);
PB_PARAM_ROW(mssm_params, 4, max_filter, min_filter, blocker_eps, upper_bound);
PB_PARAM_ROW(mssm_params, 8, delta1, delta2, upper_bound_tilt, leak_reduction);
PB_PARAM_ROW(mssm_params, 12, cosine_centroid, horizon_skip, pad2, pad3);
static_assert(sizeof(cssm_params) == 64, "cssm_params: 16 four-byte fields");
PB_PARAM_ROW(cssm_params, 0, scale, shift, tau0, kappa);
PB_PARAM_ROW(cssm_params, 4, scale_z, shift_z, tau0_z, rise);
PB_PARAM_ROW(cssm_params, 8, depth_bias, slope_bias, light_size_scale, max_filter);
PB_PARAM_ROW(cssm_params, 12, min_filter, sharpen_a, sharpen_b, damping);
static_assert(sizeof(pcss_params) == 32, "pcss_params: 8 four-byte fields");
PB_PARAM_ROW(pcss_params, 0, depth_bias, light_size_scale, max_filter, min_filter);
PB_PARAM_ROW(pcss_params, 4, blocker_taps, filter_taps, receiver_plane, pad);
static_assert(sizeof(area_range) == 8, "area_range: 2 four-byte fields");
PB_PARAM_AT(area_range, first, 0);
PB_PARAM_AT(area_range, count, 1);
#undef PB_PARAM_ROW
#undef PB_PARAM_AT
#endif

#endif
