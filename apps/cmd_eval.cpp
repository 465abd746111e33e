// `desslam eval <groundtruth> <estimate>`: ATE and RPE of a TUM-format estimate, as a table or
// JSON. The work is in desslam_eval; this file only wires arguments to it.
#include <cmath>
#include <iostream>
#include <memory>
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

void runEval(const EvalArgs& args) {
  const Trajectory gt = io::readTumTrajectory(args.groundtruth);
  const Trajectory est = io::readTumTrajectory(args.estimate);
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
  cmd->add_option("estimate", args->estimate, "Estimated trajectory, e.g. CameraTrajectory.txt")->required();
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
