// The `penumbra._penumbra` extension: the public C++ API (include/penumbra/*.hpp) through
// pybind11. The package `penumbra` (penumbra/__init__.py) re-exports it; penumbra/__init__.pyi
// holds its type stubs, written by hand.
//
// Images cross as NumPy float32 arrays of shape (H, W, C). Going out, an array is a view of the
// C++ pixels, not a copy: Frame.image and Environment.equirect keep their owner alive as the
// array's base, and functions that return a fresh Image (read_image, the references) move it into
// a capsule that the array owns. Coming in, an array is copied once into an Image (the C++ API
// takes Image by const reference and owns its pixels). Paths are str or any os.PathLike.
// penumbra::Error surfaces as penumbra.Error or one of its subclasses, by kind, with the C++
// message unchanged but for the options fields it names, which it names as Python attributes
// (keywords). Option docstrings read their defaults from the C++ structs, and option objects
// print as `RenderOptions(width=640, ...)`, generated from their properties. The long calls
// release the GIL; the references check for Ctrl-C while they run. The low-level pieces that
// need raw OpenCL objects (scan.hpp's summedAreaTable, Context::kernel/launch) are not bound.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>


#include <cctype>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <sstream>
#include <string>
#include <type_traits>
#include <utility>

#include "penumbra/penumbra.hpp"

namespace fs = std::filesystem;
namespace py = pybind11;
using namespace pybind11::literals;
using namespace penumbra;

namespace {

using FloatArray = py::array_t<float, py::array::c_style | py::array::forcecast>;

// A view of img's pixels as (H, W, C) float32, kept alive by `owner`.
py::array imageView(const Image& img, py::handle owner) {
  const py::ssize_t h = img.height, w = img.width, c = img.channels;
  const py::ssize_t f = sizeof(float);
  return py::array_t<float>({h, w, c}, {w * c * f, c * f, f},
                            const_cast<float*>(img.pixels.data()), owner);
}

// Moves img into a capsule owned by the returned array: no pixel copy.
py::array imageToArray(Image&& img) {
  auto* owned = new Image(std::move(img));
  py::capsule base(owned, [](void* p) { delete static_cast<Image*>(p); });
  return imageView(*owned, base);
}

// One copy of a (H, W), (H, W, C) float array (any dtype NumPy can cast to float32) into an Image.
Image arrayToImage(const FloatArray& a, const char* what) {
  if (a.ndim() != 2 && a.ndim() != 3)
    badInput(std::string(what) + ": expected an array of shape (H, W) or (H, W, C), got " +
             std::to_string(a.ndim()) + " dimensions");
  const py::ssize_t h = a.shape(0), w = a.shape(1), c = a.ndim() == 3 ? a.shape(2) : 1;
  if (h < 1 || w < 1 || c < 1)
    badInput(std::string(what) + ": empty image (" + std::to_string(h) + "x" + std::to_string(w) +
             "x" + std::to_string(c) + ")");
  Image img{int(w), int(h), int(c)};
  std::memcpy(img.pixels.data(), a.data(), img.pixels.size() * sizeof(float));
  return img;
}

// (N, 3) float32 array from N 3-vectors picked out of each element.
template <class Seq, class Get>
py::array_t<float> rows3(const Seq& seq, Get get) {
  py::array_t<float> out({py::ssize_t(seq.size()), py::ssize_t(3)});
  auto r = out.mutable_unchecked<2>();
  for (std::size_t i = 0; i < seq.size(); ++i) {
    const auto& v = get(seq[i]);
    for (int k = 0; k < 3; ++k) r(i, k) = float(v[k]);
  }
  return out;
}

std::vector<Vec3> arrayToVec3(const FloatArray& a, const char* what) {
  if (a.ndim() != 2 || a.shape(1) != 3)
    badInput(std::string(what) + ": expected an array of shape (N, 3)");
  std::vector<Vec3> v(std::size_t(a.shape(0)));
  if (!v.empty()) std::memcpy(v.data(), a.data(), v.size() * sizeof(Vec3));
  return v;
}

py::dict timingsDict(const std::vector<std::pair<std::string, double>>& t) {
  py::dict d;
  for (const auto& [name, ms] : t) d[py::str(name)] = ms;
  return d;
}

ShadowTechnique toTechnique(const py::object& o) {
  if (py::isinstance<py::str>(o)) return parseShadowTechnique(o.cast<std::string>());
  return o.cast<ShadowTechnique>();
}
Prefilter toPrefilter(const py::object& o) {
  if (py::isinstance<py::str>(o)) return parsePrefilter(o.cast<std::string>());
  return o.cast<Prefilter>();
}
ExtractionMethod toMethod(const py::object& o) {
  if (py::isinstance<py::str>(o)) return parseExtractionMethod(o.cast<std::string>());
  return o.cast<ExtractionMethod>();
}

// Adds `__init__(**fields)` to an options class: a default-constructed struct with the named
// fields set as attributes (so each goes through its property's checks and conversions).
template <class T, class Cls>
void initFromFields(Cls& cls) {
  cls.def(py::init([](const py::kwargs& kw) {
            py::object obj = py::cast(T{});
            for (const auto& [key, value] : kw) {
              if (!py::hasattr(obj, key))
                throw py::type_error(std::string(py::str(py::type::handle_of(obj).attr("__name__"))) +
                                     ": unknown field '" + std::string(py::str(key)) + "'");
              py::setattr(obj, key, value);
            }
            return obj.cast<T>();
          }),
          "Default values, with any field given by keyword overridden.");
}

// A default as the docstrings print it: "<text> Default <value>." with 6 significant digits.
template <class T>
std::string withDefault(const std::string& text, T value) {
  std::ostringstream o;
  o << text << " Default ";
  if constexpr (std::is_same_v<T, bool>)
    o << (value ? "True" : "False");
  else
    o << value;
  o << ".";
  return o.str();
}
std::string bytesDefault(const std::string& text, std::size_t bytes) {
  return text + " Default " + std::to_string(bytes >> 20) + " MiB.";
}

// `exposure=None` means automatic (autoExposure, as the CLI does); a number must be finite and
// > 0. Returns what toneMap/writeImage take: 0 for automatic.
float exposureArg(const py::object& exposure, const char* function) {
  if (exposure.is_none()) return 0.0f;
  const double e = exposure.cast<double>();
  if (!(std::isfinite(e) && e > 0.0))
    badInput(std::string(function) + ": exposure must be a finite number > 0 (None: automatic), "
             "got " + std::string(py::str(exposure)));
  return float(e);
}

// toneMap's bytes as a uint8 (H, W, 3) array.
py::array_t<std::uint8_t> toneMapped(const Image& img, float exposure) {
  std::vector<unsigned char> px;
  {
    py::gil_scoped_release release;
    px = toneMap(img, exposure);
  }
  py::array_t<std::uint8_t> out({py::ssize_t(img.height), py::ssize_t(img.width), py::ssize_t(3)});
  std::memcpy(out.mutable_data(), px.data(), px.size());
  return out;
}

// The PNG file writeImage would write for `img` (8-bit RGB through toneMap), in memory.
py::bytes pngBytes(const Image& img, float exposure) {
  std::vector<unsigned char> png;
  {
    py::gil_scoped_release release;
    png = encodePng(img, exposure);
  }
  return py::bytes(reinterpret_cast<const char*>(png.data()), png.size());
}

// A value as the generated reprs print it: floats that are exactly a float32 with the fewest
// digits that give that float32 back (0.002, not 0.0020000000949949026), enums as
// `ShadowTechnique.MSSM4`, arrays and long lists or dicts summarized, the rest as repr().
std::string reprValue(const py::handle& v) {
  if (py::isinstance<py::bool_>(v)) return v.cast<bool>() ? "True" : "False";
  if (py::isinstance<py::float_>(v)) {
    const double d = v.cast<double>();
    if (!std::isfinite(d)) return std::string(py::repr(v));
    char buf[64];
    const float f = float(d);
    const auto r = double(f) == d ? std::to_chars(buf, buf + sizeof buf, f)
                                  : std::to_chars(buf, buf + sizeof buf, d);
    std::string s(buf, r.ptr);
    if (s.find_first_of(".e") == std::string::npos) s += ".0";  // still a float to Python
    return s;
  }
  if (py::isinstance<py::array>(v)) {
    const auto a = py::reinterpret_borrow<py::array>(v);
    std::string shape;
    for (py::ssize_t k = 0; k < a.ndim(); ++k)
      shape += (k ? ", " : "") + std::to_string(a.shape(k));
    if (a.ndim() == 1) shape += ",";
    return "<" + std::string(py::str(a.dtype())) + " array (" + shape + ")>";
  }
  if (py::hasattr(py::type::handle_of(v), "__members__") && py::hasattr(v, "name"))
    return std::string(py::str(v));  // a pybind11 enum
  constexpr std::size_t kLongest = 8;  // items shown of a list or dict
  if (py::isinstance<py::list>(v) || py::isinstance<py::tuple>(v)) {
    const auto seq = py::reinterpret_borrow<py::sequence>(v);
    const bool list = py::isinstance<py::list>(v);
    if (seq.size() > kLongest) return "<list of " + std::to_string(seq.size()) + ">";
    std::string s = list ? "[" : "(";
    for (std::size_t i = 0; i < seq.size(); ++i) s += (i ? ", " : "") + reprValue(seq[i]);
    return s + (list ? "]" : seq.size() == 1 ? ",)" : ")");
  }
  if (py::isinstance<py::dict>(v)) {
    const auto d = py::reinterpret_borrow<py::dict>(v);
    if (d.size() > kLongest) return "<dict of " + std::to_string(d.size()) + ">";
    std::string s = "{";
    bool first = true;
    for (const auto& [key, value] : d) {
      s += (first ? "" : ", ") + std::string(py::repr(key)) + ": " + reprValue(value);
      first = false;
    }
    return s + "}";
  }
  return std::string(py::repr(v));
}

// `Name(field=value, ...)` from the instance properties of self's class, in definition order.
std::string propertyRepr(const py::handle& self) {
  const py::handle type = py::type::handle_of(self);
  const py::handle property(reinterpret_cast<PyObject*>(&PyProperty_Type));
  std::string s = std::string(py::str(type.attr("__name__"))) + "(";
  bool first = true;
  for (const auto& [key, value] : py::reinterpret_borrow<py::dict>(
           py::module_::import("builtins").attr("dict")(type.attr("__dict__")))) {
    const std::string name = py::str(key);
    if (name.empty() || name[0] == '_' || !py::isinstance(value, property)) continue;
    s += (first ? "" : ", ") + name + "=" + reprValue(self.attr(key));
    first = false;
  }
  return s + ")";
}

template <class Cls>
void addRepr(Cls& cls) {
  cls.def("__repr__", [](const py::object& self) { return propertyRepr(self); });
}

// The reference's progress callback: runs on the calling thread while the GIL is released, so it
// takes the GIL, raises a pending Ctrl-C (PyErr_CheckSignals runs Python's SIGINT handler, which
// raises KeyboardInterrupt) and then calls the user's callable with the fraction done, when it has
// grown (the library may report on a timer, the same fraction again). An exception from either
// leaves as py::error_already_set, which stops the reference (its documented contract: progress
// may throw) and reaches Python unchanged. The state lives on the binding's stack for the call and
// is held by pointer: the library may copy the std::function without the GIL.
struct PythonProgress {
  py::object callback;  // None or a callable taking the fraction
  double last = -1.0;   // the fraction it was last given
};
std::function<void(double)> progressWithInterrupts(PythonProgress* state) {
  if (!state->callback.is_none() && !PyCallable_Check(state->callback.ptr())) {
    const std::string type = py::str(py::type::handle_of(state->callback).attr("__name__"));
    throw py::type_error("progress must be a callable taking the fraction done, or None; got " +
                         type);
  }
  return [state](double fraction) {
    py::gil_scoped_acquire gil;
    if (PyErr_CheckSignals() != 0) throw py::error_already_set();
    if (!state->callback.is_none() && fraction > state->last) {
      state->last = fraction;
      state->callback(fraction);
    }
  };
}

// The library names an options field as in C++ ("RenderOptions.areaApprox.edgeSamples",
// "MedianCutOptions.faceSize", "ExtractOptions::lightTexture"); Python users set it as an
// attribute or keyword: snake case ("RenderOptions.area_approx.edge_samples"), RenderOptions'
// `shadows` is `technique`, and LoadOptions' fields are load_scene's keywords ("timeout_seconds").
std::string pythonFieldNames(const std::string& message) {
  static const std::pair<const char*, const char*> kHeads[] = {
      {"RenderOptions.", "RenderOptions."},
      {"MedianCutOptions.", "MedianCutOptions."},
      {"GreedyOptions.", "GreedyOptions."},
      {"CenterSurroundOptions.", "CenterSurroundOptions."},
      {"ReferenceOptions.", "ReferenceOptions."},
      {"ExtractOptions.", "ExtractOptions."},
      {"ExtractOptions::", "ExtractOptions."},
      {"AmbientOptions.", "AmbientOptions."},
      {"LoadOptions::", ""},
      {"LoadOptions.", ""}};
  std::string out;
  std::size_t i = 0;
  for (;;) {
    std::size_t at = std::string::npos;
    std::string head, shown;
    for (const auto& [h, as] : kHeads) {
      const std::size_t k = message.find(h, i);
      if (k < at) {
        at = k;
        head = h;
        shown = as;
      }
    }
    if (at == std::string::npos) break;
    out += message.substr(i, at - i) + shown;
    std::size_t end = at + head.size();
    std::string name;
    for (; end < message.size(); ++end) {
      const char c = message[end];
      if (c == '.' && end + 1 < message.size() &&
          std::isalpha(static_cast<unsigned char>(message[end + 1]))) {
        name += '.';
      } else if (std::isupper(static_cast<unsigned char>(c))) {
        name += '_';
        name += char(std::tolower(static_cast<unsigned char>(c)));
      } else if (std::isalnum(static_cast<unsigned char>(c))) {
        name += c;
      } else {
        break;
      }
    }
    out += head == "RenderOptions." && name == "shadows" ? "technique" : name;
    i = end;
  }
  return out + message.substr(i);
}

// A Python sequence index into the set's lights: negative counts from the end; IndexError outside.
std::size_t lightIndex(const LightSet& s, py::ssize_t i) {
  const py::ssize_t n = py::ssize_t(s.lights.size());
  if (i < -n || i >= n)
    throw py::index_error("LightSet index " + std::to_string(i) + " out of range (" +
                          std::to_string(n) + " lights)");
  return std::size_t(i < 0 ? i + n : i);
}

// The exception classes, set when the module is initialised.
struct Exceptions {
  py::object base, badInput, noPlatform, kernelBuild, outOfMemory, device, internal, cancelled;
} exceptions;

py::object makeException(py::module_& m, const char* name, py::tuple bases, const char* doc) {
  py::dict ns;
  ns["__doc__"] = doc;
  ns["__module__"] = "penumbra";
  py::object cls = py::reinterpret_borrow<py::object>(reinterpret_cast<PyObject*>(&PyType_Type))(
      name, bases, ns);
  m.attr(name) = cls;
  return cls;
}

}  // namespace

PYBIND11_MODULE(_penumbra, m) {
  m.doc() =
      "penumbra: soft shadows from area lights and HDR environment maps, computed by OpenCL "
      "kernels (PoCL on the CPU or a GPU driver), with an Embree path tracer as ground truth.\n\n"
      "Images are NumPy float32 arrays of shape (H, W, C), linear radiance, row 0 at the top.\n"
      "Typical use:\n\n"
      "    ctx = penumbra.Context()\n"
      "    scene = penumbra.builtin_scene()\n"
      "    env = penumbra.builtin_environment()\n"
      "    cam = penumbra.frame_camera(scene, 16 / 9)\n"
      "    lights = penumbra.extract_lights(ctx, env, lights=32)\n"
      "    frame = penumbra.Renderer(ctx).render(scene, cam, lights, env,\n"
      "                                          penumbra.RenderOptions(width=320, height=180))\n"
      "    penumbra.write_image('frame.exr', frame.image)\n"
      "    shown = penumbra.tonemap(frame.image)  # uint8 (H, W, 3), for plt.imshow\n\n"
      "Paths are str or os.PathLike. A LightSet is a sequence of AreaLight; option objects take "
      "their fields as keywords and print them. Errors name the keyword or attribute at fault. "
      "The references take progress= and stop on Ctrl-C.\n\n"
      "Threads: a Context and a Renderer may be shared by threads (see their docstrings); the "
      "long calls (loading, extraction, rendering, the references, waiting for the device) "
      "release the GIL, so threads run them at once. Objects passed to a call are used without "
      "the GIL: do not modify them from another thread until it returns (add_ambient_residual "
      "writes its light set: not the same one on two threads at once).\n";
  m.attr("__version__") = PENUMBRA_VERSION;

  // ---- errors -----------------------------------------------------------------------------
  exceptions.base = makeException(
      m, "Error", py::make_tuple(py::handle(PyExc_RuntimeError)),
      "Base of every error penumbra raises (C++ penumbra::Error); the message names the file, "
      "parameter or value at fault. Subclasses tell the kind.");
  exceptions.badInput = makeException(
      m, "BadInput", py::make_tuple(exceptions.base, py::handle(PyExc_ValueError)),
      "A file, parameter or value given is unusable (missing or corrupt file, impossible size, "
      "bad option). Also a ValueError.");
  exceptions.noPlatform = makeException(
      m, "NoPlatform", py::make_tuple(exceptions.base),
      "No OpenCL platform or device could be found or matched (the message names the package "
      "to install or the selector).");
  exceptions.kernelBuild = makeException(
      m, "KernelBuild", py::make_tuple(exceptions.base),
      "An embedded OpenCL kernel failed to compile; the message carries the build log.");
  exceptions.outOfMemory = makeException(
      m, "OutOfMemory", py::make_tuple(exceptions.base, py::handle(PyExc_MemoryError)),
      "The OpenCL device could not allocate a buffer. Also a MemoryError.");
  exceptions.device = makeException(m, "DeviceError", py::make_tuple(exceptions.base),
                                    "Any other OpenCL failure.");
  exceptions.internal = makeException(m, "InternalError", py::make_tuple(exceptions.base),
                                      "A bug in penumbra.");
  exceptions.cancelled = makeException(
      m, "Cancelled", py::make_tuple(exceptions.base),
      "A long call stopped on request (the C++ API's ReferenceOptions::cancel).");
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const Error& e) {
      py::object cls;
      switch (e.kind()) {
        case ErrorKind::BadInput: cls = exceptions.badInput; break;
        case ErrorKind::NoPlatform: cls = exceptions.noPlatform; break;
        case ErrorKind::KernelBuild: cls = exceptions.kernelBuild; break;
        case ErrorKind::OutOfMemory: cls = exceptions.outOfMemory; break;
        case ErrorKind::Device: cls = exceptions.device; break;
        case ErrorKind::Internal: cls = exceptions.internal; break;
        case ErrorKind::Cancelled: cls = exceptions.cancelled; break;
      }
      if (!cls) cls = exceptions.base;  // a kind added to the library later
      PyErr_SetString(cls.ptr(), pythonFieldNames(e.what()).c_str());
    } catch (const cl::Error& e) {
      // The library converts OpenCL errors itself; this is a safety net.
      PyErr_SetString(exceptions.device.ptr(),
                      (std::string(e.what()) + ": " + clErrorName(e.err())).c_str());
    }
  });

  // ---- context ----------------------------------------------------------------------------
  py::class_<DeviceInfo>(m, "DeviceInfo", "An OpenCL device as `penumbra devices` lists it.")
      .def_readonly("index", &DeviceInfo::index, "Position in list_devices().")
      .def_readonly("platform", &DeviceInfo::platform, "OpenCL platform name.")
      .def_readonly("name", &DeviceInfo::name, "Device name.")
      .def_readonly("version", &DeviceInfo::version, "OpenCL C version the device compiles.")
      .def_readonly("global_mem_bytes", &DeviceInfo::globalMemBytes, "Global memory, bytes.")
      .def_readonly("max_work_group_size", &DeviceInfo::maxWorkGroupSize,
                    "Largest work-group size.")
      .def_readonly("fp64", &DeviceInfo::fp64, "Whether the device has double precision.")
      .def_readonly("int64_atomics", &DeviceInfo::int64Atomics,
                    "Whether the device has 64-bit integer atomics.")
      .def("__repr__", [](const DeviceInfo& d) {
        return "<penumbra.DeviceInfo " + std::to_string(d.index) + ": " + d.name + " (" +
               d.platform + ")>";
      });
  m.def("list_devices", &listDevices,
        "All OpenCL devices on all platforms, in a stable order. Raises NoPlatform if there is "
        "none.");

  py::class_<Context>(m, "Context",
                      "An OpenCL device with its queue and kernel cache. Create one and pass it "
                      "to extraction, Renderer and cube_map_energy; it must outlive them (Renderer "
                      "keeps it alive).\n\n"
                      "Thread safety: one Context may be shared by any number of threads; every "
                      "function taking it (extraction, cube_map_energy, add_ambient_residual, "
                      "Renderers) may run on several threads at once with the same Context and "
                      "gives what it gives alone. Their device work runs one command at a time "
                      "on the Context's queue. Stage times are the Context's: they sum every "
                      "thread's work, and reset_timings() clears them for all.")
      .def(py::init<const std::string&>(), "device"_a = "",
           "device: '' uses $PENUMBRA_DEVICE if set, else device 0; otherwise an index into "
           "list_devices() (as a string) or a case-insensitive part of the device or platform "
           "name. Raises NoPlatform when nothing matches.")
      .def(py::init([](int index) { return new Context(std::to_string(index)); }), "device"_a,
           "Device by its index in list_devices().")
      .def_property_readonly("info", &Context::info, py::return_value_policy::copy,
                             "The chosen device (DeviceInfo).")
      .def("stage_times_ms",
           [](Context& c) {
             std::vector<std::pair<std::string, double>> t;
             {
               py::gil_scoped_release release;  // waits for the queue
               t = c.stageTimesMs();
             }
             return timingsDict(t);
           },
           "Device milliseconds per named kernel stage since the last reset_timings(), as a "
           "dict in first-launch order. Waits for the queue.")
      .def("reset_timings", &Context::resetTimings, py::call_guard<py::gil_scoped_release>(),
           "Clears the accumulated stage times (every thread's).")
      .def("finish", &Context::finish, py::call_guard<py::gil_scoped_release>(),
           "Waits until every queued command has completed (every thread's).")
      .def("__repr__", [](const Context& c) { return "<penumbra.Context " + c.info().name + ">"; });

  // ---- images -----------------------------------------------------------------------------
  m.def(
      "read_image",
      [](const fs::path& path) {
        Image img;
        {
          py::gil_scoped_release release;
          img = readImage(path.string());
        }
        return imageToArray(std::move(img));
      },
      "path"_a,
      "Reads any image OpenImageIO understands (EXR, HDR, PFM, PNG, ...) as a float32 array of "
      "shape (H, W, C). `path`: str or os.PathLike. Raises BadInput naming the file when it is "
      "missing, unreadable, truncated or empty.");
  m.def(
      "write_image",
      [](const fs::path& path, const FloatArray& image, const py::object& exposureOrNone,
         const py::object& metadata) {
        Image img = arrayToImage(image, "write_image");
        const float exposure = exposureArg(exposureOrNone, "write_image");
        ImageAttributes numbers;
        ImageText text{{"penumbra:version", PENUMBRA_VERSION}, {"penumbra:command", "python"}};
        if (!metadata.is_none())
          for (const auto& [key, value] : metadata.cast<py::dict>()) {
            const std::string name = py::str(key);
            if (py::isinstance<py::str>(value))
              text[name] = value.cast<std::string>();
            else if (py::isinstance<py::int_>(value) || py::isinstance<py::float_>(value))
              numbers[name] = value.cast<double>();
            else
              badInput("write_image: metadata['" + name + "'] must be a str or a number, got " +
                       std::string(py::str(py::type::handle_of(value).attr("__name__"))));
          }
        py::gil_scoped_release release;
        writeImage(path.string(), img, exposure, numbers, text);
      },
      "path"_a, "image"_a, "exposure"_a = py::none(), "metadata"_a = py::none(),
      "Writes a (H, W) or (H, W, C) array in the format of path's extension (str or "
      "os.PathLike): float formats (.exr, .hdr, .pfm) get the linear pixels (.exr all "
      "channels); any other format OpenImageIO writes (.png, .jpg, .tif, ...) gets "
      "tonemap(image, exposure) (alpha dropped). exposure None (the default) is automatic, "
      "auto_exposure(image), as `penumbra render` does. The header records "
      "'penumbra:version' and 'penumbra:command' ('python') plus `metadata` ({name: str or "
      "number}) where the format has room (EXR, TIFF; PNG keeps text). Written to a temporary "
      "file and renamed, so a failure leaves no half-written file. Raises BadInput on an "
      "extension without a writer, an unwritable path or an exposure <= 0.");
  m.def(
      "tonemap",
      [](const FloatArray& image, const py::object& exposure) {
        return toneMapped(arrayToImage(image, "tonemap"), exposureArg(exposure, "tonemap"));
      },
      "image"_a, "exposure"_a = py::none(),
      "The display image write_image puts in a PNG, as uint8 (H, W, 3): each channel times "
      "`exposure` (None: auto_exposure(image), the CLI's rule), then x / (1 + x) (Reinhard et "
      "al. 2002) and the sRGB transfer function. One- and two-channel images are grey; alpha is "
      "dropped. For plt.imshow and notebooks.");
  m.def(
      "auto_exposure", [](const FloatArray& image) { return autoExposure(arrayToImage(image, "auto_exposure")); },
      "image"_a,
      "Exposure mapping the log-average luminance (of the alpha > 0.5 pixels if any) to 0.25: "
      "what tonemap and write_image use when exposure is None.");

  // ---- environment ------------------------------------------------------------------------
  py::class_<Environment>(m, "Environment",
                          "An HDR environment map (equirectangular, RGB linear radiance, y up).")
      .def(py::init<>(), "An empty map; set .equirect to fill it.")
      .def_readwrite("source", &Environment::source, "File path or 'builtin'.")
      .def_property(
          "equirect", [](py::object self) { return imageView(self.cast<Environment&>().equirect, self); },
          [](Environment& e, const FloatArray& a) { e.equirect = arrayToImage(a, "equirect"); },
          "The map as a float32 (H, W, 3) array. Reading gives a view of the map's pixels (no "
          "copy; writes to it change the map); assigning copies the array in.")
      .def_readonly("sanitized_pixels", &Environment::sanitizedPixels,
                    "Pixels whose NaN/Inf/negative values were replaced with 0 when loading.")
      .def_readonly("non_finite_values", &Environment::nonFiniteValues,
                    "Channel values that were NaN or Inf (set to 0).")
      .def_readonly("negative_values", &Environment::negativeValues,
                    "Channel values below 0 (clamped to 0).")
      .def_readwrite("rotation_y_deg", &Environment::rotationYDeg,
                     "Rotation of the map about +y in degrees (counter-clockwise seen from above); "
                     "honoured by lookup, irradiance, extraction, rendering and the reference.")
      .def_property_readonly("width", [](const Environment& e) { return e.equirect.width; },
                             "Map width in texels.")
      .def_property_readonly("height", [](const Environment& e) { return e.equirect.height; },
                             "Map height in texels.")
      .def(
          "lookup",
          [](const Environment& e, const Vec3& d) {
            float rgb[3];
            e.lookup(d[0], d[1], d[2], rgb);
            return std::array<float, 3>{rgb[0], rgb[1], rgb[2]};
          },
          "direction"_a, "Radiance (r, g, b) along a world direction (nearest texel).")
      .def(
          "power",
          [](const Environment& e) {
            std::array<double, 3> p;
            e.power(p.data());
            return p;
          },
          "Integral of radiance over the sphere, per channel.")
      .def(
          "irradiance",
          [](const Environment& e, const Vec3& n) {
            std::array<double, 3> p;
            e.irradiance(n.data(), p.data());
            return p;
          },
          "normal"_a, "Irradiance (r, g, b) on a surface with the given unit normal.")
      .def("with_rotation_applied", &Environment::withRotationApplied,
           "A copy whose pixels are the rotated map and whose rotation_y_deg is 0.")
      .def("__repr__", [](const Environment& e) {
        return "<penumbra.Environment '" + e.source + "' " + std::to_string(e.equirect.width) +
               "x" + std::to_string(e.equirect.height) + ">";
      });
  m.def("load_environment", [](const fs::path& path) { return loadEnvironment(path.string()); },
        "path"_a, py::call_guard<py::gil_scoped_release>(),
        "Loads and sanitizes an EXR, Radiance HDR or PFM map (path: str or os.PathLike). Raises "
        "BadInput naming the file for unreadable, truncated, non-image or empty input.");
  m.def("builtin_environment", &builtinEnvironment, "width"_a = 512,
        "A procedural sky (sun, gradient, bright horizon patch, dark ground), width x width/2.");
  m.def("environment_from", [](const fs::path& path) { return environmentFrom(path.string()); },
        "path_or_builtin"_a, py::call_guard<py::gil_scoped_release>(),
        "'builtin' -> builtin_environment(), anything else (str or os.PathLike) -> "
        "load_environment(path).");
  m.def(
      "cube_map_energy",
      [](Context& ctx, const Environment& env, int faceSize, int supersample) {
        Image img;
        {
          py::gil_scoped_release release;
          img = cubeMapEnergy(ctx, env, faceSize, supersample);
        }
        return imageToArray(std::move(img));
      },
      "ctx"_a, "env"_a, "face_size"_a, "supersample"_a = 4,
      "The map resampled on the device to a cube map of radiant energy per texel, float32 "
      "(6*face_size, face_size, 3): faces stacked vertically. Raises BadInput for face_size "
      "outside [1, 4096].");

  // ---- scene ------------------------------------------------------------------------------
  py::class_<Mesh>(m, "Mesh", "A triangle mesh with a diffuse albedo.")
      .def(py::init<>())
      .def_readwrite("name", &Mesh::name, "Mesh name.")
      .def_property(
          "positions", [](const Mesh& me) { return rows3(me.positions, [](const Vec3& v) { return v; }); },
          [](Mesh& me, const FloatArray& a) { me.positions = arrayToVec3(a, "positions"); },
          "Vertex positions, float32 (N, 3) (a copy; assign to change).")
      .def_property(
          "normals", [](const Mesh& me) { return rows3(me.normals, [](const Vec3& v) { return v; }); },
          [](Mesh& me, const FloatArray& a) { me.normals = arrayToVec3(a, "normals"); },
          "Unit vertex normals, float32 (N, 3), or (0, 3) for flat shading (a copy).")
      .def_property(
          "triangles",
          [](const Mesh& me) {
            py::array_t<int> out({py::ssize_t(me.triangles.size()), py::ssize_t(3)});
            if (!me.triangles.empty())
              std::memcpy(out.mutable_data(), me.triangles.data(), me.triangles.size() * 12);
            return out;
          },
          [](Mesh& me, const py::array_t<int, py::array::c_style | py::array::forcecast>& a) {
            if (a.ndim() != 2 || a.shape(1) != 3) badInput("triangles: expected shape (N, 3)");
            me.triangles.resize(std::size_t(a.shape(0)));
            if (!me.triangles.empty())
              std::memcpy(me.triangles.data(), a.data(), me.triangles.size() * 12);
          },
          "Vertex indices, int32 (T, 3) (a copy; assign to change).")
      .def_readwrite("albedo", &Mesh::albedo, "Diffuse reflectance (r, g, b) in [0, 1].")
      .def("__repr__", [](const py::object& self) { return propertyRepr(self); });

  py::class_<Bounds>(m, "Bounds", "Axis-aligned bounding box.")
      .def_readwrite("lo", &Bounds::lo, "Lower corner.")
      .def_readwrite("hi", &Bounds::hi, "Upper corner.")
      .def("center", &Bounds::center, "Centre of the box.")
      .def("radius", &Bounds::radius, "Half the diagonal.")
      .def("__repr__", [](const py::object& self) { return propertyRepr(self); });

  py::class_<Camera> camera(m, "Camera", "A pinhole camera.");
  initFromFields<Camera>(camera);
  addRepr(camera);
  camera.def_readwrite("eye", &Camera::eye, "Position (x, y, z).")
      .def_readwrite("target", &Camera::target, "Point looked at.")
      .def_readwrite("up", &Camera::up, "Up direction.")
      .def_readwrite("fovy_deg", &Camera::fovyDeg, "Vertical field of view, degrees.");

  py::class_<Scene>(m, "Scene", "Triangle meshes with diffuse albedos (metres, y up).")
      .def(py::init<>())
      .def_readwrite("meshes", &Scene::meshes,
                     "The meshes, as a list of copies; assign a list to change them.")
      .def("bounds", &Scene::bounds, "Bounding box of every mesh.")
      .def("triangle_count", &Scene::triangleCount, "Triangles in all meshes.")
      .def("__repr__", [](const Scene& s) {
        return "<penumbra.Scene " + std::to_string(s.meshes.size()) + " meshes, " +
               std::to_string(s.triangleCount()) + " triangles>";
      });
  m.def("builtin_scene", &builtinScene, "time"_a = 0.0f,
        "The default scene (ground, box, sphere, floating slab, torus, lattice) at `time` "
        "seconds: the sphere bounces and the slab turns. Raises BadInput for a non-finite time.");
  // LoadOptions from keywords: the importer's limits (0: automatic, as in C++).
  const auto loadOptions = [](bool addGround, double timeoutSeconds, std::size_t memoryLimitBytes) {
    LoadOptions o;
    o.addGround = addGround;
    o.timeoutSeconds = timeoutSeconds;
    o.memoryLimitBytes = memoryLimitBytes;
    return o;
  };
  m.def(
      "load_scene",
      [loadOptions](const fs::path& path, bool addGround, double timeout, std::size_t memory) {
        return loadScene(path.string(), loadOptions(addGround, timeout, memory));
      },
      "path"_a, "add_ground"_a = true, "timeout_seconds"_a = 0.0, "memory_limit_bytes"_a = 0,
      py::call_guard<py::gil_scoped_release>(),
      "Loads a mesh file (str or os.PathLike) through Assimp (OBJ, PLY, glTF/GLB, ...), with a "
      "ground plane under it "
      "unless add_ground is False. PLY/glTF/GLB sizes are checked against the file first, then "
      "Assimp runs in a child process limited to timeout_seconds and memory_limit_bytes (0: "
      "automatic, 20 s + 1 s per MB and 1 GiB + 64x the file), so a malformed file cannot crash "
      "or hang Python. Raises BadInput naming the file: unreadable, no triangles, non-finite "
      "vertices, indices out of range, sizes beyond the file, a crash or a limit passed.");
  m.def(
      "scene_from",
      [loadOptions](const fs::path& path, bool addGround, double timeout, std::size_t memory) {
        return sceneFrom(path.string(), loadOptions(addGround, timeout, memory));
      },
      "path_or_builtin"_a, "add_ground"_a = true, "timeout_seconds"_a = 0.0,
      "memory_limit_bytes"_a = 0, py::call_guard<py::gil_scoped_release>(),
      "'builtin' -> builtin_scene(), else (str or os.PathLike) load_scene(path, ...).");
  m.def("validate_scene", &validateScene, "scene"_a,
        "Raises BadInput naming the mesh and element for what Renderer.render would refuse: a "
        "triangle index out of range, non-finite positions, bad normals, albedo outside [0, 1].");
  m.def("frame_camera", &frameCamera, "scene"_a, "aspect"_a,
        "A camera looking at the scene from above and to the side, fitting its bounds for the "
        "aspect ratio width / height.");
  m.def("parse_camera", &parseCamera, "text"_a,
        "Parses 'ex,ey,ez,tx,ty,tz[,fovy]'. Raises BadInput on malformed text.");

  // ---- lights -----------------------------------------------------------------------------
  py::enum_<LightShape>(m, "LightShape", "A light's shape on the sphere of directions.")
      .value("CAP", LightShape::Cap, "A uniform spherical cap (a disc or sphere seen from afar).")
      .value("POLYGON", LightShape::Polygon,
             "A convex spherical polygon (rectangles, cube-face regions, user polygons).");

  py::class_<LightTexture> texture(m, "LightTexture",
                                   "Radiance over a light's tangent-plane square [-1, 1]^2: texel "
                                   "(i, j) covers x in [-1 + 2i/w, -1 + 2(i+1)/w], y from the top "
                                   "row down; nearest texel. Give it to set_light_texture.");
  initFromFields<LightTexture>(texture);
  addRepr(texture);
  texture.def_readwrite("width", &LightTexture::width, "Texels across (0: no texture).")
      .def_readwrite("height", &LightTexture::height, "Texels down.")
      .def_readwrite("radiance", &LightTexture::radiance,
                     "RGB radiance, row-major from the top row, 3 * width * height floats >= 0.")
      .def("empty", &LightTexture::empty, "True without a texture.");

  py::class_<LightSample>(m, "LightSample", "A light sample: direction and weight.")
      .def_readonly("dir", &LightSample::dir, "Unit direction towards the sample.")
      .def_readonly("weight", &LightSample::weight,
                    "Weight in [0, 1]: the sample's share of radiance x solid angle, up to a "
                    "common factor.")
      .def("__repr__", [](const py::object& self) { return propertyRepr(self); });

  py::class_<AreaLight> light(m, "AreaLight",
                              "A directional area light: a uniform spherical cap of half-angle "
                              "alpha around `direction` with radiance L; power M = L * solid "
                              "angle (Kneiphof 2017 §4.1.3).");
  initFromFields<AreaLight>(light);
  addRepr(light);
  light.def_readwrite("shape", &AreaLight::shape, "LightShape.CAP or LightShape.POLYGON.")
      .def_readwrite("vertices", &AreaLight::vertices,
                     "Polygon lights: unit vertex directions, counter-clockwise seen from the "
                     "origin (empty for caps). Build polygons with make_polygon_light.")
      .def_readwrite("direction", &AreaLight::direction, "Unit vector towards the light.")
      .def_readwrite("cos_alpha", &AreaLight::cosAlpha, "Cosine of the cap's half-angle.")
      .def_readwrite("radiance", &AreaLight::radiance, "Uniform RGB radiance inside the cap.")
      .def_readwrite("power", &AreaLight::power, "RGB power M = radiance * solid angle.")
      .def_readwrite("regions", &AreaLight::regions,
                     "Cube-face regions it came from: [face, x0, y0, x1, y1] each.")
      .def("half_angle", &AreaLight::halfAngle, "Half-angle of the cap, radians.")
      .def("solid_angle", &AreaLight::solidAngle, "2 pi (1 - cos alpha), steradians.")
      .def("irradiance", &AreaLight::irradiance, "normal"_a,
           "Unshadowed irradiance on a unit normal (cap clipped by the horizon).")
      .def_readwrite("outline", &AreaLight::outline,
                     "What a polygon light stands for: LightOutline.VERTICES, RECT or ELLIPSE.")
      .def_readwrite("axis_u", &AreaLight::axisU,
                     "Tangent frame's right axis (rects, ellipses, textured caps; else zero).")
      .def_readwrite("tan_half", &AreaLight::tanHalf,
                     "Tangents of the frame's half-angles along axis_u and axis_v.")
      .def_readonly("texture", &AreaLight::texture,
                    "The radiance texture (empty: uniform); set it with set_light_texture.")
      .def("axis_v", &AreaLight::axisV, "direction x axis_u: the frame's up.")
      .def("frame_coords", &AreaLight::frameCoords, "d"_a,
           "Frame coordinates (x, y) of a direction: the light spans [-1, 1]^2 (rect) or the "
           "unit disk (cap, ellipse).")
      .def("radiance_at", &AreaLight::radianceAt, "d"_a,
           "The texture's RGB radiance towards d (the uniform radiance without a texture).")
      .def("sample_weight", &AreaLight::sampleWeight, "d"_a,
           "Texture luminance towards d over the largest texel's, in [0, 1]; 1 untextured.");
  py::enum_<AreaLight::Outline>(light, "Outline", "What a polygon light stands for.")
      .value("VERTICES", AreaLight::Outline::Vertices, "Plain vertices.")
      .value("RECT", AreaLight::Outline::Rect, "A rect (make_rect_light).")
      .value("ELLIPSE", AreaLight::Outline::Ellipse,
             "An ellipse (make_ellipse_light): its vertices are the shading polygon; the "
             "bitmask, brute-force and reference techniques sample the ellipse itself.");
  m.attr("LightOutline") = light.attr("Outline");

  py::class_<LightSet>(m, "LightSet",
                       "Area lights extracted from a map plus an unshadowed ambient residual "
                       "(9 spherical-harmonic coefficients, RGB).")
      .def(py::init<>(), "An empty set (method 'user'); fill .lights yourself.")
      .def_readwrite("lights", &LightSet::lights,
                     "The lights, as a list of AreaLight copies; assign a list to change them.")
      .def_readwrite("face_size", &LightSet::faceSize, "Cube face size used for extraction.")
      .def_readwrite("method", &LightSet::method,
                     "'median-cut', 'greedy', 'center-surround' or 'user'.")
      .def_readwrite("has_ambient", &LightSet::hasAmbient, "Whether ambient_sh is used.")
      .def_property(
          "ambient_sh",
          [](const LightSet& s) {
            py::array_t<float> out({py::ssize_t(9), py::ssize_t(3)});
            std::memcpy(out.mutable_data(), s.ambientSH.data(), sizeof(s.ambientSH));
            return out;
          },
          [](LightSet& s, const FloatArray& a) {
            if (a.ndim() != 2 || a.shape(0) != 9 || a.shape(1) != 3)
              badInput("ambient_sh: expected shape (9, 3)");
            std::memcpy(s.ambientSH.data(), a.data(), sizeof(s.ambientSH));
          },
          "Ambient residual, float32 (9, 3): SH coefficients (l,m) = (0,0) (1,-1) (1,0) (1,1) "
          "(2,-2) (2,-1) (2,0) (2,1) (2,2) by RGB (a copy; assign to change).")
      .def_property(
          "ambient_map",
          [](const LightSet& s) {
            const AmbientMap& a = s.ambientMap;
            py::array_t<float> out({py::ssize_t(a.empty() ? 0 : a.height),
                                    py::ssize_t(a.empty() ? 0 : a.width), py::ssize_t(3)});
            if (!a.empty()) std::memcpy(out.mutable_data(), a.rgb.data(), a.rgb.size() * 4);
            return out;
          },
          [](LightSet& s, const FloatArray& a) {
            if (a.ndim() != 3 || a.shape(2) != 3 || a.shape(0) > 1024 || a.shape(1) > 1024)
              badInput("ambient_map: expected shape (H, W, 3) with H, W <= 1024");
            AmbientMap m;
            if (a.shape(0) > 0 && a.shape(1) > 0) {
              m.height = int(a.shape(0));
              m.width = int(a.shape(1));
              m.rgb.assign(a.data(), a.data() + a.size());
              for (float v : m.rgb)
                if (!std::isfinite(v)) badInput("ambient_map: non-finite value");
            }
            s.ambientMap = std::move(m);
          },
          "The ambient residual's pre-integrated irradiance map, float32 (H, W, 3): row 0 is "
          "the +y pole, row H-1 the -y pole, columns as the equirect map's (a copy; assign to "
          "change; an empty (0, 0, 3) array means SH9 shading from ambient_sh).")
      .def_property_readonly(
          "directions", [](const LightSet& s) { return rows3(s.lights, [](const AreaLight& l) { return l.direction; }); },
          "Light directions, float32 (N, 3).")
      .def_property_readonly(
          "powers", [](const LightSet& s) { return rows3(s.lights, [](const AreaLight& l) { return l.power; }); },
          "Light powers, float32 (N, 3).")
      .def_property_readonly(
          "radiances", [](const LightSet& s) { return rows3(s.lights, [](const AreaLight& l) { return l.radiance; }); },
          "Light radiances, float32 (N, 3).")
      .def_property_readonly(
          "cos_alpha",
          [](const LightSet& s) {
            py::array_t<float> out(py::ssize_t(s.lights.size()));
            for (std::size_t i = 0; i < s.lights.size(); ++i) out.mutable_at(i) = s.lights[i].cosAlpha;
            return out;
          },
          "Cosines of the lights' half-angles, float32 (N,).")
      .def("power", &LightSet::power, "Lights' power plus the ambient's, RGB.")
      .def("lights_power", &LightSet::lightsPower, "Sum of the lights' power, RGB.")
      .def("ambient_power", &LightSet::ambientPower, "Integral of the ambient radiance, RGB.")
      .def("irradiance", &LightSet::irradiance, "normal"_a,
           "Unshadowed irradiance on a unit normal: every light plus the ambient.")
      .def("ambient_irradiance", &LightSet::ambientIrradiance, "normal"_a,
           "Unshadowed irradiance of the ambient residual alone.")
      .def("to_json", &LightSet::toJson, "The set as JSON text (what `penumbra lights` writes).")
      .def("__len__", [](const LightSet& s) { return s.lights.size(); },
           "The number of lights. A LightSet is a sequence of its lights: len(s), s[i] (negative "
           "i from the end), s[a:b:c] (a list), iteration and `in` give AreaLight copies; "
           "s[i] = light replaces one.")
      .def(
          "__getitem__",
          [](const LightSet& s, py::ssize_t i) { return s.lights[lightIndex(s, i)]; }, "index"_a,
          "A copy of light i (negative: from the end). IndexError outside the set.")
      .def(
          "__getitem__",
          [](const LightSet& s, const py::slice& slice) {
            std::size_t start = 0, stop = 0, step = 0, count = 0;
            if (!slice.compute(s.lights.size(), &start, &stop, &step, &count))
              throw py::error_already_set();
            py::list out;
            for (std::size_t k = 0; k < count; ++k) out.append(s.lights[start + k * step]);
            return out;
          },
          "slice"_a, "The lights in the slice, as a list of copies.")
      .def(
          "__setitem__",
          [](LightSet& s, py::ssize_t i, const AreaLight& light) {
            s.lights[lightIndex(s, i)] = light;
          },
          "index"_a, "light"_a, "Replaces light i (negative: from the end).")
      .def(
          "__iter__",
          [](const LightSet& s) {
            return py::make_iterator<py::return_value_policy::copy>(s.lights.begin(),
                                                                    s.lights.end());
          },
          py::keep_alive<0, 1>(), "Iterates over copies of the lights.")
      .def("__repr__", [](const LightSet& s) {
        return "<penumbra.LightSet " + s.method + ", " + std::to_string(s.lights.size()) +
               " lights" + (s.hasAmbient ? " + ambient>" : ">");
      });

  m.def("make_polygon_light", &makePolygonLight, "vertices"_a, "radiance"_a,
        "A polygon light from 3..32 unit directions of a convex polygon (any winding) and a "
        "uniform RGB radiance. Raises BadInput for non-convex, degenerate or too wide polygons.");
  m.def("make_rect_light", &makeRectLight, "direction"_a, "up"_a, "half_angles"_a, "radiance"_a,
        "A rect light: corners direction +- tan(a) right +- tan(b) up (half-angles in radians, "
        "each in (0, pi/2); right = up x direction).");
  m.def("make_ellipse_light", &makeEllipseLight, "direction"_a, "up"_a, "half_angles"_a,
        "radiance"_a,
        "An ellipse light (an ellipsoid seen from afar): the ellipse inscribed in the rect of "
        "make_rect_light. Raises BadInput for half-angles outside (0, pi/2).");
  m.def(
      "set_light_texture",
      [](AreaLight& l, const LightTexture& t) {
        AreaLight copy = l;
        setLightTexture(copy, t);
        l = copy;
      },
      "light"_a, "texture"_a,
      "Gives a cap, rect or ellipse light a radiance texture in place: power = its integral, "
      "radiance = power / solid angle. Raises BadInput for bad sizes, values or shapes.");
  m.def("texture_lights_from_map", &textureLightsFromMap, "env"_a, "lights"_a, "size"_a = 8,
        "supersample"_a = 4,
        "Gives every cap light in place a size x size texture of the map's radiance over it, "
        "scaled to keep its power: the shadow techniques then weight its samples by the map.");
  m.def("light_samples", &lightSamples, "light"_a, "n"_a, "rotation"_a = 0.0f,
        "n weighted light samples (LightSample) as brute force and the references use them: "
        "weights from the texture and, for ellipses, the solid angle each sample stands for.");
  m.def("light_sample_directions", &lightSampleDirections, "light"_a, "n"_a, "rotation"_a = 0.0f,
        "n directions stratified and uniform in solid angle over the light, turned about its "
        "direction by `rotation` radians.");
  m.def("validate_light_set", &validateLightSet, "light_set"_a,
        "Raises BadInput 'LightSet: light i: ...' for what Renderer.render would refuse: a "
        "direction that is not a finite unit vector, cos_alpha outside [-1, 1], non-finite or "
        "negative radiance or power, bad polygon vertices, textures or ambient.");
  m.def("rotate_light_set", &rotateLightSet, "light_set"_a, "degrees"_a,
        "The light set of the same map turned `degrees` further about +y "
        "(Environment.rotation_y_deg's sense): lights, frames and vertices turned, the ambient's "
        "SH9 rotated, its irradiance map shifted (linear between columns); regions cleared (whole "
        "turns: the set unchanged). "
        "What an animation of a turning map should use instead of extracting every frame.");
  m.def("load_light_set", [](const fs::path& path) { return loadLightSet(path.string()); },
        "path"_a, py::call_guard<py::gil_scoped_release>(),
        "Reads a light-set JSON file, path str or os.PathLike (caps, polygons, rects, ellipses, "
        "textures; the format of `penumbra render --light-set`). Raises BadInput naming the "
        "file and the light for bad input.");
  m.def("light_set_from_json", &lightSetFromJson, "text"_a, "source"_a = "light set",
        "Parses light-set JSON text; `source` names it in error messages.");

  py::enum_<ExtractionMethod>(m, "ExtractionMethod", "Light extraction method.")
      .value("MEDIAN_CUT", ExtractionMethod::MedianCut, "Median cut (Kneiphof 2017 §3.1).")
      .value("GREEDY", ExtractionMethod::Greedy, "Greedy square/rectangle fitting (Annen et al. 2008 §4.2).")
      .value("CENTER_SURROUND", ExtractionMethod::CenterSurround,
             "Center-surround filter bank (Arbree et al. 2005 §3).");

  // The defaults the docstrings print.
  const MedianCutOptions MC;
  const GreedyOptions GR;
  const CenterSurroundOptions CS;
  const AmbientOptions AM;
  const ExtractOptions EX;
  py::class_<MedianCutOptions> mc(m, "MedianCutOptions", "Options of extract_median_cut.");
  initFromFields<MedianCutOptions>(mc);
  addRepr(mc);
  mc.def_readwrite("lights", &MedianCutOptions::lights,
                   withDefault("Regions/lights, >= 1.", MC.lights).c_str())
      .def_readwrite("face_size", &MedianCutOptions::faceSize,
                     withDefault("Cube face size, 1..4096.", MC.faceSize).c_str())
      .def_readwrite("supersample", &MedianCutOptions::supersample,
                     withDefault("Sub-samples per texel side when splatting.",
                                 MC.supersample).c_str())
      .def_readwrite("min_half_angle_deg", &MedianCutOptions::minHalfAngleDeg,
                     withDefault("Lower clamp on the half-angle, degrees.",
                                 MC.minHalfAngleDeg).c_str())
      .def_readwrite("max_half_angle_deg", &MedianCutOptions::maxHalfAngleDeg,
                     withDefault("Upper clamp on the half-angle, degrees.",
                                 MC.maxHalfAngleDeg).c_str())
      .def_readwrite("merge_across_faces", &MedianCutOptions::mergeAcrossFaces,
                     withDefault("Merge compact lights split by a cube-face edge.",
                                 MC.mergeAcrossFaces).c_str())
      .def_readwrite("merge_compactness", &MedianCutOptions::mergeCompactness,
                     withDefault("Largest cap/region solid-angle ratio merged, (0, 1].",
                                 MC.mergeCompactness).c_str())
      .def_readwrite("peak_ratio", &MedianCutOptions::peakRatio,
                     withDefault("Texels brighter than this times the map's mean luminance "
                                 "become lights of their own (connected sets, at most lights / "
                                 "4); 0: off.",
                                 MC.peakRatio).c_str())
      .def_readwrite("peak_max_half_angle_deg", &MedianCutOptions::peakMaxHalfAngleDeg,
                     withDefault("A bright set whose cap would be wider than this stays with "
                                 "median cut, degrees, (0, 90).",
                                 MC.peakMaxHalfAngleDeg).c_str())
      .def_readwrite("shape", &MedianCutOptions::shape,
                     "LightShape.CAP (default) or POLYGON: a light from one region becomes that "
                     "region's cube-face quadrilateral.");

  py::class_<GreedyOptions> gr(m, "GreedyOptions", "Options of extract_greedy.");
  initFromFields<GreedyOptions>(gr);
  addRepr(gr);
  gr.def_readwrite("threshold", &GreedyOptions::threshold,
                   withDefault("A side grows while its added energy / the light's exceeds this.",
                               GR.threshold).c_str())
      .def_readwrite("square", &GreedyOptions::square,
                     withDefault("Square lights (else rectangles).", GR.square).c_str())
      .def_readwrite("face_size", &GreedyOptions::faceSize,
                     withDefault("Cube face size, 1..1024.", GR.faceSize).c_str())
      .def_readwrite("max_lights", &GreedyOptions::maxLights,
                     withDefault("Strongest lights kept.", GR.maxLights).c_str())
      .def_readwrite("supersample", &GreedyOptions::supersample,
                     withDefault("Splat sub-samples.", GR.supersample).c_str());

  py::class_<CenterSurroundOptions> cs(m, "CenterSurroundOptions",
                                       "Options of extract_center_surround.");
  initFromFields<CenterSurroundOptions>(cs);
  addRepr(cs);
  cs.def_readwrite("width", &CenterSurroundOptions::width,
                   withDefault("Working map width.", CS.width).c_str())
      .def_readwrite("sizes", &CenterSurroundOptions::sizes,
                     withDefault("Filter sizes.", CS.sizes).c_str())
      .def_readwrite("min_deg", &CenterSurroundOptions::minDeg,
                     withDefault("Smallest outer diameter.", CS.minDeg).c_str())
      .def_readwrite("max_deg", &CenterSurroundOptions::maxDeg,
                     withDefault("Largest outer diameter.", CS.maxDeg).c_str())
      .def_readwrite("inner_ratio", &CenterSurroundOptions::innerRatio,
                     withDefault("Inner / outer radius.", CS.innerRatio).c_str())
      .def_readwrite("surround_weight", &CenterSurroundOptions::surroundWeight,
                     withDefault("Weight of the ring (centre +1).", CS.surroundWeight).c_str())
      .def_readwrite("candidate_fraction", &CenterSurroundOptions::candidateFraction,
                     withDefault("Brightest fraction of texels that are candidates.",
                                 CS.candidateFraction).c_str())
      .def_readwrite("stop_fraction", &CenterSurroundOptions::stopFraction,
                     withDefault("Stop when a light carries less than this of those so far.",
                                 CS.stopFraction).c_str())
      .def_readwrite("max_lights", &CenterSurroundOptions::maxLights,
                     withDefault("Most lights.", CS.maxLights).c_str());

  py::enum_<AmbientModel>(m, "AmbientModel", "How the ambient residual is shaded.")
      .value("IRRADIANCE_MAP", AmbientModel::IrradianceMap,
             "Its pre-integrated irradiance map (Arbree et al. 2005 §3; default).")
      .value("SH9", AmbientModel::SH9, "Its 9 spherical-harmonic coefficients only.");

  py::class_<AmbientOptions> ao(m, "AmbientOptions", "Options of the ambient residual.");
  initFromFields<AmbientOptions>(ao);
  addRepr(ao);
  ao.def_readwrite("model", &AmbientOptions::model,
                   "AmbientModel.IRRADIANCE_MAP (default) or SH9.")
      .def_readwrite("map_width", &AmbientOptions::mapWidth,
                     withDefault("Irradiance map width, 1..1024.", AM.mapWidth).c_str())
      .def_readwrite("map_height", &AmbientOptions::mapHeight,
                     withDefault("Irradiance map height, 1..1024.", AM.mapHeight).c_str());

  py::class_<ExtractOptions> eo(m, "ExtractOptions", "Options of extract_lights.");
  initFromFields<ExtractOptions>(eo);
  addRepr(eo);
  eo.def_property(
        "method", [](const ExtractOptions& o) { return o.method; },
        [](ExtractOptions& o, const py::object& v) { o.method = toMethod(v); },
        "ExtractionMethod or 'median-cut' | 'greedy' | 'center-surround'. Default median cut.")
      .def_readwrite("median_cut", &ExtractOptions::medianCut, "MedianCutOptions.")
      .def_readwrite("greedy", &ExtractOptions::greedy, "GreedyOptions.")
      .def_readwrite("center_surround", &ExtractOptions::centerSurround, "CenterSurroundOptions.")
      .def_readwrite("ambient", &ExtractOptions::ambient,
                     withDefault("Add the ambient residual.", EX.ambient).c_str())
      .def_readwrite("ambient_options", &ExtractOptions::ambientOptions,
                     "AmbientOptions: its representation (default: a 128x64 irradiance map).")
      .def_readwrite("light_texture", &ExtractOptions::lightTexture,
                     "Texture each extracted cap with N x N texels of the map (0: none, default; "
                     "else 1..64): sample-based techniques weight light samples by the map.")
      .def_readwrite("target_error", &ExtractOptions::targetError,
                     "> 0: median cut chooses the fewest lights (up to median_cut.lights) whose "
                     "light_set_probe_error is at most this; 0 (default): median_cut.lights.");
  m.def("light_set_probe_error", &lightSetProbeError, "env"_a, "lights"_a,
        py::call_guard<py::gil_scoped_release>(),
        "A cheap prediction of the error the light set leaves under occlusion with exact "
        "visibility of its lights (evaluate's floor): cones block part of the sky over 64 "
        "receiver normals and what passes from the lights plus the unshadowed ambient is compared "
        "with what passes from the map. Relative (RMS over the mean), >= 0.");

  m.def(
      "extract_lights",
      [](Context& ctx, const Environment& env, const py::object& method, const py::object& lights,
         const py::object& ambient, const py::object& options) {
        ExtractOptions o = options.is_none() ? ExtractOptions{} : options.cast<ExtractOptions>();
        if (!method.is_none()) o.method = toMethod(method);
        if (!lights.is_none()) {
          const int n = lights.cast<int>();
          o.medianCut.lights = n;
          o.greedy.maxLights = n;
          o.centerSurround.maxLights = n;
        }
        if (!ambient.is_none()) o.ambient = ambient.cast<bool>();
        py::gil_scoped_release release;
        return extractLights(ctx, env, o);
      },
      "ctx"_a, "env"_a, "method"_a = py::none(), "lights"_a = py::none(), "ambient"_a = py::none(),
      "options"_a = py::none(),
      "Extracts area lights from the map on the device, then the ambient residual. Starts from "
      "`options` (ExtractOptions; defaults: median cut, 32 lights, ambient on); `method` "
      "(ExtractionMethod or its name), `lights` (the light count of every method) and "
      "`ambient` override it when given. Raises BadInput for impossible counts or sizes.");
  m.def("extract_median_cut", &extractMedianCut, "ctx"_a, "env"_a,
        "options"_a = MedianCutOptions{}, py::call_guard<py::gil_scoped_release>(),
        "Median cut on the device (Kneiphof 2017 §3.1, §4.1), without the ambient residual. Raises "
        "BadInput for lights < 1, lights > 6*face_size^2 or face_size out of range.");
  m.def("extract_greedy", &extractGreedy, "ctx"_a, "env"_a, "options"_a = GreedyOptions{},
        py::call_guard<py::gil_scoped_release>(),
        "Greedy square/rectangle fitting per cube face (Annen et al. 2008 §4.2), without the ambient.");
  m.def("extract_center_surround", &extractCenterSurround, "ctx"_a, "env"_a,
        "options"_a = CenterSurroundOptions{}, py::call_guard<py::gil_scoped_release>(),
        "Center-surround filter bank on the sphere (Arbree et al. 2005 §3), without the ambient.");
  m.def("add_ambient_residual", &addAmbientResidual, "ctx"_a, "env"_a, "lights"_a,
        "options"_a = AmbientOptions{}, py::call_guard<py::gil_scoped_release>(),
        "Sets lights.ambient_sh to the map's SH9 minus the lights', lights.ambient_map to the "
        "residual's irradiance map (options.model IRRADIANCE_MAP, the default; emptied for SH9) "
        "and has_ambient to True. Raises BadInput for a map size outside 1..1024.");
  m.def(
      "write_light_overlay",
      [](const fs::path& path, const Environment& env, const LightSet& lights) {
        writeLightOverlay(path.string(), env, lights);
      },
      "path"_a, "env"_a, "lights"_a, py::call_guard<py::gil_scoped_release>(),
      "Writes a PNG (path: str or os.PathLike) of the tone-mapped map with every light's "
      "region or cap outlined.");

  // ---- rendering --------------------------------------------------------------------------
  py::enum_<ShadowTechnique>(m, "ShadowTechnique", "How light visibility is computed.")
      .value("NONE", ShadowTechnique::None, "No shadows.")
      .value("HARD", ShadowTechnique::Hard, "One shadow map at the light's centre.")
      .value("PCSS", ShadowTechnique::PCSS, "Percentage-closer soft shadows.")
      .value("CSSM", ShadowTechnique::CSSM, "Convolution soft shadow maps (Annen et al. 2008).")
      .value("MSSM4", ShadowTechnique::MSSM4, "Moment soft shadow maps, 4 moments (Kneiphof 2017).")
      .value("MSSM6", ShadowTechnique::MSSM6, "Moment soft shadow maps, 6 moments.")
      .value("BRUTE", ShadowTechnique::Brute, "K point-sample shadow maps per light, averaged.")
      .value("BITMASK", ShadowTechnique::Bitmask, "Sample-based visibility (Sintorn et al. 2008).")
      .value("BITMASK_HARD", ShadowTechnique::BitmaskHard, "Alias-free hard shadows (Sintorn et al. 2008).")
      .value("AREA_APPROX", ShadowTechnique::AreaApprox,
             "Polygon lights sampled along their edges, visible-area estimate (Ying et al. 2002).")
      .value("AUTO", ShadowTechnique::Auto,
             "Per-light choice of hard, PCSS, MSSM4 or exact (bitmask) visibility.");
  py::enum_<Prefilter>(m, "Prefilter", "Prefiltering of the filtered techniques.")
      .value("SAT", Prefilter::SAT, "Summed-area tables.")
      .value("MIP", Prefilter::Mip, "Mip pyramids.");
  m.def("parse_shadow_technique", &parseShadowTechnique, "name"_a,
        "'none' | 'hard' | 'pcss' | 'cssm' | 'mssm4' | 'mssm6' | 'brute' | 'bitmask' | "
        "'bitmask-hard' | 'area-approx' -> ShadowTechnique. Raises BadInput otherwise.");
  m.def("technique_name", [](ShadowTechnique t) { return std::string(toString(t)); }, "technique"_a,
        "The command-line name of a ShadowTechnique.");

  const RenderOptions R;  // the defaults the docstrings print
  py::class_<ShadowOptions> so(m, "ShadowOptions",
                               "Settings every shadow-map technique shares: depth bias (not CSSM "
                               "nor the bitmask techniques), light size and filter limits (pcss, "
                               "cssm, mssm4, mssm6).");
  initFromFields<ShadowOptions>(so);
  addRepr(so);
  so.def_readwrite("depth_bias", &ShadowOptions::depthBias,
                   withDefault("Receiver depth bias, normalized depth.", R.shadow.depthBias).c_str())
      .def_readwrite("light_size_scale", &ShadowOptions::lightSizeScale,
                     withDefault("Multiplies every light's angular size, >= 0.",
                                 R.shadow.lightSizeScale).c_str())
      .def_readwrite("max_filter_texels", &ShadowOptions::maxFilterTexels,
                     withDefault("Largest filter width, texels.", R.shadow.maxFilterTexels).c_str())
      .def_readwrite("min_filter_texels", &ShadowOptions::minFilterTexels,
                     withDefault("Smallest filter width, texels, > 0.",
                                 R.shadow.minFilterTexels).c_str())
      .def_readwrite("contact_shadows", &ShadowOptions::contactShadows,
                     withDefault("Contact shadows for techniques that read shadow maps: exact "
                                 "rays towards each light against the triangles seen within 2 "
                                 "pixels.", R.shadow.contactShadows).c_str())
      .def_readwrite("contact_from_maps", &ShadowOptions::contactFromMaps,
                     withDefault("Contact rays also test the triangle each light's map sees at "
                                 "the pixel (occluders the camera does not see) and, below the "
                                 "pixel's facet, its own triangle.",
                                 R.shadow.contactFromMaps).c_str())
      .def_readwrite("contact_texels", &ShadowOptions::contactTexels,
                     withDefault("Contact rays' length in texels of each light's map, > 0.",
                                 R.shadow.contactTexels).c_str())
      .def_readwrite("horizon_visibility", &ShadowOptions::horizonVisibility,
                     withDefault("Lights whose centre is below a pixel's horizon, for techniques "
                                 "that read shadow maps, take the mean visibility of the lights "
                                 "above it near their lit part.", R.shadow.horizonVisibility).c_str())
      .def_readwrite("ground_visibility", &ShadowOptions::groundVisibility,
                     withDefault("Lights that reach below the horizontal, for techniques that "
                                 "read shadow maps, lose at pixels above the scene's ground the "
                                 "part of the cap whose rays hit the ground.",
                                 R.shadow.groundVisibility).c_str());

  py::class_<MSSMOptions> mo(m, "MSSMOptions", "Moment soft shadow map options (MSSM4, MSSM6).");
  initFromFields<MSSMOptions>(mo);
  addRepr(mo);
  mo.def_readwrite("moment_bias", &MSSMOptions::momentBias,
                   withDefault("Moment bias, in [0, 1).", R.mssm.momentBias).c_str())
      .def_readwrite("slope_bias", &MSSMOptions::slopeBias,
                     withDefault("Slope-scaled bias.", R.mssm.slopeBias).c_str())
      .def_readwrite("blocker_epsilon", &MSSMOptions::blockerEpsilon,
                     withDefault("Kneiphof 2017 eq. 7.", R.mssm.blockerEpsilon).c_str())
      .def_readwrite("upper_bound_blocker", &MSSMOptions::upperBoundBlocker,
                     withDefault("Upper-bound blocker depth (Kneiphof 2017 eq. 19).",
                                 R.mssm.upperBoundBlocker).c_str())
      .def_readwrite("delta1", &MSSMOptions::delta1,
                     withDefault("Lower clamp of eq. 19.", R.mssm.delta1).c_str())
      .def_readwrite("delta2", &MSSMOptions::delta2,
                     withDefault("Upper clamp of eq. 19.", R.mssm.delta2).c_str())
      .def_readwrite("upper_bound_tilt", &MSSMOptions::upperBoundTilt,
                     withDefault("Eq. 19's delta2 scaled by min(1, this * tan(receiver tilt)); 0: "
                                 "eq. 19 on every receiver.",
                                 R.mssm.upperBoundTilt).c_str())
      .def_readwrite("cosine_centroid", &MSSMOptions::cosineCentroid,
                     withDefault("MSSM4: the filter centred on the cosine-weighted light's "
                                 "centroid (README, 'The cosine-weighted light').",
                                 R.mssm.cosineCentroid).c_str())
      .def_readwrite("leak_reduction", &MSSMOptions::leakReduction,
                     withDefault("MSSM4: visibility v -> clamp((v - r) / (1 - r)); in [0, 1), 0: "
                                 "off.",
                                 R.mssm.leakReduction).c_str());

  py::class_<CSSMOptions> co(m, "CSSMOptions", "Convolution soft shadow map options (Annen et al. 2008).");
  initFromFields<CSSMOptions>(co);
  addRepr(co);
  co.def_readwrite("order", &CSSMOptions::order,
                   withDefault("Fourier order M, 1..32.", R.cssm.order).c_str())
      .def_readwrite("sharpen_a", &CSSMOptions::sharpenA,
                     withDefault("Sharpening A (eq. 9).", R.cssm.sharpenA).c_str())
      .def_readwrite("sharpen_b", &CSSMOptions::sharpenB,
                     withDefault("Sharpening B.", R.cssm.sharpenB).c_str())
      .def_readwrite("ringing_offset", &CSSMOptions::ringingOffset,
                     withDefault("In [0, 1].", R.cssm.ringingOffset).c_str())
      .def_readwrite("damping", &CSSMOptions::damping,
                     withDefault("Term attenuation, [0, 8].", R.cssm.damping).c_str())
      .def_readwrite("depth_bias", &CSSMOptions::depthBias,
                     withDefault("Receiver depth bias (CSSM's own).", R.cssm.depthBias).c_str())
      .def_readwrite("slope_bias", &CSSMOptions::slopeBias,
                     withDefault("Blocker search slope bias.", R.cssm.slopeBias).c_str())
      .def_readwrite("max_basis_bytes", &CSSMOptions::maxBasisBytes,
                     bytesDefault("Device bytes for basis images per batch.",
                                  R.cssm.maxBasisBytes).c_str());

  py::class_<PCSSOptions> po(m, "PCSSOptions", "Percentage-closer soft shadow options.");
  initFromFields<PCSSOptions>(po);
  addRepr(po);
  po.def_readwrite("blocker_taps", &PCSSOptions::blockerTaps,
                   withDefault("Blocker search samples, 0..4096 (0: every texel).",
                               R.pcss.blockerTaps).c_str())
      .def_readwrite("filter_taps", &PCSSOptions::filterTaps,
                     withDefault("Filter samples, 0..4096 (0: every texel, coverage weighted).",
                                 R.pcss.filterTaps).c_str())
      .def_readwrite("receiver_plane_bias", &PCSSOptions::receiverPlaneBias,
                     withDefault("Compare with the receiver's tangent plane.",
                                 R.pcss.receiverPlaneBias).c_str());

  py::class_<BruteOptions> bo(m, "BruteOptions", "Brute-force point-sample shadow map options.");
  initFromFields<BruteOptions>(bo);
  addRepr(bo);
  bo.def_readwrite("samples", &BruteOptions::samples,
                   withDefault("Point lights per light, 1..4096.", R.brute.samples).c_str())
      .def_readwrite("batch_bytes", &BruteOptions::batchBytes,
                     bytesDefault("Device bytes of sample maps at once.", R.brute.batchBytes).c_str());

  py::class_<BitmaskOptions> bm(m, "BitmaskOptions", "Sample-based visibility options (Sintorn et al. 2008).");
  initFromFields<BitmaskOptions>(bm);
  addRepr(bm);
  bm.def_readwrite("light_samples", &BitmaskOptions::lightSamples,
                   withDefault("Light samples: 128, 256, 512 or 1024.", R.bitmask.lightSamples).c_str())
      .def_readwrite("list_size", &BitmaskOptions::listSize,
                     withDefault("List grid side (0: automatic).", R.bitmask.listSize).c_str())
      .def_readwrite("mask_bytes", &BitmaskOptions::maskBytes,
                     bytesDefault("Device bytes of bitmasks at once.", R.bitmask.maskBytes).c_str());

  py::class_<AreaApproxOptions> aa(m, "AreaApproxOptions", "Area approximation options (Ying et al. 2002).");
  initFromFields<AreaApproxOptions>(aa);
  addRepr(aa);
  aa.def_readwrite("edge_samples", &AreaApproxOptions::edgeSamples,
                   withDefault("Samples per edge besides its vertices, 0..15.",
                               R.areaApprox.edgeSamples).c_str())
      .def_readwrite("cap_vertices", &AreaApproxOptions::capVertices,
                     withDefault("Vertices of the polygon standing in for a cap, 3..16.",
                                 R.areaApprox.capVertices).c_str())
      .def_readwrite("taps", &AreaApproxOptions::taps,
                     withDefault("Texel reads placing a shadow edge on a segment, 0..64 (0: "
                                 "midpoint).", R.areaApprox.taps).c_str())
      .def_readwrite("batch_bytes", &AreaApproxOptions::batchBytes,
                     bytesDefault("Device bytes of sample maps at once.",
                                  R.areaApprox.batchBytes).c_str());

  py::class_<AutoOptions> au(m, "AutoOptions", "Per-light technique choice ('auto').");
  initFromFields<AutoOptions>(au);
  addRepr(au);
  au.def_readwrite("exact_lights", &AutoOptions::exactLights,
                   withDefault("The most lights given exact (bitmask) visibility, 0..4096.",
                               R.autoChoice.exactLights).c_str())
      .def_readwrite("hard_pixels", &AutoOptions::hardPixels,
                     withDefault("Hard shadows below this penumbra width (pixels or texels).",
                                 R.autoChoice.hardPixels).c_str())
      .def_readwrite("pcss_texels", &AutoOptions::pcssTexels,
                     withDefault("PCSS up to this filter width (texels), MSSM4 beyond.",
                                 R.autoChoice.pcssTexels).c_str())
      .def_readwrite("pcss_min_elevation_deg", &AutoOptions::pcssMinElevationDeg,
                     withDefault("PCSS only for lights at least this many degrees above the "
                                 "receivers facing them (their median), 0..90.",
                                 R.autoChoice.pcssMinElevationDeg).c_str())
      .def_readwrite("filtered_lights", &AutoOptions::filteredLights,
                     withDefault("The most lights given a filtered technique, the brightest "
                                 "on screen first, the others hard; -1: no limit, -1..4096.",
                                 R.autoChoice.filteredLights).c_str())
      .def_readwrite("exact_share", &AutoOptions::exactShare,
                     withDefault("Exact visibility also for a light with at least this share of "
                                 "the lights' power and a cap at most exact_half_angle_deg wide; "
                                 "0: none, 0..1.",
                                 R.autoChoice.exactShare).c_str())
      .def_readwrite("exact_half_angle_deg", &AutoOptions::exactHalfAngleDeg,
                     withDefault("The widest cap half-angle exact_share makes exact, 0..90.",
                                 R.autoChoice.exactHalfAngleDeg).c_str());

  py::class_<RenderOptions> ro(m, "RenderOptions",
                               "Options of Renderer.render. Keywords set fields, e.g. "
                               "RenderOptions(width=64, height=32, technique='pcss'). Errors name "
                               "a field as RenderOptions.<attribute path>.");
  initFromFields<RenderOptions>(ro);
  addRepr(ro);
  ro.def_readwrite("width", &RenderOptions::width,
                   withDefault("Image width, 1..16384.", R.width).c_str())
      .def_readwrite("height", &RenderOptions::height,
                     withDefault("Image height, 1..16384.", R.height).c_str())
      .def_readwrite("shadow_map_size", &RenderOptions::shadowMapSize,
                     withDefault("Square shadow map per light, texels, 1..4096.",
                                 R.shadowMapSize).c_str())
      .def_property(
          "technique", [](const RenderOptions& o) { return o.shadows; },
          [](RenderOptions& o, const py::object& v) { o.shadows = toTechnique(v); },
          ("ShadowTechnique or its name ('mssm4', 'pcss', ...). Default '" +
           std::string(toString(R.shadows)) + "'.").c_str())
      .def_property(
          "prefilter", [](const RenderOptions& o) { return o.prefilter; },
          [](RenderOptions& o, const py::object& v) { o.prefilter = toPrefilter(v); },
          ("Prefilter or 'sat' | 'mip'. Default '" + std::string(toString(R.prefilter)) + "'.")
              .c_str())
      .def_readwrite("front_back_faces", &RenderOptions::frontBackFaces,
                     withDefault("Average front and back depths (Kneiphof 2017 §4.2.3).",
                                 R.frontBackFaces).c_str())
      .def_readwrite("shadow", &RenderOptions::shadow,
                     "ShadowOptions (depth bias, light size, filter limits).")
      .def_readwrite("mssm", &RenderOptions::mssm, "MSSMOptions.")
      .def_readwrite("cssm", &RenderOptions::cssm, "CSSMOptions.")
      .def_readwrite("pcss", &RenderOptions::pcss, "PCSSOptions.")
      .def_readwrite("brute", &RenderOptions::brute, "BruteOptions.")
      .def_readwrite("bitmask", &RenderOptions::bitmask, "BitmaskOptions.")
      .def_readwrite("area_approx", &RenderOptions::areaApprox, "AreaApproxOptions.")
      .def_readwrite("auto_choice", &RenderOptions::autoChoice, "AutoOptions.")
      .def_readwrite("environment_background", &RenderOptions::environmentBackground,
                     withDefault("Show the map behind the geometry.",
                                 R.environmentBackground).c_str())
      .def_readwrite("bent_normals", &RenderOptions::bentNormals,
                     withDefault("Bent normals at light silhouettes (Sintorn et al. 2008 §4.3): shading fades "
                                 "continuously to black on light-back-facing triangles. Meant for "
                                 "the bitmask techniques; not with the GL path.",
                                 R.bentNormals).c_str())
      .def_readwrite("bent_normals_scale", &RenderOptions::bentNormalsScale,
                     withDefault("c of the bent-normal blend min(1, max(c I_bend, 0)): shading "
                                 "unchanged where I_bend >= 1/c (Sintorn et al. 2008 §4.3). Finite, > 0.",
                                 R.bentNormalsScale).c_str());

  py::class_<Frame>(m, "Frame", "A rendered frame.")
      .def_property_readonly(
          "image", [](py::object self) { return imageView(self.cast<Frame&>().image, self); },
          "RGBA linear radiance, float32 (H, W, 4); alpha 1 on geometry. A view of the frame's "
          "pixels (no copy); the array keeps the Frame alive.")
      .def_property_readonly(
          "timings", [](const Frame& f) { return timingsDict(f.timingsMs); },
          "Device milliseconds per stage since the Context's last reset_timings(), plus 'total' "
          "(render's wall clock), as a dict.")
      .def_readonly("shadow_map_bytes", &Frame::shadowMapBytes,
                    "Device bytes of the filterable shadow maps.")
      .def("_repr_png_", [](const Frame& f) { return pngBytes(f.image, 0.0f); },
           "The frame as PNG bytes, tonemap(image) with automatic exposure (what Jupyter "
           "shows).")
      .def("__repr__", [](const py::object& self) { return propertyRepr(self); });

  py::class_<Renderer>(m, "Renderer",
                       "Renders frames on a Context. Keep one: device buffers are reused between "
                       "frames of the same sizes.\n\n"
                       "Thread safety: a Renderer may be shared by threads: render() calls run "
                       "one after another, each giving exactly the frame it gives alone, and "
                       "last_visibility() is that of the last render by any thread. For frames "
                       "that overlap, give each thread its own Renderer; any number may share "
                       "one Context.")
      .def(py::init<Context&>(), "ctx"_a, py::keep_alive<1, 2>(), "A renderer on ctx.")
      .def("render", &Renderer::render, "scene"_a, "camera"_a, "lights"_a, "env"_a,
           "options"_a = RenderOptions{}, py::call_guard<py::gil_scoped_release>(),
           "Renders one frame: shadow maps, visibility with options.technique, shading, "
           "background. Returns a Frame. Raises BadInput for impossible sizes or options.")
      .def(
          "last_visibility",
          [](Renderer& r, int width, int height) {
            std::vector<float> v;
            {
              py::gil_scoped_release release;  // waits for a render on another thread
              v = r.lastVisibility();
            }
            const py::ssize_t per = py::ssize_t(width) * height;
            if (per <= 0 || py::ssize_t(v.size()) % per != 0)
              badInput("last_visibility: " + std::to_string(v.size()) +
                       " values are not a whole number of " + std::to_string(width) + "x" +
                       std::to_string(height) + " images");
            py::array_t<float> out({py::ssize_t(v.size()) / per, py::ssize_t(height), py::ssize_t(width)});
            std::memcpy(out.mutable_data(), v.data(), v.size() * sizeof(float));
            return out;
          },
          "width"_a, "height"_a,
          "Visibility of each light at each pixel from the last render, float32 (lights, H, W) "
          "(pass the last render's width and height).");
  m.def(
      "render_report_json",
      [](const Context& ctx, const LightSet& l, const Environment& e, const RenderOptions& o,
         const Frame& f) { return renderReportJson(ctx.info().name, l, e, o, f); },
      "ctx"_a, "lights"_a, "env"_a, "options"_a, "frame"_a,
      "The JSON report `penumbra render --report` writes for a frame.");

  // ---- reference and comparison -----------------------------------------------------------
  const ReferenceOptions RF;  // the defaults the docstrings print
  py::class_<ReferenceOptions> rf(m, "ReferenceOptions", "Options of the Embree reference.");
  initFromFields<ReferenceOptions>(rf);
  addRepr(rf);
  rf.def_readwrite("width", &ReferenceOptions::width, withDefault("Image width.", RF.width).c_str())
      .def_readwrite("height", &ReferenceOptions::height,
                     withDefault("Image height.", RF.height).c_str())
      .def_readwrite("spp", &ReferenceOptions::spp,
                     withDefault("Shadow-ray samples per pixel.", RF.spp).c_str())
      .def_readwrite("seed", &ReferenceOptions::seed, "Random seed (same seed, same image).")
      .def_readwrite("threads", &ReferenceOptions::threads,
                     withDefault("Threads, 0: all.", RF.threads).c_str())
      .def_readwrite("environment_background", &ReferenceOptions::environmentBackground,
                     withDefault("Show the map behind the geometry.",
                                 RF.environmentBackground).c_str());
  m.def(
      "reference_environment",
      [](const Scene& s, const Camera& c, const Environment& e, const ReferenceOptions& options,
         const py::object& progress) {
        ReferenceOptions o = options;
        PythonProgress state{progress};
        o.progress = progressWithInterrupts(&state);
        Image img;
        {
          py::gil_scoped_release release;
          img = referenceEnvironment(s, c, e, o);
        }
        return imageToArray(std::move(img));
      },
      "scene"_a, "camera"_a, "env"_a, "options"_a = ReferenceOptions{},
      "progress"_a = py::none(),
      "Embree ground truth lit by the whole map (MIS of map and cosine), float32 (H, W, 4). "
      "`progress`: None or a callable taking the fraction done (0..1), called now and then "
      "from the calling thread; an exception it raises stops the reference and propagates. "
      "Ctrl-C (KeyboardInterrupt) stops it too. Raises BadInput for sizes outside 1..16384, "
      "spp < 1, a bad scene or an empty map.");
  m.def(
      "reference_lights",
      [](const Scene& s, const Camera& c, const LightSet& l, const Environment& e,
         const ReferenceOptions& options, const py::object& progress) {
        ReferenceOptions o = options;
        PythonProgress state{progress};
        o.progress = progressWithInterrupts(&state);
        Image img;
        {
          py::gil_scoped_release release;
          img = referenceLights(s, c, l, e, o);
        }
        return imageToArray(std::move(img));
      },
      "scene"_a, "camera"_a, "lights"_a, "env"_a, "options"_a = ReferenceOptions{},
      "progress"_a = py::none(),
      "Embree ground truth lit by the light set (plus its ambient, unshadowed), float32 "
      "(H, W, 4): isolates a shadow technique's error from the extraction's. `progress` and "
      "Ctrl-C as in reference_environment.");

  py::class_<ImageMetrics>(m, "ImageMetrics", "Errors of an image against a reference.")
      .def_readonly("rmse", &ImageMetrics::rmse, "RMSE over compared pixels and RGB.")
      .def_readonly("relative_rmse", &ImageMetrics::relativeRmse, "RMSE / mean of the reference.")
      .def_readonly("psnr", &ImageMetrics::psnr, "20 log10(max(reference) / RMSE); inf if equal.")
      .def_readonly("max_abs_error", &ImageMetrics::maxAbsError, "Largest absolute difference.")
      .def_readonly("pixels", &ImageMetrics::pixels, "Pixels compared.")
      .def("to_json", [](const ImageMetrics& mt) { return toJson(mt); },
           "The metrics as JSON (what `penumbra compare` writes).")
      .def("__repr__", [](const ImageMetrics& mt) {
        return "<penumbra.ImageMetrics relative_rmse=" + std::to_string(mt.relativeRmse) +
               " psnr=" + std::to_string(mt.psnr) + ">";
      });
  m.def(
      "compare_images",
      [](const FloatArray& a, const FloatArray& b) {
        return compareImages(arrayToImage(a, "compare_images: image"),
                             arrayToImage(b, "compare_images: reference"));
      },
      "image"_a, "reference"_a,
      "Compares image with reference over the reference's geometry pixels (alpha > 0.5, or "
      "all without alpha). Raises BadInput on mismatched sizes, fewer than 3 channels, no "
      "pixels to compare or non-finite values.");
}
