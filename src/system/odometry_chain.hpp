// One continuous pose for every frame with a pose: the "odom" frame of a robot's transform tree
// (ROS REP 105). Tracking's poses are in the world of the atlas map a frame was tracked in, and
// that world changes under a robot's feet: a new map starts at a loss (the pose jumps to the new
// map's origin), a merge moves a map into another's world, a loop correction moves the keyframes a
// frame is tracked from. A navigation stack's controller needs a pose that never jumps; here each
// frame's pose follows the previous frame's by the motion tracking measured between the two,
// computed in one world with the keyframe poses as they are now (so a correction of both is not
// taken for motion). Where the two frames are in worlds no merge has joined (a new map started, or
// the camera relocalised into a map not merged), the motion is unknown, and from a predicted frame
// to one found again it would carry the prediction's error as a jump: there the last velocity is
// extrapolated instead, for at most a bounded time (SlamSystem::updateOdometry decides which). The
// odom frame drifts (it is never corrected afterwards); T_w_odom = T_w_c * T_odom_c^-1 relates it
// to a map's world.
#pragma once

#include <optional>

#include "core/se3.hpp"
#include "core/trajectory.hpp"
#include "core/types.hpp"

namespace desslam::system {

class OdometryChain {
 public:
  // max_extrapolation_s: how long the last velocity is carried across an unknown motion (a longer
  // gap moves the camera by that much motion only: holding is safer than a wild guess).
  explicit OdometryChain(double max_extrapolation_s) : max_extrapolation_s_(max_extrapolation_s) {}

  // Adds the next frame with a pose (timestamps increasing). T_prev_now: the camera's motion from
  // the previous frame added to this one (T_cprev_cnow), nullopt when it is unknown. The first frame
  // takes T_w_c_first (its pose in its map's world: the odom frame starts as that world). Returns
  // the frame's pose in the odom frame.
  SE3 add(Timestamp timestamp, const std::optional<SE3>& T_prev_now, const SE3& T_w_c_first);

  // Every frame added, in order (T_w_c of each entry is T_odom_c).
  const Trajectory& poses() const { return poses_; }
  // Frames whose motion from the one before was unknown (extrapolated).
  size_t extrapolatedSteps() const { return extrapolated_steps_; }

 private:
  double max_extrapolation_s_;
  Trajectory poses_;
  // The last step's motion per second (a twist: SE3::log of the step over its duration).
  Vec6 velocity_per_s_ = Vec6::Zero();
  size_t extrapolated_steps_ = 0;
};

}  // namespace desslam::system
