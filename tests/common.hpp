// Shared fixtures for the test suite: one OpenCL context for the whole binary, data paths.
#pragma once
#include <penumbra/penumbra.hpp>

#include <string>

namespace penumbra::test {

// Never destroyed: under oclgrind a Context released during static destruction (after LLVM's
// own static state is gone) corrupts the heap and aborts the run.
inline Context& ctx() {
  static Context* c = new Context;
  return *c;
}

inline std::string data(const std::string& rel) { return std::string(PENUMBRA_TEST_DATA) + "/" + rel; }

inline const char* kMaps[] = {"envmaps/courtyard.exr", "envmaps/interior.exr", "envmaps/studio.exr"};

inline float luminance(const double rgb[3]) {
  return float(PB_LUM_R * rgb[0] + PB_LUM_G * rgb[1] + PB_LUM_B * rgb[2]);
}

}  // namespace penumbra::test
