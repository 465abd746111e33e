// The check for jumps in the trajectory a run hands over (report/trajectory_check.hpp).
#include <gtest/gtest.h>

#include "report/trajectory_check.hpp"
#include "support/expect_contains.hpp"

namespace desslam {
namespace {

constexpr double kFrameS = 1.0 / 30.0;

// A camera moving 1 m/s along x at 30 Hz in world `map`, frames first..first+n-1.
std::vector<report::WorldPose> walk(int map, int first, int n) {
  std::vector<report::WorldPose> poses;
  for (int i = first; i < first + n; ++i) poses.push_back({100.0 + i * kFrameS, Vec3(i * kFrameS, 0.0, 0.0), map});
  return poses;
}

TEST(TrajectoryCheck, ASmoothTrajectoryHasNoFastStep) {
  const report::FastSteps steps = report::findFastSteps(walk(0, 0, 30), 3.0);
  EXPECT_EQ(steps.steps, 29u);
  EXPECT_EQ(steps.too_fast, 0u);
  EXPECT_FALSE(report::fastStepsWarning(steps).has_value());
  EXPECT_EQ(report::toJson(steps)["steps_faster_than_max_speed"], 0);
  EXPECT_FALSE(report::toJson(steps).contains("largest"));
}

// One pose 1.5 m off its neighbours (a keyframe moved by an optimisation): the step to it and the
// step back are both too fast; the warning names the larger and where it ends.
TEST(TrajectoryCheck, OnePoseFarFromItsNeighboursGivesTwoFastSteps) {
  std::vector<report::WorldPose> poses = walk(2, 0, 20);
  poses[10].centre_w += Vec3(0.0, 0.0, -1.5);
  const report::FastSteps steps = report::findFastSteps(poses, 3.0);
  EXPECT_EQ(steps.too_fast, 2u);
  EXPECT_NEAR(steps.largest_m, 1.5, 0.01);
  EXPECT_EQ(steps.largest_world_map, 2);
  const auto warning = report::fastStepsWarning(steps);
  ASSERT_TRUE(warning.has_value());
  EXPECT_CONTAINS(*warning, "2 of 19 steps");
  EXPECT_CONTAINS(*warning, "3.0 m/s");
  EXPECT_CONTAINS(*warning, "map 2's world");
  EXPECT_EQ(report::toJson(steps)["largest"]["world_map"], 2);
}

// Poses of different worlds are not compared (two maps never merged lie in unrelated frames),
// however they interleave in time, nor does input order matter within a world.
TEST(TrajectoryCheck, WorldsAreCheckedApartAndInTimeOrder) {
  std::vector<report::WorldPose> poses = walk(0, 0, 10);
  std::vector<report::WorldPose> other = walk(1, 5, 10);
  for (report::WorldPose& p : other) p.centre_w += Vec3(5.0, 5.0, 5.0);
  poses.insert(poses.end(), other.rbegin(), other.rend());
  const report::FastSteps steps = report::findFastSteps(poses, 3.0);
  EXPECT_EQ(steps.steps, 18u);
  EXPECT_EQ(steps.too_fast, 0u);
}

// A gap of a second between two poses allows 3 m; equal timestamps count as one frame apart.
TEST(TrajectoryCheck, TheBoundGrowsWithTheTimeBetweenPoses) {
  std::vector<report::WorldPose> poses = {{100.0, Vec3::Zero(), 0}, {101.0, Vec3(2.9, 0, 0), 0}};
  EXPECT_EQ(report::findFastSteps(poses, 3.0).too_fast, 0u);
  poses[1].centre_w = Vec3(3.1, 0, 0);
  EXPECT_EQ(report::findFastSteps(poses, 3.0).too_fast, 1u);
  const std::vector<report::WorldPose> same_time = {{100.0, Vec3::Zero(), 0}, {100.0, Vec3(0.09, 0, 0), 0}};
  EXPECT_EQ(report::findFastSteps(same_time, 3.0).too_fast, 0u);
}

}  // namespace
}  // namespace desslam
