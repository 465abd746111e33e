// Small SE(3) helpers (Sophus is not packaged in Debian).
//
// Naming convention: T_a_b maps points expressed in frame b into frame a,
// p_a = T_a_b * p_b. So T_w_c is the camera-to-world pose (what TUM files store) and
// T_c_w = T_w_c.inverse() maps world points into the camera.
#pragma once

#include "core/types.hpp"

namespace desslam {

Mat3 skew(const Vec3& v);
// Rodrigues: rotation vector (axis * angle, radians) <-> rotation matrix.
Mat3 so3Exp(const Vec3& omega);
Vec3 so3Log(const Mat3& R);

class SE3 {
 public:
  SE3() : q_(Quat::Identity()), t_(Vec3::Zero()) {}
  SE3(const Quat& q, const Vec3& t) : q_(q.normalized()), t_(t) {}
  SE3(const Mat3& R, const Vec3& t) : q_(Quat(R).normalized()), t_(t) {}

  static SE3 identity() { return SE3(); }
  static SE3 fromMatrix(const Mat4& M) { return SE3(Mat3(M.block<3, 3>(0, 0)), Vec3(M.block<3, 1>(0, 3))); }
  // Exponential with xi = [rho; omega] (translation part first), using the SE(3) left Jacobian.
  static SE3 exp(const Vec6& xi);
  Vec6 log() const;

  SE3 inverse() const {
    const Quat qi = q_.conjugate();
    return SE3(qi, -(qi * t_));
  }
  SE3 operator*(const SE3& o) const { return SE3(q_ * o.q_, t_ + q_ * o.t_); }
  Vec3 operator*(const Vec3& p) const { return q_ * p + t_; }

  const Quat& quaternion() const { return q_; }
  Mat3 rotation() const { return q_.toRotationMatrix(); }
  const Vec3& translation() const { return t_; }
  Mat4 matrix() const;

  // Rotation angle of this transform in radians, in [0, pi].
  double rotationAngle() const;

 private:
  Quat q_;
  Vec3 t_;
};

}  // namespace desslam
