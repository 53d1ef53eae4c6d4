// libFuzzer target: what `penumbra compare A B` does with its image pair (readImage on both,
// compareImages, readImageAttributes on B for the reference's noise, toJson). Input: one byte
// choosing both extensions (low and high nibble), four bytes (little-endian) giving A's length
// (taken modulo what is left), then A, then B.
#include <cstddef>
#include <cstdint>

#include "fuzz_support.hpp"
#include "penumbra/image.hpp"
#include "penumbra/reference.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace penumbra::fuzz;
  if (size < 5) return 0;
  static const char* const kExt[] = {".exr", ".png", ".hdr", ".pfm"};
  const std::uint32_t declared = std::uint32_t(data[1]) | std::uint32_t(data[2]) << 8 |
                                 std::uint32_t(data[3]) << 16 | std::uint32_t(data[4]) << 24;
  const std::size_t rest = size - 5;
  const std::size_t lengthA = declared % (rest + 1);
  // PNG inputs get matching CRCs (fuzz_support.hpp), so that mutations reach libpng.
  const std::string fileA = withPngCrcsFixed(data + 5, lengthA);
  const std::string fileB = withPngCrcsFixed(data + 5 + lengthA, rest - lengthA);
  const auto bytes = [](const std::string& f) {
    return reinterpret_cast<const std::uint8_t*>(f.data());
  };
  const std::string a = scratch().write(std::string("a") + pickExtension(data[0] & 15, kExt),
                                        bytes(fileA), fileA.size());
  const std::string b = scratch().write(std::string("b") + pickExtension(data[0] >> 4, kExt),
                                        bytes(fileB), fileB.size());
  return refusalIsFine([&] {
    const penumbra::Image A = penumbra::readImage(a);
    const penumbra::Image B = penumbra::readImage(b);
    const penumbra::ImageMetrics m = penumbra::compareImages(A, B);
    (void)penumbra::readImageAttributes(b);
    (void)penumbra::toJson(m);
  });
}
