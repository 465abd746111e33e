#include <gtest/gtest.h>

#include "core/error.hpp"
#include "optim/pose_optimizer.hpp"
#include "optim/synthetic_scene.hpp"

namespace desslam::optim {
namespace {

using test::rotationErrorDeg;
using test::translationError;

struct PoseScene {
  SE3 T_c_w_true;
  std::vector<PoseObservation> observations;
  std::vector<bool> injected_outlier;
};

// Points spread over the image at 1-4 m, `depth_share` of them with depth, pixel noise 1 px
// (unit information, so chi2 is chi2-distributed), `outlier_share` moved 20-100 px away.
PoseScene makeScene(const PinholeCamera& cam, int n, double depth_share, double outlier_share, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, cam.width()), v(0, cam.height()), z(1.0, 4.0), unit(0, 1);
  std::uniform_real_distribution<double> offset(20, 100), angle(0, 2 * M_PI);
  PoseScene s;
  s.T_c_w_true = test::perturb(SE3(), rng, 0.5, 0.5);
  const SE3 T_w_c = s.T_c_w_true.inverse();
  for (int i = 0; i < n; ++i) {
    const Vec3 p_c = cam.backProject(Vec2(u(rng), v(rng)), z(rng));
    PoseObservation po;
    po.obs = test::observe(cam, p_c, unit(rng) < depth_share, 1.0, rng);
    po.point_w = T_w_c * p_c;
    const bool gross = unit(rng) < outlier_share;
    if (gross) {
      const double a = angle(rng);
      po.obs.uv += offset(rng) * Vec2(std::cos(a), std::sin(a));
    }
    s.observations.push_back(po);
    s.injected_outlier.push_back(gross);
  }
  return s;
}

TEST(OptimizePose, RecoversPoseWithQuarterGrossOutliers) {
  const auto cam = test::tumCamera();
  PoseScene s = makeScene(cam, 600, 0.7, 0.25, 11);
  std::mt19937 rng(5);
  SE3 T = test::perturb(s.T_c_w_true, rng, 0.05, 3.0 * M_PI / 180.0);

  const int inliers = optimizePose(cam, T, s.observations);

  EXPECT_LT(translationError(T, s.T_c_w_true), 0.002);
  EXPECT_LT(rotationErrorDeg(T, s.T_c_w_true), 0.1);
  int injected = 0, missed = 0, false_flags = 0, clean = 0;
  for (std::size_t i = 0; i < s.observations.size(); ++i) {
    if (s.injected_outlier[i]) {
      ++injected;
      if (!s.observations[i].outlier) ++missed;
    } else {
      ++clean;
      if (s.observations[i].outlier) ++false_flags;
    }
  }
  ASSERT_GT(injected, 100);
  EXPECT_EQ(missed, 0);
  // 1 px noise at the 95% threshold: about 5% of clean observations exceed it by chance.
  EXPECT_LT(false_flags, clean / 10);
  EXPECT_EQ(inliers, clean - false_flags);
}

TEST(OptimizePose, NoiseFreeMonoConvergesExactly) {
  const auto cam = test::tumCamera();
  PoseScene s = makeScene(cam, 100, 0.0, 0.0, 2);
  for (auto& o : s.observations) o.obs.uv = cam.project(s.T_c_w_true * o.point_w);
  std::mt19937 rng(9);
  SE3 T = test::perturb(s.T_c_w_true, rng, 0.1, 5.0 * M_PI / 180.0);
  EXPECT_EQ(optimizePose(cam, T, s.observations), 100);
  EXPECT_LT(translationError(T, s.T_c_w_true), 1e-6);
  EXPECT_LT(rotationErrorDeg(T, s.T_c_w_true), 1e-5);
}

// Six points in a small patch 3 m away: without depth, sideways translation trades against
// rotation and forward translation is barely observed; depth pins both down.
TEST(OptimizePose, DepthResolvesPoorlyConditionedCase) {
  const auto cam = test::tumCamera();
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> patch(-15, 15), z(2.9, 3.1);
  const SE3 truth = test::perturb(SE3(), rng, 0.3, 0.3);
  std::vector<PoseObservation> mono, rgbd;
  for (int i = 0; i < 6; ++i) {
    const Vec3 p_c = cam.backProject(Vec2(cam.cx() + patch(rng), cam.cy() + patch(rng)), z(rng));
    PoseObservation po;
    po.obs = test::observe(cam, p_c, true, 0.5, rng);
    po.point_w = truth.inverse() * p_c;
    rgbd.push_back(po);
    po.obs.depth = -1;
    mono.push_back(po);
  }
  const SE3 start = test::perturb(truth, rng, 0.15, 2.0 * M_PI / 180.0);
  SE3 T_mono = start, T_rgbd = start;
  optimizePose(cam, T_mono, mono);
  optimizePose(cam, T_rgbd, rgbd);
  const double err_mono = translationError(T_mono, truth), err_rgbd = translationError(T_rgbd, truth);
  EXPECT_LT(err_rgbd, 0.03);
  EXPECT_GT(err_mono, 3.0 * err_rgbd) << "mono " << err_mono << " m, rgbd " << err_rgbd << " m";
}

TEST(OptimizePose, TooFewObservationsLeavePoseUnchanged) {
  const auto cam = test::tumCamera();
  PoseScene s = makeScene(cam, 2, 1.0, 0.0, 4);
  std::mt19937 rng(1);
  const SE3 start = test::perturb(s.T_c_w_true, rng, 0.05, 0.05);
  SE3 T = start;
  optimizePose(cam, T, s.observations);
  EXPECT_EQ(translationError(T, start), 0.0);
}

TEST(OptimizePose, PointsBehindCameraAreOutliers) {
  const auto cam = test::tumCamera();
  PoseScene s = makeScene(cam, 50, 0.5, 0.0, 8);
  PoseObservation behind = s.observations.front();
  behind.point_w = s.T_c_w_true.inverse() * Vec3(0.1, 0.1, -2.0);
  s.observations.push_back(behind);
  SE3 T = s.T_c_w_true;
  optimizePose(cam, T, s.observations);
  EXPECT_TRUE(s.observations.back().outlier);
  EXPECT_LT(translationError(T, s.T_c_w_true), 0.01);
}

TEST(OptimizePose, RejectsBadInputAndOptions) {
  const auto cam = test::tumCamera();
  PoseScene s = makeScene(cam, 10, 0.5, 0.0, 8);
  SE3 T = s.T_c_w_true;
  PoseOptimizerOptions bad;
  bad.rounds = 0;
  EXPECT_THROW(optimizePose(cam, T, s.observations, bad), ConfigError);
  s.observations[3].obs.inv_sigma2 = 0.0;
  EXPECT_THROW(optimizePose(cam, T, s.observations), InputError);
}

}  // namespace
}  // namespace desslam::optim
