// libFuzzer target: the mesh loader (loadScene: Assimp, then penumbra's checks of what it
// returns). Input: one byte choosing the extension, then the file.
#include <cstddef>
#include <cstdint>

#include "fuzz_support.hpp"
#include "penumbra/scene.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace penumbra::fuzz;
  if (size < 1) return 0;
  static const char* const kExt[] = {".obj", ".ply", ".glb", ".gltf", ".stl", ".off"};
  const std::string path =
      scratch().write(std::string("mesh") + pickExtension(data[0], kExt), data + 1, size - 1);
  return refusalIsFine([&] {
    penumbra::LoadOptions opt;
    opt.addGround = (data[0] / 8) % 2 == 0;  // both with and without the CLI's ground plane
    (void)penumbra::loadScene(path, opt);
  });
}
