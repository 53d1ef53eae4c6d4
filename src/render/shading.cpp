// The shading stage: the light set's ambient and polygon vertices in the layouts shade.cl reads,
// and its launch.
#include "render/shading.hpp"

#include <vector>

#include "core/device_kind.hpp"
#include "lights/light_buffers.hpp"

namespace penumbra::detail {

namespace {
// Pixels per work-item of shade_batch. Each work-item reads its pixels' row of the visibility
// buffer for every light (lights x pixels floats, one row a light): 256 pixels make 1 KiB runs,
// which the prefetcher follows, where 64 made 256-byte ones that mostly missed (the 32-light frame's
// `shade` stage 17 -> 14 ms; 1024 measured the same as 256; bench/results/cpu_speed.md).
constexpr int kShadeGroup = 256;
}  // namespace

cl::Buffer shade(Context& ctx, BufferPool& pool, const ShadeInputs& in, const LightSet& lightSet,
                 const Environment& env, const RenderOptions& opt) {
  const int npx = opt.width * opt.height, nl = int(lightSet.lights.size());
  cl::Buffer outB = pool.buffer("frame", std::size_t(npx) * 16);
  // CPU devices: shade_batch, kShadeGroup pixels per work-item with SIMD loops over the lights
  // (kernels/render/shade.cl); the same bits as shade.
  const bool batched = useCpuBatching(ctx);
  cl::Kernel k = batched ? ctx.kernel("shade.cl", "shade_batch",
                                      cpuFormOptions(ctx, "SHADE_GROUP", kShadeGroup))
                         : ctx.kernel("shade.cl", "shade");
  std::size_t wg = batched ? 1 : ctx.workGroupSize(k, 64);
  const std::size_t items = batched ? cpuFormItems(std::size_t(npx), kShadeGroup)
                                    : (std::size_t(npx) + wg - 1) / wg * wg;
  // The ambient residual, added unshadowed (zeros when the light set has none).
  std::vector<cl_float4> amb(9, cl_float4{{0, 0, 0, 0}});
  for (int i = 0; i < 9 && lightSet.hasAmbient; ++i)
    for (int c = 0; c < 3; ++c) amb[i].s[c] = lightSet.ambientSH[i][c];
  cl::Buffer ambB = pool.upload("ambient SH", amb);
  // Polygon lights' vertices (src/lights/light_buffers.hpp); the shading uses the polygon's
  // exact irradiance (shared.h).
  cl::Buffer polyB =
      pool.upload("polygon light vertices", polygonVertexBlocks(lightSet.lights));
  // The ambient's irradiance map when it has one (else amap_w = 0: the SH9 above).
  const bool amap = lightSet.hasAmbient && !lightSet.ambientMap.empty();
  if (amap) lightSet.ambientMap.check();
  cl::Buffer amapB = pool.upload("ambient irradiance map",
                                 amap ? lightSet.ambientMap.rgb : std::vector<float>(3, 0.0f));
  const DeviceGBuffer& g = in.gbuffer;
  ctx.launchWith("shade", k, cl::NDRange(items), batched ? cl::NullRange : cl::NDRange(wg), g.position,
                 g.normal, g.albedo, in.lights, cl_int(nl), in.visibility, cl_int(npx), in.camera,
                 in.environment, cl_int(env.equirect.width), cl_int(env.equirect.height),
                 cl_float(env.rotationColumns()), cl_int(opt.environmentBackground ? 1 : 0), outB,
                 ambB, polyB, amapB, cl_int(amap ? lightSet.ambientMap.width : 0),
                 cl_int(amap ? lightSet.ambientMap.height : 0), in.bent.vert, in.bent.weight,
                 in.bent.bend, cl_int(opt.bentNormals && nl > 0 ? 1 : 0),
                 cl_float(opt.bentNormalsScale));
  return outB;
}

}  // namespace penumbra::detail
