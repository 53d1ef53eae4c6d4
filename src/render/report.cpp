// The JSON report of a rendered frame (renderReportJson, include/penumbra/renderer.hpp). Option
// blocks follow RenderOptions: "shadow" the shared settings, "mssm", "cssm", ... each technique's.
#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include "penumbra/environment.hpp"
#include "penumbra/renderer.hpp"

namespace penumbra {

std::string renderReportJson(const std::string& device, const LightSet& lights,
                             const Environment& env, const RenderOptions& opt, const Frame& f) {
  std::ostringstream o;
  o.precision(6);
  o << "{\n  \"device\": \"" << device << "\",\n  \"environment\": \"" << env.source
    << "\",\n  \"lights\": " << lights.lights.size() << ",\n  \"extract\": \"" << lights.method
    << "\",\n  \"sanitized_pixels\": " << env.sanitizedPixels
    << ",\n  \"non_finite_values\": " << env.nonFiniteValues
    << ",\n  \"negative_values\": " << env.negativeValues << ",\n  \"shadows\": \""
    << toString(opt.shadows) << "\",\n  \"width\": " << opt.width << ",\n  \"height\": "
    << opt.height << ",\n  \"shadow_map_size\": " << opt.shadowMapSize
    << ",\n  \"shadow_map_bytes\": " << f.shadowMapBytes
    << ",\n  \"shadow_map_bytes_per_texel\": "
    << (f.shadowMapBytes / std::max<std::size_t>(1, std::size_t(opt.shadowMapSize) * opt.shadowMapSize * lights.lights.size())) << ",\n  \"shadow\": {\"depth_bias\": "
    << opt.shadow.depthBias << ", \"light_size_scale\": " << opt.shadow.lightSizeScale
    << ", \"max_filter_texels\": " << opt.shadow.maxFilterTexels
    << ", \"min_filter_texels\": " << opt.shadow.minFilterTexels
    << "},\n  \"mssm\": {\"moment_bias\": " << opt.mssm.momentBias
    << ", \"slope_bias\": " << opt.mssm.slopeBias
    << ", \"blocker_epsilon\": " << opt.mssm.blockerEpsilon
    << ", \"upper_bound_blocker\": " << (opt.mssm.upperBoundBlocker ? "true" : "false")
    << ", \"upper_bound_tilt\": " << opt.mssm.upperBoundTilt
    << "},\n  \"prefilter\": \"" << toString(opt.prefilter)
    << "\",\n  \"front_back_faces\": " << (opt.frontBackFaces ? "true" : "false")
    << ",\n  \"bent_normals\": " << (opt.bentNormals ? "true" : "false")
    << ",\n  \"bent_normals_scale\": " << opt.bentNormalsScale
    << ",\n  \"cssm\": {\"order\": " << opt.cssm.order << ", \"sharpen_a\": " << opt.cssm.sharpenA
    << ", \"sharpen_b\": " << opt.cssm.sharpenB << "},\n  \"pcss\": {\"blocker_taps\": "
    << opt.pcss.blockerTaps << ", \"filter_taps\": " << opt.pcss.filterTaps
    << "},\n  \"brute\": {\"samples\": " << opt.brute.samples << "},\n  \"bitmask\": {\"light_samples\": "
    << opt.bitmask.lightSamples << ", \"list_size\": " << opt.bitmask.listSize
    << "},\n  \"auto\": {\"exact_lights\": " << opt.autoChoice.exactLights
    << ", \"hard_pixels\": " << opt.autoChoice.hardPixels
    << ", \"pcss_texels\": " << opt.autoChoice.pcssTexels << "},\n  \"stats\": {";
  // `auto` reports each light's technique as the stat "auto/light_<i>" (a ShadowTechnique value,
  // lights in order): listed by name in "auto_lights" instead.
  const std::string perLight = "auto/light_";
  std::vector<std::string> autoLights;
  bool first = true;
  for (const auto& [name, v] : f.stats) {
    if (name.compare(0, perLight.size(), perLight) == 0) {
      autoLights.push_back(toString(static_cast<ShadowTechnique>(int(v))));
      continue;
    }
    o << (first ? "" : ", ") << "\"" << name << "\": ";
    first = false;
    // counts as integers, not in 6-digit scientific form
    if (v == std::floor(v) && std::fabs(v) < 9e15) o << static_cast<long long>(v); else o << v;
  }
  o << "}";
  if (!autoLights.empty()) {
    o << ",\n  \"auto_lights\": [";
    for (std::size_t i = 0; i < autoLights.size(); ++i)
      o << (i ? ", " : "") << "\"" << autoLights[i] << "\"";
    o << "]";
  }
  o << ",\n  \"timings_ms\": {";
  for (std::size_t i = 0; i < f.timingsMs.size(); ++i)
    o << (i ? ", " : "") << "\"" << f.timingsMs[i].first << "\": " << f.timingsMs[i].second;
  o << "}\n}\n";
  return o.str();
}

}  // namespace penumbra
