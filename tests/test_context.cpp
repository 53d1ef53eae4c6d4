// OpenCL context: device selection, typed errors.
#include <gtest/gtest.h>

#include <cstdlib>
#include <optional>
#include <string>

#include "common.hpp"

using namespace penumbra;

namespace {

// Sets (or, given nullopt, unsets) an environment variable for one scope and puts back what the
// process had before, set or not: later tests in the same process (and a developer's own
// PENUMBRA_DEVICE) see the variable as it was.
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const std::optional<std::string>& value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    if (value) ::setenv(name, value->c_str(), 1);
    else ::unsetenv(name);
  }
  ~ScopedEnv() {
    if (old_) ::setenv(name_, old_->c_str(), 1);
    else ::unsetenv(name_);
  }
  ScopedEnv(const ScopedEnv&) = delete;
  ScopedEnv& operator=(const ScopedEnv&) = delete;

 private:
  const char* name_;
  std::optional<std::string> old_;
};

}  // namespace

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
