// Between the public API's poses (FramePose, 4x4 matrices) and the internal trajectories.
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "core/trajectory.hpp"
#include "desslam/desslam.hpp"

namespace desslam::api {

// A 4x4 matrix that a user handed in must be a rigid transform: finite, bottom row 0 0 0 1,
// orthonormal rotation with determinant +1 (within `tolerance`, for poses stored in float).
inline SE3 toSe3(const Eigen::Matrix4d& T, const std::string& what, double tolerance = 1e-5) {
  if (!T.allFinite()) throw InputError(what + " has a non-finite entry (nan or inf)");
  const Eigen::RowVector4d bottom = T.row(3);
  if ((bottom - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > tolerance)
    throw InputError(what + " is not a rigid transform: its bottom row must be 0 0 0 1");
  const Eigen::Matrix3d R = T.topLeftCorner<3, 3>();
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > tolerance || R.determinant() < 0)
    throw InputError(what + " is not a rigid transform: its rotation block is not orthonormal with determinant +1");
  return SE3::fromMatrix(T);
}

// Timestamps and T_w_c of `poses` (map ids are not used); `name` names them in messages.
inline Trajectory toTrajectory(const std::vector<FramePose>& poses, const std::string& name) {
  Trajectory out;
  out.reserve(poses.size());
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (!std::isfinite(poses[i].timestamp_s))
      throw InputError(name + ": pose " + std::to_string(i) + " has a non-finite timestamp");
    out.push_back({poses[i].timestamp_s, toSe3(poses[i].T_w_c, name + ": pose " + std::to_string(i))});
  }
  return out;
}

inline std::vector<FramePose> toFramePoses(const Trajectory& trajectory) {
  std::vector<FramePose> out;
  out.reserve(trajectory.size());
  for (const StampedPose& p : trajectory) out.push_back({p.timestamp, p.T_w_c.matrix(), 0, 0});
  return out;
}

}  // namespace desslam::api
