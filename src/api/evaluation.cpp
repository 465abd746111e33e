// The public evaluation (include/desslam/evaluation.hpp) over desslam_eval, computed and
// checked as `desslam eval` (apps/cmd_eval.cpp) does.
#include "desslam/evaluation.hpp"

#include <cmath>

#include <nlohmann/json.hpp>

#include "api/pose_conversion.hpp"
#include "core/error.hpp"
#include "eval/evaluation.hpp"
#include "io/trajectory_io.hpp"

namespace desslam {
namespace {

ErrorSummary toSummary(const eval::ErrorStats& s) { return {s.rmse, s.mean, s.median, s.std, s.min, s.max, s.count}; }

eval::ErrorStats toStats(const ErrorSummary& s) {
  eval::ErrorStats out;
  out.rmse = s.rmse;
  out.mean = s.mean;
  out.median = s.median;
  out.std = s.std;
  out.min = s.min;
  out.max = s.max;
  out.count = s.count;
  return out;
}

AteFigures toFigures(const eval::AteResult& ate) {
  AteFigures out;
  out.translation_m = toSummary(ate.translation_m);
  out.T_gt_est = ate.T_gt_est.matrix();
  out.matched = ate.matched;
  out.gt_poses = ate.gt_poses;
  out.est_poses = ate.est_poses;
  out.alignment_unique = ate.alignment_unique;
  return out;
}

RpeFigures toFigures(const eval::RpeResult& rpe) {
  RpeFigures out;
  out.translation_m = toSummary(rpe.translation_m);
  out.rotation_deg = toSummary(rpe.rotation_deg);
  out.delta_s = rpe.delta_s;
  out.pairs = rpe.pairs;
  return out;
}

// Back to the internal results, for the JSON and the table (one formatter for both paths).
eval::AteResult toResult(const AteFigures& ate) {
  eval::AteResult out;
  out.translation_m = toStats(ate.translation_m);
  out.T_gt_est = SE3::fromMatrix(ate.T_gt_est);
  out.matched = ate.matched;
  out.gt_poses = ate.gt_poses;
  out.est_poses = ate.est_poses;
  out.alignment_unique = ate.alignment_unique;
  return out;
}

eval::RpeResult toResult(const RpeFigures& rpe) {
  eval::RpeResult out;
  out.translation_m = toStats(rpe.translation_m);
  out.rotation_deg = toStats(rpe.rotation_deg);
  out.delta_s = rpe.delta_s;
  out.pairs = rpe.pairs;
  return out;
}

Evaluation evaluateTrajectories(const Trajectory& gt, const Trajectory& est, double max_dt, double delta_s,
                                const std::string& gt_name, const std::string& est_name) {
  const eval::AteResult ate = eval::computeAte(gt, est, max_dt);
  const eval::RpeResult rpe = eval::computeRpe(gt, est, delta_s, max_dt);
  // As `desslam eval`: a result that is not finite (poses so far apart that squares overflow) is
  // bad input, never a table of inf and nan.
  const nlohmann::json results = {{"ate", eval::toJson(ate)}, {"rpe", eval::toJson(rpe)}};
  if (results.dump().find("null") != std::string::npos || !std::isfinite(ate.translation_m.rmse))
    throw InputError("the ATE/RPE of " + est_name + " against " + gt_name +
                     " is not finite: check both for implausibly large coordinates");
  Evaluation out;
  out.ate = toFigures(ate);
  out.rpe = toFigures(rpe);
  out.max_dt = max_dt;
  return out;
}

}  // namespace

std::string Evaluation::toJson() const {
  const nlohmann::json json = {{"ate", eval::toJson(toResult(ate))}, {"rpe", eval::toJson(toResult(rpe))}};
  return json.dump(2);
}

std::string Evaluation::table() const { return eval::formatTable(toResult(ate), toResult(rpe), max_dt); }

AteFigures computeAte(const std::vector<FramePose>& groundtruth, const std::vector<FramePose>& estimate,
                      double max_dt) {
  return toFigures(eval::computeAte(api::toTrajectory(groundtruth, "the ground truth"),
                                    api::toTrajectory(estimate, "the estimate"), max_dt));
}

RpeFigures computeRpe(const std::vector<FramePose>& groundtruth, const std::vector<FramePose>& estimate,
                      double delta_s, double max_dt) {
  return toFigures(eval::computeRpe(api::toTrajectory(groundtruth, "the ground truth"),
                                    api::toTrajectory(estimate, "the estimate"), delta_s, max_dt));
}

Evaluation evaluate(const std::vector<FramePose>& groundtruth, const std::vector<FramePose>& estimate, double max_dt,
                    double delta_s) {
  return evaluateTrajectories(api::toTrajectory(groundtruth, "the ground truth"),
                              api::toTrajectory(estimate, "the estimate"), max_dt, delta_s, "the ground truth",
                              "the estimate");
}

Evaluation evaluateFiles(const std::filesystem::path& groundtruth, const std::filesystem::path& estimate,
                         double max_dt, double delta_s) {
  return evaluateTrajectories(io::readTumTrajectory(groundtruth), io::readTumTrajectory(estimate), max_dt, delta_s,
                              groundtruth.string(), estimate.string());
}

}  // namespace desslam
