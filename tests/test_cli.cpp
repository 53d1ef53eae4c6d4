// Tests for the `penumbra` command-line interface, run as a subprocess (fork/exec, stdout and
// stderr captured through pipes, PENUMBRA_DEVICE removed from the environment so the default device
// is used). Each test runs in its own fresh directory under testing::TempDir(), which is also the
// child's working directory, so relative output paths land there.
//
// Contract under test: every penumbra::Error becomes exactly one line on stderr and exit code 2,
// the line names the file or parameter at fault, and a failed run leaves no file behind (not even
// a hidden temporary one).
#include <gtest/gtest.h>

#include <fcntl.h>
#include <poll.h>
#include <pty.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include <OpenImageIO/imageio.h>

#include "penumbra/ambient.hpp"
#include "penumbra/error.hpp"
#include "penumbra/extraction.hpp"
#include "penumbra/image.hpp"
#include "penumbra/lights.hpp"
#include "penumbra/options.hpp"
#include "penumbra/reference.hpp"
#include "penumbra/version.hpp"

extern char** environ;

namespace fs = std::filesystem;
using namespace penumbra;

namespace {

const std::string kData = PENUMBRA_TEST_DATA;
const std::string kCli = PENUMBRA_CLI;

struct Result {
  int code = -1;  // exit status, or -signal if the child was killed
  std::string out, err;
};

// Runs the CLI with `args` in `cwd`; kills it after `timeoutS` seconds (reported as a failure).
Result runCli(const std::vector<std::string>& args, const fs::path& cwd, int timeoutS = 120,
              const std::vector<std::string>& extraEnv = {}) {
  Result r;
  // Everything the child needs is prepared before fork(): only async-signal-safe calls after it.
  std::vector<std::string> argStore;
  argStore.push_back(kCli);
  argStore.insert(argStore.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& s : argStore) argv.push_back(const_cast<char*>(s.c_str()));
  argv.push_back(nullptr);
  // An inherited variable that extraEnv sets again is dropped: getenv() returns the first match,
  // so a caller's OCL_ICD_VENDORS (bench/gpu/check.sh sets one) would shadow the test's.
  auto overridden = [&](const char* e) {
    for (auto& x : extraEnv)
      if (std::strncmp(e, x.c_str(), x.find('=') + 1) == 0) return true;
    return false;
  };
  std::vector<char*> envp;
  for (char** e = environ; *e; ++e)
    if (std::strncmp(*e, "PENUMBRA_DEVICE=", 16) != 0 && !overridden(*e)) envp.push_back(*e);
  for (auto& e : extraEnv) envp.push_back(const_cast<char*>(e.c_str()));
  envp.push_back(nullptr);
  std::string dir = cwd.string();

  int outPipe[2], errPipe[2];
  if (pipe2(outPipe, O_CLOEXEC) != 0 || pipe2(errPipe, O_CLOEXEC) != 0) {
    ADD_FAILURE() << "pipe2 failed: " << std::strerror(errno);
    return r;
  }
  pid_t pid = fork();
  if (pid < 0) {
    ADD_FAILURE() << "fork failed: " << std::strerror(errno);
    return r;
  }
  if (pid == 0) {
    if (chdir(dir.c_str()) != 0) _exit(126);
    dup2(outPipe[1], 1);
    dup2(errPipe[1], 2);
    int devnull = open("/dev/null", O_RDONLY);
    if (devnull >= 0) dup2(devnull, 0);
    execve(argv[0], argv.data(), envp.data());
    _exit(127);
  }
  close(outPipe[1]);
  close(errPipe[1]);
  auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(timeoutS);
  bool outOpen = true, errOpen = true, killed = false;
  char buf[4096];
  while (outOpen || errOpen) {
    auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
                    deadline - std::chrono::steady_clock::now())
                    .count();
    if (left <= 0) {
      kill(pid, SIGKILL);
      killed = true;
      break;
    }
    pollfd fds[2];
    int n = 0;
    if (outOpen) fds[n++] = {outPipe[0], POLLIN, 0};
    if (errOpen) fds[n++] = {errPipe[0], POLLIN, 0};
    int rc = poll(fds, nfds_t(n), int(std::min<long long>(left, 1000)));
    if (rc < 0 && errno != EINTR) break;
    for (int i = 0; i < n; ++i) {
      if (!(fds[i].revents & (POLLIN | POLLHUP | POLLERR))) continue;
      ssize_t got = read(fds[i].fd, buf, sizeof buf);
      bool isOut = fds[i].fd == outPipe[0];
      if (got > 0) {
        (isOut ? r.out : r.err).append(buf, std::size_t(got));
      } else if (got == 0 || errno != EINTR) {
        (isOut ? outOpen : errOpen) = false;
      }
    }
  }
  close(outPipe[0]);
  close(errPipe[0]);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (WIFEXITED(status))
    r.code = WEXITSTATUS(status);
  else if (WIFSIGNALED(status))
    r.code = -WTERMSIG(status);
  if (killed) ADD_FAILURE() << "penumbra timed out after " << timeoutS << " s";
  return r;
}

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

std::string describe(const Result& r) {
  return "exit " + std::to_string(r.code) + "\n--- stdout ---\n" + r.out + "\n--- stderr ---\n" +
         r.err;
}

std::string readText(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

// The number after "key": in a JSON text (first occurrence), or NaN if absent.
double jsonNumber(const std::string& json, const std::string& key) {
  auto k = json.find("\"" + key + "\"");
  if (k == std::string::npos) return std::nan("");
  auto colon = json.find(':', k);
  if (colon == std::string::npos) return std::nan("");
  const char* start = json.c_str() + colon + 1;
  char* end = nullptr;
  double v = std::strtod(start, &end);
  return end == start ? std::nan("") : v;
}

std::size_t count(const std::string& text, const std::string& needle) {
  std::size_t n = 0;
  for (auto p = text.find(needle); p != std::string::npos; p = text.find(needle, p + 1)) ++n;
  return n;
}

// Fast settings for the frame (tiny shadow maps and cube faces, few lights).
const std::vector<std::string> kFast = {"--lights", "8", "--shadow-map-size", "64",
                                        "--face-size", "32"};

std::vector<std::string> cat(std::vector<std::string> a, const std::vector<std::string>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

class CliFixture : public testing::Test {
 protected:
  void SetUp() override {
    const auto* info = testing::UnitTest::GetInstance()->current_test_info();
    std::string name = std::string(info->test_suite_name()) + "_" + info->name();
    for (char& c : name)
      if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
    dir_ = fs::path(testing::TempDir()) /
           ("penumbra_cli_" + std::to_string(getpid()) + "_" + name);
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    dir_ = fs::canonical(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    if (!HasFailure()) fs::remove_all(dir_, ec);
  }

  Result run(const std::vector<std::string>& args) { return runCli(args, dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  // Every entry in the test directory (hidden ones included).
  std::vector<std::string> entries() const {
    std::vector<std::string> out;
    for (auto& e : fs::directory_iterator(dir_)) out.push_back(e.path().filename().string());
    return out;
  }

  // The failure contract: exit 2, exactly one non-empty line on stderr containing every string of
  // `mentions`, no "wrote" on stdout, and nothing written to the test directory.
  void expectFailure(const std::vector<std::string>& args,
                     const std::vector<std::string>& mentions) {
    Result r = run(args);
    std::string what = describe(r);
    EXPECT_EQ(r.code, 2) << what;
    auto errLines = lines(r.err);
    EXPECT_EQ(errLines.size(), 1u) << what;
    EXPECT_TRUE(!r.err.empty() && r.err.back() == '\n') << what;
    if (!errLines.empty()) {
      EXPECT_FALSE(errLines[0].empty()) << what;
      for (auto& m : mentions) EXPECT_NE(errLines[0].find(m), std::string::npos) << m << "\n" << what;
    }
    EXPECT_EQ(r.out.find("wrote"), std::string::npos) << what;
    auto left = entries();
    EXPECT_TRUE(left.empty()) << "left behind: " << (left.empty() ? "" : left[0]) << "\n" << what;
  }

  // `render` of a bad input file with --out and --report into the test directory.
  void expectRenderFailure(const std::string& option, const std::string& file) {
    expectFailure({"render", option, file, "--size", "32x18", "--out", path("out.png"), "--report",
                   path("r.json")},
                  {file});
  }

  fs::path dir_;
};

// ---------------------------------------------------------------------------------------------
// 1. Broken input files: one line naming the file, exit 2, nothing written.

class CliBadInput : public CliFixture {};

TEST_F(CliBadInput, TruncatedEnvironment) {
  expectRenderFailure("--env", kData + "/envmaps/bad/truncated.exr");
}
TEST_F(CliBadInput, NotAnImageEnvironment) {
  expectRenderFailure("--env", kData + "/envmaps/bad/not_an_image.exr");
}
// A PNG environment cut short (here inside its image data) gets the same one line; libpng's own
// "libpng error" line used to come first.
TEST_F(CliBadInput, TruncatedPngEnvironment) {
  const fs::path src = fs::path(testing::TempDir()) /
                       ("penumbra_cut_png_" + std::to_string(::getpid()));
  fs::create_directories(src);
  const std::string whole = (src / "whole.png").string(), cut = (src / "cut.png").string();
  Image sky(64, 32, 3);
  for (std::size_t i = 0; i < sky.pixels.size(); ++i) sky.pixels[i] = float(i % 97) / 97.0f;
  writeImage(whole, sky);
  const std::uintmax_t size = fs::file_size(whole);
  fs::copy_file(whole, cut);
  fs::resize_file(cut, size - 20);
  expectRenderFailure("--env", cut);
  expectFailure({"lights", "--env", cut, "--out", path("l.json")}, {cut, "truncated"});
  fs::remove_all(src);
}
TEST_F(CliBadInput, MissingEnvironment) { expectRenderFailure("--env", path("missing.exr")); }
TEST_F(CliBadInput, MeshWithInfinites) {
  expectRenderFailure("--scene", kData + "/meshes/bad/BoxWithInfinites.glb");
}
TEST_F(CliBadInput, MeshIndexOutOfRange) {
  expectRenderFailure("--scene", kData + "/meshes/bad/IndexOutOfRange.gltf");
}
TEST_F(CliBadInput, PointCloudMesh) {
  expectRenderFailure("--scene", kData + "/meshes/bad/point_cloud.obj");
}
TEST_F(CliBadInput, MissingMesh) { expectRenderFailure("--scene", path("missing.obj")); }

// Meshes that took the process down before Assimp ran in a contained child (issue 14): an
// assertion abort inside Assimp, a header that made it loop, counts that made it allocate
// gigabytes. Each is one line, exit 2, nothing written, in seconds.
class CliUntrustedMesh : public CliFixture {
 protected:
  void expectQuickRenderFailure(const std::string& file, const std::string& problem) {
    const auto t0 = std::chrono::steady_clock::now();
    expectFailure({"render", "--scene", file, "--size", "32x18", "--out", path("out.png"),
                   "--report", path("r.json")},
                  {file, problem});
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 20.0);
  }
  // Written outside the test directory, which must stay empty.
  std::string scratch(const std::string& name, const std::string& bytes) {
    const fs::path p = dir_.parent_path() / (dir_.filename().string() + "_" + name);
    std::ofstream(p, std::ios::binary) << bytes;
    made_.push_back(p);
    return p.string();
  }
  void TearDown() override {
    for (const auto& p : made_) fs::remove(p);
    CliFixture::TearDown();
  }
  std::vector<fs::path> made_;
};

TEST_F(CliUntrustedMesh, PlyThatAbortsAssimp) {
  expectQuickRenderFailure(kData + "/meshes/bad/triangulate_abort.ply", "crashed");
}
TEST_F(CliUntrustedMesh, PlyHeaderCutShort) {
  expectQuickRenderFailure(scratch("cut.ply", "ply\nformat ascii 1.0\nelement vertex 8\nprop"),
                           "cut short");
}
TEST_F(CliUntrustedMesh, PlyCountBeyondTheFile) {
  expectQuickRenderFailure(
      scratch("huge.ply",
              "ply\nformat ascii 1.0\nelement vertex 99999999999999\nproperty float x\n"
              "property float y\nproperty float z\nelement face 1\n"
              "property list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"),
      "99999999999999 'vertex'");
}
TEST_F(CliUntrustedMesh, GlbChunkBeyondTheFile) {
  std::ifstream in(kData + "/meshes/bad/BoxWithInfinites.glb", std::ios::binary);
  std::string glb((std::istreambuf_iterator<char>(in)), {});
  ASSERT_GT(glb.size(), 20u);
  for (int k = 12; k < 16; ++k) glb[k] = char(0xff);  // JSON chunk length 0xFFFFFFFF
  expectQuickRenderFailure(scratch("chunk.glb", glb), "4294967295 bytes");
}
// The documented maximum size aborted inside PoCL after 2.9 s (issue 14); now it is refused
// before any device work, naming the size, the memory and the device's limit.
TEST_F(CliUntrustedMesh, SizeBeyondTheDeviceIsRefusedUpFront) {
  const auto t0 = std::chrono::steady_clock::now();
  expectFailure({"render", "--size", "16384x16384", "--out", path("out.png"), "--report",
                 path("r.json")},
                {"16384x16384", "MiB", "out of device memory"});
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 20.0);
}

TEST_F(CliUntrustedMesh, LoadLimitsAreOptions) {
  expectFailure({"render", "--scene", kData + "/meshes/good/WusonOBJ.obj", "--load-timeout",
                 "0.001", "--size", "32x18", "--out", path("out.png")},
                {"WusonOBJ.obj", "longer than its limit of 0.001 s"});
  expectFailure({"render", "--load-timeout", "-1", "--out", path("out.png")}, {"--load-timeout"});
  expectFailure({"render", "--load-memory", "0", "--out", path("out.png")}, {"--load-memory"});
}

// Every file in the bad-data folders that the brief lists is covered above; a new file there
// should get a test too.
TEST_F(CliBadInput, BadDataFoldersAreCovered) {
  std::vector<std::string> known = {"truncated.exr", "not_an_image.exr", "nan_inf_negative.exr",
                                    "one_pixel.exr", "BoxWithInfinites.glb",
                                    "IndexOutOfRange.gltf", "IndexOutOfRange.bin",
                                    "point_cloud.obj", "triangulate_abort.ply"};
  for (const char* sub : {"/envmaps/bad", "/meshes/bad"})
    for (auto& e : fs::directory_iterator(kData + sub)) {
      std::string f = e.path().filename().string();
      EXPECT_NE(std::find(known.begin(), known.end(), f), known.end()) << "untested: " << f;
    }
}

// A message that holds a line break (here a path with a newline) still becomes one line.
TEST_F(CliBadInput, LineBreakInMessageStaysOneLine) {
  Result r = run({"render", "--env", path("a\nb.exr"), "--out", path("out.png")});
  EXPECT_EQ(r.code, 2) << describe(r);
  EXPECT_EQ(lines(r.err).size(), 1u) << describe(r);
  EXPECT_NE(r.err.find("b.exr"), std::string::npos) << describe(r);
  EXPECT_TRUE(entries().empty());
}

// The same contract for lights and reference.
TEST_F(CliBadInput, LightsTruncatedEnvironment) {
  std::string f = kData + "/envmaps/bad/truncated.exr";
  expectFailure({"lights", "--env", f, "--out", path("l.json"), "--overlay", path("o.png")}, {f});
}
TEST_F(CliBadInput, ReferenceBadMesh) {
  std::string f = kData + "/meshes/bad/point_cloud.obj";
  expectFailure({"reference", "--scene", f, "--size", "16x9", "--spp", "1", "--out",
                 path("ref.exr")},
                {f});
}

// ---------------------------------------------------------------------------------------------
// 2. Maps that load: sanitized NaN/Inf/negative texels, a one-pixel map.

class CliEnvironment : public CliFixture {};

TEST_F(CliEnvironment, SanitizedMapRendersAndReports) {
  Result r = run(cat({"render", "--env", kData + "/envmaps/bad/nan_inf_negative.exr", "--size",
                      "64x36", "--out", "X.exr", "--report", "R.json"},
                     kFast));
  ASSERT_EQ(r.code, 0) << describe(r);
  ASSERT_TRUE(fs::is_regular_file(dir_ / "X.exr")) << describe(r);
  ASSERT_TRUE(fs::is_regular_file(dir_ / "R.json")) << describe(r);
  std::string json = readText(dir_ / "R.json");
  double sanitized = jsonNumber(json, "sanitized_pixels");
  EXPECT_GT(sanitized, 0) << json;
  // stderr reports how many pixels were replaced.
  EXPECT_NE(r.err.find("replaced " + std::to_string(std::int64_t(sanitized)) + " pixel"),
            std::string::npos)
      << describe(r);
  Image img = readImage((dir_ / "X.exr").string());
  EXPECT_EQ(img.width, 64);
  EXPECT_EQ(img.height, 36);
  for (float v : img.pixels) ASSERT_TRUE(std::isfinite(v));
}

TEST_F(CliEnvironment, OnePixelMapRenders) {
  Result r = run(cat({"render", "--env", kData + "/envmaps/bad/one_pixel.exr", "--size", "32x18",
                      "--out", "one.png"},
                     kFast));
  EXPECT_EQ(r.code, 0) << describe(r);
  EXPECT_TRUE(fs::is_regular_file(dir_ / "one.png")) << describe(r);
}

// ---------------------------------------------------------------------------------------------
// 3. Bad parameters: exit 2, one line naming the parameter, nothing written.

class CliParams : public CliFixture {
 protected:
  void expectBad(const std::vector<std::string>& extra, const std::string& mention) {
    SCOPED_TRACE(extra.empty() ? std::string() : extra[0]);
    std::vector<std::string> args = {"render", "--size", "16x9", "--out", path("out.png")};
    args.insert(args.end(), extra.begin(), extra.end());  // later options override earlier ones
    expectFailure(args, {mention});
  }
};

TEST_F(CliParams, LightsZero) { expectBad({"--lights", "0"}, "--lights"); }
TEST_F(CliParams, LightsNotANumber) { expectBad({"--lights", "abc"}, "--lights"); }
TEST_F(CliParams, SizeZero) { expectBad({"--size", "0x10"}, "--size"); }
TEST_F(CliParams, SizeWithoutHeight) { expectBad({"--size", "12"}, "--size"); }
TEST_F(CliParams, SizeEmptyHeight) { expectBad({"--size", "12x"}, "--size"); }
TEST_F(CliParams, UnknownShadows) { expectBad({"--shadows", "foo"}, "--shadows"); }
TEST_F(CliParams, ShadowMapSizeZero) { expectBad({"--shadow-map-size", "0"}, "--shadow-map-size"); }
TEST_F(CliParams, CameraTooFewNumbers) { expectBad({"--camera", "1,2"}, "--camera"); }
// Any format OpenImageIO writes is accepted (CliConventions.OutJpegWritesAJpeg); an extension
// without a writer is refused.
TEST_F(CliParams, OutUnsupportedExtension) { expectBad({"--out", path("file.xyz")}, "--out"); }
TEST_F(CliParams, OutMissingDirectory) {
  expectBad({"--out", "/nonexistent_dir/x.png"}, "--out");
}
TEST_F(CliParams, ReportWrongExtension) { expectBad({"--report", path("r.txt")}, "--report"); }
// An output path that is an existing directory is refused before any work: no image is written
// beside it and no hidden temporary file is left behind.
TEST_F(CliParams, OutputIsADirectory) {
  for (const char* which : {"--out", "--report"}) {
    SCOPED_TRACE(which);
    fs::create_directory(dir_ / "taken.png");
    fs::create_directory(dir_ / "taken.json");
    std::string out = std::string(which) == "--out" ? path("taken.png") : path("a.png");
    std::string report = std::string(which) == "--out" ? path("r.json") : path("taken.json");
    Result r = run(cat({"render", "--size", "16x9", "--out", out, "--report", report}, kFast));
    EXPECT_EQ(r.code, 2) << describe(r);
    EXPECT_EQ(lines(r.err).size(), 1u) << describe(r);
    EXPECT_NE(r.err.find(which), std::string::npos) << describe(r);
    auto left = entries();
    std::sort(left.begin(), left.end());
    EXPECT_EQ(left, (std::vector<std::string>{"taken.json", "taken.png"}));
    EXPECT_TRUE(fs::is_empty(dir_ / "taken.png"));
    EXPECT_TRUE(fs::is_empty(dir_ / "taken.json"));
    fs::remove(dir_ / "taken.png");
    fs::remove(dir_ / "taken.json");
  }
}
TEST_F(CliParams, UnknownOption) { expectBad({"--bogus"}, "--bogus"); }
// The library checks the field (RenderOptions.mssm.upperBoundTilt); the message names the option
// the user typed instead.
TEST_F(CliParams, LibraryFieldErrorsNameTheOption) {
  expectBad({"--upper-bound-tilt", "-1"}, "--upper-bound-tilt must be finite and >= 0");
  Result r = run({"render", "--size", "16x9", "--upper-bound-tilt", "-1"});
  EXPECT_EQ(r.err.find("RenderOptions"), std::string::npos) << describe(r);
}
TEST_F(CliParams, OptionWithoutValue) {
  // --lights as the last argument has no value.
  expectFailure({"render", "--out", path("out.png"), "--lights"}, {"--lights"});
}
TEST_F(CliParams, UnknownExtraction) { expectBad({"--extract", "foo"}, "--extract"); }
TEST_F(CliParams, NonFiniteExposure) { expectBad({"--exposure", "nan"}, "--exposure"); }
// The library's RenderOptions.shadow.contactTexels check, named by its flag.
TEST_F(CliParams, ContactTexelsZero) { expectBad({"--contact-texels", "0"}, "--contact-texels"); }
TEST_F(CliParams, ContactTexelsWithoutContactShadows) {
  expectBad({"--contact-texels", "4", "--no-contact-shadows"}, "--contact-texels");
}
TEST_F(CliParams, ContactMapsWithoutContactShadows) {
  expectBad({"--no-contact-maps", "--no-contact-shadows"}, "--no-contact-maps");
}
TEST_F(CliParams, UnknownCommand) { expectFailure({"frobnicate"}, {"frobnicate"}); }
TEST_F(CliParams, UnknownDevice) {
  expectFailure({"render", "--size", "16x9", "--out", path("out.png"), "--device",
                 "no-such-device-xyz"},
                {"no-such-device-xyz"});
}
TEST_F(CliParams, ReferenceSppZero) {
  expectFailure({"reference", "--size", "16x9", "--spp", "0", "--out", path("ref.exr")}, {"--spp"});
}
// Parameters are checked before any work: a bad --exposure is reported ahead of a bad scene.
TEST_F(CliParams, ReferenceExposureCheckedFirst) {
  expectFailure({"reference", "--size", "16x9", "--spp", "1", "--exposure", "nan", "--scene",
                 kData + "/meshes/bad/point_cloud.obj", "--out", path("ref.png")},
                {"--exposure"});
}
TEST_F(CliParams, LightsCommandBadCount) {
  expectFailure({"lights", "--lights", "abc", "--out", path("l.json")}, {"--lights"});
}
TEST_F(CliParams, TargetErrorWithoutAutoCount) {
  expectFailure({"lights", "--target-error", "0.05", "--out", path("l.json")}, {"--target-error"});
}
TEST_F(CliParams, AutoCountForAnotherMethod) {
  expectFailure({"lights", "--lights", "auto", "--extract", "greedy", "--out", path("l.json")},
                {"--lights auto", "greedy"});
}
TEST_F(CliParams, AutoCountBadTarget) {
  expectFailure({"lights", "--lights", "auto", "--target-error", "0", "--out", path("l.json")},
                {"--target-error"});
  expectFailure({"lights", "--lights", "auto", "--max-lights", "0", "--out", path("l.json")},
                {"--max-lights"});
}
// An error inside the progress bar's span (extraction, in reference) is still the only line: no
// "100%" before it.
TEST_F(CliParams, ReferenceErrorAfterProgressStartedIsOneLine) {
  expectFailure({"reference", "--size", "16x9", "--spp", "1", "--lights", "200", "--face-size", "4",
                 "--out", path("r.exr")},
                {"--lights", "96 texels"});
}
TEST_F(CliParams, LightsOverlayNotPng) {
  expectFailure({"lights", "--lights", "4", "--overlay", path("o.exr")}, {"--overlay"});
}

// ---------------------------------------------------------------------------------------------
// 4. --help for every command; 5. devices.

class CliHelp : public CliFixture {};

TEST_F(CliHelp, EveryCommand) {
  struct Case {
    std::string command;
    std::vector<std::string> mentions;
  };
  std::vector<Case> cases = {
      {"devices", {"usage: penumbra devices"}},
      {"render", {"usage: penumbra render", "--shadows", "--lights", "--out", "--report", "--size",
                  "--env", "--scene", "--shadow-map-size", "--camera"}},
      {"reference", {"usage: penumbra reference", "--spp", "--lights", "--out", "--size"}},
      {"compare", {"usage: penumbra compare", "--out", "reference_noise"}},
      {"evaluate", {"usage: penumbra evaluate", "--spp", "--truth", "--out-dir", "--json",
                    "--shadows", "--lights", "--size", "--camera"}},
      {"lights", {"usage: penumbra lights", "--lights", "--env", "--overlay", "--out", "--extract",
                  "center-surround", "--threshold", "--rect", "--stop", "--sizes", "--no-ambient"}},
  };
  for (auto& c : cases) {
    SCOPED_TRACE(c.command);
    Result r = run({c.command, "--help"});
    EXPECT_EQ(r.code, 0) << describe(r);
    EXPECT_TRUE(r.err.empty()) << describe(r);
    for (auto& m : c.mentions) EXPECT_NE(r.out.find(m), std::string::npos) << m << "\n" << describe(r);
  }
  EXPECT_TRUE(entries().empty());
}

TEST_F(CliHelp, TopLevel) {
  Result r = run({"--help"});
  EXPECT_EQ(r.code, 0) << describe(r);
  for (const char* c : {"devices", "render", "reference", "compare", "evaluate", "lights"})
    EXPECT_NE(r.out.find(c), std::string::npos) << c;
  Result v = run({"--version"});
  EXPECT_EQ(v.code, 0);
  EXPECT_FALSE(v.out.empty());
}

// Usage as an answer to a missing or unknown command is an error: stderr, exit 2, nothing on
// stdout (a script capturing stdout never takes it for a result). Asked for, it is the result.
TEST_F(CliHelp, UsageErrorsOnStderr) {
  Result none = run({});
  EXPECT_EQ(none.code, 2) << describe(none);
  EXPECT_TRUE(none.out.empty()) << describe(none);
  EXPECT_NE(none.err.find("usage: penumbra COMMAND"), std::string::npos) << describe(none);
  Result unknown = run({"rendr"});
  EXPECT_EQ(unknown.code, 2) << describe(unknown);
  EXPECT_TRUE(unknown.out.empty()) << describe(unknown);
  EXPECT_EQ(lines(unknown.err).size(), 1u) << describe(unknown);
  EXPECT_NE(unknown.err.find("rendr"), std::string::npos) << describe(unknown);
  for (const char* flag : {"--help", "-h"}) {
    SCOPED_TRACE(flag);
    Result r = run({flag});
    EXPECT_EQ(r.code, 0) << describe(r);
    EXPECT_TRUE(r.err.empty()) << describe(r);
    EXPECT_NE(r.out.find("usage: penumbra COMMAND"), std::string::npos) << describe(r);
  }
  EXPECT_TRUE(entries().empty());
}

class CliDevices : public CliFixture {};

TEST_F(CliDevices, ListsAtLeastOne) {
  Result r = run({"devices"});
  ASSERT_EQ(r.code, 0) << describe(r);
  auto out = lines(r.out);
  ASSERT_GE(out.size(), 1u) << describe(r);
  EXPECT_EQ(out[0].rfind("0: ", 0), 0u) << describe(r);
}

TEST_F(CliDevices, NoOpenCLPlatformNamesThePackage) {
  // ocl-icd finds no vendor files in a missing directory: no platform at all
  Result r = runCli({"render", "--out", path("out.png")}, dir_, 120,
                    {"OCL_ICD_VENDORS=" + path("no-vendors")});
  EXPECT_EQ(r.code, 2) << describe(r);
  auto err = lines(r.err);
  ASSERT_EQ(err.size(), 1u) << describe(r);
  EXPECT_NE(err[0].find("no OpenCL platform"), std::string::npos) << describe(r);
  EXPECT_NE(err[0].find("pocl-opencl-icd"), std::string::npos) << describe(r);
  EXPECT_TRUE(entries().empty());
}

TEST_F(CliDevices, UnknownDeviceIsRefused) {
  Result r = runCli({"devices"}, dir_);
  ASSERT_EQ(r.code, 0);
  expectFailure({"render", "--device", "no-such-device", "--out", path("out.png")},
                {"no-such-device"});
}

TEST_F(CliDevices, OutOfDeviceMemoryIsOneLineAndWritesNothing) {
  // 1024 lights x 4096^2 shadow maps need 64 GiB of depth maps alone
  expectFailure({"render", "--size", "64x36", "--lights", "1024", "--face-size", "64",
                 "--shadow-map-size", "4096", "--out", path("out.png"), "--report", path("r.json")},
                {"out of device memory", "shadow maps"});
}

// ---------------------------------------------------------------------------------------------
// 6. render: PNG + report, EXR with alpha.

class CliRender : public CliFixture {};

// OpenImageIO (about 260 shared libraries) is loaded only by a process that touches an image: the
// library reaches it through its own module, libpenumbra_oiio.so.<version>
// (core/image_codec.hpp). ld.so's LD_DEBUG=files lists every library a process loads, on stderr.
using CliImageModule = CliFixture;

TEST_F(CliImageModule, OnlyCommandsThatTouchImagesLoadOpenImageIO) {
  const std::vector<std::string> debug = {"LD_DEBUG=files"};
  const auto loadsOiio = [](const Result& r) {
    return r.err.find("libOpenImageIO.so") != std::string::npos;
  };
  const Result version = runCli({"--version"}, dir_, 120, debug);
  EXPECT_EQ(version.code, 0) << describe(version);
  EXPECT_FALSE(loadsOiio(version)) << describe(version);
  const Result devices = runCli({"devices"}, dir_, 120, debug);
  EXPECT_EQ(devices.code, 0) << describe(devices);
  EXPECT_FALSE(loadsOiio(devices)) << describe(devices);
  // lights prints and writes JSON only.
  const Result lights = runCli({"lights", "--lights", "4", "--out", "l.json"}, dir_, 120, debug);
  EXPECT_EQ(lights.code, 0) << describe(lights);
  EXPECT_FALSE(loadsOiio(lights)) << describe(lights);
  // A PNG, the default output, is written with libpng (core/png.hpp).
  const Result png = runCli({"render", "--size", "32x18", "--out", "a.png"}, dir_, 120, debug);
  EXPECT_EQ(png.code, 0) << describe(png);
  EXPECT_FALSE(loadsOiio(png)) << describe(png);
  EXPECT_TRUE(fs::exists(path("a.png")));
  // The control: writing an EXR loads it, through the module beside libpenumbra.
  const Result render =
      runCli({"render", "--size", "32x18", "--out", "a.exr"}, dir_, 120, debug);
  EXPECT_EQ(render.code, 0) << describe(render);
  EXPECT_TRUE(loadsOiio(render)) << describe(render);
  EXPECT_NE(render.err.find("libpenumbra_oiio.so"), std::string::npos) << describe(render);
}

TEST_F(CliImageModule, AMissingModuleIsNamedAndNothingIsWritten) {
  // A libpenumbra copied alone into a directory of its own (LD_LIBRARY_PATH comes before the
  // CLI's RUNPATH) looks for the module beside itself and finds none.
  const std::string soname = "libpenumbra.so." + std::to_string(PENUMBRA_VERSION_MAJOR) + "." +
                             std::to_string(PENUMBRA_VERSION_MINOR);
  const fs::path lib = fs::path(kCli).parent_path() / soname;
  ASSERT_TRUE(fs::exists(lib)) << lib;
  const fs::path alone = dir_ / "alone";
  fs::create_directories(alone);
  fs::copy_file(fs::canonical(lib), alone / soname);
  const fs::path work = dir_ / "work";
  fs::create_directories(work);
  const std::vector<std::string> env = {"LD_LIBRARY_PATH=" + alone.string()};
  const Result version = runCli({"--version"}, work, 120, env);
  EXPECT_EQ(version.code, 0) << describe(version);
  for (const std::string out : {"a.exr", "a.jpg"}) {
    const Result r = runCli({"render", "--size", "32x18", "--out", out}, work, 120, env);
    EXPECT_EQ(r.code, 2) << describe(r);
    EXPECT_EQ(lines(r.err).size(), 1u) << describe(r);
    EXPECT_NE(r.err.find((alone / ("libpenumbra_oiio.so." PENUMBRA_VERSION)).string() +
                         " (installed beside libpenumbra) cannot be loaded"),
              std::string::npos)
        << describe(r);
  }
  EXPECT_TRUE(fs::is_empty(work));
  // PNG needs no module.
  const Result png = runCli({"render", "--size", "32x18", "--out", "a.png"}, work, 120, env);
  EXPECT_EQ(png.code, 0) << describe(png);
  EXPECT_TRUE(fs::exists(work / "a.png"));
  const Result compare = runCli({"compare", kData + "/envmaps/courtyard.hdr", kData + "/envmaps/courtyard.hdr"},
                                work, 120, env);
  EXPECT_EQ(compare.code, 2) << describe(compare);
  EXPECT_NE(compare.err.find("libpenumbra_oiio.so"), std::string::npos) << describe(compare);
}

TEST_F(CliRender, PngAndReport) {
  Result r = run({"render", "--size", "96x54", "--lights", "8", "--shadow-map-size", "64",
                  "--face-size", "32", "--out", "a.png", "--report", "r.json"});
  ASSERT_EQ(r.code, 0) << describe(r);
  // stdout names the picture by its absolute path.
  EXPECT_NE(r.out.find("wrote " + (dir_ / "a.png").string()), std::string::npos) << describe(r);
  ASSERT_TRUE(fs::is_regular_file(dir_ / "a.png"));
  std::string bytes = readText(dir_ / "a.png");
  ASSERT_GE(bytes.size(), 8u);
  EXPECT_EQ(bytes.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  Image img = readImage((dir_ / "a.png").string());
  EXPECT_EQ(img.width, 96);
  EXPECT_EQ(img.height, 54);
  EXPECT_GE(img.channels, 3);
  float lo = 1e9f, hi = -1e9f;
  for (float v : img.pixels) lo = std::min(lo, v), hi = std::max(hi, v);
  EXPECT_LT(lo, hi) << "flat image";

  ASSERT_TRUE(fs::is_regular_file(dir_ / "r.json"));
  std::string json = readText(dir_ / "r.json");
  for (const char* key : {"\"device\"", "\"lights\"", "\"sanitized_pixels\"", "\"timings_ms\"",
                          "\"total\""})
    EXPECT_NE(json.find(key), std::string::npos) << key << "\n" << json;
  EXPECT_EQ(jsonNumber(json, "lights"), 8) << json;
  EXPECT_EQ(jsonNumber(json, "sanitized_pixels"), 0) << json;
  EXPECT_GT(jsonNumber(json, "total"), 0) << json;
  // Start-up on its own line: the loader before main() (from /proc, 10 ms ticks) and main() to
  // the first frame, both measured, neither the frame's.
  const nlohmann::json report = nlohmann::json::parse(json);
  ASSERT_TRUE(report.contains("startup_ms")) << json;
  EXPECT_TRUE(report["startup_ms"]["loader"].is_number()) << json;
  EXPECT_GE(report["startup_ms"]["loader"].get<double>(), 0.0) << json;
  EXPECT_GT(report["startup_ms"]["setup"].get<double>(), 0.0) << json;
  // The frame's programs, from the program cache or compiled (Context::programCacheStats).
  ASSERT_TRUE(report.contains("programs")) << json;
  EXPECT_GT(report["programs"]["from_cache"].get<int>() + report["programs"]["compiled"].get<int>(),
            0) << json;
  EXPECT_TRUE(report["programs"]["cache"].is_string()) << json;
  // Exactly the two outputs, no leftover temporaries.
  auto left = entries();
  EXPECT_EQ(left.size(), 2u);
}

TEST_F(CliRender, ExrHasAlpha) {
  Result r = run(cat({"render", "--size", "48x27", "--out", "a.exr", "--shadows", "none"}, kFast));
  ASSERT_EQ(r.code, 0) << describe(r);
  Image img = readImage((dir_ / "a.exr").string());
  EXPECT_EQ(img.width, 48);
  EXPECT_EQ(img.height, 27);
  ASSERT_EQ(img.channels, 4);
  int zeros = 0, ones = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      float a = img.at(x, y, 3);
      zeros += a == 0.0f;
      ones += a == 1.0f;
    }
  EXPECT_GT(zeros, 0);
  EXPECT_GT(ones, 0);
  EXPECT_EQ(zeros + ones, img.width * img.height) << "alpha is a coverage mask";
}

// ---------------------------------------------------------------------------------------------
// 7. lights.

class CliLights : public CliFixture {};

TEST_F(CliLights, JsonAndOverlay) {
  Result r = run({"lights", "--lights", "8", "--face-size", "32", "--out", "l.json", "--overlay",
                  "o.png"});
  ASSERT_EQ(r.code, 0) << describe(r);
  ASSERT_TRUE(fs::is_regular_file(dir_ / "l.json"));
  std::string json = readText(dir_ / "l.json");
  EXPECT_EQ(jsonNumber(json, "count"), 8) << json;
  EXPECT_EQ(count(json, "\"direction\""), 8u) << json;
  ASSERT_TRUE(fs::is_regular_file(dir_ / "o.png"));
  Image overlay = readImage((dir_ / "o.png").string());
  EXPECT_GT(overlay.width, 0);
  EXPECT_GT(overlay.height, 0);
  EXPECT_EQ(entries().size(), 2u);
}

// --lights auto: the count chosen to the target is said on stderr with each count tried, and is
// the count written.
// (5%: with its sun a light of its own, the built-in sky meets 8% at the first count tried, 4.)
TEST_F(CliLights, AutoCountMeetsTheTarget) {
  Result r = run({"lights", "--lights", "auto", "--target-error", "0.05", "--face-size", "32",
                  "--out", "l.json"});
  ASSERT_EQ(r.code, 0) << describe(r);
  const std::string key = "--lights auto: ";
  const std::size_t at = r.err.find(key);
  ASSERT_NE(at, std::string::npos) << describe(r);
  const int said = std::atoi(r.err.c_str() + at + key.size());
  EXPECT_NE(r.err.find("<= target 5%"), std::string::npos) << describe(r);
  EXPECT_NE(r.err.find("(tried 4: "), std::string::npos) << describe(r);
  const LightSet set = loadLightSet((dir_ / "l.json").string());
  EXPECT_EQ(int(set.lights.size()), said) << describe(r);
  EXPECT_GT(said, 4);
  EXPECT_LT(said, 64);
  // --quiet says nothing (render, which has it)
  Result q = run({"render", "--size", "16x9", "--lights", "auto", "--target-error", "0.08",
                  "--face-size", "32", "--shadows", "hard", "-q", "--out", "x.png"});
  ASSERT_EQ(q.code, 0) << describe(q);
  EXPECT_EQ(q.err.find("--lights auto"), std::string::npos) << describe(q);
}

TEST_F(CliLights, JsonOnStdout) {
  Result r = run({"lights", "--lights", "3", "--face-size", "16"});
  ASSERT_EQ(r.code, 0) << describe(r);
  EXPECT_EQ(count(r.out, "\"direction\""), 3u) << describe(r);
  EXPECT_TRUE(entries().empty());
}

// A map with NaN/Inf/negative texels: lights says on stderr how many pixels were replaced, as
// render does, and records the count in the JSON, which still loads as a light set.
TEST_F(CliLights, SanitizedPixelsReportedAndRecorded) {
  Result r = run({"lights", "--env", kData + "/envmaps/bad/nan_inf_negative.exr", "--lights", "4",
                  "--face-size", "16", "--out", "l.json"});
  ASSERT_EQ(r.code, 0) << describe(r);
  const std::string json = readText(dir_ / "l.json");
  const double sanitized = jsonNumber(json, "sanitized_pixels");
  EXPECT_GT(sanitized, 0) << json;
  EXPECT_NE(r.err.find("replaced " + std::to_string(std::int64_t(sanitized)) + " pixel"),
            std::string::npos)
      << describe(r);
  EXPECT_EQ(loadLightSet((dir_ / "l.json").string()).lights.size(), 4u);
  // a clean map records zero and says nothing
  Result clean = run({"lights", "--lights", "3", "--face-size", "16"});
  ASSERT_EQ(clean.code, 0) << describe(clean);
  EXPECT_EQ(jsonNumber(clean.out, "sanitized_pixels"), 0) << clean.out;
  EXPECT_EQ(clean.err.find("replaced"), std::string::npos) << describe(clean);
}

// The ambient residual is in the JSON by default (9 RGB coefficients and their power); with
// --no-ambient it is recorded as absent and zero.
TEST_F(CliLights, AmbientInJsonUnlessNoAmbient) {
  Result r = run({"lights", "--lights", "4", "--face-size", "16"});
  ASSERT_EQ(r.code, 0) << describe(r);
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["ambient"], true) << r.out;
  ASSERT_TRUE(j["ambient_sh"].is_array()) << r.out;
  ASSERT_EQ(j["ambient_sh"].size(), 9u) << r.out;  // 9 RGB triples
  for (const auto& c : j["ambient_sh"]) EXPECT_EQ(c.size(), 3u) << r.out;
  ASSERT_TRUE(j["ambient_power"].is_array()) << r.out;
  EXPECT_EQ(j["ambient_power"].size(), 3u) << r.out;
  // the key order a reader sees: the count of sanitized pixels second
  EXPECT_EQ(std::next(nlohmann::ordered_json::parse(r.out).items().begin()).key(),
            "sanitized_pixels");
  Result n = run({"lights", "--lights", "4", "--face-size", "16", "--no-ambient"});
  ASSERT_EQ(n.code, 0) << describe(n);
  const nlohmann::json k = nlohmann::json::parse(n.out);
  EXPECT_EQ(k["ambient"], false) << n.out;
  EXPECT_EQ(k["ambient_power"], nlohmann::json::array({0, 0, 0})) << n.out;
  EXPECT_TRUE(entries().empty());
}

// Every method through --extract, with its own options; the overlay for each.
TEST_F(CliLights, EveryMethodWithItsOptions) {
  const std::vector<std::vector<std::string>> runs = {
      {"--extract", "median-cut", "--lights", "6", "--face-size", "16"},
      {"--extract", "greedy", "--threshold", "0.05", "--rect", "--face-size", "16"},
      {"--extract", "center-surround", "--stop", "0.05", "--sizes", "8"},
  };
  for (auto& extra : runs) {
    SCOPED_TRACE(extra[1]);
    Result r = run(cat({"lights", "--out", "l.json", "--overlay", "o.png"}, extra));
    ASSERT_EQ(r.code, 0) << describe(r);
    std::string json = readText(dir_ / "l.json");
    EXPECT_NE(json.find("\"method\": \"" + extra[1] + "\""), std::string::npos) << json;
    EXPECT_GE(jsonNumber(json, "count"), 1) << json;
    EXPECT_NE(json.find("\"ambient\": true"), std::string::npos) << json;
    EXPECT_TRUE(fs::is_regular_file(dir_ / "o.png"));
  }
}

// Bad method names and options of another method: exit 2, one line naming the option and value.
TEST_F(CliLights, BadExtractionOptions) {
  expectFailure({"lights", "--extract", "median_cut", "--out", path("l.json")},
                {"--extract", "median_cut", "median-cut", "greedy", "center-surround"});
  expectFailure({"lights", "--threshold", "0.05", "--out", path("l.json")},
                {"--threshold", "greedy"});
  expectFailure({"lights", "--extract", "greedy", "--stop", "0.1"}, {"--stop", "center-surround"});
  expectFailure({"lights", "--extract", "center-surround", "--face-size", "32"}, {"--face-size"});
  expectFailure({"lights", "--extract", "center-surround", "--rect"}, {"--rect", "greedy"});
  expectFailure({"lights", "--extract", "greedy", "--threshold", "abc"}, {"--threshold", "abc"});
  expectFailure({"lights", "--extract", "greedy", "--threshold", "1.5"}, {"--threshold", "1.5"});
  expectFailure({"lights", "--extract", "center-surround", "--stop", "-1"}, {"--stop"});
  expectFailure({"lights", "--extract", "center-surround", "--sizes", "0"}, {"--sizes"});
}

// --ambient map (default) writes the irradiance map, --ambient sh9 only the coefficients,
// --ambient-size sets the table; bad values and contradictions exit 2 naming the option.
TEST_F(CliLights, AmbientModelAndSize) {
  Result d = run({"lights", "--lights", "4", "--face-size", "16"});
  ASSERT_EQ(d.code, 0) << describe(d);
  const nlohmann::json dj = nlohmann::json::parse(d.out);
  const AmbientOptions defaults;
  EXPECT_EQ(dj["ambient_map"]["width"], defaults.mapWidth) << d.out;
  EXPECT_EQ(dj["ambient_map"]["height"], defaults.mapHeight) << d.out;
  Result s = run({"lights", "--lights", "4", "--face-size", "16", "--ambient", "sh9"});
  ASSERT_EQ(s.code, 0) << describe(s);
  const nlohmann::json sj = nlohmann::json::parse(s.out);
  EXPECT_FALSE(sj.contains("ambient_map")) << s.out;
  EXPECT_EQ(sj["ambient_sh"].size(), 9u) << s.out;
  Result m = run({"lights", "--lights", "4", "--face-size", "16", "--ambient", "map",
                  "--ambient-size", "5x3", "--out", "l.json"});
  ASSERT_EQ(m.code, 0) << describe(m);
  penumbra::LightSet back = penumbra::loadLightSet(path("l.json"));
  EXPECT_EQ(back.ambientMap.width, 5);
  EXPECT_EQ(back.ambientMap.height, 3);
  EXPECT_EQ(back.ambientMap.rgb.size(), 45u);
  fs::remove(dir_ / "l.json");  // the failures below must leave nothing behind
  expectFailure({"lights", "--ambient", "sh2"}, {"--ambient", "sh2", "map", "sh9"});
  expectFailure({"lights", "--ambient-size", "0x3"}, {"--ambient-size", "0"});
  expectFailure({"lights", "--ambient-size", "64"}, {"--ambient-size", "64"});
  expectFailure({"lights", "--ambient", "sh9", "--ambient-size", "8x4"}, {"--ambient-size", "sh9"});
  expectFailure({"lights", "--no-ambient", "--ambient", "map"}, {"--ambient", "--no-ambient"});
}

TEST_F(CliLights, TruncatedEnvironmentFails) {
  std::string f = kData + "/envmaps/bad/truncated.exr";
  expectFailure({"lights", "--env", f}, {f});
}

// ---------------------------------------------------------------------------------------------
// 8. reference and compare.

class CliReference : public CliFixture {};

// Not on a terminal (the test's pipe), progress comes as one line per 10% with the time left
// ("reference: 50% (ETA 1.2 s)"), rising, ending at "reference: 100% in N s". One thread
// reports after every row; with more, a frame this small may finish between two looks. --quiet
// (-q) silences it.
TEST_F(CliReference, ProgressLinesWhenNotATerminal) {
  Result r = run({"reference", "--size", "16x20", "--spp", "1", "--threads", "1", "--out",
                  "ref.exr"});
  ASSERT_EQ(r.code, 0) << describe(r);
  const auto err = lines(r.err);
  ASSERT_FALSE(err.empty()) << describe(r);
  const std::string duration = "([0-9]+\\.[0-9] s|[0-9]+ s|[0-9]+m[0-9]{2}s|[0-9]+h[0-9]{2}m)";
  EXPECT_TRUE(std::regex_match(err.back(), std::regex("reference: 100% in " + duration)))
      << describe(r);
  const std::regex step("reference: ([1-9]0)% \\(ETA " + duration + "\\)");
  int last = 0;
  bool half = false;
  for (std::size_t i = 0; i + 1 < err.size(); ++i) {
    std::smatch m;
    ASSERT_TRUE(std::regex_match(err[i], m, step)) << err[i] << "\n" << describe(r);
    const int percent = std::stoi(m[1]);
    EXPECT_GT(percent, last) << describe(r);
    last = percent;
    half |= percent == 50;
  }
  EXPECT_TRUE(half) << describe(r);
  EXPECT_LE(err.size(), 10u) << describe(r);
  for (const char* quiet : {"--quiet", "-q"}) {
    Result q = run({"reference", "--size", "16x20", "--spp", "1", "--threads", "1", "--out",
                    "ref.exr", quiet});
    ASSERT_EQ(q.code, 0) << describe(q);
    EXPECT_TRUE(q.err.empty()) << describe(q);
  }
}

// --spp is bounded (1 to 1048576, stated in --help): beyond it, one line naming the flag.
// Any extraction option asks for the light-set reference, not only --lights and --extract (the
// help says so; --face-size alone used to be checked and then ignored).
TEST_F(CliReference, AnyExtractionOptionMeansTheLightSet) {
  for (const std::vector<std::string>& option :
       {std::vector<std::string>{"--face-size", "16"}, {"--light-texture", "2"}, {"--no-ambient"}}) {
    Result r = run(cat({"reference", "--size", "16x9", "--spp", "1", "-q", "--out", "r.exr"},
                       option));
    ASSERT_EQ(r.code, 0) << describe(r);
    EXPECT_NE(r.out.find("light-set reference"), std::string::npos) << option[0] << describe(r);
  }
  Result env = run({"reference", "--size", "16x9", "--spp", "1", "-q", "--out", "r.exr"});
  ASSERT_EQ(env.code, 0) << describe(env);
  EXPECT_EQ(env.out.find("light-set reference"), std::string::npos) << describe(env);
}
TEST_F(CliReference, SppBeyondTheMaximumIsRefused) {
  expectFailure({"reference", "--size", "16x9", "--spp", "1048577", "--out", path("ref.exr")},
                {"--spp", "1048576"});
  Result help = run({"reference", "--help"});
  EXPECT_NE(help.out.find("1048576"), std::string::npos) << describe(help);
}

TEST_F(CliReference, EnvironmentLightSetAndCompare) {
  Result env = run({"reference", "--size", "32x18", "--spp", "4", "--out", "ref.exr"});
  ASSERT_EQ(env.code, 0) << describe(env);
  EXPECT_NE(env.out.find("wrote " + (dir_ / "ref.exr").string()), std::string::npos)
      << describe(env);
  Result ls = run({"reference", "--lights", "8", "--face-size", "32", "--size", "32x18", "--spp",
                   "4", "--out", "refl.exr"});
  ASSERT_EQ(ls.code, 0) << describe(ls);
  Image a = readImage((dir_ / "ref.exr").string());
  Image b = readImage((dir_ / "refl.exr").string());
  EXPECT_EQ(a.width, 32);
  EXPECT_EQ(a.height, 18);
  EXPECT_EQ(b.width, 32);
  EXPECT_EQ(b.height, 18);

  Result cmp = run({"compare", "refl.exr", "ref.exr", "--out", "m.json"});
  ASSERT_EQ(cmp.code, 0) << describe(cmp);
  // Two different images (the light set misses part of the map's light): every error is
  // positive, the largest error is at least the RMS one (values hand-checked in
  // CliCompare.MatchesHandComputedMetrics).
  for (const char* key : {"rmse", "relative_rmse", "psnr", "max_abs_error"}) {
    double v = jsonNumber(cmp.out, key);
    EXPECT_TRUE(std::isfinite(v) && v > 0) << key << "\n" << describe(cmp);
  }
  EXPECT_GE(jsonNumber(cmp.out, "max_abs_error"), jsonNumber(cmp.out, "rmse")) << cmp.out;
  EXPECT_EQ(readText(dir_ / "m.json"), cmp.out);

  // Missing reference: exit 2, the line names the file.
  Result missing = run({"compare", "ref.exr", "missing.exr"});
  EXPECT_EQ(missing.code, 2) << describe(missing);
  EXPECT_EQ(lines(missing.err).size(), 1u) << describe(missing);
  EXPECT_NE(missing.err.find("missing.exr"), std::string::npos) << describe(missing);
  EXPECT_FALSE(fs::exists(dir_ / "missing.exr"));
}

class CliCompare : public CliFixture {};

TEST_F(CliCompare, IdenticalImages) {
  Image img(8, 4, 4, 1.0f);  // alpha 1: every pixel is compared
  writeImage(path("a.exr"), img);
  Result r = run({"compare", "a.exr", "a.exr"});
  ASSERT_EQ(r.code, 0) << describe(r);
  EXPECT_EQ(jsonNumber(r.out, "rmse"), 0) << describe(r);
  EXPECT_EQ(jsonNumber(r.out, "max_abs_error"), 0) << describe(r);
  EXPECT_NE(r.out.find("\"psnr\""), std::string::npos) << describe(r);
}

// compare --heatmap draws the error over B's geometry with a colour scale under it (heatmap.hpp):
// the image is as wide as B and taller by the scale bar; the one pixel that differs is the hottest
// (brightest) of the image rows, B's background is the neutral grey, the JSON names the file and
// the scale. Wrong uses write nothing and exit 2 naming the option.
TEST_F(CliCompare, HeatmapShowsWhereTheImagesDiffer) {
  Image b(40, 20, 4, 1.0f), a(40, 20, 4, 1.0f);
  for (int y = 0; y < 20; ++y)
    for (int x = 30; x < 40; ++x) b.at(x, y, 3) = a.at(x, y, 3) = 0.0f;  // background on the right
  for (int c = 0; c < 3; ++c) a.at(7, 5, c) = 2.0f;  // one pixel twice as bright
  writeImage(path("a.exr"), a);
  writeImage(path("b.exr"), b);
  Result r = run({"compare", "a.exr", "b.exr", "--heatmap", "h.png"});
  ASSERT_EQ(r.code, 0) << describe(r);
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["heatmap"], "h.png") << r.out;
  // A heat-map name that is not UTF-8 is written into the metrics as U+FFFD, still valid JSON.
  Result latin = run({"compare", "a.exr", "b.exr", "--heatmap", "caf\xe9.png"});
  ASSERT_EQ(latin.code, 0) << describe(latin);
  EXPECT_EQ(nlohmann::json::parse(latin.out)["heatmap"], "caf\xef\xbf\xbd.png") << latin.out;
  fs::remove(dir_ / "caf\xe9.png");
  EXPECT_GT(j["heatmap_scale"].get<double>(), 0.0) << r.out;
  const Image h = readImage(path("h.png"));
  EXPECT_EQ(h.width, 40);
  EXPECT_GT(h.height, 20);  // the scale bar below
  auto lum = [&](int x, int y) { return h.at(x, y, 0) + h.at(x, y, 1) + h.at(x, y, 2); };
  for (int y = 0; y < 20; ++y)
    for (int x = 0; x < 30; ++x)
      if (x != 7 || y != 5) EXPECT_LT(lum(x, y), lum(7, 5)) << x << "," << y;
  EXPECT_NEAR(h.at(35, 10, 0), h.at(35, 10, 1), 1e-6);  // grey: the background
  EXPECT_NEAR(h.at(35, 10, 1), h.at(35, 10, 2), 1e-6);
  EXPECT_GT(h.at(35, 10, 0), 0.1f);  // not black: it is not the zero-error colour either

  // The failure contract of expectFailure, but the inputs stay in the directory: exit 2, one
  // line naming every mention, and the heat map not written.
  auto refused = [&](const std::vector<std::string>& args, const std::string& output,
                     const std::vector<std::string>& mentions) {
    Result f = run(args);
    EXPECT_EQ(f.code, 2) << describe(f);
    const auto errLines = lines(f.err);
    ASSERT_EQ(errLines.size(), 1u) << describe(f);
    for (const auto& m : mentions)
      EXPECT_NE(errLines[0].find(m), std::string::npos) << m << "\n" << describe(f);
    EXPECT_FALSE(fs::exists(dir_ / output)) << output;
  };
  refused({"compare", "a.exr", "b.exr", "--heatmap", "h.exr"}, "h.exr", {"--heatmap", "8-bit"});
  refused({"compare", "a.exr", "b.exr", "--heatmap", "h2.png", "--heatmap-metric", "bogus"},
          "h2.png", {"--heatmap-metric", "bogus"});
  refused({"compare", "a.exr", "b.exr", "--heatmap-scale", "0.1"}, "h2.png",
          {"--heatmap-scale", "--heatmap"});
  Image small(8, 4, 4, 1.0f);
  writeImage(path("s.exr"), small);
  refused({"compare", "s.exr", "b.exr", "--heatmap", "h3.png"}, "h3.png", {"8x4", "40x20"});
  EXPECT_FALSE(fs::exists(dir_ / "h3.png"));
}

// compare's numbers against values worked out by hand from the definitions in reference.hpp and
// README ("compare"): over B's geometry pixels (alpha > 0.5) and RGB, RMSE = sqrt(mean d^2),
// relative RMSE = RMSE / mean(B), PSNR = 20 log10(max(B) / RMSE), max abs error = max |d|.
// B has two geometry pixels, (1,2,3) and (3,2,1): mean 2, max 3. A differs by (2,0,0) and
// (0,-1,1): sum d^2 = 6 over 6 values, RMSE 1, relative 0.5, PSNR 20 log10 3, max |d| 2. A third
// pixel where B's alpha is 0 differs by 100 and must not count; A's own alpha (0 on the compared
// pixels) must not mask anything. Every value is exact in the EXR's floats.
TEST_F(CliCompare, MatchesHandComputedMetrics) {
  Image a(3, 1, 4, 0.0f), b(3, 1, 4, 0.0f);
  const float bPix[3][4] = {{1, 2, 3, 1}, {3, 2, 1, 1}, {5, 5, 5, 0}};
  const float aPix[3][4] = {{3, 2, 3, 0}, {3, 1, 2, 0}, {105, 105, 105, 1}};
  for (int x = 0; x < 3; ++x)
    for (int c = 0; c < 4; ++c) a.at(x, 0, c) = aPix[x][c], b.at(x, 0, c) = bPix[x][c];
  writeImage(path("a.exr"), a);
  writeImage(path("b.exr"), b);
  Result r = run({"compare", "a.exr", "b.exr"});
  ASSERT_EQ(r.code, 0) << describe(r);
  EXPECT_NEAR(jsonNumber(r.out, "rmse"), 1.0, 1e-12) << r.out;
  EXPECT_NEAR(jsonNumber(r.out, "relative_rmse"), 0.5, 1e-12) << r.out;
  EXPECT_NEAR(jsonNumber(r.out, "psnr"), 9.5424250943932487, 1e-9) << r.out;  // 20 log10(3)
  EXPECT_NEAR(jsonNumber(r.out, "max_abs_error"), 2.0, 1e-12) << r.out;
  EXPECT_EQ(jsonNumber(r.out, "pixels"), 2) << r.out;

  // Without alpha in B every pixel counts: the third one adds 3 x 100^2 to sum d^2 over 9 values,
  // mean(B) = (12 + 15) / 9 = 3, max(B) = 5, max |d| = 100.
  Image b3(3, 1, 3, 0.0f);
  for (int x = 0; x < 3; ++x)
    for (int c = 0; c < 3; ++c) b3.at(x, 0, c) = bPix[x][c];
  writeImage(path("b3.exr"), b3);
  Result all = run({"compare", "a.exr", "b3.exr"});
  ASSERT_EQ(all.code, 0) << describe(all);
  const double rmse = std::sqrt((6.0 + 3 * 100.0 * 100.0) / 9.0);
  EXPECT_NEAR(jsonNumber(all.out, "rmse"), rmse, 1e-9 * rmse) << all.out;
  EXPECT_NEAR(jsonNumber(all.out, "relative_rmse"), rmse / 3.0, 1e-9 * rmse) << all.out;
  EXPECT_NEAR(jsonNumber(all.out, "psnr"), 20.0 * std::log10(5.0 / rmse), 1e-9) << all.out;
  EXPECT_NEAR(jsonNumber(all.out, "max_abs_error"), 100.0, 1e-9) << all.out;
  EXPECT_EQ(jsonNumber(all.out, "pixels"), 3) << all.out;
}

// PNG tone mapping (image.hpp): exposure, then Reinhard x / (1 + x) per channel, then the sRGB
// transfer function of IEC 61966-2-1 (12.92 t up to 0.0031308, 1.055 t^(1/2.4) - 0.055 above),
// rounded to 8 bits. The expected bytes are worked out here from those formulas, in double.
std::uint8_t expectedPngByte(double linear, double exposure) {
  const double x = std::max(0.0, linear * exposure);
  const double t = x / (1.0 + x);
  const double e = t <= 0.0031308 ? 12.92 * t : 1.055 * std::pow(t, 1.0 / 2.4) - 0.055;
  return std::uint8_t(std::lround(std::clamp(e, 0.0, 1.0) * 255.0));
}

// The 8-bit values of a PNG as read back without linearizing (value / 255).
std::vector<int> pngBytes(const std::string& file) {
  const Image png = readImage(file);
  std::vector<int> out;
  for (std::size_t i = 0; i < std::size_t(png.width) * png.height; ++i)
    for (int c = 0; c < 3; ++c) out.push_back(int(std::lround(png.pixels[i * png.channels + c] * 255.0f)));
  return out;
}

// The automatic exposure (image.hpp): 0.25 over the log-average luminance (Reinhard et al. 2002,
// eq. 1, with its small delta) of the pixels with alpha > 0.5 when there are any, Rec. 709
// luminance Y = 0.2126 R + 0.7152 G + 0.0722 B (the sRGB primaries).
double expectedAutoExposure(const Image& img) {
  bool anyAlpha = false;
  for (std::size_t i = 0; img.channels == 4 && i < std::size_t(img.width) * img.height; ++i)
    anyAlpha |= img.pixels[i * 4 + 3] > 0.5f;
  double logSum = 0;
  int n = 0;
  for (std::size_t i = 0; i < std::size_t(img.width) * img.height; ++i) {
    const float* p = &img.pixels[i * img.channels];
    if (anyAlpha && !(p[3] > 0.5f)) continue;
    logSum += std::log(1e-4 + 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]);
    ++n;
  }
  return 0.25 / std::exp(logSum / n);
}

TEST_F(CliCompare, PngToneMappingHasTheExpectedBytes) {
  // Values over the whole curve: the linear toe, mid-tones, highlights, a value past 1 and 0.
  const float values[8] = {0.0f, 0.001f, 0.05f, 0.18f, 0.5f, 1.0f, 3.0f, 40.0f};
  Image img(8, 1, 3);
  for (int x = 0; x < 8; ++x) {
    img.at(x, 0, 0) = values[x];
    img.at(x, 0, 1) = values[7 - x];
    img.at(x, 0, 2) = 0.5f * values[x];
  }
  for (const float exposure : {1.0f, 0.5f, 3.0f}) {
    SCOPED_TRACE(exposure);
    writeImage(path("t.png"), img, exposure);
    const std::vector<int> got = pngBytes(path("t.png"));
    for (int x = 0; x < 8; ++x)
      for (int c = 0; c < 3; ++c)
        EXPECT_EQ(got[std::size_t(x * 3 + c)], expectedPngByte(img.at(x, 0, c), exposure))
            << "pixel " << x << " channel " << c << " linear " << img.at(x, 0, c);
  }
  // Fixed points of the formulas as a check on the helper itself: 0 -> 0; x = 1 -> t = 1/2 ->
  // 1.055 * 0.5^(1/2.4) - 0.055 = 0.7354 -> 188; a huge value -> t ~ 1 -> 255.
  EXPECT_EQ(expectedPngByte(0.0, 1.0), 0);
  EXPECT_EQ(expectedPngByte(1.0, 1.0), 188);
  EXPECT_EQ(expectedPngByte(1e9, 1.0), 255);

  // Automatic exposure: two geometry pixels of luminance 0.5 and 2 have log-average 1, so the
  // exposure is 0.25 (the delta moves it by 1e-4 relative); the background pixel's 1000 must not
  // count (with it the exposure would be 0.025).
  Image rgba(3, 1, 4, 0.0f);
  for (int c = 0; c < 3; ++c) rgba.at(0, 0, c) = 0.5f, rgba.at(1, 0, c) = 2.0f, rgba.at(2, 0, c) = 1000.0f;
  rgba.at(0, 0, 3) = rgba.at(1, 0, 3) = 1.0f;
  EXPECT_NEAR(autoExposure(rgba), 0.25, 0.25 * 2e-4);
  EXPECT_NEAR(expectedAutoExposure(rgba), 0.25, 0.25 * 2e-4);
}

// render's PNG is its EXR tone mapped: at --exposure 2, and at the automatic exposure when none
// is given. Both outputs come from one run each with the same options (renders are reproducible
// bit for bit, CliOutputs.IdenticalRunsWriteIdenticalBytes). The expected bytes are computed in
// double from the EXR's floats; the library works in float, so a value within float round-off of a
// rounding boundary may land one level off: at most one level, on at most 1% of the values.
TEST_F(CliCompare, RenderPngIsTheToneMappedExr) {
  const std::vector<std::string> frame = cat({"render", "--size", "48x27", "--shadows", "hard"}, kFast);
  ASSERT_EQ(run(cat(frame, {"--out", "f.exr"})).code, 0);
  ASSERT_EQ(run(cat(frame, {"--out", "f2.png", "--exposure", "2"})).code, 0);
  ASSERT_EQ(run(cat(frame, {"--out", "fa.png"})).code, 0);
  const Image exr = readImage(path("f.exr"));
  const double autoExp = expectedAutoExposure(exr);
  // The control: the automatic exposure is not 2 (else the two PNGs could not tell them apart).
  ASSERT_GT(std::fabs(std::log(autoExp / 2.0)), 0.2) << autoExp;
  for (const auto& [file, exposure] : {std::pair<std::string, double>{"f2.png", 2.0},
                                       std::pair<std::string, double>{"fa.png", autoExp}}) {
    SCOPED_TRACE(file);
    const std::vector<int> got = pngBytes(path(file));
    ASSERT_EQ(got.size(), std::size_t(exr.width) * exr.height * 3);
    std::size_t off = 0, far = 0;
    for (std::size_t i = 0; i < std::size_t(exr.width) * exr.height; ++i)
      for (int c = 0; c < 3; ++c) {
        const int want = expectedPngByte(exr.pixels[i * 4 + c], exposure);
        const int d = std::abs(got[i * 3 + c] - want);
        off += d == 1;
        far += d > 1;
      }
    EXPECT_EQ(far, 0u);
    EXPECT_LE(off, got.size() / 100);
  }
  // Negative control: the PNG at --exposure 2 is not what the automatic exposure gives.
  const std::vector<int> two = pngBytes(path("f2.png"));
  std::size_t moved = 0;
  for (std::size_t i = 0; i < std::size_t(exr.width) * exr.height; ++i)
    for (int c = 0; c < 3; ++c)
      moved += std::abs(two[i * 3 + c] - expectedPngByte(exr.pixels[i * 4 + c], autoExp)) > 1;
  EXPECT_GT(moved, two.size() / 4);
}

TEST_F(CliCompare, DifferentSizesFail) {
  writeImage(path("a.exr"), Image(8, 4, 4, 1.0f));
  writeImage(path("b.exr"), Image(16, 8, 4, 1.0f));
  Result r = run({"compare", "a.exr", "b.exr", "--out", "m.json"});
  EXPECT_EQ(r.code, 2) << describe(r);
  EXPECT_EQ(lines(r.err).size(), 1u) << describe(r);
  EXPECT_FALSE(fs::exists(dir_ / "m.json"));
}

TEST_F(CliCompare, WrongArgumentCount) {
  writeImage(path("a.exr"), Image(8, 4, 4, 1.0f));
  Result r = run({"compare", "a.exr"});
  EXPECT_EQ(r.code, 2) << describe(r);
  EXPECT_EQ(lines(r.err).size(), 1u) << describe(r);
}

TEST_F(CliCompare, MissingFirstImage) {
  Result r = run({"compare", path("nope.exr"), path("nope2.exr")});
  EXPECT_EQ(r.code, 2) << describe(r);
  EXPECT_EQ(lines(r.err).size(), 1u) << describe(r);
  EXPECT_NE(r.err.find("nope.exr"), std::string::npos) << describe(r);
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// --light-set: lights a user defines (caps, rectangles, polygons) instead of extracted ones.

class CliLightSet : public CliFixture {
 protected:
  std::string example() const {
    return std::string(PENUMBRA_TEST_DATA) + "/../../examples/lights/window_and_sun.json";
  }
};

TEST_F(CliLightSet, RenderAndReferenceUseTheFile) {
  for (const char* t : {"mssm4", "area-approx"}) {
    Result r = run({"render", "--light-set", example(), "--shadows", t, "--size", "32x18",
                    "--shadow-map-size", "64", "--out", path(std::string(t) + ".exr"), "--report",
                    path("r.json")});
    ASSERT_EQ(r.code, 0) << describe(r);
    EXPECT_TRUE(fs::exists(path(std::string(t) + ".exr")));
    std::ifstream in(path("r.json"));
    std::string json((std::istreambuf_iterator<char>(in)), {});
    // The report counts the file's three lights.
    EXPECT_NE(json.find("\"lights\": 3,"), std::string::npos) << json.substr(0, 400);
  }
  Result r = run({"reference", "--light-set", example(), "--size", "16x9", "--spp", "16",
                  "--out", path("ref.exr")});
  ASSERT_EQ(r.code, 0) << describe(r);
  EXPECT_NE(r.out.find("light-set"), std::string::npos) << r.out;
}

TEST_F(CliLightSet, RefusedBesideExtractionOptions) {
  expectFailure({"render", "--light-set", example(), "--lights", "8", "--out", path("x.png")},
                {"--lights", "--light-set"});
}

TEST_F(CliLightSet, BadFilesNameTheFile) {
  {
    std::ofstream(path("bad.json")) << "{\"lights\": [{\"shape\": \"cap\", \"direction\": [0, 1]}]}";
  }
  const std::string bad = path("bad.json");
  Result r = run({"render", "--light-set", bad, "--size", "16x9", "--out", path("x.png")});
  EXPECT_EQ(r.code, 2) << describe(r);
  EXPECT_NE(r.err.find("bad.json"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(path("x.png")));
  r = run({"render", "--light-set", path("missing.json"), "--size", "16x9", "--out", path("x.png")});
  EXPECT_EQ(r.code, 2) << describe(r);
  EXPECT_NE(r.err.find("missing.json"), std::string::npos) << r.err;
}

TEST_F(CliLightSet, LightShapeIsMedianCutOnly) {
  expectFailure({"render", "--extract", "greedy", "--light-shape", "polygon", "--out", path("x.png")},
                {"--light-shape"});
  expectFailure({"render", "--light-shape", "hexagon", "--out", path("x.png")}, {"--light-shape"});
}

// ---------------------------------------------------------------------------------------------
// Reproducible outputs: two identical runs write byte-identical files (no time in any header).
// The runs are more than a second apart, the resolution of the EXR capDate a writer would stamp.
// Every image carries its command line, so the two runs are the same command line, run in two
// directories (the same relative --out).

class CliOutputs : public CliFixture {};

TEST_F(CliOutputs, IdenticalRunsWriteIdenticalBytes) {
  const std::vector<std::string> frame = cat({"render", "--size", "32x18"}, kFast);
  const std::vector<std::string> reference = {"reference", "--size", "16x9", "--spp", "2"};
  for (const char* pass : {"1", "2"}) {
    const fs::path cwd = dir_ / pass;
    fs::create_directory(cwd);
    for (const char* ext : {".exr", ".png"}) {
      Result r = runCli(cat(frame, {"--out", std::string("frame") + ext}), cwd);
      ASSERT_EQ(r.code, 0) << describe(r);
    }
    Result r = runCli(cat(reference, {"--out", "ref.exr"}), cwd);
    ASSERT_EQ(r.code, 0) << describe(r);
    if (std::string(pass) == "1") std::this_thread::sleep_for(std::chrono::milliseconds(1100));
  }
  for (const char* name : {"frame.exr", "frame.png", "ref.exr"}) {
    SCOPED_TRACE(name);
    const std::string bytesA = readText(dir_ / "1" / name), bytesB = readText(dir_ / "2" / name);
    ASSERT_FALSE(bytesA.empty());
    EXPECT_TRUE(bytesA == bytesB) << name << " differs between the two runs";
  }
}

// ---------------------------------------------------------------------------------------------
// The references' noise in compare; evaluate.

namespace {

// `penumbra reference` stores its relative noise in the EXR; compare reports it beside the
// metrics (null for an image without it) and notes on stderr a difference below twice it.
TEST_F(CliCompare, ReferenceNoiseFromTheHeader) {
  Result ref = run({"reference", "--size", "32x18", "--spp", "16", "--out", "r.exr"});
  ASSERT_EQ(ref.code, 0) << describe(ref);
  EXPECT_NE(ref.out.find("relative noise"), std::string::npos) << describe(ref);
  const auto attributes = readImageAttributes(path("r.exr"));
  ASSERT_EQ(attributes.count(kRelativeNoiseAttribute), 1u);
  const double noise = attributes.at(kRelativeNoiseAttribute);
  EXPECT_GT(noise, 0.0);
  Result same = run({"compare", "r.exr", "r.exr"});
  ASSERT_EQ(same.code, 0) << describe(same);
  EXPECT_DOUBLE_EQ(jsonNumber(same.out, "reference_noise"), noise) << describe(same);
  EXPECT_NE(same.err.find("below twice the reference's own noise"), std::string::npos)
      << describe(same);
  // A far-off image is not below the noise: no note.
  Image off = readImage(path("r.exr"));
  for (std::size_t i = 0; i < off.pixels.size(); ++i)
    if (i % 4 != 3) off.pixels[i] *= 2.0f;
  writeImage(path("off.exr"), off);
  Result far = run({"compare", "off.exr", "r.exr"});
  ASSERT_EQ(far.code, 0) << describe(far);
  EXPECT_TRUE(far.err.empty()) << describe(far);
  // No attribute in B: null.
  Result plain = run({"compare", "r.exr", "off.exr"});
  ASSERT_EQ(plain.code, 0) << describe(plain);
  EXPECT_NE(plain.out.find("\"reference_noise\": null"), std::string::npos) << describe(plain);
}

class CliEvaluate : public CliFixture {};

// The first cached truth file in `dir` whose name ends with `suffix`, as RGBA.
Image cachedTruth(const fs::path& dir, const std::string& suffix) {
  for (auto& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (name.size() > suffix.size() && name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0) {
      const Image packed = readImage(e.path().string());
      Image rgba(packed.width, packed.height, 4);
      for (std::size_t i = 0; i < std::size_t(packed.width) * packed.height; ++i)
        for (int k = 0; k < 4; ++k) rgba.pixels[i * 4 + k] = packed.pixels[i * packed.channels + k];
      return rgba;
    }
  }
  ADD_FAILURE() << "no *" << suffix << " in " << dir;
  return {};
}

TEST_F(CliEvaluate, BudgetMapsAndJsonMatchTheWrittenImages) {
  const std::vector<std::string> args = {"evaluate", "--size", "32x18", "--spp", "64", "--lights",
                                         "8", "--face-size", "32", "--truth", "truth",
                                         "--out-dir", "maps", "--json", "b.json"};
  Result r = run(args);
  ASSERT_EQ(r.code, 0) << describe(r);
  for (const char* line : {"total", "floor", "technique", "ambient", "sum: total^2",
                           "truth noise:", "bias", "8 lights", "environment computed"})
    EXPECT_NE(r.out.find(line), std::string::npos) << line << "\n" << describe(r);
  for (const char* f : {"error-total.png", "error-floor.png", "error-technique.png",
                        "flip-total.png", "flip-technique.png", "frame.exr"})
    EXPECT_TRUE(fs::is_regular_file(dir_ / "maps" / f)) << f;
  const nlohmann::json j = nlohmann::json::parse(readText(dir_ / "b.json"));
  for (const char* line : {"total", "floor", "technique", "ambient"}) {
    SCOPED_TRACE(line);
    EXPECT_TRUE(j[line]["relative_rmse"].is_number());
    EXPECT_TRUE(j[line]["noise"].is_number());
    EXPECT_TRUE(j[line]["flip"].is_number());  // finite: non-finite numbers are written as null
  }
  EXPECT_EQ(j["lights"], 8);

  // Recomputed from the written frame and the cached truths.
  const Image frame = readImage((dir_ / "maps" / "frame.exr").string());
  const Image G = cachedTruth(dir_ / "truth", "-environment.exr");
  const Image L = cachedTruth(dir_ / "truth", "-lights.exr");
  const double T = j["total"]["relative_rmse"], F = j["floor"]["relative_rmse"],
               Q = j["technique"]["relative_rmse"], cross = j["cross"];
  EXPECT_NEAR(T, compareImages(frame, G).relativeRmse, 1e-9 * T);
  EXPECT_NEAR(F, compareImages(L, G).relativeRmse, 1e-9 * F);
  const ImageMetrics mg = compareImages(frame, G);
  EXPECT_NEAR(Q, compareImages(frame, L).rmse / (mg.rmse / mg.relativeRmse), 1e-9 * Q);
  EXPECT_NEAR(T * T, F * F + Q * Q + 2 * cross, 1e-9 * T * T);

  // Again: the truths come from the cache, the figures are the same.
  Result again = run(args);
  ASSERT_EQ(again.code, 0) << describe(again);
  EXPECT_NE(again.out.find("environment read, lights read, lights shadowed ambient read"),
            std::string::npos)
      << describe(again);
  const nlohmann::json j2 = nlohmann::json::parse(readText(dir_ / "b.json"));
  EXPECT_EQ(j2["floor"]["relative_rmse"], j["floor"]["relative_rmse"]);
}

TEST_F(CliEvaluate, BadSppAndUncreatableTruthDirectory) {
  expectFailure({"evaluate", "--size", "32x18", "--spp", "1"}, {"--spp"});
  expectFailure({"evaluate", "--size", "32x18", "--spp", "many"}, {"--spp"});
  // A directory below a plain file cannot be created.
  const fs::path file = fs::path(testing::TempDir()) / ("penumbra_cli_file_" + std::to_string(getpid()));
  { std::ofstream(file.string()) << "x"; }
  expectFailure({"evaluate", "--size", "32x18", "--spp", "8", "--truth", (file / "t").string()},
                {"--truth"});
  fs::remove(file);
}

// ---------------------------------------------------------------------------------------------
// Conventions every command-line user brings: -h everywhere, short aliases, unknown and stray
// arguments refused with a suggestion, --version, grouped help that fits the terminal with the
// library's defaults, strict numbers, --quiet, per-frame progress, any image format, outputs that
// say what made them.

class CliConventions : public CliFixture {
 protected:
  // The help of `command` on a terminal COLUMNS wide (stdout is a pipe: $COLUMNS decides).
  Result help(const std::string& command, int columns) {
    return runCli({command, "-h"}, dir_, 60, {"COLUMNS=" + std::to_string(columns)});
  }
};

const std::vector<std::string> kCommands = {"devices", "render",   "reference",
                                            "compare", "evaluate", "lights"};

// -h is --help on every subcommand: usage on stdout, exit 0, nothing run (render -h with an
// output renders nothing).
TEST_F(CliConventions, ShortHelpEverywhereRunsNothing) {
  for (const std::string& c : kCommands) {
    SCOPED_TRACE(c);
    Result r = run({c, "-h", "--out", "x.png"});
    EXPECT_EQ(r.code, 0) << describe(r);
    EXPECT_TRUE(r.err.empty()) << describe(r);
    EXPECT_EQ(r.out.rfind("usage: penumbra " + c, 0), 0u) << describe(r);
    EXPECT_EQ(r.out.find("wrote"), std::string::npos) << describe(r);
  }
  EXPECT_TRUE(entries().empty());
}

TEST_F(CliConventions, ShortAliases) {
  Result r = run({"render", "-s", "32x18", "-o", "a.png", "-l", "4", "--face-size", "16",
                  "--shadow-map-size", "64", "-e", "builtin"});
  ASSERT_EQ(r.code, 0) << describe(r);
  const Image img = readImage(path("a.png"));
  EXPECT_EQ(img.width, 32);
  EXPECT_EQ(img.height, 18);
  Result l = run({"lights", "-l", "3", "--face-size", "16", "-o", "l.json"});
  ASSERT_EQ(l.code, 0) << describe(l);
  EXPECT_EQ(loadLightSet(path("l.json")).lights.size(), 3u);
}

TEST_F(CliConventions, StrayAndUnknownArgumentsAreRefused) {
  expectFailure({"render", "stray", "--out", path("x.png")}, {"stray"});
  expectFailure({"devices", "stray"}, {"stray"});
  expectFailure({"compare", "a.exr", "b.exr", "c.exr"}, {"c.exr"});
  expectFailure({"render", "--sise", "64x36", "--out", path("x.png")},
                {"unknown option --sise", "(did you mean --size?)"});
  expectFailure({"lights", "--overlai", "o.png"}, {"--overlai", "did you mean --overlay?"});
  expectFailure({"render", "--zzzzzz"}, {"--zzzzzz", "penumbra render --help"});
  expectFailure({"lights", "--rect=banana"}, {"--rect", "banana"});
  Result r = run({"rendr", "--size", "64x36"});
  EXPECT_EQ(r.code, 2) << describe(r);
  EXPECT_EQ(lines(r.err).size(), 1u) << describe(r);
  EXPECT_NE(r.err.find("'rendr' (did you mean render?)"), std::string::npos) << describe(r);
  EXPECT_TRUE(entries().empty());
}

TEST_F(CliConventions, VersionIsTheProjectVersion) {
  Result r = run({"--version"});
  EXPECT_EQ(r.code, 0) << describe(r);
  EXPECT_EQ(r.out, std::string(PENUMBRA_VERSION) + "\n");
  EXPECT_TRUE(r.err.empty()) << describe(r);
}

// Every help fits 80 columns when the terminal has 80, and uses the room of a wider one (the
// control: the same help at 160 columns has lines past 80).
TEST_F(CliConventions, HelpWrapsToTheTerminal) {
  for (const std::string& c : kCommands) {
    SCOPED_TRACE(c);
    Result narrow = help(c, 80);
    ASSERT_EQ(narrow.code, 0) << describe(narrow);
    for (const std::string& l : lines(narrow.out)) EXPECT_LE(l.size(), 80u) << l;
  }
  std::size_t widest = 0;
  for (const std::string& l : lines(help("render", 160).out)) widest = std::max(widest, l.size());
  EXPECT_GT(widest, 80u);
  EXPECT_LE(widest, 160u);
}

// Help text per option: the description lines after an option's first line, joined, keyed by
// its long name.
std::map<std::string, std::string> optionHelp(const std::string& helpText) {
  std::map<std::string, std::string> out;
  std::string current;
  const std::regex start("^  (-[a-zA-Z], )?\\s*--([a-z0-9-]+)(.*)$");
  for (const std::string& l : lines(helpText)) {
    std::smatch m;
    if (std::regex_match(l, m, start)) {
      current = m[2];
      out[current] = m[3];
    } else if (!current.empty() && l.rfind("      ", 0) == 0) {
      out[current] += " " + l;
    } else {
      current.clear();
    }
  }
  for (auto& [name, text] : out) text = std::regex_replace(text, std::regex("\\s+"), " ");
  return out;
}

// The number after "default " in an option's help, NaN when there is none.
double helpDefault(const std::string& text) {
  const auto at = text.rfind("default ");
  if (at == std::string::npos) return std::nan("");
  return std::strtod(text.c_str() + at + 8, nullptr);
}

// render --help lists its options in the groups, with type, range and the library's defaults.
TEST_F(CliConventions, HelpGroupsTypesRangesAndLibraryDefaults) {
  Result r = help("render", 80);
  ASSERT_EQ(r.code, 0) << describe(r);
  for (const char* group : {"\nScene:\n", "\nLights:\n", "\nShadows:\n", "\nOutput:\n",
                            "\nAdvanced:\n", "\nAnimation:\n"})
    EXPECT_NE(r.out.find(group), std::string::npos) << group;
  const auto options = optionHelp(r.out);
  const RenderOptions R;
  const MedianCutOptions M;
  const std::vector<std::pair<std::string, double>> defaults = {
      {"sharpen-b", R.cssm.sharpenB},   {"sharpen-a", R.cssm.sharpenA},
      {"cssm-order", R.cssm.order},     {"shadow-map-size", R.shadowMapSize},
      {"depth-bias", R.shadow.depthBias}, {"moment-bias", R.mssm.momentBias},
      {"lights", M.lights},             {"face-size", M.faceSize}};
  for (const auto& [name, value] : defaults) {
    SCOPED_TRACE(name);
    ASSERT_EQ(options.count(name), 1u) << r.out;
    EXPECT_NEAR(helpDefault(options.at(name)), value, 1e-6 * std::fabs(value)) << options.at(name);
  }
  EXPECT_NE(options.at("shadow-map-size").find("integer in [1, 4096]"), std::string::npos);
  EXPECT_NE(options.at("exposure").find("number > 0"), std::string::npos);
  EXPECT_NE(options.at("shadows").find("default " + std::string(toString(R.shadows))),
            std::string::npos);
  EXPECT_EQ(options.at("out").find("--out"), std::string::npos);
}

// The README's synopsis shows defaults ([--sharpen-b 80]); each one is the default the help
// states, which is the library's.
TEST_F(CliConventions, ReadmeSynopsisDefaultsMatchTheHelp) {
  const std::string readme = readText(kData + "/../../README.md");
  const auto block = readme.find("## Command line");
  ASSERT_NE(block, std::string::npos);
  const auto end = readme.find("```\n", readme.find("```sh", block) + 5);
  std::istringstream synopsis(readme.substr(block, end - block));
  std::map<std::string, std::map<std::string, std::string>> helps;
  std::string command;
  int checked = 0;
  const std::regex option("\\[--([a-z0-9-]+) ([0-9][0-9.e+-]*)\\]");
  for (std::string l; std::getline(synopsis, l);) {
    std::smatch m;
    if (std::regex_search(l, m, std::regex("^penumbra ([a-z]+)"))) command = m[1];
    for (auto it = std::sregex_iterator(l.begin(), l.end(), option); it != std::sregex_iterator();
         ++it) {
      const std::string name = (*it)[1], value = (*it)[2];
      SCOPED_TRACE(command + " --" + name + " " + value);
      if (!helps.count(command)) helps[command] = optionHelp(help(command, 80).out);
      ASSERT_EQ(helps[command].count(name), 1u);
      EXPECT_EQ(helpDefault(helps[command][name]), std::strtod(value.c_str(), nullptr))
          << helps[command][name];
      ++checked;
    }
  }
  EXPECT_GE(checked, 20);
}

// Numbers are decimal, locale-free and whole: no hex, no octal-looking leading zeros, no decimal
// comma, no trailing text, nothing non-finite.
TEST_F(CliConventions, StrictNumbers) {
  const std::vector<std::pair<std::vector<std::string>, std::vector<std::string>>> cases = {
      {{"--size", "5x5x5"}, {"--size", "5x5"}},
      {{"--size", "0x10"}, {"--size"}},
      {{"--lights", "010"}, {"--lights", "010", "leading zero"}},
      {{"--lights", "0x5"}, {"--lights", "0x5"}},
      {{"--lights", "+5"}, {"--lights"}},
      {{"--lights", "5 "}, {"--lights"}},
      {{"--sharpen-b", "0x10"}, {"--sharpen-b", "0x10"}},
      {{"--exposure", "1,5"}, {"--exposure", "1,5"}},
      {{"--depth-bias", "inf"}, {"--depth-bias"}},
      {{"--max-filter", "1e999"}, {"--max-filter"}},
  };
  for (const auto& [extra, mentions] : cases) {
    SCOPED_TRACE(extra[0] + " " + extra[1]);
    expectFailure(cat({"render", "--out", path("x.png")}, extra), mentions);
  }
}

TEST_F(CliConventions, FramesPrintProgressWithEta) {
  Result r = run(cat({"render", "--frames", "3", "-s", "24x16", "--shadows", "hard", "-o",
                      "f.png"},
                     kFast));
  ASSERT_EQ(r.code, 0) << describe(r);
  const auto err = lines(r.err);
  ASSERT_EQ(err.size(), 3u) << describe(r);
  const std::string duration = "([0-9]+\\.[0-9] s|[0-9]+ s|[0-9]+m[0-9]{2}s|[0-9]+h[0-9]{2}m)";
  for (int i = 0; i < 3; ++i)
    EXPECT_TRUE(std::regex_match(
        err[std::size_t(i)],
        std::regex("render: frame " + std::to_string(i + 1) + "/3 f_000" + std::to_string(i) +
                   "\\.png: [0-9]+ ms, elapsed " + duration + ", ETA " + duration)))
        << err[std::size_t(i)];
  // the last frame has nothing left to wait for
  EXPECT_NE(err.back().find("ETA 0.0 s"), std::string::npos) << err.back();
  Result q = run(cat({"render", "--frames", "2", "-s", "24x16", "--shadows", "hard", "-o",
                      "q.png", "-q"},
                     kFast));
  ASSERT_EQ(q.code, 0) << describe(q);
  EXPECT_TRUE(q.err.empty()) << describe(q);
}

TEST_F(CliConventions, OutJpegWritesAJpeg) {
  Result r = run(cat({"render", "-s", "32x18", "-o", "x.jpg"}, kFast));
  ASSERT_EQ(r.code, 0) << describe(r);
  const std::string bytes = readText(dir_ / "x.jpg");
  ASSERT_GE(bytes.size(), 3u);
  EXPECT_EQ(bytes.substr(0, 3), std::string("\xff\xd8\xff", 3));
  const Image img = readImage(path("x.jpg"));
  EXPECT_EQ(img.width, 32);
  EXPECT_EQ(img.height, 18);
}

// The string attributes of an image's header, read with OpenImageIO.
std::map<std::string, std::string> textAttributes(const std::string& file) {
  std::map<std::string, std::string> out;
  auto in = OIIO::ImageInput::open(file);
  if (!in) return out;
  for (const auto& p : in->spec().extra_attribs)
    if (p.type() == OIIO::TypeDesc::STRING) out[p.name().string()] = p.get_string();
  return out;
}

// Every image the CLI writes says what made it: penumbra's version, the command line (shell
// quoted) and the technique; render's report names the command and its inputs.
TEST_F(CliConventions, OutputsDescribeThemselves) {
  const std::string lightSet = kData + "/../../examples/lights/window_and_sun.json";
  const std::vector<std::string> args = {"render", "-s", "32x18", "--shadows", "hard",
                                         "--shadow-map-size", "64", "--light-set", lightSet,
                                         "-o", "it's.exr", "--report", "r.json"};
  Result r = run(args);
  ASSERT_EQ(r.code, 0) << describe(r);
  const auto text = textAttributes(path("it's.exr"));
  ASSERT_EQ(text.count("penumbra:version"), 1u);
  EXPECT_EQ(text.at("penumbra:version"), PENUMBRA_VERSION);
  EXPECT_EQ(text.at("penumbra:technique"), "hard");
  std::string expected = kCli;
  for (const std::string& a : args) expected += " " + (a == "it's.exr" ? "'it'\\''s.exr'" : a);
  EXPECT_EQ(text.at("penumbra:command"), expected);
  const nlohmann::json report = nlohmann::json::parse(readText(dir_ / "r.json"));
  EXPECT_EQ(report["command"], nlohmann::json(cat({kCli}, args)));
  EXPECT_EQ(report["version"], PENUMBRA_VERSION);
  EXPECT_EQ(report["inputs"]["light_set"], lightSet);
  EXPECT_EQ(report["inputs"]["environment"], "");  // the built-in map

  Result ref = run({"reference", "-s", "16x9", "--spp", "2", "-o", "ref.exr", "-q"});
  ASSERT_EQ(ref.code, 0) << describe(ref);
  const auto refText = textAttributes(path("ref.exr"));
  EXPECT_EQ(refText.count("penumbra:version"), 1u);
  EXPECT_EQ(refText.count("penumbra:command"), 1u);
  EXPECT_EQ(refText.count("penumbra:technique"), 1u);
  // the numeric attribute is still there beside them
  EXPECT_EQ(readImageAttributes(path("ref.exr")).count(kRelativeNoiseAttribute), 1u);
}

// On a terminal, reference's progress is one line redrawn in place ('\r'): a bar with the
// percentage and the time left, ending with the 100% line. The child's stderr is a
// pseudo-terminal here; stdout stays a pipe.
TEST_F(CliConventions, ProgressBarOnATerminal) {
  int master = -1, slave = -1;
  ASSERT_EQ(openpty(&master, &slave, nullptr, nullptr, nullptr), 0) << std::strerror(errno);
  std::vector<std::string> store = {kCli, "reference", "-s", "16x40", "--spp", "1", "-j", "1",
                                    "-o", "ref.exr"};
  std::vector<char*> argv;
  for (auto& a : store) argv.push_back(a.data());
  argv.push_back(nullptr);
  const std::string dir = dir_.string();
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    if (chdir(dir.c_str()) != 0) _exit(126);
    const int devnull = open("/dev/null", O_RDWR);
    dup2(devnull, 0);
    dup2(devnull, 1);
    dup2(slave, 2);
    close(master);
    execv(argv[0], argv.data());
    _exit(127);
  }
  close(slave);
  std::string err;
  char buf[4096];
  for (;;) {  // EIO once the child's side is closed
    const ssize_t got = read(master, buf, sizeof buf);
    if (got > 0) err.append(buf, std::size_t(got));
    else if (got < 0 && errno == EINTR) continue;
    else break;
  }
  close(master);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << err;
  EXPECT_TRUE(std::regex_search(err, std::regex("\r?reference \\[#*\\.*\\] +[0-9]+% ETA [0-9]")))
      << err;
  EXPECT_TRUE(std::regex_search(err, std::regex("reference \\[##########\\] 100% in [0-9]")))
      << err;
  // redrawn in place: one line, however many updates
  EXPECT_GT(std::count(err.begin(), err.end(), '\r'), 2) << err;
  EXPECT_LE(std::count(err.begin(), err.end(), '\n'), 1) << err;
}

}  // namespace
