// Final shading: diffuse reflection of every directional light (a cap: irradiance of Kneiphof 2017
// eqs. 15-18, with the horizon-clipped closed form of shared.h; a polygon: Lambert's formula on
// the horizon-clipped polygon, shared.h's pb_polygon_irradiance) times its visibility, times
// albedo / pi. Background pixels show the environment (nearest texel) with alpha 0.
// The ambient residual is added unshadowed, as Arbree et al. 2005 §3 applies it: from its
// pre-integrated
// irradiance map (amap, amap_w x amap_h RGB, LightSet::ambientMap) when amap_w > 0, else from its
// 9 RGB SH coefficients of radiance (zeros when the light set has none) as R&H 2001's sum of
// Ahat_l L_lm Y_lm(n) (shared.h).
// bent != 0: each light's irradiance is bent at the light's silhouette (Sintorn et al. 2008 §4.3)
// by I_bend,
// interpolated from kernels/render/bent.cl's per-vertex values (bend) with its per-pixel vertices
// and weights (RenderOptions::bentNormals), with the blend's scale bend_c.
#include "shared.h"
#include "bent.clh"
#include "lights.clh"

// A background pixel: the environment seen through it (nearest texel) when `background`, else
// black; alpha 0.
static void shade_background(int px, global const pb_view* camera, global const float* equirect,
                             int env_w, int env_h, float env_shift, int background,
                             global float4* out) {
  float3 rgb = (float3)(0.0f);
  if (background) {
    pb_view v = camera[0];
    int x = px % v.width, y = px / v.width;
    float sx = 2.0f * (x + 0.5f) / v.width - 1.0f, sy = 1.0f - 2.0f * (y + 0.5f) / v.height;
    float3 d = (float3)(v.forward[0], v.forward[1], v.forward[2]) +
               sx * v.right[3] * (float3)(v.right[0], v.right[1], v.right[2]) +
               sy * v.up[3] * (float3)(v.up[0], v.up[1], v.up[2]);
    float s, t;
    pb_dir_equirect(d.x, d.y, d.z, (float)env_w, (float)env_h, &s, &t);
    // env_shift: the map's rotation about +y in columns (Environment::rotationColumns).
    int si = pb_env_column(s, env_shift, env_w), ti = clamp((int)floor(t), 0, env_h - 1);
    global const float* e = equirect + 3 * ((size_t)ti * env_w + si);
    rgb = (float3)(e[0], e[1], e[2]);
  }
  out[px] = (float4)(rgb, 0.0f);
}

// Light l's unshadowed irradiance at pixel px with shading normal n (0 or less: the light adds
// nothing there).
static float shade_light_irradiance(int px, float3 n, global const pb_light* lights, int nlights,
                                    int l, global const float4* polys,
                                    global const int4* bend_vert,
                                    global const float4* bend_weight, global const int* bend,
                                    int bent, float bend_c) {
  pb_light L = lights[l];
  // polys: the light's PB_MAX_POLY_VERTS float4 (src/lights/light_buffers.hpp; a cap's are zero)
  global const float4* pv = polys + (size_t)l * PB_MAX_POLY_VERTS;
  const float4 dc = (float4)(L.dir[0], L.dir[1], L.dir[2], L.dir[3]);
  float e = pb_light_irradiance(dc, pv, n);
  // e0: the irradiance at normal incidence, facing the light's direction
  const float e0 = bent ? pb_light_irradiance(dc, pv, dc.xyz) : 0.0f;
  if (bent) {
    // Bent normals, Sintorn et al. 2008 §4.3: a = min(1, max(c I_bend, 0)), I' = a I + (1 - a)
    // I_bend,
    // c = bend_c (RenderOptions::bentNormalsScale, the paper's 3), with I_bend
    // (kernels/render/bent.cl, interpolated) the smallest n_F . l around the triangle's vertices.
    // In irradiance units the paper's I_bend (a cosine) is e0 I_bend, e0 the light's irradiance
    // at normal incidence: on flat geometry (n = n_F, light above the horizon) that is e itself,
    // so the blend changes nothing there. We take min(e, e0 max(I_bend, 0)) as the second term:
    // the result is then never brighter than the unbent shading (visibility is only computed
    // where e > 0), it is still continuous (e, I_bend and min are), it is e wherever I_bend >=
    // 1/c, and 0 wherever I_bend <= 0, so on every light-back-facing triangle, whose own n_F . l
    // < 0 bounds all three of its vertices' I_bend.
    float ib = pb_bent_value(bend_vert[px], bend_weight[px], bend, nlights, l);
    float a = clamp(bend_c * ib, 0.0f, 1.0f);
    e = a * e + (1.0f - a) * fmin(e, e0 * fmax(ib, 0.0f));
  }
  return e;
}

// The lights' sum `acc` plus the ambient residual, clamped at 0, times albedo / pi: out[px].
static void shade_finish(int px, float3 n, float3 acc, global const float4* galb,
                         global const float4* ambient, global const float* amap, int amap_w,
                         int amap_h, global float4* out) {
  if (amap_w > 0) {
    // The pre-integrated irradiance map (Arbree et al. 2005 §3), bilinear as
    // LightSet::ambientIrradiance.
    int idx[4];
    float wt[4];
    pb_ambient_map_taps(n.x, n.y, n.z, amap_w, amap_h, idx, wt);
    for (int k = 0; k < 4; ++k) acc += wt[k] * vload3(idx[k], amap);
  } else {
    float Y[9];
    pb_sh9(n.x, n.y, n.z, Y);
    for (int k = 0; k < 9; ++k) acc += PB_SH_AHAT(k) * Y[k] * ambient[k].xyz;
  }
  // A residual can be negative in places (a cap brighter than the texels it replaced); where the
  // lights are shadowed that could leave a negative sum, which no irradiance is.
  acc = fmax(acc, (float3)(0.0f));
  out[px] = (float4)(acc * galb[px].xyz * M_1_PI_F, 1.0f);
}

kernel void shade(global const float4* gpos, global const float4* gnrm, global const float4* galb,
                  global const pb_light* lights, int nlights, global const float* vis,
                  int npixels, global const pb_view* camera, global const float* equirect,
                  int env_w, int env_h, float env_shift, int background,
                  global float4* out, global const float4* ambient,
                  global const float4* polys, global const float* amap, int amap_w,
                  int amap_h, global const int4* bend_vert, global const float4* bend_weight,
                  global const int* bend, int bent, float bend_c) {
  int px = get_global_id(0);
  if (px >= npixels) return;
  if (gpos[px].w == 0.0f) {
    shade_background(px, camera, equirect, env_w, env_h, env_shift, background, out);
    return;
  }
  float3 n = gnrm[px].xyz;
  float3 acc = (float3)(0.0f);
  for (int l = 0; l < nlights; ++l) {
    float e = shade_light_irradiance(px, n, lights, nlights, l, polys, bend_vert, bend_weight,
                                     bend, bent, bend_c);
    if (e <= 0.0f) continue;
    float V = vis[(size_t)l * npixels + px];
    acc += e * V * (float3)(lights[l].radiance[0], lights[l].radiance[1], lights[l].radiance[2]);
  }
  shade_finish(px, n, acc, galb, ambient, amap, amap_w, amap_h, out);
}

// shade for CPU devices (as mssm4_visibility_batch, kernels/shadows/moments.cl: PoCL runs
// `shade` one work-item at a time): SHADE_GROUP consecutive pixels per work-item, the background
// ones shaded at once, the others listed; then light by light over the list, cap lights in loops
// the compiler runs SIMD-wide. A cap's irradiance is Kneiphof 2017 eq. 15's closed form where the
// whole cap is above the horizon (pb_cap_irradiance's first case, the same expression) and 0
// where it is wholly below; the pixels where it straddles the horizon take pb_cap_irradiance
// itself in a second, scalar loop (its acos and atan would stop the vectorizer), once per run of
// equal cosines. Polygon lights
// and bent normals take shade_light_irradiance per pixel. Every sum is formed as `shade` forms
// it, in the same order, so the two give the same bits on PoCL (tests/test_render_stages.cpp).
// Global size ceil(npixels / SHADE_GROUP).
#ifndef SHADE_GROUP
#define SHADE_GROUP 64
#endif
#ifndef SHADE_LANES
#define SHADE_LANES 16
#endif
kernel void shade_batch(global const float4* gpos, global const float4* gnrm,
                        global const float4* galb, global const pb_light* lights, int nlights,
                        global const float* vis, int npixels, global const pb_view* camera,
                        global const float* equirect, int env_w, int env_h, float env_shift,
                        int background, global float4* out, global const float4* ambient,
                        global const float4* polys, global const float* amap, int amap_w,
                        int amap_h, global const int4* bend_vert,
                        global const float4* bend_weight, global const int* bend, int bent,
                        float bend_c) {
  const int px0 = get_global_id(0) * SHADE_GROUP;
  int list[SHADE_GROUP];
  int m = 0;
  for (int k = 0; k < SHADE_GROUP && px0 + k < npixels; ++k) {
    if (gpos[px0 + k].w == 0.0f)
      shade_background(px0 + k, camera, equirect, env_w, env_h, env_shift, background, out);
    else
      list[m++] = px0 + k;
  }
  if (m == 0) return;
  const bool dense = m == min(SHADE_GROUP, npixels - px0);  // no background: list[j] = px0 + j
  float nx[SHADE_GROUP], ny[SHADE_GROUP], nz[SHADE_GROUP];
  float ar[SHADE_GROUP], ag[SHADE_GROUP], ab[SHADE_GROUP], es[SHADE_GROUP];
  global const float* nf = (global const float*)gnrm;
  for (int j = 0; j < m; ++j) {
    nx[j] = nf[4 * list[j]];
    ny[j] = nf[4 * list[j] + 1];
    nz[j] = nf[4 * list[j] + 2];
    ar[j] = ag[j] = ab[j] = 0.0f;
  }
  for (int l = 0; l < nlights; ++l) {
    global const pb_light* L = lights + l;
    const float r0 = L->radiance[0], r1 = L->radiance[1], r2 = L->radiance[2];
    global const float* row = vis + (size_t)l * npixels;
    const int nv = min((int)polys[(size_t)l * PB_MAX_POLY_VERTS].w, PB_MAX_POLY_VERTS);
    if (bent || nv >= 3) {
      for (int j = 0; j < m; ++j)
        es[j] = shade_light_irradiance(list[j], (float3)(nx[j], ny[j], nz[j]), lights, nlights,
                                       l, polys, bend_vert, bend_weight, bend, bent, bend_c);
    } else {
      const float dx = L->dir[0], dy = L->dir[1], dz = L->dir[2], cos_alpha = L->dir[3];
      // pb_cap_irradiance's first lines, for this light
      const float sin2a = 1.0f - cos_alpha * cos_alpha;
      const float sin_a = sqrt(sin2a > 0.0f ? sin2a : 0.0f);
      // The cap above the horizon: eq. 15's closed form; below: 0; straddling: -1, filled in
      // below (no count or other reduction in this loop: oclgrind cannot run the vector
      // reduction the compiler would make of it).
PB_SIMD_LOOP(SHADE_LANES)
      for (int j = 0; j < m; ++j) {
        // pb_light_irradiance's cosine, the same expression
        float cos_beta = nx[j] * dx + ny[j] * dy + nz[j] * dz;
        bool above = cos_beta >= sin_a, below = cos_beta <= -sin_a;
        es[j] = above ? 3.14159265358979323846f * sin2a * cos_beta : below ? 0.0f : -1.0f;
      }
      // Flat surfaces give runs of equal cosines: the last result is reused for an equal input
      // (the function is deterministic, so the bits are the same).
      float last_cos = NAN, last_e = 0.0f;
      for (int j = 0; j < m; ++j) {
        if (!(es[j] < 0.0f)) continue;
        float cos_beta = nx[j] * dx + ny[j] * dy + nz[j] * dz;
        if (cos_beta != last_cos) {
          last_cos = cos_beta;
          last_e = pb_cap_irradiance(cos_alpha, cos_beta);
        }
        es[j] = last_e;
      }
    }
    // shade: `if (e <= 0) continue;` then acc += e V radiance. Where the group has no background
    // pixel (most groups), list[j] = px0 + j and the visibility row is read as vectors, not
    // gathered (a third of this kernel's time was the gather's wait).
#define PB_SHADE_ADD(V_AT)                                             \
  PB_SIMD_LOOP(SHADE_LANES)                                            \
  for (int j = 0; j < m; ++j) {                                        \
    float e = es[j];                                                   \
    float V = row[V_AT];                                               \
    bool add = !(e <= 0.0f);                                           \
    float w = e * V;                                                   \
    float a0 = ar[j] + w * r0, a1 = ag[j] + w * r1, a2 = ab[j] + w * r2; \
    ar[j] = add ? a0 : ar[j];                                          \
    ag[j] = add ? a1 : ag[j];                                          \
    ab[j] = add ? a2 : ab[j];                                          \
  }
    if (dense) {
      PB_SHADE_ADD(px0 + j)
    } else {
      PB_SHADE_ADD(list[j])
    }
#undef PB_SHADE_ADD
  }
  for (int j = 0; j < m; ++j)
    shade_finish(list[j], (float3)(nx[j], ny[j], nz[j]), (float3)(ar[j], ag[j], ab[j]), galb,
                 ambient, amap, amap_w, amap_h, out);
}
