// Numbers in messages (internal): the shortest decimal that reads back as the same value ("95",
// "0.1", "1e+39"; a float as a float, so 0.1f is "0.1", not 0.10000000149011612).
// std::to_string and streams follow the C and C++ locales ("95,500000" under a German one);
// to_chars does not.
#pragma once
#include <charconv>
#include <string>
#include <type_traits>

namespace penumbra::detail {

template <class Float>
std::string numberText(Float v) {
  static_assert(std::is_floating_point_v<Float>, "integers: std::to_string");
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

}  // namespace penumbra::detail
