// Brute force (Annen et al. 2008 Fig. 11d): K point lights per area light, spread over its cap, one
// hard
// shadow map each, visibility = the irradiance- and sample-weighted mean of the K depth tests
// (kernels/shadows/pcss.cl's brute_visibility). The baseline that bounds the problem from above: it
// converges to the exact visibility of the cap as K grows, at K times the shadow-map cost.
//
// The K * lights maps are rasterized and tested in batches of at most BruteOptions::batchBytes,
// so memory stays bounded whatever K, the light count and the map size.
#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "penumbra/lights.hpp"
#include "shadows/shadow_options.hpp"
#include "shadows/shadow_pass.hpp"
#include "core/vec3.hpp"

namespace penumbra::detail {

void validate(const BruteOptions& o) { checkRange("RenderOptions.brute.samples", o.samples, 1, 4096); }

namespace {

// Radical inverse of i in base b (Halton): a low-discrepancy sequence in [0, 1).
float radicalInverse(int i, int b) {
  float f = 1.0f, r = 0.0f;
  for (; i > 0; i /= b) {
    f /= b;
    r += f * (i % b);
  }
  return r;
}


class BrutePass : public ShadowPass {
 public:
  void computeVisibility(ShadowFrame& f) override {
    const BruteOptions& bo = f.opt.brute;
    validate(bo);
    const int K = bo.samples, nl = int(f.lights.size()), S = f.mapSize;
    const int total = K * nl;
    const std::size_t mapBytes = std::size_t(S) * S * sizeof(cl_uint) * (f.opt.frontBackFaces ? 2 : 1);
    // at least one map per batch; counts of texels stay within the kernels' int range
    const std::size_t fit = std::min<std::size_t>(bo.batchBytes / mapBytes, (std::size_t(1) << 31) / (std::size_t(S) * S));
    const int batch = int(std::clamp<std::size_t>(fit, 1, std::size_t(total)));
    std::vector<pb_light> samples;
    std::vector<pb_view> views;
    samples.reserve(total);
    views.reserve(total);
    for (int l = 0; l < nl; ++l) {
      // K weighted samples of the light (lights.hpp lightSamples: a cap's spherical Fibonacci set
      // or a polygon's stratified samples, uniform in solid angle; an ellipse's disk points with
      // their solid angles; a textured light's weighted by the texture); without the
      // AreaLights, the pb_light's cap.
      std::vector<LightSample> ls;
      if (f.areaLights && std::size_t(l) < f.areaLights->size()) {
        ls = lightSamples((*f.areaLights)[l], K);
      } else {
        AreaLight cap;
        cap.direction = xyz(f.lights[l].dir);
        cap.cosAlpha = f.lights[l].dir[3];
        ls = lightSamples(cap, K);
      }
      for (int k = 0; k < K; ++k) {
        samples.push_back(sampleFrame(f.lights[l], ls[k].dir, S,
                                      radicalInverse(k + 1, 2) - 0.5f,
                                      radicalInverse(k + 1, 3) - 0.5f));
        // the sample's weight, which kernels/shadows/pcss.cl's brute_visibility multiplies its
        // cosine by
        samples.back().radiance[3] = ls[k].weight;
        views.push_back(orthoView(samples.back(), S));
      }
    }
    cl::Buffer& sampleBuf = f.pool.upload("brute sample lights", samples);
    const std::size_t texels = std::size_t(batch) * S * S;
    cl::Buffer& maps = f.pool.buffer("brute sample maps", texels * sizeof(cl_uint));
    heldBytesPerTexel_ = double(batch) * mapBytes / (double(S) * S * nl);

    cl::Kernel k = f.ctx.kernel("pcss.cl", "brute_visibility");
    for (int first = 0; first < total; first += batch) {
      const int count = std::min(batch, total - first);
      std::vector<pb_view> bv(views.begin() + first, views.begin() + first + count);
      f.rasterizeDepth(bv, maps, "brute");
      const int l0 = first / K, l1 = (first + count - 1) / K;
      f.ctx.launchWith("brute/visibility", k, cl::NDRange(f.pixels, l1 - l0 + 1), cl::NullRange,
                       f.gpos, f.gnrm, f.ggeo, f.lightBuffer, sampleBuf, maps, cl_int(S),
                       cl_int(K), cl_int(first), cl_int(count), cl_int(l0), cl_int(f.pixels),
                       cl_float(f.opt.shadow.depthBias), f.vis);
    }
  }
  // Device bytes of depth maps held at once (one batch), per texel per light: K * 4 when all
  // maps fit in BruteOptions::batchBytes, less when batched. Known after computeVisibility.
  std::size_t bytesPerTexel(const RenderOptions& opt) const override {
    if (heldBytesPerTexel_ > 0) return std::size_t(std::ceil(heldBytesPerTexel_));
    return std::size_t(std::max(opt.brute.samples, 1)) * sizeof(cl_uint);
  }

 private:
  double heldBytesPerTexel_ = 0;  // bytes per texel per light of the last frame's batch buffer(s)
};

}  // namespace

std::unique_ptr<ShadowPass> makeBrutePass() { return std::make_unique<BrutePass>(); }

}  // namespace penumbra::detail
