// Shadow techniques by name, and the prefilter shared by the filtered ones.
#include "penumbra/error.hpp"
#include "penumbra/scan.hpp"
#include "shadows/shadow_pass.hpp"

namespace penumbra::detail {

std::unique_ptr<ShadowPass> makeAreaApproxPass();  // src/shadows/area.cpp
std::unique_ptr<ShadowPass> makeAutoPass();        // src/shadows/auto.cpp

std::unique_ptr<ShadowPass> makeShadowPass(ShadowTechnique t) {
  switch (t) {
    case ShadowTechnique::MSSM4: return makeMSSM4Pass();
    case ShadowTechnique::MSSM6: return makeMSSM6Pass();
    case ShadowTechnique::CSSM: return makeCSSMPass();
    case ShadowTechnique::Hard: return makeHardPass();
    case ShadowTechnique::PCSS: return makePCSSPass();
    case ShadowTechnique::Brute: return makeBrutePass();
    case ShadowTechnique::Bitmask: return makeBitmaskPass(false);
    case ShadowTechnique::BitmaskHard: return makeBitmaskPass(true);
    case ShadowTechnique::AreaApprox: return makeAreaApproxPass();
    case ShadowTechnique::Auto: return makeAutoPass();
    // further techniques: one case each
    default: return nullptr;
  }
}

bool techniqueAvailable(ShadowTechnique t) {
  switch (t) {
    case ShadowTechnique::None:
    case ShadowTechnique::Hard:
    case ShadowTechnique::PCSS:
    case ShadowTechnique::Brute:
    case ShadowTechnique::Bitmask:
    case ShadowTechnique::BitmaskHard:
    case ShadowTechnique::AreaApprox:
    case ShadowTechnique::Auto:
    case ShadowTechnique::CSSM:
    case ShadowTechnique::MSSM6:
    case ShadowTechnique::MSSM4: return true;
    // further techniques: one case each
    default: return false;
  }
}

bool prefilterAvailable(Prefilter p) { return p == Prefilter::SAT || p == Prefilter::Mip; }

namespace {

// The mip pyramid's levels, as kernels/shadows/filter.clh lays them out: n_k = ceil(S / 2^k) texels
// a side, k = 0 .. L-1, n_{L-1} = 1.
int mipLevelSize(int size, int k) { return ((size - 1) >> k) + 1; }
int mipLevels(int size) {
  int L = 1;
  while (mipLevelSize(size, L - 1) > 1) ++L;
  return L;
}

std::size_t roundUpTo(std::size_t v, std::size_t m) { return (v + m - 1) / m * m; }

// kernels/shadows/mip.cl's mip_build: levels src+1 .. src+depth of `count` images.
void launchMipBuild(Context& ctx, cl::Kernel& k, cl::Buffer& maps, int size, std::size_t stride,
                    int src, int depth, int count, int tile, const std::string& stage) {
  std::size_t n1 = roundUpTo(std::size_t(mipLevelSize(size, src + 1)), std::size_t(tile));
  ctx.launchWith(stage, k, cl::NDRange(n1, n1, std::size_t(count)), cl::NDRange(tile, tile, 1),
                 maps, cl_int(size), cl_ulong(stride), cl_int(src), cl_int(depth));
}

// Builds levels 1 .. L-1 from level 0, in launches of up to log2(tile) + 1 levels. The tile is the
// largest of 16, 8, 4, 2 whose square the device (and the built kernel) takes in one work-group:
// 16 (256 work-items, 8 KiB of local memory) builds a 256^2 or a 1024^2 map in two launches.
void mipPyramid(Context& ctx, cl::Buffer& maps, int size, int count, const std::string& stage) {
  if (size < 1 || count < 1)
    badInput("prefilter mip: size " + std::to_string(size) + " and count " +
             std::to_string(count) + " must be >= 1");
  const int L = mipLevels(size);
  if (L == 1) return;  // a 1 x 1 map is its own pyramid
  const std::size_t stride = prefilterStride(Prefilter::Mip, size);
  for (int tile = 16; tile >= 2; tile /= 2) {
    if (std::size_t(tile) * tile > ctx.info().maxWorkGroupSize) continue;
    cl::Kernel k = ctx.kernel("mip.cl", "mip_build", "-DMIP_TILE=" + std::to_string(tile));
    if (ctx.workGroupSize(k, std::size_t(tile) * tile) < std::size_t(tile) * tile) continue;
    int perLaunch = 1;
    while ((1 << (perLaunch - 1)) < tile) ++perLaunch;  // log2(tile) + 1
    for (int src = 0; src < L - 1;) {
      int depth = L - 1 - src < perLaunch ? L - 1 - src : perLaunch;
      launchMipBuild(ctx, k, maps, size, stride, src, depth, count, tile, stage);
      src += depth;
    }
    return;
  }
  badInput("prefilter mip: the device takes fewer than 4 work-items per work-group");
}

}  // namespace

std::size_t prefilterStride(Prefilter p, int size) {
  if (size < 1) return 0;
  if (p == Prefilter::SAT) return std::size_t(size) * size;
  std::size_t total = 0;  // (4 S^2 - 1) / 3 for S = 2^m: the pyramid adds a third
  for (int k = 0, L = mipLevels(size); k < L; ++k) {
    std::size_t n = std::size_t(mipLevelSize(size, k));
    total += n * n;
  }
  return total;
}

void prefilter(Context& ctx, cl::Buffer& maps, Prefilter p, int size, int count,
               const std::string& stage) {
  if (p == Prefilter::Mip) return mipPyramid(ctx, maps, size, count, stage + "/mip");
  summedAreaTable(ctx, maps, ScanType::Long4, size, size, count, stage + "/sat");
}

std::string prefilterOption(Prefilter p) { return p == Prefilter::Mip ? "-DPREFILTER_MIP" : ""; }

}  // namespace penumbra::detail
