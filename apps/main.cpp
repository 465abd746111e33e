// desslam: RGB-D SLAM for dynamic scenes. `desslam --help` lists the sub-commands; the exit
// statuses (the same for every sub-command) are in core/exit_codes.hpp and the README.
#include <exception>
#include <iostream>

#include <CLI/CLI.hpp>

#include "commands.hpp"

int main(int argc, char** argv) {
  namespace exit_code = desslam::exit_code;
  CLI::App app{"DeS-SLAM: ORB RGB-D SLAM with semantic and geometric dynamic-feature removal"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "desslam 0.1.0");
  desslam::app::registerRunCommand(app);
  desslam::app::registerEvalCommand(app);
  desslam::app::registerVocabCommand(app);
  desslam::app::registerMapCheckCommand(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
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
