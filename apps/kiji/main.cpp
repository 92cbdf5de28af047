// kiji: the command line. Dispatches to a subcommand; every error is a message and an exit code.
#include "args.h"
#include "commands.h"
#include "kiji/error.h"
#include "kiji/version.h"

#include <cstdio>
#include <exception>
#include <string>
#include <vector>

namespace {

const char* kUsage =
    "usage: kiji COMMAND [options]\n"
    "\n"
    "commands:\n"
    "  drape     drop a flat garment on a body, let it settle, write the result\n"
    "  tools     list the tool plugins found, with their parameters\n"
    "  bench     measure this machine: the paper's tables, Bullet's cloth, haptics, scaling\n"
    "            ('kiji bench peers': a design session shared over LCM, the paper's table 3)\n"
    "  recover   rebuild a design session from its session file (an autosave) after a crash\n"
    "  peer      host or join a design session shared with others over the network\n"
    "  version   print Kiji's version\n"
    "\n"
    "'kiji COMMAND --help' describes a command's options.\n";

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  if (args.empty() || args[0] == "--help" || args[0] == "-h" || args[0] == "help") {
    std::fputs(kUsage, args.empty() ? stderr : stdout);
    return args.empty() ? 2 : 0;
  }
  const std::string command = args[0];
  args.erase(args.begin());
  try {
    if (command == "drape") return kiji::cli::drape_command(args);
    if (command == "tools") return kiji::cli::tools_command(args);
    if (command == "bench") return kiji::cli::bench_program(args);
    if (command == "recover") return kiji::cli::recover_command(args);
    if (command == "peer") return kiji::cli::peer_command(args);
    if (command == "version" || command == "--version") {
      std::printf("kiji %s\n", kiji::version());
      return 0;
    }
    std::fprintf(stderr, "kiji: unknown command '%s'\n\n%s", command.c_str(), kUsage);
    return 2;
  } catch (const kiji::cli::UsageError& e) {
    std::fprintf(stderr, "kiji %s: %s\n(see 'kiji %s --help')\n", command.c_str(), e.what(), command.c_str());
    return 2;
  } catch (const kiji::Error& e) {
    std::fprintf(stderr, "kiji %s: %s\n", command.c_str(), e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "kiji %s: unexpected error: %s\n", command.c_str(), e.what());
    return 1;
  }
}
