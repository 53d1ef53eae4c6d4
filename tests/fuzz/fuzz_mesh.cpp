// libFuzzer target: the mesh loader (loadScene: Assimp, then penumbra's checks of what it
// returns; Assimp itself runs in a child process, so a crash or leak there is a refusal, not a
// finding). Input: one byte choosing the extension, then the file.
#include <pthread.h>

#include <csignal>
#include <cstddef>
#include <cstdint>

#include "fuzz_support.hpp"
#include "penumbra/scene.hpp"

namespace {

// The contained reader's child inherits libFuzzer's crash handlers, which would write a crash-*
// artifact for a crash that loadScene correctly turns into a refusal. The child gets the default
// dispositions back, so it just dies and only the parent's crashes are reported.
void defaultCrashSignals() {
  for (int sig : {SIGABRT, SIGSEGV, SIGBUS, SIGFPE, SIGILL}) std::signal(sig, SIG_DFL);
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  pthread_atfork(nullptr, nullptr, defaultCrashSignals);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace penumbra::fuzz;
  if (size < 1) return 0;
  static const char* const kExt[] = {".obj", ".ply", ".glb", ".gltf", ".stl", ".off"};
  const std::string path =
      scratch().write(std::string("mesh") + pickExtension(data[0], kExt), data + 1, size - 1);
  return refusalIsFine([&] {
    penumbra::LoadOptions opt;
    opt.addGround = (data[0] / 8) % 2 == 0;  // both with and without the CLI's ground plane
    // The contained reader's own deadline, well inside libFuzzer's -timeout=30 (run.sh), so that a
    // reader that hangs is refused by loadScene (correct) rather than reported as a timeout.
    opt.timeoutSeconds = 4;
    (void)penumbra::loadScene(path, opt);
  });
}
