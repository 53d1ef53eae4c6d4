// Internal: the greedy fit of seed 000 §4.2 on a device cube of fixed-point energies
// (kernels/greedy.cl), below the public extractGreedy(). Exposed for tests/test_greedy.cpp, which
// checks it against a plain C++ copy of the algorithm.
#pragma once
#include <array>
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
constexpr int kGreedyMaxPerFace = 16384;

// Runs greedy_fit on `energy` (3 planes of 6*m*m cl_long, replaced by the remaining map). Lights
// in face order, then fitting order.
std::vector<GreedyRect> greedyFit(Context& ctx, cl::Buffer& energy, int m, float threshold,
                                  bool square);

}  // namespace penumbra::detail
