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

enum class ShadowTechnique {
  None,   // no shadows (every light fully visible)
  Hard,   // one shadow map at the light's centre, one depth test
  PCSS,   // percentage-closer soft shadows by explicit sampling (Fernando 2005)
  CSSM,   // convolution soft shadow maps, Fourier basis (seed 000)
  MSSM4,  // moment soft shadow mapping, 4 moments (seed 003 §3.2.1)
  MSSM6,  // 6 moments (seed 003 §4.2.1)
  Brute,  // K point-sample shadow maps per area light, averaged (seed 000 Fig. 11d)
};
// "none" | "hard" | "pcss" | "cssm" | "mssm4" | "mssm6" | "brute"
ShadowTechnique parseShadowTechnique(const std::string& name);
const char* toString(ShadowTechnique t);

// How the filtered techniques (CSSM, MSSM4, MSSM6) prefilter their maps (seed 000 Fig. 8).
enum class Prefilter { SAT, Mip };
Prefilter parsePrefilter(const std::string& name);  // "sat" | "mip"
const char* toString(Prefilter p);

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
  // Upper-bound blocker depth (seed 003 §4.2.2, eq. 19): weights of atoms at the receiver's depth
  // clamped to [delta1, delta2]; shadows harden rather than vanish under complex depth.
  bool upperBoundBlocker = false;
  float delta1 = 1e-3f, delta2 = 0.1f;
};

// Convolution soft shadow maps (seed 000 §3).
struct CSSMOptions {
  int order = 4;                // Fourier order M: terms k = 1..M, c_k = pi (2k - 1) (appendix)
  float sharpenA = 30.0f;       // adaptive sharpening p = 1 + A exp(-B (d - z_avg)) (eq. 9); 0: off
  float sharpenB = 10.0f;       // per unit of normalized depth
};

// Percentage-closer soft shadows (Fernando 2005; seed 003 eqs. 4-6 by explicit sampling).
struct PCSSOptions {
  int blockerTaps = 16;         // samples of the blocker search
  int filterTaps = 32;          // samples of the percentage-closer filter
};

// Brute force: K point lights spread over each area light's cap, one hard shadow map each.
struct BruteOptions {
  int samples = 64;             // K per light
};

struct RenderOptions {
  int width = 640, height = 360;
  int shadowMapSize = 256;      // square shadow map per light, texels
  ShadowTechnique shadows = ShadowTechnique::MSSM4;
  Prefilter prefilter = Prefilter::SAT;
  // Depth maps average the front- and back-facing surfaces' depths (seed 003 §4.2.3) instead of
  // keeping the nearest surface; for closed casters, it removes the need for a depth bias.
  bool frontBackFaces = false;
  MSSMOptions mssm;             // also used by MSSM6; bias, light size and filter limits by all
  CSSMOptions cssm;
  PCSSOptions pcss;
  BruteOptions brute;
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
