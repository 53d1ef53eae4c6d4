// libFuzzer target: the environment-map loader the CLI uses (environmentFrom -> loadEnvironment:
// OpenImageIO's readers, then sanitizing). Input: one byte choosing the extension, then the file.
#include <cstddef>
#include <cstdint>

#include "fuzz_support.hpp"
#include "penumbra/environment.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace penumbra::fuzz;
  if (size < 1) return 0;
  static const char* const kExt[] = {".exr", ".hdr", ".pfm", ".png"};
  const std::string path =
      scratch().write(std::string("map") + pickExtension(data[0], kExt), data + 1, size - 1);
  return refusalIsFine([&] {
    const penumbra::Environment env = penumbra::environmentFrom(path);
    // What the CLI does next with a loaded map (power for the report, the rotation's shift).
    double rgb[3];
    env.power(rgb);
    (void)env.rotationColumns();
  });
}
