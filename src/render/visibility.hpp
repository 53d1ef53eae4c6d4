// Internal: the visibility stage, shared by the OpenCL renderer (src/render/renderer.cpp) and the
// GL interop (src/gl/interop.cpp). It keeps the shadow technique's pass between frames, owns the
// visibility buffer (float [light][pixel], 1 = unshadowed) and what the pass reports about the
// frame (device bytes, statistics).
#pragma once
#include <cstddef>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "penumbra/context.hpp"
#include "penumbra/options.hpp"
#include "render/ground.hpp"
#include "render/horizon.hpp"
#include "shadows/shadow_pass.hpp"

namespace penumbra::detail {

class Visibility {
 public:
  Visibility(Context& ctx, BufferPool& pool)
      : ctx_(ctx), pool_(pool), horizon_(pool), ground_(pool) {}

  // Starts a frame of `pixels` x `lights` with technique t: sizes the visibility buffer and
  // makes the technique's pass unless the last frame's was the same technique. Passes hold what
  // depends only on their options (the bitmask's light samples and look-up tables), not on the
  // frame, so keeping them saves that work. Throws Error(BadInput) naming the field for shared
  // settings out of range (both the renderer and the GL interop start here).
  void begin(const ShadowOptions& shared, ShadowTechnique t, int pixels, int lights);
  // Whether compute() will run a pass (lights and a technique other than None), and whether
  // that pass reads the lights' shadow maps (ShadowFrame::depth).
  bool runsPass() const { return lights_ > 0 && pass_; }
  bool readsShadowMaps() const { return runsPass() && pass_->usesShadowMaps(); }
  // The visibility of every light at every pixel into buffer(): the pass on `f` (its `vis` is
  // set here), or 1 everywhere without one. f.mapSize S gives the report's S*S texels per light.
  void compute(ShadowFrame& f);

  const cl::Buffer& buffer() const { return vis_; }
  // The last frame's device bytes of the technique (Frame::shadowMapBytes) and its statistics
  // (Frame::stats), with "horizon/lights" and "contact/lights", the lights whose visibility a
  // map gave, when those steps ran, and "ground/lights", the lights that reach below the
  // horizontal, when the ground step ran; 0 and none when no pass ran.
  std::size_t frameBytes() const { return bytes_; }
  // The pass's statistics are asked for here, not in compute(), so that a pass may leave a
  // read-back queued behind the frame's later stages (the bitmask's list lengths).
  const std::vector<std::pair<std::string, double>>& stats() const;
  // The last frame's visibility read back, light-major (Renderer::lastVisibility).
  std::vector<float> download();

 private:
  Context& ctx_;
  BufferPool& pool_;
  std::unique_ptr<ShadowPass> pass_;  // nullptr for ShadowTechnique::None
  ShadowTechnique passKind_ = ShadowTechnique::None;
  cl::Buffer vis_;
  int pixels_ = 0, lights_ = 0;
  std::vector<cl_uchar> mapMask_;  // the lights whose visibility a map gave, as last uploaded
  cl::Buffer mapMaskBuffer_;
  Horizon horizon_;  // lights on the horizon (render/horizon.hpp)
  GroundOcclusion ground_;  // the ground's occlusion of low lights (render/ground.hpp)
  std::size_t bytes_ = 0;
  std::vector<std::pair<std::string, double>> steps_;  // the horizon, contact and ground counts
  mutable std::mutex statsMutex_;
  mutable bool statsPending_ = false;  // stats_ still to be built from pass_ and steps_
  mutable std::vector<std::pair<std::string, double>> stats_;
};

}  // namespace penumbra::detail
