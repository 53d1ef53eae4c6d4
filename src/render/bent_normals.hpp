// Internal: bent normals at light silhouettes (Sintorn et al. 2008 §4.3; kernels/render/bent.cl
// says how). The
// renderer calls bentNormals() after the G-buffer when RenderOptions::bentNormals is set; the
// shading (kernels/render/shade.cl) reads the per-pixel, per-light I_bend it leaves.
#pragma once
#include <array>
#include <vector>

#include "penumbra/context.hpp"
#include "common/shared.h"
#include "render/device_scene.hpp"
#include "render/rasterizer.hpp"
#include "shadows/shadow_pass.hpp"

namespace penumbra::detail {

// The triangles with every vertex replaced by the first vertex of the same position and normal
// (bit for bit, normal's w included), so faces meeting across a texture seam (split vertices)
// count as adjacent. pos, nrm: the renderer's uploads (nrm.w = 0: no vertex normal).
std::vector<cl_int4> weldedTriangles(const std::vector<cl_float4>& pos,
                                     const std::vector<cl_float4>& nrm,
                                     const std::vector<cl_int4>& tris);

// Per (vertex, light), vertex-major, minimum and maximum over the adjacent faces of the oriented
// n_F . l (kernels/render/bent.cl's bent_vertices) into `bend` (2 ints per entry,
// pb_float_to_ordered; INT_MAX / INT_MIN where no face reached the vertex). tris must be welded.
// Stage "bent-normals/vertices".
void bentVertices(Context& ctx, const cl::Buffer& pos, const cl::Buffer& nrm,
                  const cl::Buffer& tris, int ntris, int nverts, const cl::Buffer& lights,
                  int nlights, cl::Buffer& bend);

// The same on the host (the kernel's reference): {min, max} per (vertex, light), vertex-major;
// {+inf, -inf} where no face reached the vertex. lightDirs: unit directions towards the lights.
std::vector<std::array<float, 2>> bentVerticesReference(const std::vector<cl_float4>& pos,
                                                        const std::vector<cl_float4>& nrm,
                                                        const std::vector<cl_int4>& tris,
                                                        const std::vector<std::array<float, 3>>& lightDirs);

// What the shading reads (kernels/render/shade.cl, kernels/render/bent.clh): per vertex and light
// the minimum and maximum (bentVertices), per pixel its triangle's welded vertices and their
// weights.
struct BentBuffers {
  cl::Buffer bend, vert, weight;
};

// The frame's bent-normal inputs to the shading, in pool buffers: welds the scene's triangles,
// runs bent_vertices and bent_pixels (stage "bent-normals/pixels") for the camera G-buffer.
BentBuffers bentNormals(Context& ctx, BufferPool& pool, const DeviceScene& scene,
                        const cl::Buffer& lights, int nlights, const DeviceGBuffer& gbuffer,
                        int npixels);

}  // namespace penumbra::detail
