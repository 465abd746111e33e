// A trajectory: timestamped world-from-camera poses (what TUM files hold).
#pragma once

#include <vector>

#include "core/se3.hpp"
#include "core/types.hpp"

namespace desslam {

struct StampedPose {
  Timestamp timestamp = 0;
  SE3 T_w_c;
};

using Trajectory = std::vector<StampedPose>;

// A frame's pose in an atlas of maps: `map` is the map it was tracked in, `world_map` the map
// whose world the pose is expressed in (the one `map` was merged into, or `map` itself).
struct AtlasPose {
  Timestamp timestamp = 0;
  SE3 T_w_c;
  int map = 0;
  int world_map = 0;
};
using AtlasTrajectory = std::vector<AtlasPose>;

}  // namespace desslam
