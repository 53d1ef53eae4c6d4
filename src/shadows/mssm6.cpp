// MSSM6: moment soft shadow mapping with six moments (Kneiphof 2017 §4.2.1),
// kernels/shadows/moments.cl.
#include "shadows/mssm.hpp"

namespace penumbra::detail {
namespace {

class MSSM6Pass : public MomentPass {
 public:
  MSSM6Pass() : MomentPass("mssm6") {}
  // Two lights share three long4 images (kernels/shadows/moments.cl, depth_to_moments6).
  int images(int lights) const override { return 3 * ((lights + 1) / 2); }
  void moments(ShadowFrame& f, cl::Buffer& maps, std::size_t stride,
               const std::string& stage) const override {
    const int S = f.mapSize, nl = int(f.lights.size());
    cl::Kernel k = f.ctx.kernel("moments.cl", "depth_to_moments6");
    f.ctx.launchWith(stage, k, cl::NDRange(S, S, (nl + 1) / 2), cl::NullRange, f.depth,
                     f.lightBuffer, cl_int(S), cl_int(nl), cl_ulong(stride), maps);
  }
  std::size_t bytesPerTexel(const RenderOptions& opt) const override {
    // Six 64-bit values per texel and light, nothing padded: 3 long4 images per pair of lights
    // = 48 bytes (an odd light count adds one unused t1..t4 image and half an image of zeros),
    // times the prefilter's overhead (measured on a 1024^2 map).
    const std::size_t bytes = prefilterStride(opt.prefilter, 1024) * 3 * sizeof(cl_long4);
    return (bytes + 1024 * 1024) / (2 * 1024 * 1024);  // rounded to the nearest byte
  }
};

}  // namespace

std::unique_ptr<ShadowPass> makeMSSM6Pass() { return std::make_unique<MSSM6Pass>(); }

}  // namespace penumbra::detail
