// Child-process containment for untrusted parsers (see contained.hpp): fork, limits, a pipe for
// the result and one for the child's stderr, a deadline enforced by the parent.
#include "core/contained.hpp"
#include "core/number_text.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <mutex>
#include <new>

#include "penumbra/error.hpp"

namespace penumbra::detail {
namespace {

// What the child sends on its result pipe: 'R' and the result up to end of file, or 'E', one
// byte of ErrorKind and the message up to end of file. Anything else (nothing at all, when the
// child died) is a crash.
constexpr char kResult = 'R';
constexpr char kFailure = 'E';
constexpr std::size_t kStderrKeep = 4096;  // the tail of the child's stderr kept for the message

bool writeAll(int fd, const char* p, std::size_t n) {
  while (n > 0) {
    const ssize_t w = ::write(fd, p, n);
    if (w < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    p += w;
    n -= static_cast<std::size_t>(w);
  }
  return true;
}

// The address space the child already has when it starts (the parent's, copied): the memory
// limit is added on top of it so that a large parent does not leave the child nothing.
std::size_t currentAddressSpace() {
  unsigned long pages = 0;
  if (FILE* f = std::fopen("/proc/self/statm", "r")) {
    if (std::fscanf(f, "%lu", &pages) != 1) pages = 0;
    std::fclose(f);
  }
  return static_cast<std::size_t>(pages) * static_cast<std::size_t>(::sysconf(_SC_PAGESIZE));
}

std::string mib(std::size_t bytes) { return std::to_string((bytes + (1u << 20) - 1) >> 20); }

std::string seconds(double s) { return detail::numberText(s); }

[[noreturn]] void childMain(int out, int err, const std::string& label,
                            const ContainLimits& limits,
                            const std::function<std::string()>& work) {
  // A child that outlives a killed parent would keep the file's damage running.
  ::prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (::getppid() == 1) ::_exit(111);
  const int devnull = ::open("/dev/null", O_RDWR);
  if (devnull >= 0) {
    ::dup2(devnull, 0);
    ::dup2(devnull, 1);
    ::close(devnull);
  }
  ::dup2(err, 2);
  ::close(err);
  // The default action for the crash signals, whatever handler the parent had: the OpenCL
  // driver's compiler (libLLVM, loaded with PoCL) installs one for SIGSEGV when a Context is
  // created, which returns from a raised signal and prints its own report to stderr, the text the
  // parent quotes; AddressSanitizer's reports and exits. A fault in the reader must end the child
  // by its signal, and be reported as such, in every build.
  for (int sig : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT}) ::signal(sig, SIG_DFL);
  if (limits.memoryBytes > 0) {
    rlimit r{};
    r.rlim_cur = r.rlim_max = currentAddressSpace() + limits.memoryBytes;
    ::setrlimit(RLIMIT_AS, &r);
  }
  if (limits.seconds > 0) {
    // The parent's deadline is the real limit; CPU time is a backstop should the parent stop.
    rlimit r{};
    r.rlim_cur = r.rlim_max = static_cast<rlim_t>(std::ceil(limits.seconds)) + 2;
    ::setrlimit(RLIMIT_CPU, &r);
  }
  char kind = static_cast<char>(ErrorKind::BadInput);
  std::string message;
  try {
    const std::string result = work();
    const bool ok = writeAll(out, &kResult, 1) && writeAll(out, result.data(), result.size());
    ::_exit(ok ? 0 : 112);
  } catch (const Error& e) {
    kind = static_cast<char>(e.kind());
    message = e.what();
  } catch (const std::bad_alloc&) {
    message = label + ": reading it needs more memory than its limit of " +
              mib(limits.memoryBytes) + " MiB; the file declares more data than it holds or is "
              "too large for the limit";
  } catch (const std::exception& e) {
    message = label + ": " + e.what();
  } catch (...) {
    message = label + ": the reader failed with an unknown exception";
  }
  const bool ok = writeAll(out, &kFailure, 1) && writeAll(out, &kind, 1) &&
                  writeAll(out, message.data(), message.size());
  ::_exit(ok ? 0 : 112);
}

std::string lastLine(std::string text) {
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r' || text.back() == ' '))
    text.pop_back();
  const auto nl = text.find_last_of("\r\n");
  if (nl != std::string::npos) text = text.substr(nl + 1);
  return text;
}

}  // namespace

std::string runContained(const std::string& label, const ContainLimits& limits,
                         const std::function<std::string()>& work) {
  // One contained child at a time per process; other callers wait. Two reasons: a fork from
  // another thread between our pipe2 and the close of our write ends below would copy those
  // write ends into its child (our read would then wait for that child too); and a fork while
  // another thread of ours is allocating (appending to its result) can leave the child's
  // allocator locked forever under sanitizer runtimes that do not guard fork (AddressSanitizer in
  // clang 14 did: SceneUntrusted.ConcurrentLoadsAgree hung). glibc's malloc guards fork itself.
  static std::mutex forkMutex;
  std::unique_lock<std::mutex> forking(forkMutex);
  int out[2], err[2];
  if (::pipe2(out, O_CLOEXEC) != 0)
    throw Error(ErrorKind::Internal, label + ": cannot create a pipe: " + std::strerror(errno));
  if (::pipe2(err, O_CLOEXEC) != 0) {
    const int e = errno;
    ::close(out[0]);
    ::close(out[1]);
    throw Error(ErrorKind::Internal, label + ": cannot create a pipe: " + std::strerror(e));
  }
  const pid_t pid = ::fork();
  if (pid < 0) {
    const int e = errno;
    for (int fd : {out[0], out[1], err[0], err[1]}) ::close(fd);
    throw Error(ErrorKind::Internal,
                label + ": cannot start the reader process: " + std::strerror(e));
  }
  if (pid == 0) {
    ::close(out[0]);
    ::close(err[0]);
    childMain(out[1], err[1], label, limits, work);
  }
  ::close(out[1]);
  ::close(err[1]);

  using Clock = std::chrono::steady_clock;
  const bool bounded = limits.seconds > 0;
  const auto deadline =
      Clock::now() + std::chrono::duration_cast<Clock::duration>(
                         std::chrono::duration<double>(bounded ? limits.seconds : 0.0));
  std::string result, errText;
  pollfd fds[2] = {{out[0], POLLIN, 0}, {err[0], POLLIN, 0}};
  int openPipes = 2;
  bool timedOut = false;
  char buf[1 << 16];
  while (openPipes > 0) {
    int waitMs = -1;
    if (bounded) {
      const auto left =
          std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
      if (left <= 0) {
        timedOut = true;
        break;
      }
      waitMs = static_cast<int>(std::min<long long>(left, 1000));
    }
    const int n = ::poll(fds, 2, waitMs);
    if (n < 0) {
      if (errno == EINTR) continue;
      break;
    }
    for (pollfd& p : fds) {
      if (p.fd < 0 || !(p.revents & (POLLIN | POLLHUP | POLLERR))) continue;
      const ssize_t r = ::read(p.fd, buf, sizeof buf);
      if (r < 0 && errno == EINTR) continue;
      if (r <= 0) {
        ::close(p.fd);
        p.fd = -1;
        --openPipes;
        continue;
      }
      if (p.fd == out[0]) {
        result.append(buf, static_cast<std::size_t>(r));
      } else {
        errText.append(buf, static_cast<std::size_t>(r));
        if (errText.size() > 2 * kStderrKeep) errText.erase(0, errText.size() - kStderrKeep);
      }
    }
  }
  for (pollfd& p : fds)
    if (p.fd >= 0) ::close(p.fd);
  if (timedOut) ::kill(pid, SIGKILL);
  int status = 0;
  pid_t w;
  do {
    w = ::waitpid(pid, &status, 0);
  } while (w < 0 && errno == EINTR);
  const bool reaped = w == pid;

  if (timedOut)
    throw Error(ErrorKind::BadInput,
                label + ": reading it took longer than its limit of " + seconds(limits.seconds) +
                    " s; the file is malformed or too large for the limit");
  const std::string said = lastLine(errText);
  const std::string quoted = said.empty() ? "" : ": " + said;
  if (reaped && WIFSIGNALED(status)) {
    const int sig = WTERMSIG(status);
    if (sig == SIGXCPU)
      throw Error(ErrorKind::BadInput, label + ": reading it used more CPU time than its limit of " +
                                           seconds(limits.seconds) + " s");
    throw Error(ErrorKind::BadInput, label + ": the file is malformed: it crashed its reader (" +
                                         strsignal(sig) + ", signal " + std::to_string(sig) +
                                         quoted + ")");
  }
  if (result.empty() || (reaped && WIFEXITED(status) && WEXITSTATUS(status) != 0))
    throw Error(ErrorKind::BadInput,
                label + ": the file is malformed: its reader ended without an answer" +
                    (said.empty() ? "" : " (" + said + ")"));
  if (result[0] == kResult) return result.substr(1);
  if (result[0] == kFailure && result.size() >= 2) {
    const auto code = static_cast<unsigned char>(result[1]);
    const auto kind = code <= static_cast<unsigned char>(ErrorKind::Cancelled)
                          ? static_cast<ErrorKind>(code)
                          : ErrorKind::Internal;
    throw Error(kind, result.substr(2));
  }
  throw Error(ErrorKind::Internal, label + ": the reader process sent a malformed answer");
}

}  // namespace penumbra::detail
