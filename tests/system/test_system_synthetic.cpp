// End to end in-process: a static synthetic room rendered along sim::sweepPath, written in the
// TUM layout, read back through io::TumSequence and tracked by system::SlamSystem in
// deterministic mode. The ground truth is exact, so the error is the system's alone (plus 0.2 mm
// depth quantisation).
#include <cstdio>

#include <gtest/gtest.h>

#include "eval/evaluation.hpp"
#include "io/tum_dataset.hpp"
#include "support/temp_dir.hpp"
#include "system/slam_system.hpp"
#include "system_support.hpp"

namespace desslam {
namespace {


TEST(SystemSynthetic, StaticRoomSweepIsTrackedToMillimetres) {
  constexpr int kFrames = 180;  // 6 s at 30 fps
  test::TempDir dir;
  test::writeSyntheticSequence(dir.path(), kFrames);

  const io::TumSequence sequence = io::TumSequence::open(dir.path());
  ASSERT_EQ(sequence.size(), static_cast<size_t>(kFrames));
  ASSERT_TRUE(sequence.groundTruth().has_value());

  const SystemOptions options = test::syntheticSystemOptions();
  const test::RunResult run = test::runOver(sequence, options);
  EXPECT_EQ(run.frames, static_cast<size_t>(kFrames));

  // >= 99 % of the frames carry a pose.
  EXPECT_GE(run.camera.size(), static_cast<size_t>(0.99 * kFrames))
      << run.camera.size() << " of " << kFrames << " frames tracked";
  ASSERT_GE(run.camera.size(), 3u);

  const eval::AteResult ate = eval::computeAte(*sequence.groundTruth(), run.camera);
  std::printf("synthetic sweep: %zu frames, %zu tracked, %zu keyframes, ATE RMSE %.2f mm (max %.2f mm)\n",
              run.frames, run.camera.size(), run.keyframes.size(), 1000 * ate.translation_m.rmse,
              1000 * ate.translation_m.max);
  EXPECT_EQ(ate.matched, run.camera.size()) << "every pose must pair with a ground-truth pose";
  EXPECT_TRUE(ate.alignment_unique);
  EXPECT_LT(ate.translation_m.rmse, 0.005) << "ATE RMSE " << ate.translation_m.rmse << " m over " << ate.matched
                                           << " poses (max " << ate.translation_m.max << " m)";

  // Keyframes exist, and their poses are as good as the frames'.
  ASSERT_GE(run.keyframes.size(), 3u);
  const eval::AteResult kf_ate = eval::computeAte(*sequence.groundTruth(), run.keyframes);
  EXPECT_LT(kf_ate.translation_m.rmse, 0.005) << "keyframe ATE RMSE " << kf_ate.translation_m.rmse << " m";

  // Statistics agree with what was run.
  EXPECT_EQ(run.statistics["counts"]["frames"].get<size_t>(), static_cast<size_t>(kFrames));
  EXPECT_EQ(run.statistics["counts"]["frames_tracked"].get<size_t>(), run.camera.size());
  EXPECT_EQ(run.statistics["mode"], "deterministic");
}

// The trajectory starts where the sequence starts: the first frame defines the map, so it is
// tracked, and timestamps come out in order with the RGB stamps.
TEST(SystemSynthetic, TrajectoryFollowsTheRgbTimestamps) {
  constexpr int kFrames = 30;
  test::TempDir dir;
  test::writeSyntheticSequence(dir.path(), kFrames);
  const io::TumSequence sequence = io::TumSequence::open(dir.path());
  const test::RunResult run = test::runOver(sequence, test::syntheticSystemOptions());
  ASSERT_FALSE(run.camera.empty());
  EXPECT_DOUBLE_EQ(run.camera.front().timestamp, sequence.record(0).rgb_timestamp);
  for (size_t i = 1; i < run.camera.size(); ++i)
    EXPECT_LT(run.camera[i - 1].timestamp, run.camera[i].timestamp) << "pose " << i;
  for (const StampedPose& pose : run.camera) {
    EXPECT_TRUE(pose.T_w_c.translation().allFinite());
    EXPECT_NEAR(pose.T_w_c.quaternion().norm(), 1.0, 1e-9);
  }
}

}  // namespace
}  // namespace desslam
