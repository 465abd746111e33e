// desslam: RGB-D SLAM for dynamic scenes. `desslam --help` lists the sub-commands; the exit
// statuses (the same for every sub-command) are in core/exit_codes.hpp and the README.
#include <exception>
#include <iostream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <spdlog/cfg/env.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "commands.hpp"

namespace {

// The sub-commands of `level` (every one, also those not used on this command line).
std::vector<CLI::App*> subcommandsOf(CLI::App& level) {
  return level.get_subcommands([](CLI::App*) { return true; });
}

// "type one of run, eval, ... (e.g. `desslam run --help`; `desslam --help` lists them)": what to
// type after `path`, the command whose sub-commands `subs` are (not empty).
std::string whatToType(const std::string& path, const std::vector<CLI::App*>& subs) {
  std::string names;
  for (CLI::App* sub : subs) names += (names.empty() ? "" : ", ") + sub->get_name();
  return "type one of " + names + " (e.g. `" + path + " " + subs.front()->get_name() + " --help`; `" + path +
         " --help` lists them)";
}

// "desslam frobnicate" / "desslam vocab tran": says which sub-commands there are (CLI11 alone
// would only say that an argument was not expected). Empty when the words name sub-commands.
std::string unknownSubcommandMessage(CLI::App& app, int argc, char** argv) {
  CLI::App* level = &app;
  std::string path = "desslam";
  for (int i = 1; i < argc; ++i) {
    const std::string word = argv[i];
    if (word.empty() || word[0] == '-') return {};  // options: CLI11 checks them
    const std::vector<CLI::App*> subs = subcommandsOf(*level);
    if (subs.empty()) return {};  // a positional argument of the command
    CLI::App* found = nullptr;
    for (CLI::App* sub : subs)
      if (sub->get_name() == word) found = sub;
    if (found == nullptr) return "unknown sub-command '" + word + "' of " + path + ": " + whatToType(path, subs);
    level = found;
    path += " " + word;
  }
  return {};
}

// "desslam" or "desslam vocab" with no sub-command after it (CLI11 would only say "A subcommand is
// required"): which sub-commands there are. Empty when that is not what `error` is about.
std::string missingSubcommandMessage(CLI::App& app, const CLI::ParseError& error) {
  if (dynamic_cast<const CLI::RequiredError*>(&error) == nullptr) return {};
  // The innermost command given on the command line.
  CLI::App* level = &app;
  std::string path = "desslam";
  while (!level->get_subcommands().empty()) {
    level = level->get_subcommands().front();
    path += " " + level->get_name();
  }
  const std::vector<CLI::App*> subs = subcommandsOf(*level);
  if (subs.empty() || level->get_require_subcommand_min() == 0) return {};
  return path + " needs a sub-command: " + whatToType(path, subs);
}

}  // namespace

int main(int argc, char** argv) {
  namespace exit_code = desslam::exit_code;
  CLI::App app{"DeS-SLAM: ORB RGB-D SLAM with semantic and geometric dynamic-feature removal"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "desslam 0.1.0");
  desslam::app::registerRunCommand(app);
  desslam::app::registerEvalCommand(app);
  desslam::app::registerVocabCommand(app);
  desslam::app::registerMapCheckCommand(app);
  desslam::app::registerReportCommand(app);
  // Log lines go to stderr, results (tables, JSON) to stdout, so a pipe gets only the results.
  // SPDLOG_LEVEL (e.g. debug, or "info,loop=debug") or --log-level choose how much.
  spdlog::set_default_logger(spdlog::stderr_color_mt("desslam"));
  spdlog::cfg::load_env_levels();
  std::string log_level;
  app.add_option("--log-level", log_level,
                 "Log detail on stderr: trace, debug, info (default), warning, error, off (or env SPDLOG_LEVEL)")
      ->check(CLI::IsMember({"trace", "debug", "info", "warning", "warn", "error", "off"}));
  app.parse_complete_callback([&log_level] {
    if (!log_level.empty()) spdlog::set_level(spdlog::level::from_str(log_level == "warning" ? "warn" : log_level));
  });
  if (const std::string unknown = unknownSubcommandMessage(app, argc, argv); !unknown.empty()) {
    std::cerr << "error: " << unknown << "\n";
    return exit_code::kUsage;
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (const std::string missing = missingSubcommandMessage(app, e); !missing.empty()) {
      std::cerr << "error: " << missing << "\n";
      return exit_code::kUsage;
    }
    // --help and --version are "errors" with status 0; every real command-line error is kUsage.
    const int cli_status = app.exit(e);
    return cli_status == 0 ? exit_code::kOk : exit_code::kUsage;
  } catch (const desslam::app::ExitStatus& status) {
    return status.code;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return desslam::app::exitCodeFor(e);
  }
  return exit_code::kOk;
}
