// `penumbra compare A B`: error metrics of an image against a reference, as JSON, with the
// reference's own noise when its header holds it.
#include "options.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <iostream>

namespace penumbra::cli {

CLI::App* addCompareCommand(CLI::App& root, Registry& reg) {
  CLI::App* app = root.add_subcommand("compare", "error metrics of an image against a reference");
  app->description("Compares image A with reference B over B's geometry pixels (alpha > 0.5): "
                   "RMSE, relative RMSE (RMSE / mean of B), PSNR, max abs error, as JSON, and "
                   "\"reference_noise\": B's own relative noise when B is an EXR written by "
                   "`penumbra reference` (null otherwise). A relative RMSE below twice that noise "
                   "is noted on stderr.");
  app->add_option("A", "the image to compare")->group(kGroupOutput);
  app->add_option("B", "the reference image")->group(kGroupOutput);
  reg.text(*app, "-o,--out", "FILE.json", "also write the metrics JSON to this file", "",
           kGroupOutput);
  return app;
}

int runCompare(const Args& a) {
  const std::string first = a.get("A"), second = a.get("B");
  const int given = int(a.has("A")) + int(a.has("B"));
  if (given != 2)
    badInput("penumbra compare needs two images, A and the reference B (got " +
             std::to_string(given) + ")");
  if (a.has("out")) checkOutput(a.get("out"), {".json"}, "out");
  const Image A = readImage(first);
  const Image B = readImage(second);
  const ImageMetrics m = compareImages(A, B);
  // The reference's own noise, when `penumbra reference` stored it in B's header.
  const ImageAttributes attributes = readImageAttributes(second);
  const auto noise = attributes.find(kRelativeNoiseAttribute);
  const bool haveNoise = noise != attributes.end() && std::isfinite(noise->second);
  auto json = nlohmann::ordered_json::parse(toJson(m));
  json["reference_noise"] = haveNoise ? nlohmann::ordered_json(noise->second) : nullptr;
  const std::string text = json.dump(2) + "\n";
  std::cout << text;
  if (haveNoise && m.relativeRmse < 2.0 * noise->second)
    std::cerr << "penumbra: compare: relative RMSE " << percentText(m.relativeRmse)
              << " is below twice the reference's own noise (" << percentText(noise->second)
              << "): the difference is not resolved by this reference\n";
  if (a.has("out")) writeTextAtomic(a.get("out"), text);
  return 0;
}

}  // namespace penumbra::cli
