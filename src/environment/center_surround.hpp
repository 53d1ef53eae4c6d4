// Internal: a look inside the center-surround extraction (center_surround.cpp) for the
// tests, which compare the device's filter responses with a brute-force loop.
#pragma once
#include <vector>

#include "penumbra/context.hpp"
#include "penumbra/environment.hpp"
#include "penumbra/extraction.hpp"

namespace penumbra::detail {

struct CenterSurroundProbe {
  int width = 0, height = 0;              // working equirect grid
  std::vector<float> lumEnergy;           // luminance x texel solid angle, width*height, row-major
  std::vector<int> candidates;            // working-grid texel indices, ascending
  std::vector<float> responses;           // candidates.size() x sizes: normalized responses
  std::vector<double> innerRadius, outerRadius;  // per size, radians
};

// Validates opt, resamples env to the working grid, selects the candidates and evaluates every
// filter size at every candidate, as the first iteration of extractCenterSurround does.
CenterSurroundProbe centerSurroundProbe(Context& ctx, const Environment& env,
                                        const CenterSurroundOptions& opt);

}  // namespace penumbra::detail
