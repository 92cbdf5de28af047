#include "isolated.h"

#include "kiji/error.h"
#include "parallel.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/time.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <new>
#include <sstream>

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define KIJI_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || __has_feature(memory_sanitizer)
#define KIJI_SANITIZED 1
#endif
#endif

namespace kiji::detail {

namespace {

enum Status : std::uint8_t { kOk = 0, kInput = 1, kFailed = 2, kOutOfMemory = 3 };

// Fields of /proc/<pid>/statm, in bytes: 0 = address space, 1 = resident.
std::size_t statm_bytes(pid_t pid, int field) {
  char name[64];
  std::snprintf(name, sizeof name, "/proc/%d/statm", static_cast<int>(pid));
  std::FILE* f = std::fopen(name, "r");
  if (!f) return 0;
  unsigned long long v[2] = {0, 0};
  const int n = std::fscanf(f, "%llu %llu", &v[0], &v[1]);
  std::fclose(f);
  if (n != 2) return 0;
  return static_cast<std::size_t>(v[field]) * static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
}

// Set in the child when an allocation failed: assimp catches std::bad_alloc and reports it as an
// unreadable file, but the reason the user can act on is the memory limit.
bool allocation_failed = false;

void on_allocation_failure() {
  allocation_failed = true;
  std::set_new_handler(nullptr);  // the next failure throws std::bad_alloc, as without a handler
  throw std::bad_alloc();
}

bool write_all(int fd, const void* data, std::size_t n) {
  const char* p = static_cast<const char*>(data);
  while (n > 0) {
    const ssize_t w = ::write(fd, p, n);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) return false;
    p += w;
    n -= static_cast<std::size_t>(w);
  }
  return true;
}

[[noreturn]] void child(int fd, const std::function<std::string()>& work, const ImportLimits& limits,
                        std::size_t address_space) {
  // The child dies with its parent, writes no core file, and a crash ends it (the parent's handlers,
  // Python's fault handler for one, would run in it otherwise). Sanitizers keep their own handlers,
  // which report the crash.
  prctl(PR_SET_PDEATHSIG, SIGKILL);
  const rlimit no_core{0, 0};
  setrlimit(RLIMIT_CORE, &no_core);
#ifndef KIJI_SANITIZED
  for (int sig : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT}) signal(sig, SIG_DFL);
  // An allocation past the limit fails at once, rather than after the memory is touched. Sanitizers
  // reserve terabytes of address space up front, so there the resident limit below does it alone.
  if (address_space > 0) {
    const std::size_t cap = address_space + limits.memory_mb * (std::size_t{1} << 20);
    const rlimit as{cap, cap};
    setrlimit(RLIMIT_AS, &as);
  }
#else
  (void)address_space;
#endif
  for (int sig : {SIGINT, SIGTERM, SIGPIPE}) signal(sig, SIG_DFL);
  // Only this thread exists in the child: the worker pool's threads stayed in the parent.
  parallel::run_serially();
  std::set_new_handler(on_allocation_failure);
  Status status = kOk;
  std::string payload;
  try {
    payload = work();
  } catch (const InputError& e) {
    status = kInput;
    payload = e.what();
  } catch (const std::bad_alloc&) {
    status = kOutOfMemory;
    payload.clear();
  } catch (const std::exception& e) {
    status = kFailed;
    payload = e.what();
  } catch (...) {
    status = kFailed;
    payload = "an exception that is not a std::exception";
  }
  if (allocation_failed && status != kOk) {
    status = kOutOfMemory;
    payload.clear();
  }
  const std::uint64_t size = payload.size();
  const bool ok = write_all(fd, &status, 1) && write_all(fd, &size, sizeof size) &&
                  write_all(fd, payload.data(), payload.size());
  // _exit: the parent's atexit handlers and buffered output are the parent's, not this copy's.
  _exit(ok ? 0 : 3);
}

[[noreturn]] void refuse_for_memory(const std::string& what, std::size_t mb) {
  throw InputError(what + ": reading it took more than " + std::to_string(mb) +
                   " MiB of memory, so it was stopped (this session is unharmed): the file is malformed, or "
                   "larger than the import memory limit allows; raise the limit for a very large mesh, or "
                   "export it again");
}

}  // namespace

std::string run_isolated(const std::function<std::string()>& work, const ImportLimits& limits,
                         const std::string& what) {
  if (!limits.isolate) return work();
  if (!(limits.seconds > 0) || !std::isfinite(limits.seconds))
    throw InputError(what + ": the import time limit is " + std::to_string(limits.seconds) +
                     " s; give a positive number of seconds");
  if (limits.memory_mb == 0)
    throw InputError(what + ": the import memory limit is 0 MiB; give a positive number of MiB");

  const std::size_t resident_at_start = statm_bytes(getpid(), 1);
  const std::size_t address_space = statm_bytes(getpid(), 0);
  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0)
    throw Error(what + ": cannot start the process that reads it (" + std::strerror(errno) + ")");
  const pid_t pid = fork();
  if (pid < 0) {
    const int err = errno;
    close(fds[0]);
    close(fds[1]);
    throw Error(what + ": cannot start the process that reads it (" + std::strerror(err) +
                "): the system is short of processes or memory");
  }
  if (pid == 0) {
    close(fds[0]);
    child(fds[1], work, limits, address_space);
  }
  close(fds[1]);

  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  const auto deadline = start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(limits.seconds));
  const std::size_t memory_cap = limits.memory_mb * (std::size_t{1} << 20);
  // What the parent keeps of the answer is bounded too: no larger than the child could hold.
  const std::size_t answer_cap = memory_cap + (std::size_t{64} << 20);
  enum class Stop { None, Time, Memory, Answer } stopped = Stop::None;
  std::string answer;
  char chunk[1 << 16];
  for (;;) {
    pollfd p{fds[0], POLLIN, 0};
    const int r = poll(&p, 1, 20);
    if (r < 0 && errno != EINTR) break;
    bool eof = false;
    if (r > 0) {
      const ssize_t n = ::read(fds[0], chunk, sizeof chunk);
      if (n > 0) answer.append(chunk, static_cast<std::size_t>(n));
      else if (n == 0 || errno != EINTR) eof = true;
    }
    if (eof) {
      if (Clock::now() > deadline) stopped = Stop::Time;
      break;
    }
    const std::size_t resident = statm_bytes(pid, 1);
    const std::size_t grown = resident > resident_at_start ? resident - resident_at_start : 0;
    if (grown > memory_cap) stopped = Stop::Memory;
    else if (Clock::now() > deadline) stopped = Stop::Time;
    else if (answer.size() > answer_cap) stopped = Stop::Answer;
    if (stopped != Stop::None) {
      kill(pid, SIGKILL);
      break;
    }
  }
  close(fds[0]);
  int wstatus = 0;
  rusage usage{};
  while (wait4(pid, &wstatus, 0, &usage) < 0 && errno == EINTR) {
  }
  // The peak, which polling can miss: the child started with this process's resident pages.
  const std::size_t peak = static_cast<std::size_t>(usage.ru_maxrss) * 1024;
  if (stopped == Stop::None && peak > resident_at_start && peak - resident_at_start > memory_cap)
    stopped = Stop::Memory;

  const std::string unharmed = " (this session is unharmed)";
  switch (stopped) {
    case Stop::Memory:
      refuse_for_memory(what, limits.memory_mb);
    case Stop::Time: {
      std::ostringstream s;
      s << what << ": reading it took longer than " << limits.seconds << " s, so it was stopped" << unharmed
        << ": the file is malformed, or larger than the import time limit allows; raise the limit for a very "
           "large mesh, or export it again";
      throw InputError(s.str());
    }
    case Stop::Answer:
      throw InputError(what + ": the mesh read from it is larger than the import memory limit (" +
                       std::to_string(limits.memory_mb) + " MiB) allows; raise the limit for a very large mesh");
    case Stop::None:
      break;
  }

  constexpr std::size_t header = 1 + sizeof(std::uint64_t);
  std::uint64_t size = 0;
  if (answer.size() >= header) std::memcpy(&size, answer.data() + 1, sizeof size);
  const bool whole = answer.size() >= header && answer.size() - header == size;
  if (!(WIFEXITED(wstatus) && WEXITSTATUS(wstatus) == 0 && whole)) {
    std::ostringstream s;
    s << what << ": assimp crashed while reading it (";
    if (WIFSIGNALED(wstatus)) {
      const int sig = WTERMSIG(wstatus);
      const char* name = strsignal(sig);
      s << "signal " << sig << ", " << (name ? name : "unknown");
    } else if (WIFEXITED(wstatus)) {
      s << "its process exited with status " << WEXITSTATUS(wstatus) << " and no result";
    } else {
      s << "its process ended with no result";
    }
    s << ")" << unharmed
      << ": the file is malformed in a way Kiji's checks do not catch; export it again, or in another format";
    throw InputError(s.str());
  }
  const auto status = static_cast<Status>(static_cast<std::uint8_t>(answer[0]));
  std::string payload = answer.substr(header);
  switch (status) {
    case kOk:
      return payload;
    case kInput:
      throw InputError(payload);
    case kOutOfMemory:
      refuse_for_memory(what, limits.memory_mb);
    case kFailed:
    default:
      throw InputError(what + ": assimp failed while reading it (" + payload + ")" + unharmed +
                       ": check the file is a mesh file, or export it again");
  }
}

}  // namespace kiji::detail
