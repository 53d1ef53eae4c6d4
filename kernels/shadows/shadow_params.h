/* The parameter blocks the shadow techniques' kernels take by value (and area.cl's per-light
 * ranges), defined once for both sides. Written in the common subset of C++ and OpenCL C 1.2, as
 * common/shared.h: the kernels get it spliced in at build time (cmake/embed_kernels.cmake), the
 * host includes it as "shadows/shadow_params.h" and fills the blocks field by field
 * (src/shadows/). Only 4-byte scalars, so both compilers lay them out alike; the host checks every
 * size and offset below. Depths are normalized (0 at the map's near plane, 1 at its far plane);
 * filter widths are in shadow-map texels. */
#ifndef PENUMBRA_SHADOW_PARAMS_H
#define PENUMBRA_SHADOW_PARAMS_H

/* MSSM4 and MSSM6 (kernels/moments.cl): ShadowOptions and MSSMOptions. */
typedef struct {
  float moment_bias, depth_bias, slope_bias, light_size_scale;
  float max_filter, min_filter, blocker_eps;
  int upper_bound;  /* seed 003 eq. 19 instead of eq. 7 */
  float delta1, delta2, pad0, pad1;
} mssm_params;

/* CSSM (kernels/csm.cl): the ringing suppression derived from the order (src/shadows/cssm.cpp),
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

/* PCSS (kernels/pcss.cl): ShadowOptions and PCSSOptions. */
typedef struct {
  float depth_bias, light_size_scale, max_filter, min_filter;
  int blocker_taps;   /* 0: every texel of the search box; n > 0: round(sqrt(n))^2 grid points */
  int filter_taps;    /* 0: every texel of the filter box; n > 0: round(sqrt(n))^2 bilinear taps */
  int receiver_plane; /* 1: compare against the receiver's plane, 0: against its depth alone */
  int pad;
} pcss_params;

/* Area approximation (kernels/area.cl): one light's boundary samples. */
typedef struct {
  int first; /* index of the light's first boundary sample (samples, q, and the maps from `base`) */
  int count; /* boundary samples, 3..AREA_MAX_SAMPLES */
} area_range;

#ifndef __OPENCL_VERSION__
#include <stddef.h>
/* Field i of a block of 4-byte scalars sits at byte 4 i: what the kernels' layout is. */
#define PB_PARAM_AT(type, field, i) \
  static_assert(offsetof(type, field) == 4 * (i), #type "." #field " is not at byte 4 * " #i)
static_assert(sizeof(mssm_params) == 48, "mssm_params: 12 four-byte fields");
PB_PARAM_AT(mssm_params, moment_bias, 0);
PB_PARAM_AT(mssm_params, depth_bias, 1);
PB_PARAM_AT(mssm_params, slope_bias, 2);
PB_PARAM_AT(mssm_params, light_size_scale, 3);
PB_PARAM_AT(mssm_params, max_filter, 4);
PB_PARAM_AT(mssm_params, min_filter, 5);
PB_PARAM_AT(mssm_params, blocker_eps, 6);
PB_PARAM_AT(mssm_params, upper_bound, 7);
PB_PARAM_AT(mssm_params, delta1, 8);
PB_PARAM_AT(mssm_params, delta2, 9);
PB_PARAM_AT(mssm_params, pad0, 10);
PB_PARAM_AT(mssm_params, pad1, 11);
static_assert(sizeof(cssm_params) == 64, "cssm_params: 16 four-byte fields");
PB_PARAM_AT(cssm_params, scale, 0);
PB_PARAM_AT(cssm_params, shift, 1);
PB_PARAM_AT(cssm_params, tau0, 2);
PB_PARAM_AT(cssm_params, kappa, 3);
PB_PARAM_AT(cssm_params, scale_z, 4);
PB_PARAM_AT(cssm_params, shift_z, 5);
PB_PARAM_AT(cssm_params, tau0_z, 6);
PB_PARAM_AT(cssm_params, rise, 7);
PB_PARAM_AT(cssm_params, depth_bias, 8);
PB_PARAM_AT(cssm_params, slope_bias, 9);
PB_PARAM_AT(cssm_params, light_size_scale, 10);
PB_PARAM_AT(cssm_params, max_filter, 11);
PB_PARAM_AT(cssm_params, min_filter, 12);
PB_PARAM_AT(cssm_params, sharpen_a, 13);
PB_PARAM_AT(cssm_params, sharpen_b, 14);
PB_PARAM_AT(cssm_params, damping, 15);
static_assert(sizeof(pcss_params) == 32, "pcss_params: 8 four-byte fields");
PB_PARAM_AT(pcss_params, depth_bias, 0);
PB_PARAM_AT(pcss_params, light_size_scale, 1);
PB_PARAM_AT(pcss_params, max_filter, 2);
PB_PARAM_AT(pcss_params, min_filter, 3);
PB_PARAM_AT(pcss_params, blocker_taps, 4);
PB_PARAM_AT(pcss_params, filter_taps, 5);
PB_PARAM_AT(pcss_params, receiver_plane, 6);
PB_PARAM_AT(pcss_params, pad, 7);
static_assert(sizeof(area_range) == 8, "area_range: 2 four-byte fields");
PB_PARAM_AT(area_range, first, 0);
PB_PARAM_AT(area_range, count, 1);
#undef PB_PARAM_AT
#endif

#endif
