// Internal: the ground's occlusion of low lights (kernels/render/ground.cl), the last step of the
// visibility stage for techniques that read shadow maps, after lights on the horizon.
#pragma once
#include <optional>
#include <vector>

#include "penumbra/scene.hpp"
#include "shadows/shadow_pass.hpp"

namespace penumbra::detail {

// Directions per light (GR_DIRS): the blocked share moves in steps of at most 1/kGroundDirs of
// the light, where a light is one of dozens.
inline constexpr int kGroundDirs = 32;

// The frame's ground from findGround's (or the GL interop caller's) plane, absent without one.
// eps: heights up to it count as on the ground, 1e-5 of the largest side of `bounds` (above the
// G-buffer's float error on the ground).
GroundRect groundRect(const std::optional<GroundPlane>& ground, const Bounds& bounds);

// For each light that reaches below the horizontal (axis y below the sine of its half-angle), its
// axis (w: the tangent of how far below the horizontal the cap reaches) and kGroundDirs
// directions uniform in solid angle over its cap, GR_DIRS + 1 float4 each, into dirs, and its
// index into indices. The directions are sphericalFibonacciCap's N/2 rings (lights/sampling.hpp)
// and the same set turned by pi, interleaved: opposite pairs, ring by ring, so their mean lies on
// the axis. Exposed for the tests' reference.
void groundDirections(const std::vector<pb_light>& lights, std::vector<cl_float4>& dirs,
                      std::vector<int>& indices);

// For every geometry pixel above f.ground and every light l with lightMask[l] != 0 that reaches
// below the horizontal, scales f.vis[l][pixel] by the share of the light (cosine-weighted, above
// the pixel's tangent plane) whose rays miss the ground; where the light's axis hits the ground,
// sets it to that share (ground.cl). No-op without a ground. Returns the number of lights it
// covered.
class GroundOcclusion {
 public:
  explicit GroundOcclusion(BufferPool& pool) : pool_(pool) {}
  int run(const ShadowFrame& f, const cl::Buffer& lightMask);

 private:
  BufferPool& pool_;
  std::vector<cl_float4> dirs_;  // as last uploaded
  std::vector<int> indices_;
  cl::Buffer dirsB_, indicesB_;
};

}  // namespace penumbra::detail
