#include <algorithm>
#include <cmath>
#include <filesystem>
#include <set>
#include <thread>

#include <gtest/gtest.h>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.hpp"
#include "feature/descriptor.hpp"
#include "feature/orb_extractor.hpp"
#include "support/shared_data.hpp"

namespace desslam::feature {
namespace {

const std::filesystem::path kClip = test::clipDir("fr1_xyz_0000_0099");

// First RGB frame of the clip, as gray.
cv::Mat loadClipFrame() {
  std::vector<std::filesystem::path> files;
  for (const auto& entry : std::filesystem::directory_iterator(kClip / "rgb"))
    if (entry.path().extension() == ".png") files.push_back(entry.path());
  if (files.empty()) throw InputError("no PNG in " + (kClip / "rgb").string());
  std::sort(files.begin(), files.end());
  cv::Mat gray = cv::imread(files.front().string(), cv::IMREAD_GRAYSCALE);
  if (gray.empty()) throw InputError("cannot read " + files.front().string());
  return gray;
}

// Random rectangles of random gray values (each contributes corners) drawn into `roi`, with
// intensities in [lo, hi].
void drawRectangles(cv::Mat& image, const cv::Rect& roi, int count, int lo, int hi, cv::RNG& rng) {
  for (int i = 0; i < count; ++i) {
    const int w = rng.uniform(8, 40), h = rng.uniform(8, 40);
    const int x = rng.uniform(roi.x, roi.x + roi.width - w), y = rng.uniform(roi.y, roi.y + roi.height - h);
    cv::rectangle(image, cv::Rect(x, y, w, h), cv::Scalar(rng.uniform(lo, hi + 1)), cv::FILLED);
  }
}

cv::Mat syntheticTexturedImage() {
  cv::RNG rng(1234);
  cv::Mat image(480, 640, CV_8U, cv::Scalar(128));
  drawRectangles(image, cv::Rect(0, 0, 640, 480), 1500, 0, 255, rng);
  return image;
}

// Strong texture in the top-left quarter only; low-contrast texture (steps of about 10 grey
// levels: above the minimum FAST threshold 7, below the initial 20) everywhere else.
cv::Mat concentratedTextureImage() {
  cv::RNG rng(99);
  cv::Mat image(480, 640, CV_8U, cv::Scalar(128));
  drawRectangles(image, cv::Rect(0, 0, 640, 480), 600, 118, 138, rng);
  cv::Mat strong = image(cv::Rect(0, 0, 320, 240));
  strong.setTo(cv::Scalar(128));
  drawRectangles(strong, cv::Rect(0, 0, 320, 240), 800, 0, 255, rng);
  return image;
}

// Share of the cells of a cols x rows grid over the image that hold at least one keypoint.
double occupiedShare(const std::vector<cv::KeyPoint>& keypoints, cv::Size image, int cols = 8, int rows = 6) {
  std::set<int> cells;
  for (const cv::KeyPoint& kp : keypoints) {
    const int c = std::clamp(static_cast<int>(kp.pt.x * cols / image.width), 0, cols - 1);
    const int r = std::clamp(static_cast<int>(kp.pt.y * rows / image.height), 0, rows - 1);
    cells.insert(r * cols + c);
  }
  return double(cells.size()) / (cols * rows);
}

void expectWellFormed(const cv::Mat& image, const std::vector<cv::KeyPoint>& keypoints, const cv::Mat& descriptors,
                      const ScalePyramid& pyramid) {
  ASSERT_EQ(descriptors.rows, static_cast<int>(keypoints.size()));
  ASSERT_EQ(descriptors.cols, 32);
  ASSERT_EQ(descriptors.type(), CV_8U);
  for (const cv::KeyPoint& kp : keypoints) {
    ASSERT_GE(kp.octave, 0);
    ASSERT_LT(kp.octave, pyramid.levels());
    EXPECT_NEAR(kp.size, 31.0 * pyramid.scale[kp.octave], 1e-3);
    EXPECT_GE(kp.angle, 0.f);
    EXPECT_LT(kp.angle, 360.f);
    EXPECT_GT(kp.response, 0.f);
    EXPECT_TRUE(kp.pt.x >= 0 && kp.pt.y >= 0 && kp.pt.x < image.cols && kp.pt.y < image.rows);
  }
}

TEST(OrbExtractor, ClipFrameCountSpreadAndAllOctaves) {
  DESSLAM_REQUIRE_SHARED(kClip);
  const cv::Mat gray = loadClipFrame();
  const OrbExtractor extractor(OrbOptions{});
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  extractor.extract(gray, keypoints, descriptors);
  expectWellFormed(gray, keypoints, descriptors, extractor.pyramid());

  EXPECT_NEAR(static_cast<double>(keypoints.size()), 1000.0, 100.0);
  EXPECT_GE(occupiedShare(keypoints, gray.size()), 0.8);
  std::vector<int> per_octave(8, 0);
  for (const cv::KeyPoint& kp : keypoints) ++per_octave[kp.octave];
  for (int level = 0; level < 8; ++level) EXPECT_GT(per_octave[level], 0) << "octave " << level << " unused";
}

TEST(OrbExtractor, SyntheticTexturedImageCount) {
  const cv::Mat image = syntheticTexturedImage();
  for (int wanted : {500, 1000, 2000}) {
    OrbOptions options;
    options.num_features = wanted;
    std::vector<cv::KeyPoint> keypoints;
    cv::Mat descriptors;
    OrbExtractor(options).extract(image, keypoints, descriptors);
    EXPECT_NEAR(static_cast<double>(keypoints.size()), wanted, 0.1 * wanted) << "num_features " << wanted;
    EXPECT_EQ(descriptors.rows, static_cast<int>(keypoints.size()));
  }
}

TEST(OrbExtractor, SpreadsBetterThanOpenCvOrbWhenTextureIsConcentrated) {
  const cv::Mat image = concentratedTextureImage();
  const OrbExtractor extractor(OrbOptions{});
  std::vector<cv::KeyPoint> ours;
  cv::Mat descriptors;
  extractor.extract(image, ours, descriptors);

  const cv::Ptr<cv::ORB> orb = cv::ORB::create(static_cast<int>(ours.size()), 1.2f, 8);
  std::vector<cv::KeyPoint> theirs;
  orb->detect(image, theirs);

  const double our_share = occupiedShare(ours, image.size());
  const double their_share = occupiedShare(theirs, image.size());
  RecordProperty("our_share", std::to_string(our_share));
  RecordProperty("opencv_share", std::to_string(their_share));
  EXPECT_GE(our_share, their_share + 0.3) << "ours " << our_share << ", cv::ORB " << their_share;
  EXPECT_GE(our_share, 0.8);
}

TEST(OrbExtractor, DeterministicAcrossCallsAndThreads) {
  const cv::Mat image = syntheticTexturedImage();
  const OrbExtractor extractor(OrbOptions{});
  std::vector<cv::KeyPoint> reference;
  cv::Mat reference_descriptors;
  extractor.extract(image, reference, reference_descriptors);

  constexpr int kThreads = 4;
  std::vector<std::vector<cv::KeyPoint>> keypoints(kThreads);
  std::vector<cv::Mat> descriptors(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t)
    threads.emplace_back([&, t] { extractor.extract(image, keypoints[t], descriptors[t]); });
  for (auto& thread : threads) thread.join();

  for (int t = 0; t < kThreads; ++t) {
    ASSERT_EQ(keypoints[t].size(), reference.size()) << "thread " << t;
    for (size_t i = 0; i < reference.size(); ++i) {
      ASSERT_EQ(keypoints[t][i].pt, reference[i].pt) << "thread " << t << " keypoint " << i;
      ASSERT_EQ(keypoints[t][i].angle, reference[i].angle);
      ASSERT_EQ(keypoints[t][i].octave, reference[i].octave);
    }
    EXPECT_EQ(cv::norm(descriptors[t], reference_descriptors, cv::NORM_HAMMING), 0.0) << "thread " << t;
  }
}

TEST(OrbExtractor, MatchesSurviveA30DegreeRotation) {
  DESSLAM_REQUIRE_SHARED(kClip);
  const cv::Mat gray = loadClipFrame();
  const cv::Point2f centre(gray.cols / 2.f, gray.rows / 2.f);
  const cv::Mat R = cv::getRotationMatrix2D(centre, 30.0, 1.0);  // 2x3 CV_64F
  cv::Mat rotated;
  cv::warpAffine(gray, rotated, R, gray.size(), cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));

  const OrbExtractor extractor(OrbOptions{});
  std::vector<cv::KeyPoint> kp_a, kp_b;
  cv::Mat desc_a, desc_b;
  extractor.extract(gray, kp_a, desc_a);
  extractor.extract(rotated, kp_b, desc_b);
  ASSERT_FALSE(kp_b.empty());

  int matches = 0, correct = 0;
  for (int i = 0; i < desc_a.rows; ++i) {
    int best = 1 << 20, second = 1 << 20, best_j = -1;
    for (int j = 0; j < desc_b.rows; ++j) {
      const int d = descriptorDistance(desc_a.ptr<uint8_t>(i), desc_b.ptr<uint8_t>(j));
      if (d < best) {
        second = best;
        best = d;
        best_j = j;
      } else if (d < second) {
        second = d;
      }
    }
    if (best > 64 || best >= 0.8 * second) continue;  // nearest neighbour + ratio test
    ++matches;
    const cv::Point2f& p = kp_a[i].pt;
    const cv::Point2f expected(static_cast<float>(R.at<double>(0, 0) * p.x + R.at<double>(0, 1) * p.y + R.at<double>(0, 2)),
                               static_cast<float>(R.at<double>(1, 0) * p.x + R.at<double>(1, 1) * p.y + R.at<double>(1, 2)));
    const double tolerance = 3.0 * extractor.pyramid().scale[kp_a[i].octave];
    if (cv::norm(kp_b[best_j].pt - expected) <= tolerance) ++correct;
  }
  const double share = matches > 0 ? double(correct) / matches : 0.0;
  RecordProperty("matches", matches);
  RecordProperty("correct_share", std::to_string(share));
  EXPECT_GE(matches, 150) << "too few matches survive the rotation";
  EXPECT_GT(share, 0.7) << correct << " of " << matches << " matches are geometrically correct";
}

TEST(OrbExtractor, PyramidAndQuotas) {
  OrbOptions options;
  const OrbExtractor extractor(options);
  const ScalePyramid& p = extractor.pyramid();
  ASSERT_EQ(p.levels(), 8);
  EXPECT_DOUBLE_EQ(p.scale[0], 1.0);
  EXPECT_NEAR(p.scale[7], std::pow(1.2, 7), 1e-12);
  EXPECT_NEAR(p.sigma2[3] * p.inv_sigma2[3], 1.0, 1e-12);
  EXPECT_NEAR(p.scale[2] * p.inv_scale[2], 1.0, 1e-12);
  const std::vector<int>& quota = extractor.featuresPerLevel();
  ASSERT_EQ(quota.size(), 8u);
  int sum = 0;
  for (size_t l = 0; l < quota.size(); ++l) {
    sum += quota[l];
    if (l > 0) EXPECT_LT(quota[l], quota[l - 1]) << "coarser levels must get fewer features";
  }
  EXPECT_EQ(sum, options.num_features);
  // Area series: consecutive quotas differ by 1.2^2.
  EXPECT_NEAR(double(quota[0]) / quota[1], 1.44, 0.02);
}

TEST(OrbExtractor, RejectsBadInputAndOptions) {
  OrbOptions bad;
  bad.num_levels = 0;
  EXPECT_THROW(OrbExtractor{bad}, ConfigError);
  bad = OrbOptions{};
  bad.min_fast_threshold = 30;  // above the initial threshold
  EXPECT_THROW(OrbExtractor{bad}, ConfigError);

  const OrbExtractor extractor(OrbOptions{});
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  EXPECT_THROW(extractor.extract(cv::Mat(), keypoints, descriptors), InputError);
  EXPECT_THROW(extractor.extract(cv::Mat(480, 640, CV_8UC3, cv::Scalar::all(0)), keypoints, descriptors), InputError);
  // Too small for any level: no keypoints, no crash.
  extractor.extract(cv::Mat(30, 30, CV_8U, cv::Scalar(0)), keypoints, descriptors);
  EXPECT_TRUE(keypoints.empty());
  EXPECT_EQ(descriptors.rows, 0);
}

}  // namespace
}  // namespace desslam::feature
