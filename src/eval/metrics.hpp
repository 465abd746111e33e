// Trajectory accuracy: absolute trajectory error (ATE) and relative pose error (RPE), computed
// the way TUM's evaluate_ate.py / evaluate_rpe.py do for RGB-D sequences.
#pragma once

#include <cstddef>
#include <optional>
#include <vector>

#include "core/se3.hpp"
#include "core/trajectory.hpp"

namespace desslam::eval {

// Summary of a list of errors. std is the population standard deviation (numpy's default);
// median averages the two middle values of an even count. All zero when the list is empty.
struct ErrorStats {
  double rmse = 0, mean = 0, median = 0, std = 0, min = 0, max = 0;
  std::size_t count = 0;
};
ErrorStats summarize(std::vector<double> errors);

// One matched pose's ATE: at the estimate's timestamp, indices into the trajectories as given.
struct PoseError {
  Timestamp timestamp = 0;
  double error_m = 0;
  std::size_t gt_index = 0, est_index = 0;
};

struct AteResult {
  ErrorStats translation_m;  // |gt_i - T_gt_est * est_i| over the matched poses
  SE3 T_gt_est;              // maps the estimate's world frame into the ground truth's
  std::size_t matched = 0, gt_poses = 0, est_poses = 0;
  bool alignment_unique = true;  // false: the estimate is collinear/stationary, T_gt_est is one of many
  std::vector<PoseError> per_pose;  // what translation_m summarises, in estimate-time order (plots)
};

// Associates (max_dt seconds), aligns with one rigid SE(3), reports translation errors.
// Throws InputError when fewer than 3 poses associate: "the estimate has N poses, too few" (or
// the ground truth) when a trajectory has fewer than 3, else "no timestamps within max_dt".
AteResult computeAte(const Trajectory& gt, const Trajectory& est, double max_dt = 0.02);

// The ATE of a run's maps that were never merged (CameraTrajectory_all.txt, grouped by
// world_map): each map lives in its own world, so each is aligned on its own; one alignment across
// them would mix unrelated frames (metres of "error" on a run whose every map is right).
struct MapAte {
  int world_map = 0;
  std::size_t poses = 0;  // of the estimate, in this map
  std::optional<AteResult> ate;  // none when fewer than 3 of its poses associate
};
struct AtlasAteResult {
  std::vector<MapAte> maps;  // by world_map id
  ErrorStats all_maps_m;     // every matched pose's error, each map aligned on its own
};
// Throws InputError when no map has 3 poses that associate with the ground truth.
AtlasAteResult computeAtlasAte(const Trajectory& gt, const AtlasTrajectory& est, double max_dt = 0.02);

// One RPE pair: estimate poses at start_time and end_time (about delta_s later).
struct RpePair {
  Timestamp start_time = 0, end_time = 0;
  double translation_m = 0, rotation_deg = 0;
};

struct RpeResult {
  ErrorStats translation_m;  // metres per delta_s
  ErrorStats rotation_deg;   // degrees per delta_s
  double delta_s = 1.0;
  std::size_t pairs = 0;
  std::vector<RpePair> per_pair;  // what the two summaries summarise, in start-time order (plots)
};

// For each associated estimate pose i, the associated estimate pose j whose time is closest to
// t_i + delta_s; error E = (gt_i^-1 gt_j)^-1 (est_i^-1 est_j). Pairs whose window would reach
// past the last associated pose are skipped, so a trajectory shorter than delta_s gives 0 pairs.
// Throws InputError when fewer than 2 poses associate (worded as for computeAte) or delta_s is not
// positive.
RpeResult computeRpe(const Trajectory& gt, const Trajectory& est, double delta_s = 1.0, double max_dt = 0.02);

}  // namespace desslam::eval
