#include "core/se3.hpp"

#include <cmath>

namespace desslam {

Mat3 skew(const Vec3& v) {
  Mat3 S;
  S << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return S;
}

Mat3 so3Exp(const Vec3& omega) {
  const double theta = omega.norm();
  const Mat3 W = skew(omega);
  if (theta < 1e-10) return Mat3::Identity() + W;
  return Mat3::Identity() + std::sin(theta) / theta * W +
         (1.0 - std::cos(theta)) / (theta * theta) * W * W;
}

Vec3 so3Log(const Mat3& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.axis() * aa.angle();
}

namespace {
// Left Jacobian of SO(3), V in the SE(3) exponential: t = V * rho.
Mat3 leftJacobian(const Vec3& omega) {
  const double theta = omega.norm();
  const Mat3 W = skew(omega);
  if (theta < 1e-6) return Mat3::Identity() + 0.5 * W;
  const double t2 = theta * theta;
  return Mat3::Identity() + (1.0 - std::cos(theta)) / t2 * W +
         (theta - std::sin(theta)) / (t2 * theta) * W * W;
}
}  // namespace

SE3 SE3::exp(const Vec6& xi) {
  const Vec3 rho = xi.head<3>();
  const Vec3 omega = xi.tail<3>();
  return SE3(so3Exp(omega), leftJacobian(omega) * rho);
}

Vec6 SE3::log() const {
  const Vec3 omega = so3Log(rotation());
  Vec6 xi;
  xi.head<3>() = leftJacobian(omega).inverse() * t_;
  xi.tail<3>() = omega;
  return xi;
}

Mat4 SE3::matrix() const {
  Mat4 M = Mat4::Identity();
  M.block<3, 3>(0, 0) = rotation();
  M.block<3, 1>(0, 3) = t_;
  return M;
}

double SE3::rotationAngle() const {
  // 2*atan2(|v|, |w|) is accurate for small and large angles alike.
  return 2.0 * std::atan2(q_.vec().norm(), std::abs(q_.w()));
}

}  // namespace desslam
