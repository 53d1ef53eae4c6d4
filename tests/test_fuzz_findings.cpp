// What the fuzz targets (tests/fuzz) found, as unit tests of the refusal each finding now gets.
// The inputs that found them are replayed as they are by the sanitizer build
// (tests/data/fuzz/crashes/<target>/); these tests pin the behaviour in every build.
#include <gtest/gtest.h>

#include <string>

#include "penumbra/error.hpp"
#include "penumbra/lights.hpp"

using namespace penumbra;

// fuzz_lightset: a "regions" entry beyond int's range was converted to int (undefined behaviour,
// reported by UBSan; in practice INT_MIN, accepted). Every entry must be a whole number in
// 0..INT_MAX, and the message names the light and the field.
TEST(FuzzFindings, LightSetRegionsMustBeIntegersInRange) {
  const char* bad[] = {"8.8e99", "-1", "1.5", "\"3\"", "1e400", "null"};
  for (const char* v : bad) {
    const std::string text = std::string("{\"lights\": [{\"direction\": [0, 1, 0], ") +
                             "\"half_angle_deg\": 5, \"radiance\": [1, 1, 1], " +
                             "\"regions\": [[1, 0, 0, " + v + ", 4]]}]}";
    try {
      lightSetFromJson(text, "regions.json");
      ADD_FAILURE() << "accepted a region coordinate " << v;
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::BadInput);
      const std::string msg = e.what();
      EXPECT_NE(msg.find("regions.json"), std::string::npos) << msg;
      EXPECT_NE(msg.find("\"regions\""), std::string::npos) << v << ": " << msg;
    }
  }
  // The largest accepted value still loads, as the integer it is.
  const LightSet ok = lightSetFromJson(
      "{\"lights\": [{\"direction\": [0, 1, 0], \"half_angle_deg\": 5, \"radiance\": [1, 1, 1], "
      "\"regions\": [[1, 0, 0, 2147483647, 4]]}]}",
      "regions.json");
  ASSERT_EQ(ok.lights.size(), 1u);
  ASSERT_EQ(ok.lights[0].regions.size(), 1u);
  EXPECT_EQ(ok.lights[0].regions[0][3], 2147483647);
}
