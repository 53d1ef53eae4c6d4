// OpenCL context: device selection, typed errors, the program cache.
#include <gtest/gtest.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include "common.hpp"
#include "core/program_cache.hpp"
#include "support/scoped_env.hpp"

using namespace penumbra;
using penumbra::test::ScopedEnv;

TEST(Context, ListsDevicesAndSelectsByIndexAndName) {
  auto devices = listDevices();
  ASSERT_FALSE(devices.empty());
  Context byIndex("0");
  EXPECT_EQ(byIndex.info().name, devices[0].name);
  // a case-insensitive substring of the device or platform name
  std::string part = devices[0].name.substr(0, std::min<std::size_t>(6, devices[0].name.size()));
  for (auto& c : part) c = char(std::toupper(c));
  Context byName(part);
  EXPECT_EQ(byName.info().name, devices[0].name);
}

TEST(Context, UnknownDeviceIsANamedError) {
  for (std::string sel : {"no-such-device-xyz", "99"}) {
    try {
      Context c(sel);
      FAIL() << sel << " accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::NoPlatform);
      EXPECT_NE(std::string(e.what()).find(sel), std::string::npos) << e.what();
    }
  }
}

TEST(Context, EnvironmentVariableSelectsTheDevice) {
  const char* before = std::getenv("PENUMBRA_DEVICE");
  const std::optional<std::string> old = before ? std::optional<std::string>(before) : std::nullopt;
  {
    ScopedEnv bad("PENUMBRA_DEVICE", std::string("no-such-device-xyz"));
    EXPECT_THROW(Context c, Error);
  }
  {
    ScopedEnv unset("PENUMBRA_DEVICE", std::nullopt);
    EXPECT_NO_THROW(Context c);
  }
  // Both scopes put back what the process had.
  const char* after = std::getenv("PENUMBRA_DEVICE");
  EXPECT_EQ(after != nullptr, old.has_value());
  if (after && old) EXPECT_EQ(std::string(after), *old);
}

TEST(Context, KernelBuildFailureCarriesLogAndFile) {
  Context& ctx = test::ctx();
  try {
    ctx.kernel("scan.cl", "scan_rows", "-DSCAN_T=not_a_type");
    FAIL() << "bad build options accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::KernelBuild);
    std::string msg = e.what();
    EXPECT_NE(msg.find("kernels/common/scan.cl"), std::string::npos) << msg;
    EXPECT_NE(msg.find("not_a_type"), std::string::npos) << msg;  // from the build log
  }
  EXPECT_THROW(ctx.kernel("missing.cl", "x"), Error);
}

TEST(Context, OversizedBufferIsOutOfMemory) {
  Context& ctx = test::ctx();
  try {
    ctx.buffer(ctx.info().globalMemBytes + (std::size_t(1) << 30), "test buffer");
    FAIL() << "oversized buffer accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::OutOfMemory);
    EXPECT_NE(std::string(e.what()).find("test buffer"), std::string::npos);
  }
}

TEST(Context, NamedLaunchesBecomeStageTimes) {
  Context& ctx = test::ctx();
  ctx.resetTimings();
  std::vector<float> data(64 * 8, 1.0f);
  cl::Buffer b = ctx.upload(data, "data");
  summedAreaTable(ctx, b, ScanType::Float, 64, 8, 1, "mysat");
  auto times = ctx.stageTimesMs();
  ASSERT_FALSE(times.empty());
  for (auto& [name, ms] : times) {
    EXPECT_EQ(name.rfind("mysat/", 0), 0u) << name;
    EXPECT_GE(ms, 0.0);
  }
  auto out = ctx.download<float>(b, data.size(), "data");
  EXPECT_FLOAT_EQ(out.back(), 64.0f * 8.0f);
}

// On a CPU device a buffer of 2 MiB or more lives in memory the context maps itself, aligned to
// a huge page (src/core/context.cpp, hostPages: the first frame's page faults), and kernels and
// transfers see it as any buffer; smaller buffers, and every buffer under
// PENUMBRA_HOST_PAGES=off, are the driver's. The mapping goes when the buffer does (mincore then
// finds no page there) and the ledger counts the buffer out, twice over.
TEST(Context, LargeCpuBuffersLiveInHugePageAlignedMemory) {
  for (const char* mode : {"on", "off"}) {
    ScopedEnv env("PENUMBRA_HOST_PAGES", std::string(mode));
    Context ctx;
    const cl_device_type type = ctx.device().getInfo<CL_DEVICE_TYPE>();
    const bool cpu = (type & CL_DEVICE_TYPE_CPU) && !(type & CL_DEVICE_TYPE_GPU);
    const bool own = cpu && std::string(mode) == "on";
    const std::size_t big = (std::size_t(4) << 20) + 12, small = (std::size_t(2) << 20) - 4;
    for (int round = 0; round < 2; ++round) {
      const std::uint64_t before = ctx.deviceBytesInUse();
      void* hb = nullptr;
      {
        cl::Buffer b = ctx.buffer(big, "test big");
        cl::Buffer s = ctx.buffer(small, "test small");
        hb = b.getInfo<CL_MEM_HOST_PTR>();
        EXPECT_EQ(hb != nullptr, own) << mode;
        if (hb) {
          EXPECT_EQ(reinterpret_cast<std::uintptr_t>(hb) % (std::uintptr_t(2) << 20), 0u);
        }
        EXPECT_EQ(s.getInfo<CL_MEM_HOST_PTR>(), nullptr) << mode;
        EXPECT_EQ(ctx.deviceBytesInUse(), before + big + small);
        // a kernel writes the first 4 MiB (the SAT of 1024 x 1024 ones), a read sees it
        const int w = 1024, h = int(big / 4 / w);
        std::vector<float> ones(std::size_t(w) * h, 1.0f);
        ctx.write(b, ones.data(), ones.size() * 4, "test big");
        summedAreaTable(ctx, b, ScanType::Float, w, h, 1, "test/sat");
        const std::vector<float> out = ctx.download<float>(b, ones.size(), "test big");
        EXPECT_EQ(out[std::size_t(w) * 3 + 5], 4.0f * 6.0f);
        EXPECT_EQ(out[std::size_t(w) * (h - 1) + 9], float(h) * 10.0f);
      }
      ctx.finish();
      // The ledger counts a buffer out, and the mapping goes, in the driver's destructor
      // callbacks, which PoCL runs on its own thread once the buffer's last command is done:
      // finish() can return first (seen once in a loaded ctest -j2 run, 4 MiB still counted).
      // Each is waited for up to a second.
      const auto within1s = [](const auto& done) {
        for (int i = 0; i < 100 && !done(); ++i) usleep(10000);
        return done();
      };
      EXPECT_TRUE(within1s([&] { return ctx.deviceBytesInUse() == before; }))
          << mode << " round " << round << ": " << ctx.deviceBytesInUse() << " bytes counted, "
          << before << " before";
      if (hb) {
        unsigned char resident = 0;
        const bool unmapped =
            within1s([&] { return mincore(hb, 4096, &resident) != 0 && errno == ENOMEM; });
        EXPECT_TRUE(unmapped) << "round " << round << ": the buffer's memory is still mapped";
      }
    }
  }
}

// Context::mapRead: the view shows the buffer's contents; once it is gone, a kernel's writes to the
// buffer land and a second view shows them; on a CPU device's own large buffers (host pages) the
// view is the buffer's memory, nothing copied; no bytes give a null view, not an error.
TEST(Context, ReadViewsShowTheBufferAndLetLaterKernelsWriteIt) {
  Context& ctx = test::ctx();
  for (const std::size_t w : {std::size_t(5), std::size_t(1024)}) {  // 20 bytes; 4 MiB
    const std::size_t h = w == 5 ? 1 : 1024, n = w * h;
    cl::Buffer b = ctx.buffer(n * 4, "test view");
    std::vector<float> ones(n, 1.0f);
    ctx.write(b, ones.data(), n * 4, "test view");
    void* host = b.getInfo<CL_MEM_HOST_PTR>();
    {
      const Context::ReadView view = ctx.mapRead(b, n * 4, "test view");
      const auto* v = static_cast<const float*>(view.data());
      ASSERT_NE(v, nullptr);
      EXPECT_EQ(v[0], 1.0f);
      EXPECT_EQ(v[n - 1], 1.0f);
      if (host) EXPECT_EQ(view.data(), host) << "a CPU buffer of host pages is viewed in place";
    }
    summedAreaTable(ctx, b, ScanType::Float, int(w), int(h), 1, "test/sat");
    Context::ReadView view = ctx.mapRead(b, n * 4, "test view");
    const auto* v = static_cast<const float*>(view.data());
    EXPECT_EQ(v[n - 1], float(n)) << w << " x " << h;
    view = Context::ReadView();
    EXPECT_EQ(view.data(), nullptr);
  }
  EXPECT_EQ(ctx.mapRead(ctx.buffer(16, "test view"), 0, "test view").data(), nullptr);
}

// Context::scratch: one buffer per role, handed out again once its lease is released while it is
// large enough (the same cl_mem), replaced by a larger one when a call needs more, kept apart from
// other roles, and never handed to a second holder while leased.
TEST(Context, ScratchBuffersAreReusedPerRoleAndGrow) {
  Context& ctx = test::ctx();
  cl_mem a = ctx.scratch("test scratch a", 256).buffer()();
  EXPECT_EQ(ctx.scratch("test scratch a", 100).buffer()(), a);
  EXPECT_EQ(ctx.scratch("test scratch a", 256).buffer()(), a);
  EXPECT_NE(ctx.scratch("test scratch b", 100).buffer()(), a);
  Context::ScratchLease big = ctx.scratch("test scratch a", 4096);
  EXPECT_GE(big.buffer().getInfo<CL_MEM_SIZE>(), 4096u);
  {
    // while `big` is leased, the role's next holder gets another buffer
    Context::ScratchLease other = ctx.scratch("test scratch a", 1000);
    EXPECT_NE(other.buffer()(), big.buffer()());
  }
  std::vector<int> v(1024, 7);
  ctx.write(big.buffer(), v.data(), v.size() * sizeof(int), "scratch");
  const cl_mem bigMem = big.buffer()();
  big = Context::ScratchLease();  // released
  // what one holder wrote is there for the next (the contents are the last holder's)
  Context::ScratchLease again = ctx.scratch("test scratch a", 1000);
  EXPECT_EQ(again.buffer()(), bigMem);
  EXPECT_EQ(ctx.download<int>(again.buffer(), 1024, "scratch"), v);
}

namespace {

namespace fs = std::filesystem;

// A fresh cache directory for one test, removed after it.
struct CacheDir {
  fs::path dir;
  explicit CacheDir(const std::string& name)
      : dir(fs::path(testing::TempDir()) /
            ("penumbra_program_cache_" + std::to_string(::getpid()) + "_" + name)) {
    fs::remove_all(dir);
  }
  ~CacheDir() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
  std::vector<fs::path> files() const {
    std::vector<fs::path> out;
    std::error_code ec;
    if (fs::is_directory(dir / "programs", ec))
      for (const auto& e : fs::directory_iterator(dir / "programs")) out.push_back(e.path());
    return out;
  }
};

// A 13x7 summed-area table of ones through `ctx`, in float and in 64-bit integers (the scan built
// for two element types: two programs), checked against its closed form (x+1)(y+1): a program
// made from a cached binary must compute the same.
template <typename T>
void expectSatOfOnes(Context& ctx, ScanType type) {
  const int w = 13, h = 7;
  std::vector<T> host(std::size_t(w) * h, T(1));
  cl::Buffer buf(ctx.context(), CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, host.size() * sizeof(T),
                 host.data());
  summedAreaTable(ctx, buf, type, w, h);
  ctx.queue().enqueueReadBuffer(buf, CL_TRUE, 0, host.size() * sizeof(T), host.data());
  int wrong = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) wrong += host[std::size_t(y) * w + x] != T((x + 1) * (y + 1));
  EXPECT_EQ(wrong, 0);
}

void expectSatOfOnes(Context& ctx) {
  expectSatOfOnes<float>(ctx, ScanType::Float);
  expectSatOfOnes<cl_long>(ctx, ScanType::Long);
}

// A Context of its own through expectSatOfOnes: what it took from the cache, compiled and stored.
Context::ProgramCacheStats runOnce() {
  Context ctx;
  expectSatOfOnes(ctx);
  return ctx.programCacheStats();
}

}  // namespace

TEST(ProgramCache, SecondContextMakesItsProgramsFromTheCache) {
  CacheDir cache("second");
  ScopedEnv env("PENUMBRA_CACHE_DIR", cache.dir.string());
  const Context::ProgramCacheStats first = runOnce();
  EXPECT_EQ(first.directory, (cache.dir / "programs").string());
  EXPECT_EQ(first.compiled, 2u);
  EXPECT_EQ(first.stored, first.compiled);
  EXPECT_EQ(first.fromCache, 0u);
  EXPECT_EQ(cache.files().size(), first.stored);
  const std::size_t compiled = first.compiled;
  Context second;
  expectSatOfOnes(second);
  const Context::ProgramCacheStats s = second.programCacheStats();
  EXPECT_EQ(s.fromCache, compiled);
  EXPECT_EQ(s.compiled, 0u);
  EXPECT_EQ(s.stored, 0u);
  // A program that fails to build is not stored.
  EXPECT_THROW(second.kernel("scan.cl", "scan_rows", "-DSCAN_T=not_a_type"), Error);
  EXPECT_EQ(cache.files().size(), compiled);
}

TEST(ProgramCache, DamagedFilesAreNeverUsedAndAreReplaced) {
  CacheDir cache("damaged");
  ScopedEnv env("PENUMBRA_CACHE_DIR", cache.dir.string());
  const std::size_t compiled = runOnce().compiled;
  const std::vector<fs::path> files = cache.files();
  ASSERT_EQ(files.size(), compiled);
  ASSERT_GE(files.size(), 2u);
  // One truncated, the rest with a byte of the binary flipped (the checksum catches it).
  fs::resize_file(files[0], fs::file_size(files[0]) / 2);
  for (std::size_t i = 1; i < files.size(); ++i) {
    std::fstream f(files[i], std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(std::streamoff(fs::file_size(files[i]) - 100));
    char c = 0;
    f.seekg(f.tellp());
    f.get(c);
    f.seekp(std::streamoff(fs::file_size(files[i]) - 100));
    f.put(char(c ^ 0x5a));
  }
  const Context::ProgramCacheStats second = runOnce();
  EXPECT_EQ(second.fromCache, 0u);
  EXPECT_EQ(second.compiled, compiled);
  EXPECT_EQ(second.stored, compiled);
  EXPECT_EQ(runOnce().fromCache, compiled);
}

TEST(ProgramCache, OffKeepsNothingAndAnUnwritableDirectoryCostsNothingButTime) {
  {
    CacheDir cache("off");
    ScopedEnv env("PENUMBRA_CACHE_DIR", std::string("off"));
    const Context::ProgramCacheStats s = runOnce();
    EXPECT_EQ(s.directory, "");
    EXPECT_EQ(s.stored, 0u);
    EXPECT_EQ(s.fromCache, 0u);
    EXPECT_GE(s.compiled, 1u);
  }
  {
    // A regular file where the directory should be: nothing can be stored, nothing fails.
    CacheDir cache("blocked");
    fs::create_directories(cache.dir);
    std::ofstream(cache.dir / "programs") << "not a directory";
    ScopedEnv env("PENUMBRA_CACHE_DIR", cache.dir.string());
    const Context::ProgramCacheStats s = runOnce();
    EXPECT_GE(s.compiled, 1u);
    EXPECT_EQ(s.stored, 0u);
  }
}

TEST(ProgramCache, KeyCoversDeviceOptionsAndSource) {
  CacheDir cache("keys");
  const std::string dir = (cache.dir / "programs").string();
  const detail::ProgramCache a(dir, "device A"), b(dir, "device B");
  EXPECT_NE(a.fileFor("src", "-O"), b.fileFor("src", "-O"));
  EXPECT_NE(a.fileFor("src", "-O"), a.fileFor("src", "-O2"));
  EXPECT_NE(a.fileFor("src", "-O"), a.fileFor("src2", "-O"));
  // Where the options end and the source begins is part of the key.
  EXPECT_NE(a.fileFor("xy", "-O"), a.fileFor("y", "-Ox"));
  EXPECT_TRUE(a.load("src", "-O").empty());
  const std::vector<unsigned char> binary = {1, 2, 3, 0, 255};
  EXPECT_TRUE(a.store("src", "-O", binary));
  EXPECT_EQ(a.load("src", "-O"), binary);
  EXPECT_TRUE(b.load("src", "-O").empty());
  EXPECT_TRUE(a.load("src", "-O2").empty());
  // A file renamed to another key's name is not that key's.
  fs::copy_file(a.fileFor("src", "-O"), a.fileFor("other", "-O"));
  EXPECT_TRUE(a.load("other", "-O").empty());
}
