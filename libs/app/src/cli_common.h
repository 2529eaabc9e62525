// Private to dbacov_app: command-line pieces that every app shares (CLI11).
#pragma once

#include <ostream>
#include <string>

namespace CLI {
class App;
}

namespace dbacov::app::detail {

/// Call in a `catch (...)` around cli.parse() and the usage checks that follow it: for --help
/// (CLI11's ParseError with exit code 0) prints the help to `out` and returns 0; for any other
/// CLI11 error or std::exception prints "<app>: <error>" and a hint to `err` and returns 2 (bad
/// usage). Anything else is rethrown.
int usageExitStatus(const CLI::App& cli, const std::string& app, std::ostream& out,
                    std::ostream& err);

/// The app's --help text (CLI11's, without range annotations such as `INT in [0 - 4096]`).
std::string helpText(const CLI::App& cli);

/// Registers --keep-going (the default) and --fail-fast (sets `fail_fast`), mutually exclusive,
/// for apps that read several snapshots (docs/reference/reliability.md).
void addFailurePolicyOptions(CLI::App& cli, bool& fail_fast);

}  // namespace dbacov::app::detail
