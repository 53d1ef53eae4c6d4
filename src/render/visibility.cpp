// The visibility stage: the technique cache, the visibility buffer and the frame's report.
#include "render/visibility.hpp"
#include "render/contact.hpp"
#include "render/horizon.hpp"
#include "shadows/shadow_options.hpp"

#include <algorithm>
#include <cstdlib>
#include <cstring>

namespace penumbra::detail {

void Visibility::begin(const ShadowOptions& shared, ShadowTechnique t, int pixels, int lights) {
  // The settings every technique reads, checked here because the renderer and the GL interop
  // both come through this stage; each technique checks its own struct in its pass.
  validate(shared);
  const std::size_t bytes =
      std::max<std::size_t>(1, std::size_t(pixels) * std::max(lights, 1)) * 4;
  vis_ = pool_.buffer("visibility buffer", bytes);
  pixels_ = pixels;
  lights_ = lights;
  if (!pass_ || passKind_ != t) {
    pass_ = makeShadowPass(t);
    passKind_ = t;
  }
  bytes_ = 0;
  std::lock_guard<std::mutex> lock(statsMutex_);
  steps_.clear();
  stats_.clear();
  statsPending_ = false;
}

const std::vector<std::pair<std::string, double>>& Visibility::stats() const {
  std::lock_guard<std::mutex> lock(statsMutex_);
  if (statsPending_) {
    stats_ = pass_->frameStats();
    stats_.insert(stats_.end(), steps_.begin(), steps_.end());
    statsPending_ = false;
  }
  return stats_;
}

void Visibility::compute(ShadowFrame& f) {
  f.vis = vis_;
  // The horizon step below runs for every map-shadowed light (the mask's), which are the only
  // lights a pass filters through a map. PENUMBRA_HORIZON_SKIP=off (exactly) has the pass filter
  // those pairs anyway: the same images, a check (tests/test_horizon.cpp).
  const char* skip = std::getenv("PENUMBRA_HORIZON_SKIP");
  f.horizonRewrites = f.opt.shadow.horizonVisibility && !(skip && std::strcmp(skip, "off") == 0);
  if (runsPass()) {
    pass_->computeVisibility(f);
    bytes_ = pass_->frameBytes(f.opt, std::size_t(f.mapSize) * f.mapSize * lights_);
    std::vector<std::pair<std::string, double>> steps;
    // The lights whose visibility came from a map: contact.cl's occluders a map cannot resolve,
    // then horizon.cl's lights on the horizon. The techniques that test triangles themselves (the
    // bitmask's) need neither.
    const bool horizon = f.opt.shadow.horizonVisibility;
    const bool contact = f.opt.shadow.contactShadows && hasContactInputs(f);
    const bool ground = f.opt.shadow.groundVisibility && f.ground.present;
    if (horizon || contact || ground) {
      std::vector<cl_uchar> mask(std::size_t(lights_), 0);
      int groundLights = 0;
      int n = 0;
      bool contactMaps = false;
      for (int l = 0; l < lights_; ++l) n += mask[std::size_t(l)] = pass_->lightFromShadowMap(l);
      if (n > 0) {
        // Uploaded only when it changes (a blocking write would wait for the pass every frame).
        if (mask != mapMask_) {
          mapMaskBuffer_ = pool_.upload("map-visibility lights", mask);
          mapMask_ = mask;
        }
        if (contact) {
          contactShadows(f, mapMaskBuffer_);
          // where the frame's maps were drawn with ids (none for a technique that reads no
          // frame maps, nor with front/back maps)
          if (f.opt.shadow.contactFromMaps && f.mapIds()) {
            contactFromMaps(f, mapMaskBuffer_);
            contactMaps = true;
          }
        }
        // after contact shadows, so that the sources it reads are final
        if (horizon) horizon_.run(f, mapMaskBuffer_);
        // last: it scales the final value of each pair
        if (ground) groundLights = ground_.run(f, mapMaskBuffer_);
      }
      if (horizon) steps.emplace_back("horizon/lights", double(n));
      if (contact) steps.emplace_back("contact/lights", double(n));
      if (contactMaps) steps.emplace_back("contact/map_lights", double(n));
      if (ground) steps.emplace_back("ground/lights", double(groundLights));
    }
    // stats() builds the statistics when asked, after the frame's later stages are queued
    std::lock_guard<std::mutex> lock(statsMutex_);
    steps_ = std::move(steps);
    stats_.clear();
    statsPending_ = true;
  } else if (lights_ > 0) {
    const cl_float one = 1.0f;
    ctx_.fill(vis_, &one, 4, std::size_t(pixels_) * lights_ * 4, "visibility buffer");
  }
}

std::vector<float> Visibility::download() {
  return ctx_.download<float>(vis_, std::size_t(pixels_) * lights_, "visibility");
}

}  // namespace penumbra::detail
