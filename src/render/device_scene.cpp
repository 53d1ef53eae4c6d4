// The scene stage: flattening the scene's meshes into the rasterizer's arrays, and keeping them
// and the environment map on the device across frames.
//
// Change detection compares the new frame's data with a host copy of what was last uploaded
// (memcmp, bit for bit: nothing is missed, and -0/+0 or a NaN's payload count as changes). It
// reads both copies once and writes nothing, where an upload flattens (writes the host arrays)
// and copies every byte to the device. Measured on PoCL (shared 2-core CPU, built-in scene of
// 1,875 vertices and 3,176 triangles, 512x256 sky; update() and environment() timed over
// 3 x 50 frames, changed and unchanged in turn): comparing took 0.001 ms (scene) and 0.04 ms
// (sky), flattening and uploading 0.5-2.0 ms and 0.5-1.9 ms per frame. On a discrete GPU the
// upload also crosses the bus.
#include "render/device_scene.hpp"

#include <algorithm>
#include <cstring>

namespace penumbra::detail {

namespace {

template <class T>
bool sameBits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

bool sameGeometry(const Mesh& a, const Mesh& b) {
  return sameBits(a.positions, b.positions) && sameBits(a.normals, b.normals) &&
         sameBits(a.triangles, b.triangles) &&
         std::memcmp(a.albedo.data(), b.albedo.data(), sizeof a.albedo) == 0;
}

}  // namespace

void DeviceScene::update(const Scene& scene) {
  if (sceneUploads_ > 0 && scene.meshes.size() == meshes_.size() &&
      std::equal(scene.meshes.begin(), scene.meshes.end(), meshes_.begin(), sameGeometry))
    return;
  pos_.clear();
  nrm_.clear();
  alb_.clear();
  tris_.clear();
  for (std::size_t mi = 0; mi < scene.meshes.size(); ++mi) {
    const Mesh& m = scene.meshes[mi];
    int base = int(pos_.size());
    bool hasN = m.normals.size() == m.positions.size();
    for (std::size_t i = 0; i < m.positions.size(); ++i) {
      auto& p = m.positions[i];
      pos_.push_back({{p[0], p[1], p[2], 1.0f}});
      if (hasN)
        nrm_.push_back({{m.normals[i][0], m.normals[i][1], m.normals[i][2], 1.0f}});
      else
        nrm_.push_back({{0, 0, 0, 0}});
    }
    for (auto& t : m.triangles) tris_.push_back({{base + t[0], base + t[1], base + t[2], int(mi)}});
    alb_.push_back({{m.albedo[0], m.albedo[1], m.albedo[2], 1.0f}});
  }
  posB_ = pool_.upload("vertex positions", pos_);
  nrmB_ = pool_.upload("vertex normals", nrm_);
  triB_ = pool_.upload("triangles", tris_);
  albB_ = pool_.upload("albedo", alb_);
  meshes_ = scene.meshes;
  ++sceneUploads_;
}

const cl::Buffer& DeviceScene::environment(const Environment& env) {
  if (envUploads_ == 0 || !sameBits(env.equirect.pixels, envPixels_)) {
    envB_ = pool_.upload("environment map", env.equirect.pixels);
    envPixels_ = env.equirect.pixels;
    ++envUploads_;
  }
  return envB_;
}

}  // namespace penumbra::detail
