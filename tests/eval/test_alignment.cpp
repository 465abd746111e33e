#include <random>

#include <gtest/gtest.h>

#include "core/error.hpp"
#include "eval/alignment.hpp"

namespace desslam::eval {
namespace {

SE3 randomPose(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Vec3 axis(n(rng), n(rng), n(rng));
  const double angle = std::uniform_real_distribution<double>(0.3, 3.0)(rng);
  return SE3(so3Exp(axis.normalized() * angle), Vec3(n(rng), n(rng), n(rng)) * 2.0);
}

TEST(EvalAlignRigid, RecoversKnownTransformFromNoisyPoints) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> box(-1.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.001);  // 1 mm
  for (int trial = 0; trial < 5; ++trial) {
    const SE3 T_gt_est = randomPose(rng);
    std::vector<Vec3> est, gt;
    for (int i = 0; i < 200; ++i) {
      est.emplace_back(box(rng), box(rng), box(rng));
      gt.push_back(T_gt_est * est.back() + Vec3(noise(rng), noise(rng), noise(rng)));
    }
    const SE3 found = alignRigid(est, gt);
    const SE3 diff = found.inverse() * T_gt_est;
    EXPECT_LT(diff.translation().norm(), 1e-3) << "trial " << trial;
    EXPECT_LT(diff.rotationAngle(), 1e-3) << "trial " << trial;
  }
}

TEST(EvalAlignRigid, ExactForThreePointsAndNeverReturnsAReflection) {
  std::mt19937 rng(11);
  const SE3 T_gt_est = randomPose(rng);
  const std::vector<Vec3> est{{0, 0, 0}, {1, 0, 0}, {0, 2, 0}};  // planar: sign fix must apply
  std::vector<Vec3> gt;
  for (const Vec3& p : est) gt.push_back(T_gt_est * p);
  const SE3 found = alignRigid(est, gt);
  EXPECT_NEAR(found.rotation().determinant(), 1.0, 1e-12);
  EXPECT_LT((found.inverse() * T_gt_est).log().norm(), 1e-9);
}

TEST(EvalAlignRigid, CollinearOrTooFewPointsThrow) {
  std::vector<Vec3> line;
  for (int i = 0; i < 10; ++i) line.push_back(Vec3(1, 2, 3) + 0.37 * i * Vec3(0.2, -0.5, 1.0));
  EXPECT_THROW(alignRigid(line, line), InputError);
  EXPECT_FALSE(alignmentIsUnique(line, line));
  const std::vector<Vec3> same(5, Vec3(1, 1, 1));
  EXPECT_THROW(alignRigid(same, same), InputError);
  const std::vector<Vec3> two{{0, 0, 0}, {1, 0, 0}};
  EXPECT_THROW(alignRigid(two, two), InputError);
  const std::vector<Vec3> three{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  EXPECT_THROW(alignRigid(three, two), InputError);
}

TEST(EvalAlignRigid, DegenerateInputCanStillBeAlignedOptimally) {
  // A straight-line estimate against a straight-line ground truth: any rotation about the line
  // is optimal; kAnyMinimiser must return one that maps the line exactly.
  std::mt19937 rng(3);
  const SE3 T_gt_est = randomPose(rng);
  std::vector<Vec3> est, gt;
  for (int i = 0; i < 10; ++i) {
    est.push_back(Vec3(0.1 * i, 0.05 * i, 0));
    gt.push_back(T_gt_est * est.back());
  }
  const SE3 found = alignRigid(est, gt, DegenerateInput::kAnyMinimiser);
  for (std::size_t i = 0; i < est.size(); ++i) EXPECT_LT((found * est[i] - gt[i]).norm(), 1e-9);
}

}  // namespace
}  // namespace desslam::eval
