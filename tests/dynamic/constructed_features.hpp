// Hand-made feature sets for the dynamic-check tests: keypoints placed at chosen pixels with
// chosen descriptors, depth sampled from a depth image built from flat patches.
#pragma once

#include <memory>
#include <random>
#include <vector>

#include <opencv2/core.hpp>

#include "core/camera.hpp"
#include "feature/orb_extractor.hpp"
#include "map/features.hpp"

namespace desslam::dynamic::test {

inline CameraOptions testCameraOptions() {
  CameraOptions c;
  c.fx = c.fy = 525.0;
  c.cx = 319.5;
  c.cy = 239.5;
  c.width = 640;
  c.height = 480;
  return c;
}

// A descriptor per id: random but reproducible, so two different ids are ~128 bits apart.
inline cv::Mat descriptorFor(int id) {
  std::mt19937 rng(static_cast<unsigned>(1000 + id));
  cv::Mat d(1, 32, CV_8UC1);
  for (int b = 0; b < 32; ++b) d.at<uint8_t>(0, b) = static_cast<uint8_t>(rng() & 0xFF);
  return d;
}

struct PlacedFeature {
  cv::Point2f pixel;  // raw pixel (the test camera has no distortion)
  int descriptor_id;
};

inline std::shared_ptr<const map::FeatureSet> makeFeatures(const std::vector<PlacedFeature>& placed,
                                                           const PinholeCamera& camera, const cv::Mat& depth_m) {
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors(0, 32, CV_8UC1);
  for (const PlacedFeature& p : placed) {
    keypoints.emplace_back(p.pixel, 31.0f, 0.0f, 50.0f, 0);
    descriptors.push_back(descriptorFor(p.descriptor_id));
  }
  auto pyramid = std::make_shared<const feature::ScalePyramid>(feature::makeScalePyramid(8, 1.2));
  return map::buildFeatureSet(std::move(keypoints), descriptors, camera, depth_m, pyramid, 0.1, 10.0);
}

// depth image: `background` everywhere, then each (rect, depth) patch painted in order.
inline cv::Mat depthImage(float background, const std::vector<std::pair<cv::Rect, float>>& patches = {}) {
  cv::Mat d(480, 640, CV_32FC1, cv::Scalar(background));
  for (const auto& [rect, z] : patches) d(rect).setTo(z);
  return d;
}

// A square patch of half-size r around a pixel.
inline cv::Rect around(cv::Point2f p, int r) {
  return {static_cast<int>(std::lround(p.x)) - r, static_cast<int>(std::lround(p.y)) - r, 2 * r + 1, 2 * r + 1};
}

}  // namespace desslam::dynamic::test
