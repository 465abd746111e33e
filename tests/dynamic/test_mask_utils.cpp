#include <gtest/gtest.h>

#include "core/error.hpp"
#include "dynamic/constructed_features.hpp"
#include "dynamic/mask_utils.hpp"

namespace desslam::dynamic {
namespace {

TEST(DilateMask, GrowsByTheRadiusWithADisc) {
  cv::Mat mask(41, 41, CV_8UC1, cv::Scalar(0));
  mask.at<uint8_t>(20, 20) = 1;  // any nonzero value counts
  const cv::Mat grown = dilateMask(mask, 5);
  EXPECT_EQ(grown.at<uint8_t>(20, 25), 255);  // on the axes: exactly the radius
  EXPECT_EQ(grown.at<uint8_t>(15, 20), 255);
  EXPECT_EQ(grown.at<uint8_t>(20, 26), 0);
  EXPECT_EQ(grown.at<uint8_t>(26, 20), 0);
  EXPECT_EQ(grown.at<uint8_t>(23, 23), 255);  // diagonal at 4.2 px: inside the disc
  EXPECT_EQ(grown.at<uint8_t>(25, 25), 0);    // corner of the square at 7.1 px: outside
  const int area = cv::countNonZero(grown);
  EXPECT_GT(area, 60);   // ~ pi * 5^2 = 79; a square kernel would give 121
  EXPECT_LT(area, 100);
  const cv::Mat copy = dilateMask(mask, 0);
  EXPECT_EQ(cv::countNonZero(copy), 1);
  EXPECT_EQ(copy.at<uint8_t>(20, 20), 255);
  EXPECT_THROW(dilateMask(mask, -1), InputError);
  EXPECT_THROW(dilateMask(cv::Mat(5, 5, CV_32FC1), 1), InputError);
}

// A vertical band (x in [0, 99]) covers the left of a 200 x 100 image; keypoints one per column.
TEST(DilateMaskLeavingFeatures, ShrinksTheGrowthUntilEnoughKeypointsAreOutside) {
  cv::Mat mask(100, 200, CV_8UC1, cv::Scalar(0));
  mask.colRange(0, 100).setTo(255);
  std::vector<cv::KeyPoint> keypoints;
  for (int x = 0; x < 200; ++x) keypoints.emplace_back(cv::Point2f(static_cast<float>(x), 50.0f), 7.0f);
  // Radius 10 + 30: columns 140..199 stay outside = 30 % of the keypoints.
  GrownMask full = dilateMaskLeavingFeatures(mask, keypoints, 10, 30, 10, 0.3);
  EXPECT_EQ(full.radius_px, 40);
  EXPECT_EQ(full.mask.at<uint8_t>(50, 139), 255);
  EXPECT_EQ(full.mask.at<uint8_t>(50, 140), 0);
  // 40 % wanted: growth 30 -> 20 leaves columns 130..199 (35 %), 10 leaves 120..199 (40 %).
  GrownMask shrunk = dilateMaskLeavingFeatures(mask, keypoints, 10, 30, 10, 0.4);
  EXPECT_EQ(shrunk.radius_px, 20);
  EXPECT_EQ(shrunk.mask.at<uint8_t>(50, 119), 255);
  EXPECT_EQ(shrunk.mask.at<uint8_t>(50, 120), 0);
  // More than even the plain dilation leaves: no growth at all, never less than the dilation.
  EXPECT_EQ(dilateMaskLeavingFeatures(mask, keypoints, 10, 30, 10, 0.9).radius_px, 10);
  // Share 0 keeps the whole growth; the result matches dilateMask's.
  GrownMask kept = dilateMaskLeavingFeatures(mask, keypoints, 10, 30, 10, 0.0);
  EXPECT_EQ(kept.radius_px, 40);
  EXPECT_EQ(cv::countNonZero(kept.mask != dilateMask(mask, 40)), 0);
  // The base dilation alone comes with it, grown or not (stage 1 tells the grown ring by it).
  EXPECT_EQ(cv::countNonZero(kept.base_mask != dilateMask(mask, 10)), 0);
  EXPECT_EQ(cv::countNonZero(shrunk.base_mask != dilateMask(mask, 10)), 0);
  GrownMask ungrown = dilateMaskLeavingFeatures(mask, keypoints, 10, 0, 10, 0.3);
  EXPECT_EQ(ungrown.radius_px, 10);
  EXPECT_EQ(cv::countNonZero(ungrown.base_mask != ungrown.mask), 0);
  EXPECT_THROW(dilateMaskLeavingFeatures(mask, keypoints, -1, 30, 10, 0.3), InputError);
}

TEST(FeaturesInMask, LooksUpTheRoundedRawKeypoint) {
  const PinholeCamera camera(test::testCameraOptions());
  const auto features = test::makeFeatures({{{10.4f, 20.6f}, 1}, {{100, 100}, 2}}, camera, test::depthImage(2.0f));
  cv::Mat mask(480, 640, CV_8UC1, cv::Scalar(0));
  mask.at<uint8_t>(21, 10) = 255;
  EXPECT_EQ(featuresInMask(*features, mask), (std::vector<uint8_t>{1, 0}));
}

}  // namespace
}  // namespace desslam::dynamic
