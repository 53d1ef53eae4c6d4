// Headless GL contexts: EGL (surfaceless, device, default display) with OSMesa as the fallback,
// both loaded with dlopen so that libpenumbra has no link-time dependency on GL.
#include "penumbra/gl/context.hpp"

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <dlfcn.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "glfuncs.hpp"
#include "penumbra/error.hpp"

namespace penumbra::gl {

Backend parseBackend(const std::string& name) {
  if (name == "auto") return Backend::Auto;
  if (name == "egl") return Backend::EGL;
  if (name == "osmesa") return Backend::OSMesa;
  badInput("gl::Backend: unknown backend '" + name + "' (available: egl, osmesa, auto)");
}

const char* toString(Backend b) {
  switch (b) {
    case Backend::EGL: return "egl";
    case Backend::OSMesa: return "osmesa";
    default: return "auto";
  }
}

namespace {

// OSMesa's constants and entry points (GL/osmesa.h pulls in GL/gl.h, which clashes with
// glcorearb.h; the values are fixed by that header's ABI).
constexpr int kOSMesaFormat = 0x22, kOSMesaDepthBits = 0x30, kOSMesaProfile = 0x33,
              kOSMesaCoreProfile = 0x34, kOSMesaMajor = 0x36, kOSMesaMinor = 0x37;
using OSMesaContext = void*;
using OSMesaCreateContextAttribsFn = OSMesaContext (*)(const int*, OSMesaContext);
using OSMesaMakeCurrentFn = unsigned char (*)(OSMesaContext, void*, GLenum, GLsizei, GLsizei);
using OSMesaDestroyContextFn = void (*)(OSMesaContext);
using OSMesaGetCurrentContextFn = OSMesaContext (*)();
using OSMesaGetProcAddressFn = void* (*)(const char*);

std::string envOr(const char* name, const char* fallback) {
  const char* v = std::getenv(name);
  return v && *v ? v : fallback;
}

// One process-wide handle per library: dlopen of a loaded library returns the same one.
struct EGLLib {
  void* handle = nullptr;
  std::string file, error;
  decltype(&eglGetProcAddress) getProcAddress = nullptr;
  decltype(&eglQueryString) queryString = nullptr;
  decltype(&eglGetDisplay) getDisplay = nullptr;
  decltype(&eglInitialize) initialize = nullptr;
  decltype(&eglTerminate) terminate = nullptr;
  decltype(&eglBindAPI) bindAPI = nullptr;
  decltype(&eglChooseConfig) chooseConfig = nullptr;
  decltype(&eglCreateContext) createContext = nullptr;
  decltype(&eglDestroyContext) destroyContext = nullptr;
  decltype(&eglMakeCurrent) makeCurrent = nullptr;
  decltype(&eglGetCurrentContext) getCurrentContext = nullptr;
  decltype(&eglCreatePbufferSurface) createPbufferSurface = nullptr;
  decltype(&eglDestroySurface) destroySurface = nullptr;
  decltype(&eglGetError) getError = nullptr;
};

struct OSMesaLib {
  void* handle = nullptr;
  std::string file, error;
  OSMesaCreateContextAttribsFn createContextAttribs = nullptr;
  OSMesaMakeCurrentFn makeCurrent = nullptr;
  OSMesaDestroyContextFn destroyContext = nullptr;
  OSMesaGetCurrentContextFn getCurrentContext = nullptr;
  OSMesaGetProcAddressFn getProcAddress = nullptr;
};

template <class F>
bool sym(void* h, const char* name, F& out, std::string& error) {
  out = reinterpret_cast<F>(dlsym(h, name));
  if (!out) error = "missing symbol " + std::string(name);
  return out != nullptr;
}

// The libraries, each as (environment variable that overrides it, default file name).
const char* const kEglLibrary[2] = {"PENUMBRA_EGL_LIBRARY", "libEGL.so.1"};
const char* const kOSMesaLibrary[2] = {"PENUMBRA_OSMESA_LIBRARY", "libOSMesa.so.8"};

// dlopen()s $envVar or `fallback` into l.handle; on failure l.error says which file and why.
template <class Lib>
bool openLibrary(Lib& l, const char* envVar, const char* fallback) {
  l.file = envOr(envVar, fallback);
  l.handle = dlopen(l.file.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (l.handle) return true;
  const char* e = dlerror();
  l.error = "cannot load " + l.file + (e ? std::string(" (") + e + ")" : "");
  return false;
}

EGLLib& eglLib() {
  static EGLLib lib = [] {
    EGLLib l;
    if (!openLibrary(l, kEglLibrary[0], kEglLibrary[1])) return l;
    std::string& e = l.error;
    bool ok = sym(l.handle, "eglGetProcAddress", l.getProcAddress, e) &&
              sym(l.handle, "eglQueryString", l.queryString, e) &&
              sym(l.handle, "eglGetDisplay", l.getDisplay, e) &&
              sym(l.handle, "eglInitialize", l.initialize, e) &&
              sym(l.handle, "eglTerminate", l.terminate, e) &&
              sym(l.handle, "eglBindAPI", l.bindAPI, e) &&
              sym(l.handle, "eglChooseConfig", l.chooseConfig, e) &&
              sym(l.handle, "eglCreateContext", l.createContext, e) &&
              sym(l.handle, "eglDestroyContext", l.destroyContext, e) &&
              sym(l.handle, "eglMakeCurrent", l.makeCurrent, e) &&
              sym(l.handle, "eglGetCurrentContext", l.getCurrentContext, e) &&
              sym(l.handle, "eglCreatePbufferSurface", l.createPbufferSurface, e) &&
              sym(l.handle, "eglDestroySurface", l.destroySurface, e) &&
              sym(l.handle, "eglGetError", l.getError, e);
    if (!ok) l.handle = nullptr;
    return l;
  }();
  return lib;
}

OSMesaLib& osmesaLib() {
  static OSMesaLib lib = [] {
    OSMesaLib l;
    if (!openLibrary(l, kOSMesaLibrary[0], kOSMesaLibrary[1])) return l;
    std::string& e = l.error;
    bool ok = sym(l.handle, "OSMesaCreateContextAttribs", l.createContextAttribs, e) &&
              sym(l.handle, "OSMesaMakeCurrent", l.makeCurrent, e) &&
              sym(l.handle, "OSMesaDestroyContext", l.destroyContext, e) &&
              sym(l.handle, "OSMesaGetCurrentContext", l.getCurrentContext, e) &&
              sym(l.handle, "OSMesaGetProcAddress", l.getProcAddress, e);
    if (!ok) l.handle = nullptr;
    return l;
  }();
  return lib;
}

void* eglLoader(const char* name) {
  return reinterpret_cast<void*>(eglLib().getProcAddress(name));
}
void* osmesaLoader(const char* name) { return osmesaLib().getProcAddress(name); }

bool hasExtension(const char* list, const char* name) {
  if (!list) return false;
  std::size_t n = std::strlen(name);
  for (const char* p = list; (p = std::strstr(p, name)); p += n)
    if ((p == list || p[-1] == ' ') && (p[n] == ' ' || p[n] == '\0')) return true;
  return false;
}

std::string hex(long v) {
  char b[32];
  std::snprintf(b, sizeof b, "0x%lx", v);
  return b;
}

}  // namespace

struct HeadlessContext::Impl {
  Backend backend = Backend::Auto;
  std::string description;
  // EGL
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLContext context = EGL_NO_CONTEXT;
  EGLSurface surface = EGL_NO_SURFACE;
  // OSMesa
  OSMesaContext osmesa = nullptr;
  std::vector<unsigned char> osmesaBuffer;

  // Returns "" on success, else why not.
  std::string createEGL() {
    EGLLib& l = eglLib();
    if (!l.handle) return l.error;
    const char* clientExt = l.queryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    auto getPlatformDisplay = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
        l.getProcAddress("eglGetPlatformDisplayEXT"));
    std::vector<std::pair<std::string, EGLDisplay>> candidates;
    if (getPlatformDisplay && hasExtension(clientExt, "EGL_MESA_platform_surfaceless"))
      candidates.push_back({"surfaceless", getPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA,
                                                              EGL_DEFAULT_DISPLAY, nullptr)});
    if (getPlatformDisplay && hasExtension(clientExt, "EGL_EXT_platform_device")) {
      auto queryDevices = reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(
          l.getProcAddress("eglQueryDevicesEXT"));
      EGLDeviceEXT devices[8];
      EGLint n = 0;
      if (queryDevices && queryDevices(8, devices, &n) && n > 0)
        candidates.push_back(
            {"device", getPlatformDisplay(EGL_PLATFORM_DEVICE_EXT, devices[0], nullptr)});
    }
    candidates.push_back({"default display", l.getDisplay(EGL_DEFAULT_DISPLAY)});
    std::string why;
    for (auto& [name, dpy] : candidates) {
      std::string w = tryDisplay(dpy);
      if (w.empty()) {
        description = "EGL " + name;
        return "";
      }
      why += (why.empty() ? "" : "; ") + name + ": " + w;
    }
    return why;
  }

  std::string tryDisplay(EGLDisplay dpy) {
    EGLLib& l = eglLib();
    if (dpy == EGL_NO_DISPLAY) return "no display";
    EGLint major = 0, minor = 0;
    if (!l.initialize(dpy, &major, &minor)) return "eglInitialize failed (" + hex(l.getError()) + ")";
    if (!l.bindAPI(EGL_OPENGL_API)) {
      l.terminate(dpy);
      return "desktop OpenGL not supported";
    }
    const EGLint cfgAttr[] = {EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_RENDERABLE_TYPE,
                              EGL_OPENGL_BIT, EGL_NONE};
    const EGLint cfgAttrAny[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
    EGLConfig cfg = nullptr;
    EGLint n = 0;
    bool pbuffer = l.chooseConfig(dpy, cfgAttr, &cfg, 1, &n) && n > 0;
    if (!pbuffer && !(l.chooseConfig(dpy, cfgAttrAny, &cfg, 1, &n) && n > 0)) {
      l.terminate(dpy);
      return "no OpenGL config";
    }
    const EGLint ctxAttr[] = {EGL_CONTEXT_MAJOR_VERSION, 3, EGL_CONTEXT_MINOR_VERSION, 3,
                              EGL_CONTEXT_OPENGL_PROFILE_MASK,
                              EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
    EGLContext ctx = l.createContext(dpy, cfg, EGL_NO_CONTEXT, ctxAttr);
    if (ctx == EGL_NO_CONTEXT) {
      l.terminate(dpy);
      return "no OpenGL 3.3 core context (" + hex(l.getError()) + ")";
    }
    EGLSurface surf = EGL_NO_SURFACE;
    const char* ext = l.queryString(dpy, EGL_EXTENSIONS);
    if (!hasExtension(ext, "EGL_KHR_surfaceless_context") && pbuffer) {
      const EGLint pb[] = {EGL_WIDTH, 1, EGL_HEIGHT, 1, EGL_NONE};
      surf = l.createPbufferSurface(dpy, cfg, pb);
    }
    if (!l.makeCurrent(dpy, surf, surf, ctx)) {
      if (surf != EGL_NO_SURFACE) l.destroySurface(dpy, surf);
      l.destroyContext(dpy, ctx);
      l.terminate(dpy);
      return "eglMakeCurrent failed (" + hex(l.getError()) + ")";
    }
    display = dpy;
    context = ctx;
    surface = surf;
    backend = Backend::EGL;
    return "";
  }

  std::string createOSMesa() {
    OSMesaLib& l = osmesaLib();
    if (!l.handle) return l.error;
    const int attr[] = {kOSMesaFormat, GL_RGBA, kOSMesaDepthBits, 24, kOSMesaProfile,
                        kOSMesaCoreProfile, kOSMesaMajor, 3, kOSMesaMinor, 3, 0};
    osmesa = l.createContextAttribs(attr, nullptr);
    if (!osmesa) return "no OpenGL 3.3 core context";
    osmesaBuffer.assign(4 * 4 * 4, 0);  // the default framebuffer; penumbra draws into FBOs
    if (!l.makeCurrent(osmesa, osmesaBuffer.data(), GL_UNSIGNED_BYTE, 4, 4)) {
      l.destroyContext(osmesa);
      osmesa = nullptr;
      return "OSMesaMakeCurrent failed";
    }
    backend = Backend::OSMesa;
    description = "OSMesa";
    return "";
  }

  void destroy() {
    if (backend == Backend::EGL && display != EGL_NO_DISPLAY) {
      EGLLib& l = eglLib();
      l.makeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
      if (surface != EGL_NO_SURFACE) l.destroySurface(display, surface);
      l.destroyContext(display, context);
      // The display is left initialized: EGL displays are per process and shared between
      // contexts; terminating it would pull it from under another HeadlessContext.
    } else if (backend == Backend::OSMesa && osmesa) {
      osmesaLib().destroyContext(osmesa);
    }
  }
};

HeadlessContext::HeadlessContext(Backend backend) : impl_(std::make_unique<Impl>()) {
  std::string eglWhy, osWhy;
  if (backend == Backend::EGL || backend == Backend::Auto) eglWhy = impl_->createEGL();
  bool ok = impl_->backend != Backend::Auto;
  if (!ok && (backend == Backend::OSMesa || backend == Backend::Auto)) {
    osWhy = impl_->createOSMesa();
    ok = impl_->backend != Backend::Auto;
  }
  if (!ok) {
    std::string msg = "no OpenGL context (--gl " + std::string(toString(backend)) + "):";
    if (backend != Backend::OSMesa) msg += " EGL: " + eglWhy + ";";
    if (backend != Backend::EGL) msg += " OSMesa: " + osWhy + ";";
    msg += " install libegl1 libegl-mesa0 libgl1-mesa-dri (EGL) or libosmesa6 (OSMesa)";
    throw Error(ErrorKind::NoPlatform, msg);
  }
  detail::GLFunctions f;
  f.load(loader());
  const char* version = reinterpret_cast<const char*>(f.GetString(GL_VERSION));
  const char* renderer = reinterpret_cast<const char*>(f.GetString(GL_RENDERER));
  impl_->description += std::string(", ") + (version ? version : "?") + ", " +
                        (renderer ? renderer : "?");
}

HeadlessContext::~HeadlessContext() { impl_->destroy(); }

void HeadlessContext::makeCurrent() {
  if (impl_->backend == Backend::EGL) {
    if (!eglLib().makeCurrent(impl_->display, impl_->surface, impl_->surface, impl_->context))
      throw Error(ErrorKind::Device, "eglMakeCurrent failed");
  } else if (!osmesaLib().makeCurrent(impl_->osmesa, impl_->osmesaBuffer.data(),
                                      GL_UNSIGNED_BYTE, 4, 4)) {
    throw Error(ErrorKind::Device, "OSMesaMakeCurrent failed");
  }
}

Backend HeadlessContext::backend() const { return impl_->backend; }
const std::string& HeadlessContext::description() const { return impl_->description; }
ProcLoader HeadlessContext::loader() const {
  return impl_->backend == Backend::EGL ? eglLoader : osmesaLoader;
}

ProcLoader currentContextLoader() {
  // Only libraries already loaded (by penumbra or the application) are asked.
  std::string eglFile = envOr(kEglLibrary[0], kEglLibrary[1]);
  if (void* h = dlopen(eglFile.c_str(), RTLD_NOW | RTLD_NOLOAD)) {
    dlclose(h);
    EGLLib& l = eglLib();
    if (l.handle && l.getCurrentContext() != EGL_NO_CONTEXT) return eglLoader;
  }
  std::string osFile = envOr(kOSMesaLibrary[0], kOSMesaLibrary[1]);
  if (void* h = dlopen(osFile.c_str(), RTLD_NOW | RTLD_NOLOAD)) {
    dlclose(h);
    OSMesaLib& l = osmesaLib();
    if (l.handle && l.getCurrentContext()) return osmesaLoader;
  }
  return nullptr;
}

namespace detail {

void GLFunctions::load(ProcLoader loader) {
  if (!loader) throw Error(ErrorKind::NoPlatform, "no current OpenGL context (EGL or OSMesa)");
#define PB_GL_LOAD(type, name)                                                              \
  name = reinterpret_cast<type>(loader("gl" #name));                                       \
  if (!name)                                                                                \
    throw Error(ErrorKind::NoPlatform, "OpenGL function gl" #name " is missing (OpenGL 3.3 " \
                                       "core needed)");
  PB_GL_FUNCTIONS(PB_GL_LOAD)
#undef PB_GL_LOAD
}

void GLFunctions::check(const std::string& what) const {
  GLenum e = GetError();
  if (e == GL_NO_ERROR) return;
  const char* name = e == GL_INVALID_ENUM        ? "GL_INVALID_ENUM"
                     : e == GL_INVALID_VALUE     ? "GL_INVALID_VALUE"
                     : e == GL_INVALID_OPERATION ? "GL_INVALID_OPERATION"
                     : e == GL_OUT_OF_MEMORY     ? "GL_OUT_OF_MEMORY"
                     : e == GL_INVALID_FRAMEBUFFER_OPERATION ? "GL_INVALID_FRAMEBUFFER_OPERATION"
                                                             : "GL error";
  while (GetError() != GL_NO_ERROR) {
  }
  throw Error(e == GL_OUT_OF_MEMORY ? ErrorKind::OutOfMemory : ErrorKind::Device,
              "OpenGL: " + what + " failed: " + name);
}

GLuint GLFunctions::program(const std::string& name, const std::string& vertex,
                            const std::string& fragment) const {
  auto compile = [&](GLenum type, const std::string& src) {
    GLuint s = CreateShader(type);
    const char* p = src.c_str();
    ShaderSource(s, 1, &p, nullptr);
    CompileShader(s);
    GLint ok = 0;
    GetShaderiv(s, GL_COMPILE_STATUS, &ok);
    if (!ok) {
      char log[4096] = {0};
      GetShaderInfoLog(s, sizeof log, nullptr, log);
      DeleteShader(s);
      throw Error(ErrorKind::KernelBuild, "GLSL " + name + " failed to compile: " + log);
    }
    return s;
  };
  GLuint vs = compile(GL_VERTEX_SHADER, vertex), fs = compile(GL_FRAGMENT_SHADER, fragment);
  GLuint p = CreateProgram();
  AttachShader(p, vs);
  AttachShader(p, fs);
  LinkProgram(p);
  DeleteShader(vs);
  DeleteShader(fs);
  GLint ok = 0;
  GetProgramiv(p, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[4096] = {0};
    GetProgramInfoLog(p, sizeof log, nullptr, log);
    DeleteProgram(p);
    throw Error(ErrorKind::KernelBuild, "GLSL " + name + " failed to link: " + log);
  }
  return p;
}

}  // namespace detail
}  // namespace penumbra::gl
