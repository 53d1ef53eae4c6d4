// libFuzzer target: the light-set JSON parser (lightSetFromJson, which loadLightSet and
// `--light-set` use), and the round trip of whatever it accepts through LightSet::toJson.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_support.hpp"
#include "penumbra/lights.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace penumbra::fuzz;
  const std::string text(reinterpret_cast<const char*>(data), size);
  return refusalIsFine([&] {
    const penumbra::LightSet set = penumbra::lightSetFromJson(text, "fuzz.json");
    // An accepted set must serialize to a document that parses again.
    (void)penumbra::lightSetFromJson(set.toJson(), "round trip");
  });
}
