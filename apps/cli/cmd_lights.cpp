// `penumbra lights`: the area lights extracted from a map, as a light set JSON (loadLightSet
// reads it back) with the map's sanitized-pixel count, and an overlay of the lights on the map.
#include "options.hpp"

#include <nlohmann/json.hpp>

#include <iostream>

namespace penumbra::cli {

CLI::App* addLightsCommand(CLI::App& root, Registry& reg) {
  CLI::App* app = root.add_subcommand("lights", "extract area lights from an environment map");
  app->description("Extracts area lights from an environment map and writes them as JSON: how "
                   "many of the map's pixels were sanitized (\"sanitized_pixels\"), each light's "
                   "direction, half-angle, radiance and power, then the ambient residual (9 RGB "
                   "spherical-harmonic coefficients of radiance, \"ambient_sh\", and its power; "
                   "with --ambient map, the default, also its irradiance map, \"ambient_map\").");
  reg.text(*app, "-e,--env", "PATH", "environment map or 'builtin'", "builtin", kGroupScene);
  reg.text(*app, "-d,--device", "INDEX|NAME", "OpenCL device: index or name substring; also "
           "$PENUMBRA_DEVICE", "0", kGroupScene)
      ->envname("PENUMBRA_DEVICE");
  addExtractOptions(*app, reg);
  reg.text(*app, "-o,--out", "FILE.json", "write the light set JSON here", "standard output",
           kGroupOutput);
  reg.text(*app, "--overlay", "FILE.png", "write the map with every light outlined to this PNG",
           "", kGroupOutput);
  return app;
}

int runLights(const Args& a) {
  if (a.has("out")) checkOutput(a.get("out"), {".json"}, "out");
  if (a.has("overlay")) checkOutput(a.get("overlay"), {".png"}, "overlay");
  ExtractOptions eo = parseExtractOptions(a);
  const Environment env = loadEnvironmentNoting(a.get("env", "builtin"));
  Context ctx(a.get("device"));
  const LightSet lights = extractNoting(ctx, env, eo, a);
  // The count belongs to the map, not to the light set (LightSet has no field for it), so it is
  // recorded here, second, as render's report records it; loadLightSet accepts it.
  const auto set = nlohmann::ordered_json::parse(lights.toJson());
  nlohmann::ordered_json json = nlohmann::ordered_json::object();
  for (const auto& [key, value] : set.items()) {
    json[key] = value;
    if (json.size() == 1) json["sanitized_pixels"] = env.sanitizedPixels;
  }
  const std::string text =
      json.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
  // the overlay first: if it fails, no JSON is left behind either
  if (a.has("overlay")) writeLightOverlay(a.get("overlay"), env, lights);
  if (a.has("out"))
    writeTextAtomic(a.get("out"), text);
  else
    std::cout << text;
  return 0;
}

}  // namespace penumbra::cli
