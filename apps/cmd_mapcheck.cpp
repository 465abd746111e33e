// `desslam mapcheck <out_dir> <sequence_dir>`: consistency of a run's dense map: the share of
// map points that LATER keyframes see through (observed depth along the point's ray more than
// the tolerance beyond it). Ghosts of moving people produce such points; static surfaces do not.
// The work is dense::checkRunMap; this file resolves the config and prints.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "core/error.hpp"
#include "dense/run_map_check.hpp"
#include "io/config.hpp"

namespace desslam::app {
namespace {

namespace fs = std::filesystem;

struct MapCheckArgs {
  std::string out_dir;
  std::string sequence;
  std::string config;  // empty: the one named in out_dir/report.json
  bool json = false;
  double tolerance = 0.05;
  int window_radius_px = 1;
};

// The camera the run used: --config, else the config path recorded in report.json.
SystemOptions loadRunConfig(const MapCheckArgs& args) {
  if (!args.config.empty()) return io::loadConfig(args.config);
  const fs::path report_path = fs::path(args.out_dir) / "report.json";
  std::ifstream in(report_path);
  if (!in) throw InputError("no --config given and " + report_path.string() + " is missing: pass --config <yaml>");
  const nlohmann::json report = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
  if (!report.is_object() || !report.contains("config") || !report["config"].is_string())
    throw InputError(report_path.string() + " names no config: pass --config <yaml>");
  const fs::path config = report["config"].get<std::string>();
  if (!fs::is_regular_file(config))
    throw InputError("config " + config.string() + " named in " + report_path.string() +
                     " does not exist (relative to the current folder): pass --config <yaml>");
  return io::loadConfig(config);
}

void runMapCheck(const MapCheckArgs& args) {
  const SystemOptions options = loadRunConfig(args);
  dense::MapCheckOptions check_options;
  check_options.tolerance = args.tolerance;
  check_options.window_radius_px = args.window_radius_px;
  const dense::RunMapCheckResult run = dense::checkRunMap(args.out_dir, args.sequence, options.camera, check_options);
  const dense::MapCheckResult& result = run.check;
  if (args.json) {
    const nlohmann::json j = {{"out_dir", args.out_dir},
                              {"sequence", args.sequence},
                              {"map_points", run.map_points},
                              {"keyframes", run.keyframes},
                              {"tolerance_m", args.tolerance},
                              {"window_radius_px", args.window_radius_px},
                              {"checked", result.checked},
                              {"violations", result.violations},
                              {"free_space_violation_share", result.share()}};
    std::cout << j.dump(2) << "\n";
  } else {
    std::cout << "map points          " << run.map_points << "\n"
              << "keyframes           " << run.keyframes << "\n"
              << "checked points      " << result.checked << " (seen by a later keyframe)\n"
              << "seen through        " << result.violations << " (depth > point + " << args.tolerance << " m)\n"
              << "violation share     " << result.share() << "\n";
  }
}

}  // namespace

void registerMapCheckCommand(CLI::App& app) {
  auto args = std::make_shared<MapCheckArgs>();
  CLI::App* cmd = app.add_subcommand(
      "mapcheck", "Dense-map consistency: share of map points that later keyframes see through (ghosts)");
  cmd->add_option("out_dir", args->out_dir, "Output folder of `desslam run` (dense_map.ply, dense_map_sources.bin, "
                                             "KeyFrameTrajectory.txt)")
      ->required();
  cmd->add_option("sequence", args->sequence, "The run's sequence folder (depth images of the keyframes)")->required();
  cmd->add_option("--config,-c", args->config, "Camera YAML of the run (default: the one named in report.json)");
  cmd->add_flag("--json", args->json, "Print one JSON object instead of a table");
  cmd->add_option("--tolerance", args->tolerance, "Metres the observed depth may lie beyond a point")
      ->check(finiteRange(1e-4, 10.0))
      ->capture_default_str();
  cmd->add_option("--window", args->window_radius_px,
                  "Seen through only if every reading within this many pixels is beyond the point")
      ->check(CLI::Range(0, 50))
      ->capture_default_str();
  cmd->callback([args] { runMapCheck(*args); });
}

}  // namespace desslam::app
