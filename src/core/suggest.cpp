// Spelling suggestions (include/penumbra/suggest.hpp): an optimal-string-alignment edit distance
// over the known names.
#include "penumbra/suggest.hpp"

#include <algorithm>
#include <cstddef>

namespace penumbra {
namespace {

// Edit distance with adjacent transpositions (the "optimal string alignment" form of
// Damerau 1964 / Levenshtein 1966), case-sensitive, over bytes.
std::size_t editDistance(const std::string& a, const std::string& b) {
  const std::size_t n = a.size(), m = b.size();
  std::vector<std::size_t> prev2(m + 1), prev(m + 1), cur(m + 1);
  for (std::size_t j = 0; j <= m; ++j) prev[j] = j;
  for (std::size_t i = 1; i <= n; ++i) {
    cur[0] = i;
    for (std::size_t j = 1; j <= m; ++j) {
      std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1])
        cur[j] = std::min(cur[j], prev2[j - 2] + 1);
    }
    prev2.swap(prev);
    prev.swap(cur);
  }
  return prev[m];
}

}  // namespace

std::string suggestName(const std::string& given, const std::vector<std::string>& known) {
  if (given.empty()) return "";
  const std::size_t allowed = given.size() <= 4 ? 1 : given.size() <= 8 ? 2 : 3;
  std::string best;
  std::size_t bestDistance = allowed + 1;
  for (const auto& name : known) {
    if (name == given) return name;
    std::size_t d = editDistance(given, name);
    if (d < bestDistance) {
      bestDistance = d;
      best = name;
    }
  }
  if (!best.empty()) return best;
  if (given.size() >= 3)
    for (const auto& name : known)
      if (name.compare(0, given.size(), given) == 0) return name;
  return "";
}

std::string didYouMean(const std::string& given, const std::vector<std::string>& known,
                       const std::string& quote) {
  std::string s = suggestName(given, known);
  return s.empty() ? std::string() : " (did you mean " + quote + s + quote + "?)";
}

}  // namespace penumbra
