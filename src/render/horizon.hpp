// Internal: lights on the horizon (kernels/render/horizon.cl), the last step of the visibility
// stage for techniques that read shadow maps, after contact shadows.
#pragma once
#include <vector>

#include "shadows/shadow_pass.hpp"

namespace penumbra::detail {

// For every geometry pixel and every light l with lightMask[l] != 0 (uchar per light) whose cap
// straddles the pixel's horizon with its axis below it, replaces f.vis[l][pixel] by the mean
// visibility of the lights whose axis is above that horizon and within twice l's half-angle of the
// lit part's middle (1 with none). Reads f.gpos, f.gnrm, f.lightBuffer; writes f.vis. Keeps each
// light's list of candidate sources (the lights within 3a + 0.01 rad of its axis) between frames,
// uploaded again only when it changes (turning every light together keeps it).
class Horizon {
 public:
  explicit Horizon(BufferPool& pool) : pool_(pool) {}
  void run(const ShadowFrame& f, const cl::Buffer& lightMask);

 private:
  BufferPool& pool_;
  std::vector<int> offsets_, indices_;  // CSR as last uploaded
  cl::Buffer offsetsB_, indicesB_;
};

// The candidate sources of each light, as Horizon uploads them: offsets (lights + 1) into
// indices, each light's list in increasing index, the light itself left out. Exposed for the
// tests' reference.
void horizonCandidates(const std::vector<pb_light>& lights, std::vector<int>& offsets,
                       std::vector<int>& indices);

}  // namespace penumbra::detail
