// One tracked RGB-D frame: its features, its pose estimate and what its features matched.
// Owned by the tracking thread alone (no lock); the map points it points at are guarded by the
// Map lock.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/se3.hpp"
#include "map/features.hpp"
#include "map/map_types.hpp"

namespace desslam::map {


// Frame::map_verifiable values (0 = neither).
inline constexpr uint8_t kMapVerifiable = 1;
inline constexpr uint8_t kMapVerified = 2;

struct FeatureMatch {
  MapPoint* point = nullptr;  // a map point, or
  bool has_vo_point = false;  // a temporary point from the previous frame's depth (visual odometry)
  Vec3 vo_point = Vec3::Zero();
  bool outlier = false;
  bool matched() const { return point != nullptr || has_vo_point; }
};

struct Frame {
  uint64_t id = 0;
  Timestamp timestamp = 0;
  double depth_time_offset = 0;       // seconds the depth image was taken after the RGB image
  std::string image_name;
  std::shared_ptr<const FeatureSet> features;
  cv::Mat depth;                      // CV_32F metres (shared with the caller, not copied)
  cv::Mat dynamic_mask;               // CV_8U dilated semantic mask (255 = possibly moving); may be empty
  // The same without the growth of a late (carried) mask: dilated by dynamic.mask_dilation_px only.
  // Equal to dynamic_mask for a fresh mask; empty when unknown (then no feature counts as grown over).
  cv::Mat ungrown_mask;
  // A keyframe made from this frame maps nothing within this many pixels of dynamic_mask (a late
  // mask: the people may have moved out of it). Tracking still uses the features there. 0 = none.
  int mapping_margin_px = 0;
  std::vector<FeatureStatus> status;  // per feature
  // Per feature (empty = none): masked features outside ungrown_mask (in the ring a late mask's
  // growth adds) that stage 1 dropped only because their reference frame had no match for them
  // (or no depth there), having depth themselves. The local-map search may still take one where a
  // map point lies at its depth (Tracker::trackLocalMap): then it is static again, matched to that
  // point, and marked kMapVerified.
  std::vector<uint8_t> map_verifiable;
  std::vector<FeatureMatch> matches;  // per feature
  SE3 T_c_w;
  bool has_pose = false;

  Frame() = default;
  Frame(uint64_t id, Timestamp timestamp, std::string image_name, std::shared_ptr<const FeatureSet> features)
      : id(id), timestamp(timestamp), image_name(std::move(image_name)), features(std::move(features)) {
    status.assign(this->features->size(), FeatureStatus::kStatic);
    matches.assign(this->features->size(), {});
  }
  bool usable(size_t i) const { return status[i] == FeatureStatus::kStatic; }
  void clearMatches() { matches.assign(features->size(), {}); }
};

}  // namespace desslam::map
