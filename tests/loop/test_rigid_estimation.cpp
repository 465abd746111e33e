// Rigid SE(3) RANSAC on constructed 3-D-3-D correspondences with known truth.
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "core/error.hpp"
#include "loop/rigid_estimation.hpp"

namespace desslam::loop {
namespace {

constexpr double kPi = 3.14159265358979323846;

struct Constructed {
  std::vector<PointCorrespondence> correspondences;
  std::vector<bool> outlier;
};

// Points in front of a camera (frame b), 0.5-4 m deep, mapped into frame a by T_a_b with small
// depth-dependent noise; a share of them replaced by unrelated points.
Constructed construct(const SE3& T_a_b, int n, double outlier_share, double noise_at_1m, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> xy(-1.5, 1.5), z(0.5, 4.0), unit(0.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  Constructed out;
  for (int i = 0; i < n; ++i) {
    PointCorrespondence c;
    const double depth = z(rng);
    c.p_b = Vec3(xy(rng) * depth / 2, xy(rng) * depth / 2, depth);
    c.depth = depth;
    const bool outlier = unit(rng) < outlier_share;
    if (outlier) {
      c.p_a = Vec3(xy(rng) * 3, xy(rng) * 3, z(rng) * 2);  // anywhere in the room
    } else {
      const double sigma = noise_at_1m * depth * depth;
      c.p_a = T_a_b * c.p_b + sigma * Vec3(gauss(rng), gauss(rng), gauss(rng));
    }
    out.correspondences.push_back(c);
    out.outlier.push_back(outlier);
  }
  return out;
}

double rotationErrorDeg(const SE3& a, const SE3& b) { return (a.inverse() * b).rotationAngle() * 180.0 / kPi; }

TEST(RigidRansac, RecoversTransformWithHalfOutliers) {
  const SE3 truth(Quat(Eigen::AngleAxisd(0.7, Vec3(0.3, -1.0, 0.2).normalized())), Vec3(0.8, -0.4, 1.3));
  const Constructed data = construct(truth, 200, 0.5, 0.0, 3);
  RigidRansacOptions options;
  const RigidRansacResult result = estimateRigidRansac(data.correspondences, options);
  ASSERT_TRUE(result.success);
  EXPECT_LT((result.T_a_b.translation() - truth.translation()).norm(), 0.001);
  EXPECT_LT(rotationErrorDeg(result.T_a_b, truth), 0.1);
  // Every true correspondence is an inlier; random outliers almost never land within 2 cm.
  int true_inliers = 0, wrong = 0;
  for (size_t i = 0; i < data.outlier.size(); ++i) {
    if (!data.outlier[i]) {
      ++true_inliers;
      EXPECT_TRUE(result.inliers[i]) << "correspondence " << i;
    } else if (result.inliers[i]) {
      ++wrong;
    }
  }
  EXPECT_LE(wrong, 2);
  EXPECT_GE(result.inlier_count, true_inliers);
}

TEST(RigidRansac, NoisyDepthStillWithinMillimetreAndTenthOfDegree) {
  const SE3 truth(Quat(Eigen::AngleAxisd(-1.2, Vec3(0.0, 0.0, 1.0))), Vec3(-2.0, 0.5, 0.1));
  // 1 mm at 1 m, 9 mm at 3 m: Kinect-like. Many points average the noise out.
  const Constructed data = construct(truth, 600, 0.5, 0.001, 11);
  const RigidRansacResult result = estimateRigidRansac(data.correspondences, RigidRansacOptions{});
  ASSERT_TRUE(result.success);
  EXPECT_LT((result.T_a_b.translation() - truth.translation()).norm(), 0.001);
  EXPECT_LT(rotationErrorDeg(result.T_a_b, truth), 0.1);
}

TEST(RigidRansac, RejectsUnrelatedPoints) {
  const Constructed data = construct(SE3(), 100, 1.0, 0.0, 5);
  const RigidRansacResult result = estimateRigidRansac(data.correspondences, RigidRansacOptions{});
  EXPECT_FALSE(result.success);
  EXPECT_LT(result.inlier_count, 20);
}

TEST(RigidRansac, TooFewOrDegenerateCorrespondences) {
  std::vector<PointCorrespondence> two(2);
  EXPECT_FALSE(estimateRigidRansac(two, RigidRansacOptions{}).success);
  // All on one line: no rotation about it is determined, no triple is sampled.
  std::vector<PointCorrespondence> line;
  for (int i = 0; i < 30; ++i) line.push_back({Vec3(i * 0.1, 0, 1), Vec3(i * 0.1, 0, 1), 1.0});
  EXPECT_FALSE(estimateRigidRansac(line, RigidRansacOptions{}).success);
}

TEST(RigidRansac, ThresholdGrowsWithDepthSquared) {
  RigidRansacOptions options;
  options.threshold_m = 0.01;
  EXPECT_DOUBLE_EQ(inlierThreshold({Vec3::Zero(), Vec3::Zero(), 0.5}, options), 0.01);
  EXPECT_DOUBLE_EQ(inlierThreshold({Vec3::Zero(), Vec3::Zero(), 3.0}, options), 0.09);
  options.iterations = 0;
  EXPECT_THROW(estimateRigidRansac({}, options), ConfigError);
}

}  // namespace
}  // namespace desslam::loop
