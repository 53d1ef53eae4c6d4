// ScopedEnv: an environment variable set (or unset) for one scope, for the tests that switch the
// library's PENUMBRA_* variables (device, host pages, program cache, CPU forms).
#pragma once
#include <cstdlib>
#include <optional>
#include <string>

namespace penumbra::test {

// Sets (or, given nullopt, unsets) an environment variable for one scope and puts back what the
// process had before, set or not: later tests in the same process (and a developer's own
// PENUMBRA_DEVICE) see the variable as it was.
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const std::optional<std::string>& value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    if (value) ::setenv(name, value->c_str(), 1);
    else ::unsetenv(name);
  }
  ~ScopedEnv() {
    if (old_) ::setenv(name_, old_->c_str(), 1);
    else ::unsetenv(name_);
  }
  ScopedEnv(const ScopedEnv&) = delete;
  ScopedEnv& operator=(const ScopedEnv&) = delete;

 private:
  const char* name_;
  std::optional<std::string> old_;
};

}  // namespace penumbra::test
