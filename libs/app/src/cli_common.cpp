#include "cli_common.h"

#include <exception>

#include <CLI/CLI.hpp>

namespace dbacov::app::detail {

int usageExitStatus(const CLI::App& cli, const std::string& app, std::ostream& out,
                    std::ostream& err) {
  try {
    throw;
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) {
      out << cli.help();
      return 0;
    }
    err << app << ": " << e.what() << "\nRun with --help for usage.\n";
  } catch (const std::exception& e) {
    err << app << ": " << e.what() << "\nRun with --help for usage.\n";
  }
  return 2;
}

void addFailurePolicyOptions(CLI::App& cli, bool& fail_fast) {
  auto* keep_going = cli.add_flag(
      "--keep-going",
      "After a failed snapshot, go on with the others and write every output (default)");
  cli.add_flag("--fail-fast", fail_fast,
               "Stop at the first failed snapshot (exit 1) and write no output at all")
      ->excludes(keep_going);
}

}  // namespace dbacov::app::detail
