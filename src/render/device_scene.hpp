// Internal: the scene stage. The scene flattened into the rasterizer's arrays and the environment
// map, on the device and on the host, kept across frames and uploaded again only when they change.
#pragma once
#include <cstddef>
#include <vector>

#include "penumbra/context.hpp"
#include "penumbra/environment.hpp"
#include "penumbra/scene.hpp"
#include "common/shared.h"
#include "shadows/shadow_pass.hpp"

namespace penumbra::detail {

class DeviceScene {
 public:
  explicit DeviceScene(Context& ctx) : pool_(ctx) {}
  DeviceScene(const DeviceScene&) = delete;
  DeviceScene& operator=(const DeviceScene&) = delete;

  // Brings the device copy up to date with `scene`: flattened and uploaded only when a mesh's
  // positions, normals, triangles or albedo differ, bit for bit, from the last upload's (mesh
  // names do not matter).
  void update(const Scene& scene);
  // The environment's equirect pixels (RGB float, row-major) on the device, uploaded only when
  // they differ, bit for bit, from the last upload's.
  const cl::Buffer& environment(const Environment& env);

  // The scene as uploaded: float4 positions (w = 1), normals (w = 1; all 0 for a mesh without
  // vertex normals), int4 triangles (v0, v1, v2, mesh) indexing all meshes' vertices at once,
  // float4 albedo per mesh (w = 1).
  const std::vector<cl_float4>& positions() const { return pos_; }
  const std::vector<cl_float4>& normals() const { return nrm_; }
  const std::vector<cl_int4>& triangles() const { return tris_; }
  int triangleCount() const { return int(tris_.size()); }
  const cl::Buffer& positionBuffer() const { return posB_; }
  const cl::Buffer& normalBuffer() const { return nrmB_; }
  const cl::Buffer& triangleBuffer() const { return triB_; }
  const cl::Buffer& albedoBuffer() const { return albB_; }

  // Uploads so far, for the tests that check a frame of an unchanged scene re-uploads nothing.
  int sceneUploads() const { return sceneUploads_; }
  int environmentUploads() const { return envUploads_; }

 private:
  BufferPool pool_;  // its own, grow-only: the renderer's per-frame pool never holds these
  cl::Buffer posB_, nrmB_, triB_, albB_, envB_;
  std::vector<Mesh> meshes_;      // the geometry last uploaded, to compare the next frame's with
  std::vector<cl_float4> pos_, nrm_, alb_;
  std::vector<cl_int4> tris_;
  std::vector<float> envPixels_;  // the environment last uploaded
  int sceneUploads_ = 0, envUploads_ = 0;
};

}  // namespace penumbra::detail
