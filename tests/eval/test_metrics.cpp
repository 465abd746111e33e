#include <algorithm>
#include <cmath>
#include <string>
#include <vector>
#include <numbers>

#include <gtest/gtest.h>

#include "core/error.hpp"
#include "eval/metrics.hpp"

namespace desslam::eval {
namespace {

constexpr double kT0 = 1305031101.6258;  // timestamps at the magnitude of real TUM files
constexpr double kRate = 30.0;

// A camera moving on a curve and turning, sampled at 30 Hz for `seconds`.
Trajectory curvedGroundTruth(double seconds) {
  Trajectory gt;
  for (int k = 0; k <= static_cast<int>(seconds * kRate); ++k) {
    const double s = k / kRate;
    const Vec3 p(std::cos(0.7 * s), std::sin(0.7 * s), 0.2 * s + 0.1 * std::sin(2.0 * s));
    gt.push_back({kT0 + s, SE3(so3Exp(Vec3(0.1 * s, 0.3 * s, -0.05 * s)), p)});
  }
  return gt;
}

Trajectory transformed(const Trajectory& trajectory, const SE3& T) {
  Trajectory out = trajectory;
  for (StampedPose& pose : out) pose.T_w_c = T * pose.T_w_c;
  return out;
}

TEST(EvalSummarize, MatchesHandComputedValues) {
  const ErrorStats s = summarize({3.0, 1.0, 4.0, 2.0});
  EXPECT_EQ(s.count, 4u);
  EXPECT_DOUBLE_EQ(s.mean, 2.5);
  EXPECT_DOUBLE_EQ(s.median, 2.5);
  EXPECT_DOUBLE_EQ(s.rmse, std::sqrt(30.0 / 4.0));
  EXPECT_DOUBLE_EQ(s.std, std::sqrt(1.25));  // population std, as numpy
  EXPECT_DOUBLE_EQ(s.min, 1.0);
  EXPECT_DOUBLE_EQ(s.max, 4.0);
  EXPECT_DOUBLE_EQ(summarize({5.0, 1.0, 2.0}).median, 2.0);
  EXPECT_EQ(summarize({}).count, 0u);
}

TEST(EvalAte, RigidlyMovedCopyOfGroundTruthHasZeroError) {
  const Trajectory gt = curvedGroundTruth(4.0);
  const SE3 T_est_gt(so3Exp(Vec3(0.4, -1.2, 2.0)), Vec3(3.0, -1.0, 0.5));
  const AteResult ate = computeAte(gt, transformed(gt, T_est_gt), 0.02);
  EXPECT_EQ(ate.matched, gt.size());
  EXPECT_EQ(ate.est_poses, gt.size());
  EXPECT_LT(ate.translation_m.rmse, 1e-9);
  EXPECT_LT(ate.translation_m.max, 1e-9);
  EXPECT_TRUE(ate.alignment_unique);
  EXPECT_LT((ate.T_gt_est * T_est_gt).log().norm(), 1e-9);  // recovers the inverse transform
}

TEST(EvalAte, RadialOffsetThatAlignmentCannotRemoveGivesItsSize) {
  // Ground truth on a circle of radius 1, estimate on a concentric circle of radius 1.05, then
  // moved rigidly: the best rigid alignment is the identity, every error is 0.05 m.
  Trajectory gt, est;
  for (int k = 0; k < 90; ++k) {
    const double a = 2.0 * std::numbers::pi * k / 90.0;
    const Vec3 dir(std::cos(a), std::sin(a), 0.0);
    gt.push_back({kT0 + k / kRate, SE3(Quat::Identity(), dir)});
    est.push_back({kT0 + k / kRate + 0.005, SE3(Quat::Identity(), 1.05 * dir)});  // 5 ms clock offset
  }
  const AteResult ate = computeAte(gt, transformed(est, SE3(so3Exp(Vec3(0.3, 0.2, -0.9)), Vec3(1, 2, 3))), 0.02);
  EXPECT_EQ(ate.matched, 90u);
  EXPECT_NEAR(ate.translation_m.rmse, 0.05, 1e-9);
  EXPECT_NEAR(ate.translation_m.mean, 0.05, 1e-9);
  EXPECT_NEAR(ate.translation_m.std, 0.0, 1e-7);
}

TEST(EvalAte, PerPoseErrorsAreWhatTheSummaryIsOf) {
  // Errors grow along the trajectory (a scale error the rigid alignment cannot remove): the
  // per-pose list must carry each pose's own error, at its own time, in time order.
  const Trajectory gt = curvedGroundTruth(3.0);
  Trajectory est = gt;
  for (StampedPose& pose : est) pose.T_w_c = SE3(pose.T_w_c.quaternion(), 1.1 * pose.T_w_c.translation());
  std::reverse(est.begin(), est.end());  // unsorted input: the list is still in time order
  const AteResult ate = computeAte(gt, est, 0.02);
  ASSERT_EQ(ate.per_pose.size(), ate.matched);
  std::vector<double> errors;
  for (size_t k = 0; k < ate.per_pose.size(); ++k) {
    const PoseError& e = ate.per_pose[k];
    if (k > 0) {
      EXPECT_GT(e.timestamp, ate.per_pose[k - 1].timestamp);
    }
    EXPECT_DOUBLE_EQ(e.timestamp, est[e.est_index].timestamp);
    EXPECT_DOUBLE_EQ(gt[e.gt_index].timestamp, est[e.est_index].timestamp);
    EXPECT_NEAR(e.error_m,
                (gt[e.gt_index].T_w_c.translation() - ate.T_gt_est * est[e.est_index].T_w_c.translation()).norm(),
                1e-12);
    errors.push_back(e.error_m);
  }
  const ErrorStats again = summarize(errors);
  EXPECT_DOUBLE_EQ(again.rmse, ate.translation_m.rmse);
  EXPECT_GT(ate.translation_m.max - ate.translation_m.min, 0.01);  // the errors do differ
}

TEST(EvalAte, OnlyAssociatedPosesCount) {
  const Trajectory gt = curvedGroundTruth(3.0);
  Trajectory est = gt;
  est.push_back({kT0 + 100.0, SE3(Quat::Identity(), Vec3(50, 50, 50))});  // no ground truth there
  const AteResult ate = computeAte(gt, est, 0.02);
  EXPECT_EQ(ate.matched, gt.size());
  EXPECT_EQ(ate.est_poses, gt.size() + 1);
  EXPECT_LT(ate.translation_m.rmse, 1e-9);
}

TEST(EvalAte, DifferentSequencesThrowWithAHint) {
  const Trajectory gt = curvedGroundTruth(2.0);
  Trajectory other = gt;
  for (StampedPose& pose : other) pose.timestamp += 1000.0;
  try {
    computeAte(gt, other, 0.02);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no timestamps within max_dt: are these the same sequence?"),
              std::string::npos);
  }
}

// Too few poses in a file is not a clock mismatch: the message says how many there are.
TEST(EvalAte, TooFewPosesAreToldApartFromPosesThatDoNotAssociate) {
  const Trajectory gt = curvedGroundTruth(2.0);
  const auto message = [](const auto& compute) {
    try {
      compute();
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no InputError");
  };
  const Trajectory empty;
  const Trajectory two(gt.begin(), gt.begin() + 2);  // both associate
  const std::string none = message([&] { computeAte(gt, empty, 0.02); });
  EXPECT_NE(none.find("the estimate has 0 poses, too few: ATE needs at least 3"), std::string::npos) << none;
  const std::string pair = message([&] { computeAte(gt, two, 0.02); });
  EXPECT_NE(pair.find("the estimate has 2 poses, too few: ATE needs at least 3"), std::string::npos) << pair;
  const std::string one = message([&] { computeRpe(gt, Trajectory(gt.begin(), gt.begin() + 1), 1.0, 0.02); });
  EXPECT_NE(one.find("the estimate has 1 pose, too few: RPE needs at least 2"), std::string::npos) << one;
  const std::string short_gt = message([&] { computeAte(two, gt, 0.02); });
  EXPECT_NE(short_gt.find("the ground truth has 2 poses, too few: ATE needs at least 3"), std::string::npos)
      << short_gt;
  for (const std::string& m : {none, pair, one, short_gt}) EXPECT_EQ(m.find("same sequence"), std::string::npos) << m;

  // Enough poses that do not associate keep the association message.
  Trajectory shifted(gt.begin(), gt.begin() + 5);
  for (StampedPose& pose : shifted) pose.timestamp += 1000.0;
  const std::string apart = message([&] { computeAte(gt, shifted, 0.02); });
  EXPECT_NE(apart.find("no timestamps within max_dt: are these the same sequence? (0 of 5 estimate poses"),
            std::string::npos)
      << apart;
}

TEST(EvalAte, StationaryEstimateIsReportedNotRejected) {
  const Trajectory gt = curvedGroundTruth(3.0);
  Trajectory est = gt;
  for (StampedPose& pose : est) pose.T_w_c = SE3();
  const AteResult ate = computeAte(gt, est, 0.02);
  EXPECT_FALSE(ate.alignment_unique);
  // Every alignment puts the estimate on one point; the best is the ground-truth centroid, so the
  // ATE is the spread of the ground truth about its centroid.
  Vec3 centroid = Vec3::Zero();
  for (const StampedPose& pose : gt) centroid += pose.T_w_c.translation();
  centroid /= static_cast<double>(gt.size());
  double sum_sq = 0;
  for (const StampedPose& pose : gt) sum_sq += (pose.T_w_c.translation() - centroid).squaredNorm();
  EXPECT_NEAR(ate.translation_m.rmse, std::sqrt(sum_sq / gt.size()), 1e-9);
}

TEST(EvalRpe, ConstantTranslationDriftOfOneCentimetrePerSecond) {
  const Trajectory gt = curvedGroundTruth(5.0);
  Trajectory est = gt;
  const Vec3 drift_per_s(0.006, 0.0, -0.008);  // |drift| = 1 cm/s, in the world frame
  for (StampedPose& pose : est)
    pose.T_w_c = SE3(pose.T_w_c.quaternion(), pose.T_w_c.translation() + drift_per_s * (pose.timestamp - kT0));
  // A rigid change of the estimate's world frame must not matter for RPE either.
  const RpeResult rpe = computeRpe(gt, transformed(est, SE3(so3Exp(Vec3(0, 0, 1)), Vec3(1, 0, 0))), 1.0, 0.02);
  // Windows start at every pose whose t + 1 s is still inside the 5 s trajectory: 4 s * 30 Hz + 1.
  EXPECT_EQ(rpe.pairs, 121u);
  EXPECT_DOUBLE_EQ(rpe.delta_s, 1.0);
  EXPECT_NEAR(rpe.translation_m.rmse, 0.01, 1e-6);
  EXPECT_NEAR(rpe.translation_m.min, 0.01, 1e-6);
  EXPECT_NEAR(rpe.translation_m.max, 0.01, 1e-6);
  EXPECT_LT(rpe.rotation_deg.max, 1e-6);

  ASSERT_EQ(rpe.per_pair.size(), rpe.pairs);
  for (const RpePair& pair : rpe.per_pair) {
    EXPECT_NEAR(pair.end_time - pair.start_time, 1.0, 0.5 / kRate);
    EXPECT_NEAR(pair.translation_m, 0.01, 1e-6);
    EXPECT_LT(pair.rotation_deg, 1e-6);
  }
  EXPECT_NEAR(rpe.per_pair.front().start_time, kT0, 1e-9);

  const RpeResult half = computeRpe(gt, est, 0.5, 0.02);
  EXPECT_NEAR(half.translation_m.rmse, 0.005, 1e-6);
}

TEST(EvalRpe, ConstantRotationDriftOfTwoDegreesPerSecond) {
  Trajectory gt, est;
  const double rate = 2.0 * std::numbers::pi / 180.0;  // rad/s
  for (int k = 0; k <= 90; ++k) {
    const double s = k / kRate;
    gt.push_back({kT0 + s, SE3(so3Exp(Vec3(0.2, 0.1, 0.3)), Vec3(1, 2, 3))});
    est.push_back({kT0 + s, SE3(so3Exp(Vec3(0.2, 0.1, 0.3)) * so3Exp(Vec3(0, 0, rate * s)), Vec3(1, 2, 3))});
  }
  const RpeResult rpe = computeRpe(gt, est, 1.0, 0.02);
  EXPECT_EQ(rpe.pairs, 61u);  // 3 s at 30 Hz: windows start at t <= 2 s
  EXPECT_NEAR(rpe.rotation_deg.rmse, 2.0, 1e-6);
  EXPECT_LT(rpe.translation_m.max, 1e-9);
}

TEST(EvalRpe, TrajectoryShorterThanDeltaHasNoPairs) {
  const Trajectory gt = curvedGroundTruth(0.5);
  const RpeResult rpe = computeRpe(gt, gt, 1.0, 0.02);
  EXPECT_EQ(rpe.pairs, 0u);
  EXPECT_EQ(rpe.translation_m.count, 0u);
  EXPECT_THROW(computeRpe(gt, gt, 0.0, 0.02), InputError);
}

}  // namespace
}  // namespace desslam::eval
