#include <string>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/error.hpp"
#include "semantic/mask_directory_segmenter.hpp"
#include "support/temp_dir.hpp"

namespace desslam::semantic {
namespace {

TEST(MaskDirectory, NonzeroPixelsAreDynamic) {
  test::TempDir dir;
  cv::Mat mask(48, 64, CV_8U, cv::Scalar(0));
  mask(cv::Rect(10, 5, 20, 15)).setTo(1);  // any nonzero value counts, not only 255
  ASSERT_TRUE(cv::imwrite((dir.path() / "1305031102.175304.png").string(), mask));

  MaskDirectorySegmenter segmenter(dir.path());
  EXPECT_EQ(segmenter.name(), "mask_dir");
  const cv::Mat bgr(48, 64, CV_8UC3, cv::Scalar(0, 0, 0));
  const Segmentation s = segmenter.segment(bgr, "1305031102.175304.png");
  EXPECT_TRUE(s.labels.empty());
  ASSERT_EQ(s.dynamic_mask.type(), CV_8U);
  ASSERT_EQ(s.dynamic_mask.size(), bgr.size());
  EXPECT_EQ(cv::countNonZero(s.dynamic_mask), 20 * 15);
  EXPECT_EQ(s.dynamic_mask.at<std::uint8_t>(5, 10), 255);
  EXPECT_EQ(s.dynamic_mask.at<std::uint8_t>(4, 10), 0);
}

TEST(MaskDirectory, SixteenBitAndColourMasks) {
  test::TempDir dir;
  cv::Mat deep(8, 8, CV_16U, cv::Scalar(0));
  deep.at<std::uint16_t>(2, 3) = 256;  // zero in the low byte: must still count
  ASSERT_TRUE(cv::imwrite((dir.path() / "a.png").string(), deep));
  cv::Mat colour(8, 8, CV_8UC3, cv::Scalar(0, 0, 0));
  colour.at<cv::Vec3b>(1, 1) = {0, 0, 9};  // red only
  ASSERT_TRUE(cv::imwrite((dir.path() / "b.png").string(), colour));

  MaskDirectorySegmenter segmenter(dir.path());
  const cv::Mat bgr(8, 8, CV_8UC3);
  const Segmentation a = segmenter.segment(bgr, "a.png");
  EXPECT_EQ(cv::countNonZero(a.dynamic_mask), 1);
  EXPECT_EQ(a.dynamic_mask.at<std::uint8_t>(2, 3), 255);
  const Segmentation b = segmenter.segment(bgr, "b.png");
  EXPECT_EQ(cv::countNonZero(b.dynamic_mask), 1);
  EXPECT_EQ(b.dynamic_mask.at<std::uint8_t>(1, 1), 255);
}

TEST(MaskDirectory, MissingMaskNamesTheFile) {
  test::TempDir dir;
  MaskDirectorySegmenter segmenter(dir.path());
  try {
    segmenter.segment(cv::Mat(8, 8, CV_8UC3), "1305031102.175304.png");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find((dir.path() / "1305031102.175304.png").string()),
              std::string::npos)
        << e.what();
  }
}

TEST(MaskDirectory, SizeMismatchIsAnInputError) {
  test::TempDir dir;
  ASSERT_TRUE(cv::imwrite((dir.path() / "f.png").string(), cv::Mat(8, 8, CV_8U, cv::Scalar(0))));
  MaskDirectorySegmenter segmenter(dir.path());
  EXPECT_THROW(segmenter.segment(cv::Mat(16, 8, CV_8UC3), "f.png"), InputError);
}

TEST(MaskDirectory, MissingDirectoryIsAnInputError) {
  EXPECT_THROW(MaskDirectorySegmenter("/nonexistent/desslam/masks"), InputError);
  SemanticOptions options;
  options.segmenter = SegmenterKind::kMaskDir;
  options.mask_dir = "/nonexistent/desslam/masks";
  EXPECT_THROW(makeSegmenter(options), InputError);
}

TEST(MaskDirectory, MadeFromOptions) {
  test::TempDir dir;
  SemanticOptions options;
  options.segmenter = SegmenterKind::kMaskDir;
  options.mask_dir = dir.path().string();
  const auto segmenter = makeSegmenter(options);
  ASSERT_NE(segmenter, nullptr);
  EXPECT_EQ(segmenter->name(), "mask_dir");
}

}  // namespace
}  // namespace desslam::semantic
