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
  reg.text(*app, "--heatmap", "FILE",
           "also draw the per-pixel error over B's geometry (background grey) with a labelled "
           "colour scale under it: any 8-bit image format (.png, .jpg, ...)",
           "", kGroupOutput);
  reg.text(*app, "--heatmap-metric", "NAME",
           "relative: |lum A - lum B| / mean lum B, magma; signed: the same with its sign, blue "
           "(A darker) to red (A brighter); flip: the HDR-FLIP map (Andersson et al. 2021)",
           "relative", kGroupOutput);
  reg.real(*app, "--heatmap-scale", "top of the colour scale for relative and signed (0.05 = 5% "
           "of B's mean); 0 = the 99th percentile rounded up to 1, 2 or 5 x 10^k",
           Bounds::nonNegative(), "0", kGroupOutput);
  return app;
}

int runCompare(const Args& a) {
  const std::string first = a.get("A"), second = a.get("B");
  const int given = int(a.has("A")) + int(a.has("B"));
  if (given != 2)
    badInput("penumbra compare needs two images, A and the reference B (got " +
             std::to_string(given) + ")");
  if (a.has("out")) checkOutput(a.get("out"), {".json"}, "out");
  HeatmapOptions heat;
  if (a.has("heatmap")) {
    checkOutput(a.get("heatmap"), {}, "heatmap");
    if (isFloatImageFormat(a.get("heatmap")))
      badInput("--heatmap " + a.get("heatmap") +
               ": the heat map is a picture (display colours): use an 8-bit format such as .png");
    const std::string metric = a.get("heatmap-metric", "relative");
    if (metric == "relative") heat.metric = HeatmapMetric::RelativeError;
    else if (metric == "signed") heat.metric = HeatmapMetric::SignedRelativeError;
    else if (metric == "flip") heat.metric = HeatmapMetric::Flip;
    else badInput("--heatmap-metric " + metric + ": unknown metric (use relative, signed or flip)");
    if (a.has("heatmap-scale")) heat.scale = a.real("heatmap-scale");
  } else if (a.has("heatmap-metric") || a.has("heatmap-scale")) {
    badInput(std::string("--") + (a.has("heatmap-metric") ? "heatmap-metric" : "heatmap-scale") +
             " needs --heatmap FILE");
  }
  const Image A = readImage(first);
  const Image B = readImage(second);
  const ImageMetrics m = compareImages(A, B);
  // The reference's own noise, when `penumbra reference` stored it in B's header.
  const ImageAttributes attributes = readImageAttributes(second);
  const auto noise = attributes.find(kRelativeNoiseAttribute);
  const bool haveNoise = noise != attributes.end() && std::isfinite(noise->second);
  auto json = nlohmann::ordered_json::parse(toJson(m));
  json["reference_noise"] = haveNoise ? nlohmann::ordered_json(noise->second) : nullptr;
  if (a.has("heatmap")) {
    // The metrics are computed first: a size mismatch is refused there, before any file appears.
    json["heatmap"] = a.get("heatmap");
    json["heatmap_scale"] = writeHeatmap(a.get("heatmap"), A, B, heat);
  }
  const std::string text =
      json.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
  std::cout << text;
  if (haveNoise && m.relativeRmse < 2.0 * noise->second)
    std::cerr << "penumbra: compare: relative RMSE " << percentText(m.relativeRmse)
              << " is below twice the reference's own noise (" << percentText(noise->second)
              << "): the difference is not resolved by this reference\n";
  if (a.has("out")) writeTextAtomic(a.get("out"), text);
  return 0;
}

}  // namespace penumbra::cli
