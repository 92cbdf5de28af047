#include "import/isolated.h"

#include "kiji/error.h"
#include "base/parallel.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/time.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
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
constexpr std::size_t kHeader = 1 + sizeof(std::uint64_t);
// Past these a limit means "none": the arithmetic below stays in range.
constexpr std::size_t kMaxMemoryMb = std::size_t{1} << 30;
constexpr double kMaxSeconds = 1e7;
constexpr int kAnswerFd = 3;

// Fields of /proc/<pid>/statm, in bytes: 0 = address space, 1 = resident; 0 if it cannot be read.
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

// Set in the child when an allocation failed. assimp catches std::bad_alloc, reports it as an
// unreadable file and sometimes carries on without the object: either way the cause is memory.
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

[[noreturn]] void child(int fd, pid_t parent, const std::function<std::string()>& work, std::size_t memory_mb,
                        double seconds, std::size_t address_space) {
  // The child dies with the thread that forked it (which waits for it), writes no core file, and
  // holds no descriptor but its answer's and the standard three: another import's pipe held open
  // here would keep that import waiting for this one.
  prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (getppid() != parent) _exit(4);
  if (fd != kAnswerFd) {
    if (dup2(fd, kAnswerFd) < 0) _exit(4);
    fd = kAnswerFd;
  }
  close_range(kAnswerFd + 1, ~0U, 0);
  const rlimit no_core{0, 0};
  setrlimit(RLIMIT_CORE, &no_core);
  // A backstop for a child whose parent cannot watch the clock (stopped, or gone before the signal).
  const auto cpu = static_cast<rlim_t>(std::ceil(seconds)) + 10;
  const rlimit cpu_limit{cpu, cpu + 5};
  setrlimit(RLIMIT_CPU, &cpu_limit);
#ifndef KIJI_SANITIZED
  // A crash ends the child: the parent's handlers (Python's fault handler, for one) would run in it
  // otherwise. Sanitizers keep their own, which report the crash.
  for (int sig : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT}) signal(sig, SIG_DFL);
  // An allocation past the limit fails at once, rather than after the memory is touched. Sanitizers
  // reserve terabytes of address space up front, so there the resident limit alone holds it.
  if (address_space > 0) {
    const rlim_t cap = address_space + memory_mb * (std::size_t{1} << 20);
    const rlimit as{cap, cap};
    setrlimit(RLIMIT_AS, &as);
  }
#else
  (void)address_space;
#endif
  for (int sig : {SIGINT, SIGTERM, SIGHUP, SIGPIPE}) signal(sig, SIG_DFL);
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
  } catch (const std::exception& e) {
    status = kFailed;
    payload = e.what();
  } catch (...) {
    status = kFailed;
    payload = "an exception that is not a std::exception";
  }
  if (allocation_failed) {
    status = kOutOfMemory;
    payload.clear();
  }
  const std::uint64_t size = payload.size();
  const bool ok = write_all(fd, &status, 1) && write_all(fd, &size, sizeof size) &&
                  write_all(fd, payload.data(), payload.size());
  // _exit: the parent's atexit handlers and buffered output are the parent's, not this copy's.
  _exit(ok ? 0 : 3);
}

// Kills and reaps the child and closes the pipe however the parent leaves (an exception, a
// cancelled thread): no child is left running, blocked on a full pipe, or unreaped.
struct ChildGuard {
  pid_t pid;
  int fd;
  bool reaped = false;
  int wstatus = 0;
  bool status_known = false;
  long peak_kb = 0;

  // Waits for the child's end, up to `deadline`; false if it had not ended by then.
  template <typename TimePoint>
  bool wait_until(TimePoint deadline) {
    for (;;) {
      rusage usage{};
      const pid_t r = wait4(pid, &wstatus, WNOHANG, &usage);
      if (r == pid) {
        reaped = status_known = true;
        peak_kb = usage.ru_maxrss;
        return true;
      }
      if (r < 0 && errno == EINTR) continue;
      if (r < 0) {  // reaped elsewhere (SIGCHLD ignored, or another waiter): its status is lost
        reaped = true;
        return true;
      }
      if (TimePoint::clock::now() >= deadline) return false;
      usleep(1000);
    }
  }
  void kill_and_reap() {
    if (reaped) return;
    kill(pid, SIGKILL);
    rusage usage{};
    pid_t r;
    while ((r = wait4(pid, &wstatus, 0, &usage)) < 0 && errno == EINTR) {
    }
    reaped = true;
    status_known = r == pid;
    if (status_known) peak_kb = usage.ru_maxrss;
  }
  ~ChildGuard() {
    kill_and_reap();
    if (fd >= 0) close(fd);
  }
};

std::string limit_text(double seconds) {
  std::ostringstream s;
  s << seconds << " s";
  return s.str();
}

}  // namespace

std::string run_isolated(const std::function<std::string()>& work, const ImportLimits& limits,
                         const std::string& what) {
  if (!limits.isolate) return work();
  if (!(limits.seconds > 0) || std::isnan(limits.seconds))
    throw InputError(what + ": the import time limit is " + limit_text(limits.seconds) +
                     "; give a positive number of seconds");
  if (limits.memory_mb == 0)
    throw InputError(what + ": the import memory limit is 0 MiB; give a positive number of MiB");
  const double seconds = std::min(limits.seconds, kMaxSeconds);
  const std::size_t memory_mb = std::min(limits.memory_mb, kMaxMemoryMb);

  // Memory is counted from what this process holds now: the child starts with its pages.
  const std::size_t resident_at_start = statm_bytes(getpid(), 1);
  const std::size_t address_space = statm_bytes(getpid(), 0);
  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0)
    throw Error(what + ": cannot start the process that reads it (" + std::strerror(errno) + ")");
  const pid_t parent = getpid();
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
    child(fds[1], parent, work, memory_mb, seconds, address_space);
  }
  close(fds[1]);
  ChildGuard guard{pid, fds[0]};

  using Clock = std::chrono::steady_clock;
  const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
  const std::size_t memory_cap = memory_mb * (std::size_t{1} << 20);
  // The answer is no larger than what the child could hold.
  const std::size_t answer_cap = memory_cap + (std::size_t{64} << 20);
  enum class Stop { None, Time, Memory, Answer, Broken } stopped = Stop::None;
  int broken_errno = 0;
  std::string answer;
  std::uint64_t size = 0;
  bool whole = false;
  auto last_check = Clock::time_point{};
  char chunk[1 << 16];
  while (!whole) {
    pollfd p{fds[0], POLLIN, 0};
    const int r = poll(&p, 1, 20);
    if (r < 0 && errno != EINTR) {
      stopped = Stop::Broken;
      broken_errno = errno;
      break;
    }
    bool eof = false;
    if (r > 0) {
      const ssize_t n = ::read(fds[0], chunk, sizeof chunk);
      if (n > 0) {
        answer.append(chunk, static_cast<std::size_t>(n));
        if (size == 0 && answer.size() >= kHeader) {
          std::memcpy(&size, answer.data() + 1, sizeof size);
          if (size > answer_cap) {
            stopped = Stop::Answer;
            break;
          }
          answer.reserve(kHeader + size);
        }
        whole = answer.size() >= kHeader && answer.size() - kHeader >= size;
      } else if (n == 0) {
        eof = true;
      } else if (errno != EINTR) {
        stopped = Stop::Broken;
        broken_errno = errno;
        break;
      }
    }
    if (whole || eof) break;
    const auto now = Clock::now();
    if (now >= deadline) {
      stopped = Stop::Time;
      break;
    }
    if (resident_at_start > 0 && now - last_check >= std::chrono::milliseconds(20)) {
      last_check = now;
      const std::size_t resident = statm_bytes(pid, 1);
      if (resident > resident_at_start && resident - resident_at_start > memory_cap) {
        stopped = Stop::Memory;
        break;
      }
    }
  }
  if (whole) {
    guard.wait_until(Clock::now() + std::chrono::seconds(1));  // it exits as soon as it has written
  } else if (stopped == Stop::None && !guard.wait_until(deadline)) {
    stopped = Stop::Time;  // it closed its pipe and went on
  }
  guard.kill_and_reap();
  // The peak, which polling can miss (the child started with this process's resident pages).
  const std::size_t peak = static_cast<std::size_t>(guard.peak_kb) * 1024;
  if (stopped == Stop::None && !whole && resident_at_start > 0 && peak > resident_at_start &&
      peak - resident_at_start > memory_cap)
    stopped = Stop::Memory;

  const std::string unharmed = " (this session is unharmed)";
  const std::string memory_refusal =
      what + ": reading it needed more than " + std::to_string(memory_mb) + " MiB of memory, the import limit, " +
      "so it was stopped" + unharmed +
      ": a count in the file is likely wrong, or the mesh is larger than the limit allows; raise the limit for a "
      "very large mesh, or export it again";
  switch (stopped) {
    case Stop::Memory:
      throw InputError(memory_refusal);
    case Stop::Time:
      throw InputError(what + ": reading it took longer than " + limit_text(seconds) + ", the import limit, so it "
                       "was stopped" + unharmed + ": the file is malformed, or larger than the limit allows; raise "
                       "the limit for a very large mesh, or export it again");
    case Stop::Answer:
      throw InputError(what + ": the mesh read from it is larger than the import memory limit (" +
                       std::to_string(memory_mb) + " MiB) allows" + unharmed + "; raise the limit for a very large mesh");
    case Stop::Broken:
      throw Error(what + ": the process reading it could not be followed (" + std::strerror(broken_errno) + ")" + unharmed);
    case Stop::None:
      break;
  }

  if (!whole) {
    std::ostringstream s;
    s << what << ": ";
    const int sig = guard.status_known && WIFSIGNALED(guard.wstatus) ? WTERMSIG(guard.wstatus) : 0;
    const char* name = sig ? strsignal(sig) : nullptr;
    if (sig == SIGXCPU) {
      s << "reading it used more than its CPU time limit, so it was stopped" << unharmed
        << ": the file is malformed, or larger than the limit allows; raise the limit for a very large mesh";
    } else if (sig == SIGKILL || sig == SIGINT || sig == SIGTERM || sig == SIGHUP) {
      s << "the process reading it was stopped from outside (signal " << sig << ", " << (name ? name : "unknown")
        << ")" << unharmed << (sig == SIGKILL ? ": the system may have run short of memory; try again" : ": try again");
    } else {
      s << "assimp crashed while reading it (";
      if (sig) s << "signal " << sig << ", " << (name ? name : "unknown");
      else if (guard.status_known && WIFEXITED(guard.wstatus))
        s << "its process exited with status " << WEXITSTATUS(guard.wstatus) << " and no result";
      else s << "its process ended with no result";
      s << ")" << unharmed
        << ": the file is malformed in a way Kiji's checks do not catch; export it again, or in another format";
    }
    throw InputError(s.str());
  }
  const auto status = static_cast<Status>(static_cast<std::uint8_t>(answer[0]));
  answer.resize(kHeader + size);
  answer.erase(0, kHeader);
  switch (status) {
    case kOk:
      return answer;
    case kInput:
      throw InputError(answer);
    case kOutOfMemory:
      throw InputError(memory_refusal);
    case kFailed:
    default:
      throw InputError(what + ": reading it failed (" + answer + ")" + unharmed +
                       ": check the file is a mesh file, or export it again");
  }
}

}  // namespace kiji::detail
