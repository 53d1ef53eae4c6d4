/// \file
/// The frame, stage by stage (src/render/): scene on the device -> camera G-buffer -> bent normals
/// -> the lights' shadow maps and the technique's visibility -> shading.
///
/// Usage: build a Renderer on a Context once, call render() per frame with the scene, camera and
/// light set (extract the lights with extractMedianCut, or pass your own). Buffers are reused
/// between frames of the same sizes; the scene and the environment map stay on the device and are
/// uploaded again only when they change. The returned Frame is complete when render() returns.
///
/// Thread safety: a Renderer may be shared by threads: render() and lastVisibility() take a mutex,
/// so concurrent calls run one after another and each returns exactly what it would alone (a
/// Renderer's buffers, kernels and last visibility are one frame's state, and the device runs one
/// command at a time on the Context's queue anyway, so a lock costs no device parallelism).
/// lastVisibility() is that of the last render() by any thread. For frames whose host work (scene
/// upload, light frames) overlaps, give each thread its own Renderer: any number of Renderers may
/// share one Context (context.hpp, "Thread safety"). The Scene, LightSet and Environment passed to
/// render() are only read, and may be shared by threads that do not modify them meanwhile.
#pragma once
#include <array>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "penumbra/image.hpp"
#include "penumbra/lights.hpp"
#include "penumbra/options.hpp"
#include "penumbra/scene.hpp"

namespace penumbra {

class Context;
struct Environment;

struct Frame {
  Image image;  ///< RGBA linear radiance; alpha 1 on geometry, 0 on background
  /// Device time per stage since the Context's last resetTimings() (so a caller that resets before
  /// extracting lights sees extraction and rendering together), plus "total": render()'s wall clock.
  std::vector<std::pair<std::string, double>> timingsMs;
  std::size_t shadowMapBytes = 0;  ///< device bytes of the filterable shadow maps (SATs); for
                                   ///< bitmask: list grid, lists and masks
  /// Technique statistics (bitmask: list_size, view_samples, list_texels, occupied_texels,
  /// mean_list_length, max_list_length of Sintorn et al. 2008 Figure 9), empty for the others.
  std::vector<std::pair<std::string, double>> stats;
};

class Renderer {
 public:
  explicit Renderer(Context& ctx);
  ~Renderer();
  Frame render(const Scene& scene, const Camera& camera, const LightSet& lights,
               const Environment& env, const RenderOptions& opt);
  /// Visibility of each light at each pixel (light-major, width*height per light) from the last
  /// render(), read back on demand. Background pixels hold 1, and so do pixels whose surface
  /// has the light wholly below its horizon (their visibility is never used, so never computed).
  std::vector<float> lastVisibility();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// What a report says about how the frame was asked for (the caller knows it; the renderer does
/// not): the command line and the input files, "" for a built-in default or an extracted set.
struct ReportInfo {
  std::vector<std::string> command;  ///< argv as run (the CLI) or e.g. {"python", ...}
  std::string scene, environment, lightSet;
};

/// The JSON report of a render (UTF-8, valid JSON whatever the names hold): penumbra's version,
/// the command and inputs (when given), device, lights, sanitized pixels, timings, the shared
/// shadow options ("shadow") and the option block of each technique used ("mssm" for mssm4 and
/// mssm6, "cssm", "pcss", "brute", "bitmask" for bitmask and bitmask-hard, "area_approx"; `auto`
/// adds "auto" and the blocks of the techniques it picked; hard and none have none).
std::string renderReportJson(const std::string& device, const LightSet& lights,
                             const Environment& env, const RenderOptions& opt, const Frame& f,
                             const ReportInfo& info = {});

}  // namespace penumbra
