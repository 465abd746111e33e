// The odometry frame (system/odometry_chain.hpp): each pose follows the one before by the measured
// motion; an unknown motion is the last velocity, for a bounded time.
#include <gtest/gtest.h>

#include "system/odometry_chain.hpp"

namespace desslam::system {
namespace {

SE3 yawAndStep(double yaw_rad, const Vec3& t) {
  Vec6 xi = Vec6::Zero();
  xi.tail<3>() = Vec3(0, yaw_rad, 0);
  return SE3(SE3::exp(xi).quaternion(), t);
}

TEST(OdometryChain, TheFirstFrameStartsAtItsWorldPoseAndMeasuredMotionsCompose) {
  OdometryChain chain(0.3);
  const SE3 T_w_c0 = yawAndStep(0.4, Vec3(1, 2, 3));
  const SE3 step = yawAndStep(0.05, Vec3(0.01, 0, 0.02));
  EXPECT_LT((chain.add(0.0, std::nullopt, T_w_c0).matrix() - T_w_c0.matrix()).norm(), 1e-12);
  // Measured motions: the world pose a later frame is given (here a jump) does not matter.
  const SE3 jumped = yawAndStep(-2.0, Vec3(-5, 0, 0));
  chain.add(0.1, step, jumped);
  const SE3 T_odom_c2 = chain.add(0.2, step, jumped);
  EXPECT_LT((T_odom_c2.matrix() - (T_w_c0 * step * step).matrix()).norm(), 1e-12);
  EXPECT_EQ(chain.poses().size(), 3u);
  EXPECT_EQ(chain.extrapolatedSteps(), 0u);
}

TEST(OdometryChain, AnUnknownMotionIsTheLastVelocityForAtMostTheBound) {
  OdometryChain chain(0.3);
  const SE3 step = yawAndStep(0.02, Vec3(0.03, 0, 0));  // per 0.1 s
  chain.add(0.0, std::nullopt, SE3());
  chain.add(0.1, step, SE3());
  // 0.2 s without a measured motion: two steps' worth.
  const SE3 T_odom_c2 = chain.add(0.3, std::nullopt, SE3());
  EXPECT_LT((T_odom_c2.matrix() - (step * step * step).matrix()).norm(), 1e-9);
  EXPECT_EQ(chain.extrapolatedSteps(), 1u);
  // 1 s without one: the bound's 0.3 s only (three steps), not ten.
  const SE3 T_odom_c3 = chain.add(1.3, std::nullopt, SE3());
  EXPECT_LT((T_odom_c3.matrix() - (T_odom_c2 * step * step * step).matrix()).norm(), 1e-9);
  EXPECT_EQ(chain.extrapolatedSteps(), 2u);
}

TEST(OdometryChain, WithoutAMeasuredMotionYetAnUnknownOneHolds) {
  OdometryChain chain(0.3);
  const SE3 T_w_c0(Quat::Identity(), Vec3(0.5, 0, 0));
  chain.add(0.0, std::nullopt, T_w_c0);
  const SE3 T_odom_c1 = chain.add(0.1, std::nullopt, SE3());
  EXPECT_LT((T_odom_c1.matrix() - T_w_c0.matrix()).norm(), 1e-12);
}

}  // namespace
}  // namespace desslam::system
