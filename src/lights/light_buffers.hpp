// How polygon lights reach the device: one layout for every kernel and shader that evaluates a
// light's irradiance (kernels/render/shade.cl, kernels/environment/irradiance.cl through
// kernels/lights/lights.clh, and the GL shading pass), so the three cannot drift apart.
#pragma once
#include <algorithm>
#include <vector>

#include "penumbra/context.hpp"
#include "penumbra/lights.hpp"
#include "common/shared.h"

namespace penumbra::detail {

// PB_MAX_POLY_VERTS float4 per light: a polygon's vertices (xyz), w of the first = the vertex
// count; all zero for a cap. At least one light's block, so the buffer is never empty.
inline std::vector<cl_float4> polygonVertexBlocks(const std::vector<AreaLight>& lights) {
  std::vector<cl_float4> poly(std::max<std::size_t>(1, lights.size()) * PB_MAX_POLY_VERTS,
                              cl_float4{{0, 0, 0, 0}});
  for (std::size_t l = 0; l < lights.size(); ++l) {
    const AreaLight& a = lights[l];
    if (a.shape != LightShape::Polygon) continue;
    const std::size_t nv = std::min<std::size_t>(a.vertices.size(), PB_MAX_POLY_VERTS);
    for (std::size_t i = 0; i < nv; ++i)
      for (int c = 0; c < 3; ++c) poly[l * PB_MAX_POLY_VERTS + i].s[c] = a.vertices[i][c];
    poly[l * PB_MAX_POLY_VERTS].s[3] = float(nv);
  }
  return poly;
}

}  // namespace penumbra::detail
