// A check of the trajectory a run hands over: consecutive poses of one world (one map, or maps a
// merge joined) that lie further apart than the camera could have moved between them. Tracking
// refuses such a jump (tracking.max_speed_m_s), but what the run writes is also shaped later, by
// bundle adjustment and loop correction, and holds poses extrapolated through losses; a jump there
// means a pose is wrong, and a user feeding the trajectory to navigation must be told.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/types.hpp"

namespace desslam::report {

struct WorldPose {
  double timestamp_s = 0;
  Vec3 centre_w;       // camera centre in its world
  int world_map = 0;   // the map whose world it is in (CameraTrajectory_all.txt's last column)
};

struct FastSteps {
  double max_speed_m_s = 0;
  size_t steps = 0;            // consecutive pairs (time order, per world) checked
  size_t too_fast = 0;         // ... that imply a speed above max_speed_m_s
  double largest_m = 0;        // the largest such step
  double largest_at_s = 0;     // timestamp of the later pose of that step
  int largest_world_map = -1;
};

// The steps between time-consecutive poses of each world; a step shorter than min_interval_s
// (equal or near-equal timestamps) counts as min_interval_s (one frame at 30 Hz by default).
FastSteps findFastSteps(std::vector<WorldPose> poses, double max_speed_m_s, double min_interval_s = 1.0 / 30.0);

nlohmann::json toJson(const FastSteps& steps);

// One line for the user when any step is too fast; nothing otherwise.
std::optional<std::string> fastStepsWarning(const FastSteps& steps);

}  // namespace desslam::report
