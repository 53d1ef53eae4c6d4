// A labelled crop grid for comparing techniques by eye: one row per image (the reference first),
// and for each crop box two cells, the tone-mapped crop and its error heat map against the
// reference (with --truth-column, no reference row: each row shows the reference's crop first) (include/penumbra/heatmap.hpp, one colour scale for the whole grid, its bar under
// the grid). Each row is labelled with its name and its relative RMSE over the whole frame
// (compareImages). tools/readme_figures.sh makes the README's figures with it.
// Usage: crop_grid --reference REF.exr [--crop X,Y,W,H]... [--zoom K] [--scale S] [--truth-column]
//                  --out GRID.png NAME=IMAGE.exr...
#include <penumbra/heatmap.hpp>
#include <penumbra/penumbra.hpp>

#include <CLI/CLI.hpp>

#include <algorithm>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "metrics/heatmap.hpp"

using namespace penumbra;

namespace {

struct Box {
  int x = 0, y = 0, w = 0, h = 0;
};

struct Entry {
  std::string name;
  Image image;
};

Box parseBox(const std::string& s) {
  Box b;
  char tail = 0;
  if (std::sscanf(s.c_str(), "%d,%d,%d,%d%c", &b.x, &b.y, &b.w, &b.h, &tail) != 4 || b.w < 1 ||
      b.h < 1 || b.x < 0 || b.y < 0)
    throw CLI::ValidationError("--crop", "must be X,Y,W,H with X, Y >= 0 and W, H >= 1, got '" + s + "'");
  return b;
}

// The display image (RGB in [0,1]) of `im`: toneMap's bytes at `exposure`, or `im` as it is.
Image display(const Image& im, float exposure) {
  const std::vector<unsigned char> bytes = toneMap(im, exposure);
  Image out(im.width, im.height, 3);
  for (std::size_t i = 0; i < bytes.size(); ++i) out.pixels[i] = float(bytes[i]) / 255.0f;
  return out;
}

// `box` of display image `src` enlarged `zoom` times, pasted at (x0, y0) of `dst`.
void pasteCell(Image& dst, const Image& src, const Box& box, int zoom, int x0, int y0) {
  for (int y = 0; y < box.h * zoom; ++y)
    for (int x = 0; x < box.w * zoom; ++x)
      for (int c = 0; c < 3; ++c)
        dst.at(x0 + x, y0 + y, c) = src.at(box.x + x / zoom, box.y + y / zoom, c);
}

int run(int argc, char** argv) {
  std::string referencePath, outPath;
  std::vector<std::string> crops, named;
  int zoom = 1;
  double scale = 0;
  bool truthColumn = false;
  CLI::App app{"A labelled crop grid: per image and crop box, the tone-mapped crop and its error "
               "heat map against the reference, one colour scale and its bar under the grid",
               "crop_grid"};
  app.add_option("--reference", referencePath,
                 "the truth every image is compared with (its alpha marks the geometry)")
      ->required()->check(CLI::ExistingFile);
  app.add_option("--out", outPath, "the grid, any 8-bit format (.png)")->required();
  app.add_option("--crop", crops, "a box X,Y,W,H in pixels (repeatable; default: the whole frame)");
  app.add_option("--zoom", zoom, "enlarge each cell K times, nearest pixel")
      ->check(CLI::Range(1, 16))->capture_default_str();
  app.add_option("--scale", scale, "top of the error colour scale, a fraction of the reference's "
                                   "mean (default: the largest of the images' automatic scales)")
      ->check(CLI::PositiveNumber);
  app.add_flag("--truth-column", truthColumn,
               "the reference's crop first in every row, instead of a row of its own");
  app.add_option("images", named, "NAME=IMAGE: an image to compare (the reference's size), "
                                  "labelled NAME")->required();
  std::vector<Box> boxes;
  std::vector<std::pair<std::string, std::string>> inputs;
  try {
    app.parse(argc, argv);
    for (const std::string& c : crops) boxes.push_back(parseBox(c));
    for (const std::string& n : named) {
      const std::size_t eq = n.find('=');
      if (eq == std::string::npos || eq == 0 || eq + 1 == n.size())
        throw CLI::ValidationError("images", "must be NAME=IMAGE, got '" + n + "'");
      inputs.emplace_back(n.substr(0, eq), n.substr(eq + 1));
    }
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::cerr << "crop_grid: " << e.what() << " (--help lists the options)\n";
    return 2;
  }

  const Image reference = readImage(referencePath);
  std::vector<Entry> entries;
  for (const auto& [name, path] : inputs) entries.push_back({name, readImage(path)});
  if (boxes.empty()) boxes.push_back({0, 0, reference.width, reference.height});
  for (const Box& b : boxes)
    if (b.x + b.w > reference.width || b.y + b.h > reference.height)
      badInput("--crop box leaves the " + std::to_string(reference.width) + "x" +
               std::to_string(reference.height) + " reference");

  // One scale for every heat map, so equal colours mean equal errors across rows.
  HeatmapOptions ho;
  ho.scaleBar = false;
  if (scale > 0) {
    ho.scale = scale;
  } else {
    for (const Entry& e : entries) scale = std::max(scale, errorHeatmap(e.image, reference, ho).scale);
    ho.scale = scale;
  }

  const float exposure = autoExposure(reference);
  const int gap = 2;
  int cellsWidth = 0, cellHeight = 0;
  const int cellsPerBox = truthColumn ? 3 : 2;
  for (const Box& b : boxes) {
    cellsWidth += cellsPerBox * (b.w * zoom + gap);
    cellHeight = std::max(cellHeight, b.h * zoom);
  }
  const int W = cellsWidth + gap, rows = int(entries.size()) + (truthColumn ? 0 : 1);
  Image grid(W, rows * (cellHeight + gap) + gap, 3, 0.0f);
  const int fontSize = std::clamp(cellHeight / 8, 11, 16);
  const std::vector<float> white(3, 1.0f);
  const Image truth = display(reference, exposure);
  auto addRow = [&](int row, const std::string& label, const Image& shown, const Image* heat) {
    const int y = gap + row * (cellHeight + gap);
    int x = gap;
    for (const Box& b : boxes) {
      if (truthColumn) {
        pasteCell(grid, truth, b, zoom, x, y);
        detail::drawText(grid, x + 4, y + fontSize + 2, "Embree truth", fontSize, white,
                         detail::TextAlign::Left, 1);
        x += b.w * zoom + gap;
      }
      const int labelX = x;
      pasteCell(grid, shown, b, zoom, x, y);
      if (&b == &boxes.front())
        detail::drawText(grid, labelX + 4, y + fontSize + 2, label, fontSize, white,
                         detail::TextAlign::Left, 1);
      x += b.w * zoom + gap;
      if (heat) pasteCell(grid, *heat, b, zoom, x, y);
      x += b.w * zoom + gap;
    }
  };
  if (!truthColumn) addRow(0, "Embree truth", truth, nullptr);
  for (std::size_t i = 0; i < entries.size(); ++i) {
    const Entry& e = entries[i];
    const Heatmap h = errorHeatmap(e.image, reference, ho);
    char label[160];
    std::snprintf(label, sizeof label, "%s: rel. RMSE %.1f%%", e.name.c_str(),
                  100.0 * compareImages(e.image, reference).relativeRmse);
    addRow(int(i) + (truthColumn ? 0 : 1), label, display(e.image, exposure), &h.image);
  }
  const detail::ColourMap magma = detail::magmaColourMap();
  writeDisplayImage(outPath, detail::withScaleBar(grid, magma, "0",
                                                   "|error| / mean, " + detail::percentLabel(scale / 2, false),
                                                   detail::percentLabel(scale, false)));
  std::cout << "crop_grid: wrote " << outPath << " (" << entries.size() << " rows, scale "
            << detail::percentLabel(scale, false) << " of the reference's mean)\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const Error& e) {
    std::cerr << "crop_grid: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "crop_grid: bad input: " << e.what() << "\n";
    return 2;
  }
}
