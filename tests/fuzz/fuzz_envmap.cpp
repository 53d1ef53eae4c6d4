// libFuzzer target: the environment-map loader the CLI uses (environmentFrom -> loadEnvironment:
// OpenImageIO's readers, then sanitizing). Input: one byte choosing the extension (and whether a
// PNG's CRCs are fixed up), then the file.
#include <cstddef>
#include <cstdint>

#include "fuzz_support.hpp"
#include "penumbra/environment.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace penumbra::fuzz;
  if (size < 1) return 0;
  static const char* const kExt[] = {".exr", ".hdr", ".pfm", ".png"};
  // The selector's top bit left clear (as in the seed corpus): a PNG's CRCs are made to match,
  // so that mutations reach libpng's parsers; set: the file as it is, for the CRC check in the
  // loader's trial decode.
  const std::string file = (data[0] & 0x80) ? std::string(reinterpret_cast<const char*>(data + 1),
                                                          size - 1)
                                            : withPngCrcsFixed(data + 1, size - 1);
  const std::string path =
      scratch().write(std::string("map") + pickExtension(data[0] & 0x7f, kExt),
                      reinterpret_cast<const std::uint8_t*>(file.data()), file.size());
  return refusalIsFine([&] {
    const penumbra::Environment env = penumbra::environmentFrom(path);
    // What the CLI does next with a loaded map (power for the report, the rotation's shift).
    double rgb[3];
    env.power(rgb);
    (void)env.rotationColumns();
  });
}
