// GL interop (src/gl/interop.cpp): textures read back from OpenGL into penumbra's encodings.
//
// GL stores rows bottom-up (window y grows upwards); penumbra's maps and G-buffer rows go top-down
// (raster.cl: row y at sy = 1 - 2 (y + 0.5) / height). Both kernels flip rows.
#include "shared.h"

// GL window depth of light l's orthographic shadow map -> penumbra's depth encoding. The light's
// GL projection (gl::Interop::lightViews) maps light-space distance d from the map's near plane
// linearly to window depth z = d / range, range = pb_light.origin[3], so d = z * range; z >= 1
// (the cleared far plane, beyond all geometry: lightFrame puts the far plane a margin past the
// scene) and non-finite values become PB_DEPTH_EMPTY. gl: count maps of size x size floats.
kernel void gl_depth_to_distance(global const float* gl, global const pb_light* lights, int size,
                                 int count, global uint* depth) {
  int x = get_global_id(0), y = get_global_id(1), l = get_global_id(2);
  if (x >= size || y >= size || l >= count) return;
  float z = gl[((size_t)l * size + (size - 1 - y)) * size + x];
  uint out = PB_DEPTH_EMPTY;
  if (z >= 0.0f && z < 1.0f) out = as_uint(z * lights[l].origin[3]);
  depth[((size_t)l * size + y) * size + x] = out;
}

// A float4 G-buffer texture read back from GL -> penumbra's layout. kind 0 (positions): w becomes
// exactly 1 where the application marked geometry (w > 0.5) and the texel is all zeros elsewhere,
// as gbuffer_resolve writes it; kind 1 (directions): w = 0, the vector unchanged.
kernel void gl_flip_gbuffer(global const float4* gl, int width, int height, int kind,
                            global float4* out) {
  int x = get_global_id(0), y = get_global_id(1);
  if (x >= width || y >= height) return;
  float4 v = gl[(size_t)(height - 1 - y) * width + x];
  if (kind == 0)
    v = v.w > 0.5f ? (float4)(v.xyz, 1.0f) : (float4)(0.0f);
  else
    v.w = 0.0f;
  out[(size_t)y * width + x] = v;
}

// Where shadow tests start (src/scene/shadow_offset.hpp): each geometry pixel's position moved by
// `offset` along its geometric normal (facing the camera), as the OpenCL renderer's G-buffer and
// the Embree reference move it. Run after gl_flip_gbuffer; n pixels.
kernel void gl_lift_positions(global float4* gpos, global const float4* ggeo, int n,
                              float offset) {
  int i = get_global_id(0);
  if (i >= n) return;
  float4 p = gpos[i];
  if (p.w == 0.0f) return;
  float3 g = ggeo[i].xyz;
  float len = length(g);
  if (!(len > 0.0f)) return;
  gpos[i] = (float4)(p.xyz + (offset / len) * g, 1.0f);
}
