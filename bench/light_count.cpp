// The light-count predictor against the measured floor (bench/results/light_count.md): for one
// map, extracts median-cut light sets at the given counts and prints, per count, the lights it
// gave, lightSetProbeError and the time the prediction took, one JSON object per line.
// Usage: light_count [--env PATH|builtin] [--lights 4,8,16,...]
#include <penumbra/penumbra.hpp>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <chrono>
#include <iostream>
#include <string>
#include <vector>

using namespace penumbra;

int main(int argc, char** argv) {
  CLI::App app{"the light-count predictor (lightSetProbeError) per median-cut light count"};
  std::string envPath = "builtin";
  std::vector<int> counts = {4, 8, 16, 32, 64, 128};
  app.add_option("-e,--env", envPath, "environment map or 'builtin'");
  app.add_option("-l,--lights", counts, "light counts")->delimiter(',')->check(CLI::Range(1, 1024));
  CLI11_PARSE(app, argc, argv);
  try {
    Context ctx;
    const Environment env = environmentFrom(envPath);
    for (int n : counts) {
      ExtractOptions eo;
      eo.medianCut.lights = n;
      const LightSet set = extractLights(ctx, env, eo);
      const auto t0 = std::chrono::steady_clock::now();
      const double e = lightSetProbeError(env, set);
      const double ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      nlohmann::ordered_json j{{"env", envPath}, {"asked", n}, {"lights", set.lights.size()},
                               {"predicted", e}, {"predict_ms", ms}};
      std::cout << j.dump() << std::endl;
    }
  } catch (const std::exception& e) {
    std::cerr << "light_count: " << e.what() << "\n";
    return 2;
  }
  return 0;
}
