/// \file
/// Spelling suggestions for names a user typed: the CLI's "did you mean --size?", the JSON readers'
/// unknown fields and the Python bindings' keywords all use the same rule.
#pragma once
#include <string>
#include <vector>

namespace penumbra {

/// The known name closest to `given` by edit distance (Levenshtein 1966: insertions, deletions,
/// substitutions, and a swap of two neighbouring letters counted as one edit), or "" when none is
/// close: at most 1 edit for names of up to 4 letters, 2 up to 8, 3 beyond. A known name that
/// starts with `given` (3 letters or more) is also accepted. Ties go to the first in `known`.
std::string suggestName(const std::string& given, const std::vector<std::string>& known);

/// " (did you mean "x"?)" with the suggestion quoted as `quote` + x + `quote`, or "" when there is
/// none: ready to append to an error message.
std::string didYouMean(const std::string& given, const std::vector<std::string>& known,
                       const std::string& quote = "\"");

}  // namespace penumbra
