// Trajectory accuracy, as `desslam eval` computes it: absolute trajectory error (ATE, after one
// rigid alignment) and relative pose error (RPE), the way TUM's evaluate_ate.py / evaluate_rpe.py
// do for RGB-D sequences. Poses are associated by timestamp (nearest within max_dt, one to one).
//
//   const auto gt = desslam::readTumTrajectory("groundtruth.txt");
//   const desslam::Evaluation e = desslam::evaluate(gt, slam.trajectory());
//   std::cout << e.ate.translation_m.rmse << " m\n";
//
// Only the timestamps and T_w_c of the poses are used (map ids are ignored). Errors are thrown as
// std::runtime_error whose message says what is wrong (too few poses associate, a pose is not a
// rigid transform, a file is malformed).
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "desslam/desslam.hpp"

namespace desslam {

// Summary of a list of errors. std is the population standard deviation (numpy's default); median
// averages the two middle values of an even count. All zero when the list is empty.
struct ErrorSummary {
  double rmse = 0, mean = 0, median = 0, std = 0, min = 0, max = 0;
  std::size_t count = 0;
};

struct AteFigures {
  ErrorSummary translation_m;  // |gt_i - T_gt_est * est_i| over the matched poses
  // The rigid transform that maps the estimate's world frame into the ground truth's.
  Eigen::Matrix4d T_gt_est = Eigen::Matrix4d::Identity();
  std::size_t matched = 0;       // associated pose pairs
  std::size_t gt_poses = 0, est_poses = 0;
  bool alignment_unique = true;  // false: the estimate is collinear/stationary, T_gt_est is one of many
};

struct RpeFigures {
  ErrorSummary translation_m;  // metres per delta_s
  ErrorSummary rotation_deg;   // degrees per delta_s
  double delta_s = 1.0;
  std::size_t pairs = 0;  // 0 when the trajectory is shorter than delta_s
};

struct Evaluation {
  AteFigures ate;
  RpeFigures rpe;
  double max_dt = 0.02;
  // The figures as JSON text: {"ate": ..., "rpe": ...}, the objects `desslam eval --json` prints
  // (T_gt_est's quaternion is recomputed from the matrix: equal to rounding, ~1e-16).
  std::string toJson() const;
  // The table `desslam eval` prints.
  std::string table() const;
};

// ATE; throws when fewer than 3 poses associate within max_dt (seconds).
AteFigures computeAte(const std::vector<FramePose>& groundtruth, const std::vector<FramePose>& estimate,
                      double max_dt = 0.02);
// RPE over windows of delta_s seconds; throws when fewer than 2 poses associate or delta_s <= 0.
RpeFigures computeRpe(const std::vector<FramePose>& groundtruth, const std::vector<FramePose>& estimate,
                      double delta_s = 1.0, double max_dt = 0.02);
// Both, and a check that the figures are finite (poses absurdly far apart are bad input).
Evaluation evaluate(const std::vector<FramePose>& groundtruth, const std::vector<FramePose>& estimate,
                    double max_dt = 0.02, double delta_s = 1.0);
// The same on two TUM trajectory files: what `desslam eval <groundtruth> <estimate>` computes.
Evaluation evaluateFiles(const std::filesystem::path& groundtruth, const std::filesystem::path& estimate,
                         double max_dt = 0.02, double delta_s = 1.0);

}  // namespace desslam
