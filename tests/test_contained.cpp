// Tests for the child-process containment that untrusted parsers run in (src/core/contained.hpp):
// results and errors come back intact, and a child that aborts, loops or allocates without bound
// is reported as bad input within its limits while this process carries on.
#include <gtest/gtest.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>
#include <vector>

#include "core/contained.hpp"
#include "penumbra/context.hpp"
#include "penumbra/error.hpp"
#include "support/sanitizers.hpp"

using namespace penumbra;
using detail::ContainLimits;
using detail::runContained;

namespace {

ContainLimits limits(double seconds, std::size_t memoryMiB = 512) {
  ContainLimits l;
  l.seconds = seconds;
  l.memoryBytes = memoryMiB << 20;
  return l;
}

// The error runContained throws, or a failure when it returns.
Error failureOf(const ContainLimits& l, const std::function<std::string()>& work) {
  try {
    runContained("thing.bin", l, work);
  } catch (const Error& e) {
    return e;
  }
  ADD_FAILURE() << "runContained returned";
  return Error(ErrorKind::Internal, "");
}

double secondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

TEST(Contained, ResultComesBackWhole) {
  // Larger than a pipe's buffer many times over, with every byte value.
  std::string big(8u << 20, '\0');
  for (std::size_t i = 0; i < big.size(); ++i) big[i] = char((i * 2654435761u) >> 13);
  EXPECT_EQ(runContained("x", limits(30), [&] { return big; }), big);
  EXPECT_EQ(runContained("x", limits(30), [] { return std::string(); }), "");
}

TEST(Contained, ErrorsKeepKindAndMessage) {
  const Error e = failureOf(limits(30), []() -> std::string {
    throw Error(ErrorKind::OutOfMemory, "thing.bin: too big for the device");
  });
  EXPECT_EQ(e.kind(), ErrorKind::OutOfMemory);
  EXPECT_STREQ(e.what(), "thing.bin: too big for the device");
  const Error other = failureOf(limits(30), []() -> std::string {
    throw std::runtime_error("parser said no");
  });
  EXPECT_EQ(other.kind(), ErrorKind::BadInput);
  EXPECT_STREQ(other.what(), "thing.bin: parser said no");
}

TEST(Contained, AbortIsReportedWithTheChildsLastWords) {
  const Error e = failureOf(limits(30), []() -> std::string {
    std::fprintf(stderr, "first line\nassertion 'n > 0' failed\n");
    std::abort();
  });
  EXPECT_EQ(e.kind(), ErrorKind::BadInput);
  const std::string m = e.what();
  EXPECT_EQ(m.rfind("thing.bin: ", 0), 0u) << m;
  EXPECT_NE(m.find("Aborted"), std::string::npos) << m;
  EXPECT_NE(m.find("assertion 'n > 0' failed"), std::string::npos) << m;
  EXPECT_EQ(m.find("first line"), std::string::npos) << m;  // only the last line is quoted
  const Error segv = failureOf(limits(30), []() -> std::string {
    std::raise(SIGSEGV);
    return "";
  });
  EXPECT_EQ(segv.kind(), ErrorKind::BadInput);
  EXPECT_NE(std::string(segv.what()).find("Segmentation"), std::string::npos) << segv.what();
}

// A Context loads the OpenCL driver, whose compiler (libLLVM) installs a SIGSEGV handler in this
// process that returns from a raised signal: the child must still end by the signal (the child
// restores the default action; before it did, AbortIsReportedWithTheChildsLastWords failed when
// it ran after a test with a Context in the same process).
TEST(Contained, CrashAfterAContextIsStillACrash) {
  penumbra::Context ctx;
  const Error segv = failureOf(limits(30), []() -> std::string {
    std::raise(SIGSEGV);
    return "";
  });
  EXPECT_EQ(segv.kind(), ErrorKind::BadInput);
  EXPECT_NE(std::string(segv.what()).find("Segmentation"), std::string::npos) << segv.what();
}

TEST(Contained, EndlessLoopIsKilledAtTheLimit) {
  const auto t0 = std::chrono::steady_clock::now();
  const Error e = failureOf(limits(0.5), []() -> std::string {
    for (volatile unsigned long i = 0;; i = i + 1) {
    }
  });
  const double took = secondsSince(t0);
  EXPECT_EQ(e.kind(), ErrorKind::BadInput);
  EXPECT_NE(std::string(e.what()).find("longer than its limit of 0.5 s"), std::string::npos)
      << e.what();
  EXPECT_GE(took, 0.5);
  EXPECT_LT(took, 5.0);
  // A child that sleeps (no CPU) is stopped by the same wall-clock limit.
  const Error sleeper = failureOf(limits(0.3), []() -> std::string {
    for (;;) std::this_thread::sleep_for(std::chrono::seconds(1));
  });
  EXPECT_NE(std::string(sleeper.what()).find("longer than its limit"), std::string::npos);
}

TEST(Contained, AllocationBeyondTheLimitIsRefused) {
  const Error e = failureOf(limits(30, 64), []() -> std::string {
    std::vector<char> v(std::size_t{2} << 30, 1);  // 2 GiB against a 64 MiB limit
    return std::string(1, v[12345]);
  });
  EXPECT_EQ(e.kind(), ErrorKind::BadInput);
#if PENUMBRA_TEST_ASAN
  // AddressSanitizer's allocator reports the failed allocation and exits instead of throwing.
  EXPECT_NE(std::string(e.what()).find("without an answer"), std::string::npos) << e.what();
#else
  EXPECT_NE(std::string(e.what()).find("more memory than its limit of 64 MiB"), std::string::npos)
      << e.what();
#endif
}

TEST(Contained, ChildOutputDoesNotReachOurs) {
  // What the reader prints on stdout is discarded, not mixed into the caller's output.
  testing::internal::CaptureStdout();
  EXPECT_EQ(runContained("x", limits(30), [] {
              std::printf("noise from the reader\n");
              std::fflush(stdout);
              return std::string("ok");
            }),
            "ok");
  EXPECT_EQ(testing::internal::GetCapturedStdout(), "");
}
