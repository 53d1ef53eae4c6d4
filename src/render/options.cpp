// Technique and prefilter names, and the validation of RenderOptions (include/penumbra/options.hpp).
#include <cmath>
#include <string>
#include <utility>

#include "penumbra/error.hpp"
#include "penumbra/options.hpp"
#include "render/options_check.hpp"
#include "shadows/shadow_pass.hpp"

namespace penumbra {

namespace {
const std::pair<ShadowTechnique, const char*> kTechniques[] = {
    {ShadowTechnique::None, "none"},   {ShadowTechnique::Hard, "hard"},
    {ShadowTechnique::PCSS, "pcss"},   {ShadowTechnique::CSSM, "cssm"},
    {ShadowTechnique::MSSM4, "mssm4"}, {ShadowTechnique::MSSM6, "mssm6"},
    {ShadowTechnique::Brute, "brute"},  {ShadowTechnique::Bitmask, "bitmask"},
    {ShadowTechnique::BitmaskHard, "bitmask-hard"},
    {ShadowTechnique::AreaApprox, "area-approx"},
};
}  // namespace

ShadowTechnique parseShadowTechnique(const std::string& name) {
  std::string list;
  for (auto& [t, n] : kTechniques) {
    if (name == n && detail::techniqueAvailable(t)) return t;
    if (detail::techniqueAvailable(t)) list += (list.empty() ? "" : ", ") + std::string(n);
  }
  badInput("--shadows: unknown technique '" + name + "' (available: " + list + ")");
}

const char* toString(ShadowTechnique t) {
  for (auto& [k, n] : kTechniques)
    if (k == t) return n;
  return "?";
}

Prefilter parsePrefilter(const std::string& name) {
  if (name == "sat") return Prefilter::SAT;
  if (name == "mip" && detail::prefilterAvailable(Prefilter::Mip)) return Prefilter::Mip;
  badInput("--prefilter: unknown prefilter '" + name + "' (available: sat" +
           std::string(detail::prefilterAvailable(Prefilter::Mip) ? ", mip" : "") + ")");
}

const char* toString(Prefilter p) { return p == Prefilter::SAT ? "sat" : "mip"; }

namespace detail {

void validateFrameInputs(const Scene& scene, const Environment& env, const RenderOptions& opt) {
  if (opt.width < 1 || opt.height < 1 || opt.width > 16384 || opt.height > 16384)
    badInput("--size must be between 1x1 and 16384x16384, got " + std::to_string(opt.width) +
             "x" + std::to_string(opt.height));
  if (opt.shadowMapSize < 1 || opt.shadowMapSize > 4096)
    badInput("--shadow-map-size must be in [1, 4096], got " + std::to_string(opt.shadowMapSize));
  const MSSMOptions& mo = opt.mssm;
  if (!(mo.momentBias >= 0 && mo.momentBias < 1)) badInput("moment bias must be in [0, 1)");
  if (!(mo.lightSizeScale >= 0) || !std::isfinite(mo.lightSizeScale))
    badInput("light-size scale must be >= 0");
  if (!(mo.minFilterTexels > 0) || !(mo.maxFilterTexels >= mo.minFilterTexels))
    badInput("filter sizes must satisfy 0 < min <= max");
  if (scene.triangleCount() == 0) badInput("scene has no triangles");
  if (!(opt.bentNormalsScale > 0) || !std::isfinite(opt.bentNormalsScale))
    badInput("--bent-normals-scale must be finite and > 0, got " +
             std::to_string(opt.bentNormalsScale));
  if (env.equirect.empty()) badInput("environment map is empty");

  if (!detail::techniqueAvailable(opt.shadows))
    badInput(std::string("--shadows ") + toString(opt.shadows) + " is not available");
  if (!detail::prefilterAvailable(opt.prefilter))
    badInput(std::string("--prefilter ") + toString(opt.prefilter) + " is not available");
}

}  // namespace detail
}  // namespace penumbra
