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

TEST(FeaturesInMask, LooksUpTheRoundedRawKeypoint) {
  const PinholeCamera camera(test::testCameraOptions());
  const auto features = test::makeFeatures({{{10.4f, 20.6f}, 1}, {{100, 100}, 2}}, camera, test::depthImage(2.0f));
  cv::Mat mask(480, 640, CV_8UC1, cv::Scalar(0));
  mask.at<uint8_t>(21, 10) = 255;
  EXPECT_EQ(featuresInMask(*features, mask), (std::vector<uint8_t>{1, 0}));
}

}  // namespace
}  // namespace desslam::dynamic
