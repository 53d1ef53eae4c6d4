// CSSM: convolution soft shadow maps (Annen et al. 2008 §3 and appendix), kernels/shadows/csm.cl.
//
// The host derives the ringing suppression of §3.3 from the order M (deriveCssmSeries), writes
// the 4M + 1 basis images per light, prefilters them and runs the visibility kernel. Lights are
// processed in batches so that the basis images of one batch fit CSSMOptions::maxBasisBytes.
#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>
#include <string>
#include <utility>

#include "shadows/shadow_options.hpp"
#include "shadows/shadow_params.h"
#include "shadows/shadow_pass.hpp"

namespace penumbra::detail {
namespace {

// The truncated complementary shadow test of Annen et al. 2008 eq. 10 as a function of t = d - z:
//   S_M(t) = 1/2 + 2 sum_{k=1..M} sin(c_k t) / c_k,   c_k = pi (2k - 1).
// It is the partial Fourier sum of the period-2 square wave H(t) on (-1, 1), so it is odd about
// (0, 1/2), S_M(1 - t) = S_M(t) (symmetric about t = 1/2), and S_M > 1/2 on (0, 1). It rises
// over ~1/(2M), overshoots by the Gibbs ~9% at t = 1/(2M) and then ripples about 1; its lowest
// value on the plateau [1/(2M), 1 - 1/(2M)] is the first trough (t = 1/M), 0.9459 for M = 4,
// 0.9511 for M = 16. With damping alpha > 0 each term is attenuated by sigma_k = exp(-alpha
// (k/M)^2) (Annen et al. 2007's ringing attenuation): the same basis images, smaller ripple, a
// slower rise.
double cssmSeries(int M, double alpha, double t) {
  double s = 0.5;
  for (int k = 1; k <= M; ++k) {
    double ck = M_PI * (2 * k - 1), kk = double(k) / M;
    s += 2.0 * std::exp(-alpha * kk * kk) * std::sin(ck * t) / ck;
  }
  return s;
}

// The series of one order and damping, and the ringing suppression (§3.3) derived from it.
struct CssmSeries {
  int M = 4;
  double alpha = 0;
  double plateauMin = 1;  // s_hi: lowest value of S_M past its first peak
  double plateauMax = 1;  // the Gibbs peak
  double rise = 0;        // t0: where S_M first reaches s_hi
  double kappa = 1;       // depth scale: the series sees z~ = kappa z
  double S(double t) const { return cssmSeries(M, alpha, t); }
};

// One scale/shift of the test: shadow = clamp(scale * S_M(tau) + shift), tau = kappa t - tau0.
struct CssmShift {
  double tau0 = 0, scale = 1, shift = 0;
};

// Ringing suppression, derived from the series:
//   s_hi  = min of S_M on its plateau: every blocker on the plateau must map to >= 1, so the
//           plateau's ripple lies above 1 and is clamped away;
//   t0    = where S_M first reaches s_hi: the rise, i.e. the contact zone where the truncated
//           test is soft;
//   kappa = 1 - t0: depth scale keeping every depth difference on the series' good range. A
//           blocker (0 < t <= 1) stays at tau <= 1 - t0, where S_M >= s_hi still (S_M is
//           symmetric about 1/2; a blocker at the far end of the range maps exactly to 1). A lit
//           texel (t >= -1) stays at tau >= -1 + t0 - tau0, where S_M(-1 + x) = 1 - S_M(x)
//           <= s_lo holds for the visibility's shift (tau0 = 0). The blocker search's shift
//           (tau0 = t0) wraps only for receivers in the top t0 of the range facing texels near the
//           far plane (t < -1 + t0): those count as blockers deeper than the receiver, and
//           clamping z_avg to the receiver's depth turns them into a contact (no blocker can be
//           that close to the light anyway).
CssmSeries deriveCssmSeries(int M, double alpha) {
  CssmSeries r;
  r.M = M;
  r.alpha = alpha;
  const int n = 1 << 14;
  int ip = n / 2;  // first peak: first local maximum of S_M on (0, 1/2]
  for (int i = 1; i < n / 2; ++i)
    if (r.S(double(i) / n) >= r.S(double(i + 1) / n)) {
      ip = i;
      break;
    }
  double shi = r.S(double(ip) / n), peak = shi;
  for (int i = ip; i <= n - ip; ++i) {
    shi = std::min(shi, r.S(double(i) / n));
    peak = std::max(peak, r.S(double(i) / n));
  }
  double lo = 0, hi = double(ip) / n;  // S_M rises monotonically up to the first peak
  for (int it = 0; it < 60; ++it) {
    double mid = 0.5 * (lo + hi);
    (r.S(mid) < shi ? lo : hi) = mid;
  }
  r.plateauMin = shi;
  r.plateauMax = peak;
  r.rise = hi;
  r.kappa = 1.0 - r.rise;
  return r;
}

//   tau0  = lambda t0, the shift along depth: a receiver texel (t = 0) reads
//           S_M(-tau0) = 1 - S_M(tau0) =: s_lo;
//   scale = 1 / (s_hi - s_lo), shift = -s_lo scale: s_lo -> 0 (the receiver does not shadow
// itself) and s_hi -> 1. lambda = 1 is the symmetric map of Annen et al. 2008 Fig. 3c (ripple of
//           both plateaus outside [0,1]); lambda = 0 keeps the receiver at the centre of the rise
//           (S_M(0) = 1/2 -> 0): a tilted receiver's own texels cancel (S_M - 1/2 is odd),
//           contact shadows start at once, but surfaces behind the receiver (S_M ~ 0) then weigh
//           about -1/(2 s_hi - 1) each in the filter.
CssmShift shiftFor(const CssmSeries& ser, double lambda) {
  CssmShift r;
  r.tau0 = lambda * ser.rise;
  double slo = 1.0 - ser.S(r.tau0);
  r.scale = 1.0 / (ser.plateauMin - slo);
  r.shift = -slo * r.scale;
  return r;
}

constexpr int kMaxOrder = 32;

int groupsFor(int M) { return M + 1; }  // 4M + 1 values in long4 groups

// The series is sampled on 2^14 points per (M, alpha): a few ms at M = 32, so once per process.
const CssmSeries& seriesFor(int M, double alpha) {
  static std::mutex mutex;
  static std::map<std::pair<int, double>, CssmSeries> cache;
  std::lock_guard<std::mutex> lock(mutex);
  auto it = cache.find({M, alpha});
  if (it == cache.end())
    it = cache.emplace(std::make_pair(M, alpha), deriveCssmSeries(M, alpha)).first;
  return it->second;
}

class CSSMPass : public ShadowPass {
 public:
  void computeVisibility(ShadowFrame& f) override {
    Context& ctx = f.ctx;
    const CSSMOptions& co = f.opt.cssm;
    validate(co);
    const int M = co.order, G = groupsFor(M);
    const int S = f.mapSize, nl = int(f.lights.size());
    const std::size_t stride = prefilterStride(f.opt.prefilter, S);
    const std::size_t perLight = stride * G * sizeof(cl_long4);
    const int batch = int(std::clamp<std::size_t>(co.maxBasisBytes / perLight, 1, nl));
    cl::Buffer& maps = f.pool.buffer("cssm basis", perLight * batch);
    const CssmSeries& ser = seriesFor(M, co.damping);
    // the visibility's test, and the blocker search's (shifted by the whole rise)
    const CssmShift vis = shiftFor(ser, co.ringingOffset), blk = shiftFor(ser, 1.0);
    cssm_params P{};
    P.scale = float(vis.scale);
    P.shift = float(vis.shift);
    P.tau0 = float(vis.tau0);
    P.kappa = float(ser.kappa);
    P.scale_z = float(blk.scale);
    P.shift_z = float(blk.shift);
    P.tau0_z = float(blk.tau0);
    P.rise = float(ser.rise / ser.kappa);
    P.depth_bias = co.depthBias;
    P.slope_bias = co.slopeBias;
    setFilterLimits(P, f.opt.shadow);
    P.sharpen_a = co.sharpenA;
    P.sharpen_b = co.sharpenB;
    P.damping = co.damping;
    const std::string options =
        "-DCSSM_ORDER=" + std::to_string(M) + " " + prefilterOption(f.opt.prefilter);
    cl::Kernel basis = ctx.kernel("csm.cl", "cssm_basis", options);
    cl::Kernel visibility = ctx.kernel("csm.cl", "cssm_visibility", options);
    for (int first = 0; first < nl; first += batch) {
      const int count = std::min(batch, nl - first);
      // basis images of lights first .. first + count - 1, then their visibility at every pixel
      ctx.launchWith("cssm/basis", basis, cl::NDRange(S, S, count), cl::NullRange, f.depth,
                     f.lightBuffer, cl_int(S), cl_ulong(stride), cl_int(first),
                     cl_float(ser.kappa), maps);
      prefilter(ctx, maps, f.opt.prefilter, S, count * G, "cssm");
      ctx.launchWith("cssm/visibility", visibility, cl::NDRange(f.pixels, count), cl::NullRange,
                     f.gpos, f.gnrm, f.ggeo, f.lightBuffer, maps, cl_int(S), cl_ulong(stride),
                     cl_int(f.pixels), cl_int(first), P, f.vis);
    }
  }
  // 4M + 1 values per texel (CSM 2M, CSM-Z 2M, z) in M + 1 long4 groups, times the prefilter's
  // overhead (measured on a 1024^2 map). Per light: a frame keeps one batch of lights resident
  // (CSSMOptions::maxBasisBytes), not all of them.
  std::size_t bytesPerTexel(const RenderOptions& opt) const override {
    return prefilterStride(opt.prefilter, 1024) * groupsFor(opt.cssm.order) * sizeof(cl_long4) /
           (1024 * 1024);
  }
};

}  // namespace

void validate(const CSSMOptions& o) {
  checkRange("RenderOptions.cssm.order", o.order, 1, kMaxOrder);
  if (!(o.ringingOffset >= 0 && o.ringingOffset <= 1))
    badOption("RenderOptions.cssm.ringingOffset", "be in [0, 1]", o.ringingOffset);
  if (!(o.damping >= 0 && o.damping <= 8))
    badOption("RenderOptions.cssm.damping", "be in [0, 8]", o.damping);
  if (!std::isfinite(o.depthBias))
    badOption("RenderOptions.cssm.depthBias", "be finite", o.depthBias);
  if (!std::isfinite(o.slopeBias))
    badOption("RenderOptions.cssm.slopeBias", "be finite", o.slopeBias);
  if (!(o.sharpenA >= 0) || !std::isfinite(o.sharpenA))
    badOption("RenderOptions.cssm.sharpenA", "be finite and >= 0", o.sharpenA);
  if (!(o.sharpenB >= 0) || !std::isfinite(o.sharpenB))
    badOption("RenderOptions.cssm.sharpenB", "be finite and >= 0", o.sharpenB);
}

std::unique_ptr<ShadowPass> makeCSSMPass() { return std::make_unique<CSSMPass>(); }

}  // namespace penumbra::detail
