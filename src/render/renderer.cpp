// The frame as a list of stages: the scene on the device (device_scene.hpp), the lights' frames,
// the camera G-buffer (rasterizer.hpp), bent normals, the lights' shadow maps and the technique's
// visibility (visibility.hpp), shading (shading.hpp).
#include "penumbra/renderer.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <mutex>

#include "penumbra/context.hpp"
#include "penumbra/environment.hpp"
#include "common/shared.h"
#include "core/vec3.hpp"
#include "render/bent_normals.hpp"
#include "render/device_scene.hpp"
#include "render/options_check.hpp"
#include "render/rasterizer.hpp"
#include "render/shading.hpp"
#include "render/visibility.hpp"
#include "scene/shadow_offset.hpp"
#include "shadows/shadow_pass.hpp"

namespace penumbra {

namespace {

std::string mib(std::uint64_t bytes) { return std::to_string((bytes + (1u << 20) - 1) >> 20); }

// Whether a frame's shadow maps (when its technique reads them) are drawn with triangle ids: for
// contact shadows from the lights' side (kernels/render/contact.cl, contact_map); front/back maps
// hold no one surface a texel's id could name.
bool mapsWithIds(const RenderOptions& opt) {
  return opt.shadow.contactShadows && opt.shadow.contactFromMaps && !opt.frontBackFaces;
}

// Refuses, before any device work, a frame whose own buffers cannot fit the device: camera depth
// and triangle ids (4 + 4 bytes a pixel), the four G-buffer planes and the shaded frame (16 each),
// the visibility buffer (4 bytes a pixel per light) and, for a technique that reads them, one
// 32-bit depth map per light in one buffer (and, for contact shadows from the lights' side, as
// many triangle ids): the sizes the stages allocate (rasterizer.cpp,
// shading.cpp, visibility.cpp, Impl::shadows below). A technique's own maps and lists come on top
// and are refused as they are allocated (Context::buffer).
void checkFrameFits(const Context& ctx, const RenderOptions& opt, int lights) {
  const std::uint64_t px = std::uint64_t(opt.width) * std::uint64_t(opt.height);
  const std::uint64_t texels = std::uint64_t(opt.shadowMapSize) * std::uint64_t(opt.shadowMapSize);
  const std::uint64_t frame = px * (4 + 4 + 4 * 16 + 16);
  const std::uint64_t vis = px * std::max(lights, 1) * 4;
  const auto pass = lights > 0 ? detail::makeShadowPass(opt.shadows) : nullptr;
  const bool readsMaps = pass && pass->usesShadowMaps();
  const std::uint64_t maps = readsMaps ? texels * std::uint64_t(lights) * 4 : 0;
  // and, for contact shadows from the lights' side, the maps' triangle ids (as large)
  const std::uint64_t mapIds = mapsWithIds(opt) ? maps : 0;
  const std::uint64_t largest = std::max({px * 16, vis, maps});
  const char* largestRole =
      largest == maps ? "shadow maps" : largest == vis ? "visibility buffer" : "frame plane";
  const DeviceInfo& d = ctx.info();
  const std::string what = "RenderOptions " + std::to_string(opt.width) + "x" +
                           std::to_string(opt.height) + " with " + std::to_string(lights) +
                           " lights and " + std::to_string(opt.shadowMapSize) + "^2 maps";
  if (d.maxAllocBytes > 0 && largest > d.maxAllocBytes)
    throw Error(ErrorKind::OutOfMemory,
                what + " needs a " + mib(largest) + " MiB buffer (" + largestRole +
                    ") but device " + d.name +
                    " allows " + mib(d.maxAllocBytes) +
                    " MiB per buffer (out of device memory; reduce the size or light count)");
  // Against the whole device: this renderer's buffers from the last frame are reused, not added.
  if (frame + vis + maps + mapIds > d.globalMemBytes)
    throw Error(ErrorKind::OutOfMemory,
                what + " needs at least " + mib(frame + vis + maps + mapIds) + " MiB (frame " +
                    mib(frame) + ", visibility " + mib(vis) + ", shadow maps " +
                    mib(maps + mapIds) + ") but device " +
                    d.name + " has " + mib(d.globalMemBytes) +
                    " MiB (out of device memory; reduce the size or light count)");
}

pb_view cameraView(const Camera& c, int w, int h) {
  CameraBasis b = cameraBasis(c, w, h);
  pb_view v{};
  for (int k = 0; k < 3; ++k) {
    v.origin[k] = b.eye[k];
    v.forward[k] = b.forward[k];
    v.right[k] = b.right[k];
    v.up[k] = b.up[k];
  }
  v.right[3] = b.tanHalfX;
  v.up[3] = b.tanHalfY;
  v.width = w;
  v.height = h;
  v.ortho = 0;
  return v;
}

}  // namespace

struct Renderer::Impl {
  // Serializes render() and lastVisibility() (renderer.hpp, "Thread safety"): the members below
  // are one frame's state (kernels with their arguments set, the buffer pool, the last visibility).
  std::mutex mutex;
  Context& ctx;
  detail::BufferPool pool;
  detail::DeviceScene scene;
  detail::Rasterizer raster;
  detail::Visibility visibility;
  explicit Impl(Context& c) : ctx(c), pool(c), scene(c), raster(c, pool), visibility(c, pool) {}

  // What the shading needs to bend normals (Sintorn et al. 2008 §4.3), or small stand-ins it never
  // reads.
  detail::BentBuffers bentNormals(const RenderOptions& opt, const cl::Buffer& lightB, int nl,
                                  const detail::DeviceGBuffer& g) {
    if (opt.bentNormals && nl > 0)
      return detail::bentNormals(ctx, pool, scene, lightB, nl, g, opt.width * opt.height);
    const cl::Buffer& off = pool.buffer("bent normals off", 16);
    return {off, off, off};
  }

  // The lights' shadow maps when the technique reads them, then its visibility.
  void shadows(const Scene& sc, const RenderOptions& opt, const LightSet& lightSet,
               const detail::LightFrames& lf, const cl::Buffer& lightB,
               const detail::DeviceGBuffer& g) {
    const int S = opt.shadowMapSize, nl = int(lf.lights.size());
    visibility.begin(opt.shadow, opt.shadows, opt.width * opt.height, nl);
    detail::ShadowFrame sf(ctx, pool, opt, lf.lights);
    if (visibility.runsPass()) {
      // Techniques with their own light-space structures (the bitmask's lists) never read them.
      const bool maps = visibility.readsShadowMaps();
      sf.depth = pool.buffer("shadow maps", maps ? std::size_t(S) * S * nl * 4 : 4);
      if (maps && mapsWithIds(opt)) {
        sf.mapIds = pool.buffer("shadow-map ids", std::size_t(S) * S * nl * 4);
        raster.depthMapsWithIds(lf.views, sf.depth, sf.mapIds, "shadow-maps");
      } else if (maps) {
        raster.depthMaps(lf.views, sf.depth, "shadow-maps");
      }
    }
    sf.width = opt.width;
    sf.height = opt.height;
    sf.pixels = opt.width * opt.height;
    sf.mapSize = S;
    sf.lightBuffer = lightB;
    sf.gpos = g.position;
    sf.gnrm = g.normal;
    sf.ggeo = g.geometricNormal;
    sf.rasterizer = &raster;
    sf.gids = g.ids;
    sf.positions = scene.positionBuffer();
    sf.triangles = scene.triangleBuffer();
    sf.triangleCount = scene.triangleCount();
    sf.hostPositions = &scene.positions();
    sf.hostTriangles = &scene.triangles();
    sf.areaLights = &lightSet.lights;
    sf.ground = detail::groundRect(findGround(sc), sc.bounds());
    visibility.compute(sf);
  }
};

Renderer::Renderer(Context& ctx) : impl_(std::make_unique<Impl>(ctx)) {}
Renderer::~Renderer() = default;

Frame Renderer::render(const Scene& scene, const Camera& camera, const LightSet& lightSet,
                       const Environment& env, const RenderOptions& opt) {
  Impl& m = *impl_;
  std::lock_guard<std::mutex> lock(m.mutex);
  auto t0 = std::chrono::steady_clock::now();  // after the wait for other threads' frames
  detail::validateFrameInputs(scene, camera, lightSet, env, opt);
  const int W = opt.width, H = opt.height, nl = int(lightSet.lights.size());
  checkFrameFits(m.ctx, opt, nl);

  // scene, camera and lights on the device
  m.scene.update(scene);
  // the scene's box, walked once: the light frames fit it, the shadow offset scales with it
  const Bounds box = scene.bounds();
  const detail::LightFrames lf = detail::lightFrames(lightSet, box, opt.shadowMapSize);
  cl::Buffer camB = m.pool.upload("camera", std::vector<pb_view>{cameraView(camera, W, H)});
  cl::Buffer lightB = m.pool.upload("lights", lf.lights);
  // camera G-buffer
  m.raster.setFrame(m.scene, opt.shadowMapSize, opt.frontBackFaces);
  const detail::DeviceGBuffer g =
      m.raster.gbuffer(camB, W, H, detail::shadowRayOffset(box.lo.data(), box.hi.data()));
  // bent normals, shadow maps and visibility
  const detail::BentBuffers bent = m.bentNormals(opt, lightB, nl, g);
  m.shadows(scene, opt, lightSet, lf, lightB, g);
  // shading
  const detail::ShadeInputs in{g, lightB, m.visibility.buffer(), camB, m.scene.environment(env),
                               bent};
  cl::Buffer outB = detail::shade(m.ctx, m.pool, in, lightSet, env, opt);

  Frame frame;
  frame.shadowMapBytes = m.visibility.frameBytes();
  frame.stats = m.visibility.stats();
  frame.image = Image(W, H, 4);
  m.ctx.read(outB, frame.image.pixels.data(), std::size_t(W) * H * 16, "frame");
  frame.timingsMs = m.ctx.stageTimesMs();
  double total =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  frame.timingsMs.emplace_back("total", total);
  return frame;
}

std::vector<float> Renderer::lastVisibility() {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->visibility.download();
}

}  // namespace penumbra
