/// \file
/// OpenCL context: device choice, one in-order profiling queue, the program cache and named kernel
/// launches whose profiling events become per-stage timings.
///
/// Call order: construct a Context (it picks the device), then obtain kernels with kernel(file,
/// name, options) and launch them with launch(stage, ...). Timings accumulate per stage name until
/// resetTimings(); stageTimesMs() waits for the queue, so its numbers are complete when it returns.
///
/// Thread safety: one Context may be shared by any number of threads: every member function, and
/// every library call that takes a Context (light extraction, cubeMapEnergy, addAmbientResidual,
/// summedAreaTable, Renderers: renderer.hpp), may be called concurrently with the same one. The
/// program cache and the event list are behind mutexes; a scratch buffer is leased to one caller
/// at a time (scratch()); all threads enqueue on the one in-order queue, so the device runs their
/// commands one after another in enqueue order. Stage timings are the Context's, not a thread's: they add up every
/// thread's launches, and resetTimings() clears them for all. What is not shared: a cl::Kernel
/// (its arguments are set per object: take one from kernel() per thread, as the library does) and
/// a cl::Buffer two threads write. The Context must outlive every call and object using it.
#pragma once
// penumbra targets OpenCL 1.2 through the Khronos C++ bindings with exceptions (DESIGN.md: target
// 300 with minimum 120 does not compile against Debian's opencl.hpp).
#ifndef CL_HPP_TARGET_OPENCL_VERSION
#define CL_HPP_TARGET_OPENCL_VERSION 120
#endif
#ifndef CL_HPP_MINIMUM_OPENCL_VERSION
#define CL_HPP_MINIMUM_OPENCL_VERSION 120
#endif
#ifndef CL_HPP_ENABLE_EXCEPTIONS
#define CL_HPP_ENABLE_EXCEPTIONS
#endif
#include <CL/opencl.hpp>

#include <cstdint>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "penumbra/error.hpp"

namespace penumbra {

struct DeviceInfo {
  int index = 0;             ///< position in the list `penumbra devices` prints
  std::string platform;
  std::string name;
  std::string version;       ///< OpenCL C version the device compiles
  std::uint64_t globalMemBytes = 0;   ///< CL_DEVICE_GLOBAL_MEM_SIZE: all buffers together
  std::uint64_t maxAllocBytes = 0;    ///< CL_DEVICE_MAX_MEM_ALLOC_SIZE: one buffer
  std::size_t maxWorkGroupSize = 0;
  bool fp64 = false;
  bool int64Atomics = false;
};

/// Converts a cl::Error into a penumbra::Error with `what` in the message.
[[noreturn]] void rethrowCl(const cl::Error& e, const std::string& what);
const char* clErrorName(cl_int code);

/// All OpenCL devices on all platforms, in a stable order. Throws Error(NoPlatform) with the
/// package that provides one if there is none.
std::vector<DeviceInfo> listDevices();

namespace detail {
struct BufferLedger;  ///< src/core/context.cpp
class ProgramCache;   ///< src/core/program_cache.hpp
}

class Context {
 public:
  /// selector: "" uses $PENUMBRA_DEVICE if set, else device 0. Otherwise an index into
  /// listDevices() or a case-insensitive substring of the device or platform name.
  explicit Context(const std::string& selector = "");
  /// Waits for the work still queued: a program that ends right after its last enqueue must not
  /// leave PoCL compiling or running kernels while the process tears its libraries down.
  ~Context();
  /// One owner: the destructor drains the queue, and the program cache, stage timings and scratch
  /// buffers belong to this object alone. Share a Context by reference (between threads too).
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;

  const DeviceInfo& info() const { return info_; }
  cl::Context& context() { return context_; }
  cl::Device& device() { return device_; }
  cl::CommandQueue& queue() { return queue_; }

  /// Builds (once per file and option string) the embedded `kernels/<file>` and returns a new kernel
  /// object for `name`. Build failures throw Error(KernelBuild) with the log and the file name.
  cl::Kernel kernel(const std::string& file, const std::string& name,
                    const std::string& options = "");
  /// The work-group size to use for a kernel: the largest power of two <= min(preferred, limits).
  std::size_t workGroupSize(const cl::Kernel& k, std::size_t preferred = 256) const;

  /// Enqueues k under a stage name; the event's profiled duration is added to that stage. Without
  /// a local size, the first dimension is padded up to a multiple of the chosen work-group size:
  /// such kernels must return early for ids beyond their range.
  void launch(const std::string& stage, const cl::Kernel& k, const cl::NDRange& global,
              const cl::NDRange& local = cl::NullRange);
  /// The typed form of launch(): sets k's arguments from `args` in order (a cl::Buffer, a scalar
  /// such as cl_int or cl_float, a struct passed by value, or cl::Local(bytes) for local memory)
  /// after checking that their count is the kernel's, then launches it as launch() does. A
  /// kernel whose parameter list changes without its call site fails here with both counts.
  template <class... A>
  void launchWith(const std::string& stage, cl::Kernel& k, const cl::NDRange& global,
                  const cl::NDRange& local, const A&... args) {
    setArgs(stage, k, args...);
    launch(stage, k, global, local);
  }
  /// Only the argument setting of launchWith (for a kernel launched several times with the same
  /// arguments, or with one changed by setArg between launches).
  /// An argument the device refuses throws Error naming the stage.
  template <class... A>
  static void setArgs(const std::string& stage, cl::Kernel& k, const A&... args) {
    checkArgCount(stage, k, sizeof...(A));
    cl_uint i = 0;
    try {
      (k.setArg(i++, args), ...);
    } catch (const cl::Error& e) {
      rethrowCl(e, "setting argument " + std::to_string(i - 1) + " of " + stage);
    }
  }
  /// Throws Error(Internal) naming the stage and both counts unless k takes exactly `count`.
  static void checkArgCount(const std::string& stage, const cl::Kernel& k, std::size_t count);
  /// Buffer helpers that turn allocation failures into Error(OutOfMemory) naming `what`.
  /// buffer() refuses, before asking the driver, a buffer larger than the device's
  /// CL_DEVICE_MAX_MEM_ALLOC_SIZE or one that would bring this context's live buffers past its
  /// CL_DEVICE_GLOBAL_MEM_SIZE (drivers such as PoCL accept such requests and fail later, at first
  /// use, with an assertion); the message gives the bytes asked, the bytes in use and the limit.
  cl::Buffer buffer(std::size_t bytes, const std::string& what,
                    cl_mem_flags flags = CL_MEM_READ_WRITE);
  /// Bytes of device buffers this context has allocated and not yet released, and the most it has
  /// held at once since construction or the last resetPeakDeviceBytes().
  std::uint64_t deviceBytesInUse() const;
  std::uint64_t peakDeviceBytes() const;
  void resetPeakDeviceBytes();
  template <class T>
  cl::Buffer upload(const std::vector<T>& data, const std::string& what) {
    cl::Buffer b = buffer(std::max<std::size_t>(1, data.size()) * sizeof(T), what);
    if (!data.empty()) write(b, data.data(), data.size() * sizeof(T), what);
    return b;
  }
  void write(cl::Buffer& b, const void* src, std::size_t bytes, const std::string& what);
  /// The same without waiting: `src` must stay unchanged until the returned event completes.
  cl::Event writeAsync(cl::Buffer& b, const void* src, std::size_t bytes, const std::string& what);
  void read(const cl::Buffer& b, void* dst, std::size_t bytes, const std::string& what);
  /// The same without waiting: `dst` must stay valid, and is filled, once the returned event
  /// completes (wait on it before reading `dst`).
  cl::Event readAsync(const cl::Buffer& b, void* dst, std::size_t bytes, const std::string& what);
  template <class T>
  std::vector<T> download(const cl::Buffer& b, std::size_t count, const std::string& what) {
    std::vector<T> out(count);
    if (count) read(b, out.data(), count * sizeof(T), what);
    return out;
  }
  void fill(cl::Buffer& b, const void* pattern, std::size_t patternBytes, std::size_t bytes,
            const std::string& what);
  /// A buffer's first bytes on the host, read-only, until the view is destroyed (a blocking
  /// clEnqueueMapBuffer; the unmap is queued by the destructor, so work queued after it sees the
  /// buffer again). Where the device's memory is the host's (PoCL), the driver hands out the
  /// buffer's own memory and nothing is copied, where read() copies: 38 MB a frame for the
  /// default frame's shadow maps, read by `--shadows auto`. Keep the view shorter than any write
  /// to the buffer; views must not outlive their Context.
  class ReadView {
   public:
    ReadView() = default;
    ReadView(ReadView&& o) noexcept { *this = std::move(o); }
    ReadView& operator=(ReadView&& o) noexcept;
    ReadView(const ReadView&) = delete;
    ReadView& operator=(const ReadView&) = delete;
    ~ReadView() { release(); }
    const void* data() const { return ptr_; }

   private:
    friend class Context;
    ReadView(Context* c, cl::Buffer b, void* p) : ctx_(c), buffer_(std::move(b)), ptr_(p) {}
    void release() noexcept;
    Context* ctx_ = nullptr;
    cl::Buffer buffer_;
    void* ptr_ = nullptr;
  };
  /// Errors (a driver refusing the map) throw Error naming `what`; no bytes give a null view.
  ReadView mapRead(const cl::Buffer& b, std::size_t bytes, const std::string& what);
  void finish();
  /// A lease on a scratch buffer (scratch()): the buffer is the holder's alone until the lease is
  /// destroyed or reassigned, then goes back to the context for the next caller with its role.
  /// Keep the lease, not a copy of buffer(), for as long as the buffer is used. Leases must not
  /// outlive their Context.
  class ScratchLease {
   public:
    ScratchLease() = default;
    ScratchLease(ScratchLease&& o) noexcept { *this = std::move(o); }
    ScratchLease& operator=(ScratchLease&& o) noexcept;
    ScratchLease(const ScratchLease&) = delete;
    ScratchLease& operator=(const ScratchLease&) = delete;
    ~ScratchLease() { release(); }
    cl::Buffer& buffer() { return slot_->buffer; }
    const cl::Buffer& buffer() const { return slot_->buffer; }

   private:
    friend class Context;
    struct Slot {
      cl::Buffer buffer;
      std::size_t bytes = 0;
      bool leased = false;
    };
    ScratchLease(Context* c, Slot* s) : ctx_(c), slot_(s) {}
    void release() noexcept;
    Context* ctx_ = nullptr;
    Slot* slot_ = nullptr;
  };
  /// A buffer of at least `bytes` kept by the context under `role` and handed out again to later
  /// calls with the same role, so that work repeated every frame (light extraction from an animated
  /// map) neither allocates nor first-touches its buffers each time (first-touch page faults were
  /// most of env/sat-inputs at face 512 on PoCL). Reallocated when a call needs more, never shrunk:
  /// the context holds the largest size each role has needed until it is destroyed. Its contents
  /// are the previous holder's. While one lease on a role is held, another caller (another thread)
  /// gets another buffer for that role, so the context keeps as many per role as were ever leased
  /// at once; one thread alone always gets the same one.
  ScratchLease scratch(const std::string& role, std::size_t bytes);
  /// The rule behind scratch() and the renderer's per-frame buffer pool: the buffer kept in
  /// slots[role], reallocated (the smaller one released first) only when `bytes` exceeds it. The
  /// slots are the caller's: it keeps them to one thread at a time.
  using BufferSlots = std::map<std::string, std::pair<cl::Buffer, std::size_t>>;
  cl::Buffer& reuse(BufferSlots& slots, const std::string& role, std::size_t bytes);

  /// Stage name -> milliseconds of device time, in first-launch order. Waits for the queue.
  std::vector<std::pair<std::string, double>> stageTimesMs();
  void resetTimings();
  /// Launches whose profiling events are still held. Once they reach kEventBound, launch() folds
  /// the finished ones into per-stage totals (waiting for the older half of them if too few have
  /// finished), so a long run's memory does not grow with its launches; stageTimesMs() adds the
  /// same durations in the same order either way.
  static constexpr std::size_t kEventBound = 4096;
  std::size_t heldEvents() const;

  /// Compiled programs are kept between processes, per device, driver and penumbra version, in
  /// $PENUMBRA_CACHE_DIR/programs (else $XDG_CACHE_HOME/penumbra/programs, else
  /// ~/.cache/penumbra/programs; PENUMBRA_CACHE_DIR=off keeps none; the directory is chosen when
  /// the Context is made, each file read when its program is first needed): a program found
  /// there is made from its binary, which on PoCL takes 2-6 ms where
  /// building from source takes 50-100 ms even with PoCL's own cache warm. A file that is
  /// truncated or corrupt, or owned by another user, is never used; a binary the driver refuses
  /// is built again from source. The checksum finds damage, not tampering: the directory must be
  /// writable by its user only, as PoCL's own cache is.
  /// This Context's programs so far: from the cache, compiled from source, and stored.
  struct ProgramCacheStats {
    std::size_t fromCache = 0, compiled = 0, stored = 0;
    std::string directory;  ///< "" when the cache is off
  };
  ProgramCacheStats programCacheStats() const;

 private:
  DeviceInfo info_;
  cl::Context context_;
  cl::Device device_;
  cl::CommandQueue queue_;
  /// Each mutex guards the members below it. Held while a program builds (a second thread asking
  /// for the same program waits for it rather than building it again).
  mutable std::mutex programsMutex_;
  std::map<std::pair<std::string, std::string>, cl::Program> programs_;
  std::shared_ptr<const detail::ProgramCache> programCache_;
  ProgramCacheStats programStats_;
  /// Builds `source` into `program` and stores its binary (programsMutex_ held).
  void compileProgram(cl::Program& program, const std::string& source, const std::string& path,
                      const std::string& opts);
  /// Held across enqueue and append in launch(), so that events_ is in queue order (the folding
  /// relies on it); never held by a thread waiting on something other than the queue.
  mutable std::mutex eventsMutex_;
  std::vector<std::pair<std::string, cl::Event>> events_;
  std::vector<std::pair<std::string, double>> folded_;  ///< per-stage totals of dropped events
  /// Folds events_[0, count) into folded_ and drops them (eventsMutex_ held).
  void foldEvents(std::size_t count);
  std::mutex scratchMutex_;
  std::map<std::string, std::list<ScratchLease::Slot>> scratch_;  ///< role -> its buffers
  /// Live and peak bytes of this context's buffers. Shared with each buffer's release callback,
  /// which may run after the Context is gone (a buffer the caller still holds).
  std::shared_ptr<detail::BufferLedger> ledger_;
};

}  // namespace penumbra
