/// \file
/// Headless OpenGL contexts for penumbra's GL interop layer (built with -DPENUMBRA_BUILD_GL=ON).
///
/// A HeadlessContext is an OpenGL 3.3 core context with no window: EGL first (Mesa's surfaceless
/// platform, EGL_MESA_platform_surfaceless, then the device platform, EGL_EXT_platform_device,
/// then the default display), OSMesa as the fallback. Under Mesa without a GPU both give llvmpipe.
/// EGL and OSMesa are loaded at run time (dlopen), so a machine without them still runs every
/// OpenCL-only path; creating a context there throws Error(NoPlatform) naming what is missing.
/// $PENUMBRA_EGL_LIBRARY and $PENUMBRA_OSMESA_LIBRARY override the library file names
/// (libEGL.so.1, libOSMesa.so.8).
#pragma once
#include <memory>
#include <string>

namespace penumbra::gl {

enum class Backend { Auto, EGL, OSMesa };
/// "auto" | "egl" | "osmesa"; anything else throws Error(BadInput) naming --gl.
Backend parseBackend(const std::string& name);
const char* toString(Backend b);

/// Returns the address of a GL function by name, for the context current on the calling thread.
using ProcLoader = void* (*)(const char* name);

class HeadlessContext {
 public:
  /// Creates the context and makes it current on the calling thread.
  explicit HeadlessContext(Backend backend = Backend::Auto);
  ~HeadlessContext();
  HeadlessContext(const HeadlessContext&) = delete;
  HeadlessContext& operator=(const HeadlessContext&) = delete;

  void makeCurrent();
  Backend backend() const;            // the one in use: EGL or OSMesa
  const std::string& description() const;  ///< e.g. "EGL surfaceless, 4.5 (Core Profile) Mesa
                                            ///< 22.3.6, llvmpipe (LLVM 15.0.6, 256 bits)"
  ProcLoader loader() const;          // GL functions of this context

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The loader for whatever EGL or OSMesa context is current on the calling thread (an
/// application's own), or nullptr when neither library is loaded or no context is current.
ProcLoader currentContextLoader();

}  // namespace penumbra::gl
