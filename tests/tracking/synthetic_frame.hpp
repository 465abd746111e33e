// A frame of the synthetic room as SlamSystem builds one: ORB features with their depths, the
// depth image attached. Shared by the tracking tests that drive a Tracker directly.
#pragma once

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "core/camera.hpp"
#include "feature/orb_extractor.hpp"
#include "map/features.hpp"
#include "map/frame.hpp"
#include "sim/synthetic_scene.hpp"
#include "tracking/tracking_options.hpp"

namespace desslam::test {

// Frame `id` at time t from a grey image and its depth (CV_32F metres).
inline map::Frame frameFromImages(const cv::Mat& gray, const cv::Mat& depth, const feature::OrbExtractor& extractor,
                                  const std::shared_ptr<const feature::ScalePyramid>& pyramid,
                                  const PinholeCamera& camera, const TrackingOptions& tracking, Timestamp t,
                                  uint64_t id, const std::string& name) {
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  extractor.extract(gray, keypoints, descriptors);
  auto features = map::buildFeatureSet(std::move(keypoints), std::move(descriptors), camera, depth, pyramid,
                                       tracking.min_depth, tracking.max_depth);
  map::Frame frame(id, t, name, std::move(features));
  frame.depth = depth;
  return frame;
}

// The scene seen from T_w_c (world = the room's frame) at time t, as frame `id`.
inline map::Frame renderSyntheticFrame(const sim::SyntheticScene& scene, const feature::OrbExtractor& extractor,
                                       const std::shared_ptr<const feature::ScalePyramid>& pyramid,
                                       const PinholeCamera& camera, const TrackingOptions& tracking,
                                       const SE3& T_w_c, Timestamp t, uint64_t id) {
  const sim::RenderedFrame rendered = scene.render(T_w_c, t);
  cv::Mat gray;
  cv::cvtColor(rendered.bgr, gray, cv::COLOR_BGR2GRAY);
  return frameFromImages(gray, rendered.depth, extractor, pyramid, camera, tracking, t, id,
                         "synthetic_" + std::to_string(id));
}

// A covered camera at time t: black image, no depth (no features).
inline map::Frame coveredFrame(const feature::OrbExtractor& extractor,
                               const std::shared_ptr<const feature::ScalePyramid>& pyramid,
                               const PinholeCamera& camera, const TrackingOptions& tracking, Timestamp t, uint64_t id) {
  const cv::Mat gray(camera.height(), camera.width(), CV_8UC1, cv::Scalar(0));
  const cv::Mat depth(gray.size(), CV_32FC1, cv::Scalar(0.0f));
  return frameFromImages(gray, depth, extractor, pyramid, camera, tracking, t, id, "covered_" + std::to_string(id));
}

}  // namespace desslam::test
