// A frame of the synthetic room as SlamSystem builds one: ORB features with their depths, the
// depth image attached. Shared by the tracking tests that drive a Tracker directly.
#pragma once

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "core/camera.hpp"
#include "core/options.hpp"
#include "feature/orb_extractor.hpp"
#include "map/features.hpp"
#include "map/frame.hpp"
#include "sim/synthetic_scene.hpp"

namespace desslam::test {

// The scene seen from T_w_c (world = the room's frame) at time t, as frame `id`.
inline map::Frame renderSyntheticFrame(const sim::SyntheticScene& scene, const feature::OrbExtractor& extractor,
                                       const std::shared_ptr<const feature::ScalePyramid>& pyramid,
                                       const PinholeCamera& camera, const TrackingOptions& tracking,
                                       const SE3& T_w_c, Timestamp t, uint64_t id) {
  const sim::RenderedFrame rendered = scene.render(T_w_c, t);
  cv::Mat gray;
  cv::cvtColor(rendered.bgr, gray, cv::COLOR_BGR2GRAY);
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  extractor.extract(gray, keypoints, descriptors);
  auto features = map::buildFeatureSet(std::move(keypoints), std::move(descriptors), camera, rendered.depth, pyramid,
                                       tracking.min_depth, tracking.max_depth);
  map::Frame frame(id, t, "synthetic_" + std::to_string(id), std::move(features));
  frame.depth = rendered.depth;
  return frame;
}

}  // namespace desslam::test
