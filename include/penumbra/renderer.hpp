// The frame: environment -> lights -> shadow maps -> moments -> SATs -> visibility -> shading.
//
// Usage: build a Renderer on a Context once, call render() per frame with the scene, camera and
// light set (extract the lights with extractMedianCut, or pass your own). Buffers are reused
// between frames of the same sizes. The returned Frame is complete when render() returns.
#pragma once
#include <array>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "penumbra/image.hpp"
#include "penumbra/lights.hpp"
#include "penumbra/scene.hpp"

namespace penumbra {

class Context;
struct Environment;

enum class ShadowTechnique { None, MSSM4 };
ShadowTechnique parseShadowTechnique(const std::string& name);  // "none" | "mssm4"
const char* toString(ShadowTechnique t);

// Moment soft shadow mapping with 4 moments (seed 003 §3.2.1). Distances are in shadow-map texels
// or normalized light-space depth (0 at the map's near plane, 1 at its far plane).
struct MSSMOptions {
  float momentBias = 3e-5f;     // blend of the filtered moments towards those of the uniform
                                // distribution (kernels/moments.cl). Larger: more light leaking
  float depthBias = 0.002f;     // subtracted from the receiver depth (normalized depth units)
  float slopeBias = 0.0f;       // extra depth bias: this times the filter radius times the
                                // receiver's depth slope. Off by default: it hides real blockers
                                // near tilted receivers; measured relative RMSE vs Embree over the
                                // built-in scene, Wuson/courtyard and spider/interior: mean 6.2% at
                                // 0, 6.4% at 0.5, 8.6% at 1.5 (README, "Measuring")
  float lightSizeScale = 1.0f;  // multiplies every light's angular size for the filter widths
  float maxFilterTexels = 27.0f;// largest filter width in texels (seed 003 §6.2 used 27 at 256^2)
  float minFilterTexels = 1.0f; // smallest filter width in texels
  float blockerEpsilon = 1e-3f; // epsilon of seed 003 eq. 7 (pulls z_avg towards the receiver)
};

struct RenderOptions {
  int width = 640, height = 360;
  int shadowMapSize = 256;      // square shadow map per light, texels
  ShadowTechnique shadows = ShadowTechnique::MSSM4;
  MSSMOptions mssm;
  bool environmentBackground = true;  // show the environment behind the geometry (alpha stays 0)
};

struct Frame {
  Image image;  // RGBA linear radiance; alpha 1 on geometry, 0 on background
  // Device time per stage since the Context's last resetTimings() (so a caller that resets before
  // extracting lights sees extraction and rendering together), plus "total": render()'s wall clock.
  std::vector<std::pair<std::string, double>> timingsMs;
  std::size_t shadowMapBytes = 0;  // device bytes of the filterable shadow maps (SATs)
};

class Renderer {
 public:
  explicit Renderer(Context& ctx);
  ~Renderer();
  Frame render(const Scene& scene, const Camera& camera, const LightSet& lights,
               const Environment& env, const RenderOptions& opt);
  // Visibility of each light at each pixel (light-major, width*height per light) from the last
  // render(), read back on demand. Background pixels hold 1, and so do pixels whose surface
  // has the light wholly below its horizon (their visibility is never used, so never computed).
  std::vector<float> lastVisibility();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Writes a JSON report of a render: device, lights, sanitized pixels, timings and options.
std::string renderReportJson(const std::string& device, const LightSet& lights,
                             const Environment& env, const RenderOptions& opt, const Frame& f);

}  // namespace penumbra
