// Brute force (seed 000 Fig. 11d): K point lights per area light, spread over its cap, one hard
// shadow map each, visibility = the irradiance- and sample-weighted mean of the K depth tests
// (kernels/pcss.cl's brute_visibility). The baseline that bounds the problem from above: it
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

// Orthographic frame of a point light in direction `dir`, fitted (as lightFrame fits the scene's
// box) to the oriented box of the area light's own frame, which holds the whole scene: a sample
// near the cap's axis gets the area light's texel size, not that of a looser world-axis box.
//
// The map's texel grid is shifted by (jx, jy) texels (in [-1/2, 1/2)). Without it every sample's
// grid is anchored at the projection of the box's centre, so a sample's texel rounding of its
// shadow edge moves with the same tilt that moves the edge: on a plane the K edges then fall only
// on every other texel-wide strip and the average is a staircase of two-texel steps (measured:
// 0.086 max error at K = 256 on a 5-degree planar penumbra). Shifts from a Halton sequence make
// the rounding independent of the direction, so it only blurs the profile by about a texel.
pb_light sampleFrame(const pb_light& area, const V3& dir, int size, float jx, float jy) {
  V3 aex = xyz(area.ex), aey = xyz(area.ey), afwd = {-area.dir[0], -area.dir[1], -area.dir[2]};
  V3 w = normalize(dir);
  V3 ref = std::fabs(w[1]) < 0.99f ? V3{0, 1, 0} : V3{1, 0, 0};
  V3 ex = normalize(cross(ref, w));
  V3 ey = cross(w, ex);
  V3 fwd = {-w[0], -w[1], -w[2]};
  float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
  for (int i = 0; i < 8; ++i) {
    float sx = i & 1 ? area.ex[3] : -area.ex[3], sy = i & 2 ? area.ey[3] : -area.ey[3];
    float sz = i & 4 ? area.origin[3] : 0.0f;
    V3 c;
    for (int a = 0; a < 3; ++a) c[a] = area.origin[a] + sx * aex[a] + sy * aey[a] + sz * afwd[a];
    float p[3] = {dot(c, ex), dot(c, ey), dot(c, fwd)};
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], p[a]);
      hi[a] = std::max(hi[a], p[a]);
    }
  }
  float margin = 1e-3f * std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], 1e-6f});
  float hx = 0.5f * (hi[0] - lo[0]) + margin, hy = 0.5f * (hi[1] - lo[1]) + margin;
  float cx = 0.5f * (lo[0] + hi[0]), cy = 0.5f * (lo[1] + hi[1]);
  if (size > 0) {
    // one more texel each side, so that the shift keeps the whole box inside the map
    hx *= float(size) / std::max(size - 2, 1);
    hy *= float(size) / std::max(size - 2, 1);
    cx += jx * 2 * hx / size;
    cy += jy * 2 * hy / size;
  }
  float z0 = lo[2] - margin;
  pb_light L{};
  for (int a = 0; a < 3; ++a) {
    L.dir[a] = w[a];
    L.radiance[a] = area.radiance[a];
    L.ex[a] = ex[a];
    L.ey[a] = ey[a];
    L.origin[a] = cx * ex[a] + cy * ey[a] + z0 * fwd[a];
  }
  L.dir[3] = 1.0f;  // a point on the cap
  L.radiance[3] = 0.0f;
  L.ex[3] = hx;
  L.ey[3] = hy;
  L.origin[3] = hi[2] + margin - z0;
  return L;
}

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
        // the sample's weight, which kernels/pcss.cl's brute_visibility multiplies its cosine by
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
