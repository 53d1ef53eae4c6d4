// The strict JSON reader and the shared number forms (core/json.hpp). nlohmann-json parses; a
// parser callback adds what it lets through (duplicate keys, unbounded nesting), and an input
// iterator that counts the bytes read places those refusals in the text as nlohmann places its
// own syntax errors.
#include "core/json.hpp"

#include <charconv>
#include <cmath>
#include <iterator>
#include <set>
#include <vector>

#include "penumbra/error.hpp"

namespace penumbra::detail {
namespace {

// Reads the text as nlohmann's input adapter does, one byte per increment, and records how many
// bytes it has read: where the parser stands when the callback refuses something.
class CountingIterator {
 public:
  using iterator_category = std::input_iterator_tag;
  using value_type = char;
  using difference_type = std::ptrdiff_t;
  using pointer = const char*;
  using reference = const char&;

  CountingIterator(const char* p, const char* base, std::size_t* read)
      : p_(p), base_(base), read_(read) {}
  reference operator*() const { return *p_; }
  CountingIterator& operator++() {
    ++p_;
    *read_ = std::size_t(p_ - base_);
    return *this;
  }
  CountingIterator operator++(int) {
    CountingIterator old = *this;
    ++*this;
    return old;
  }
  bool operator==(const CountingIterator& o) const { return p_ == o.p_; }
  bool operator!=(const CountingIterator& o) const { return p_ != o.p_; }

 private:
  const char* p_;
  const char* base_;
  std::size_t* read_;
};

// "<source>: invalid JSON at line L, column C: <what>", with L and C counted as nlohmann counts
// them: `read` bytes consumed, the column being the bytes read on the current line.
[[noreturn]] void refuse(const std::string& text, const std::string& source, std::size_t read,
                         const std::string& what) {
  const std::size_t seen = std::min(read, text.size());
  std::size_t line = 1, lineStart = 0;
  for (std::size_t i = 0; i < seen; ++i)
    if (text[i] == '\n') ++line, lineStart = i + 1;
  badInput(source + ": invalid JSON at line " + std::to_string(line) + ", column " +
           std::to_string(read - lineStart) + ": " + what);
}

// nlohmann's message without its "[json.exception.parse_error.101] parse error at line 1,
// column 5: " head, which refuse() writes in our own form.
std::string detailOf(const std::string& what) {
  std::size_t at = what.find("parse error");
  at = at == std::string::npos ? what.find("] ") : what.find(": ", at);
  return at == std::string::npos ? what : what.substr(at + 2);
}

}  // namespace

Json parseJson(const std::string& text, const std::string& source, int maxDepth) {
  std::size_t read = 0;
  std::vector<std::set<std::string>> keys;  // the keys seen so far in each open object
  const Json::parser_callback_t check = [&](int depth, Json::parse_event_t event, Json& parsed) {
    switch (event) {
      case Json::parse_event_t::object_start:
      case Json::parse_event_t::array_start:
        if (depth >= maxDepth)
          refuse(text, source, read,
                 "nested too deeply (more than " + std::to_string(maxDepth) + " levels)");
        if (event == Json::parse_event_t::object_start) keys.emplace_back();
        break;
      case Json::parse_event_t::object_end:
        keys.pop_back();
        break;
      case Json::parse_event_t::key:
        if (!keys.empty() && !keys.back().insert(parsed.get<std::string>()).second)
          refuse(text, source, read, "duplicate key \"" + parsed.get<std::string>() + "\"");
        break;
      default:
        break;
    }
    return true;
  };
  const char* base = text.data();
  try {
    return Json::parse(CountingIterator(base, base, &read),
                       CountingIterator(base + text.size(), base, &read), check);
  } catch (const Json::parse_error& e) {
    refuse(text, source, e.byte, detailOf(e.what()));
  } catch (const Json::exception& e) {
    // out_of_range 406: a number beyond double's range ("number overflow parsing '1e400'")
    refuse(text, source, read, detailOf(e.what()));
  }
}

double shortestDecimal(float v) {
  if (!std::isfinite(v)) return double(v);
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  double d = 0.0;
  std::from_chars(buf, r.ptr, d);
  return d;
}

Json finiteOrNull(double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); }

std::string dumpJson(const Json& j, int indent) {
  return j.dump(indent, ' ', false, Json::error_handler_t::replace);
}

}  // namespace penumbra::detail
