// Loading the OpenImageIO module (core/image_codec.hpp): found beside libpenumbra, whose own path
// dladdr gives, loaded once.
#include "core/image_codec.hpp"

#include <dlfcn.h>

#include <cstring>
#include <filesystem>
#include <mutex>

#include "penumbra/error.hpp"
#include "penumbra/version.hpp"

namespace penumbra::detail {

namespace {

struct Loaded {
  const ImageCodec* codec = nullptr;
  std::string error;  // why codec is null
};

Loaded load() {
  Loaded out;
  Dl_info self{};
  if (!dladdr(reinterpret_cast<const void*>(&imageCodec), &self) || !self.dli_fname) {
    out.error = "image support: cannot find where libpenumbra was loaded from, so not " +
                kImageCodecFile + " beside it either";
    return out;
  }
  const std::string file =
      (std::filesystem::path(self.dli_fname).parent_path() / kImageCodecFile).string();
  const std::string what = "image support: " + file + " (installed beside libpenumbra)";
  // Never closed: OpenImageIO keeps threads and caches until the process ends.
  void* handle = dlopen(file.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle) {
    const char* why = dlerror();
    out.error = what + " cannot be loaded: " + (why ? why : "unknown reason");
    return out;
  }
  using Entry = const ImageCodec* (*)();
  const auto entry = reinterpret_cast<Entry>(dlsym(handle, kImageCodecSymbol));
  const ImageCodec* codec = entry ? entry() : nullptr;
  if (!codec) {
    out.error = what + " has no " + kImageCodecSymbol + " table";
    return out;
  }
  if (codec->abi != kImageCodecAbi || !codec->version ||
      std::strcmp(codec->version, PENUMBRA_VERSION) != 0) {
    out.error = what + " is from another build (penumbra " +
                (codec->version ? codec->version : "?") + ", interface " +
                std::to_string(codec->abi) + "; this libpenumbra is " + PENUMBRA_VERSION +
                ", interface " + std::to_string(kImageCodecAbi) + ")";
    return out;
  }
  out.codec = codec;
  return out;
}

std::once_flag gLoadOnce;
Loaded gLoaded;

void loadOnce() {
  std::call_once(gLoadOnce, [] { gLoaded = load(); });
}

}  // namespace

const ImageCodec& imageCodec() {
  loadOnce();
  if (!gLoaded.codec) throw Error(ErrorKind::Internal, gLoaded.error);
  return *gLoaded.codec;
}

}  // namespace penumbra::detail
