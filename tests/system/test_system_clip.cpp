// End to end on real data: the first 100 frames of TUM fr1_xyz (../shared clip) with the fr1
// preset, in deterministic mode.
#include <cstdio>

#include <gtest/gtest.h>

#include "eval/evaluation.hpp"
#include "io/config.hpp"
#include "io/tum_dataset.hpp"
#include "support/shared_data.hpp"
#include "system_support.hpp"

namespace desslam {
namespace {

TEST(SystemClip, Fr1XyzIsTrackedWithinTwoCentimetres) {
  const auto clip = test::clipDir("fr1_xyz_0000_0099");
  DESSLAM_REQUIRE_SHARED(clip);
  const SystemOptions options = io::loadConfig(test::sourceDir() / "config" / "tum_fr1.yaml");
  const io::TumSequence sequence = io::TumSequence::open(clip);
  ASSERT_TRUE(sequence.groundTruth().has_value()) << clip << " lacks groundtruth.txt";
  ASSERT_GE(sequence.size(), 90u);

  const Trajectory trajectory = test::runOver(sequence, options).camera;

  // "All paired frames tracked": every RGB-D pair that has a ground-truth pose got an estimate.
  Trajectory frames;
  for (const auto& record : sequence.records()) frames.push_back({record.rgb_timestamp, SE3()});
  const size_t with_ground_truth = eval::associate(*sequence.groundTruth(), frames).size();
  ASSERT_GE(with_ground_truth, 3u);
  EXPECT_EQ(trajectory.size(), sequence.size()) << "frames without a pose";

  const eval::AteResult ate = eval::computeAte(*sequence.groundTruth(), trajectory);
  std::printf("fr1_xyz clip: %zu pairs, %zu tracked, %zu with ground truth, ATE RMSE %.2f mm (max %.2f mm)\n",
              sequence.size(), trajectory.size(), with_ground_truth, 1000 * ate.translation_m.rmse,
              1000 * ate.translation_m.max);
  EXPECT_EQ(ate.matched, with_ground_truth) << "paired frames with ground truth but no pose";
  EXPECT_LT(ate.translation_m.rmse, 0.02) << "ATE RMSE " << ate.translation_m.rmse << " m";
}

}  // namespace
}  // namespace desslam
