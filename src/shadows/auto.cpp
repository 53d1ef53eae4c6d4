// `auto`: a shadow technique chosen per light (AutoOptions), and the pass that runs each chosen
// technique's own pass on its subset of the lights and gathers their visibility rows.
//
// The rule, and why. Approximate techniques err inside penumbrae (PCSS's and MSSM's single planar
// blocker, the filter's limit on wide penumbrae; hard shadows everywhere there), so a light's
// share of the image's error grows with the irradiance it brings times the screen area its
// penumbrae cover (their width). Exact sampled visibility (the bitmask technique, Sintorn,
// Eisemann & Assarsson 2008 §4) removes that error at a cost that also grows with the penumbra:
// each caster triangle walks the list texels of its influence region, which widens with the
// light's angular size. Gain per cost is then about the irradiance alone: not the light's power
// but what of it reaches the surfaces on screen, power times the mean of max(0, n.w) over the
// camera's pixels (a light below the ground's horizon lights only what faces it; one grazing the
// ground brings it little). The lights are ranked by that ("brightest on screen"), so:
//  1. the brightest lights on screen get exact visibility, at most AutoOptions::exactLights of
//     them (a count: the technique costs one to several default frames per light on a 2-core
//     CPU), and so does every compact bright source (a share of the power of at least
//     AutoOptions::exactShare from a cap at most exactHalfAngleDeg wide): the cost grows with the
//     light's size, and a small cap's is a fraction of a frame;
//  2. a light whose penumbra is narrower than a camera pixel or a shadow-map texel, whichever is
//     coarser (times hardPixels), gets hard shadows: neither the screen nor the map resolves a
//     narrower penumbra, so a filter adds cost and no accuracy;
//  3. the rest are filtered: PCSS while the filter it pays for (the penumbra in texels, clamped to
//     ShadowOptions::maxFilterTexels as the kernel clamps it) is at most pcssTexels wide (its
//     explicit filter reads every texel of the box: a cost growing with the width squared),
//     MSSM4 beyond (a constant reconstruction per pixel after a prefilter whose cost does not
//     depend on the width). A light that grazes its receivers (the median of n.w over the pixels
//     facing it under sin AutoOptions::pcssMinElevationDeg) stays with MSSM4 whatever its width.
//     Found when PCSS's receiver plane was still clamped at a slope of tan 84 degrees (lit ground
//     shadowed itself under lights 1-4 degrees high: PCSS's squared error 4-23x MSSM4's there,
//     courtyard + Wuson, per light against exact visibility). With the plane unclamped (stop 44)
//     what is left is a light whose cap crosses the receivers' plane (studio + Wuson's 2.6-degree
//     light 1.6 degrees high: 0.227 against MSSM4's 0.061), and the cut still pays there: every
//     light filtered, PCSS up to 12 texels, studio 2.570% with the cut, 2.601% without
//     (bench/results/accuracy.md, "PCSS under grazing light").
//  4. past AutoOptions::filteredLights filtered lights (counted brightest on screen first), the
//     rest get hard shadows: a light's error share grows with the irradiance it brings, and a hard
//     shadow costs a fraction of a filtered one, so a frame's time is better spent on more lights
//     than on filtering dim ones (bench/results/accuracy.md, "Light count against technique").
//     Ranked by power alone, as it was until stop 45, the budget went to lights under the
//     ground's horizon and left wide high ones hard: per light against exact visibility, the
//     technique error of the default frame fell from 0.73 / 1.54 / 0.72 / 1.19% to 0.69 / 1.39 /
//     0.58 / 1.17% with the same 24 filtered lights (accuracy.md, "The filtered budget by
//     irradiance on screen").
// The penumbra width is 2 tan(alpha) times the median caster-receiver distance of the light's
// shadowed pixels (casterDistance). The rule reads light properties (power, cap size, that
// distance, the map's texel, the receivers' cosines) and the camera's pixel footprint, never a
// technique's measured error, so it holds as the techniques improve.
#include "shadows/auto.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <string>
#include <thread>

#include "shadows/shadow_options.hpp"
#include "shadows/shadow_pass.hpp"

namespace penumbra::detail {

void validate(const AutoOptions& o) {
  checkRange("RenderOptions.autoChoice.exactLights", o.exactLights, 0, 4096);
  if (!(o.hardPixels >= 0) || !std::isfinite(o.hardPixels))
    badOption("RenderOptions.autoChoice.hardPixels", "be finite and >= 0", o.hardPixels);
  if (!(o.pcssTexels >= 0) || !std::isfinite(o.pcssTexels))
    badOption("RenderOptions.autoChoice.pcssTexels", "be finite and >= 0", o.pcssTexels);
  checkRange("RenderOptions.autoChoice.filteredLights", o.filteredLights, -1, 4096);
  if (!(o.exactShare >= 0 && o.exactShare <= 1))
    badOption("RenderOptions.autoChoice.exactShare", "be in [0, 1]", o.exactShare);
  if (!(o.pcssMinElevationDeg >= 0 && o.pcssMinElevationDeg <= 90))
    badOption("RenderOptions.autoChoice.pcssMinElevationDeg", "be in [0, 90]",
              o.pcssMinElevationDeg);
  if (!(o.exactHalfAngleDeg >= 0 && o.exactHalfAngleDeg <= 90))
    badOption("RenderOptions.autoChoice.exactHalfAngleDeg", "be in [0, 90]", o.exactHalfAngleDeg);
}

namespace {
// The upper median of v (reordered), 0 for none.
double median(std::vector<double>& v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}
}  // namespace

AutoLight autoLight(const pb_light& L, const AreaLight* light, int mapSize, double distance) {
  const double c = std::clamp(double(L.dir[3]), -1.0, 1.0), s = std::sqrt(1 - c * c);
  AutoLight a;
  a.tanAlpha = c > 1e-6 ? s / c : 1e6;  // a cap past a hemisphere: as wide as the rule can see
  auto luminance = [](double r, double g, double b) {
    return PB_LUM_R * r + PB_LUM_G * g + PB_LUM_B * b;
  };
  if (light) {  // radiance (the mean, on a textured light) times the exact solid angle: the power
    const double omega = light->solidAngle();
    a.power = omega * luminance(light->radiance[0], light->radiance[1], light->radiance[2]);
  } else {
    const double omega = 2 * M_PI * (1 - c);
    a.power = omega * luminance(L.radiance[0], L.radiance[1], L.radiance[2]);
  }
  a.distance = distance;
  a.texel = 2.0 * std::max(L.ex[3], L.ey[3]) / std::max(mapSize, 1);
  return a;
}

std::vector<CasterSample> casterSamples(const std::vector<cl_float4>& gpos,
                                        const std::vector<cl_float4>& gnrm, int step) {
  std::vector<CasterSample> out;
  casterSamples(gpos, gnrm, step, out);
  return out;
}

void casterSamples(const std::vector<cl_float4>& gpos, const std::vector<cl_float4>& gnrm,
                   int step, std::vector<CasterSample>& out) {
  casterSamples(gpos.data(), gnrm.data(), gpos.size(), step, out);
}

void casterSamples(const cl_float4* gpos, const cl_float4* gnrm, std::size_t pixels, int step,
                   std::vector<CasterSample>& out) {
  out.clear();
  for (std::size_t px = 0; px < pixels; px += std::size_t(std::max(step, 1))) {
    const cl_float4 &p = gpos[px], &n = gnrm[px];
    if (p.s[3] != 1.0f) continue;
    out.push_back({{p.s[0], p.s[1], p.s[2]}, {n.s[0], n.s[1], n.s[2]}});
  }
}

CasterStats casterStats(const pb_light& L, const cl_uint* map, int size,
                        const std::vector<CasterSample>& samples, float depthBias,
                        std::vector<double>& gaps, std::vector<double>* sines) {
  // the map's projection, as kernels/shadows/pcss.cl's map_point_of
  const double hx = L.ex[3], hy = L.ey[3], range = L.origin[3];
  const double texel = 2.0 * std::max(hx, hy) / std::max(size, 1);
  gaps.clear();
  if (sines) sines->clear();
  // Two passes: each sample facing the light, its texel and its depth along the light; then the
  // map's depths at those texels. The second is a short loop of independent loads that the
  // memory system overlaps: in one loop each load (the map was just drawn on the device, mostly
  // outside this core's caches) waited behind the sample's arithmetic, and those loads were
  // two thirds of this function's time (`perf annotate`).
  std::vector<std::size_t> texels;
  std::vector<double> depths;
  texels.reserve(samples.size());
  depths.reserve(samples.size());
  double cosSum = 0;
  for (const CasterSample& s : samples) {
    const float* n = s.normal;
    const float nw = n[0] * L.dir[0] + n[1] * L.dir[1] + n[2] * L.dir[2];
    if (nw <= 0) continue;  // unlit side
    cosSum += nw;
    if (sines) sines->push_back(nw);
    double r[3], x = 0, y = 0, d = 0;
    for (int k = 0; k < 3; ++k) r[k] = double(s.position[k]) - L.origin[k];
    for (int k = 0; k < 3; ++k) {
      x += r[k] * L.ex[k];
      y += r[k] * L.ey[k];
      d -= r[k] * L.dir[k];
    }
    const int i = std::clamp(int((x / hx + 1) * 0.5 * size), 0, size - 1);
    const int j = std::clamp(int((1 - y / hy) * 0.5 * size), 0, size - 1);
    texels.push_back(std::size_t(j) * size + i);
    depths.push_back(d);
  }
  const double least = depthBias * range + 2 * texel;
  const std::size_t* at = texels.data();
  const double* depth = depths.data();
  for (std::size_t k = 0; k < texels.size(); ++k) {
    float z;
    std::memcpy(&z, &map[at[k]], sizeof z);  // +inf where empty
    const double gap = depth[k] - double(z);
    if (gap > least) gaps.push_back(gap);
  }
  CasterStats st;
  st.distance = median(gaps);
  if (sines && !sines->empty()) st.receiverSin = median(*sines);
  if (!samples.empty()) st.screenCos = cosSum / double(samples.size());
  return st;
}

double casterDistance(const pb_light& L, const cl_uint* map, int size,
                      const std::vector<CasterSample>& samples, float depthBias,
                      std::vector<double>& gaps) {
  return casterStats(L, map, size, samples, depthBias, gaps, nullptr).distance;
}

double casterDistance(const pb_light& L, const cl_uint* map, int size,
                      const std::vector<cl_float4>& gpos, const std::vector<cl_float4>& gnrm,
                      float depthBias, int step) {
  std::vector<double> gaps;
  return casterDistance(L, map, size, casterSamples(gpos, gnrm, step), depthBias, gaps);
}

double autoPenumbraWidth(const AutoLight& l) { return 2 * l.tanAlpha * l.distance; }

double autoScreenIrradiance(const AutoLight& l) { return l.power * l.screenCos; }

double pixelFootprint(const std::vector<cl_float4>& gpos, int width, int height) {
  return pixelFootprint(gpos.data(), width, height, nullptr);
}

double pixelFootprint(const cl_float4* gpos, int width, int height, std::vector<double>* scratch) {
  std::vector<double> own;
  std::vector<double>& d = scratch ? *scratch : own;
  d.clear();
  for (int y = 0; y < height; ++y)
    for (int x = 0; x + 1 < width; ++x) {
      const std::size_t i = std::size_t(y) * width + x;
      const cl_float4 &a = gpos[i], &b = gpos[i + 1];
      if (a.s[3] != 1.0f || b.s[3] != 1.0f) continue;
      const double dx = a.s[0] - b.s[0], dy = a.s[1] - b.s[1], dz = a.s[2] - b.s[2];
      d.push_back(dx * dx + dy * dy + dz * dz);
    }
  // The root of the squared distances' median: the distances' median (the root keeps their
  // order, ties included), without a root per pair.
  return std::sqrt(median(d));
}

std::vector<ShadowTechnique> chooseShadowTechniques(const std::vector<AutoLight>& lights,
                                                    double pixel, const AutoOptions& o,
                                                    float maxFilterTexels, bool exactAllowed) {
  validate(o);
  const std::size_t n = lights.size();
  // 1. exact: the brightest on screen first; ties keep the lights' order
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), std::size_t(0));
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return autoScreenIrradiance(lights[a]) > autoScreenIrradiance(lights[b]);
  });
  std::vector<ShadowTechnique> out(n, ShadowTechnique::MSSM4);
  const std::size_t budget = exactAllowed ? std::size_t(o.exactLights) : 0;
  for (std::size_t k = 0; k < n && k < budget; ++k) out[order[k]] = ShadowTechnique::Bitmask;
  // 1b. compact bright sources: exact as well
  if (exactAllowed && o.exactShare > 0) {
    double total = 0;
    for (const AutoLight& l : lights) total += l.power;
    const double tanMax = std::tan(double(o.exactHalfAngleDeg) * M_PI / 180.0);
    for (std::size_t i = 0; i < n; ++i)
      if (lights[i].power >= double(o.exactShare) * total && lights[i].tanAlpha <= tanMax)
        out[i] = ShadowTechnique::Bitmask;
  }
  // in the same order, so that the filtered budget goes to the brightest on screen
  std::size_t filtered = 0;
  const double sinPcss = std::sin(double(o.pcssMinElevationDeg) * M_PI / 180.0);
  for (std::size_t i : order) {
    if (out[i] == ShadowTechnique::Bitmask) continue;
    const double width = autoPenumbraWidth(lights[i]);
    const double texels = lights[i].texel > 0 ? width / lights[i].texel : 0;
    // 2. unresolved penumbra: hard
    if (width < o.hardPixels * std::max(pixel, lights[i].texel)) {
      out[i] = ShadowTechnique::Hard;
      continue;
    }
    // 4. past the filtered budget: hard
    if (o.filteredLights >= 0 && filtered >= std::size_t(o.filteredLights)) {
      out[i] = ShadowTechnique::Hard;
      continue;
    }
    ++filtered;
    // 3. filtered, by the filter's cost
    if (std::min(texels, double(maxFilterTexels)) <= o.pcssTexels &&
        lights[i].receiverSin >= sinPcss)
      out[i] = ShadowTechnique::PCSS;
  }
  return out;
}

namespace {

constexpr ShadowTechnique kChoices[] = {ShadowTechnique::Hard, ShadowTechnique::PCSS,
                                        ShadowTechnique::MSSM4, ShadowTechnique::Bitmask};

// The stat name of a choice's light count.
std::string countName(ShadowTechnique t) {
  return t == ShadowTechnique::Bitmask ? "auto/lights_exact"
                                       : std::string("auto/lights_") + toString(t);
}

// Copies row from[i] of src to row to[i] of dst, rows `bytes` long; a run of indices consecutive
// in both lists is one copy.
void copyRows(Context& ctx, const cl::Buffer& src, const std::vector<int>& from, cl::Buffer& dst,
              const std::vector<int>& to, std::size_t bytes) {
  for (std::size_t i = 0; i < from.size();) {
    std::size_t j = i + 1;
    while (j < from.size() && from[j] == from[j - 1] + 1 && to[j] == to[j - 1] + 1) ++j;
    ctx.queue().enqueueCopyBuffer(src, dst, std::size_t(from[i]) * bytes,
                                  std::size_t(to[i]) * bytes, (j - i) * bytes);
    i = j;
  }
}

// casterDistance's pixel budget per frame. Every 4th pixel up to 320x180; at 640x360 every 15th
// gave the same choices as every 4th on issue 13's four scenes with 8, 16 and 32 of 64 lights
// filtered, and its medians took 5.8 ms for 64 lights instead of 12-18 ms (2 threads).
constexpr std::size_t kCasterSamples = 16384;

class AutoPass : public ShadowPass {
 public:
  void computeVisibility(ShadowFrame& f) override {
    validate(f.opt.autoChoice);
    const int nl = int(f.lights.size()), S = f.mapSize;
    // The camera's pixel footprint and each light's caster distance, from the G-buffer and the
    // lights' depth maps mapped (every 4th pixel is plenty for a median): on a CPU device that
    // copies nothing (bench/results/cpu_speed.md; the maps are 38 MiB for 64 lights at 384^2, of
    // which the medians read a few texels, and the G-buffer's two planes 7 MiB at 640x360, which
    // had been read into vectors kept between frames).
    const std::size_t pixels = std::size_t(f.pixels);
    Context::ReadView posView =
        f.ctx.mapRead(f.gpos, pixels * sizeof(cl_float4), "auto positions");
    Context::ReadView nrmView = f.ctx.mapRead(f.gnrm, pixels * sizeof(cl_float4), "auto normals");
    Context::ReadView mapView =
        f.ctx.mapRead(f.depth, std::size_t(S) * S * nl * sizeof(cl_uint), "auto shadow maps");
    const auto* maps = static_cast<const cl_uint*>(mapView.data());
    const auto* gpos = static_cast<const cl_float4*>(posView.data());
    const auto* gnrm = static_cast<const cl_float4*>(nrmView.data());
    const double pixel = pixelFootprint(gpos, f.width, f.height, &footprint_);
    std::vector<AutoLight> info(nl);
    const bool known = f.areaLights && int(f.areaLights->size()) == nl;
    // Each light's caster distance is a median: every 4th pixel, at most kCasterSamples of them,
    // is plenty. The lights' medians run in threads (the device waits for the choice meanwhile).
    const int step =
        std::max(4, int((std::size_t(f.pixels) + kCasterSamples - 1) / kCasterSamples));
    casterSamples(gpos, gnrm, pixels, step, samples_);
    const unsigned threads =
        std::max(1u, std::min(std::thread::hardware_concurrency(), unsigned(nl)));
    gaps_.resize(threads);
    sines_.resize(threads);
    // the receivers' height only where the rule reads it (some light could get PCSS)
    const AutoOptions& ao = f.opt.autoChoice;
    const bool heights = ao.pcssTexels > 0 && ao.pcssMinElevationDeg > 0;
    std::vector<CasterStats> stats(nl);
    auto lights = [&](unsigned t) {
      for (int l = int(t); l < nl; l += int(threads))
        stats[l] = casterStats(f.lights[l], maps + std::size_t(S) * S * l, S, samples_,
                               f.opt.shadow.depthBias, gaps_[t], heights ? &sines_[t] : nullptr);
    };
    std::vector<std::thread> pool;
    for (unsigned t = 1; t < threads; ++t) pool.emplace_back(lights, t);
    lights(0);
    for (std::thread& t : pool) t.join();
    // unmapped before the techniques' kernels read the maps (and the next frame's write the
    // G-buffer)
    mapView = Context::ReadView();
    posView = Context::ReadView();
    nrmView = Context::ReadView();
    for (int l = 0; l < nl; ++l) {
      info[l] = autoLight(f.lights[l], known ? &(*f.areaLights)[l] : nullptr, S, stats[l].distance);
      info[l].receiverSin = stats[l].receiverSin;
      info[l].screenCos = stats[l].screenCos;
    }
    // The bitmask technique needs the scene's triangles; a frame without them (the GL interop)
    // gets no exact lights.
    choice_ = chooseShadowTechniques(info, pixel, f.opt.autoChoice, f.opt.shadow.maxFilterTexels,
                                     f.triangleCount > 0);
    pixel_ = pixel;
    bytes_ = 0;
    ran_.clear();
    for (ShadowTechnique t : kChoices) {
      std::vector<int> subset, rows;
      for (int l = 0; l < nl; ++l)
        if (choice_[l] == t) {
          rows.push_back(int(rows.size()));
          subset.push_back(l);
        }
      if (subset.empty()) continue;
      std::unique_ptr<ShadowPass>& pass = passes_[t];
      if (!pass) pass = makeShadowPass(t);
      if (int(subset.size()) == nl) {
        pass->computeVisibility(f);  // one technique for all: the frame as it is
      } else {
        run(f, t, *pass, subset, rows);
      }
      const std::size_t texels = std::size_t(S) * S * subset.size();
      bytes_ += pass->frameBytes(f.opt, texels);
      ran_.push_back(t);
    }
  }

  bool lightFromShadowMap(int l) const override {
    return l >= 0 && l < int(choice_.size()) && choice_[l] != ShadowTechnique::Bitmask &&
           choice_[l] != ShadowTechnique::BitmaskHard;
  }
  std::size_t bytesPerTexel(const RenderOptions&) const override { return sizeof(cl_uint); }
  std::size_t frameBytes(const RenderOptions&, std::size_t) const override { return bytes_; }

  // Per technique its light count ("auto/lights_hard", ..., "auto/lights_exact"), the pixel
  // footprint the rule used, each light's choice as "auto/light_<i>" = its ShadowTechnique value
  // (the report lists them by name), then the sub-passes' own statistics ("<technique>/<name>").
  std::vector<std::pair<std::string, double>> frameStats() const override {
    std::vector<std::pair<std::string, double>> s;
    for (ShadowTechnique t : kChoices)
      s.emplace_back(countName(t), double(std::count(choice_.begin(), choice_.end(), t)));
    s.emplace_back("auto/pixel_footprint", pixel_);
    for (std::size_t l = 0; l < choice_.size(); ++l)
      s.emplace_back("auto/light_" + std::to_string(l), double(int(choice_[l])));
    // asked here, not when the techniques ran: the bitmask's statistics wait for its read-back
    for (ShadowTechnique t : ran_)
      for (auto& [name, v] : passes_.at(t)->frameStats())
        s.emplace_back(std::string(toString(t)) + "/" + name, v);
    return s;
  }

 private:
  // The lights `subset` of f through `pass`: a frame of those lights alone (their frames uploaded,
  // their depth maps copied out of f's), its visibility rows copied back into f.vis; or, for a
  // pass that reads ShadowFrame::rows, f's own maps and visibility rows in place (MSSM4 on CPUs:
  // the copies were 36 MiB and 3 ms of the 32-light frame).
  void run(ShadowFrame& f, ShadowTechnique t, ShadowPass& pass, const std::vector<int>& subset,
           const std::vector<int>& rows) {
    Sub& sub = subs_[t];
    const std::string role = std::string("auto ") + toString(t);
    const std::size_t k = subset.size(), S2 = std::size_t(f.mapSize) * f.mapSize;
    sub.lights.clear();
    sub.areaLights.clear();
    for (int l : subset) {
      sub.lights.push_back(f.lights[l]);
      if (f.areaLights && f.areaLights->size() == f.lights.size())
        sub.areaLights.push_back((*f.areaLights)[l]);
    }
    ShadowFrame s(f, sub.lights);
    s.lightBuffer = f.pool.upload(role + " lights", sub.lights);
    s.areaLights = sub.areaLights.empty() ? nullptr : &sub.areaLights;
    if (pass.readsFrameRows(f.ctx, f.opt)) {
      // the subset reads the frame's maps and writes its visibility rows where they are
      s.depth = f.depth;
      s.vis = f.vis;
      s.rows = f.pool.upload(role + " rows", subset);
      pass.computeVisibility(s);
      return;
    }
    if (pass.usesShadowMaps()) {
      s.depth = f.pool.buffer(role + " shadow maps", S2 * k * sizeof(cl_uint));
      copyRows(f.ctx, f.depth, subset, s.depth, rows, S2 * sizeof(cl_uint));
      bytes_ += S2 * k * sizeof(cl_uint);
    } else {
      s.depth = f.depth;
    }
    const std::size_t rowBytes = std::size_t(f.pixels) * sizeof(cl_float);
    s.vis = f.pool.buffer(role + " visibility", rowBytes * k);
    pass.computeVisibility(s);
    copyRows(f.ctx, s.vis, rows, f.vis, subset, rowBytes);
    bytes_ += rowBytes * k;
  }

  std::vector<CasterSample> samples_;  // casterDistance's pixels, storage reused
  std::vector<double> footprint_;      // pixelFootprint's distances, storage reused
  std::vector<std::vector<double>> gaps_, sines_;  // its scratch, one per thread
  // A technique's subset, kept between frames: the frame holds references to these.
  struct Sub {
    std::vector<pb_light> lights;
    std::vector<AreaLight> areaLights;
  };
  std::map<ShadowTechnique, std::unique_ptr<ShadowPass>> passes_;  // kept between frames
  std::map<ShadowTechnique, Sub> subs_;
  std::vector<ShadowTechnique> choice_;
  std::vector<ShadowTechnique> ran_;  // the techniques this frame ran, in order
  double pixel_ = 0;
  std::size_t bytes_ = 0;
};

}  // namespace

std::unique_ptr<ShadowPass> makeAutoPass() { return std::make_unique<AutoPass>(); }

}  // namespace penumbra::detail
