// Numbers in messages (internal): the shortest decimal that reads back as the same double ("95",
// "0.1", "1e+39"). std::to_string and streams follow the C and C++ locales ("95,500000" under a
// German one); to_chars does not.
#pragma once
#include <charconv>
#include <string>

namespace penumbra::detail {

inline std::string numberText(double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

}  // namespace penumbra::detail
