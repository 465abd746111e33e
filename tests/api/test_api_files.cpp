// The public evaluation, TUM reader and trajectory files (include/desslam/evaluation.hpp,
// dataset.hpp) against the internal code they wrap, on the synthetic room.
#include <gtest/gtest.h>

#include "desslam/dataset.hpp"
#include "desslam/evaluation.hpp"
#include "eval/evaluation.hpp"
#include "io/trajectory_io.hpp"
#include "io/tum_dataset.hpp"
#include "api_support.hpp"
#include "support/expect_contains.hpp"
#include "support/temp_dir.hpp"
#include "system/system_support.hpp"

namespace desslam {
namespace {

constexpr int kFrames = 20;

TEST(ApiFiles, DatasetLoadsWhatTheInternalReaderLoads) {
  test::TempDir dir;
  test::writeSyntheticSequence(dir.path(), kFrames);
  const Config config = test::syntheticConfig();
  const TumDataset dataset = TumDataset::open(dir.path());
  const io::TumSequence sequence = io::TumSequence::open(dir.path());
  ASSERT_EQ(dataset.size(), sequence.size());
  ASSERT_EQ(dataset.frames().size(), sequence.size());
  for (std::size_t i : {std::size_t{0}, sequence.size() - 1}) {
    const RgbdFrame frame = dataset.load(i, config);
    const io::RgbdImage image = sequence.load(i, config.options().camera);
    EXPECT_EQ(frame.timestamp_s, image.timestamp);
    EXPECT_EQ(frame.depth_time_offset_s, sequence.record(i).depth_timestamp - sequence.record(i).rgb_timestamp);
    EXPECT_EQ(frame.image_name, sequence.record(i).rgb_path.filename().string());
    EXPECT_EQ(cv::norm(frame.bgr, image.bgr, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(frame.depth_m, image.depth, cv::NORM_INF), 0.0);
  }
  ASSERT_TRUE(dataset.groundTruth().has_value());
  const std::vector<FramePose> gt = *dataset.groundTruth();
  ASSERT_EQ(gt.size(), sequence.groundTruth()->size());
  EXPECT_EQ(gt.back().T_w_c, sequence.groundTruth()->back().T_w_c.matrix());
  EXPECT_THROW(dataset.load(dataset.size(), config), std::runtime_error);
  EXPECT_THROW(TumDataset::open(dir.path() / "missing"), std::runtime_error);
}

TEST(ApiFiles, EvaluationGivesTheFiguresOfTheInternalEvaluation) {
  test::TempDir dir;
  test::writeSyntheticSequence(dir.path(), kFrames);
  const Trajectory gt = io::readTumTrajectory(dir.path() / "groundtruth.txt");
  // An estimate: the ground truth in another world frame, each position a little off.
  Trajectory est = gt;
  const SE3 T_other_w = SE3::exp((Vec6() << 0.3, -1.0, 0.5, 0.1, 0.2, -0.3).finished());
  for (std::size_t i = 0; i < est.size(); ++i) {
    est[i].T_w_c = T_other_w * est[i].T_w_c;
    est[i].T_w_c = SE3(est[i].T_w_c.quaternion(), est[i].T_w_c.translation() + Vec3(0.002 * (i % 3), 0, -0.001 * (i % 2)));
  }
  io::writeTumTrajectory(dir.path() / "estimate.txt", est);
  const Trajectory est_file = io::readTumTrajectory(dir.path() / "estimate.txt");

  const eval::AteResult ate = eval::computeAte(gt, est_file);
  const eval::RpeResult rpe = eval::computeRpe(gt, est_file, 0.3);
  const Evaluation files = evaluateFiles(dir.path() / "groundtruth.txt", dir.path() / "estimate.txt", 0.02, 0.3);
  EXPECT_EQ(files.ate.translation_m.rmse, ate.translation_m.rmse);
  EXPECT_EQ(files.ate.translation_m.max, ate.translation_m.max);
  EXPECT_EQ(files.ate.matched, ate.matched);
  EXPECT_EQ(files.rpe.rotation_deg.rmse, rpe.rotation_deg.rmse);
  EXPECT_EQ(files.rpe.pairs, rpe.pairs);
  EXPECT_EQ(files.table(), eval::formatTable(ate, rpe, 0.02));
  EXPECT_GT(files.ate.translation_m.rmse, 0.0005);

  // Poses as 4x4 matrices: the same figures up to the matrix -> quaternion round trip.
  const Evaluation arrays = evaluate(readTumTrajectory(dir.path() / "groundtruth.txt"),
                                     readTumTrajectory(dir.path() / "estimate.txt"), 0.02, 0.3);
  EXPECT_NEAR(arrays.ate.translation_m.rmse, ate.translation_m.rmse, 1e-12);
  EXPECT_NEAR(arrays.rpe.translation_m.rmse, rpe.translation_m.rmse, 1e-12);
  EXPECT_NEAR(computeAte(readTumTrajectory(dir.path() / "groundtruth.txt"), readTumTrajectory(dir.path() / "estimate.txt"))
                  .translation_m.rmse,
              ate.translation_m.rmse, 1e-12);
  EXPECT_CONTAINS(arrays.toJson(), "\"rmse\"");
}

TEST(ApiFiles, TrajectoryFilesRoundTripAndRejectNonRigidPoses) {
  test::TempDir dir;
  std::vector<FramePose> poses(3);
  for (std::size_t i = 0; i < poses.size(); ++i) {
    poses[i].timestamp_s = 100.0 + 0.5 * static_cast<double>(i);
    poses[i].T_w_c = SE3::exp((Vec6() << 0.1 * i, 0.2, -0.3, 0.05 * i, -0.1, 0.2).finished()).matrix();
  }
  writeTumTrajectory(dir.path() / "t.txt", poses);
  const std::vector<FramePose> back = readTumTrajectory(dir.path() / "t.txt");
  ASSERT_EQ(back.size(), poses.size());
  for (std::size_t i = 0; i < poses.size(); ++i) {
    EXPECT_EQ(back[i].timestamp_s, poses[i].timestamp_s);
    EXPECT_LT((back[i].T_w_c - poses[i].T_w_c).cwiseAbs().maxCoeff(), 1e-8);
  }
  poses[1].T_w_c.topLeftCorner<3, 3>() *= 1.5;
  try {
    writeTumTrajectory(dir.path() / "bad.txt", poses);
    FAIL() << "a scaled rotation was written";
  } catch (const std::runtime_error& e) {
    EXPECT_CONTAINS(e.what(), "pose 1 is not a rigid transform");
  }
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "bad.txt"));
}

}  // namespace
}  // namespace desslam
