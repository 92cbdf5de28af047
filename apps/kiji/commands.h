// The kiji command line's subcommands. Each returns the process exit code.
#pragma once

#include <string>
#include <vector>

namespace kiji::cli {

int drape_command(const std::vector<std::string>& args);
int tools_command(const std::vector<std::string>& args);
// `kiji bench ...` and `kiji bench peers ...`: runs kiji-bench with the same arguments.
int bench_program(const std::vector<std::string>& args);
int recover_command(const std::vector<std::string>& args);
int peer_command(const std::vector<std::string>& args);

}  // namespace kiji::cli
