#include "loop/loop_options.hpp"

namespace desslam {

void LoopOptions::validate() const {
  const char* s = kSection;
  requireInRange(s, "min_keyframes_between_loops", min_keyframes_between_loops, 0, 100000);
  requireInRange(s, "min_consistent_keyframes", min_consistent_keyframes, 1, 100);
  requireInRange(s, "group_size", group_size, 0, 100);
  requireInRange(s, "group_score_ratio", group_score_ratio, 0.0, 1.0);
  requireInRange(s, "max_candidates", max_candidates, 1, 100);
  requireInRange(s, "confirm_keyframes", confirm_keyframes, 0, 100);
  requireInRange(s, "min_confirm_matches", min_confirm_matches, 3, 100000);
  requireInRange(s, "max_descriptor_distance", max_descriptor_distance, 1, 256);
  requireInRange(s, "match_ratio", match_ratio, 0.1, 1.0);
  requireInRange(s, "ransac_iterations", ransac_iterations, 1, 100000);
  requireInRange(s, "ransac_threshold_m", ransac_threshold_m, 1e-4, 1.0);
  requireInRange(s, "min_rigid_inliers", min_rigid_inliers, 3, 100000);
  requireInRange(s, "projection_radius_px", projection_radius_px, 1.0, 200.0);
  requireInRange(s, "min_loop_matches", min_loop_matches, min_rigid_inliers, 100000);
  requireInRange(s, "strong_covisibility_weight", strong_covisibility_weight, 1, 100000);
  requireInRange(s, "pose_graph_iterations", pose_graph_iterations, 1, 1000);
  requireInRange(s, "global_ba_iterations", global_ba_iterations, 1, 1000);
  requireInRange(s, "queue_capacity", queue_capacity, 1, 100000);
}

}  // namespace desslam
