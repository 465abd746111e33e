// `desslam eval <groundtruth> <estimate>`: ATE and RPE of a TUM-format estimate, as a table or
// JSON; for a CameraTrajectory_all.txt whose maps were not all merged, each map's ATE. The work is
// in desslam_eval; this file only wires arguments to it.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <map>
#include <memory>
#include <set>
#include <string>

#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "core/error.hpp"
#include "eval/evaluation.hpp"
#include "io/trajectory_io.hpp"

namespace desslam::app {
namespace {

struct EvalArgs {
  std::string groundtruth;
  std::string estimate;
  bool json = false;
  double max_dt = 0.02;
  double delta_s = 1.0;
  std::string aligned_path;
};

// CameraTrajectory_all.txt with maps never merged: each map's ATE, aligned on its own, and the RMS
// over all of them; no RPE (a pair across two maps compares unrelated worlds).
void runAtlasEval(const EvalArgs& args, const Trajectory& gt, const AtlasTrajectory& est) {
  eval::AtlasAteResult result;
  try {
    result = eval::computeAtlasAte(gt, est, args.max_dt);
  } catch (const InputError& e) {
    throw InputError(args.estimate + " against " + args.groundtruth + ": " + e.what());
  }
  if (!std::isfinite(result.all_maps_m.rmse))
    throw InputError("the ATE of " + args.estimate + " against " + args.groundtruth +
                     " is not finite: check both files for implausibly large coordinates");
  if (!args.aligned_path.empty()) {
    // Each pose moved by its own map's alignment: one file to plot over the ground truth (a map
    // with fewer than 3 poses that associate has no alignment and is left out).
    std::map<int, SE3> T_gt_est;
    for (const eval::MapAte& m : result.maps)
      if (m.ate) T_gt_est[m.world_map] = m.ate->T_gt_est;
    Trajectory aligned;
    for (const AtlasPose& p : est)
      if (auto it = T_gt_est.find(p.world_map); it != T_gt_est.end()) aligned.push_back({p.timestamp, it->second * p.T_w_c});
    io::writeTumTrajectory(args.aligned_path, aligned);
  }
  if (args.json) {
    nlohmann::json maps = nlohmann::json::array();
    for (const eval::MapAte& m : result.maps)
      maps.push_back({{"world_map", m.world_map},
                      {"poses", m.poses},
                      {"ate", m.ate ? eval::toJson(*m.ate) : nlohmann::json(nullptr)}});
    const nlohmann::json report = {{"groundtruth", args.groundtruth},
                                   {"estimate", args.estimate},
                                   {"max_dt", args.max_dt},
                                   {"maps", maps},
                                   {"ate_all_maps", eval::toJson(result.all_maps_m)}};
    std::cout << report.dump(2) << "\n";
    return;
  }
  std::printf("%zu maps never merged: each is aligned to the ground truth on its own (one alignment across\n"
              "them would mix unrelated worlds); no RPE across maps (evaluate CameraTrajectory.txt for the\n"
              "main map's RPE)\n",
              result.maps.size());
  std::printf("%-10s %8s %8s %12s %10s\n", "world_map", "poses", "matched", "ATE rmse [m]", "max [m]");
  for (const eval::MapAte& m : result.maps) {
    if (m.ate)
      std::printf("%-10d %8zu %8zu %12.6f %10.6f\n", m.world_map, m.poses, m.ate->matched, m.ate->translation_m.rmse,
                  m.ate->translation_m.max);
    else
      std::printf("%-10d %8zu %8s %12s %10s   (fewer than 3 poses associate)\n", m.world_map, m.poses, "-", "-", "-");
  }
  std::printf("%-10s %8zu %8zu %12.6f %10.6f   (every matched pose, each map aligned on its own)\n", "all",
              est.size(), result.all_maps_m.count, result.all_maps_m.rmse, result.all_maps_m.max);
  if (!args.aligned_path.empty()) std::cout << "aligned estimate written to " << args.aligned_path << "\n";
}

void runEval(const EvalArgs& args) {
  const Trajectory gt = io::readTumTrajectory(args.groundtruth);
  Trajectory est;
  if (io::hasAtlasColumns(args.estimate)) {
    const AtlasTrajectory atlas = io::readAtlasTrajectory(args.estimate);
    std::set<int> worlds;
    for (const AtlasPose& p : atlas) worlds.insert(p.world_map);
    if (worlds.size() > 1) return runAtlasEval(args, gt, atlas);
    for (const AtlasPose& p : atlas) est.push_back({p.timestamp, p.T_w_c});  // one world: one trajectory
  } else {
    est = io::readTumTrajectory(args.estimate);
  }
  // The metrics' errors (too few poses, timestamps that do not associate) name both files.
  const auto evaluate = [&](const auto& compute) {
    try {
      return compute();
    } catch (const InputError& e) {
      throw InputError(args.estimate + " against " + args.groundtruth + ": " + e.what());
    }
  };
  const eval::AteResult ate = evaluate([&] { return eval::computeAte(gt, est, args.max_dt); });
  const eval::RpeResult rpe = evaluate([&] { return eval::computeRpe(gt, est, args.delta_s, args.max_dt); });
  // The readers refuse non-finite poses; a result that still is not finite (poses so far apart
  // that squares overflow) is bad input too, never a table of inf and nan.
  const nlohmann::json results = {{"ate", eval::toJson(ate)}, {"rpe", eval::toJson(rpe)}};
  if (results.dump().find("null") != std::string::npos || !std::isfinite(ate.translation_m.rmse))
    throw InputError("the ATE/RPE of " + args.estimate + " against " + args.groundtruth +
                     " is not finite: check both files for implausibly large coordinates");

  if (!args.aligned_path.empty()) {
    Trajectory aligned = est;
    for (StampedPose& pose : aligned) pose.T_w_c = ate.T_gt_est * pose.T_w_c;
    io::writeTumTrajectory(args.aligned_path, aligned);
  }
  if (args.json) {
    const nlohmann::json report = {{"groundtruth", args.groundtruth}, {"estimate", args.estimate},
                                   {"max_dt", args.max_dt},           {"ate", eval::toJson(ate)},
                                   {"rpe", eval::toJson(rpe)}};
    std::cout << report.dump(2) << "\n";
  } else {
    std::cout << eval::formatTable(ate, rpe, args.max_dt);
    if (!args.aligned_path.empty()) std::cout << "aligned estimate written to " << args.aligned_path << "\n";
  }
}

}  // namespace

void registerEvalCommand(CLI::App& app) {
  auto args = std::make_shared<EvalArgs>();
  CLI::App* cmd = app.add_subcommand(
      "eval", "Accuracy of an estimated trajectory against ground truth (TUM format): ATE and RPE");
  cmd->add_option("groundtruth", args->groundtruth, "Ground-truth trajectory (timestamp tx ty tz qx qy qz qw)")
      ->required();
  cmd->add_option("estimate", args->estimate,
                  "Estimated trajectory, e.g. CameraTrajectory.txt; CameraTrajectory_all.txt with maps never merged "
                  "gives each map's ATE, each aligned on its own")
      ->required();
  cmd->add_flag("--json", args->json, "Print one JSON object instead of a table");
  cmd->add_option("--max-dt", args->max_dt, "Largest timestamp difference for associating poses (s)")
      ->check(finiteRange(1e-6, 10.0))
      ->capture_default_str();
  cmd->add_option("--delta", args->delta_s, "RPE window (s); TUM's RGB-D default is 1 s")
      ->check(finiteRange(1e-3, 1e6))
      ->capture_default_str();
  cmd->add_option("--aligned", args->aligned_path, "Write the estimate aligned to the ground truth (TUM format)");
  cmd->callback([args] { runEval(*args); });
}

}  // namespace desslam::app
