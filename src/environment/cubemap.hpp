// Internal: the environment map resampled to a cube of fixed-point energies on the device, shared
// by light extraction and the public cubeMapEnergy().
#pragma once
#include "penumbra/context.hpp"
#include "penumbra/environment.hpp"

namespace penumbra::detail {

struct DeviceCube {
  Context::ScratchLease lease;  // holds `energy` for this cube's user (Context::scratch)
  cl::Buffer energy;  // 3 planes (R, G, B) of 6*m*m cl_long: energy x scale
  double scale = 1;   // fixed-point units per unit of radiance x steradian
  int faceSize = 0;
};

// The cube lives in the context's scratch buffer "cube-map energy" (Context::scratch), leased to
// the returned DeviceCube: valid while it lives. splatStrip: equirect texels per work-item along a row when
// splatting (kernels/environment/envmap.cl env_splat); any value gives the same bits. Measured on
// the 1024x512 built-in map, 2-core CPU through PoCL, env/resample ms at face 64 / 256: strip 1:
// 8.2-10.3 / 22.1-22.4, 4: 6.2-6.9 / 20.0-20.5, 16: 5.4-6.2 / 18.3-18.7, 64: 5.1-5.5 / 17.6-17.8.
// 16 keeps W/16 x H work-items (32K here) for devices that want many; 64 would gain another 5% on
// this CPU.
DeviceCube resampleToCube(Context& ctx, const Environment& env, int faceSize, int supersample,
                          int splatStrip = 16);

}  // namespace penumbra::detail
