/// \file
/// The GL interop API: an application that draws with OpenGL hands penumbra its own textures (one
/// depth texture per light, the camera G-buffer) and gets the shaded frame back in a GL texture.
///
/// Per frame (the application's GL context current on the calling thread):
///   1. views = interop.lightViews(lights, sceneBounds, S): each light's orthographic shadow-map
///      frame (penumbra's, fitted to the bounds) as GL view and projection matrices. Rasterize the
///      scene into one S x S depth texture per light with them (depth test on, glDepthRange 0..1,
///      cleared to 1, no culling): window depth = distance from the map's near plane / range.
///   2. Rasterize the camera G-buffer (W x H) with the camera of penumbra's Camera (any projection
///      that puts the same pixels where penumbra's camera does: scene.hpp's cameraBasis).
///   3. interop.shade(depthTextures, gbuffer, output, camera, lights, bounds, env, options):
///      visibility with options.shadows in OpenCL (prefiltering etc.), then shading by a GL
///      fragment shader into `output` (RGBA32F or RGBA16F, W x H: radiance, alpha 1 on geometry).
///      The formula equals kernels/render/shade.cl's. When shade() returns, `output` is complete.
/// shade() restores the draw framebuffer, viewport, program, vertex array, active texture unit,
/// depth test and blending it found; it changes the GL_TEXTURE_2D / GL_TEXTURE_2D_ARRAY bindings of
/// texture units 0-6, uniform-buffer binding point 0 and the pixel pack/unpack alignment (4). Wrong
/// formats or sizes throw Error(BadInput) naming the texture, before anything is drawn.
///
/// Transfers: zero-copy through cl_khr_gl_sharing needs an OpenCL context created against the GL
/// context; penumbra's Context is not (and PoCL has no GL sharing), so every frame takes the
/// explicit host-copy path: glGetTexImage -> clEnqueueWriteBuffer in, clEnqueueReadBuffer ->
/// glTexSubImage3D out. Its cost is reported as the stages interop/upload and interop/download.
///
/// Thread safety: an Interop or GLRenderer belongs to the thread whose GL context was current when
/// it was made: GL contexts are current on one thread at a time, and the GL names it holds live in
/// that context. Use it only from that thread, with that context current; never from two threads.
/// Its OpenCL Context may be shared with other threads and renderers (context.hpp).
#pragma once
#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "penumbra/gl/context.hpp"
#include "penumbra/lights.hpp"
#include "penumbra/renderer.hpp"
#include "penumbra/scene.hpp"

namespace penumbra {
class Context;
struct Environment;
}  // namespace penumbra

namespace penumbra::gl {

using TextureId = std::uint32_t;  ///< a GL texture name (GLuint), GL_TEXTURE_2D

struct LightView {
  std::array<float, 16> view{};        ///< world -> light eye space (column-major, as GL takes it)
  std::array<float, 16> projection{};  ///< orthographic, eye -> clip: near plane 0, far = range
  float range = 0;                     ///< world distance the depth range [0, 1] spans
  int size = 0;                        ///< S: the depth texture is S x S
};

struct GBuffer {
  TextureId position = 0;         ///< RGBA32F (or RGBA16F): world position, alpha 1 on geometry and
                                  ///< 0 on the background
  TextureId normal = 0;           ///< RGBA32F/RGBA16F: unit shading normal facing the camera
  TextureId albedo = 0;           ///< RGBA8, RGBA16F or RGBA32F: diffuse albedo in rgb
  TextureId geometricNormal = 0;  ///< optional, as `normal`; 0: the shading normal stands in (used
                                  ///< by hard, PCSS and CSSM for receiver-plane tests, and to lift
                                  ///< positions off their surface where shadow tests start: README,
                                  ///< "Where shadow tests start")
};

class Interop {
 public:
  /// Binds to the GL context current on this thread (loader: its GL functions; nullptr: the
  /// current EGL or OSMesa context's). Throws Error(NoPlatform) if there is none.
  explicit Interop(Context& cl, ProcLoader loader = nullptr);
  ~Interop();
  Interop(const Interop&) = delete;
  Interop& operator=(const Interop&) = delete;

  /// Each light's shadow-map frame (the one Renderer uses), for depth textures of size x size.
  std::vector<LightView> lightViews(const LightSet& lights, const Bounds& bounds,
                                    int size) const;

  /// One frame; see the top of this file. opt.shadows may be none, hard, pcss, cssm, mssm4,
  /// mssm6, or auto with opt.autoChoice.exactLights 0 (the others, and auto's exact lights,
  /// rasterize more maps from the scene's triangles, which the interop does not have);
  /// opt.width/height/shadowMapSize are taken from the textures. Cap and polygon lights
  /// (a polygon's visibility is its bounding cap's, its irradiance exact, as in Renderer).
  /// opt.shadow.contactShadows is ignored: contact shadows cast rays against the scene's
  /// triangles, which the interop does not have, so its frames have none. `ground`: the scene's
  /// ground for opt.shadow.groundVisibility (findGround(scene) for a penumbra Scene; the
  /// application's own ground plane otherwise); without one the frame has no ground step.
  void shade(const std::vector<TextureId>& depthMaps, const GBuffer& gbuffer, TextureId output,
             const Camera& camera, const LightSet& lights, const Bounds& bounds,
             const Environment& env, const RenderOptions& opt,
             const std::optional<GroundPlane>& ground = std::nullopt);

  /// Visibility of the last shade(), light-major, rows top-down (as Renderer::lastVisibility).
  std::vector<float> lastVisibility();
  /// Wall-clock milliseconds of the last shade() by stage: interop/upload (GL -> host -> device),
  /// interop/convert, interop/download (device -> host -> GL), gl/shade (fragment shader, with
  /// glFinish), plus the OpenCL visibility stages' device times.
  const std::vector<std::pair<std::string, double>>& timingsMs() const;
  /// The last shade()'s statistics, as Frame::stats (e.g. auto's choice per light).
  const std::vector<std::pair<std::string, double>>& stats() const;
  bool zeroCopy() const { return false; }  // see "Transfers" above

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// `penumbra render --gl`: the whole frame with GL rasterizing the shadow maps and the camera
/// G-buffer from the scene's triangles, OpenCL computing visibility, GL shading (through
/// Interop). Needs a current GL context (a HeadlessContext). Frame::timingsMs holds gl/scene,
/// gl/gbuffer, gl/shadow-maps, interop/*, the visibility stages, gl/shade, gl/readback and total.
class GLRenderer {
 public:
  explicit GLRenderer(Context& cl, ProcLoader loader = nullptr);
  ~GLRenderer();
  Frame render(const Scene& scene, const Camera& camera, const LightSet& lights,
               const Environment& env, const RenderOptions& opt);
  Interop& interop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace penumbra::gl
