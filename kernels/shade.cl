// Final shading: diffuse reflection of every directional cap light (irradiance of seed 003
// eqs. 15-18, with the horizon-clipped closed form of shared.h) times its visibility, times
// albedo / pi. Background pixels show the environment (nearest texel) with alpha 0.
#include "shared.h"

kernel void shade(global const float4* gpos, global const float4* gnrm, global const float4* galb,
                  global const pb_light* lights, int nlights, global const float* vis,
                  int npixels, global const pb_view* camera, global const float* equirect,
                  int env_w, int env_h, int background, global float4* out) {
  int px = get_global_id(0);
  if (px >= npixels) return;
  if (gpos[px].w == 0.0f) {
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
      int si = clamp((int)floor(s), 0, env_w - 1), ti = clamp((int)floor(t), 0, env_h - 1);
      global const float* e = equirect + 3 * ((size_t)ti * env_w + si);
      rgb = (float3)(e[0], e[1], e[2]);
    }
    out[px] = (float4)(rgb, 0.0f);
    return;
  }
  float3 n = gnrm[px].xyz;
  float3 acc = (float3)(0.0f);
  for (int l = 0; l < nlights; ++l) {
    pb_light L = lights[l];
    float cb = n.x * L.dir[0] + n.y * L.dir[1] + n.z * L.dir[2];
    float e = pb_cap_irradiance(L.dir[3], cb);
    if (e <= 0.0f) continue;
    float V = vis[(size_t)l * npixels + px];
    acc += e * V * (float3)(L.radiance[0], L.radiance[1], L.radiance[2]);
  }
  out[px] = (float4)(acc * galb[px].xyz * M_1_PI_F, 1.0f);
}
