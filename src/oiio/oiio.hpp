// The OpenImageIO module's functions (see core/image_codec.hpp), in a namespace of their own so
// that none of them is interposed by, or interposes, libpenumbra's function of the same name.
#pragma once
#include <string>
#include <vector>

#include "metrics/heatmap.hpp"
#include "penumbra/image.hpp"

namespace penumbra::oiio {

// image_io.cpp
Image readImage(const std::string& path, bool linearize);
ImageAttributes readImageAttributes(const std::string& path);
bool canWriteImage(const std::string& path);
void writeImage(const std::string& path, const Image& image, float exposure,
                const ImageAttributes& numbers, const ImageText& text);
void writeDisplayImage(const std::string& path, const Image& display);

// drawing.cpp
detail::ColourMap magmaColourMap();
Image colourMap(const std::vector<float>& values, int width, int height, const detail::ColourMap& map);
Image withScaleBar(const Image& rgb, const detail::ColourMap& map, const std::string& low,
                   const std::string& mid, const std::string& high);
bool drawText(Image& image, int x, int y, const std::string& text, int size,
              const std::vector<float>& colour, detail::TextAlign align, int shadow);
int textWidth(const std::string& text, int size);

}  // namespace penumbra::oiio
