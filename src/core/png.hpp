// PNG files written with libpng directly: the default output of `penumbra render` and of most
// frames, which so never load OpenImageIO's module (core/image_codec.hpp). The file holds what
// OpenImageIO's PNG writer put in it for the same image (IHDR, an oFFs of 0,0, the text
// attributes as tEXt in name order, IDAT at zlib level 6), so switching writers changed no byte.
#pragma once
#include <cstddef>
#include <string>
#include <vector>

#include "penumbra/image.hpp"

namespace penumbra::detail {

// Writes `rgb` (width*height*3 bytes, row 0 at the top) to `file` with `text` as tEXt chunks.
// Throws Error(BadInput) naming `nameForMessages` and libpng's or the system's reason; a file it
// started is left for the caller to remove.
void writePng(const std::string& file, const std::string& nameForMessages, int width, int height,
              const std::vector<unsigned char>& rgb, const ImageText& text);

// The same file's bytes, in memory (penumbra::encodePng). Throws Error(BadInput) when libpng fails.
std::vector<unsigned char> encodePngBytes(int width, int height,
                                          const std::vector<unsigned char>& rgb,
                                          const ImageText& text);

// Decodes the PNG `file` with libpng, row by row into one reused row, and returns libpng's reason
// when it cannot (a failed CRC in any chunk, corrupt deflate data, a bad filter byte, too little
// image data, ...), or an empty string when every row decodes. Nothing is printed: the image
// module calls this before OpenImageIO reads a PNG, because OpenImageIO leaves libpng's default
// error handler in place, which prints "libpng error: ..." on stderr beside penumbra's own
// message. A file whose rows are over maxRowBytes is not decoded (empty result): the reader
// refuses that width itself.
std::string pngDecodeProblem(const std::string& file, std::size_t maxRowBytes);

}  // namespace penumbra::detail
