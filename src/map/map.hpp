// The map: sole owner of keyframes and map points, and of the one lock that guards them
// (see map_types.hpp for the lock discipline). The free functions below that modify the map
// require the caller to hold mutex() exclusively; those that read require it shared.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <shared_mutex>
#include <string>
#include <vector>

#include "map/map_types.hpp"

namespace desslam::map {

// One map of the atlas. Maps start when tracking cannot go on in the current one; a merge moves
// every keyframe and point of one map into another's world and relabels them.
struct MapRecord {
  int id = 0;
  uint64_t first_frame_id = 0;   // the frame that started it
  Timestamp start_time = 0;
  std::string reason;            // why it started: "first", "lost", "young map lost", "implicit"
  int merged_into = -1;          // the map it was merged into (-1: none)
  SE3 T_into_this;               // T_w(into)_w(this) applied at the merge
  Timestamp merged_at = 0;       // timestamp of the keyframe whose recognition merged it
};

class Map {
 public:
  std::shared_mutex& mutex() const { return mutex_; }
  // Held shared by tracking for a whole frame, exclusively by a map merge's rigid move: a frame is
  // never tracked half in a map's old world and half in its new one. Lock order: world gate ->
  // mutex(); a merge takes it after pausing local mapping (loop/loop_closer.hpp).
  std::shared_mutex& worldGate() const { return world_gate_; }

  // -- exclusive lock --
  // map_id: the atlas map (a merged one is replaced by the map it went into); the first keyframe
  // of a map is its origin.
  Keyframe* createKeyframe(uint64_t frame_id, Timestamp timestamp, std::string image_name,
                           std::shared_ptr<const FeatureSet> features, std::vector<FeatureStatus> status,
                           cv::Mat half_depth, const SE3& T_c_w, int map_id = 0);
  MapPoint* createPoint(const Vec3& position, Keyframe* reference);  // in the reference's map
  // A new, empty map of the atlas; returns its id.
  int createMap(uint64_t first_frame_id, Timestamp start_time, std::string reason);
  // Moves every keyframe (culled ones too) and point of map `from` by T_into_from into map
  // `into`'s world and relabels them; `from`'s origin is no longer one. Both must be live maps.
  void mergeMap(int from, int into, const SE3& T_into_from, Timestamp merged_at);
  void setKeyframeBad(Keyframe* kf);   // culls: reassigns children, removes observations
  void setPointBad(MapPoint* point);   // removes the point from every keyframe observing it

  // -- shared lock --
  std::vector<Keyframe*> keyframes() const;  // good ones, by id
  std::vector<MapPoint*> points() const;     // good ones, by id
  std::vector<Keyframe*> allKeyframes() const;  // including culled, by id (for the trajectory)
  size_t keyframeCount() const { return good_keyframes_; }
  size_t pointCount() const { return good_points_; }
  Keyframe* firstKeyframe() const { return keyframes_.empty() ? nullptr : keyframes_.begin()->second.get(); }
  std::vector<MapRecord> mapRecords() const;     // by id
  int liveMap(int map_id) const;                 // the map `map_id` ended up in after merges
  size_t keyframeCount(int map_id) const;        // good keyframes of a live map
  size_t mergeCount() const;                     // maps merged into another so far

 private:
  mutable std::shared_mutex mutex_;
  mutable std::shared_mutex world_gate_;
  std::map<uint64_t, std::unique_ptr<Keyframe>> keyframes_;
  std::map<uint64_t, std::unique_ptr<MapPoint>> points_;
  uint64_t next_keyframe_id_ = 0;
  uint64_t next_point_id_ = 0;
  size_t good_keyframes_ = 0;
  size_t good_points_ = 0;
  std::map<int, MapRecord> maps_;
  std::map<int, size_t> good_keyframes_per_map_;
  std::map<int, size_t> keyframes_created_per_map_;
  int next_map_id_ = 0;
  MapRecord& recordOf(int map_id);  // registers an unknown id ("implicit")
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
// Per keyframe: whether it is its map's origin (the gauge of a bundle adjustment over whole maps);
// the first keyframe when none is.
std::vector<bool> originsFixed(const std::vector<Keyframe*>& keyframes);
// What a bundle adjustment over whole maps holds fixed: the origins, and the keyframes held where
// tracking put them (Keyframe::pose_held), which local BA never moves either. Freed in the final
// global BA, one held because local BA would carry it 21 cm (an fr1_xyz composite, 5-frame-old
// masks) ended 8.5 cm off (43 cm in a run changed elsewhere), the frames tracked from it with it;
// held there too, they end 1.0-1.7 cm off.
std::vector<bool> globalBaFixed(const std::vector<Keyframe*>& keyframes);
// T_c_w of a keyframe; a culled one follows its parent (through T_c_parent).
SE3 keyframeTcw(const Keyframe* kf);

}  // namespace desslam::map
