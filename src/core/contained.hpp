// Running untrusted parsing in a child process: a forked child does the work under a memory and
// a time limit and sends back a byte string, so that a library that crashes, loops or allocates
// without bound on a malformed file (Assimp does all three) cannot take the caller's process down.
#pragma once
#include <cstddef>
#include <functional>
#include <string>

namespace penumbra::detail {

struct ContainLimits {
  std::size_t memoryBytes = 0;  // address space the child may add to what it inherits
  double seconds = 0;           // wall-clock limit; the child is killed after it
};

// Forks, runs `work` in the child and returns the string it produced. In the child, an Error
// thrown by `work` is sent back and rethrown here with its kind and message; std::bad_alloc (the
// memory limit) and any other exception become Error(BadInput). When the child dies by a signal
// or passes the time limit, throws Error(BadInput) "<label>: <what happened>", quoting the last
// line the child wrote to stderr (an assertion message, say). The child never returns into the
// caller's code: it leaves with _exit, running no destructors or atexit handlers of the parent.
// Calls from several threads are safe and run one after another (one child at a time).
std::string runContained(const std::string& label, const ContainLimits& limits,
                         const std::function<std::string()>& work);

}  // namespace penumbra::detail
