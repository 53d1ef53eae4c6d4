// The extraction entry point (extraction.hpp extractLights): the chosen method, then the light
// textures, then the ambient residual; and the methods' names.
#include "penumbra/error.hpp"
#include "penumbra/extraction.hpp"

namespace penumbra {

ExtractionMethod parseExtractionMethod(const std::string& name) {
  for (ExtractionMethod m :
       {ExtractionMethod::MedianCut, ExtractionMethod::Greedy, ExtractionMethod::CenterSurround})
    if (name == toString(m)) return m;
  badInput("ExtractOptions.method: unknown method '" + name +
           "' (accepted: median-cut, greedy, center-surround)");
}

const char* toString(ExtractionMethod m) {
  switch (m) {
    case ExtractionMethod::MedianCut: return "median-cut";
    case ExtractionMethod::Greedy: return "greedy";
    case ExtractionMethod::CenterSurround: return "center-surround";
  }
  return "unknown";
}

LightSet extractLights(Context& ctx, const Environment& env, const ExtractOptions& opt) {
  if (opt.lightTexture < 0 || opt.lightTexture > 64)
    badInput("ExtractOptions::lightTexture must be 0 (none) or in [1, 64], got " +
             std::to_string(opt.lightTexture));
  if (opt.targetError != 0.0) return extractToTargetError(ctx, env, opt);
  LightSet set;
  switch (opt.method) {
    case ExtractionMethod::MedianCut: set = extractMedianCut(ctx, env, opt.medianCut); break;
    case ExtractionMethod::Greedy: set = extractGreedy(ctx, env, opt.greedy); break;
    case ExtractionMethod::CenterSurround:
      set = extractCenterSurround(ctx, env, opt.centerSurround);
      break;
  }
  if (opt.lightTexture > 0) textureLightsFromMap(env, set, opt.lightTexture);
  if (opt.ambient) addAmbientResidual(ctx, env, set, opt.ambientOptions);
  return set;
}

}  // namespace penumbra
