// The library's JSON conventions on top of nlohmann-json (internal): a strict reader that gives
// line and column for every refusal and refuses what nlohmann would merge silently (a duplicate
// key), and the number forms every writer shares (floats as their shortest decimal, non-finite
// values as null). All of it is independent of the C and C++ locales.
#pragma once
#include <nlohmann/json.hpp>
#include <string>

#include "core/number_text.hpp"  // numberText, for the readers' messages

namespace penumbra::detail {

using Json = nlohmann::ordered_json;  // objects keep their keys in document (or insertion) order

// Parses `text` as one JSON value. Throws Error(BadInput) "<source>: invalid JSON at line L,
// column C: <what>" for a syntax error (nlohmann's: trailing commas, 0x5, 01, NaN, a bad escape,
// ill-formed UTF-8), a number beyond double's range, a key that appears twice in one object, or
// containers nested deeper than `maxDepth`.
Json parseJson(const std::string& text, const std::string& source, int maxDepth = 64);

// The shortest decimal that reads back as the same float, as a double (0.1f gives 0.1, not
// 0.10000000149011612), through to_chars/from_chars; a non-finite value as is (dumped as null).
double shortestDecimal(float v);

// v, or null when it is not finite (JSON has no NaN or infinity).
Json finiteOrNull(double v);

// `j` as text, indented by `indent` spaces (-1: one line); text that is not valid UTF-8 is written
// with U+FFFD instead of throwing, so the output is always valid JSON.
std::string dumpJson(const Json& j, int indent);

}  // namespace penumbra::detail
