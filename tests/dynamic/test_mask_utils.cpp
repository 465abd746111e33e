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

// The camera moves 0.08 m along x in front of a wall at 2 m: every pixel moves by
// -fx * 0.08 / 2 = -21 px in frame k (p_k = T_k_j * p_j, translation (-0.08, 0, 0)).
TEST(CarryMaskForward, PureTranslationShiftsTheMaskByTheExpectedPixels) {
  const PinholeCamera camera(test::testCameraOptions());
  cv::Mat mask(480, 640, CV_8UC1, cv::Scalar(0));
  mask(cv::Rect(200, 150, 80, 160)).setTo(255);
  const cv::Mat depth = test::depthImage(2.0f);
  const SE3 T_k_j(Quat::Identity(), Vec3(-0.08, 0, 0));
  const cv::Mat carried = carryMaskForward(mask, depth, T_k_j, camera);
  cv::Mat expected(480, 640, CV_8UC1, cv::Scalar(0));
  expected(cv::Rect(179, 150, 80, 160)).setTo(255);
  EXPECT_EQ(cv::countNonZero(carried != expected), 0);
}

TEST(CarryMaskForward, FillsHolesWithoutDepthAndGapsWhenComingCloser) {
  const PinholeCamera camera(test::testCameraOptions());
  cv::Mat mask(480, 640, CV_8UC1, cv::Scalar(0));
  const cv::Rect person(280, 180, 80, 120);
  mask(person).setTo(255);
  cv::Mat depth = test::depthImage(2.0f);
  depth(cv::Rect(300, 200, 20, 20)).setTo(0.0f);  // no depth there: too big for the closing to fill
  // The camera moves 0.2 m closer: the mask grows by 2 / 1.8 and a plain forward warp would
  // leave one-pixel gaps between splatted pixels.
  const cv::Mat carried = carryMaskForward(mask, depth, SE3(Quat::Identity(), Vec3(0, 0, -0.2)), camera);
  const double scale = 2.0 / 1.8;
  const cv::Rect grown(static_cast<int>(319.5 + (280 - 319.5) * scale) + 2, static_cast<int>(239.5 + (180 - 239.5) * scale) + 2,
                       static_cast<int>(80 * scale) - 4, static_cast<int>(120 * scale) - 4);
  EXPECT_EQ(cv::countNonZero(carried(grown)), grown.area());  // solid inside
  EXPECT_EQ(carried.at<uint8_t>(240, 200), 0);                 // nothing far outside
  EXPECT_THROW(carryMaskForward(mask, cv::Mat(10, 10, CV_32FC1), SE3(), camera), InputError);
}

}  // namespace
}  // namespace desslam::dynamic
