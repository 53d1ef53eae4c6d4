// Internal: the interface every shadow technique implements, and what the renderer hands it.
//
// The renderer rasterizes the camera G-buffer and one depth map per light (all faces, the light's
// orthographic frame fitted to the scene), then asks the technique for the visibility of every
// light at every pixel. A technique adds its own stages (named "<technique>/<stage>") and may
// rasterize more depth maps through ShadowFrame::rasterizeDepth (front/back faces, sample views).
#pragma once
#include <array>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "penumbra/context.hpp"
#include "penumbra/renderer.hpp"
#include "common/shared.h"

namespace penumbra::detail {

// Device buffers kept between frames by role; reallocated only when a frame needs more. Fresh
// allocations cost first-touch page faults on CPU devices (measured: a 64 MiB moment buffer
// doubled the moments stage) and allocation calls on GPUs.
class BufferPool {
 public:
  explicit BufferPool(Context& ctx) : ctx_(ctx) {}
  cl::Buffer& buffer(const std::string& role, std::size_t bytes);
  template <class T>
  cl::Buffer& upload(const std::string& role, const std::vector<T>& data) {
    cl::Buffer& b = buffer(role, std::max<std::size_t>(1, data.size()) * sizeof(T));
    if (!data.empty()) ctx_.write(b, data.data(), data.size() * sizeof(T), role);
    return b;
  }

 private:
  Context& ctx_;
  Context::BufferSlots pool_;
};

// Which faces a depth map keeps, judged against the view direction.
enum class Cull { None = 0, KeepFront = 1, KeepBack = 2 };

struct ShadowFrame {
  Context& ctx;
  BufferPool& pool;
  const RenderOptions& opt;
  int width = 0, height = 0, pixels = 0;  // camera image
  int mapSize = 0;                        // S: every depth map is S x S
  const std::vector<pb_light>& lights;    // frames of the lights, as uploaded in `lightBuffer`
  cl::Buffer lightBuffer;                 // pb_light[lights.size()]
  cl::Buffer gpos, gnrm, ggeo;            // G-buffer: position (w = 1 on geometry), shading and
                                          // geometric normal (facing the camera), float4 each
  cl::Buffer depth;                       // per light S*S uint: ray distance bits from the near
                                          // plane (as_float), PB_DEPTH_EMPTY where nothing
  cl::Buffer vis;                         // out: float [light][pixel], 1 = unshadowed
  // Renders depth maps of the scene for `views` (orthographic pb_view, S x S each) into `out`
  // (views.size()*S*S uint), same encoding as `depth`, front and back faces averaged when
  // opt.frontBackFaces. Stages "<prefix>/raster" (or /raster-front, /raster-back, /front-back).
  std::function<void(const std::vector<pb_view>& views, cl::Buffer& out, const std::string& prefix)>
      rasterizeDepth;
  cl::Buffer gids;                        // camera triangle id per pixel (PB_ID_EMPTY: none)
  cl::Buffer positions, triangles;        // the scene as rasterized: float4 vertices, int4
  int triangleCount = 0;                  // (v0, v1, v2, mesh) triangles
  // The lights themselves (shape, polygon vertices), parallel to `lights`: for techniques that
  // sample a light (lightSampleDirections in lights.hpp). Set by the renderer.
  const std::vector<AreaLight>* areaLights = nullptr;
};

class ShadowPass {
 public:
  virtual ~ShadowPass() = default;
  virtual void computeVisibility(ShadowFrame& f) = 0;
  // Device bytes per shadow-map texel per light the technique keeps (for the report).
  virtual std::size_t bytesPerTexel(const RenderOptions& opt) const = 0;
  // Whether the technique reads ShadowFrame::depth (the renderer skips rasterizing it if not).
  virtual bool usesShadowMaps() const { return true; }
  // Device bytes the technique held for the last frame (Frame::shadowMapBytes); mapTexels: S*S
  // per light times the lights.
  virtual std::size_t frameBytes(const RenderOptions& opt, std::size_t mapTexels) const {
    return mapTexels * bytesPerTexel(opt);
  }
  // Technique statistics of the last frame, for the report (Frame::stats).
  virtual std::vector<std::pair<std::string, double>> frameStats() const { return {}; }
};

// One implementation per technique (src/shadows_*.cpp), dispatched in src/shadows.cpp; None has
// no pass (nullptr).
std::unique_ptr<ShadowPass> makeShadowPass(ShadowTechnique t);

// Orthographic frame of a point light in direction `dir`, fitted to the oriented box of the area
// light `area`'s own frame (which holds the whole scene): brute force's and area approximation's
// one map per light sample. size > 0: the grid is shifted by (jx, jy) texels of a size x size map,
// with a texel of margin each side so the shift keeps the box inside (src/shadows_brute.cpp).
pb_light sampleFrame(const pb_light& area, const std::array<float, 3>& dir, int size = 0,
                     float jx = 0.0f, float jy = 0.0f);
bool techniqueAvailable(ShadowTechnique t);
std::unique_ptr<ShadowPass> makeMSSM4Pass();
std::unique_ptr<ShadowPass> makeMSSM6Pass();
std::unique_ptr<ShadowPass> makeCSSMPass();
std::unique_ptr<ShadowPass> makeHardPass(), makePCSSPass(), makeBrutePass();
std::unique_ptr<ShadowPass> makeBitmaskPass(bool hard);  // src/shadows_bitmask.cpp

// Filterable maps: `count` images of S x S long4 texels, image i at element i * stride.
// prefilterStride: elements one image needs for the prefilter (S*S for a SAT; more for a mip
// pyramid, whose levels follow level 0). prefilter() turns raw texels (level 0) into the
// filterable form in place. Kernels select the matching FILTER_BOX with prefilterOption().
bool prefilterAvailable(Prefilter p);
std::size_t prefilterStride(Prefilter p, int size);
void prefilter(Context& ctx, cl::Buffer& maps, Prefilter p, int size, int count,
               const std::string& stage);
std::string prefilterOption(Prefilter p);

// The orthographic frame of a directional light fitted to a box, and its view for the rasterizer.
pb_light lightFrame(const std::array<float, 3>& direction, float cosAlpha,
                    const std::array<float, 3>& radiance, const Bounds& bounds);
pb_view orthoView(const pb_light& light, int size);

}  // namespace penumbra::detail
