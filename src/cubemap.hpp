// Internal: the environment map resampled to a cube of fixed-point energies on the device, shared
// by light extraction and the public cubeMapEnergy().
#pragma once
#include "penumbra/context.hpp"
#include "penumbra/environment.hpp"

namespace penumbra::detail {

struct DeviceCube {
  cl::Buffer energy;  // 3 planes (R, G, B) of 6*m*m cl_long: energy x scale
  double scale = 1;   // fixed-point units per unit of radiance x steradian
  int faceSize = 0;
};

DeviceCube resampleToCube(Context& ctx, const Environment& env, int faceSize, int supersample);

}  // namespace penumbra::detail
