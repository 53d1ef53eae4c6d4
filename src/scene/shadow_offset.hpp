// Internal: where a shadow ray starts. The Embree reference (src/reference/reference.cpp) and the
// renderer's G-buffer (kernels/render/raster.cl, gbuffer_resolve) both move a surface point
// along its camera-facing geometric normal by this offset before any shadow test, so the two
// render one model.
//
// Why an offset at all. Smooth-shaded meshes shade with interpolated vertex normals n_s, while
// shadows are cast by the flat triangles. Near the terminator a point can face the light by n_s
// (lit by the shading) while its own triangle faces away by the geometric normal n_g
// (n_s.w > 0 > n_g.w): a ray towards the light then leaves below the triangle's plane and, from
// the surface itself, runs into the neighbouring triangles of the same convex surface within a
// fraction of a triangle, and the pixel turns black inside a lit area (the "shadow terminator"
// problem). From the lifted origin the ray still meets its own triangle where it crosses it, but
// near the triangle's edges it passes over the neighbours, where the facets stray most from the
// smooth surface; the reference has always started its rays there, and the renderer now does
// too (bench/results/accuracy.md, "The shadow terminator").
#pragma once
#include <algorithm>
#include <cmath>
#include <limits>

namespace penumbra::detail {

// 1e-4 of the bounds' half-diagonal (the geometry's scale), at least 64 float ulps of the largest
// coordinate (rounding far from the origin) and at least 1e-7.
inline float shadowRayOffset(const float lo[3], const float hi[3]) {
  double r2 = 0, maxAbs = 0;
  for (int c = 0; c < 3; ++c) {
    r2 += 0.25 * double(hi[c] - lo[c]) * double(hi[c] - lo[c]);
    maxAbs = std::max({maxAbs, std::fabs(double(lo[c])), std::fabs(double(hi[c]))});
  }
  return float(std::max({1e-4 * std::sqrt(r2),
                         64.0 * std::numeric_limits<float>::epsilon() * maxAbs, 1e-7}));
}

}  // namespace penumbra::detail
