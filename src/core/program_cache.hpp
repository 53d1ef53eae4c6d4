// Compiled OpenCL programs kept between processes (Context::kernel). PoCL keeps its own cache of
// compiled kernels, but reaching it from source still runs the preprocessor over every program
// to hash it: about 50 ms a program, 8 programs in a default frame. A program made from the
// binary this cache keeps skips that and finds the same compiled kernels.
//
// One file per (device, driver, penumbra version, build options, source), named by a 128-bit hash
// of all of them, holding a header that repeats the hash, the binary's size and a checksum of it:
// a file that is truncated, corrupt, stored under another key's name or owned by another user is
// never handed to the driver. The checksum finds damage, not tampering: a binary holds native
// code, so the directory must be writable by its user only (as PoCL's own cache is). A binary the
// driver refuses all the same is built again from source and stored over. Files are written
// beside their final name (a name of their own per process and store) and renamed into place, so
// readers never see half a file.
// Failing to read or write the cache only costs the time it would have saved: nothing throws.
#pragma once
#include <string>
#include <vector>

namespace penumbra::detail {

class ProgramCache {
 public:
  // The directory: $PENUMBRA_CACHE_DIR, else $XDG_CACHE_HOME/penumbra, else $HOME/.cache/penumbra
  // (then programs/ inside it); "" when PENUMBRA_CACHE_DIR is "off" or no variable gives one.
  static std::string defaultDirectory();

  // `device` identifies the compiler: platform, device, driver and their versions.
  ProgramCache(std::string directory, std::string device);

  bool enabled() const { return !directory_.empty(); }
  const std::string& directory() const { return directory_; }

  // The binary stored for this source and these build options; empty when there is none (or it
  // does not check out).
  std::vector<unsigned char> load(const std::string& source, const std::string& options) const;
  // Stores `binary`; false (and nothing left behind) when it could not.
  bool store(const std::string& source, const std::string& options,
             const std::vector<unsigned char>& binary) const;

  // The file that holds (source, options).
  std::string fileFor(const std::string& source, const std::string& options) const;

 private:
  std::string directory_;
  std::string device_;
};

}  // namespace penumbra::detail
