// What the libFuzzer targets in tests/fuzz share: a per-process scratch directory that the
// loaders taking a path read the fuzz input from, and the rule that a refusal (penumbra::Error)
// is a correct outcome while anything else (a crash, a sanitizer report, another exception, a
// hang or a memory blow-up caught by libFuzzer) is a finding.
#pragma once
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <zlib.h>

#include "penumbra/error.hpp"

namespace penumbra::fuzz {

// A directory of this process's own (mkdtemp under $TMPDIR), removed with everything in it when
// the process exits normally. libFuzzer's -fork/-jobs workers are separate processes, so they never
// share a file.
class ScratchDir {
 public:
  ScratchDir() {
    const char* tmp = std::getenv("TMPDIR");
    std::string pattern = std::string(tmp && *tmp ? tmp : "/tmp") + "/penumbra-fuzz-XXXXXX";
    if (!mkdtemp(pattern.data())) std::abort();  // no scratch space: nothing can be tested
    path_ = pattern;
  }
  ~ScratchDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;

  // Writes bytes to <dir>/<name> (replacing the previous input of that name) and returns the path.
  std::string write(const std::string& name, const std::uint8_t* data, std::size_t size) const {
    const std::string p = path_ + "/" + name;
    std::ofstream out(p, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), std::streamsize(size));
    if (!out) std::abort();
    return p;
  }

 private:
  std::string path_;
};

// The scratch directory of this process. A function-local static, because libFuzzer calls the
// target as a plain function many times and the directory must outlive every call; its destructor
// runs at exit.
inline const ScratchDir& scratch() {
  static const ScratchDir dir;
  return dir;
}

// One byte of the input picks the file extension the loader sees, so the fuzzer drives the reader
// choice (OpenImageIO and Assimp pick their readers by extension first) as well as the content.
template <std::size_t N>
const char* pickExtension(std::uint8_t selector, const char* const (&extensions)[N]) {
  return extensions[selector % N];
}

// The input with every whole chunk's CRC recomputed, when it is a PNG file (its 8-byte signature;
// chunks of a big-endian length, a type, the data and a CRC-32 of type and data, PNG
// specification §5.3). libpng checks every chunk's CRC, and the loader's trial decode makes a
// failed one an error, so without this nearly every mutation of a PNG would be refused for its
// CRC and libpng's parsers would see little of it. Other inputs, and the bytes past a cut-off
// chunk, are unchanged.
inline std::string withPngCrcsFixed(const std::uint8_t* data, std::size_t size) {
  std::string out(reinterpret_cast<const char*>(data), size);
  static const char kSignature[8] = {char(0x89), 'P', 'N', 'G', 0x0d, 0x0a, 0x1a, 0x0a};
  if (size < 8 || out.compare(0, 8, kSignature, 8) != 0) return out;
  for (std::size_t at = 8; at + 12 <= size;) {
    const auto byte = [&](std::size_t i) { return std::uint32_t(data[at + i]); };
    const std::size_t length = byte(0) << 24 | byte(1) << 16 | byte(2) << 8 | byte(3);
    if (length > size - at - 12) break;
    const uLong crc = crc32(crc32(0L, Z_NULL, 0), data + at + 4, uInt(4 + length));
    for (int k = 0; k < 4; ++k) out[at + 8 + length + std::size_t(k)] = char(crc >> (24 - 8 * k));
    at += 12 + length;
  }
  return out;
}

// Runs one input through `body`; penumbra::Error is the loader refusing the file, which is what it
// should do with garbage. Every other exception propagates and libFuzzer reports it as a crash.
template <class Body>
int refusalIsFine(Body&& body) {
  try {
    body();
  } catch (const penumbra::Error&) {
  }
  return 0;
}

}  // namespace penumbra::fuzz
