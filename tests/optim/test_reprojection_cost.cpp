// The analytic Jacobians (the reason pose-only optimisation is fast) against central
// differences taken through the manifold's Plus, i.e. in the tangent space Ceres solves in.
#include <gtest/gtest.h>

#include "optim/reprojection_cost.hpp"
#include "optim/synthetic_scene.hpp"

namespace desslam::optim {
namespace {

using detail::PoseBlock;

template <int kDim>
void expectJacobiansMatchNumeric(bool with_depth) {
  const auto cam = test::tumCamera();
  const auto K = detail::StereoIntrinsics::from(cam, test::kBf);
  std::mt19937 rng(7);
  const SE3 T_c_w = test::perturb(SE3(), rng, 0.3, 0.4);
  const Vec3 p_w = T_c_w.inverse() * Vec3(0.4, -0.3, 2.5);
  Observation obs;
  obs.uv = Vec2(300, 200);
  obs.depth = with_depth ? 2.4 : -1;
  obs.inv_sigma2 = 1.0 / (1.2 * 1.2);
  std::unique_ptr<ceres::CostFunction> cost(detail::makePosePointCost(K, obs));
  ASSERT_EQ(cost->num_residuals(), kDim);

  PoseBlock pose = detail::toPoseBlock(T_c_w);
  double point[3] = {p_w.x(), p_w.y(), p_w.z()};
  double residual[kDim];
  double j_pose[kDim * 7], j_point[kDim * 3];
  const double* params[2] = {pose.data(), point};
  double* jacobians[2] = {j_pose, j_point};
  ASSERT_TRUE(cost->Evaluate(params, residual, jacobians));

  detail::Se3LeftManifold manifold;
  double j_tangent[kDim * 6];
  manifold.RightMultiplyByPlusJacobian(pose.data(), kDim, j_pose, j_tangent);

  const double h = 1e-6;
  for (int i = 0; i < 6; ++i) {
    double delta[6] = {0, 0, 0, 0, 0, 0};
    PoseBlock plus, minus;
    delta[i] = h;
    manifold.Plus(pose.data(), delta, plus.data());
    delta[i] = -h;
    manifold.Plus(pose.data(), delta, minus.data());
    double r_plus[kDim], r_minus[kDim];
    const double* p_plus[2] = {plus.data(), point};
    const double* p_minus[2] = {minus.data(), point};
    ASSERT_TRUE(cost->Evaluate(p_plus, r_plus, nullptr));
    ASSERT_TRUE(cost->Evaluate(p_minus, r_minus, nullptr));
    for (int r = 0; r < kDim; ++r)
      EXPECT_NEAR(j_tangent[r * 6 + i], (r_plus[r] - r_minus[r]) / (2 * h), 1e-3) << "pose row " << r << " col " << i;
  }
  for (int i = 0; i < 3; ++i) {
    double plus[3] = {point[0], point[1], point[2]}, minus[3] = {point[0], point[1], point[2]};
    plus[i] += h;
    minus[i] -= h;
    double r_plus[kDim], r_minus[kDim];
    const double* p_plus[2] = {pose.data(), plus};
    const double* p_minus[2] = {pose.data(), minus};
    ASSERT_TRUE(cost->Evaluate(p_plus, r_plus, nullptr));
    ASSERT_TRUE(cost->Evaluate(p_minus, r_minus, nullptr));
    for (int r = 0; r < kDim; ++r)
      EXPECT_NEAR(j_point[r * 3 + i], (r_plus[r] - r_minus[r]) / (2 * h), 1e-3) << "point row " << r << " col " << i;
  }

  // The pose-only cost is the same residual with the point held fixed.
  std::unique_ptr<ceres::CostFunction> pose_only(detail::makePoseOnlyCost(K, obs, p_w));
  double r_pose_only[kDim], j_pose_only[kDim * 7];
  double* jp[1] = {j_pose_only};
  const double* pp[1] = {pose.data()};
  ASSERT_TRUE(pose_only->Evaluate(pp, r_pose_only, jp));
  for (int r = 0; r < kDim; ++r) {
    EXPECT_NEAR(r_pose_only[r], residual[r], 1e-9);
    for (int c = 0; c < 7; ++c) EXPECT_NEAR(j_pose_only[r * 7 + c], j_pose[r * 7 + c], 1e-9);
  }
}

TEST(ReprojectionCost, MonoJacobiansMatchNumericDifferences) { expectJacobiansMatchNumeric<2>(false); }
TEST(ReprojectionCost, DepthJacobiansMatchNumericDifferences) { expectJacobiansMatchNumeric<3>(true); }

TEST(ReprojectionCost, Chi2IsZeroAtTruthAndInfiniteBehindCamera) {
  const auto cam = test::tumCamera();
  const auto K = detail::StereoIntrinsics::from(cam, test::kBf);
  const Vec3 p_c(0.2, -0.1, 2.0);
  Observation obs;
  obs.uv = cam.project(p_c);
  obs.depth = 2.0;
  EXPECT_NEAR(detail::chi2(K, p_c, obs), 0.0, 1e-18);
  // One pixel off in u moves both u and u_r: chi2 = 2 with unit information.
  obs.uv.x() += 1.0;
  EXPECT_NEAR(detail::chi2(K, p_c, obs), 2.0, 1e-9);
  obs.inv_sigma2 = 0.25;
  EXPECT_NEAR(detail::chi2(K, p_c, obs), 0.5, 1e-9);
  EXPECT_TRUE(std::isinf(detail::chi2(K, Vec3(0, 0, -1), obs)));
}

TEST(Se3LeftManifold, PlusThenMinusRecoversTheIncrement) {
  std::mt19937 rng(3);
  const SE3 T = test::perturb(SE3(), rng, 1.0, 1.0);
  const PoseBlock x = detail::toPoseBlock(T);
  const double delta[6] = {0.01, -0.02, 0.03, 0.05, -0.04, 0.02};
  PoseBlock y;
  detail::Se3LeftManifold manifold;
  ASSERT_TRUE(manifold.Plus(x.data(), delta, y.data()));
  double back[6];
  ASSERT_TRUE(manifold.Minus(y.data(), x.data(), back));
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(back[i], delta[i], 1e-12);
  // Left-multiplicative: y = exp(delta) * x.
  const SE3 expected = SE3::exp(Eigen::Map<const Vec6>(delta)) * T;
  EXPECT_LT(test::translationError(detail::fromPoseBlock(y.data()), expected), 1e-12);
}

}  // namespace
}  // namespace desslam::optim
