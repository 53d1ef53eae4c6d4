// ProgramCache (core/program_cache.hpp).
#include "core/program_cache.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <atomic>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "penumbra/version.hpp"

namespace penumbra::detail {

namespace {

namespace fs = std::filesystem;

constexpr char kMagic[] = "penumbra program binary 1\n";

// FNV-1a, 64 bits, from a given basis: two bases give two independent-enough halves of the key.
std::uint64_t fnv1a(const std::string& bytes, std::uint64_t basis) {
  std::uint64_t h = basis;
  for (unsigned char c : bytes) {
    h ^= c;
    h *= 0x100000001b3ull;
  }
  return h;
}

std::string hex64(std::uint64_t v) {
  char s[17];
  std::snprintf(s, sizeof s, "%016llx", static_cast<unsigned long long>(v));
  return s;
}

std::string checksum(const std::vector<unsigned char>& binary) {
  return hex64(fnv1a(std::string(binary.begin(), binary.end()), 0xcbf29ce484222325ull));
}

}  // namespace

std::string ProgramCache::defaultDirectory() {
  const char* own = std::getenv("PENUMBRA_CACHE_DIR");
  fs::path base;
  if (own && *own) {
    if (std::string(own) == "off") return "";
    base = own;
  } else if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg) {
    base = fs::path(xdg) / "penumbra";
  } else if (const char* home = std::getenv("HOME"); home && *home) {
    base = fs::path(home) / ".cache" / "penumbra";
  } else {
    return "";
  }
  return (base / "programs").string();
}

ProgramCache::ProgramCache(std::string directory, std::string device)
    : directory_(std::move(directory)), device_(std::move(device) + '\n' + PENUMBRA_VERSION) {}

std::string ProgramCache::fileFor(const std::string& source, const std::string& options) const {
  const std::string key = device_ + '\0' + options + '\0' + source;
  return (fs::path(directory_) /
          (hex64(fnv1a(key, 0xcbf29ce484222325ull)) + hex64(fnv1a(key, 0x84222325cbf29ce4ull)) +
           ".bin"))
      .string();
}

std::vector<unsigned char> ProgramCache::load(const std::string& source,
                                              const std::string& options) const {
  if (!enabled()) return {};
  const std::string file = fileFor(source, options);
  struct stat st{};
  if (::stat(file.c_str(), &st) != 0 || st.st_uid != ::geteuid()) return {};
  std::ifstream in(file, std::ios::binary);
  if (!in) return {};
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  // magic, the file's own name (its key), the binary's size and checksum, then the binary.
  const std::string name = fs::path(file).stem().string();
  const std::string head = kMagic + name + '\n';
  if (bytes.compare(0, head.size(), head) != 0) return {};
  std::size_t at = head.size();
  const std::size_t sizeEnd = bytes.find('\n', at);
  if (sizeEnd == std::string::npos || sizeEnd - at > 19) return {};
  std::uint64_t size = 0;
  for (std::size_t i = at; i < sizeEnd; ++i) {
    if (bytes[i] < '0' || bytes[i] > '9') return {};
    size = size * 10 + std::uint64_t(bytes[i] - '0');
  }
  at = sizeEnd + 1;
  if (bytes.size() < at + 17) return {};
  const std::string sum = bytes.substr(at, 16);
  at += 17;
  if (bytes[at - 1] != '\n' || bytes.size() - at != size || size == 0) return {};
  std::vector<unsigned char> binary(bytes.begin() + std::ptrdiff_t(at), bytes.end());
  if (checksum(binary) != sum) return {};
  return binary;
}

bool ProgramCache::store(const std::string& source, const std::string& options,
                         const std::vector<unsigned char>& binary) const {
  if (!enabled() || binary.empty()) return false;
  std::error_code ec;
  fs::create_directories(directory_, ec);
  const std::string file = fileFor(source, options);
  // Two Contexts of one process may store the same program at once: each store its own file.
  static std::atomic<unsigned> stores{0};
  const std::string tmp =
      file + ".tmp" + std::to_string(::getpid()) + "." + std::to_string(stores.fetch_add(1));
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) return false;
    out << kMagic << fs::path(file).stem().string() << '\n'
        << binary.size() << '\n'
        << checksum(binary) << '\n';
    out.write(reinterpret_cast<const char*>(binary.data()), std::streamsize(binary.size()));
    out.close();
    if (!out) {
      fs::remove(tmp, ec);
      return false;
    }
  }
  fs::rename(tmp, file, ec);
  if (ec) {
    fs::remove(tmp, ec);
    return false;
  }
  return true;
}

}  // namespace penumbra::detail
