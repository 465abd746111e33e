// The map: sole owner of keyframes and map points, and of the one lock that guards them
// (see map_types.hpp for the lock discipline). The free functions below that modify the map
// require the caller to hold mutex() exclusively; those that read require it shared.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <shared_mutex>
#include <vector>

#include "map/map_types.hpp"

namespace desslam::map {

class Map {
 public:
  std::shared_mutex& mutex() const { return mutex_; }

  // -- exclusive lock --
  Keyframe* createKeyframe(uint64_t frame_id, Timestamp timestamp, std::string image_name,
                           std::shared_ptr<const FeatureSet> features, std::vector<FeatureStatus> status,
                           cv::Mat half_depth, const SE3& T_c_w);
  MapPoint* createPoint(const Vec3& position, Keyframe* reference);
  void setKeyframeBad(Keyframe* kf);   // culls: reassigns children, removes observations
  void setPointBad(MapPoint* point);   // removes the point from every keyframe observing it

  // -- shared lock --
  std::vector<Keyframe*> keyframes() const;  // good ones, by id
  std::vector<MapPoint*> points() const;     // good ones, by id
  std::vector<Keyframe*> allKeyframes() const;  // including culled, by id (for the trajectory)
  size_t keyframeCount() const { return good_keyframes_; }
  size_t pointCount() const { return good_points_; }
  Keyframe* firstKeyframe() const { return keyframes_.empty() ? nullptr : keyframes_.begin()->second.get(); }

 private:
  mutable std::shared_mutex mutex_;
  std::map<uint64_t, std::unique_ptr<Keyframe>> keyframes_;
  std::map<uint64_t, std::unique_ptr<MapPoint>> points_;
  uint64_t next_keyframe_id_ = 0;
  uint64_t next_point_id_ = 0;
  size_t good_keyframes_ = 0;
  size_t good_points_ = 0;
};

// ---- operations (exclusive lock) ----
void addObservation(MapPoint* point, Keyframe* kf, int feature);
void eraseObservation(Map& map, MapPoint* point, Keyframe* kf);  // point set bad when < 2 observations
// Moves every observation of `from` to `to` (loop/duplicate fusion); `from` becomes bad.
void replacePoint(Map& map, MapPoint* from, MapPoint* to);
// Recomputes the representative descriptor (smallest median distance to the others).
void updateDescriptor(MapPoint* point);
// Recomputes mean viewing direction and the scale-invariance distance range.
void updateNormalAndDepth(MapPoint* point);
// Recomputes kf's covisibility weights from shared points (edges with >= min_weight shared points,
// or the best one if none reaches it) and updates the neighbours' edges and the spanning tree.
void updateConnections(Keyframe* kf, int min_weight = 15);

// ---- queries (shared lock) ----
// Up to n best covisible keyframes (all when n <= 0).
std::vector<Keyframe*> bestCovisibles(const Keyframe* kf, int n);
std::vector<Keyframe*> covisiblesWithWeight(const Keyframe* kf, int min_weight);
int trackedPointCount(const Keyframe* kf, int min_observations);
// Level predicted for a point seen at `distance` (scale invariance of ORB).
int predictLevel(const MapPoint* point, double distance, const feature::ScalePyramid& pyramid);
// T_c_w of a keyframe; a culled one follows its parent (through T_c_parent).
SE3 keyframeTcw(const Keyframe* kf);

}  // namespace desslam::map
