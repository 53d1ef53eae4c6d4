// Center-surround light extraction (Arbree et al. 2005 §3), on the device. The host builds the
// small tables
// (row and column trigonometry, the sorted filter radii), drives Arbree et al.'s (2005) iteration
// loop and
// applies the 2% stopping rule; kernels/environment/center_surround.cl resamples the map, selects
// the candidate centres, evaluates the filter bank on the sphere (its header explains the
// parameterization), finds the strongest response and removes the chosen centre cap.
//
// Speed: a candidate's responses cost one pass over the rows of its largest cap with two prefix-sum
// look-ups per row and radius (kernels/environment/center_surround.cl). After a light is removed
// only the candidates whose largest filter reaches the removed cap (centre distance < largest outer
// radius + the light's radius) can change, so only those are re-evaluated; the candidate list is
// sorted by texel index, so they lie in one contiguous range of rows, and the rest of that range is
// culled per work-group on the device.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "environment/center_surround.hpp"
#include "core/number_text.hpp"
#include "penumbra/context.hpp"
#include "penumbra/environment.hpp"
#include "penumbra/error.hpp"
#include "penumbra/extraction.hpp"
#include "common/shared.h"

namespace penumbra {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;
constexpr int kMaxSizes = 32;     // 64 sorted radii: the private histogram of cs_response
constexpr int kMaxWidth = 8192;
constexpr int kCullOff = -3;      // cs_response's cull.w meaning "evaluate every candidate"
constexpr double kMaxTableBytes = 1 << 30;  // cap on the half-width table (H x rows x 2 sizes)

void validate(const Environment& env, const CenterSurroundOptions& o) {
  auto num = [](double v) { return detail::numberText(v); };
  if (env.equirect.empty() || env.equirect.channels != 3)
    badInput("center-surround: the environment map must be a non-empty RGB image");
  if (o.width < 8 || o.width > kMaxWidth || o.width % 2)
    badInput("center-surround width must be even and in [8, " + std::to_string(kMaxWidth) +
             "], got " + std::to_string(o.width));
  if (o.sizes < 1 || o.sizes > kMaxSizes)
    badInput("center-surround sizes must be in [1, " + std::to_string(kMaxSizes) + "], got " +
             std::to_string(o.sizes));
  if (!(o.minDeg > 0) || !(o.maxDeg >= o.minDeg) || !(o.maxDeg <= 180))
    badInput("center-surround minDeg/maxDeg must satisfy 0 < minDeg <= maxDeg <= 180, got " +
             num(o.minDeg) + " / " + num(o.maxDeg));
  if (o.sizes > 1 && !(o.maxDeg > o.minDeg))
    badInput("center-surround maxDeg must exceed minDeg when sizes > 1, got " + num(o.minDeg) +
             " / " + num(o.maxDeg));
  if (!(o.innerRatio > 0 && o.innerRatio < 1))
    badInput("center-surround innerRatio must be in (0, 1), got " + num(o.innerRatio));
  if (!(o.surroundWeight <= 0) || !std::isfinite(o.surroundWeight))
    badInput("center-surround surroundWeight must be finite and <= 0, got " +
             num(o.surroundWeight));
  if (!(o.candidateFraction > 0 && o.candidateFraction <= 1))
    badInput("center-surround candidateFraction must be in (0, 1], got " +
             num(o.candidateFraction));
  if (!(o.stopFraction >= 0 && o.stopFraction < 1))
    badInput("center-surround stopFraction must be in [0, 1), got " + num(o.stopFraction));
  if (o.maxLights < 1 || o.maxLights > PB_MAX_LIGHTS)
    badInput("center-surround maxLights must be in [1, " + std::to_string(PB_MAX_LIGHTS) +
             "], got " + std::to_string(o.maxLights));
}

// The whole state of one extraction: tables, device buffers, candidates, responses.
class CenterSurround {
 public:
  CenterSurround(Context& ctx, const Environment& env, const CenterSurroundOptions& opt)
      : ctx_(ctx), opt_(opt) {
    validate(env, opt);
    W_ = opt.width;
    H_ = W_ / 2;
    S_ = opt.sizes;
    bins_ = 2 * S_;
    buildTables();
    const std::string defs = "-DCS_BINS=" + std::to_string(bins_) +
                             " -DCS_MAX_ROWS=" + std::to_string(maxRows_);
    kResponse_ = ctx_.kernel("center_surround.cl", "cs_response", defs);
    kTake_ = ctx_.kernel("center_surround.cl", "cs_take", defs);
    kPrefix_ = ctx_.kernel("center_surround.cl", "cs_row_prefix", defs);
    std::size_t pow2 = 1;
    while (pow2 < std::size_t(bins_)) pow2 *= 2;
    wgResponse_ = ctx_.workGroupSize(kResponse_, pow2);
    wgTake_ = ctx_.workGroupSize(kTake_, 256);
    resample(env, defs);
    prefixRows(0, H_);
    extents(defs);
    selectCandidates(defs);
    resp_ = ctx_.buffer(std::max<std::size_t>(1, nCand_) * S_ * sizeof(cl_float), "cs responses");
    best_ = ctx_.buffer(std::max<std::size_t>(1, nCand_) * sizeof(cl_float), "cs best response");
    bestSize_ = ctx_.buffer(std::max<std::size_t>(1, nCand_) * sizeof(cl_int), "cs best size");
    out_ = ctx_.buffer(12 * sizeof(cl_int), "cs light record");
    respond(0, nCand_, nullptr, 0, "center-surround/response");
  }

  LightSet extract() {
    LightSet set;
    set.method = "center-surround";
    set.faceSize = 0;  // no cube map involved
    double lumTotal = 0;
    while (int(set.lights.size()) < opt_.maxLights) {
      take();
      std::vector<cl_int> rec = ctx_.download<cl_int>(out_, 12, "cs light record");
      if (!rec[11]) break;  // no positive response left: no compact bright region
      float f[8];
      std::memcpy(f, rec.data(), sizeof f);
      // Arbree et al. 2005 §3: stop when the light's intensity is below 2% of the lights found so
      // far
      // (Weber's law); we measure intensity as luminance power. The first light always counts.
      const double lumPower = f[3];
      if (!(lumPower > 0)) break;
      if (!set.lights.empty() && lumPower < opt_.stopFraction * lumTotal) break;
      lumTotal += lumPower;
      const int c = rec[8], k = rec[9];
      set.lights.push_back(makeLight(f, c, k));
      if (int(set.lights.size()) == opt_.maxLights) break;
      // The removed cap's rows get new prefix sums; then re-evaluate only the candidates whose
      // largest filter reaches the cap.
      prefixRows(c / W_ - rrows_, c / W_ + rrows_ + 1);
      const double reach = std::min(kPi, outerR_[S_ - 1] + innerR_[k] + 1e-3);
      double d[3];
      texelDir(c, d);
      respond(0, 0, d, std::cos(reach), "center-surround/update", c / W_,
              int(std::floor(reach / (kPi / H_))) + 1);
    }
    return set;
  }

  detail::CenterSurroundProbe probe() {
    detail::CenterSurroundProbe p;
    p.width = W_;
    p.height = H_;
    std::vector<cl_float4> e = ctx_.download<cl_float4>(energy_, std::size_t(W_) * H_, "cs energy");
    for (const cl_float4& v : e) p.lumEnergy.push_back(v.s[3]);
    p.candidates = ctx_.download<cl_int>(cand_, nCand_, "cs candidates");
    p.responses = ctx_.download<cl_float>(resp_, std::size_t(nCand_) * S_, "cs responses");
    p.innerRadius = innerR_;
    p.outerRadius = outerR_;
    return p;
  }

 private:
  void buildTables() {
    const double dth = kPi / H_, dph = 2 * kPi / W_;
    std::vector<cl_float4> rowTrig(H_);
    for (int t = 0; t < H_; ++t) {
      double th = (t + 0.5) * dth;
      double omega = dph * 2 * std::sin((t + 0.5) * dth) * std::sin(0.5 * dth);
      rowTrig[t] = {{float(std::cos(th)), float(std::sin(th)), float(omega), float(th)}};
    }
    std::vector<cl_float> colCos(W_ / 2 + 1);
    for (int k = 0; k <= W_ / 2; ++k) colCos[k] = float(std::cos(k * dph));
    std::vector<cl_float2> colDir(W_);
    for (int s = 0; s < W_; ++s) {
      double ph = ((s + 0.5) / W_ - 0.5) * 2 * kPi;  // pb_equirect_dir at the texel centre
      colDir[s] = {{float(std::sin(ph)), float(std::cos(ph))}};
    }
    rowTrigHost_ = rowTrig;
    colDirHost_ = colDir;
    // Filter sizes (Arbree et al. 2005 §3): outer angular DIAMETERS geometric from minDeg to
    // maxDeg; the
    // radius is half of it, the centre's radius innerRatio of the outer one.
    innerR_.resize(S_);
    outerR_.resize(S_);
    std::vector<cl_float> invExtent(S_);
    for (int k = 0; k < S_; ++k) {
      double q = S_ > 1 ? double(k) / (S_ - 1) : 0.0;
      double diam = opt_.minDeg * std::pow(double(opt_.maxDeg) / opt_.minDeg, q) * kDeg;
      outerR_[k] = 0.5 * diam;
      innerR_[k] = opt_.innerRatio * outerR_[k];
      // "The filter weights are divided by the angular extent of the filter": its outer diameter
      // in radians (a constant factor 2 from the radius, so the arg max is the same either way).
      invExtent[k] = float(1.0 / diam);
    }
    // The 2S radii sorted ascending (stable: on equal radii the inner one first); thr holds their
    // cosines, descending, and sizeBins where each size's inner and outer radius landed.
    std::vector<std::pair<double, int>> radii;  // (radius, 2k + isOuter)
    for (int k = 0; k < S_; ++k) {
      radii.push_back({innerR_[k], 2 * k});
      radii.push_back({outerR_[k], 2 * k + 1});
    }
    std::stable_sort(radii.begin(), radii.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    std::vector<cl_float> thr(bins_);
    std::vector<cl_int2> sizeBins(S_);
    for (int j = 0; j < bins_; ++j) {
      thr[j] = float(std::cos(radii[j].first));
      int k = radii[j].second / 2;
      if (radii[j].second % 2) sizeBins[k].s[1] = j;
      else sizeBins[k].s[0] = j;
    }
    rrows_ = std::min(H_ - 1, int(std::floor(outerR_[S_ - 1] / dth)) + 1);
    maxRows_ = 2 * rrows_ + 1;
    if (double(H_) * maxRows_ * bins_ * sizeof(cl_short) > kMaxTableBytes)
      badInput("center-surround width " + std::to_string(W_) + " with maxDeg " +
               std::to_string(opt_.maxDeg) + " and sizes " + std::to_string(S_) +
               " needs a half-width table over 1 GiB; lower one of them");
    rowTrig_ = ctx_.upload(rowTrig, "cs row table");
    colCos_ = ctx_.upload(colCos, "cs column cosines");
    colDir_ = ctx_.upload(colDir, "cs column directions");
    thr_ = ctx_.upload(thr, "cs sorted radii");
    sizeBins_ = ctx_.upload(sizeBins, "cs size bins");
    invExtent_ = ctx_.upload(invExtent, "cs filter extents");
  }

  void resample(const Environment& env, const std::string& defs) {
    const Image& img = env.equirect;
    // Fixed-point scale for the prefix sums: a power of two with the map's total luminance energy
    // at most 2^61 units, so no sum of texels overflows 64 bits.
    double total = 0;
    for (int t = 0; t < img.height; ++t) {
      double row = 0;
      for (int x = 0; x < img.width; ++x) {
        const float* p = &img.pixels[(std::size_t(t) * img.width + x) * 3];
        row += PB_LUM_R * p[0] + PB_LUM_G * p[1] + PB_LUM_B * p[2];
      }
      total += row * env.texelSolidAngle(t);
    }
    const int e = total > 0 ? std::clamp(61 - int(std::ceil(std::log2(total))), -120, 120) : 0;
    scale_ = std::ldexp(1.0, e);
    cl::Buffer src = ctx_.upload(img.pixels, "cs source map");
    const std::size_t n = std::size_t(W_) * H_;
    energy_ = ctx_.buffer(n * sizeof(cl_float4), "cs energy");
    q_ = ctx_.buffer(n * sizeof(cl_long), "cs fixed-point luminance");
    P_ = ctx_.buffer(n * sizeof(cl_long), "cs row prefix sums");
    key_ = ctx_.buffer(n * sizeof(cl_uint), "cs keys");
    cl::Kernel k = ctx_.kernel("center_surround.cl", "cs_resample", defs);
    // rotationColumns(): Environment::rotationYDeg, honoured exactly
    ctx_.launchWith("center-surround/resample", k, cl::NDRange(W_, H_), cl::NullRange, src,
                    cl_int(img.width), cl_int(img.height), cl_float(env.rotationColumns()),
                    cl_int(W_), cl_int(H_), cl_float(scale_), energy_, q_, key_);
  }

  // Row prefix sums of rows [r0, r1) (clamped to the map).
  void prefixRows(int r0, int r1) {
    r0 = std::max(0, r0);
    r1 = std::min(H_, r1);
    if (r1 <= r0) return;
    ctx_.launchWith("center-surround/prefix", kPrefix_, cl::NDRange(r1 - r0), cl::NullRange, q_,
                    cl_int(W_), cl_int(r0), cl_int(r1 - r0), P_);
  }

  void extents(const std::string& defs) {
    E_ = ctx_.buffer(std::size_t(H_) * maxRows_ * bins_ * sizeof(cl_short), "cs half-width table");
    cl::Kernel k = ctx_.kernel("center_surround.cl", "cs_extents", defs);
    ctx_.launchWith("center-surround/extents", k, cl::NDRange(maxRows_, H_), cl::NullRange,
                    rowTrig_, colCos_, thr_, cl_int(W_), cl_int(H_), cl_int(rrows_), E_);
  }

  // The brightest candidateFraction of the texels (by luminance radiance): the K-th largest key by
  // a 4-pass radix select on the device (256-bin histograms), then the rows' candidates written in
  // texel order; ties at the threshold go to the lowest texel indices, so exactly K are chosen.
  void selectCandidates(const std::string& defs) {
    const int n = W_ * H_;
    const int K = std::clamp(int(std::ceil(double(opt_.candidateFraction) * n - 1e-9)), 1, n);
    cl::Kernel kh = ctx_.kernel("center_surround.cl", "cs_key_histogram", defs);
    const std::size_t wg = ctx_.workGroupSize(kh, 64);
    const std::size_t groups = std::min<std::size_t>(64, (n + wg - 1) / wg);
    cl::Buffer hist = ctx_.buffer(256 * sizeof(cl_uint), "cs key histogram");
    cl_uint prefix = 0, mask = 0;
    std::int64_t rem = K;  // rank still to find among the keys matching the prefix
    for (int shift = 24; shift >= 0; shift -= 8) {
      cl_uint zero = 0;
      ctx_.fill(hist, &zero, sizeof zero, 256 * sizeof(cl_uint), "cs key histogram");
      ctx_.launchWith("center-surround/select", kh, cl::NDRange(groups * wg), cl::NDRange(wg), key_,
                      cl_int(n), cl_int(shift), mask, prefix, hist,
                      cl::Local(256 * sizeof(cl_uint)));
      std::vector<cl_uint> h = ctx_.download<cl_uint>(hist, 256, "cs key histogram");
      int digit = 255;
      for (; digit > 0; --digit) {
        if (std::int64_t(h[digit]) >= rem) break;
        rem -= h[digit];
      }
      prefix |= cl_uint(digit) << shift;
      mask |= 0xffu << shift;
    }
    const cl_uint thresh = prefix;  // the K-th largest key; `rem` keys equal to it are taken
    cl::Buffer counts = ctx_.buffer(H_ * sizeof(cl_int2), "cs row counts");
    cl::Kernel kc = ctx_.kernel("center_surround.cl", "cs_row_counts", defs);
    ctx_.launchWith("center-surround/candidates", kc, cl::NDRange(H_), cl::NullRange, key_,
                    cl_int(W_), cl_int(H_), thresh, counts);
    std::vector<cl_int2> cnt = ctx_.download<cl_int2>(counts, H_, "cs row counts");
    rowStart_.assign(H_ + 1, 0);
    std::vector<cl_int> takeEq(H_);
    std::int64_t eqLeft = rem;
    for (int t = 0; t < H_; ++t) {
      takeEq[t] = int(std::min<std::int64_t>(cnt[t].s[1], eqLeft));
      eqLeft -= takeEq[t];
      rowStart_[t + 1] = rowStart_[t] + cnt[t].s[0] + takeEq[t];
    }
    nCand_ = rowStart_[H_];
    if (nCand_ != K)
      throw Error(ErrorKind::Internal, "center-surround: selected " + std::to_string(nCand_) +
                                           " candidates, expected " + std::to_string(K));
    cand_ = ctx_.buffer(std::size_t(nCand_) * sizeof(cl_int), "cs candidates");
    cl::Buffer start = ctx_.upload(std::vector<cl_int>(rowStart_.begin(), rowStart_.end() - 1),
                                   "cs row starts");
    cl::Buffer take = ctx_.upload(takeEq, "cs ties taken");
    cl::Kernel kw = ctx_.kernel("center_surround.cl", "cs_row_write", defs);
    ctx_.launchWith("center-surround/candidates", kw, cl::NDRange(H_), cl::NullRange, key_,
                    cl_int(W_), cl_int(H_), thresh, start, take, cand_);
  }

  // Evaluates the filter bank at candidates [begin, end), or, with a cull centre, at the
  // candidates of rows [row - rows, row + rows] within acos(cullCos) of it.
  void respond(int begin, int end, const double* cullDir, double cullCos, const char* stage,
               int row = 0, int rows = 0) {
    cl_float4 cull = {{0, 0, 0, float(kCullOff)}};
    if (cullDir) {
      begin = rowStart_[std::max(0, row - rows)];
      end = rowStart_[std::min(H_, row + rows + 1)];
      cull = {{float(cullDir[0]), float(cullDir[1]), float(cullDir[2]), float(cullCos)}};
    }
    if (end <= begin) return;
    cl::Kernel& k = kResponse_;
    ctx_.launchWith(stage, k, cl::NDRange(std::size_t(end - begin) * wgResponse_),
                    cl::NDRange(wgResponse_), P_, cl_int(W_), cl_int(H_), rowTrig_, colDir_, E_,
                    sizeBins_, invExtent_, cl_int(S_), cl_float(opt_.surroundWeight),
                    cl_float(1.0 / scale_), cl_int(rrows_), cand_, cl_int(begin), cull, resp_,
                    best_, bestSize_, cl::Local(bins_ * sizeof(cl_long)),
                    cl::Local(S_ * sizeof(cl_float)));
  }

  void take() {
    cl::Kernel& k = kTake_;
    ctx_.launchWith("center-surround/take", k, cl::NDRange(wgTake_), cl::NDRange(wgTake_), q_,
                    energy_, cl_int(W_), cl_int(H_), rowTrig_, colDir_, E_, sizeBins_,
                    cl_int(rrows_), cand_, cl_int(nCand_), best_, bestSize_, out_,
                    cl::Local(wgTake_ * 8 * sizeof(cl_float)), cl::Local(wgTake_ * sizeof(cl_int)));
  }

  void texelDir(int c, double d[3]) const {
    const cl_float4& r = rowTrigHost_[c / W_];
    const cl_float2& p = colDirHost_[c % W_];
    d[0] = double(r.s[1]) * p.s[0];
    d[1] = r.s[0];
    d[2] = -double(r.s[1]) * p.s[1];
  }

  // A light covering the centre cap of size k at texel c, carrying that cap's energy (Arbree et al.
  // 2005
  // §3 steps 1-4). Direction: the luminance-weighted centroid of the removed texels rather than
  // the filter centre: the centre sits on the working grid (steps of 360/W degrees) while the
  // centroid places the light where its energy is, to a fraction of a texel, and gives the cap the
  // removed energy's first moment, which is what the irradiance of normals facing it depends on.
  AreaLight makeLight(const float f[8], int c, int k) const {
    AreaLight l;
    double v[3] = {f[4], f[5], f[6]};
    double len = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (!(len > 0)) {
      texelDir(c, v);
      len = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    }
    for (int i = 0; i < 3; ++i) l.direction[i] = float(v[i] / len);
    l.cosAlpha = float(std::cos(innerR_[k]));
    l.setPower({f[0], f[1], f[2]});
    return l;
  }

  Context& ctx_;
  CenterSurroundOptions opt_;
  int W_ = 0, H_ = 0, S_ = 0, bins_ = 0, rrows_ = 0, maxRows_ = 0, nCand_ = 0;
  std::size_t wgResponse_ = 1, wgTake_ = 1;
  std::vector<double> innerR_, outerR_;
  std::vector<cl_float4> rowTrigHost_;
  std::vector<cl_float2> colDirHost_;
  std::vector<int> rowStart_;  // candidates of row t: [rowStart_[t], rowStart_[t+1])
  double scale_ = 1;           // fixed-point units per unit of luminance energy (a power of two)
  cl::Kernel kResponse_, kTake_, kPrefix_;
  cl::Buffer rowTrig_, colCos_, colDir_, thr_, sizeBins_, invExtent_, E_;
  cl::Buffer energy_, q_, P_, key_, cand_, resp_, best_, bestSize_, out_;
};

}  // namespace

LightSet extractCenterSurround(Context& ctx, const Environment& env,
                              const CenterSurroundOptions& opt) {
  try {
    CenterSurround cs(ctx, env, opt);
    return cs.extract();
  } catch (const cl::Error& e) {
    rethrowCl(e, "center-surround extraction");
  }
}

namespace detail {
CenterSurroundProbe centerSurroundProbe(Context& ctx, const Environment& env,
                                        const CenterSurroundOptions& opt) {
  try {
    CenterSurround cs(ctx, env, opt);
    return cs.probe();
  } catch (const cl::Error& e) {
    rethrowCl(e, "center-surround probe");
  }
}
}  // namespace detail

}  // namespace penumbra
