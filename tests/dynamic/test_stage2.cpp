// Stage 2 on constructed geometry: thresholds, the occlusion rule, majority voting, and the
// half-resolution keyframe depth.
#include <gtest/gtest.h>

#include "core/error.hpp"
#include "dynamic/constructed_features.hpp"
#include "dynamic/depth_checks.hpp"

namespace desslam::dynamic {
namespace {

const PinholeCamera kCamera{test::testCameraOptions()};

cv::Mat halfDepth(float z) { return makeHalfResolutionDepth(test::depthImage(z)); }

// A keyframe at the origin looking along +z; the point sits on the optical axis at depth d.
Stage2Decision onAxis(double d, float observed, const DynamicOptions& options = {}) {
  const cv::Mat half = halfDepth(observed);
  return checkStage2(Vec3(0, 0, d), {{SE3(), &half}}, kCamera, options);
}

TEST(HalfResolutionDepth, TakesTheNearestValidReadingOfEachBlock) {
  cv::Mat d(4, 6, CV_32FC1, cv::Scalar(0));
  d.at<float>(0, 1) = 2.0f;  // block (0,0): {0, 2.0, 1.5, 0} -> 1.5
  d.at<float>(1, 0) = 1.5f;
  d.at<float>(2, 2) = 3.0f;  // block (1,1): {3.0} -> 3.0
  const cv::Mat half = makeHalfResolutionDepth(d);
  ASSERT_EQ(half.size(), cv::Size(3, 2));
  ASSERT_EQ(half.type(), CV_32FC1);
  EXPECT_FLOAT_EQ(half.at<float>(0, 0), 1.5f);
  EXPECT_FLOAT_EQ(half.at<float>(1, 1), 3.0f);
  EXPECT_FLOAT_EQ(half.at<float>(0, 2), 0.0f);  // no reading in the block
  EXPECT_EQ(makeHalfResolutionDepth(test::depthImage(2.0f)).size(), cv::Size(320, 240));
  EXPECT_THROW(makeHalfResolutionDepth(cv::Mat(4, 4, CV_16UC1, cv::Scalar(1))), InputError);
}

TEST(HalfResolutionDepth, IsSampledAtFullResolutionPixels) {
  cv::Mat full = test::depthImage(3.0f, {{cv::Rect(400, 100, 40, 40), 1.25f}});
  const cv::Mat half = makeHalfResolutionDepth(full);
  EXPECT_FLOAT_EQ(sampleHalfResolutionDepth(half, Vec2(420, 120), kCamera), 1.25f);
  EXPECT_FLOAT_EQ(sampleHalfResolutionDepth(half, Vec2(100, 400), kCamera), 3.0f);
  EXPECT_EQ(sampleHalfResolutionDepth(half, Vec2(-5, 10), kCamera), 0.0);
}

TEST(Stage2, ResidualJustBelowThresholdIsKept) {
  const Stage2Decision d = onAxis(2.0 * (1 - 0.079), 2.0f);  // sensor sees 7.9 % beyond the point
  EXPECT_FALSE(d.dynamic);
  EXPECT_EQ(d.keyframes_checked, 1);
  EXPECT_EQ(d.keyframes_inconsistent, 0);
  EXPECT_NEAR(d.median_residual, 0.079, 1e-9);
}

TEST(Stage2, ResidualJustAboveThresholdIsRemoved) {
  const Stage2Decision d = onAxis(2.0 * (1 - 0.081), 2.0f);
  EXPECT_TRUE(d.dynamic);
  EXPECT_EQ(d.keyframes_inconsistent, 1);
  EXPECT_NEAR(d.median_residual, 0.081, 1e-9);
  DynamicOptions loose;
  loose.stage2_threshold = 0.1;
  EXPECT_FALSE(onAxis(2.0 * (1 - 0.081), 2.0f, loose).dynamic);
}

// Something 8.1 % IN FRONT of the point: occluded, no vote.
TEST(Stage2, OccludedPointAbstains) {
  const Stage2Decision d = onAxis(2.0 * (1 + 0.081), 2.0f);
  EXPECT_FALSE(d.dynamic);
  EXPECT_EQ(d.keyframes_checked, 0);
  EXPECT_EQ(d.keyframes_occluded, 1);
  // Within the threshold in front of the point is an ordinary, consistent vote.
  const Stage2Decision close = onAxis(2.0 * (1 + 0.079), 2.0f);
  EXPECT_EQ(close.keyframes_checked, 1);
  EXPECT_EQ(close.keyframes_occluded, 0);
  EXPECT_NEAR(close.median_residual, 0.079, 1e-9);
}

// Keyframes spread sideways along x, all looking along +z at a wall 3 m away; a person (1.5 m)
// stands in front of the wall point in some of them.
struct Keyframes {
  std::vector<cv::Mat> images;
  std::vector<KeyframeDepthView> views;
  Keyframes(const std::vector<float>& observed) {
    images.reserve(observed.size());
    for (size_t i = 0; i < observed.size(); ++i) {
      images.push_back(halfDepth(observed[i]));
      views.push_back({SE3(Quat::Identity(), Vec3(-0.05 * static_cast<double>(i), 0, 0)), &images.back()});
    }
  }
};

TEST(Stage2, StaticPointBehindAPassingPersonStays) {
  const Vec3 wall_point(0.1, 0.0, 3.0);
  const Keyframes some({1.5f, 3.0f, 1.5f, 3.0f, 3.0f});
  Stage2Decision d = checkStage2(wall_point, some.views, kCamera, {});
  EXPECT_FALSE(d.dynamic);
  EXPECT_EQ(d.keyframes_occluded, 2);
  EXPECT_EQ(d.keyframes_checked, 3);
  const Keyframes all({1.5f, 1.5f, 1.5f});
  d = checkStage2(wall_point, all.views, kCamera, {});
  EXPECT_FALSE(d.dynamic);
  EXPECT_EQ(d.keyframes_checked, 0);
}

// The point was made on a person at 1.5 m who has since left: the keyframes see the wall
// through it.
TEST(Stage2, PointSeenThroughInMostKeyframesIsRemoved) {
  const Vec3 person_point(0.1, 0.0, 1.5);
  const Keyframes gone({3.0f, 1.5f, 3.0f, 3.0f, 1.5f});
  const Stage2Decision d = checkStage2(person_point, gone.views, kCamera, {});
  EXPECT_TRUE(d.dynamic);
  EXPECT_EQ(d.keyframes_checked, 5);
  EXPECT_EQ(d.keyframes_inconsistent, 3);
  EXPECT_NEAR(d.median_residual, 0.5, 1e-9);
}

TEST(Stage2, ATieKeepsThePoint) {
  const Keyframes tie({3.0f, 1.5f, 3.0f, 1.5f});
  EXPECT_FALSE(checkStage2(Vec3(0.1, 0, 1.5), tie.views, kCamera, {}).dynamic);
}

TEST(Stage2, VotesStopAtTheConfiguredNumberOfKeyframes) {
  // The best three keyframes agree with the point; the later ones would outvote them.
  const Keyframes many({1.5f, 1.5f, 1.5f, 3.0f, 3.0f, 3.0f, 3.0f});
  DynamicOptions options;
  options.stage2_keyframes = 3;
  Stage2Decision d = checkStage2(Vec3(0.1, 0, 1.5), many.views, kCamera, options);
  EXPECT_EQ(d.keyframes_checked, 3);
  EXPECT_FALSE(d.dynamic);
  options.stage2_keyframes = 7;
  d = checkStage2(Vec3(0.1, 0, 1.5), many.views, kCamera, options);
  EXPECT_EQ(d.keyframes_checked, 7);
  EXPECT_TRUE(d.dynamic);
}

TEST(Stage2, KeyframesThatCannotSeeThePointAreSkipped) {
  const cv::Mat half = halfDepth(3.0f);
  const cv::Mat empty_half = halfDepth(0.0f);
  const std::vector<KeyframeDepthView> views{
      {SE3(Quat::Identity(), Vec3(0, 0, -2.0)), &half},  // point behind the camera
      {SE3(Quat::Identity(), Vec3(5.0, 0, 0)), &half},   // outside the image
      {SE3(), &empty_half},                              // no depth reading
  };
  const Stage2Decision d = checkStage2(Vec3(0, 0, 1.5), views, kCamera, {});
  EXPECT_EQ(d.keyframes_checked, 0);
  EXPECT_EQ(d.keyframes_occluded, 0);
  EXPECT_FALSE(d.dynamic);
  EXPECT_EQ(d.median_residual, 0.0);
}

}  // namespace
}  // namespace desslam::dynamic
