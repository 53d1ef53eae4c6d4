// The table libpenumbra's loader (core/image_codec.cpp) asks this module for.
#include "core/image_codec.hpp"
#include "oiio/oiio.hpp"
#include "penumbra/version.hpp"

namespace {

const penumbra::detail::ImageCodec kCodec = {
    penumbra::detail::kImageCodecAbi,
    PENUMBRA_VERSION,
    penumbra::oiio::readImage,
    penumbra::oiio::readImageAttributes,
    penumbra::oiio::canWriteImage,
    penumbra::oiio::writeImage,
    penumbra::oiio::writeDisplayImage,
    penumbra::oiio::magmaColourMap,
    penumbra::oiio::colourMap,
    penumbra::oiio::withScaleBar,
    penumbra::oiio::drawText,
    penumbra::oiio::textWidth,
};

}  // namespace

extern "C" __attribute__((visibility("default"))) const penumbra::detail::ImageCodec*
penumbra_image_codec() {
  return &kCodec;
}
