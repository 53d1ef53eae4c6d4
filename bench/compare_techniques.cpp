// The comparison table of issue 3: every shadow technique x light count x shadow-map size on the
// default scene under each environment map, against two Embree references (the map itself, and
// the same light set), with device time per stage and shadow-map memory. Writes
//   OUT/table.json, OUT/table.md, and OUT/crops_<map>.png (a grid of crops: contact shadow and
//   wide penumbra, every technique beside the reference, each with an error heat map).
// Usage: compare_techniques [OUT_DIR] [--quick] [--maps builtin,PATH,...]
#include <penumbra/penumbra.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

using namespace penumbra;
namespace fs = std::filesystem;

namespace {

struct Row {
  std::string map, technique;
  int lights = 0, mapSize = 0;
  double relEnv = 0, relLights = 0, totalMs = 0, shadowMs = 0;
  std::size_t bytes = 0, bytesPerTexel = 0;
  std::vector<std::pair<std::string, double>> stages;
};

// Device time of the stages that belong to shadowing (everything but extraction, G-buffer, shade).
double shadowStageMs(const std::vector<std::pair<std::string, double>>& t) {
  double ms = 0;
  for (auto& [name, v] : t) {
    if (name == "total" || name.rfind("env/", 0) == 0 || name.rfind("extract/", 0) == 0 ||
        name.rfind("gbuffer/", 0) == 0 || name == "shade")
      continue;
    ms += v;
  }
  return ms;
}

// Per-pixel relative error heat map (|A - B| luminance / mean of B), blue -> red.
Image heat(const Image& a, const Image& b) {
  double mean = 0;
  int n = 0;
  for (std::size_t i = 0; i < b.pixels.size(); i += 4)
    if (b.pixels[i + 3] > 0.5f) mean += 0.2126 * b.pixels[i] + 0.7152 * b.pixels[i + 1] + 0.0722 * b.pixels[i + 2], ++n;
  mean = n ? mean / n : 1;
  Image h(a.width, a.height, 4);
  for (std::size_t i = 0; i < a.pixels.size(); i += 4) {
    double d = 0;
    for (int c = 0; c < 3; ++c) d += std::fabs(a.pixels[i + c] - b.pixels[i + c]) / 3;
    float t = float(std::clamp(d / (0.25 * mean), 0.0, 1.0));  // full red at 25% of the mean
    h.pixels[i] = t;
    h.pixels[i + 1] = 0.15f * (1 - t);
    h.pixels[i + 2] = 1 - t;
    h.pixels[i + 3] = 1;
  }
  return h;
}

Image crop(const Image& img, int x0, int y0, int w, int h) {
  Image c(w, h, 4);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int k = 0; k < 4; ++k)
        c.at(x, y, k) = img.at(std::clamp(x0 + x, 0, img.width - 1), std::clamp(y0 + y, 0, img.height - 1),
                            std::min(k, img.channels - 1));
  return c;
}

void paste(Image& dst, const Image& src, int x0, int y0, float exposure, bool tone) {
  for (int y = 0; y < src.height; ++y)
    for (int x = 0; x < src.width; ++x)
      for (int c = 0; c < 3; ++c)
        dst.at(x0 + x, y0 + y, c) = tone ? toneMapChannel(src.at(x, y, c) * exposure) : src.at(x, y, c);
}

}  // namespace

int main(int argc, char** argv) {
  fs::path out = "compare-out";
  bool quick = false;
  std::vector<std::string> maps = {"builtin", std::string(PENUMBRA_SOURCE_DIR) + "/tests/data/envmaps/courtyard.exr",
                                   std::string(PENUMBRA_SOURCE_DIR) + "/tests/data/envmaps/interior.exr",
                                   std::string(PENUMBRA_SOURCE_DIR) + "/tests/data/envmaps/studio.exr"};
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "--quick") quick = true;
    else if (a == "--maps" && i + 1 < argc) {
      maps.clear();
      std::stringstream ss(argv[++i]);
      for (std::string m; std::getline(ss, m, ',');) maps.push_back(m);
    } else out = a;
  }
  fs::create_directories(out);
  const int W = 320, H = 180;
  const int envSpp = quick ? 128 : 1024, lightSpp = quick ? 64 : 512;
  std::vector<int> lightCounts = quick ? std::vector<int>{32} : std::vector<int>{16, 32, 64};
  std::vector<int> mapSizes = quick ? std::vector<int>{256} : std::vector<int>{128, 256, 512};
  std::vector<std::string> techniques;
  for (const char* t : {"hard", "pcss", "cssm", "mssm4", "mssm6", "brute"}) {
    try {
      parseShadowTechnique(t);
      techniques.push_back(t);
    } catch (const Error&) {
      std::cerr << "compare_techniques: " << t << " is not available in this build; left out\n";
    }
  }

  Context ctx;
  Scene scene = builtinScene();
  Camera cam = frameCamera(scene, float(W) / H);
  Renderer renderer(ctx);
  std::vector<Row> rows;
  for (const std::string& mapPath : maps) {
    Environment env = environmentFrom(mapPath);
    std::string mapName = mapPath == "builtin" ? "builtin" : fs::path(mapPath).stem().string();
    std::cerr << "compare_techniques: " << mapName << ": environment reference (" << envSpp << " spp)\n";
    ReferenceOptions rf;
    rf.width = W;
    rf.height = H;
    rf.spp = envSpp;
    Image refEnv = referenceEnvironment(scene, cam, env, rf);
    writeImage((out / ("reference_" + mapName + ".exr")).string(), refEnv);
    std::map<std::string, Image> cropsImages;  // technique -> image at 32 lights, 256^2
    for (int nl : lightCounts) {
      MedianCutOptions mc;
      mc.lights = nl;
      LightSet lights = extractMedianCut(ctx, env, mc);
      rf.spp = lightSpp;
      Image refLights = referenceLights(scene, cam, lights, env, rf);
      for (int S : mapSizes)
        for (const std::string& t : techniques) {
          RenderOptions ro;
          ro.width = W;
          ro.height = H;
          ro.shadowMapSize = S;
          ro.shadows = parseShadowTechnique(t);
          renderer.render(scene, cam, lights, env, ro);  // warm-up: kernels compile on first use
          ctx.resetTimings();
          Frame f = renderer.render(scene, cam, lights, env, ro);
          Row r;
          r.map = mapName;
          r.technique = t;
          r.lights = nl;
          r.mapSize = S;
          r.relEnv = compareImages(f.image, refEnv).relativeRmse;
          r.relLights = compareImages(f.image, refLights).relativeRmse;
          r.totalMs = f.timingsMs.back().second;
          r.shadowMs = shadowStageMs(f.timingsMs);
          r.bytes = f.shadowMapBytes;
          r.bytesPerTexel = f.shadowMapBytes / (std::size_t(S) * S * std::max<std::size_t>(1, lights.lights.size()));
          r.stages = f.timingsMs;
          rows.push_back(r);
          std::fprintf(stderr, "  %-6s %3d lights %3d^2: rel RMSE env %.4f lights %.4f, shadows %.1f ms\n",
                       t.c_str(), nl, S, r.relEnv, r.relLights, r.shadowMs);
          if (nl == (quick ? 32 : 32) && S == 256) cropsImages[t] = f.image;
        }
    }
    // Crop grid: rows = techniques (+ reference), columns = [contact crop, its error, wide crop, its error].
    const int cw = 96, ch = 72;
    const int contactX = W * 38 / 100, contactY = H * 60 / 100;  // box/sphere base
    const int wideX = W * 50 / 100, wideY = H * 30 / 100;        // under the slab and lattice
    Image grid(4 * cw + 5, int(cropsImages.size() + 1) * ch + int(cropsImages.size() + 2), 3, 1.0f);
    float exposure = autoExposure(refEnv);
    int row = 0;
    auto addRow = [&](const Image& img) {
      int y = 1 + row * (ch + 1);
      paste(grid, crop(img, contactX, contactY, cw, ch), 1, y, exposure, true);
      paste(grid, heat(crop(img, contactX, contactY, cw, ch), crop(refEnv, contactX, contactY, cw, ch)), cw + 2, y, 1, false);
      paste(grid, crop(img, wideX, wideY, cw, ch), 2 * cw + 3, y, exposure, true);
      paste(grid, heat(crop(img, wideX, wideY, cw, ch), crop(refEnv, wideX, wideY, cw, ch)), 3 * cw + 4, y, 1, false);
      ++row;
    };
    addRow(refEnv);
    for (const std::string& t : techniques)
      if (cropsImages.count(t)) addRow(cropsImages[t]);
    // the grid is already display-referred: write it without further tone mapping
    Image linearGrid = grid;
    for (float& v : linearGrid.pixels) {
      float s = std::clamp(v, 0.0f, 0.999f);
      float lin = s <= 0.04045f ? s / 12.92f : std::pow((s + 0.055f) / 1.055f, 2.4f);
      v = lin / (1 - lin);  // inverse of writeImage's x/(1+x), so the PNG shows `grid` as is
    }
    writeImage((out / ("crops_" + mapName + ".png")).string(), linearGrid, 1.0f);
  }

  std::ofstream js(out / "table.json");
  js << "[\n";
  for (std::size_t i = 0; i < rows.size(); ++i) {
    auto& r = rows[i];
    js << "  {\"map\": \"" << r.map << "\", \"technique\": \"" << r.technique << "\", \"lights\": " << r.lights
       << ", \"shadow_map_size\": " << r.mapSize << ", \"relative_rmse_env\": " << r.relEnv
       << ", \"relative_rmse_lights\": " << r.relLights << ", \"total_ms\": " << r.totalMs
       << ", \"shadow_ms\": " << r.shadowMs << ", \"shadow_map_bytes\": " << r.bytes
       << ", \"bytes_per_texel\": " << r.bytesPerTexel << ", \"stages_ms\": {";
    for (std::size_t k = 0; k < r.stages.size(); ++k)
      js << (k ? ", " : "") << "\"" << r.stages[k].first << "\": " << r.stages[k].second;
    js << "}}" << (i + 1 < rows.size() ? "," : "") << "\n";
  }
  js << "]\n";
  std::ofstream md(out / "table.md");
  md << "| map | technique | lights | map size | rel. RMSE vs env | rel. RMSE vs lights | shadow ms | total ms | bytes/texel | shadow-map MiB |\n";
  md << "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n";
  for (auto& r : rows) {
    char buf[512];
    std::snprintf(buf, sizeof buf, "| %s | %s | %d | %d | %.4f | %.4f | %.1f | %.1f | %zu | %.1f |\n",
                  r.map.c_str(), r.technique.c_str(), r.lights, r.mapSize, r.relEnv, r.relLights, r.shadowMs,
                  r.totalMs, r.bytesPerTexel, double(r.bytes) / (1 << 20));
    md << buf;
  }
  std::cerr << "compare_techniques: wrote " << fs::absolute(out / "table.md").string() << "\n";
  return 0;
}
