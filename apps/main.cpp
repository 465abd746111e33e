// desslam: RGB-D SLAM for dynamic scenes. `desslam --help` lists the sub-commands.
#include <exception>
#include <iostream>

#include <CLI/CLI.hpp>

#include "commands.hpp"

int main(int argc, char** argv) {
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
    return app.exit(e);
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
