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

// The cube lives in the context's scratch buffer "cube-map energy" (Context::scratch): valid until
// the next call on the same context. splatStrip: equirect texels per work-item along a row when
// splatting (kernels/envmap.cl env_splat); any value gives the same bits, 16 measured fastest
// with 8 and 64 within noise (bench/bench_extract BM_Resample ... on this CPU, PoCL).
DeviceCube resampleToCube(Context& ctx, const Environment& env, int faceSize, int supersample,
                          int splatStrip = 16);

}  // namespace penumbra::detail
