// Keyframes and map points: plain data owned by the Map (map/map.hpp).
//
// Lock discipline (one lock for all shared map state): every field marked "guarded" may only be
// read under Map::mutex() held shared, and written under it held exclusively. Fields marked
// "immutable" are set at construction and may be read without the lock. Objects are never freed
// while the Map lives (erased ones are flagged bad), so raw pointers between them stay valid.
#pragma once

#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/se3.hpp"
#include "map/features.hpp"

namespace desslam::map {

class Keyframe;

class MapPoint {
 public:
  MapPoint(uint64_t id, const Vec3& position, Keyframe* reference, uint64_t created_at_keyframe)
      : id(id), created_at_keyframe(created_at_keyframe), position(position), reference(reference) {}

  const uint64_t id;                   // immutable
  const uint64_t created_at_keyframe;  // immutable: id of the keyframe that created it

  // guarded
  Vec3 position;
  Vec3 normal = Vec3::Zero();     // mean viewing direction (unit)
  cv::Mat descriptor;             // 1 x 32, the observation descriptor closest to all others
  double min_distance = 0;        // scale-invariance range of distances it can be matched at
  double max_distance = 0;
  Keyframe* reference = nullptr;  // keyframe whose observation sets the distance range
  std::map<uint64_t, std::pair<Keyframe*, int>> observations;  // keyframe id -> (keyframe, feature)
  bool bad = false;
  MapPoint* replaced_by = nullptr;  // set when fused into another point
  int map_id = 0;                   // atlas map it belongs to (its reference keyframe's; merges relabel)

  // Tracking statistics (atomic: tracking updates them under the shared lock).
  std::atomic<int> visible{1};  // frames in whose frustum it was
  std::atomic<int> found{1};    // frames in which it was matched

  double foundRatio() const { return static_cast<double>(found.load()) / std::max(1, visible.load()); }
};

class Keyframe {
 public:
  Keyframe(uint64_t id, uint64_t frame_id, Timestamp timestamp, std::string image_name,
           std::shared_ptr<const FeatureSet> features, std::vector<FeatureStatus> status, cv::Mat half_depth,
           const SE3& T_c_w)
      : id(id),
        frame_id(frame_id),
        timestamp(timestamp),
        image_name(std::move(image_name)),
        features(std::move(features)),
        status(std::move(status)),
        half_depth(std::move(half_depth)),
        T_c_w(T_c_w),
        points(this->features->size(), nullptr) {}

  const uint64_t id;                                // immutable
  const uint64_t frame_id;                          // immutable
  const Timestamp timestamp;                        // immutable
  const std::string image_name;                     // immutable (RGB file name)
  const std::shared_ptr<const FeatureSet> features; // immutable
  // Dynamic features are never mapped. Set at creation; the one later change (a feature found in
  // the keyframe's own, late mask becomes kDynamicMask) is made by local mapping's thread under
  // the unique Map lock before local mapping processes the keyframe. Other threads read it only
  // after that (they reach a keyframe through local mapping), so reading needs no lock.
  std::vector<FeatureStatus> status;
  const cv::Mat half_depth;                         // immutable: CV_32F metres at half resolution (stage 2)

  // guarded
  SE3 T_c_w;
  std::vector<MapPoint*> points;                  // per feature, nullptr if none
  std::map<uint64_t, std::pair<Keyframe*, int>> connection_weights;  // covisible id -> (kf, shared points)
  std::vector<Keyframe*> ordered_connections;     // by weight desc, then id asc (deterministic)
  Keyframe* parent = nullptr;                     // spanning tree
  std::map<uint64_t, Keyframe*> children;
  bool bad = false;
  SE3 T_c_parent;                                 // set when culled: its pose follows the parent's
  bool not_erase = false;                         // protected from culling (e.g. while loop closing uses it)
  int map_id = 0;                                 // atlas map it belongs to (merges relabel it)
  int made_in_map = 0;                            // atlas map it was made in (merges keep it)
  bool map_origin = false;                        // first keyframe of its map: holds the gauge, never culled
  // Made at a frame-to-frame odometry pose while sharing too few points with its map for bundle
  // adjustment to place it: its pose is held like the origin's (local BA keeps it fixed, culling
  // keeps it), and the keyframes built on its points follow it.
  bool pose_held = false;
  // Made at a weak pose (few local-map inliers near the motion prediction): local BA may not move
  // it far from where tracking put it (LocalMapper holds it there instead).
  bool made_at_weak_pose = false;

  bool usable(size_t i) const { return status[i] == FeatureStatus::kStatic; }
  SE3 T_w_c() const { return T_c_w.inverse(); }
  Vec3 center() const { return T_c_w.inverse().translation(); }
};

}  // namespace desslam::map
