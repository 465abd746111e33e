#include "optim/reprojection_cost.hpp"

#include <algorithm>
#include <cmath>

namespace desslam::optim::detail {

PoseBlock toPoseBlock(const SE3& T_c_w) {
  const Quat& q = T_c_w.quaternion();
  const Vec3& t = T_c_w.translation();
  return {q.x(), q.y(), q.z(), q.w(), t.x(), t.y(), t.z()};
}

SE3 fromPoseBlock(const double* block) {
  return SE3(Quat(block[3], block[0], block[1], block[2]), Vec3(block[4], block[5], block[6]));
}

namespace {

template <int kDim>
Eigen::Matrix<double, kDim, 1> measurement(const StereoIntrinsics& K, const Observation& obs) {
  Eigen::Matrix<double, kDim, 1> m;
  m(0) = obs.uv.x();
  m(1) = obs.uv.y();
  if constexpr (kDim == 3) m(2) = obs.uv.x() - K.bf / obs.depth;
  return m;
}

// Whitened residual sqrt_info * (measured - predicted) and, if asked, its Jacobian with respect
// to the camera-frame point. False when the point cannot be projected.
template <int kDim>
bool whitenedResidual(const StereoIntrinsics& K, const Eigen::Matrix<double, kDim, 1>& measured,
                      double sqrt_info, const Vec3& p_c, double* residuals,
                      Eigen::Matrix<double, kDim, 3>* d_r_d_pc) {
  if (!(p_c.z() > kMinProjectableDepth)) return false;
  const double inv_z = 1.0 / p_c.z();
  const double u = K.fx * p_c.x() * inv_z + K.cx;
  const double v = K.fy * p_c.y() * inv_z + K.cy;
  residuals[0] = sqrt_info * (measured(0) - u);
  residuals[1] = sqrt_info * (measured(1) - v);
  if constexpr (kDim == 3) residuals[2] = sqrt_info * (measured(2) - (u - K.bf * inv_z));
  if (d_r_d_pc != nullptr) {
    const double inv_z2 = inv_z * inv_z;
    auto& J = *d_r_d_pc;
    const double s = -sqrt_info;  // residual = measured - predicted
    J(0, 0) = s * K.fx * inv_z;
    J(0, 1) = 0.0;
    J(0, 2) = s * -K.fx * p_c.x() * inv_z2;
    J(1, 0) = 0.0;
    J(1, 1) = s * K.fy * inv_z;
    J(1, 2) = s * -K.fy * p_c.y() * inv_z2;
    if constexpr (kDim == 3) {
      J(2, 0) = J(0, 0);
      J(2, 1) = 0.0;
      J(2, 2) = J(0, 2) + s * K.bf * inv_z2;
    }
  }
  return true;
}

// d p_c / d delta for p_c = exp(delta) * p_c at delta = 0 is [I, -skew(p_c)].
template <int kDim>
void writePoseJacobian(const Eigen::Matrix<double, kDim, 3>& d_r_d_pc, const Vec3& p_c, double* out) {
  Eigen::Map<Eigen::Matrix<double, kDim, kPoseAmbientSize, Eigen::RowMajor>> J(out);
  J.template leftCols<3>() = d_r_d_pc;
  J.template middleCols<3>(3) = -d_r_d_pc * skew(p_c);
  J.col(6).setZero();
}

Eigen::Map<const Quat> quaternionOf(const double* pose) { return Eigen::Map<const Quat>(pose); }
Eigen::Map<const Vec3> translationOf(const double* pose) { return Eigen::Map<const Vec3>(pose + 4); }

}  // namespace

double chi2(const StereoIntrinsics& K, const Vec3& p_c, const Observation& obs) {
  const double sqrt_info = std::sqrt(obs.inv_sigma2);
  double r[3] = {0, 0, 0};
  const bool ok = obs.hasDepth()
                      ? whitenedResidual<3>(K, measurement<3>(K, obs), sqrt_info, p_c, r, nullptr)
                      : whitenedResidual<2>(K, measurement<2>(K, obs), sqrt_info, p_c, r, nullptr);
  if (!ok) return std::numeric_limits<double>::infinity();
  return r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
}

// ---- Se3LeftManifold ----

bool Se3LeftManifold::Plus(const double* x, const double* delta, double* x_plus_delta) const {
  const SE3 updated = SE3::exp(Eigen::Map<const Vec6>(delta)) * fromPoseBlock(x);
  const PoseBlock block = toPoseBlock(updated);
  std::copy(block.begin(), block.end(), x_plus_delta);
  return true;
}

bool Se3LeftManifold::PlusJacobian(const double* /*x*/, double* jacobian) const {
  Eigen::Map<Eigen::Matrix<double, kPoseAmbientSize, kPoseTangentSize, Eigen::RowMajor>> J(jacobian);
  J.setZero();
  J.topRows<kPoseTangentSize>().setIdentity();
  return true;
}

bool Se3LeftManifold::RightMultiplyByPlusJacobian(const double* /*x*/, int num_rows,
                                                  const double* ambient_matrix,
                                                  double* tangent_matrix) const {
  // Product with [I6; 0]: keep the first six columns of every row.
  for (int r = 0; r < num_rows; ++r)
    std::copy_n(ambient_matrix + r * kPoseAmbientSize, kPoseTangentSize, tangent_matrix + r * kPoseTangentSize);
  return true;
}

bool Se3LeftManifold::Minus(const double* y, const double* x, double* y_minus_x) const {
  const Vec6 delta = (fromPoseBlock(y) * fromPoseBlock(x).inverse()).log();
  std::copy_n(delta.data(), kPoseTangentSize, y_minus_x);
  return true;
}

bool Se3LeftManifold::MinusJacobian(const double* /*x*/, double* jacobian) const {
  Eigen::Map<Eigen::Matrix<double, kPoseTangentSize, kPoseAmbientSize, Eigen::RowMajor>> J(jacobian);
  J.setZero();
  J.leftCols<kPoseTangentSize>().setIdentity();
  return true;
}

// ---- PoseOnlyCost ----

template <int kDim>
PoseOnlyCost<kDim>::PoseOnlyCost(const StereoIntrinsics& K, const Observation& obs, const Vec3& p_w)
    : K_(K), measured_(measurement<kDim>(K, obs)), sqrt_info_(std::sqrt(obs.inv_sigma2)), p_w_(p_w) {}

template <int kDim>
bool PoseOnlyCost<kDim>::Evaluate(double const* const* parameters, double* residuals,
                                  double** jacobians) const {
  const double* pose = parameters[0];
  const Vec3 p_c = quaternionOf(pose) * p_w_ + translationOf(pose);
  const bool want_jacobian = jacobians != nullptr && jacobians[0] != nullptr;
  Eigen::Matrix<double, kDim, 3> d_r_d_pc;
  if (!whitenedResidual<kDim>(K_, measured_, sqrt_info_, p_c, residuals, want_jacobian ? &d_r_d_pc : nullptr))
    return false;
  if (want_jacobian) writePoseJacobian<kDim>(d_r_d_pc, p_c, jacobians[0]);
  return true;
}

// ---- PosePointCost ----

template <int kDim>
PosePointCost<kDim>::PosePointCost(const StereoIntrinsics& K, const Observation& obs)
    : K_(K), measured_(measurement<kDim>(K, obs)), sqrt_info_(std::sqrt(obs.inv_sigma2)) {}

template <int kDim>
bool PosePointCost<kDim>::Evaluate(double const* const* parameters, double* residuals,
                                   double** jacobians) const {
  const double* pose = parameters[0];
  const Eigen::Map<const Vec3> p_w(parameters[1]);
  const auto q = quaternionOf(pose);
  const Vec3 p_c = q * p_w + translationOf(pose);
  const bool want_pose = jacobians != nullptr && jacobians[0] != nullptr;
  const bool want_point = jacobians != nullptr && jacobians[1] != nullptr;
  Eigen::Matrix<double, kDim, 3> d_r_d_pc;
  if (!whitenedResidual<kDim>(K_, measured_, sqrt_info_, p_c, residuals,
                              (want_pose || want_point) ? &d_r_d_pc : nullptr))
    return false;
  if (want_pose) writePoseJacobian<kDim>(d_r_d_pc, p_c, jacobians[0]);
  if (want_point) {
    Eigen::Map<Eigen::Matrix<double, kDim, 3, Eigen::RowMajor>> J(jacobians[1]);
    J = d_r_d_pc * q.toRotationMatrix();
  }
  return true;
}

template class PoseOnlyCost<2>;
template class PoseOnlyCost<3>;
template class PosePointCost<2>;
template class PosePointCost<3>;

ceres::CostFunction* makePoseOnlyCost(const StereoIntrinsics& K, const Observation& obs, const Vec3& p_w) {
  if (obs.hasDepth()) return new PoseOnlyCost<3>(K, obs, p_w);
  return new PoseOnlyCost<2>(K, obs, p_w);
}

ceres::CostFunction* makePosePointCost(const StereoIntrinsics& K, const Observation& obs) {
  if (obs.hasDepth()) return new PosePointCost<3>(K, obs);
  return new PosePointCost<2>(K, obs);
}

}  // namespace desslam::optim::detail
