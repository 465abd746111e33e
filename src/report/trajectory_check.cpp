#include "report/trajectory_check.hpp"

#include <algorithm>
#include <cstdio>

namespace desslam::report {

FastSteps findFastSteps(std::vector<WorldPose> poses, double max_speed_m_s, double min_interval_s) {
  FastSteps result;
  result.max_speed_m_s = max_speed_m_s;
  std::stable_sort(poses.begin(), poses.end(), [](const WorldPose& a, const WorldPose& b) {
    return a.world_map != b.world_map ? a.world_map < b.world_map : a.timestamp_s < b.timestamp_s;
  });
  for (size_t i = 1; i < poses.size(); ++i) {
    const WorldPose& before = poses[i - 1];
    const WorldPose& after = poses[i];
    if (before.world_map != after.world_map) continue;
    ++result.steps;
    const double interval_s = std::max(after.timestamp_s - before.timestamp_s, min_interval_s);
    const double step_m = (after.centre_w - before.centre_w).norm();
    if (step_m <= max_speed_m_s * interval_s) continue;
    ++result.too_fast;
    if (step_m > result.largest_m) {
      result.largest_m = step_m;
      result.largest_at_s = after.timestamp_s;
      result.largest_world_map = after.world_map;
    }
  }
  return result;
}

nlohmann::json toJson(const FastSteps& steps) {
  nlohmann::json j = {{"max_speed_m_s", steps.max_speed_m_s},
                      {"steps_checked", steps.steps},
                      {"steps_faster_than_max_speed", steps.too_fast}};
  if (steps.too_fast > 0)
    j["largest"] = {{"step_m", steps.largest_m}, {"at_timestamp", steps.largest_at_s},
                    {"world_map", steps.largest_world_map}};
  return j;
}

std::optional<std::string> fastStepsWarning(const FastSteps& steps) {
  if (steps.too_fast == 0) return std::nullopt;
  char text[512];
  std::snprintf(text, sizeof text,
                "%zu of %zu steps between consecutive poses in CameraTrajectory_all.txt imply a camera faster than "
                "tracking.max_speed_m_s (%.1f m/s); the largest, %.3f m, ends at t = %.6f in map %d's world: one of "
                "its poses is wrong (tracking refuses such jumps: it was moved later, by bundle adjustment or a loop "
                "correction, or extrapolated, as predicted poses are)",
                steps.too_fast, steps.steps, steps.max_speed_m_s, steps.largest_m, steps.largest_at_s,
                steps.largest_world_map);
  return std::string(text);
}

}  // namespace desslam::report
