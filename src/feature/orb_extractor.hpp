// ORB features (FAST corners + oriented rBRIEF descriptors) spread evenly over the image and
// over a scale pyramid, as the ORB-SLAM papers describe.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "core/options.hpp"
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

  const ScalePyramid& pyramid() const { return pyramid_; }
  const OrbOptions& options() const { return options_; }
  // Wanted keypoints per level (sum = num_features): a geometric series in the level's area.
  const std::vector<int>& featuresPerLevel() const { return features_per_level_; }

 private:
  OrbOptions options_;
  ScalePyramid pyramid_;
  std::vector<int> features_per_level_;
  std::vector<int> circle_half_width_;  // half width of the orientation disc per row offset |dy|
};

}  // namespace desslam::feature
