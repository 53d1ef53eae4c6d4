/// \file
/// penumbra::Error: the one exception type the library throws, with a kind that tells the caller
/// (and the CLI's exit code) whether the input, the device or the library itself is at fault.
#pragma once
#include <stdexcept>
#include <string>

namespace penumbra {

enum class ErrorKind {
  BadInput,     // a file, parameter or value the caller gave is unusable; the message names it
  NoPlatform,   // no OpenCL platform/device could be found or matched
  KernelBuild,  // an embedded kernel failed to compile; the message carries the build log
  OutOfMemory,  // the device could not allocate a buffer
  Device,       // any other OpenCL failure
  Internal,     // a bug in penumbra, or a broken installation (libpenumbra_oiio.so.* missing)
  Cancelled,    // the caller asked a long call to stop (ReferenceOptions::cancel); not a failure
};

const char* toString(ErrorKind kind);

class Error : public std::runtime_error {
 public:
  Error(ErrorKind kind, const std::string& message) : std::runtime_error(message), kind_(kind) {}
  ErrorKind kind() const { return kind_; }

 private:
  ErrorKind kind_;
};

[[noreturn]] inline void badInput(const std::string& message) {
  throw Error(ErrorKind::BadInput, message);
}

}  // namespace penumbra
