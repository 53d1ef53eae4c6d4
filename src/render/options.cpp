// Technique and prefilter names, and the checks of RenderOptions (include/penumbra/options.hpp)
// that hold for every frame: sizes, the shared shadow settings, bent normals, the build's
// techniques. Errors name the field (RenderOptions.width); the technique's own struct is checked
// by its pass (src/shadows/shadow_options.hpp).
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "penumbra/error.hpp"
#include "core/number_text.hpp"
#include "penumbra/options.hpp"
#include "render/options_check.hpp"
#include "shadows/shadow_options.hpp"
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
    {ShadowTechnique::Auto, "auto"},
};
}  // namespace

ShadowTechnique parseShadowTechnique(const std::string& name) {
  std::string list;
  for (auto& [t, n] : kTechniques) {
    if (name == n && detail::techniqueAvailable(t)) return t;
    if (detail::techniqueAvailable(t)) list += (list.empty() ? "" : ", ") + std::string(n);
  }
  badInput("RenderOptions.shadows: unknown technique '" + name + "' (available: " + list + ")");
}

const char* toString(ShadowTechnique t) {
  for (auto& [k, n] : kTechniques)
    if (k == t) return n;
  return "?";
}

Prefilter parsePrefilter(const std::string& name) {
  if (name == "sat") return Prefilter::SAT;
  if (name == "mip" && detail::prefilterAvailable(Prefilter::Mip)) return Prefilter::Mip;
  badInput("RenderOptions.prefilter: unknown prefilter '" + name + "' (available: sat" +
           std::string(detail::prefilterAvailable(Prefilter::Mip) ? ", mip" : "") + ")");
}

const char* toString(Prefilter p) { return p == Prefilter::SAT ? "sat" : "mip"; }

namespace detail {

void validateFrameInputs(const Scene& scene, const Camera& camera, const LightSet& lights,
                         const Environment& env, const RenderOptions& opt) {
  checkRange("RenderOptions.width", opt.width, 1, 16384);
  checkRange("RenderOptions.height", opt.height, 1, 16384);
  checkRange("RenderOptions.shadowMapSize", opt.shadowMapSize, 1, 4096);
  validateScene(scene);
  cameraBasis(camera, opt.width, opt.height);
  validateLightSet(lights);
  if (!std::isfinite(env.rotationYDeg))
    badInput("Environment.rotationYDeg must be finite, got " + detail::numberText(env.rotationYDeg));
  for (float v : env.equirect.pixels)
    if (!(v >= 0 && v <= std::numeric_limits<float>::max()))
      badInput("environment map " + env.source +
               " holds a non-finite or negative value (loadEnvironment replaces them; a map "
               "built in code must not hold any)");
  if (!(opt.bentNormalsScale > 0) || !std::isfinite(opt.bentNormalsScale))
    badOption("RenderOptions.bentNormalsScale", "be finite and > 0", opt.bentNormalsScale);
  if (env.equirect.empty()) badInput("environment map is empty");

  if (!detail::techniqueAvailable(opt.shadows))
    badInput(std::string("RenderOptions.shadows ") + toString(opt.shadows) +
             " is not available in this build");
  if (!detail::prefilterAvailable(opt.prefilter))
    badInput(std::string("RenderOptions.prefilter ") + toString(opt.prefilter) +
             " is not available in this build");
}

}  // namespace detail
}  // namespace penumbra
