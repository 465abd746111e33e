#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

#include "core/error.hpp"
#include "sim/camera_path.hpp"

namespace desslam::sim {
namespace {

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

struct Motion {
  double mean_speed = 0, max_speed = 0, max_angular_deg = 0;
};

Motion measure(const Trajectory& path) {
  Motion m;
  for (std::size_t i = 1; i < path.size(); ++i) {
    const double dt = path[i].timestamp - path[i - 1].timestamp;
    const SE3 step = path[i - 1].T_w_c.inverse() * path[i].T_w_c;
    const double speed = step.translation().norm() / dt;
    m.mean_speed += speed / (path.size() - 1);
    m.max_speed = std::max(m.max_speed, speed);
    m.max_angular_deg = std::max(m.max_angular_deg, step.rotationAngle() / dt * kRadToDeg);
  }
  return m;
}

void expectHandHeld(const Trajectory& path) {
  const Motion m = measure(path);
  EXPECT_GE(m.mean_speed, 0.2);
  EXPECT_LE(m.mean_speed, 0.5);
  EXPECT_LE(m.max_speed, 0.6);
  EXPECT_LE(m.max_angular_deg, 30.0);
  EXPECT_GE(m.max_angular_deg, 5.0);  // the orientation does change
  for (const auto& p : path) {
    const Vec3& c = p.T_w_c.translation();
    EXPECT_LE(std::abs(c.x()), 1.3);
    EXPECT_GE(c.y(), -1.05);
    EXPECT_LE(c.y(), -0.15);
    EXPECT_GE(c.z(), 1.25);
    EXPECT_LE(c.z(), 1.55);
  }
}

TEST(CameraPath, SweepHasTimestampsAndHandHeldSpeeds) {
  const Trajectory path = sweepPath(300, 30.0, 50.0);
  ASSERT_EQ(path.size(), 300u);
  for (std::size_t i = 0; i < path.size(); ++i) EXPECT_NEAR(path[i].timestamp, 50.0 + i / 30.0, 1e-9);
  expectHandHeld(path);
  expectHandHeld(sweepPath(100, 30.0));
  // Open: the end is far from the start.
  EXPECT_GT((path.back().T_w_c.translation() - path.front().T_w_c.translation()).norm(), 0.8);
}

TEST(CameraPath, LoopReturnsToItsStartEveryLap) {
  for (int laps : {1, 2, 3}) {
    SCOPED_TRACE(laps);
    const int frames = 300 * laps;
    const Trajectory path = loopPath(frames, 30.0, laps);
    ASSERT_EQ(path.size(), std::size_t(frames));
    expectHandHeld(path);
    for (int lap = 1; lap < laps; ++lap) {
      const SE3 delta = path[0].T_w_c.inverse() * path[lap * frames / laps].T_w_c;
      EXPECT_LT(delta.translation().norm(), 1e-9);
      EXPECT_LT(delta.rotationAngle(), 1e-9);
    }
    // The last frame is one step before the start: the path closes smoothly.
    const SE3 closing = path.back().T_w_c.inverse() * path.front().T_w_c;
    EXPECT_LT(closing.translation().norm(), 0.6 / 30.0);
    // It actually goes somewhere in between.
    double farthest = 0;
    for (const auto& p : path) farthest = std::max(farthest, (p.T_w_c.translation() - path[0].T_w_c.translation()).norm());
    EXPECT_GT(farthest, 0.5);
  }
  expectHandHeld(loopPath(100, 30.0, 1));  // a short lap keeps its speeds too
}

TEST(CameraPath, LooksAlongPlusYSlightlyDown) {
  const Mat3 R = lookRotation(0, 0, 0);
  EXPECT_LT((R * Vec3::UnitZ() - Vec3::UnitY()).norm(), 1e-12);  // optical axis
  EXPECT_LT((R * Vec3::UnitY() + Vec3::UnitZ()).norm(), 1e-12);  // image down = world down
  EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
  const Vec3 forward = sweepPath(1, 30.0)[0].T_w_c.rotation() * Vec3::UnitZ();
  EXPECT_GT(forward.y(), 0.9);
  EXPECT_LT(forward.z(), -0.1);
}

TEST(CameraPath, RejectsBadArguments) {
  EXPECT_THROW(sweepPath(0, 30.0), ConfigError);
  EXPECT_THROW(sweepPath(10, 0.0), ConfigError);
  EXPECT_THROW(loopPath(10, 30.0, 0), ConfigError);
}

}  // namespace
}  // namespace desslam::sim
