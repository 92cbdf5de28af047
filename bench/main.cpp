// kiji-bench: the benchmarks behind `kiji bench`, a program of their own so that the user's command
// line does not link Bullet's soft body (the comparison's cloth). `kiji bench ARGS` runs
// `kiji-bench ARGS`; the messages name `kiji bench`, the command the user typed.
#include "args.h"
#include "bench_commands.h"
#include "kiji/error.h"

#include <cstdio>
#include <exception>
#include <string>
#include <vector>

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  const bool peers = !args.empty() && args[0] == "peers";
  if (peers) args.erase(args.begin());
  try {
    return peers ? kiji::cli::peer_bench_command(args) : kiji::cli::bench_command(args);
  } catch (const kiji::cli::UsageError& e) {
    std::fprintf(stderr, "kiji bench: %s\n(see 'kiji bench --help')\n", e.what());
    return 2;
  } catch (const kiji::Error& e) {
    std::fprintf(stderr, "kiji bench: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "kiji bench: unexpected error: %s\n", e.what());
    return 1;
  }
}
