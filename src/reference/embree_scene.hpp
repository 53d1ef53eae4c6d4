// Internal: a scene flattened for Embree (every mesh's triangles in one geometry, two-sided,
// with the inputs checked) and the Embree scene built from it. Used by the references
// (src/reference/reference.cpp) and by the bitmask technique's shadow-ray checks
// (src/reference/reference_samples.cpp).
#pragma once
#include <embree3/rtcore.h>

#include <array>
#include <cstdint>
#include <limits>
#include <vector>

#include "penumbra/scene.hpp"

namespace penumbra::detail {

struct FlatScene {
  std::vector<float> positions;          // xyz per vertex, all meshes
  std::vector<unsigned> indices;         // 3 per triangle, into `positions`
  std::vector<std::uint32_t> triMesh;    // mesh index per triangle
  std::vector<const Mesh*> meshes;
  std::vector<std::uint32_t> meshFirstVertex;
  float epsilon = 1e-4f;                 // shadow-ray origin offset
};

// Throws Error(BadInput) naming the mesh for non-finite vertices, indices out of range, no
// triangles, or a scene too large for 32-bit indices.
FlatScene flatten(const Scene& scene);

class EmbreeScene {
 public:
  // threads: Embree's own build threads (0: its default, all hardware threads).
  EmbreeScene(const FlatScene& f, int threads);
  ~EmbreeScene();
  EmbreeScene(const EmbreeScene&) = delete;
  EmbreeScene& operator=(const EmbreeScene&) = delete;
  RTCScene get() const { return scene_; }

 private:
  void check(const char* what);
  RTCDevice device_ = nullptr;
  RTCScene scene_ = nullptr;
};

// Whether a triangle blocks the ray from `origin` along `dir` between tnear and infinity:
// Embree's occlusion query, which sets tfar to -inf on a hit. Safe from several threads at once.
inline bool rayOccluded(RTCScene scene, const std::array<float, 3>& origin,
                        const std::array<float, 3>& dir, float tnear) {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRay r;
  r.org_x = origin[0];
  r.org_y = origin[1];
  r.org_z = origin[2];
  r.dir_x = dir[0];
  r.dir_y = dir[1];
  r.dir_z = dir[2];
  r.tnear = tnear;
  r.tfar = std::numeric_limits<float>::infinity();
  r.time = 0.0f;
  r.mask = 0xFFFFFFFFu;
  r.id = 0;
  r.flags = 0;
  rtcOccluded1(scene, &ctx, &r);
  return r.tfar < 0.0f;
}

}  // namespace penumbra::detail
