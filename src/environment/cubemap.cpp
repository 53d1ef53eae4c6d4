// Environment map -> cube map of radiant energy on the device (kernels/environment/envmap.cl).
#include "environment/cubemap.hpp"

#include <algorithm>
#include <cmath>

#include "penumbra/error.hpp"

namespace penumbra {
namespace detail {

DeviceCube resampleToCube(Context& ctx, const Environment& env, int m, int supersample,
                          int splatStrip) {
  if (m < 1 || m > 4096) badInput("cube face size must be in [1, 4096], got " + std::to_string(m));
  if (splatStrip < 1) badInput("splat strip must be >= 1, got " + std::to_string(splatStrip));
  if (supersample < 1 || supersample > 64)
    badInput("supersample must be in [1, 64], got " + std::to_string(supersample));
  const Image& eq = env.equirect;
  if (eq.empty() || eq.channels != 3) badInput(env.source + ": environment has no RGB pixels");

  // Fixed-point scale: everything (4 pi x the brightest value) fits in 2^48, leaving room for the
  // exact luminance product (x 10^4 < 2^14) and for SAT sums below 2^63.
  float maxv = 0.0f;
  for (float v : eq.pixels) maxv = std::max(maxv, v);
  DeviceCube cube;
  cube.faceSize = m;
  cube.scale = maxv > 0 ? std::ldexp(1.0, 48) / (4.0 * 3.14159265358979323846 * maxv) : 1.0;

  // The map and the cube are the context's scratch buffers (Context::scratch): a caller may
  // extract every frame (render --frames --extract-each-frame, a list of maps, a program's own
  // loop), and allocating and first-touching them each time cost more than the kernels.
  const std::size_t bytes = 3ull * 6 * m * m * sizeof(cl_long);
  Context::ScratchLease eqLease =
      ctx.scratch("environment map", eq.pixels.size() * sizeof(float));
  cl::Buffer& eqBuf = eqLease.buffer();
  ctx.write(eqBuf, eq.pixels.data(), eq.pixels.size() * sizeof(float), "environment map");
  cube.lease = ctx.scratch("cube-map energy", bytes);
  cube.energy = cube.lease.buffer();

  // Splat when the map's texels are at least as fine as the cube's (equator texel 2 pi / W versus
  // face-centre texel (pi/2) / m), gather otherwise. Sub-samples per side: about two per
  // destination texel, capped by the option; more only smooths aliasing, energy is conserved
  // either way (exactly when splatting).
  const bool splat = eq.width >= 4 * m;
  const double ratio = splat ? 4.0 * m / eq.width : eq.width / (4.0 * m);
  const int ss = std::clamp(int(std::ceil(2.0 * ratio)), 1, supersample);
  if (splat) {
    // Tables of the separable sub-texel directions (kernels/environment/envmap.cl
    // env_splat_rows/_columns).
    const std::size_t nr = std::size_t(eq.height) * ss, nc = std::size_t(eq.width) * ss;
    Context::ScratchLease rowsLease = ctx.scratch("splat row table", nr * sizeof(cl_float4));
    Context::ScratchLease colsLease = ctx.scratch("splat column table", nc * sizeof(cl_float2));
    cl::Buffer &rows = rowsLease.buffer(), &cols = colsLease.buffer();
    cl::Kernel kr = ctx.kernel("envmap.cl", "env_splat_rows");
    ctx.launchWith("env/resample/rows", kr, cl::NDRange(nr), cl::NullRange, cl_int(eq.height),
                   cl_int(ss), cl_float(cube.scale), cl_int(eq.width), rows);
    cl::Kernel kc = ctx.kernel("envmap.cl", "env_splat_columns");
    ctx.launchWith("env/resample/columns", kc, cl::NDRange(nc), cl::NullRange, cl_int(eq.width),
                   cl_int(ss), cl_float(env.rotationColumns()), cols);
    cl_long zero = 0;
    ctx.fill(cube.energy, &zero, sizeof zero, bytes, "cube-map energy");
    const int strip = splatStrip;
    cl::Kernel k = ctx.kernel("envmap.cl", "env_splat");
    ctx.launchWith("env/resample", k, cl::NDRange((eq.width + strip - 1) / strip, eq.height),
                   cl::NullRange, eqBuf, rows, cols, cl_int(eq.width), cl_int(eq.height),
                   cl_int(ss), cl_int(strip), cl_int(m), cube.energy);
  } else {
    // The side faces' map columns (kernels/environment/envmap.cl env_gather_columns). Every cube
    // texel is written: no clearing.
    const std::size_t nc = 4ull * m * ss;
    Context::ScratchLease colsLease = ctx.scratch("gather column table", nc * sizeof(cl_int));
    cl::Buffer& cols = colsLease.buffer();
    cl::Kernel kc = ctx.kernel("envmap.cl", "env_gather_columns");
    ctx.launchWith("env/resample/columns", kc, cl::NDRange(nc), cl::NullRange, cl_int(eq.width),
                   cl_float(env.rotationColumns()), cl_int(ss), cl_int(m), cols);
    cl::Kernel k = ctx.kernel("envmap.cl", "env_gather");
    // 2 side-face pairs, 2 polar faces
    ctx.launchWith("env/resample", k, cl::NDRange(m, m, 4), cl::NullRange, eqBuf, cols,
                   cl_int(eq.width), cl_int(eq.height), cl_float(env.rotationColumns()), cl_int(ss),
                   cl_int(m), cl_float(cube.scale), cube.energy);
  }
  return cube;
}

}  // namespace detail

Image cubeMapEnergy(Context& ctx, const Environment& env, int faceSize, int supersample) {
  detail::DeviceCube cube = detail::resampleToCube(ctx, env, faceSize, supersample);
  const std::size_t n = 6ull * faceSize * faceSize;
  auto e = ctx.download<cl_long>(cube.energy, 3 * n, "cube-map energy");
  Image out(faceSize, 6 * faceSize, 3);
  for (std::size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) out.pixels[i * 3 + c] = float(double(e[c * n + i]) / cube.scale);
  return out;
}

}  // namespace penumbra
