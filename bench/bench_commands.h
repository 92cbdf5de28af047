// kiji-bench's two benchmarks (run as `kiji bench` and `kiji bench peers`). Each returns the exit code.
#pragma once

#include <string>
#include <vector>

namespace kiji::cli {

int bench_command(const std::vector<std::string>& args);
int peer_bench_command(const std::vector<std::string>& args);

}  // namespace kiji::cli
