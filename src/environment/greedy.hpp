// Internal: the greedy fit of Annen et al. 2008 §4.2 on a device cube of fixed-point energies
// (kernels/environment/greedy.cl), below the public extractGreedy(). Exposed for
// tests/test_greedy.cpp, which checks it against a plain C++ copy of the algorithm.
#pragma once
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "penumbra/context.hpp"

namespace penumbra::detail {

struct GreedyRect {
  int face = 0, x0 = 0, y0 = 0, x1 = 0, y1 = 0;  // texels [x0,x1) x [y0,y1)
  std::array<std::int64_t, 4> removed{};         // fixed-point energy taken: R, G, B, luminance Y
  std::array<std::int64_t, 3> moment{};          // sum of Y * unit direction over the taken energy
};

// Most lights a face may receive: m^2 (each light covers at least one new texel) up to this.
// Reached in practice: on the built-in sky at t = 0.02 the square fit of a 512^2 face stops here
// with 24-54% of its texels covered. A texel dimmer than the face's mean gives nothing when
// covered, so where the map is dim it does not change, and each new seed beside a light regrows
// nearly the same ~100-texel square, covering a few new texels (measured with the reference of
// tests/test_greedy.cpp: about 100 growth steps and 10^4 texels per light, 4-9 of them new).
constexpr int kGreedyMaxPerFace = 16384;

// Runs greedy_fit on `energy` (3 planes of 6*m*m cl_long, replaced by the remaining map). Lights
// in face order, then fitting order. `workGroupSize` (a power of two; 0: the device's best) does
// not change the result; tests vary it.
std::vector<GreedyRect> greedyFit(Context& ctx, cl::Buffer& energy, int m, float threshold,
                                  bool square, std::size_t workGroupSize = 0);

}  // namespace penumbra::detail
