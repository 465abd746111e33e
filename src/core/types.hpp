// Basic numeric types shared by every stage.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace desslam {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat3 = Eigen::Matrix3d;
using Mat4 = Eigen::Matrix4d;
using Quat = Eigen::Quaterniond;

// Timestamps: seconds since the epoch, as in TUM/Bonn files. One type everywhere.
using Timestamp = double;

}  // namespace desslam
