#include "cli_common.h"

#include <exception>
#include <regex>

#include <CLI/CLI.hpp>

namespace dbacov::app::detail {
namespace {

/// CLI11's help without its range annotations: `--threads UINT:INT in [0 - 4096]` reads as
/// `--threads UINT` (the ranges are checked all the same, and the error names them).
class HelpFormatter : public CLI::Formatter {
 public:
  std::string make_option_opts(const CLI::Option* opt) const override {
    static const std::regex range(R"((:[A-Z]+)? in \[[^\]]*\])");
    return std::regex_replace(CLI::Formatter::make_option_opts(opt), range, "");
  }
};

}  // namespace

std::string helpText(const CLI::App& cli) {
  return HelpFormatter().make_help(&cli, cli.get_name(), CLI::AppFormatMode::Normal);
}

int usageExitStatus(const CLI::App& cli, const std::string& app, std::ostream& out,
                    std::ostream& err) {
  try {
    throw;
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) {
      out << helpText(cli);
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
