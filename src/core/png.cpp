// PNG writing, and the decoding check before a PNG is read, through libpng (core/png.hpp). libpng
// reports errors by longjmp, so the parts that call it hold no C++ object whose destructor a jump
// would skip.
#include "core/png.hpp"

#include <png.h>
#include <zlib.h>

#include <cerrno>
#include <csetjmp>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <new>

#include "penumbra/error.hpp"

namespace penumbra::detail {

namespace {

struct PngFailure {
  char message[256];
};

void onError(png_structp png, png_const_charp message) {
  auto* failure = static_cast<PngFailure*>(png_get_error_ptr(png));
  std::snprintf(failure->message, sizeof failure->message, "%s", message ? message : "libpng error");
  png_longjmp(png, 1);
}

void onWarning(png_structp, png_const_charp) {}

// Appends to the std::vector<unsigned char> that is the write's io pointer. Memory running out
// becomes libpng's error (a longjmp), outside the handler: no exception crosses libpng's frames.
void appendToMemory(png_structp png, png_bytep data, png_size_t size) {
  auto* memory = static_cast<std::vector<unsigned char>*>(png_get_io_ptr(png));
  bool full = false;
  try {
    memory->insert(memory->end(), data, data + size);
  } catch (const std::bad_alloc&) {
    full = true;
  }
  if (full) png_error(png, "out of memory");
}

void flushMemory(png_structp) {}

// Writes to `f`, or when it is null appends to `memory`. False with failure->message set when
// libpng gives up.
bool writeRows(std::FILE* f, std::vector<unsigned char>* memory, int width, int height,
               png_bytep* rows, png_text* text, int ntext, PngFailure* failure) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, failure, onError, onWarning);
  if (!png) {
    std::snprintf(failure->message, sizeof failure->message, "libpng could not start");
    return false;
  }
  png_infop info = png_create_info_struct(png);
  if (!info) {
    png_destroy_write_struct(&png, nullptr);
    std::snprintf(failure->message, sizeof failure->message, "libpng could not start");
    return false;
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return false;
  }
  if (f) png_init_io(png, f);
  else png_set_write_fn(png, memory, appendToMemory, flushMemory);
  // zlib level 6 with the default strategy, as OpenImageIO's writer sets it (libpng alone would
  // pick Z_FILTERED for filtered rows).
  png_set_compression_level(png, 6);
  png_set_compression_strategy(png, Z_DEFAULT_STRATEGY);
  png_set_IHDR(png, info, png_uint_32(width), png_uint_32(height), 8, PNG_COLOR_TYPE_RGB,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_set_oFFs(png, info, 0, 0, PNG_OFFSET_PIXEL);
  if (ntext > 0) png_set_text(png, info, text, ntext);
  png_write_info(png, info);
  png_write_image(png, rows);
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return true;
}

// What writeRows reads: row pointers into `rgb` and tEXt entries pointing into `text`, both of
// which outlive the write.
struct PngInput {
  std::vector<png_bytep> rows;
  std::vector<png_text> chunks;
  PngInput(int width, int height, const std::vector<unsigned char>& rgb, const ImageText& text)
      : rows(static_cast<std::size_t>(height)) {
    for (int y = 0; y < height; ++y)
      rows[std::size_t(y)] = const_cast<png_bytep>(rgb.data() + std::size_t(y) * width * 3);
    for (const auto& [name, value] : text) {
      png_text t{};
      t.compression = PNG_TEXT_COMPRESSION_NONE;
      t.key = const_cast<png_charp>(name.c_str());
      t.text = const_cast<png_charp>(value.c_str());
      t.text_length = value.size();
      chunks.push_back(t);
    }
  }
};

// Decodes every row of the PNG in `f` into one row buffer, keeping nothing. False with
// failure->message set when libpng gives up; true as well, without decoding, when a row holds
// more than maxRowBytes (the reader refuses such widths with its own message).
bool decodeRows(std::FILE* f, std::size_t maxRowBytes, PngFailure* failure) {
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, failure, onError, onWarning);
  if (!png) {
    std::snprintf(failure->message, sizeof failure->message, "libpng could not start");
    return false;
  }
  png_infop info = png_create_info_struct(png);
  if (!info) {
    png_destroy_read_struct(&png, nullptr, nullptr);
    std::snprintf(failure->message, sizeof failure->message, "libpng could not start");
    return false;
  }
  // Set after setjmp, so volatile: a jump must see the buffer to free it.
  png_bytep volatile row = nullptr;
  if (setjmp(png_jmpbuf(png))) {
    std::free(row);
    png_destroy_read_struct(&png, &info, nullptr);
    return false;
  }
  png_init_io(png, f);
  // A failed CRC is an error in any chunk (libpng's default only warns for ancillary chunks and
  // drops them, which OpenImageIO's read would then print).
  png_set_crc_action(png, PNG_CRC_ERROR_QUIT, PNG_CRC_ERROR_QUIT);
  png_read_info(png, info);
  const png_uint_32 height = png_get_image_height(png, info);
  const int passes = png_set_interlace_handling(png);
  png_read_update_info(png, info);
  const std::size_t rowBytes = png_get_rowbytes(png, info);
  if (rowBytes <= maxRowBytes) {
    row = static_cast<png_bytep>(std::malloc(rowBytes > 0 ? rowBytes : 1));
    if (!row) png_error(png, "out of memory");
    for (int pass = 0; pass < passes; ++pass)
      for (png_uint_32 y = 0; y < height; ++y) png_read_row(png, row, nullptr);
    png_read_end(png, nullptr);
  }
  std::free(row);
  png_destroy_read_struct(&png, &info, nullptr);
  return true;
}

}  // namespace

std::string pngDecodeProblem(const std::string& file, std::size_t maxRowBytes) {
  std::FILE* f = std::fopen(file.c_str(), "rb");
  if (!f) return std::string("cannot open (") + std::strerror(errno) + ")";
  PngFailure failure{};
  const bool ok = decodeRows(f, maxRowBytes, &failure);
  std::fclose(f);
  return ok ? std::string() : std::string(failure.message);
}

std::vector<unsigned char> encodePngBytes(int width, int height,
                                          const std::vector<unsigned char>& rgb,
                                          const ImageText& text) {
  PngInput input(width, height, rgb, text);
  std::vector<unsigned char> png;
  PngFailure failure{};
  if (!writeRows(nullptr, &png, width, height, input.rows.data(), input.chunks.data(),
                 int(input.chunks.size()), &failure))
    badInput(std::string("encodePng: encoding failed (") + failure.message + ")");
  return png;
}

void writePng(const std::string& file, const std::string& nameForMessages, int width, int height,
              const std::vector<unsigned char>& rgb, const ImageText& text) {
  PngInput input(width, height, rgb, text);
  std::FILE* f = std::fopen(file.c_str(), "wb");
  if (!f) badInput(nameForMessages + ": cannot open for writing (" + std::strerror(errno) + ")");
  PngFailure failure{};
  const bool ok = writeRows(f, nullptr, width, height, input.rows.data(), input.chunks.data(),
                            int(input.chunks.size()), &failure);
  const bool flushed = std::fflush(f) == 0;
  const int flushErrno = errno;
  const bool closed = std::fclose(f) == 0;
  if (!ok) badInput(nameForMessages + ": writing failed (" + failure.message + ")");
  if (!flushed || !closed)
    badInput(nameForMessages + ": writing failed (" + std::strerror(flushed ? errno : flushErrno) + ")");
}

}  // namespace penumbra::detail
