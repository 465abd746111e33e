// ORB features (FAST corners + oriented rBRIEF descriptors) spread evenly over the image and
// over a scale pyramid, as the ORB-SLAM papers describe.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "feature/orb_options.hpp"
#include "feature/scale_pyramid.hpp"

namespace desslam::feature {

class OrbExtractor {
 public:
  // Validates `options` (throws desslam::ConfigError naming the orb.* key).
  explicit OrbExtractor(const OrbOptions& options);

  // gray: CV_8UC1 (throws desslam::InputError otherwise). Keypoints are in level-0 raw pixel
  // coordinates (undistortion is the caller's job); octave = pyramid level, angle in degrees
  // [0, 360), size = patch size (31) * level scale, response = FAST score.
  // descriptors: N x 32 CV_8U, row i belongs to keypoints[i].
  // Const and reentrant: several threads may call extract() on one extractor at once.
  void extract(const cv::Mat& gray, std::vector<cv::KeyPoint>& keypoints, cv::Mat& descriptors) const;

  // As extract(), but only corners outside `exclude` (CV_8U of gray's size, nonzero = excluded),
  // num_features of them spread over the levels and the image as extract() spreads its own.
  // Used to spend more of the feature budget on the static background when a person fills most
  // of the view. Throws InputError for a wrong exclude type or size.
  void extractOutside(const cv::Mat& gray, const cv::Mat& exclude, int num_features,
                      std::vector<cv::KeyPoint>& keypoints, cv::Mat& descriptors) const;

  const ScalePyramid& pyramid() const { return pyramid_; }
  const OrbOptions& options() const { return options_; }
  // Wanted keypoints per level (sum = num_features): a geometric series in the level's area.
  const std::vector<int>& featuresPerLevel() const { return features_per_level_; }

 private:
  // exclude: empty or as in extractOutside(); wanted: keypoints per level.
  void extractImpl(const cv::Mat& gray, const cv::Mat& exclude, const std::vector<int>& wanted,
                   std::vector<cv::KeyPoint>& keypoints, cv::Mat& descriptors) const;

  OrbOptions options_;
  ScalePyramid pyramid_;
  std::vector<int> features_per_level_;
  std::vector<int> circle_half_width_;  // half width of the orientation disc per row offset |dy|
};

// Appends to (keypoints, descriptors) the extra keypoints that do not coincide with one already
// there (same octave, within 1 pixel of that level), with their descriptor rows. Returns how many
// were appended.
int appendDistinctKeypoints(std::vector<cv::KeyPoint>& keypoints, cv::Mat& descriptors,
                            const std::vector<cv::KeyPoint>& extra, const cv::Mat& extra_descriptors,
                            const ScalePyramid& pyramid);

// Tops up (keypoints, descriptors) outside `exclude` (CV_8UC1, non-zero = excluded) until at
// least `wanted_with_depth` keypoints there have a depth in [min_depth_m, max_depth_m] in depth_m
// (CV_32FC1 metres, registered to the image; empty: every keypoint counts), as far as the texture
// allows. The extractor is asked for the shortfall divided by the depth-backed share of the
// keypoints already outside (at least a quarter), in up to 3 rounds. Returns how many keypoints
// were appended (0 when there were enough).
int topUpOutside(const OrbExtractor& extractor, const cv::Mat& gray, const cv::Mat& exclude, const cv::Mat& depth_m,
                 double min_depth_m, double max_depth_m, int wanted_with_depth, std::vector<cv::KeyPoint>& keypoints,
                 cv::Mat& descriptors);

}  // namespace desslam::feature
