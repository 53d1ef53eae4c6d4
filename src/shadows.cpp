// Shadow techniques by name, and the prefilter shared by the filtered ones.
#include "penumbra/error.hpp"
#include "penumbra/scan.hpp"
#include "shadow_pass.hpp"

namespace penumbra::detail {

std::unique_ptr<ShadowPass> makeShadowPass(ShadowTechnique t) {
  switch (t) {
    case ShadowTechnique::MSSM4: return makeMSSM4Pass();
    // further techniques: one case each
    default: return nullptr;
  }
}

bool techniqueAvailable(ShadowTechnique t) {
  switch (t) {
    case ShadowTechnique::None:
    case ShadowTechnique::MSSM4: return true;
    // further techniques: one case each
    default: return false;
  }
}

bool prefilterAvailable(Prefilter p) { return p == Prefilter::SAT; }

std::size_t prefilterStride(Prefilter p, int size) {
  (void)p;
  return std::size_t(size) * size;
}

void prefilter(Context& ctx, cl::Buffer& maps, Prefilter p, int size, int count,
               const std::string& stage) {
  if (p != Prefilter::SAT) badInput(std::string("prefilter ") + toString(p) + " is not available");
  summedAreaTable(ctx, maps, ScanType::Long4, size, size, count, stage + "/sat");
}

std::string prefilterOption(Prefilter p) { return p == Prefilter::Mip ? "-DPREFILTER_MIP" : ""; }

}  // namespace penumbra::detail
