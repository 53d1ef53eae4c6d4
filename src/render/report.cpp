// The JSON report of a rendered frame (renderReportJson, include/penumbra/renderer.hpp), written
// with nlohmann-json so names with quotes, backslashes or non-ASCII text stay valid JSON. Option
// blocks follow RenderOptions: "shadow" the shared settings, then "mssm", "cssm", ... only for the
// techniques the frame used (for `auto`, those it picked per light).
#include <cmath>
#include <initializer_list>
#include <set>
#include <string>
#include <vector>

#include "core/json.hpp"
#include "penumbra/environment.hpp"
#include "penumbra/renderer.hpp"
#include "penumbra/version.hpp"

namespace penumbra {
namespace {

using detail::Json;
using detail::shortestDecimal;

Json number(double v) {
  if (!std::isfinite(v)) return nullptr;  // JSON has no NaN or infinity
  // counts stay integers, not 1e+06
  if (v == std::floor(v) && std::fabs(v) < 9e15) return static_cast<long long>(v);
  return v;
}

// The techniques whose options shaped the frame: the one asked for, and for `auto` also those it
// picked per light (the stats "auto/light_<i>", a ShadowTechnique value each).
std::set<ShadowTechnique> techniquesUsed(const RenderOptions& opt, const Frame& f,
                                         const std::string& perLight) {
  std::set<ShadowTechnique> used = {opt.shadows};
  if (opt.shadows == ShadowTechnique::Auto)
    for (const auto& [name, v] : f.stats)
      if (name.compare(0, perLight.size(), perLight) == 0)
        used.insert(static_cast<ShadowTechnique>(int(v)));
  return used;
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
  // The shared settings, then only the blocks of the techniques that ran: an option of another
  // technique did not touch this frame.
  const std::string perLight = "auto/light_";
  const std::set<ShadowTechnique> used = techniquesUsed(opt, f, perLight);
  auto uses = [&](std::initializer_list<ShadowTechnique> ts) {
    for (ShadowTechnique t : ts)
      if (used.count(t)) return true;
    return false;
  };
  // Whether contact shadows, lights on the horizon and the ground's occlusion ran on this frame
  // (the visibility stage's "contact/lights", "contact/map_lights", "horizon/lights" and
  // "ground/lights" count the lights they covered): none for the bitmask techniques, no contact
  // shadows without triangles (GL interop), none from the lights' maps where the frame drew none
  // with ids (a technique with maps of its own, front/back maps), no ground step without a
  // ground or a light that reaches below the horizontal.
  double contactLights = 0, contactMapLights = 0, horizonLights = 0, groundLights = 0;
  for (const auto& [name, v] : f.stats) {
    if (name == "contact/map_lights") contactMapLights = v;
    if (name == "ground/lights") groundLights = v;
    if (name == "contact/lights") contactLights = v;
    if (name == "horizon/lights") horizonLights = v;
  }
  o["shadow"] = {{"depth_bias", shortestDecimal(opt.shadow.depthBias)},
                 {"light_size_scale", shortestDecimal(opt.shadow.lightSizeScale)},
                 {"max_filter_texels", shortestDecimal(opt.shadow.maxFilterTexels)},
                 {"min_filter_texels", shortestDecimal(opt.shadow.minFilterTexels)},
                 {"contact_shadows", opt.shadow.contactShadows && contactLights > 0},
                 {"contact_maps", opt.shadow.contactShadows && opt.shadow.contactFromMaps &&
                                      contactMapLights > 0},
                 {"contact_texels", shortestDecimal(opt.shadow.contactTexels)},
                 {"horizon_visibility", opt.shadow.horizonVisibility && horizonLights > 0},
                 {"ground_visibility", opt.shadow.groundVisibility && groundLights > 0}};
  if (uses({ShadowTechnique::MSSM4, ShadowTechnique::MSSM6}))
    o["mssm"] = {{"moment_bias", shortestDecimal(opt.mssm.momentBias)},
                 {"slope_bias", shortestDecimal(opt.mssm.slopeBias)},
                 {"blocker_epsilon", shortestDecimal(opt.mssm.blockerEpsilon)},
                 {"upper_bound_blocker", opt.mssm.upperBoundBlocker},
                 {"upper_bound_tilt", shortestDecimal(opt.mssm.upperBoundTilt)},
                 {"delta1", shortestDecimal(opt.mssm.delta1)},
                 {"delta2", shortestDecimal(opt.mssm.delta2)},
                 {"cosine_centroid", opt.mssm.cosineCentroid},
                 {"leak_reduction", shortestDecimal(opt.mssm.leakReduction)}};
  o["prefilter"] = toString(opt.prefilter);
  o["front_back_faces"] = opt.frontBackFaces;
  o["bent_normals"] = opt.bentNormals;
  o["bent_normals_scale"] = shortestDecimal(opt.bentNormalsScale);
  if (uses({ShadowTechnique::CSSM}))
    o["cssm"] = {{"order", opt.cssm.order},
                 {"sharpen_a", shortestDecimal(opt.cssm.sharpenA)},
                 {"sharpen_b", shortestDecimal(opt.cssm.sharpenB)},
                 {"ringing_offset", shortestDecimal(opt.cssm.ringingOffset)},
                 {"damping", shortestDecimal(opt.cssm.damping)},
                 {"depth_bias", shortestDecimal(opt.cssm.depthBias)},
                 {"slope_bias", shortestDecimal(opt.cssm.slopeBias)}};
  if (uses({ShadowTechnique::PCSS}))
    o["pcss"] = {{"blocker_taps", opt.pcss.blockerTaps},
                 {"filter_taps", opt.pcss.filterTaps},
                 {"receiver_plane_bias", opt.pcss.receiverPlaneBias}};
  if (uses({ShadowTechnique::Brute})) o["brute"] = {{"samples", opt.brute.samples}};
  if (uses({ShadowTechnique::Bitmask, ShadowTechnique::BitmaskHard}))
    o["bitmask"] = {{"light_samples", opt.bitmask.lightSamples},
                    {"list_size", opt.bitmask.listSize},
                    {"jitter", opt.bitmask.jitter}};
  if (uses({ShadowTechnique::AreaApprox}))
    o["area_approx"] = {{"edge_samples", opt.areaApprox.edgeSamples},
                        {"cap_vertices", opt.areaApprox.capVertices},
                        {"taps", opt.areaApprox.taps}};
  if (uses({ShadowTechnique::Auto}))
    o["auto"] = {{"exact_lights", opt.autoChoice.exactLights},
                 {"hard_pixels", shortestDecimal(opt.autoChoice.hardPixels)},
                 {"pcss_texels", shortestDecimal(opt.autoChoice.pcssTexels)},
                 {"pcss_min_elevation_deg", shortestDecimal(opt.autoChoice.pcssMinElevationDeg)},
                 {"filtered_lights", opt.autoChoice.filteredLights},
                 {"exact_share", shortestDecimal(opt.autoChoice.exactShare)},
                 {"exact_half_angle_deg", shortestDecimal(opt.autoChoice.exactHalfAngleDeg)}};
  // `auto` reports each light's technique as the stat "auto/light_<i>" (a ShadowTechnique value,
  // lights in order): listed by name in "auto_lights" instead.
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
  for (const auto& [stage, ms] : f.timingsMs) timings[stage] = detail::finiteOrNull(ms);
  o["timings_ms"] = timings;
  // replace: a name that is not valid UTF-8 (a Latin-1 file name) is written with U+FFFD instead
  // of throwing, so the report is still valid JSON.
  return detail::dumpJson(o, 2) + "\n";
}

}  // namespace penumbra
