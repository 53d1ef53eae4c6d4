// The rasterizer stage: raster_triangles for the camera and for depth maps, the G-buffer resolve
// and the front/back combination (kernels/render/raster.cl).
#include "render/rasterizer.hpp"

#include <algorithm>

#include "core/device_kind.hpp"

namespace penumbra::detail {

namespace {
// Rows of the bounding box each triangle's work is split into: large triangles (the ground) are
// shared by this many work-items on a GPU. On a CPU every work-item pays the triangle's setup for
// the few rows of a small triangle it gets (most of a mesh's triangles cover a texel or two of a
// 256^2 map), and the 32 maps of a frame give its cores enough to share: one stripe (measured on
// PoCL, 2 cores, the default frame's 32 maps: 54 ms with 8 stripes, 42 with 2, 37 with 1).
constexpr int kGpuStripes = 8;
constexpr int kCpuStripes = 1;
// Bands of the camera's rows per core (raster_bands on CPUs): a band takes every triangle that
// meets it, so wide triangles are set up once a band, and the bands of the busy middle of a frame
// take longer than those of its sky.
constexpr int kCpuBandsPerCore = 8;
}  // namespace

void Rasterizer::setFrame(const DeviceScene& scene, int mapSize, bool frontBackFaces) {
  scene_ = &scene;
  mapSize_ = mapSize;
  frontBack_ = frontBackFaces;
  // One kernel object for every launch (a technique may rasterize in a loop of batches).
  // CPUs: an orthographic view's rows in SIMD loops (raster.cl, RASTER_ROW_SIMD).
  if (!raster_()) {
    const bool cpu = useCpuBatching(ctx_);
    const std::string options = cpu ? "-DRASTER_ROW_SIMD" + simdLoopOption(ctx_) : "";
    raster_ = ctx_.kernel("raster.cl", "raster_triangles", options);
    // CPUs: several views' depth, one work-item per view (raster.cl, raster_views), where the
    // views are at least as many as the cores that run them
    if (cpu) {
      views_ = ctx_.kernel("raster.cl", "raster_views", options);
      rows_ = ctx_.kernel("raster.cl", "triangle_rows", options);
      bands_ = ctx_.kernel("raster.cl", "raster_bands", options);
      cores_ = int(computeUnits(ctx_));
    }
  }
}

bool Rasterizer::viewsRun(int nviews, int pass) const {
  return views_() && pass == 0 && nviews > 1 && nviews >= cores_;
}

bool Rasterizer::raster(const cl::Buffer& views, int nviews, int pass, Cull cull,
                        cl::Buffer& depth, cl::Buffer& ids, const std::string& stage,
                        bool clear) {
  const int ntris = scene_->triangleCount();
  if (viewsRun(nviews, pass)) {
    // ids apart from depth: raster_views keeps each texel's id with its depth (raster.cl's pass 2)
    const bool withIds = &ids != &depth;
    ctx_.launchWith(stage, views_, cl::NDRange(nviews), cl::NDRange(1), scene_->positionBuffer(),
                    scene_->triangleBuffer(), cl_int(ntris), views, cl_int(nviews), depth,
                    cl_int(cull), ids, cl_int(withIds), cl_int(clear));
    return withIds;
  }
  if (clear)
    throw Error(ErrorKind::Internal, stage + ": only raster_views empties its maps itself");
  const int stripes = useCpuBatching(ctx_) ? kCpuStripes : kGpuStripes;
  ctx_.launchWith(stage, raster_, cl::NDRange(ntris, stripes, nviews), cl::NullRange,
                  scene_->positionBuffer(), scene_->triangleBuffer(), cl_int(ntris), views,
                  cl_int(stripes), cl_int(pass), depth, ids, cl_int(cull));
  return false;
}

DeviceGBuffer Rasterizer::gbuffer(const cl::Buffer& camera, int W, int H, float shadowOffset) {
  const std::size_t npx = std::size_t(W) * H;
  DeviceGBuffer g;
  g.depth = pool_.buffer("camera depth", npx * 4);
  g.ids = pool_.buffer("camera triangle ids", npx * 4);
  const cl_uint emptyDepth = PB_DEPTH_EMPTY, emptyId = PB_ID_EMPTY;
  ctx_.fill(g.depth, &emptyDepth, 4, npx * 4, "camera depth");
  ctx_.fill(g.ids, &emptyId, 4, npx * 4, "camera triangle ids");
  if (bands_()) {
    // CPUs: bands of rows, one writer each, depth and id in one pass (raster.cl, raster_bands);
    // kCpuBandsPerCore bands a core, so that uneven bands even out
    const int ntris = scene_->triangleCount();
    cl::Buffer& rows = pool_.buffer("camera triangle rows", std::size_t(ntris) * 8);
    ctx_.launchWith("gbuffer/rows", rows_, cl::NDRange(ntris), cl::NullRange,
                    scene_->positionBuffer(), scene_->triangleBuffer(), cl_int(ntris), camera,
                    rows);
    const int nbands = std::max(1, std::min(H, kCpuBandsPerCore * cores_));
    const int band = (H + nbands - 1) / nbands;
    ctx_.launchWith("gbuffer/raster", bands_, cl::NDRange((H + band - 1) / band), cl::NDRange(1),
                    scene_->positionBuffer(), scene_->triangleBuffer(), cl_int(ntris), camera,
                    rows, cl_int(band), g.depth, g.ids);
  } else {
    raster(camera, 1, 0, Cull::None, g.depth, g.ids, "gbuffer/depth");
    raster(camera, 1, 1, Cull::None, g.depth, g.ids, "gbuffer/ids");
  }
  g.position = pool_.buffer("G-buffer positions", npx * 16);
  g.normal = pool_.buffer("G-buffer normals", npx * 16);
  g.geometricNormal = pool_.buffer("G-buffer geometric normals", npx * 16);
  g.albedo = pool_.buffer("G-buffer albedo", npx * 16);
  // the CPU form on CPU devices (raster.cl, gbuffer_resolve_batch: the same bits on PoCL), 64
  // pixels of a row a work-item (GB_GROUP)
  KernelForm k =
      kernelForm(ctx_, "raster.cl", "gbuffer_resolve", "GB_GROUP", 64, std::size_t(W));
  ctx_.launchWith("gbuffer/resolve", k.kernel, cl::NDRange(k.items, std::size_t(H)), cl::NullRange,
                  scene_->positionBuffer(), scene_->normalBuffer(), scene_->triangleBuffer(),
                  scene_->albedoBuffer(), camera, g.ids, g.position, g.normal, g.geometricNormal,
                  g.albedo, cl_float(shadowOffset));
  return g;
}

void Rasterizer::depthMapsWithIds(const std::vector<pb_view>& views, cl::Buffer& out,
                                  cl::Buffer& ids, const std::string& prefix) {
  if (frontBack_)
    throw Error(ErrorKind::Internal, prefix + ": depth maps with ids and front/back maps at once");
  depthMapsOf(views, out, &ids, prefix);
}

void Rasterizer::depthMaps(const std::vector<pb_view>& views, cl::Buffer& out,
                           const std::string& prefix) {
  depthMapsOf(views, out, nullptr, prefix);
}

void Rasterizer::depthMapsOf(const std::vector<pb_view>& views, cl::Buffer& out, cl::Buffer* ids,
                             const std::string& prefix) {
  const cl_uint emptyDepth = PB_DEPTH_EMPTY, emptyId = PB_ID_EMPTY;
  cl::Buffer& vb = pool_.upload("views " + prefix, views);
  const std::size_t texels = views.size() * std::size_t(mapSize_) * mapSize_;
  const int nviews = int(views.size());
  // Where raster_views draws the maps, it empties them itself (depth, and ids when it keeps
  // them); elsewhere the buffers are filled first.
  const bool inKernel = viewsRun(nviews, 0);
  auto one = [&](Cull cull, cl::Buffer& dst, const std::string& stage) {
    if (!inKernel) ctx_.fill(dst, &emptyDepth, 4, texels * 4, stage);
    return raster(vb, nviews, 0, cull, dst, ids ? *ids : dst, stage, inKernel);
  };
  if (ids) {
    if (!inKernel) ctx_.fill(*ids, &emptyId, 4, texels * 4, prefix + "/ids");
    // the ids with the depth where raster_views runs, else in raster_triangles' id pass
    if (!one(Cull::None, out, prefix + "/raster"))
      raster(vb, nviews, 1, Cull::None, out, *ids, prefix + "/ids");
    return;
  }
  if (!frontBack_) {
    one(Cull::None, out, prefix + "/raster");
    return;
  }
  cl::Buffer& back = pool_.buffer("back-face maps " + prefix, texels * 4);
  one(Cull::KeepFront, out, prefix + "/raster-front");
  one(Cull::KeepBack, back, prefix + "/raster-back");
  cl::Kernel k = ctx_.kernel("raster.cl", "combine_front_back");
  ctx_.launchWith(prefix + "/front-back", k, cl::NDRange(texels), cl::NullRange, out, back,
                  cl_int(texels));
}

}  // namespace penumbra::detail
