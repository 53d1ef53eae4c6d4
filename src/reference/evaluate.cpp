// The error budget (include/penumbra/evaluate.hpp): the three Embree truths (cached by a digest of
// what they depend on), the budget's figures over geometry and penumbra pixels, its JSON and text,
// and the heat maps (metrics/heatmap.hpp's colour maps, a scale bar under each image).
#include "penumbra/evaluate.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>

#include "core/json.hpp"
#include "penumbra/environment.hpp"
#include "penumbra/error.hpp"
#include "penumbra/heatmap.hpp"
#include "common/shared.h"
#include "metrics/heatmap.hpp"

namespace penumbra {
namespace {

namespace fs = std::filesystem;
constexpr double kNaN = BudgetLine::kNaN;

// FNV-1a, 64 bits (Fowler, Noll and Vo): a digest for cache file names, not for security.
class Digest {
 public:
  void bytes(const void* p, std::size_t n) {
    const auto* c = static_cast<const unsigned char*>(p);
    for (std::size_t i = 0; i < n; ++i) h_ = (h_ ^ c[i]) * 0x100000001B3ull;
  }
  template <class... T>
  void value(const T&... v) { (bytes(&v, sizeof v), ...); }
  template <class T>
  void vec(const std::vector<T>& v) {
    value(v.size());
    if (!v.empty()) bytes(v.data(), v.size() * sizeof(T));
  }
  void text(const std::string& s) {
    value(s.size());
    bytes(s.data(), s.size());
  }
  std::string hex() const {
    char buf[17];
    std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h_));
    return buf;
  }

 private:
  std::uint64_t h_ = 0xCBF29CE484222325ull;
};

// A truth in the cache: NAME.exr (the image, its noise in the header as `penumbra reference`
// writes it), NAME-half-a.exr, NAME-half-b.exr and, in light-set mode, NAME-visibility.exr. The
// noise is recomputed from the halves when read.
std::vector<std::string> cacheFiles(const std::string& base, bool withVisibility) {
  std::vector<std::string> f = {base + ".exr", base + "-half-a.exr", base + "-half-b.exr"};
  if (withVisibility) f.push_back(base + "-visibility.exr");
  return f;
}

void writeCached(const std::vector<std::string>& files, const ReferenceImage& r) {
  // The image last: its presence is what marks a complete entry.
  writeImage(files[1], r.halfA);
  writeImage(files[2], r.halfB);
  if (files.size() > 3) writeImage(files[3], r.visibility);
  writeImage(files[0], r.image, 1.0f, {{kRelativeNoiseAttribute, r.relativeNoise}});
}

ReferenceImage readCached(const std::vector<std::string>& files) {
  ReferenceImage r;
  r.image = readImage(files[0]);
  r.halfA = readImage(files[1]);
  r.halfB = readImage(files[2]);
  if (files.size() > 3) r.visibility = readImage(files[3]);
  const Image& im = r.image;
  for (const Image* h : {&r.halfA, &r.halfB})
    if (im.channels != 4 || h->channels != 4 || h->width != im.width || h->height != im.height)
      badInput("EvaluateOptions.cacheDir: " + files[0] + " and its halves are not a cached truth");
  if (files.size() > 3 && (r.visibility.channels != 1 || r.visibility.width != im.width ||
                           r.visibility.height != im.height))
    badInput("EvaluateOptions.cacheDir: " + files[3] + " is not a cached visibility");
  r.relativeNoise = relativeNoiseOfHalves(r.halfA, r.halfB, r.image);
  return r;
}

// A truth from the cache, or computed (and then cached).
template <class Compute>
ReferenceImage cachedTruth(const std::string& dir, const std::string& name, bool withVisibility,
                           bool& fromCache, Compute&& compute) {
  const std::vector<std::string> files =
      dir.empty() ? std::vector<std::string>() : cacheFiles((fs::path(dir) / name).string(), withVisibility);
  std::error_code ec;
  bool present = !files.empty();
  for (const std::string& f : files) present = present && fs::is_regular_file(f, ec);
  if (present) {
    fromCache = true;
    return readCached(files);
  }
  fromCache = false;
  ReferenceImage r = compute();
  if (!files.empty()) {
    try {
      writeCached(files, r);
    } catch (const Error& e) {
      badInput(std::string("EvaluateOptions.cacheDir: cannot write the truth: ") + e.what());
    }
  }
  return r;
}

// An operand of an error image: the full image and its two halves (the frame's halves are itself).
struct Operand {
  const Image* full;
  const Image* a;
  const Image* b;
};
Operand operand(const ReferenceImage& r) { return {&r.image, &r.halfA, &r.halfB}; }
Operand operand(const Image& frame) { return {&frame, &frame, &frame}; }

double luminance(const float* p) { return PB_LUM_R * p[0] + PB_LUM_G * p[1] + PB_LUM_B * p[2]; }

}  // namespace

std::string truthKey(const Scene& scene, const Camera& camera, const Environment& env,
                     const LightSet* lights, const ReferenceOptions& opt) {
  Digest d;
  // 2: light sets are hashed as nlohmann-json writes them (LightSet::toJson), since issue 16.
  d.text("penumbra truth 2");
  d.value(scene.meshes.size());
  for (const Mesh& m : scene.meshes) {
    d.vec(m.positions);
    d.vec(m.normals);
    d.vec(m.triangles);
    d.value(m.albedo);
  }
  d.value(camera.eye, camera.target, camera.up, camera.fovyDeg);
  d.value(opt.width, opt.height, opt.spp, opt.seed);
  d.value(env.equirect.width, env.equirect.height, env.equirect.channels);
  d.vec(env.equirect.pixels);
  d.value(env.rotationYDeg);
  if (lights) {
    d.text(lights->toJson());
    d.value(opt.shadowAmbient);
  }
  return d.hex();
}

EvaluateTruths evaluateTruths(const Scene& scene, const Camera& camera, const LightSet& lights,
                              const Environment& env, const EvaluateOptions& opt) {
  if (!opt.cacheDir.empty()) {
    std::error_code ec;
    fs::create_directories(opt.cacheDir, ec);
    if (!fs::is_directory(opt.cacheDir))
      badInput("EvaluateOptions.cacheDir " + opt.cacheDir + ": cannot create the directory" +
               (ec ? " (" + ec.message() + ")" : std::string()));
  }
  EvaluateTruths t;
  ReferenceOptions ro = opt.truth;
  ro.shadowAmbient = false;
  // The truths are compared over geometry pixels only, and FLIP filters across pixels: a truth
  // without its map behind the geometry needs no blacking out, and its cache key (which does not
  // hold the background) stays exact.
  ro.environmentBackground = false;
  // One progress from 0 to 1 over the three truths: a third each.
  int stage = 0;
  if (opt.truth.progress)
    ro.progress = [&stage, &opt](double f) { opt.truth.progress((stage + f) / 3.0); };
  t.environment = cachedTruth(opt.cacheDir, truthKey(scene, camera, env, nullptr, ro) + "-environment",
                              false, t.fromCache[0],
                              [&] { return referenceEnvironmentWithNoise(scene, camera, env, ro); });
  stage = 1;
  t.lights = cachedTruth(opt.cacheDir, truthKey(scene, camera, env, &lights, ro) + "-lights", true,
                         t.fromCache[1],
                         [&] { return referenceLightsWithNoise(scene, camera, lights, env, ro); });
  ro.shadowAmbient = true;
  stage = 2;
  t.lightsShadowedAmbient = cachedTruth(
      opt.cacheDir, truthKey(scene, camera, env, &lights, ro) + "-lights-shadowed-ambient", true,
      t.fromCache[2], [&] { return referenceLightsWithNoise(scene, camera, lights, env, ro); });
  return t;
}

ErrorBudget errorBudget(const Image& frame, const EvaluateTruths& truths,
                        const EvaluateOptions& opt) {
  const Image& G = truths.environment.image;
  const Image& L = truths.lights.image;
  const Image& S = truths.lightsShadowedAmbient.image;
  for (const Image* im : {&frame, &L, &S, &G})
    if (im->width != G.width || im->height != G.height || im->channels != 4)
      badInput("errorBudget: the frame and the truths must be RGBA images of one size (frame " +
               std::to_string(frame.width) + "x" + std::to_string(frame.height) + ", truth " +
               std::to_string(G.width) + "x" + std::to_string(G.height) + ")");
  const std::size_t n = std::size_t(G.width) * std::size_t(G.height);
  const Image& vis = truths.lights.visibility;

  ErrorBudget b;
  b.noiseEnvironment = truths.environment.relativeNoise;
  b.noiseLights = truths.lights.relativeNoise;
  b.noiseShadowedAmbient = truths.lightsShadowedAmbient.relativeNoise;
  b.penumbraMask = Image(G.width, G.height, 1, 0.0f);
  Image geometryMask(G.width, G.height, 1, 0.0f);
  for (std::size_t i = 0; i < n; ++i) {
    if (!(G.pixels[i * G.channels + 3] > 0.5f)) continue;
    geometryMask.pixels[i] = 1.0f;
    ++b.geometryPixels;
    const float v = vis.empty() ? 1.0f : vis.pixels[i];
    if (v > opt.penumbraLow && v < opt.penumbraHigh) {
      b.penumbraMask.pixels[i] = 1.0f;
      ++b.penumbraPixels;
    }
  }
  if (b.geometryPixels == 0) badInput("errorBudget: no geometry pixels in the environment truth");

  // One region (whole frame or penumbra) at a time.
  auto region = [&](const Image& mask, bool penumbra) {
    double sumG = 0;
    std::size_t values = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (!(mask.pixels[i] > 0.5f)) continue;
      for (int k = 0; k < 3; ++k) sumG += G.pixels[i * G.channels + k];
      values += 3;
    }
    const double mean = values ? sumG / double(values) : kNaN;
    // The relative RMSE of X - Y and the noise of that error from the halves.
    auto line = [&](Operand x, Operand y, double& rel, double& noise) {
      double sq = 0, halfSq = 0;
      for (std::size_t i = 0; i < n; ++i) {
        if (!(mask.pixels[i] > 0.5f)) continue;
        for (int k = 0; k < 3; ++k) {
          const std::size_t at = i * 4 + k;
          const double e = double(x.full->pixels[at]) - double(y.full->pixels[at]);
          const double h = (double(x.a->pixels[at]) - double(y.a->pixels[at])) -
                           (double(x.b->pixels[at]) - double(y.b->pixels[at]));
          sq += e * e;
          halfSq += h * h;
        }
      }
      rel = values ? std::sqrt(sq / double(values)) / mean : kNaN;
      noise = values ? 0.5 * std::sqrt(halfSq / double(values)) / mean : kNaN;
    };
    auto pick = [&](BudgetLine& l, Operand x, Operand y) {
      line(x, y, penumbra ? l.relativeRmsePenumbra : l.relativeRmse,
           penumbra ? l.noisePenumbra : l.noise);
    };
    pick(b.total, operand(frame), operand(truths.environment));
    pick(b.floor, operand(truths.lights), operand(truths.environment));
    pick(b.technique, operand(frame), operand(truths.lights));
    pick(b.ambient, operand(truths.lights), operand(truths.lightsShadowedAmbient));
    double cross = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (!(mask.pixels[i] > 0.5f)) continue;
      for (int k = 0; k < 3; ++k) {
        const std::size_t at = i * 4 + k;
        cross += (double(L.pixels[at]) - double(G.pixels[i * G.channels + k])) *
                 (double(frame.pixels[at]) - double(L.pixels[at]));
      }
    }
    (penumbra ? b.crossPenumbra : b.cross) = values ? cross / double(values) / (mean * mean) : kNaN;
    (penumbra ? b.truthMeanPenumbra : b.truthMean) = mean;
  };
  region(geometryMask, false);
  region(b.penumbraMask, true);

  // Signed bias per channel over the geometry pixels, and the technique's over the lit ones.
  for (std::size_t i = 0; i < n; ++i)
    b.litPixels += geometryMask.pixels[i] > 0.5f && (vis.empty() || vis.pixels[i] >= opt.penumbraHigh);
  for (int k = 0; k < 3; ++k) {
    double dT = 0, dQ = 0, sG = 0, sL = 0, dLit = 0, sLit = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (!(geometryMask.pixels[i] > 0.5f)) continue;
      const std::size_t at = i * 4 + k;
      dT += double(frame.pixels[at]) - double(G.pixels[at]);
      dQ += double(frame.pixels[at]) - double(L.pixels[at]);
      sG += G.pixels[at];
      sL += L.pixels[at];
      if (vis.empty() || vis.pixels[i] >= opt.penumbraHigh) {
        dLit += double(frame.pixels[at]) - double(L.pixels[at]);
        sLit += L.pixels[at];
      }
    }
    b.biasTotal[std::size_t(k)] = sG > 0 ? dT / sG : kNaN;
    b.biasTechnique[std::size_t(k)] = sL > 0 ? dQ / sL : kNaN;
    b.biasTechniqueLit[std::size_t(k)] = sLit > 0 ? dLit / sLit : kNaN;
  }

  // Mean HDR-FLIP of each line, over the geometry pixels (flip's own mean) and the penumbra.
  auto maskedMean = [&](const Image& map, const Image& mask) {
    double s = 0;
    std::size_t c = 0;
    for (std::size_t i = 0; i < n; ++i)
      if (mask.pixels[i] > 0.5f) {
        s += map.pixels[i * map.channels];
        ++c;
      }
    return c ? s / double(c) : kNaN;
  };
  // FLIP filters across pixels, so the frame's background (the map) would bleed into the
  // geometry's edge: the frame gets the truths' black background (evaluateTruths renders them
  // without the map).
  Image frameB = frame;
  for (std::size_t i = 0; i < n; ++i)
    if (!(geometryMask.pixels[i] > 0.5f))
      for (int k = 0; k < 3; ++k) frameB.pixels[i * 4 + k] = 0.0f;
  const Image &GB = G, &LB = L, &SB = S;
  auto flipLine = [&](BudgetLine& l, const Image& test, const Image& ref, Image* keep) {
    FlipResult f = flip(test, ref, opt.flip, &geometryMask);
    l.flip = f.mean;
    l.flipPenumbra = maskedMean(f.map, b.penumbraMask);
    if (keep) *keep = std::move(f.map);
  };
  flipLine(b.total, frameB, GB, &b.flipTotalMap);
  flipLine(b.floor, LB, GB, nullptr);
  flipLine(b.technique, frameB, LB, &b.flipTechniqueMap);
  flipLine(b.ambient, LB, SB, nullptr);
  b.spp = opt.truth.spp;
  b.seed = opt.truth.seed;
  b.penumbraLow = opt.penumbraLow;
  b.penumbraHigh = opt.penumbraHigh;
  return b;
}

namespace {

using detail::Json;
Json number(double v) { return detail::finiteOrNull(v); }

Json lineJson(const BudgetLine& l) {
  return {{"relative_rmse", number(l.relativeRmse)},
          {"relative_rmse_penumbra", number(l.relativeRmsePenumbra)},
          {"flip", number(l.flip)},
          {"flip_penumbra", number(l.flipPenumbra)},
          {"noise", number(l.noise)},
          {"noise_penumbra", number(l.noisePenumbra)},
          {"relative_rmse_without_noise", number(l.withoutNoise())},
          {"relative_rmse_penumbra_without_noise", number(l.withoutNoisePenumbra())},
          {"below_noise", l.belowNoise()},
          {"below_noise_penumbra", l.belowNoisePenumbra()}};
}

Json rgb(const std::array<double, 3>& v) {
  return Json::array({number(v[0]), number(v[1]), number(v[2])});
}

}  // namespace

std::string toJson(const ErrorBudget& b) {
  Json j;
  j["shadows"] = b.shadows;
  j["lights"] = b.lights;
  j["frame_ms"] = number(b.frameMs);
  j["spp"] = b.spp;
  j["seed"] = b.seed;
  j["pixels"] = b.geometryPixels;
  j["penumbra_pixels"] = b.penumbraPixels;
  j["penumbra_visibility"] = {b.penumbraLow, b.penumbraHigh};
  j["total"] = lineJson(b.total);
  j["floor"] = lineJson(b.floor);
  j["technique"] = lineJson(b.technique);
  j["ambient"] = lineJson(b.ambient);
  j["cross"] = number(b.cross);
  j["cross_penumbra"] = number(b.crossPenumbra);
  const double t = b.total.relativeRmse, f = b.floor.relativeRmse, q = b.technique.relativeRmse;
  j["sum_check"] = {{"total_sq", number(t * t)}, {"parts_sq", number(f * f + q * q + 2 * b.cross)}};
  j["truth_noise"] = {{"environment", number(b.noiseEnvironment)},
                      {"lights", number(b.noiseLights)},
                      {"lights_shadowed_ambient", number(b.noiseShadowedAmbient)}};
  j["bias_total"] = rgb(b.biasTotal);
  j["bias_technique"] = rgb(b.biasTechnique);
  j["bias_technique_lit"] = rgb(b.biasTechniqueLit);
  j["lit_pixels"] = b.litPixels;
  return detail::dumpJson(j, 2) + "\n";
}

namespace {

// printf's %<width>.<precision><f|g> as in the C locale, whatever the process's locale is:
// to_chars formats as printf does in the C locale. `plus` writes the sign of positive values too.
std::string format(double v, std::chars_format form, int precision, int width = 0,
                   bool plus = false) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v, form, precision);
  std::string s(buf, r.ptr);
  if (plus && s[0] != '-') s.insert(s.begin(), '+');
  if (int(s.size()) < width) s.insert(0, std::size_t(width) - s.size(), ' ');
  return s;
}
std::string fixed(double v, int precision, int width = 0) {
  return format(v, std::chars_format::fixed, precision, width);
}

}  // namespace

std::string toText(const ErrorBudget& b) {
  constexpr auto general = std::chars_format::general;
  auto pct = [](double v) {
    return std::isfinite(v) ? fixed(100.0 * v, 2, 6) + "%" : std::string("    -  ");
  };
  auto flipText = [](double v) { return std::isfinite(v) ? fixed(v, 4, 6) : std::string("   -  "); };
  std::string o = "frame: " + b.shadows + ", " + std::to_string(b.lights) + " lights, " +
                  fixed(b.frameMs, 2) + " ms (render, warm)\n";
  o += "truths: " + std::to_string(b.spp) + " spp, seed " + std::to_string(b.seed) + "; pixels: " +
       std::to_string(b.geometryPixels) + " geometry, " + std::to_string(b.penumbraPixels) +
       " penumbra (" + format(100.0 * b.penumbraLow, general, 6) + "%.." +
       format(100.0 * b.penumbraHigh, general, 6) + "% of the lights' irradiance arrives)\n";
  o += "           whole frame: rel. RMSE (noise) w/o noise | penumbra: rel. RMSE (noise) w/o "
       "noise | FLIP, penumbra\n";
  auto row = [&](std::string name, const BudgetLine& l) {
    name.resize(std::max<std::size_t>(name.size(), 10), ' ');
    o += name + " " + pct(l.relativeRmse) + " (" + pct(l.noise) + ")" +
         (l.belowNoise() ? "~" : " ") + " " + pct(l.withoutNoise()) + " | " +
         pct(l.relativeRmsePenumbra) + " (" + pct(l.noisePenumbra) + ")" +
         (l.belowNoisePenumbra() ? "~" : " ") + " " + pct(l.withoutNoisePenumbra()) + " | " +
         flipText(l.flip) + " " + flipText(l.flipPenumbra) + "\n";
  };
  row("total", b.total);
  row("floor", b.floor);
  row("technique", b.technique);
  row("ambient", b.ambient);
  o += "(~: below twice the noise it sits in, not resolved by these truths)\n";
  const double t = b.total.relativeRmse, f = b.floor.relativeRmse, q = b.technique.relativeRmse;
  o += "sum: total^2 " + format(t * t, general, 6) + " = floor^2 + technique^2 + 2 cross = " +
       format(f * f, general, 6) + " + " + format(q * q, general, 6) + " + 2 x " +
       format(b.cross, general, 6) + " = " + format(f * f + q * q + 2 * b.cross, general, 6) + "\n";
  o += "truth noise: environment " + pct(b.noiseEnvironment) + ", lights " + pct(b.noiseLights) +
       ", lights shadowed ambient " + pct(b.noiseShadowedAmbient) + "\n";
  auto bias = [](const std::array<double, 3>& v) {
    return format(v[0], std::chars_format::fixed, 4, 0, true) + " " +
           format(v[1], std::chars_format::fixed, 4, 0, true) + " " +
           format(v[2], std::chars_format::fixed, 4, 0, true);
  };
  o += "bias (mean signed error / truth mean, RGB): total " + bias(b.biasTotal) + ", technique " +
       bias(b.biasTechnique) + "\n";
  o += "technique bias where the lights' truth is lit (" + std::to_string(b.litPixels) +
       " pixels, >= " + format(b.penumbraHigh * 100, std::chars_format::general, 3) +
       "% of the irradiance arrives): " + bias(b.biasTechniqueLit) + "\n";
  return o;
}

std::vector<std::string> writeHeatMaps(const ErrorBudget& b, const Image& frame,
                                       const EvaluateTruths& truths, const std::string& dir,
                                       double* scaleOut) {
  if (!fs::is_directory(dir)) badInput("writeHeatMaps: directory " + dir + " does not exist");
  const Image& G = truths.environment.image;
  const int W = G.width, H = G.height;
  const std::size_t n = std::size_t(W) * std::size_t(H);
  const double mean = b.truthMean;
  // Signed luminance errors relative to the truth's mean; one scale for all three maps.
  auto signedError = [&](const Image& x, const Image& y) {
    std::vector<float> e(n, 0.0f);
    for (std::size_t i = 0; i < n; ++i)
      if (G.pixels[i * G.channels + 3] > 0.5f)
        e[i] = float((luminance(&x.pixels[i * 4]) - luminance(&y.pixels[i * 4])) / mean);
    return e;
  };
  const std::vector<float> eTotal = signedError(frame, G),
                           eFloor = signedError(truths.lights.image, G),
                           eTech = signedError(frame, truths.lights.image);
  std::vector<float> mags;
  for (std::size_t i = 0; i < n; ++i)
    if (G.pixels[i * G.channels + 3] > 0.5f) mags.push_back(std::fabs(eTotal[i]));
  const double s = detail::roundedScale(mags);
  if (scaleOut) *scaleOut = s;
  // Blue (darker than the truth), white, red (brighter).
  const detail::ColourMap diverging = detail::divergingColourMap(), magma = detail::magmaColourMap();
  std::vector<std::string> written;
  auto signedMap = [&](const std::vector<float>& e, const std::string& name) {
    std::vector<float> v(n);
    for (std::size_t i = 0; i < n; ++i) v[i] = float(std::clamp(0.5 + 0.5 * e[i] / s, 0.0, 1.0));
    const std::string path = (fs::path(dir) / name).string();
    writeDisplayImage(path, detail::withScaleBar(detail::colourMapped(v, W, H, diverging, &G), diverging,
                                                 detail::percentLabel(-s, true), "0",
                                                 detail::percentLabel(s, true)));
    written.push_back(path);
  };
  signedMap(eTotal, "error-total.png");
  signedMap(eFloor, "error-floor.png");
  signedMap(eTech, "error-technique.png");

  // FLIP maps through magma.
  auto flipMap = [&](const Image& map, const std::string& name) {
    if (map.empty()) return;
    std::vector<float> v(n);
    for (std::size_t i = 0; i < n; ++i) v[i] = map.pixels[i * map.channels];
    const std::string path = (fs::path(dir) / name).string();
    writeDisplayImage(path, detail::withScaleBar(detail::colourMapped(v, W, H, magma, &G), magma,
                                                 "0", "FLIP 0.5", "1"));
    written.push_back(path);
  };
  flipMap(b.flipTotalMap, "flip-total.png");
  flipMap(b.flipTechniqueMap, "flip-technique.png");
  return written;
}

}  // namespace penumbra
