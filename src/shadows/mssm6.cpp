// MSSM6: moment soft shadow mapping with six moments (seed 003 §4.2.1), kernels/moments.cl.
#include "shadows/mssm.hpp"
#include "shadows/option_checks.hpp"

namespace penumbra::detail {
namespace {

class MSSM6Pass : public ShadowPass {
 public:
  void computeVisibility(ShadowFrame& f) override {
    validate(f.opt.mssm);
    Context& ctx = f.ctx;
    const int S = f.mapSize, nl = int(f.lights.size());
    // Two lights share three long4 images (kernels/moments.cl, depth_to_moments6).
    const int pairs = (nl + 1) / 2, images = 3 * pairs;
    const std::size_t stride = prefilterStride(f.opt.prefilter, S);
    cl::Buffer& maps = f.pool.buffer("mssm6 moments", stride * images * sizeof(cl_long4));
    cl::Kernel k = ctx.kernel("moments.cl", "depth_to_moments6");
    ctx.launchWith("mssm6/moments", k, cl::NDRange(S, S, pairs), cl::NullRange, f.depth,
                   f.lightBuffer, cl_int(S), cl_int(nl), cl_ulong(stride), maps);
    prefilter(ctx, maps, f.opt.prefilter, S, images, "mssm6");
    mssmVisibility(f, "mssm6", maps, stride);
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
