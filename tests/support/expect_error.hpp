// The suite's one check of the library's error contract: a call that must fail throws
// penumbra::Error of the expected kind, with one line naming the parameter or file and the problem.
#pragma once
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "penumbra/error.hpp"

namespace penumbra::test {

// Runs f, which must throw penumbra::Error of `kind` with a one-line message (the library's
// contract: one clear line naming the file or parameter and the problem) holding every needle.
template <class F>
void expectError(ErrorKind kind, F&& f, const std::vector<std::string>& needles) {
  try {
    f();
    ADD_FAILURE() << "no exception; expected one mentioning " << needles.front();
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_EQ(e.kind(), kind) << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << "message spans lines: " << msg;
    for (const std::string& n : needles)
      EXPECT_NE(msg.find(n), std::string::npos) << "'" << n << "' missing from: " << msg;
  }
}
template <class F>
void expectBadInput(F&& f, const std::vector<std::string>& needles) {
  expectError(ErrorKind::BadInput, f, needles);
}
template <class F>
void expectBadInput(F&& f, const char* needle) {
  expectError(ErrorKind::BadInput, f, std::vector<std::string>{needle});
}

}  // namespace penumbra::test
