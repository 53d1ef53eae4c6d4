// OpenCL context, device selection, program cache and named, profiled launches; shared between
// threads (context.hpp, "Thread safety").
#include "penumbra/context.hpp"

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <sstream>

#include <sys/mman.h>

#include "core/device_kind.hpp"
#include "core/program_cache.hpp"

namespace penumbra {
namespace detail {
const std::map<std::string, std::string>& embeddedKernels();
const std::map<std::string, std::string>& embeddedKernelPaths();
}

const char* toString(ErrorKind kind) {
  switch (kind) {
    case ErrorKind::BadInput: return "bad input";
    case ErrorKind::NoPlatform: return "no OpenCL device";
    case ErrorKind::KernelBuild: return "kernel build failure";
    case ErrorKind::OutOfMemory: return "out of device memory";
    case ErrorKind::Device: return "OpenCL error";
    case ErrorKind::Internal: return "internal error";
    case ErrorKind::Cancelled: return "cancelled";
  }
  return "error";
}

const char* clErrorName(cl_int code) {
  switch (code) {
    case CL_DEVICE_NOT_FOUND: return "CL_DEVICE_NOT_FOUND";
    case CL_MEM_OBJECT_ALLOCATION_FAILURE: return "CL_MEM_OBJECT_ALLOCATION_FAILURE";
    case CL_OUT_OF_RESOURCES: return "CL_OUT_OF_RESOURCES";
    case CL_OUT_OF_HOST_MEMORY: return "CL_OUT_OF_HOST_MEMORY";
    case CL_BUILD_PROGRAM_FAILURE: return "CL_BUILD_PROGRAM_FAILURE";
    case CL_INVALID_VALUE: return "CL_INVALID_VALUE";
    case CL_INVALID_BUFFER_SIZE: return "CL_INVALID_BUFFER_SIZE";
    case CL_INVALID_WORK_GROUP_SIZE: return "CL_INVALID_WORK_GROUP_SIZE";
    case CL_INVALID_WORK_ITEM_SIZE: return "CL_INVALID_WORK_ITEM_SIZE";
    case CL_INVALID_GLOBAL_WORK_SIZE: return "CL_INVALID_GLOBAL_WORK_SIZE";
    case CL_INVALID_KERNEL_ARGS: return "CL_INVALID_KERNEL_ARGS";
    case CL_INVALID_ARG_SIZE: return "CL_INVALID_ARG_SIZE";
    case CL_INVALID_ARG_VALUE: return "CL_INVALID_ARG_VALUE";
    case CL_INVALID_KERNEL_NAME: return "CL_INVALID_KERNEL_NAME";
    case CL_PLATFORM_NOT_FOUND_KHR: return "CL_PLATFORM_NOT_FOUND_KHR";
    default: return "CL error";
  }
}

[[noreturn]] void rethrowCl(const cl::Error& e, const std::string& what) {
  std::ostringstream msg;
  msg << what << ": " << e.what() << " failed with " << clErrorName(e.err()) << " (" << e.err()
      << ")";
  if (e.err() == CL_MEM_OBJECT_ALLOCATION_FAILURE || e.err() == CL_OUT_OF_RESOURCES ||
      e.err() == CL_OUT_OF_HOST_MEMORY || e.err() == CL_INVALID_BUFFER_SIZE)
    throw Error(ErrorKind::OutOfMemory, msg.str() + " (out of device memory)");
  throw Error(ErrorKind::Device, msg.str());
}

namespace {

const char* kNoPlatformHelp =
    "no OpenCL platform found. Install an OpenCL driver: on Debian 12 `apt-get install "
    "pocl-opencl-icd ocl-icd-libopencl1` runs penumbra on the CPU; GPU vendors ship their own ICD";

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

struct Found {
  DeviceInfo info;
  cl::Device device;
};

std::vector<Found> enumerate() {
  std::vector<cl::Platform> platforms;
  try {
    cl::Platform::get(&platforms);
  } catch (const cl::Error&) {
    platforms.clear();
  }
  std::vector<Found> out;
  for (auto& p : platforms) {
    std::vector<cl::Device> devs;
    try {
      p.getDevices(CL_DEVICE_TYPE_ALL, &devs);
    } catch (const cl::Error&) {
      continue;
    }
    for (auto& d : devs) {
      Found f;
      f.device = d;
      f.info.index = int(out.size());
      f.info.platform = p.getInfo<CL_PLATFORM_NAME>();
      f.info.name = d.getInfo<CL_DEVICE_NAME>();
      f.info.version = d.getInfo<CL_DEVICE_OPENCL_C_VERSION>();
      f.info.globalMemBytes = d.getInfo<CL_DEVICE_GLOBAL_MEM_SIZE>();
      f.info.maxAllocBytes = d.getInfo<CL_DEVICE_MAX_MEM_ALLOC_SIZE>();
      f.info.maxWorkGroupSize = d.getInfo<CL_DEVICE_MAX_WORK_GROUP_SIZE>();
      std::string ext = d.getInfo<CL_DEVICE_EXTENSIONS>();
      f.info.fp64 = ext.find("cl_khr_fp64") != std::string::npos;
      f.info.int64Atomics = ext.find("cl_khr_int64_base_atomics") != std::string::npos;
      while (!f.info.name.empty() && f.info.name.back() == '\0') f.info.name.pop_back();
      while (!f.info.platform.empty() && f.info.platform.back() == '\0') f.info.platform.pop_back();
      out.push_back(f);
    }
  }
  if (out.empty()) throw Error(ErrorKind::NoPlatform, kNoPlatformHelp);
  return out;
}

}  // namespace

std::vector<DeviceInfo> listDevices() {
  std::vector<DeviceInfo> out;
  for (auto& f : enumerate()) out.push_back(f.info);
  return out;
}

Context::~Context() {
  try {
    if (queue_()) queue_.finish();
  } catch (...) {  // a destructor must not throw; a failed device has nothing left to wait for
  }
}

namespace detail {
struct BufferLedger {
  std::atomic<std::uint64_t> live{0};
  std::atomic<std::uint64_t> peak{0};
  bool hostPages = false;  // a CPU device: large buffers live in our own huge-page memory
};
}  // namespace detail

namespace {
using detail::BufferLedger;
// What a buffer's release callback needs: the ledger (kept alive by this copy) and its size.
struct LedgerEntry {
  std::shared_ptr<BufferLedger> ledger;
  std::uint64_t bytes;
};
void CL_CALLBACK releaseEntry(cl_mem, void* user) {
  auto* e = static_cast<LedgerEntry*>(user);
  e->ledger->live.fetch_sub(e->bytes);
  delete e;
}
// Large buffers of CPU devices, in memory of our own. A CPU driver (PoCL) allocates a buffer
// with malloc, and the kernel then maps its pages 4 KiB at a time as the first kernels write
// them: on this project's 2-core VM one fault costs about 6 us, and a default frame's 150 MiB of
// MSSM4 moments took 220 ms of faults in the first frame against 9 ms in later ones. Asked for
// with madvise(MADV_HUGEPAGE) (transparent huge pages in their default "madvise" mode), the same
// memory faults 2 MiB at a time. The driver uses the memory as the buffer itself
// (CL_MEM_USE_HOST_PTR): the kernels are the same, and so are the bits. Buffers of 2 MiB or
// more; PENUMBRA_HOST_PAGES=off (exactly) leaves every buffer to the driver.
constexpr std::size_t kHugePage = std::size_t(2) << 20;
constexpr std::size_t kPage = std::size_t(4) << 10;

// A mapping of `length` bytes (`base`): the memory of one buffer.
struct HostPages {
  void* base = nullptr;
  std::size_t length = 0;
};
void CL_CALLBACK releaseHostPages(cl_mem, void* user) {
  auto* h = static_cast<HostPages*>(user);
  munmap(h->base, h->length);
  delete h;
}
// `bytes` (at least one huge page) of fresh memory whose start is aligned to a huge page, or null
// where mmap fails (the driver then allocates as usual). Only the whole huge pages are advised:
// a partial last one stays in 4 KiB pages, so the buffer takes no more memory than the driver's
// would (one 2 MiB fault would otherwise commit up to 2 MiB past its end).
void* hostPages(std::size_t bytes, HostPages& out) {
  const std::size_t length = (bytes + kPage - 1) / kPage * kPage + kHugePage;  // room to align
  void* m = mmap(nullptr, length, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (m == MAP_FAILED) return nullptr;
  const auto start = reinterpret_cast<std::uintptr_t>(m);
  const std::uintptr_t aligned = (start + kHugePage - 1) / kHugePage * kHugePage;
  madvise(reinterpret_cast<void*>(aligned), bytes / kHugePage * kHugePage,
          MADV_HUGEPAGE);  // advice: the kernel may refuse it, and 4 KiB pages work as before
  out.base = m;
  out.length = length;
  return reinterpret_cast<void*>(aligned);
}

std::string mibText(std::uint64_t bytes) { return std::to_string((bytes + (1u << 20) - 1) >> 20); }
}  // namespace

Context::Context(const std::string& selectorIn) : ledger_(std::make_shared<detail::BufferLedger>()) {
  std::string selector = selectorIn;
  if (selector.empty()) {
    const char* env = std::getenv("PENUMBRA_DEVICE");
    if (env) selector = env;
  }
  auto all = enumerate();
  const Found* pick = nullptr;
  if (selector.empty()) {
    pick = &all[0];
  } else if (std::all_of(selector.begin(), selector.end(), ::isdigit)) {
    std::size_t i = std::stoul(selector);
    if (i >= all.size())
      throw Error(ErrorKind::NoPlatform, "device index " + selector + " is out of range: " +
                                             std::to_string(all.size()) +
                                             " OpenCL device(s) found (see `penumbra devices`)");
    pick = &all[i];
  } else {
    for (auto& f : all)
      if (lower(f.info.name).find(lower(selector)) != std::string::npos ||
          lower(f.info.platform).find(lower(selector)) != std::string::npos) {
        pick = &f;
        break;
      }
    if (!pick)
      throw Error(ErrorKind::NoPlatform, "no OpenCL device matches '" + selector +
                                             "' (see `penumbra devices` for the list)");
  }
  info_ = pick->info;
  device_ = pick->device;
  try {
    const char* v = std::getenv("PENUMBRA_HOST_PAGES");
    ledger_->hostPages = detail::isCpuDevice(*this) && !(v && std::strcmp(v, "off") == 0);
  } catch (const Error&) {  // the device type could not be read: the driver allocates
  }
  try {
    context_ = cl::Context(device_);
    queue_ = cl::CommandQueue(context_, device_, CL_QUEUE_PROFILING_ENABLE);
  } catch (const cl::Error& e) {
    rethrowCl(e, "creating an OpenCL context on " + info_.name);
  }
  // The compiler a binary comes from: a new driver, device or platform version is a new key.
  std::string compiler;
  try {
    const cl::Platform platform(device_.getInfo<CL_DEVICE_PLATFORM>());
    compiler = info_.platform + '\n' + platform.getInfo<CL_PLATFORM_VERSION>() + '\n' + info_.name +
               '\n' + device_.getInfo<CL_DEVICE_VERSION>() + '\n' +
               device_.getInfo<CL_DRIVER_VERSION>();
  } catch (const cl::Error&) {
  }
  if (!compiler.empty())
    programCache_ = std::make_shared<const detail::ProgramCache>(
        detail::ProgramCache::defaultDirectory(), compiler);
  if (programCache_) programStats_.directory = programCache_->directory();
}

Context::ProgramCacheStats Context::programCacheStats() const {
  std::lock_guard<std::mutex> lock(programsMutex_);
  return programStats_;
}

cl::Kernel Context::kernel(const std::string& file, const std::string& name,
                           const std::string& options) {
  auto key = std::make_pair(file, options);
  std::unique_lock<std::mutex> lock(programsMutex_);
  auto it = programs_.find(key);
  if (it == programs_.end()) {
    const auto& sources = detail::embeddedKernels();
    auto src = sources.find(file);
    if (src == sources.end())
      throw Error(ErrorKind::Internal, "kernel file " + file + " is not embedded in the library");
    const std::string path = detail::embeddedKernelPaths().at(file);  // kernels/<family>/<file>
    std::string opts = "-cl-std=CL1.2 " + options;
    if (info_.fp64) opts += " -DPB_HAS_FP64=1";
    cl::Program program;
    const bool cached = programCache_ && programCache_->enabled();
    if (cached) {
      const std::vector<unsigned char> binary = programCache_->load(src->second, opts);
      if (!binary.empty()) {
        try {
          program = cl::Program(context_, {device_}, cl::Program::Binaries{binary});
          program.build({device_}, opts.c_str());
          ++programStats_.fromCache;
        } catch (const cl::Error&) {
          program = cl::Program();  // refused by this driver: built from source below
        }
      }
    }
    if (!program()) compileProgram(program, src->second, path, opts);
    it = programs_.emplace(key, program).first;
  }
  const cl::Program program = it->second;
  lock.unlock();  // clCreateKernel is thread-safe; only the map needs the lock
  try {
    return cl::Kernel(program, name.c_str());
  } catch (const cl::Error& e) {
    rethrowCl(e, "creating kernel " + name + " from kernels/" + file);
  }
}

void Context::compileProgram(cl::Program& program, const std::string& source,
                             const std::string& path, const std::string& opts) {
  try {
    program = cl::Program(context_, source);
  } catch (const cl::Error& e) {
    rethrowCl(e, "creating program " + path);
  }
  try {
    program.build({device_}, opts.c_str());
  } catch (const cl::Error& e) {
    std::string log;
    try {
      log = program.getBuildInfo<CL_PROGRAM_BUILD_LOG>(device_);
    } catch (...) {
    }
    throw Error(ErrorKind::KernelBuild, path + " failed to build on " + info_.name +
                                            " with options '" + opts + "':\n" + log);
  }
  ++programStats_.compiled;
  if (programCache_ && programCache_->enabled()) {
    try {
      const auto binaries = program.getInfo<CL_PROGRAM_BINARIES>();
      if (binaries.size() == 1 && programCache_->store(source, opts, binaries[0]))
        ++programStats_.stored;
    } catch (const cl::Error&) {  // a driver without binaries: nothing to keep
    }
  }
}

std::size_t Context::workGroupSize(const cl::Kernel& k, std::size_t preferred) const {
  std::size_t limit = preferred;
  try {
    limit = std::min(limit, k.getWorkGroupInfo<CL_KERNEL_WORK_GROUP_SIZE>(device_));
  } catch (const cl::Error&) {
  }
  limit = std::min(limit, info_.maxWorkGroupSize);
  std::size_t p = 1;
  while (p * 2 <= limit) p *= 2;
  return p;
}

void Context::checkArgCount(const std::string& stage, const cl::Kernel& k, std::size_t count) {
  cl_uint n = 0;
  try {
    n = k.getInfo<CL_KERNEL_NUM_ARGS>();
  } catch (const cl::Error& e) {
    rethrowCl(e, "reading the argument count of " + stage);
  }
  if (n != count)
    throw Error(ErrorKind::Internal, stage + ": the kernel " + k.getInfo<CL_KERNEL_FUNCTION_NAME>() +
                                         " takes " + std::to_string(n) + " arguments, " +
                                         std::to_string(count) + " were given");
}

void Context::launch(const std::string& stage, const cl::Kernel& k, const cl::NDRange& global,
                     const cl::NDRange& local) {
  cl::Event ev;
  cl::NDRange g = global, l = local;
  if (local.dimensions() == 0 && global.dimensions() > 0) {
    // Left to itself PoCL picks work-groups of a handful of items for 2D/3D ranges, and per-group
    // overhead then dominates simple kernels (measured: 10x on depth_to_moments). Use groups of up
    // to 64 along the first dimension, padding it; kernels ignore ids past their range.
    std::size_t wg = workGroupSize(k, 64);
    std::size_t g0 = (global[0] + wg - 1) / wg * wg;
    if (global.dimensions() == 1) {
      g = cl::NDRange(g0);
      l = cl::NDRange(wg);
    } else if (global.dimensions() == 2) {
      g = cl::NDRange(g0, global[1]);
      l = cl::NDRange(wg, 1);
    } else {
      g = cl::NDRange(g0, global[1], global[2]);
      l = cl::NDRange(wg, 1, 1);
    }
  }
  std::lock_guard<std::mutex> lock(eventsMutex_);
  try {
    queue_.enqueueNDRangeKernel(k, cl::NullRange, g, l, nullptr, &ev);
  } catch (const cl::Error& e) {
    rethrowCl(e, "launching " + stage);
  }
  events_.emplace_back(stage, ev);
  if (events_.size() < kEventBound) return;
  // The queue is in order: the finished events are a prefix. Fold it, or, when fewer than half
  // have finished (a long queue of short launches), wait for the older half and fold that.
  std::size_t done = 0;
  for (; done < events_.size(); ++done) {
    cl_int status = CL_COMPLETE;
    try {
      status = events_[done].second.getInfo<CL_EVENT_COMMAND_EXECUTION_STATUS>();
    } catch (const cl::Error&) {
    }
    if (status > CL_COMPLETE) break;  // queued, submitted or running; negative: failed, final
  }
  if (done < events_.size() / 2) {
    done = events_.size() / 2;
    try {
      events_[done - 1].second.wait();
    } catch (const cl::Error&) {  // a failed command: its duration reads as 0 ms, as before
    }
  }
  foldEvents(done);
}

namespace {
// Adds one event's profiled milliseconds to its stage's total (appended in first-launch order).
void addEvent(std::vector<std::pair<std::string, double>>& totals, const std::string& stage,
              const cl::Event& ev) {
  double ms = 0;
  try {
    auto t0 = ev.getProfilingInfo<CL_PROFILING_COMMAND_START>();
    auto t1 = ev.getProfilingInfo<CL_PROFILING_COMMAND_END>();
    ms = double(t1 - t0) * 1e-6;
  } catch (const cl::Error&) {
  }
  auto it = std::find_if(totals.begin(), totals.end(), [&](auto& p) { return p.first == stage; });
  if (it == totals.end())
    totals.emplace_back(stage, ms);
  else
    it->second += ms;
}
}  // namespace

void Context::foldEvents(std::size_t count) {
  for (std::size_t i = 0; i < count; ++i) addEvent(folded_, events_[i].first, events_[i].second);
  events_.erase(events_.begin(), events_.begin() + std::ptrdiff_t(count));
}

cl::Buffer Context::buffer(std::size_t bytes, const std::string& what, cl_mem_flags flags) {
  const std::string advice = " (out of device memory; reduce the size, map size or light count)";
  if (info_.maxAllocBytes > 0 && bytes > info_.maxAllocBytes)
    throw Error(ErrorKind::OutOfMemory,
                what + ": needs " + mibText(bytes) + " MiB in one buffer but device " +
                    info_.name + " allows " + mibText(info_.maxAllocBytes) +
                    " MiB per buffer" + advice);
  // Reserve first, so that threads sharing the context cannot together pass the limit.
  std::uint64_t live = ledger_->live.load();
  do {
    if (live + bytes > info_.globalMemBytes)
      throw Error(ErrorKind::OutOfMemory,
                  what + ": needs " + mibText(bytes) + " MiB more with " + mibText(live) +
                      " MiB already in use, but device " + info_.name + " has " +
                      mibText(info_.globalMemBytes) + " MiB" + advice);
  } while (!ledger_->live.compare_exchange_weak(live, live + bytes));
  std::uint64_t peak = ledger_->peak.load();
  while (live + bytes > peak && !ledger_->peak.compare_exchange_weak(peak, live + bytes)) {
  }
  try {
    cl::Buffer b;
    if (ledger_->hostPages && bytes >= kHugePage &&
        !(flags & (CL_MEM_USE_HOST_PTR | CL_MEM_ALLOC_HOST_PTR | CL_MEM_COPY_HOST_PTR))) {
      auto pages = std::make_unique<HostPages>();
      if (void* host = hostPages(bytes, *pages)) {
        cl_int rc = CL_SUCCESS;
        cl_mem m = clCreateBuffer(context_(), flags | CL_MEM_USE_HOST_PTR, bytes, host, &rc);
        if (rc == CL_SUCCESS &&
            clSetMemObjectDestructorCallback(m, releaseHostPages, pages.get()) == CL_SUCCESS) {
          pages.release();  // the callback frees it, once the driver is done with the memory
          b = cl::Buffer(m);  // takes the reference clCreateBuffer returned
        } else {
          // the driver would not take the memory, or could not say when it is done with it:
          // it allocates the buffer itself below
          if (rc == CL_SUCCESS) clReleaseMemObject(m);
          munmap(pages->base, pages->length);
        }
      }
    }
    if (!b()) b = cl::Buffer(context_, flags, bytes);
    auto* entry = new LedgerEntry{ledger_, bytes};
    const cl_int rc = clSetMemObjectDestructorCallback(b(), releaseEntry, entry);
    if (rc != CL_SUCCESS) {
      delete entry;
      ledger_->live.fetch_sub(bytes);  // untracked from here on; the driver still counts it
    }
    return b;
  } catch (const cl::Error& e) {
    ledger_->live.fetch_sub(bytes);
    rethrowCl(e, "allocating " + std::to_string(bytes) + " bytes for " + what);
  }
}

std::uint64_t Context::deviceBytesInUse() const { return ledger_->live.load(); }
std::uint64_t Context::peakDeviceBytes() const { return ledger_->peak.load(); }
void Context::resetPeakDeviceBytes() { ledger_->peak.store(ledger_->live.load()); }

cl::Buffer& Context::reuse(BufferSlots& slots, const std::string& role, std::size_t bytes) {
  auto& slot = slots[role];
  if (slot.second < bytes) {
    slot = {cl::Buffer(), 0};  // release the smaller one before allocating
    slot.first = buffer(bytes, role);
    slot.second = bytes;
  }
  return slot.first;
}

Context::ScratchLease Context::scratch(const std::string& role, std::size_t bytes) {
  bytes = std::max<std::size_t>(1, bytes);
  std::lock_guard<std::mutex> lock(scratchMutex_);
  auto& slots = scratch_[role];
  // A free slot large enough, else any free one (grown below), else a new one.
  ScratchLease::Slot* pick = nullptr;
  for (auto& s : slots)
    if (!s.leased && (!pick || (pick->bytes < bytes && s.bytes > pick->bytes))) pick = &s;
  if (!pick) pick = &slots.emplace_back();
  if (pick->bytes < bytes) {
    pick->buffer = cl::Buffer();  // release the smaller one before allocating
    pick->bytes = 0;
    pick->buffer = buffer(bytes, role);
    pick->bytes = bytes;
  }
  pick->leased = true;
  return ScratchLease(this, pick);
}

Context::ScratchLease& Context::ScratchLease::operator=(ScratchLease&& o) noexcept {
  if (this != &o) {
    release();
    ctx_ = o.ctx_;
    slot_ = o.slot_;
    o.ctx_ = nullptr;
    o.slot_ = nullptr;
  }
  return *this;
}

// The holder's commands on the buffer may still be queued: the next holder's are enqueued after
// them on the same in-order queue, so they never overlap.
void Context::ScratchLease::release() noexcept {
  if (!slot_) return;
  std::lock_guard<std::mutex> lock(ctx_->scratchMutex_);
  slot_->leased = false;
  slot_ = nullptr;
  ctx_ = nullptr;
}

void Context::write(cl::Buffer& b, const void* src, std::size_t bytes, const std::string& what) {
  try {
    queue_.enqueueWriteBuffer(b, CL_TRUE, 0, bytes, src);
  } catch (const cl::Error& e) {
    rethrowCl(e, "uploading " + what);
  }
}

cl::Event Context::writeAsync(cl::Buffer& b, const void* src, std::size_t bytes,
                              const std::string& what) {
  cl::Event ev;
  try {
    queue_.enqueueWriteBuffer(b, CL_FALSE, 0, bytes, src, nullptr, &ev);
  } catch (const cl::Error& e) {
    rethrowCl(e, "uploading " + what);
  }
  return ev;
}

void Context::read(const cl::Buffer& b, void* dst, std::size_t bytes, const std::string& what) {
  try {
    queue_.enqueueReadBuffer(b, CL_TRUE, 0, bytes, dst);
  } catch (const cl::Error& e) {
    rethrowCl(e, "reading back " + what);
  }
}

cl::Event Context::readAsync(const cl::Buffer& b, void* dst, std::size_t bytes,
                             const std::string& what) {
  cl::Event ev;
  try {
    queue_.enqueueReadBuffer(b, CL_FALSE, 0, bytes, dst, nullptr, &ev);
  } catch (const cl::Error& e) {
    rethrowCl(e, "reading back " + what);
  }
  return ev;
}

Context::ReadView Context::mapRead(const cl::Buffer& b, std::size_t bytes,
                                  const std::string& what) {
  if (bytes == 0) return ReadView();  // a map of no bytes is an error in OpenCL
  try {
    void* p = queue_.enqueueMapBuffer(b, CL_TRUE, CL_MAP_READ, 0, bytes);
    return ReadView(this, b, p);
  } catch (const cl::Error& e) {
    rethrowCl(e, "mapping " + what + " for reading");
  }
}

Context::ReadView& Context::ReadView::operator=(ReadView&& o) noexcept {
  if (this != &o) {
    release();
    ctx_ = std::exchange(o.ctx_, nullptr);
    buffer_ = std::move(o.buffer_);
    ptr_ = std::exchange(o.ptr_, nullptr);
  }
  return *this;
}

void Context::ReadView::release() noexcept {
  if (ptr_ && ctx_)  // a failed unmap leaves nothing to undo here; the queue reports its error
    clEnqueueUnmapMemObject(ctx_->queue_(), buffer_(), ptr_, 0, nullptr, nullptr);
  ptr_ = nullptr;
  ctx_ = nullptr;
}

void Context::fill(cl::Buffer& b, const void* pattern, std::size_t patternBytes,
                   std::size_t bytes, const std::string& what) {
  try {
    cl_int err = clEnqueueFillBuffer(queue_(), b(), pattern, patternBytes, 0, bytes, 0, nullptr,
                                     nullptr);
    if (err != CL_SUCCESS) throw cl::Error(err, "clEnqueueFillBuffer");
  } catch (const cl::Error& e) {
    rethrowCl(e, "clearing " + what);
  }
}

void Context::finish() {
  try {
    queue_.finish();
  } catch (const cl::Error& e) {
    rethrowCl(e, "waiting for the device");
  }
}

std::vector<std::pair<std::string, double>> Context::stageTimesMs() {
  finish();
  std::lock_guard<std::mutex> lock(eventsMutex_);
  // Launches other threads made since finish() may still run: the queue is in order, so their
  // last one's end is all of theirs. (Already complete when one thread uses the Context.)
  if (!events_.empty()) {
    try {
      events_.back().second.wait();
    } catch (const cl::Error&) {  // a failed command: its duration reads as 0 ms
    }
  }
  std::vector<std::pair<std::string, double>> out = folded_;
  for (auto& [stage, ev] : events_) addEvent(out, stage, ev);
  return out;
}

void Context::resetTimings() {
  std::lock_guard<std::mutex> lock(eventsMutex_);
  events_.clear();
  folded_.clear();
}

std::size_t Context::heldEvents() const {
  std::lock_guard<std::mutex> lock(eventsMutex_);
  return events_.size();
}

}  // namespace penumbra
