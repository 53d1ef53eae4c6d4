// Internal: the interface every shadow technique implements, and what the renderer hands it.
//
// The renderer rasterizes the camera G-buffer and one depth map per light (all faces, the light's
// orthographic frame fitted to the scene), then asks the technique for the visibility of every
// light at every pixel. A technique adds its own stages (named "<technique>/<stage>") and may
// rasterize more depth maps through ShadowFrame::rasterizeDepth (front/back faces, sample views).
// The renderer's visibility stage (src/render/visibility.hpp) keeps the pass between frames and
// runs it, for the OpenCL renderer and the GL interop alike.
#pragma once
#include <array>
#include <cstring>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "penumbra/context.hpp"
#include "penumbra/error.hpp"
#include "penumbra/lights.hpp"
#include "penumbra/options.hpp"
#include "penumbra/scene.hpp"
#include "common/shared.h"

namespace penumbra::detail {

// Device buffers kept between frames by role; reallocated only when a frame needs more. Fresh
// allocations cost first-touch page faults on CPU devices (measured: a 64 MiB moment buffer
// doubled the moments stage) and allocation calls on GPUs.
class BufferPool {
 public:
  explicit BufferPool(Context& ctx) : ctx_(ctx) {}
  BufferPool(const BufferPool&) = delete;
  BufferPool& operator=(const BufferPool&) = delete;
  ~BufferPool() {
    for (auto& [role, st] : staged_) waitFor(st);
  }
  cl::Buffer& buffer(const std::string& role, std::size_t bytes) {
    return ctx_.reuse(pool_, role, bytes);
  }
  // The data goes to the device behind the work already queued, without waiting for it: a copy
  // is kept per role until the write is done (the next upload of the role waits for the last
  // one). A blocking write would drain the queue first, and on PoCL the device's threads then
  // sleep and wake for the next launch, a fraction of a millisecond each time.
  template <class T>
  cl::Buffer& upload(const std::string& role, const std::vector<T>& data) {
    cl::Buffer& b = buffer(role, std::max<std::size_t>(1, data.size()) * sizeof(T));
    if (!data.empty()) {
      Staged& st = staged_[role];
      waitFor(st);
      const std::size_t bytes = data.size() * sizeof(T);
      st.data.resize(bytes);
      std::memcpy(st.data.data(), data.data(), bytes);
      st.done = ctx_.writeAsync(b, st.data.data(), bytes, role);
    }
    return b;
  }

 private:
  struct Staged {
    std::vector<unsigned char> data;
    cl::Event done;
  };
  static void waitFor(Staged& st) {
    if (!st.done()) return;
    try {
      st.done.wait();
    } catch (const cl::Error&) {  // a failed write: the queue reports it at its next use
    }
    st.done = cl::Event();
  }
  Context& ctx_;
  Context::BufferSlots pool_;
  std::map<std::string, Staged> staged_;
};

// What a technique asks of the rasterizer stage (src/render/rasterizer.hpp): depth maps of the
// scene for `views` (orthographic pb_view, S x S each) into `out` (views.size()*S*S uint), the
// encoding of ShadowFrame::depth, front and back faces averaged when opt.frontBackFaces. Stages
// "<prefix>/raster" (or /raster-front, /raster-back, /front-back). The GL interop, which has no
// triangles, hands techniques one that refuses.
class DepthRasterizer {
 public:
  virtual ~DepthRasterizer() = default;
  virtual void depthMaps(const std::vector<pb_view>& views, cl::Buffer& out,
                         const std::string& prefix) = 0;
};

// The frame's ground (src/render/ground.hpp's groundRect), absent where the scene has none.
struct GroundRect {
  bool present = false;
  GroundPlane plane;
  float eps = 0;   // heights above plane.y up to eps count as on the ground
  float lift = 0;  // the G-buffer's shadow offset (scene/shadow_offset.hpp): a position is the
                   // surface point moved by lift along its geometric normal
};

// One frame as a technique sees it. The four references are what every frame has; the rest is
// assigned by name where the frame is built (src/render/renderer.cpp, src/gl/interop.cpp), and
// what a caller cannot give keeps its empty default (the GL interop has no triangles).
struct ShadowFrame {
  ShadowFrame(Context& c, BufferPool& p, const RenderOptions& o, const std::vector<pb_light>& l)
      : ctx(c), pool(p), opt(o), lights(l) {}
  // Frame f for other lights `l` (a subset of f's, src/shadows/auto.cpp): every field but those
  // that depend on the lights, which the caller sets (lightBuffer, depth, vis, rows,
  // areaLights). Kept beside the fields so that a new one is copied too.
  ShadowFrame(const ShadowFrame& f, const std::vector<pb_light>& l)
      : ShadowFrame(f.ctx, f.pool, f.opt, l) {
    width = f.width;
    height = f.height;
    pixels = f.pixels;
    mapSize = f.mapSize;
    gpos = f.gpos;
    gnrm = f.gnrm;
    ggeo = f.ggeo;
    rasterizer = f.rasterizer;
    gids = f.gids;
    positions = f.positions;
    triangles = f.triangles;
    triangleCount = f.triangleCount;
    hostPositions = f.hostPositions;
    hostTriangles = f.hostTriangles;
    ground = f.ground;
    horizonRewrites = f.horizonRewrites;
  }
  Context& ctx;
  BufferPool& pool;
  const RenderOptions& opt;
  const std::vector<pb_light>& lights;    // frames of the lights, as uploaded in `lightBuffer`
  int width = 0, height = 0, pixels = 0;  // camera image
  int mapSize = 0;                        // S: every depth map is S x S
  cl::Buffer lightBuffer;                 // pb_light[lights.size()]
  cl::Buffer gpos, gnrm, ggeo;            // G-buffer: position (w = 1 on geometry), shading and
                                          // geometric normal (facing the camera), float4 each
  cl::Buffer depth;                       // per light S*S uint: ray distance bits from the near
                                          // plane (as_float), PB_DEPTH_EMPTY where nothing
  cl::Buffer mapIds;                      // per light S*S uint: the triangle each texel of
                                          // `depth` sees (PB_ID_EMPTY: none); null where the
                                          // maps were drawn without (contact.cl reads them)
  cl::Buffer vis;                         // out: float [light][pixel], 1 = unshadowed (set by
                                          // the visibility stage, src/render/visibility.hpp)
  cl::Buffer rows;                        // int per light: its map in `depth` and its row in
                                          // `vis`, for a subset of a frame's lights that reads
                                          // and writes the frame's own buffers (auto.cpp, for a
                                          // pass whose readsFrameRows()); null: light l is row l
  DepthRasterizer* rasterizer = nullptr;  // more depth maps of the scene (rasterizeDepth)
  cl::Buffer gids;                        // camera triangle id per pixel (PB_ID_EMPTY: none)
  cl::Buffer positions, triangles;        // the scene as rasterized: float4 vertices, int4
  int triangleCount = 0;                  // (v0, v1, v2, mesh) triangles
  // The same scene on the host, as uploaded (src/render/device_scene.hpp), for techniques that
  // need it there (the bitmask's mesh orientation): no read-back of what was just uploaded.
  const std::vector<cl_float4>* hostPositions = nullptr;
  const std::vector<cl_int4>* hostTriangles = nullptr;
  // The lights themselves (shape, polygon vertices), parallel to `lights`: for techniques that
  // sample a light (lightSampleDirections in lights.hpp). Set by the renderer.
  const std::vector<AreaLight>* areaLights = nullptr;
  // The scene's ground, for the ground's occlusion of low lights (src/render/ground.hpp); the GL
  // interop has it from its caller.
  GroundRect ground;
  // Set by the visibility stage (src/render/visibility.cpp) where the horizon step follows the
  // pass: it then replaces the visibility of every pair of a map-shadowed light whose centre is
  // below the pixel's horizon while part of its cap is above (kernels/render/horizon.cl), so a
  // pass may write those pairs 0 instead of filtering them (filter.clh, horizon_rewrites).
  bool horizonRewrites = false;

  // Depth maps of the scene for `views` through `rasterizer` (DepthRasterizer::depthMaps).
  void rasterizeDepth(const std::vector<pb_view>& views, cl::Buffer& out,
                      const std::string& prefix) {
    if (!rasterizer) throw Error(ErrorKind::Internal, prefix + ": the frame has no rasterizer");
    rasterizer->depthMaps(views, out, prefix);
  }
};

class ShadowPass {
 public:
  virtual ~ShadowPass() = default;
  virtual void computeVisibility(ShadowFrame& f) = 0;
  // Device bytes per shadow-map texel per light the technique keeps (for the report).
  virtual std::size_t bytesPerTexel(const RenderOptions& opt) const = 0;
  // Whether the technique reads ShadowFrame::depth (the renderer skips rasterizing it if not).
  virtual bool usesShadowMaps() const { return true; }
  // Whether it honours ShadowFrame::rows for these options on this device: then `auto` hands it
  // a subset of the lights with the frame's own maps and visibility buffer, where it otherwise
  // copies the subset's maps out and its visibility rows back.
  virtual bool readsFrameRows(Context& /*ctx*/, const RenderOptions& /*opt*/) const {
    return false;
  }
  // Whether the last frame's light l came from depth maps read with a bias (the frame's maps or
  // the technique's own, as brute force's and area-approx's), and so gets contact shadows
  // (src/render/contact.hpp); lights whose visibility tests triangles (the bitmask's) do not.
  virtual bool lightFromShadowMap(int /*l*/) const { return true; }
  // Device bytes the technique held for the last frame (Frame::shadowMapBytes); mapTexels: S*S
  // per light times the lights.
  virtual std::size_t frameBytes(const RenderOptions& opt, std::size_t mapTexels) const {
    return mapTexels * bytesPerTexel(opt);
  }
  // Technique statistics of the last frame, for the report (Frame::stats): kept by the pass
  // itself, so two renderers (two passes) never see each other's.
  virtual std::vector<std::pair<std::string, double>> frameStats() const { return {}; }
};

// One implementation per technique (src/shadows/<technique>.cpp), dispatched in
// src/shadows/registry.cpp; None has no pass (nullptr).
std::unique_ptr<ShadowPass> makeShadowPass(ShadowTechnique t);

// Orthographic frame of a point light in direction `dir`, fitted to the oriented box of the area
// light `area`'s own frame (which holds the whole scene): brute force's and area approximation's
// one map per light sample. size > 0: the grid is shifted by (jx, jy) texels of a size x size map,
// with a texel of margin each side so the shift keeps the box inside
// (src/shadows/light_frames.cpp).
pb_light sampleFrame(const pb_light& area, const std::array<float, 3>& dir, int size = 0,
                     float jx = 0.0f, float jy = 0.0f);
bool techniqueAvailable(ShadowTechnique t);
std::unique_ptr<ShadowPass> makeMSSM4Pass();
std::unique_ptr<ShadowPass> makeMSSM6Pass();
std::unique_ptr<ShadowPass> makeCSSMPass();
std::unique_ptr<ShadowPass> makeHardPass(), makePCSSPass(), makeBrutePass();
std::unique_ptr<ShadowPass> makeBitmaskPass(bool hard);  // src/shadows/bitmask.cpp

// Filterable maps: `count` images of S x S long4 texels, image i at element i * stride.
// prefilterStride: elements one image needs for the prefilter (S*S for a SAT; more for a mip
// pyramid, whose levels follow level 0). prefilter() turns raw texels (level 0) into the
// filterable form in place. Kernels select the matching FILTER_BOX with prefilterOption().
bool prefilterAvailable(Prefilter p);
std::size_t prefilterStride(Prefilter p, int size);
void prefilter(Context& ctx, cl::Buffer& maps, Prefilter p, int size, int count,
               const std::string& stage);
std::string prefilterOption(Prefilter p);

// The orthographic frame of a directional light fitted to a box, and its view for the rasterizer
// (src/shadows/light_frames.cpp).
pb_light lightFrame(const std::array<float, 3>& direction, float cosAlpha,
                    const std::array<float, 3>& radiance, const Bounds& bounds);
pb_view orthoView(const pb_light& light, int size);
// Every light's frame fitted to the scene's box and its view for a size x size map, in order.
struct LightFrames {
  std::vector<pb_light> lights;
  std::vector<pb_view> views;
};
LightFrames lightFrames(const LightSet& lightSet, const Bounds& bounds, int size);

}  // namespace penumbra::detail
