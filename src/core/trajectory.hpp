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

}  // namespace desslam
