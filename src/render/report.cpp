// The JSON report of a rendered frame (renderReportJson, include/penumbra/renderer.hpp), written
// with nlohmann-json so names with quotes, backslashes or non-ASCII text stay valid JSON. Option
// blocks follow RenderOptions: "shadow" the shared settings, "mssm", "cssm", ... each technique's.
#include <charconv>
#include <cmath>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "penumbra/environment.hpp"
#include "penumbra/renderer.hpp"
#include "penumbra/version.hpp"

namespace penumbra {
namespace {

using Json = nlohmann::ordered_json;

// A float option as the shortest decimal that reads back as the same float (0.1f is 0.1, not
// 0.10000000149011612), through to_chars/from_chars, which ignore the locale.
double decimal(float v) {
  if (!std::isfinite(v)) return double(v);
  char buf[32];
  auto r = std::to_chars(buf, buf + sizeof buf, v);
  double d = 0.0;
  std::from_chars(buf, r.ptr, d);
  return d;
}

Json number(double v) {
  if (!std::isfinite(v)) return nullptr;  // JSON has no NaN or infinity
  // counts stay integers, not 1e+06
  if (v == std::floor(v) && std::fabs(v) < 9e15) return static_cast<long long>(v);
  return v;
}

}  // namespace

std::string renderReportJson(const std::string& device, const LightSet& lights,
                             const Environment& env, const RenderOptions& opt, const Frame& f,
                             const ReportInfo& info) {
  Json o;
  o["version"] = PENUMBRA_VERSION;
  if (!info.command.empty()) o["command"] = info.command;
  if (!info.scene.empty() || !info.environment.empty() || !info.lightSet.empty())
    o["inputs"] = {{"scene", info.scene}, {"environment", info.environment},
                   {"light_set", info.lightSet}};
  o["device"] = device;
  o["environment"] = env.source;
  o["lights"] = lights.lights.size();
  o["extract"] = lights.method;
  o["sanitized_pixels"] = env.sanitizedPixels;
  o["non_finite_values"] = env.nonFiniteValues;
  o["negative_values"] = env.negativeValues;
  o["shadows"] = toString(opt.shadows);
  o["width"] = opt.width;
  o["height"] = opt.height;
  o["shadow_map_size"] = opt.shadowMapSize;
  o["shadow_map_bytes"] = f.shadowMapBytes;
  o["shadow_map_bytes_per_texel"] =
      f.shadowMapBytes /
      std::max<std::size_t>(1, std::size_t(opt.shadowMapSize) * opt.shadowMapSize * lights.lights.size());
  o["shadow"] = {{"depth_bias", decimal(opt.shadow.depthBias)},
                 {"light_size_scale", decimal(opt.shadow.lightSizeScale)},
                 {"max_filter_texels", decimal(opt.shadow.maxFilterTexels)},
                 {"min_filter_texels", decimal(opt.shadow.minFilterTexels)}};
  o["mssm"] = {{"moment_bias", decimal(opt.mssm.momentBias)},
               {"slope_bias", decimal(opt.mssm.slopeBias)},
               {"blocker_epsilon", decimal(opt.mssm.blockerEpsilon)},
               {"upper_bound_blocker", opt.mssm.upperBoundBlocker},
               {"upper_bound_tilt", decimal(opt.mssm.upperBoundTilt)}};
  o["prefilter"] = toString(opt.prefilter);
  o["front_back_faces"] = opt.frontBackFaces;
  o["bent_normals"] = opt.bentNormals;
  o["bent_normals_scale"] = decimal(opt.bentNormalsScale);
  o["cssm"] = {{"order", opt.cssm.order},
               {"sharpen_a", decimal(opt.cssm.sharpenA)},
               {"sharpen_b", decimal(opt.cssm.sharpenB)}};
  o["pcss"] = {{"blocker_taps", opt.pcss.blockerTaps}, {"filter_taps", opt.pcss.filterTaps}};
  o["brute"] = {{"samples", opt.brute.samples}};
  o["bitmask"] = {{"light_samples", opt.bitmask.lightSamples}, {"list_size", opt.bitmask.listSize}};
  o["auto"] = {{"exact_lights", opt.autoChoice.exactLights},
               {"hard_pixels", decimal(opt.autoChoice.hardPixels)},
               {"pcss_texels", decimal(opt.autoChoice.pcssTexels)}};
  // `auto` reports each light's technique as the stat "auto/light_<i>" (a ShadowTechnique value,
  // lights in order): listed by name in "auto_lights" instead.
  const std::string perLight = "auto/light_";
  Json stats = Json::object(), autoLights = Json::array();
  for (const auto& [name, v] : f.stats) {
    if (name.compare(0, perLight.size(), perLight) == 0)
      autoLights.push_back(toString(static_cast<ShadowTechnique>(int(v))));
    else
      stats[name] = number(v);
  }
  o["stats"] = stats;
  if (!autoLights.empty()) o["auto_lights"] = autoLights;
  Json timings = Json::object();
  for (const auto& [stage, ms] : f.timingsMs) timings[stage] = std::isfinite(ms) ? Json(ms) : Json(nullptr);
  o["timings_ms"] = timings;
  // replace: a name that is not valid UTF-8 (a Latin-1 file name) is written with U+FFFD instead
  // of throwing, so the report is still valid JSON.
  return o.dump(2, ' ', false, Json::error_handler_t::replace) + "\n";
}

}  // namespace penumbra
