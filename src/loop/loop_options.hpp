// loop.*: loop closing.
#pragma once

#include "core/option_fields.hpp"
#include "map/atlas_options.hpp"
#include "matching/matcher_options.hpp"

namespace desslam {

// Loop closing (loop/loop_closer.hpp): place recognition over the keyframe BoW database, a rigid
// SE(3) from 3-D-3-D matches (depth makes scale observable), pose-graph optimisation over the
// essential graph, then a global bundle adjustment in its own thread.
struct LoopOptions {
  bool enabled = true;
  int min_keyframes_between_loops = 10;  // after a closed loop (and at the map's start) no detection
  int min_consistent_keyframes = 3;      // a candidate group must recur in this many consecutive keyframes
  int group_size = 10;                   // a candidate's covisibility group: it and its best neighbours
  double group_score_ratio = 0.75;       // groups below this share of the best group's score are dropped
  int max_candidates = 3;                // consistent candidates verified geometrically per keyframe
  // A loop found from the keyframe must also hold from its best covisible keyframes: of its
  // confirm_keyframes best covisibles (all it has, if fewer), every one must see at least
  // min_confirm_matches of the loop's points where the loop's transform puts them (descriptor
  // and 3-D agreement). A keyframe without covisibles cannot close a loop. 0: no confirmation.
  int confirm_keyframes = 2;
  int min_confirm_matches = 20;
  int max_descriptor_distance = 50;      // Hamming; BoW-guided matching has no geometry, so strict
  double match_ratio = 0.75;             // best / second-best descriptor distance
  int ransac_iterations = 300;
  // 3-D inlier distance at 1 m depth; grows with depth^2 like Kinect-type depth noise.
  double ransac_threshold_m = 0.02;
  int min_rigid_inliers = 20;            // RANSAC inliers to accept a candidate
  double projection_radius_px = 10.0;    // guided search of the loop group's points (level 0 pixels)
  int min_loop_matches = 40;             // matches after the guided search to close the loop
  int strong_covisibility_weight = 100;  // covisibility edges in the essential graph
  int pose_graph_iterations = 20;
  bool global_ba = true;                 // global BA in its own thread after each closed loop
  int global_ba_iterations = 10;
  int queue_capacity = 64;               // keyframes waiting; when full the oldest is dropped

  static constexpr const char* kSection = "loop";
  template <class V> void fields(V& v) {
    v("enabled", enabled); v("min_keyframes_between_loops", min_keyframes_between_loops);
    v("min_consistent_keyframes", min_consistent_keyframes); v("group_size", group_size);
    v("group_score_ratio", group_score_ratio); v("max_candidates", max_candidates);
    v("confirm_keyframes", confirm_keyframes); v("min_confirm_matches", min_confirm_matches);
    v("max_descriptor_distance", max_descriptor_distance); v("match_ratio", match_ratio);
    v("ransac_iterations", ransac_iterations); v("ransac_threshold_m", ransac_threshold_m);
    v("min_rigid_inliers", min_rigid_inliers); v("projection_radius_px", projection_radius_px);
    v("min_loop_matches", min_loop_matches); v("strong_covisibility_weight", strong_covisibility_weight);
    v("pose_graph_iterations", pose_graph_iterations); v("global_ba", global_ba);
    v("global_ba_iterations", global_ba_iterations); v("queue_capacity", queue_capacity);
  }
  void validate() const;
};

namespace loop {
// The sections of the run's options loop closing reads (system/system_options.hpp:
// loopCloserOptions); only these, so that another stage's options do not recompile it.
struct LoopCloserOptions {
  LoopOptions loop;
  MatcherOptions matching;
  AtlasOptions atlas;
};
}  // namespace loop

}  // namespace desslam
