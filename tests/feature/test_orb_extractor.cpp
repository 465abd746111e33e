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
    if (l > 0) {
      EXPECT_LT(quota[l], quota[l - 1]) << "coarser levels must get fewer features";
    }
  }
  EXPECT_EQ(sum, options.num_features);
  // Area series: consecutive quotas differ by 1.2^2.
  EXPECT_NEAR(double(quota[0]) / quota[1], 1.44, 0.02);
}

// ---- extractOutside / appendDistinctKeypoints -------------------------------------------------

// A person-sized block covering the middle 40 % of the width and most of the height: a mask
// "filling much of the view", as when extractOutside is called in tracking.
cv::Mat centralExclusionMask(cv::Size size) {
  cv::Mat exclude(size, CV_8UC1, cv::Scalar(0));
  exclude(cv::Rect(size.width * 3 / 10, size.height / 10, size.width * 4 / 10, size.height * 9 / 10)).setTo(255);
  return exclude;
}

TEST(OrbExtractor, ExtractOutsideKeepsEveryKeypointOutTheMask) {
  const cv::Mat image = syntheticTexturedImage();
  const cv::Mat exclude = centralExclusionMask(image.size());
  const OrbExtractor extractor(OrbOptions{});
  for (int wanted : {300, 600}) {
    SCOPED_TRACE(wanted);
    std::vector<cv::KeyPoint> keypoints;
    cv::Mat descriptors;
    extractor.extractOutside(image, exclude, wanted, keypoints, descriptors);
    expectWellFormed(image, keypoints, descriptors, extractor.pyramid());
    // The budget is spent outside the mask, not lost to it: close to the count asked for.
    EXPECT_NEAR(static_cast<double>(keypoints.size()), wanted, 0.1 * wanted);
    std::set<int> octaves;
    for (const cv::KeyPoint& kp : keypoints) {
      const int x = std::clamp(static_cast<int>(std::lround(kp.pt.x)), 0, image.cols - 1);
      const int y = std::clamp(static_cast<int>(std::lround(kp.pt.y)), 0, image.rows - 1);
      EXPECT_EQ(exclude.at<uint8_t>(y, x), 0) << "keypoint at " << kp.pt << " octave " << kp.octave
                                              << " lies in the excluded region";
      octaves.insert(kp.octave);
    }
    EXPECT_GE(octaves.size(), 5u) << "extractOutside should spread over the pyramid as extract() does";
    // Both sides of the block get keypoints (the spread over the image holds outside the mask).
    const auto left = std::count_if(keypoints.begin(), keypoints.end(),
                                    [&](const cv::KeyPoint& kp) { return kp.pt.x < image.cols * 0.3; });
    const auto right = std::count_if(keypoints.begin(), keypoints.end(),
                                     [&](const cv::KeyPoint& kp) { return kp.pt.x >= image.cols * 0.7; });
    EXPECT_GT(left, static_cast<long>(wanted) / 5);
    EXPECT_GT(right, static_cast<long>(wanted) / 5);
  }
}

TEST(OrbExtractor, ExtractOutsideWithAnEmptyMaskMatchesExtract) {
  // Nothing excluded and the full budget: the same keypoints as extract() (one shared path).
  const cv::Mat image = syntheticTexturedImage();
  const OrbExtractor extractor(OrbOptions{});
  std::vector<cv::KeyPoint> all, outside;
  cv::Mat all_descriptors, outside_descriptors;
  extractor.extract(image, all, all_descriptors);
  extractor.extractOutside(image, cv::Mat::zeros(image.size(), CV_8UC1), extractor.options().num_features, outside,
                           outside_descriptors);
  ASSERT_EQ(outside.size(), all.size());
  for (size_t i = 0; i < all.size(); ++i) {
    ASSERT_EQ(outside[i].pt, all[i].pt) << i;
    ASSERT_EQ(outside[i].octave, all[i].octave) << i;
  }
  EXPECT_EQ(cv::norm(outside_descriptors, all_descriptors, cv::NORM_HAMMING), 0.0);
}

TEST(OrbExtractor, ExtractOutsideRejectsAWrongMask) {
  const cv::Mat image = syntheticTexturedImage();
  const OrbExtractor extractor(OrbOptions{});
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  EXPECT_THROW(extractor.extractOutside(image, cv::Mat(), 100, keypoints, descriptors), InputError);
  EXPECT_THROW(extractor.extractOutside(image, cv::Mat::zeros(240, 320, CV_8UC1), 100, keypoints, descriptors),
               InputError);
  EXPECT_THROW(extractor.extractOutside(image, cv::Mat::zeros(image.size(), CV_32FC1), 100, keypoints, descriptors),
               InputError);
  EXPECT_THROW(extractor.extractOutside(image, cv::Mat::zeros(image.size(), CV_8UC3), 100, keypoints, descriptors),
               InputError);
}

// Descriptor rows that differ from each other (row i: bytes i*32 .. i*32+31, mod 256).
cv::Mat distinctDescriptors(int rows, int first_value) {
  cv::Mat d(rows, 32, CV_8UC1);
  for (int r = 0; r < rows; ++r)
    for (int b = 0; b < 32; ++b) d.at<uint8_t>(r, b) = static_cast<uint8_t>((first_value + r * 32 + b) % 256);
  return d;
}

cv::KeyPoint keypointAt(float x, float y, int octave) {
  return cv::KeyPoint(cv::Point2f(x, y), 31.f, 0.f, 1.f, octave);
}

bool sameRow(const cv::Mat& a, int row_a, const cv::Mat& b, int row_b) {
  return cv::norm(a.row(row_a), b.row(row_b), cv::NORM_HAMMING) == 0.0;
}

TEST(AppendDistinctKeypoints, SkipsCoincidingKeypointsAndCopiesTheRightRows) {
  const ScalePyramid pyramid = makeScalePyramid(8, 1.2);
  std::vector<cv::KeyPoint> keypoints = {keypointAt(100, 100, 0), keypointAt(200, 200, 3)};
  cv::Mat descriptors = distinctDescriptors(2, 0);
  const cv::Mat existing_descriptors = descriptors.clone();

  // Tolerance: 1 pixel of the keypoint's level, 1.2^3 = 1.728 level-0 pixels at octave 3.
  const std::vector<cv::KeyPoint> extra = {
      keypointAt(100.8f, 99.5f, 0),  // 0: within 1 px of the first, same octave: duplicate
      keypointAt(100, 100, 1),       // 1: same spot, other octave: distinct
      keypointAt(101.5f, 100, 0),    // 2: 1.5 px away at octave 0: distinct
      keypointAt(201.5f, 199, 3),    // 3: within 1.728 px at octave 3: duplicate
      keypointAt(202, 200, 3),       // 4: 2 px away at octave 3: distinct
      keypointAt(400, 50, 2),        // 5: nowhere near: distinct
  };
  const cv::Mat extra_descriptors = distinctDescriptors(static_cast<int>(extra.size()), 100);
  const std::vector<int> expected = {1, 2, 4, 5};

  const int appended = appendDistinctKeypoints(keypoints, descriptors, extra, extra_descriptors, pyramid);
  EXPECT_EQ(appended, static_cast<int>(expected.size()));
  ASSERT_EQ(keypoints.size(), 2 + expected.size());
  ASSERT_EQ(descriptors.rows, static_cast<int>(keypoints.size()));
  ASSERT_EQ(descriptors.type(), CV_8UC1);
  // The existing keypoints and rows stay first and unchanged.
  EXPECT_EQ(keypoints[0].pt, cv::Point2f(100, 100));
  EXPECT_EQ(keypoints[1].pt, cv::Point2f(200, 200));
  EXPECT_TRUE(sameRow(descriptors, 0, existing_descriptors, 0));
  EXPECT_TRUE(sameRow(descriptors, 1, existing_descriptors, 1));
  // Then the distinct extras, in order, each with its own descriptor row.
  for (size_t k = 0; k < expected.size(); ++k) {
    const int row = static_cast<int>(2 + k);
    EXPECT_EQ(keypoints[row].pt, extra[expected[k]].pt) << "appended " << k;
    EXPECT_EQ(keypoints[row].octave, extra[expected[k]].octave) << "appended " << k;
    EXPECT_TRUE(sameRow(descriptors, row, extra_descriptors, expected[k])) << "appended " << k;
  }
}

TEST(AppendDistinctKeypoints, AppendsEverythingToAnEmptySetAndNothingWhenNoExtra) {
  const ScalePyramid pyramid = makeScalePyramid(8, 1.2);
  const std::vector<cv::KeyPoint> extra = {keypointAt(10, 10, 0), keypointAt(10.5f, 10, 0), keypointAt(300, 20, 4)};
  const cv::Mat extra_descriptors = distinctDescriptors(3, 7);
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  EXPECT_EQ(appendDistinctKeypoints(keypoints, descriptors, extra, extra_descriptors, pyramid), 3);
  ASSERT_EQ(keypoints.size(), 3u);
  ASSERT_EQ(descriptors.rows, 3);
  for (int r = 0; r < 3; ++r) {
    EXPECT_EQ(keypoints[r].pt, extra[r].pt);
    EXPECT_TRUE(sameRow(descriptors, r, extra_descriptors, r)) << r;
  }

  const cv::Mat before = descriptors.clone();
  EXPECT_EQ(appendDistinctKeypoints(keypoints, descriptors, {}, cv::Mat(0, 32, CV_8UC1), pyramid), 0);
  EXPECT_EQ(keypoints.size(), 3u);
  EXPECT_EQ(cv::norm(descriptors, before, cv::NORM_HAMMING), 0.0);
  // Everything again: each one now coincides with itself.
  EXPECT_EQ(appendDistinctKeypoints(keypoints, descriptors, extra, extra_descriptors, pyramid), 0);
  EXPECT_EQ(descriptors.rows, 3);
}

TEST(AppendDistinctKeypoints, ExtraFromExtractOutsideAddsOnlyNewCorners) {
  // The tracking use: the normal extraction, topped up outside a big mask. The same detector
  // finds some of the same corners again; they must not be doubled.
  const cv::Mat image = syntheticTexturedImage();
  const OrbExtractor extractor(OrbOptions{});
  std::vector<cv::KeyPoint> keypoints, extra;
  cv::Mat descriptors, extra_descriptors;
  extractor.extract(image, keypoints, descriptors);
  extractor.extractOutside(image, centralExclusionMask(image.size()), 500, extra, extra_descriptors);
  const std::vector<cv::KeyPoint> original = keypoints;
  const cv::Mat original_descriptors = descriptors.clone();

  const auto coincides = [&](const cv::KeyPoint& e) {
    const double tolerance = extractor.pyramid().scale[e.octave];
    return std::any_of(original.begin(), original.end(), [&](const cv::KeyPoint& kp) {
      return kp.octave == e.octave && std::abs(kp.pt.x - e.pt.x) <= tolerance &&
             std::abs(kp.pt.y - e.pt.y) <= tolerance;
    });
  };
  int expected = 0;
  for (const cv::KeyPoint& e : extra) expected += coincides(e) ? 0 : 1;
  ASSERT_GT(expected, 0);
  ASSERT_LT(expected, static_cast<int>(extra.size())) << "the test needs some corners found by both extractions";

  const int appended = appendDistinctKeypoints(keypoints, descriptors, extra, extra_descriptors, extractor.pyramid());
  EXPECT_EQ(appended, expected);
  ASSERT_EQ(keypoints.size(), original.size() + static_cast<size_t>(appended));
  ASSERT_EQ(descriptors.rows, static_cast<int>(keypoints.size()));
  EXPECT_EQ(cv::norm(descriptors.rowRange(0, static_cast<int>(original.size())), original_descriptors,
                     cv::NORM_HAMMING),
            0.0);
  // Each appended keypoint is a non-coinciding extra, in order, carrying that extra's row.
  size_t next = original.size();
  for (size_t i = 0; i < extra.size(); ++i) {
    if (coincides(extra[i])) continue;
    ASSERT_LT(next, keypoints.size());
    EXPECT_EQ(keypoints[next].pt, extra[i].pt);
    EXPECT_EQ(keypoints[next].octave, extra[i].octave);
    EXPECT_TRUE(sameRow(descriptors, static_cast<int>(next), extra_descriptors, static_cast<int>(i))) << i;
    ++next;
  }
}

// Keypoints outside `exclude` with a depth in [min, max] in depth_m.
int outsideWithDepth(const std::vector<cv::KeyPoint>& keypoints, const cv::Mat& exclude, const cv::Mat& depth_m,
                     float min_m, float max_m) {
  int n = 0;
  for (const cv::KeyPoint& kp : keypoints) {
    const int x = std::clamp(cvRound(kp.pt.x), 0, exclude.cols - 1), y = std::clamp(cvRound(kp.pt.y), 0, exclude.rows - 1);
    const float d = depth_m.at<float>(y, x);
    n += exclude.at<uint8_t>(y, x) == 0 && d >= min_m && d <= max_m ? 1 : 0;
  }
  return n;
}

TEST(TopUpOutside, CountsOnlyKeypointsWithDepthTowardsTheTarget) {
  // A person over the left 60 % of the view and no depth reading on the lower half of the rest
  // (a window, a dark floor): asking the extractor for the target alone leaves too few with
  // depth, which is what a new map needs.
  const cv::Mat image = syntheticTexturedImage();
  const OrbExtractor extractor(OrbOptions{});
  cv::Mat exclude(image.size(), CV_8UC1, cv::Scalar(0));
  exclude(cv::Rect(0, 0, 384, 480)).setTo(255);
  cv::Mat depth(image.size(), CV_32FC1, cv::Scalar(0.0f));
  depth(cv::Rect(0, 0, 640, 240)).setTo(2.0f);
  constexpr int kWanted = 400;

  std::vector<cv::KeyPoint> plain;
  cv::Mat plain_descriptors;
  extractor.extractOutside(image, exclude, kWanted, plain, plain_descriptors);
  ASSERT_LT(outsideWithDepth(plain, exclude, depth, 0.1f, 4.0f), kWanted)
      << "the test needs a view where the plain top-up falls short";

  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  extractor.extract(image, keypoints, descriptors);
  const size_t before = keypoints.size();
  const int appended = topUpOutside(extractor, image, exclude, depth, 0.1, 4.0, kWanted, keypoints, descriptors);
  EXPECT_EQ(static_cast<size_t>(appended), keypoints.size() - before);
  EXPECT_EQ(descriptors.rows, static_cast<int>(keypoints.size()));
  EXPECT_GE(outsideWithDepth(keypoints, exclude, depth, 0.1f, 4.0f), kWanted);
  for (size_t i = before; i < keypoints.size(); ++i) {
    const cv::Point p(cvRound(keypoints[i].pt.x), cvRound(keypoints[i].pt.y));
    EXPECT_EQ(exclude.at<uint8_t>(std::min(p.y, 479), std::min(p.x, 639)), 0) << "appended keypoint " << i << " in the mask";
  }

  // Enough already: nothing appended.
  const size_t now = keypoints.size();
  EXPECT_EQ(topUpOutside(extractor, image, exclude, depth, 0.1, 4.0, 50, keypoints, descriptors), 0);
  EXPECT_EQ(keypoints.size(), now);
  // A depth image of another size is an input error, not a silent miscount.
  EXPECT_THROW(topUpOutside(extractor, image, exclude, cv::Mat(10, 10, CV_32FC1, cv::Scalar(1.0f)), 0.1, 4.0,
                            kWanted, keypoints, descriptors),
               InputError);
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
