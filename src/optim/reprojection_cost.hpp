// Internal to optim: the reprojection residuals and the SE(3) pose parametrisation shared by
// pose-only optimisation and bundle adjustment. Not part of the public API.
//
// Residual (ORB-SLAM2 paper, RGB-D keypoints as virtual stereo): an observation with depth d is
// the measurement (u, v, u_r = u - bf/d); the prediction for a camera point p = (x, y, z) is
// (fx x/z + cx, fy y/z + cy, u_pred - bf/z). Without depth only (u, v). Residuals are whitened by
// sqrt(inv_sigma2), so their squared norm is the chi2 compared with the 95% thresholds.
//
// Pose block: 7 doubles [qx qy qz qw tx ty tz] holding T_c_w (Eigen quaternion order). Updates
// are left-multiplicative, T <- exp(delta) * T with delta = [rho; omega] in R^6. The cost
// functions report Jacobians directly with respect to delta in the first six columns of the
// 7-wide ambient Jacobian (the last column is zero) and Se3LeftManifold's PlusJacobian is
// [I6; 0], so Ceres's product of the two is exactly the tangent-space Jacobian. This saves
// differentiating through the quaternion.
#pragma once

#include <array>
#include <limits>

#include <ceres/ceres.h>

#include "core/camera.hpp"
#include "core/se3.hpp"
#include "optim/observation.hpp"

namespace desslam::optim::detail {

inline constexpr int kPoseAmbientSize = 7;
inline constexpr int kPoseTangentSize = 6;
// Points closer than this (metres, camera z) cannot be projected; evaluation fails there.
inline constexpr double kMinProjectableDepth = 1e-6;

using PoseBlock = std::array<double, kPoseAmbientSize>;
PoseBlock toPoseBlock(const SE3& T_c_w);
SE3 fromPoseBlock(const double* block);

// Intrinsics plus the virtual stereo baseline bf (pixel * metres).
struct StereoIntrinsics {
  double fx = 0, fy = 0, cx = 0, cy = 0, bf = 0;
  static StereoIntrinsics from(const PinholeCamera& camera, double bf) {
    return {camera.fx(), camera.fy(), camera.cx(), camera.cy(), bf};
  }
};

// Residual dimension of an observation: 3 with depth, 2 without.
inline int residualDim(const Observation& obs) { return obs.hasDepth() ? 3 : 2; }

// e^T * Omega * e of an observation for a camera-frame point; +infinity if the point is not in
// front of the camera (such observations are always outliers).
double chi2(const StereoIntrinsics& K, const Vec3& p_c, const Observation& obs);

// T <- exp(delta) * T on the 7-double pose block (see the file comment for the Jacobian trick).
class Se3LeftManifold final : public ceres::Manifold {
 public:
  int AmbientSize() const override { return kPoseAmbientSize; }
  int TangentSize() const override { return kPoseTangentSize; }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  bool PlusJacobian(const double* x, double* jacobian) const override;
  bool RightMultiplyByPlusJacobian(const double* x, int num_rows, const double* ambient_matrix,
                                   double* tangent_matrix) const override;
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  bool MinusJacobian(const double* x, double* jacobian) const override;
};

// Pose-only residual: the world point is a constant. kDim = 2 (mono) or 3 (with depth).
template <int kDim>
class PoseOnlyCost final : public ceres::SizedCostFunction<kDim, kPoseAmbientSize> {
 public:
  PoseOnlyCost(const StereoIntrinsics& K, const Observation& obs, const Vec3& p_w);
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  StereoIntrinsics K_;
  Eigen::Matrix<double, kDim, 1> measured_;
  double sqrt_info_;
  Vec3 p_w_;
};

// Bundle-adjustment residual: pose block (7) and world point block (3).
template <int kDim>
class PosePointCost final : public ceres::SizedCostFunction<kDim, kPoseAmbientSize, 3> {
 public:
  PosePointCost(const StereoIntrinsics& K, const Observation& obs);
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  StereoIntrinsics K_;
  Eigen::Matrix<double, kDim, 1> measured_;
  double sqrt_info_;
};

// Builds the right-sized cost for an observation (caller owns the result).
ceres::CostFunction* makePoseOnlyCost(const StereoIntrinsics& K, const Observation& obs, const Vec3& p_w);
ceres::CostFunction* makePosePointCost(const StereoIntrinsics& K, const Observation& obs);

}  // namespace desslam::optim::detail
