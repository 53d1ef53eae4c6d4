// Internal: the rasterizer stage (kernels/render/raster.cl). From the scene on the device it
// renders the camera G-buffer and depth maps for any set of views: the lights' shadow maps and
// the extra maps techniques ask for through DepthRasterizer (ShadowFrame::rasterizeDepth).
#pragma once
#include <string>
#include <vector>

#include "penumbra/context.hpp"
#include "common/shared.h"
#include "render/device_scene.hpp"
#include "shadows/shadow_pass.hpp"

namespace penumbra::detail {

// Which faces a depth map keeps, judged against the view direction (raster_triangles' cull).
enum class Cull { None = 0, KeepFront = 1, KeepBack = 2 };

// The camera G-buffer, W x H each, in pool buffers valid until the next frame.
struct DeviceGBuffer {
  cl::Buffer depth;     // uint: depth bits, PB_DEPTH_EMPTY where nothing
  cl::Buffer ids;       // uint: triangle id, PB_ID_EMPTY where nothing
  cl::Buffer position;  // float4: world position, w = 1 on geometry, 0 on the background
  cl::Buffer normal;    // float4: shading normal facing the camera
  cl::Buffer geometricNormal;  // float4: geometric normal facing the camera
  cl::Buffer albedo;    // float4
};

class Rasterizer : public DepthRasterizer {
 public:
  Rasterizer(Context& ctx, BufferPool& pool) : ctx_(ctx), pool_(pool) {}
  // What the frame's rasterizations draw: the scene, the depth maps' size S and whether depth
  // maps average front- and back-facing surfaces (RenderOptions::frontBackFaces).
  void setFrame(const DeviceScene& scene, int mapSize, bool frontBackFaces);
  // The camera G-buffer for `camera` (one pb_view): stages gbuffer/depth, gbuffer/ids (on CPUs
  // gbuffer/rows, gbuffer/raster: the same bits), gbuffer/resolve. Every face counts (no culling).
  // Positions are moved by shadowOffset along the camera-facing geometric normal: where shadow
  // rays start (scene/shadow_offset.hpp).
  DeviceGBuffer gbuffer(const cl::Buffer& camera, int width, int height, float shadowOffset);
  // Every depth map of the frame (the lights' and any a technique adds) goes through here, so
  // front/back applies to all of them alike: nearest surface, or the average of the front- and
  // back-facing surfaces' depths (Kneiphof 2017 §4.2.3).
  void depthMaps(const std::vector<pb_view>& views, cl::Buffer& out,
                 const std::string& prefix) override;
  // The same, and in `ids` the triangle each texel sees (the least index among those at its
  // depth, PB_ID_EMPTY where none; as the camera's id pass). Not with front/back maps, whose
  // texels hold no one surface's depth.
  void depthMapsWithIds(const std::vector<pb_view>& views, cl::Buffer& out, cl::Buffer& ids,
                        const std::string& prefix);

 private:
  // One raster_triangles launch over `nviews` views: pass 0 writes depth, pass 1 the ids of the
  // triangles that won it (pass 0 over several views on a CPU: raster_views, which writes the
  // ids too when `ids` is not `depth`).
  // Returns whether it wrote the ids too. clear (raster_views only): the kernel empties the maps
  // (and the ids it keeps) before drawing, instead of a fill before the launch.
  bool raster(const cl::Buffer& views, int nviews, int pass, Cull cull, cl::Buffer& depth,
              cl::Buffer& ids, const std::string& stage, bool clear = false);
  // Whether raster() runs raster_views for these views and pass.
  bool viewsRun(int nviews, int pass) const;
  // depthMaps' and depthMapsWithIds' work: with ids (never with front/back maps) or without.
  void depthMapsOf(const std::vector<pb_view>& views, cl::Buffer& out, cl::Buffer* ids,
                   const std::string& prefix);

  Context& ctx_;
  BufferPool& pool_;
  const DeviceScene* scene_ = nullptr;
  int mapSize_ = 0;
  bool frontBack_ = false;
  cl::Kernel raster_;
  cl::Kernel views_;  // raster_views, where the CPU forms run (else null)
  cl::Kernel rows_;   // triangle_rows and raster_bands: the camera's, where the CPU forms run
  cl::Kernel bands_;
  int cores_ = 1;     // the device's compute units
};

}  // namespace penumbra::detail
