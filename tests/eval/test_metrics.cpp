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

// Two maps never merged, each a rigidly moved piece of the ground truth in its own world: each
// aligned on its own, both are exact; one alignment across them (what a TUM tool reading the first
// eight columns of CameraTrajectory_all.txt does) reports metres.
TEST(EvalAtlasAte, EachMapIsAlignedOnItsOwn) {
  const Trajectory gt = curvedGroundTruth(4.0);
  const SE3 T_a(so3Exp(Vec3(0.2, -0.5, 1.0)), Vec3(1.0, 2.0, -0.5));
  const SE3 T_b(so3Exp(Vec3(-1.0, 0.3, 0.4)), Vec3(-3.0, 0.5, 2.0));
  AtlasTrajectory est;
  Trajectory one_world;
  for (size_t i = 0; i < gt.size(); ++i) {
    const bool first_half = i < gt.size() / 2;
    const SE3 T_w_c = (first_half ? T_a : T_b) * gt[i].T_w_c;
    est.push_back({gt[i].timestamp, T_w_c, first_half ? 0 : 3, first_half ? 0 : 2});
    one_world.push_back({gt[i].timestamp, T_w_c});
  }
  est.push_back({kT0 + 100.0, SE3(), 5, 5});  // a map whose one pose has no ground truth
  const AtlasAteResult r = computeAtlasAte(gt, est);
  ASSERT_EQ(r.maps.size(), 3u);
  EXPECT_EQ(r.maps[0].world_map, 0);
  EXPECT_EQ(r.maps[1].world_map, 2);
  EXPECT_EQ(r.maps[2].world_map, 5);
  ASSERT_TRUE(r.maps[0].ate && r.maps[1].ate);
  EXPECT_FALSE(r.maps[2].ate);
  EXPECT_EQ(r.maps[0].poses + r.maps[1].poses, gt.size());
  EXPECT_LT(r.maps[0].ate->translation_m.rmse, 1e-9);
  EXPECT_LT(r.maps[1].ate->translation_m.rmse, 1e-9);
  EXPECT_EQ(r.all_maps_m.count, gt.size());
  EXPECT_LT(r.all_maps_m.rmse, 1e-9);
  EXPECT_GT(computeAte(gt, one_world).translation_m.rmse, 0.1);
}

TEST(EvalAtlasAte, AllMapsErrorIsTheRmsOverEveryMatchedPose) {
  const Trajectory gt = curvedGroundTruth(2.0);
  AtlasTrajectory est;
  // Map 0 exact; map 1 with every position 3 cm off along x (a constant offset the alignment
  // removes) plus +-1 cm alternating along z (which it cannot).
  for (size_t i = 0; i < gt.size(); ++i) {
    const bool in_map_1 = i >= gt.size() / 2;
    SE3 T_w_c = gt[i].T_w_c;
    if (in_map_1) T_w_c = SE3(T_w_c.quaternion(), T_w_c.translation() + Vec3(0.03, 0, (i % 2 ? 0.01 : -0.01)));
    est.push_back({gt[i].timestamp, T_w_c, in_map_1 ? 1 : 0, in_map_1 ? 1 : 0});
  }
  const AtlasAteResult r = computeAtlasAte(gt, est);
  ASSERT_EQ(r.maps.size(), 2u);
  ASSERT_TRUE(r.maps[1].ate);
  EXPECT_NEAR(r.maps[1].ate->translation_m.rmse, 0.01, 2e-4);
  const double n0 = static_cast<double>(r.maps[0].ate->matched), n1 = static_cast<double>(r.maps[1].ate->matched);
  EXPECT_NEAR(r.all_maps_m.rmse, std::sqrt(n1 * std::pow(r.maps[1].ate->translation_m.rmse, 2) / (n0 + n1)), 1e-9);
}

TEST(EvalAtlasAte, NoMapWithThreeAssociatedPosesIsAnError) {
  const Trajectory gt = curvedGroundTruth(1.0);
  const AtlasTrajectory est = {{gt[0].timestamp, gt[0].T_w_c, 0, 0}, {gt[1].timestamp, gt[1].T_w_c, 0, 0},
                               {gt[2].timestamp, gt[2].T_w_c, 1, 1}, {gt[3].timestamp, gt[3].T_w_c, 1, 1}};
  try {
    computeAtlasAte(gt, est);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no map of the estimate has 3 poses"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("4 poses in 2 maps"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace desslam::eval
