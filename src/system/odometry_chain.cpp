#include "system/odometry_chain.hpp"

#include <algorithm>

namespace desslam::system {

SE3 OdometryChain::add(Timestamp timestamp, const std::optional<SE3>& T_prev_now, const SE3& T_w_c_first) {
  if (poses_.empty()) {
    poses_.push_back({timestamp, T_w_c_first});
    return T_w_c_first;
  }
  const StampedPose& previous = poses_.back();
  const double dt_s = timestamp - previous.timestamp;
  SE3 step;
  if (T_prev_now) {
    step = *T_prev_now;
    if (dt_s > 0) velocity_per_s_ = step.log() / dt_s;
  } else {
    step = SE3::exp(velocity_per_s_ * std::clamp(dt_s, 0.0, max_extrapolation_s_));
    ++extrapolated_steps_;
  }
  const SE3 T_odom_c = previous.T_w_c * step;
  poses_.push_back({timestamp, T_odom_c});
  return T_odom_c;
}

}  // namespace desslam::system
