// Test helper: a map of the synthetic room built by Tracker + LocalMapper (inline, deterministic)
// along the first part of sim::sweepPath, with the keyframe database kept up to date the way the
// system is meant to (add on keyframe insertion, erase after culling); and frames rendered at any
// path index or pose, to present to the relocaliser.
#pragma once

#include <memory>
#include <mutex>
#include <shared_mutex>
#include <string>

#include <opencv2/imgproc.hpp>

#include "core/camera.hpp"
#include "feature/orb_extractor.hpp"
#include "map/frame.hpp"
#include "map/map.hpp"
#include "mapping/local_mapper.hpp"
#include "place/keyframe_database.hpp"
#include "place/vocabulary_location.hpp"
#include "sim/camera_path.hpp"
#include "sim/synthetic_scene.hpp"
#include "system/system_options.hpp"
#include "tracking/relocaliser.hpp"
#include "tracking/synthetic_frame.hpp"
#include "tracking/tracker.hpp"

namespace desslam::tracking::test {

class RelocalisationScene {
 public:
  struct Settings {
    int mapped_frames = 120;  // frames tracked to build the map (4 s at 30 Hz, ~1.2 m of travel)
  };

  explicit RelocalisationScene(const Settings& settings)
      : options_(makeOptions()),
        camera_(options_.camera),
        scene_(sim::SceneOptions{}, options_.camera),
        path_(sim::sweepPath(settings.mapped_frames, options_.camera.fps)),
        extractor_(options_.orb),
        pyramid_(std::make_shared<feature::ScalePyramid>(extractor_.pyramid())),
        vocabulary_(place::loadVocabulary(options_.relocalisation.vocabulary)),
        database_(vocabulary_, options_.relocalisation.direct_index_level),
        tracker_(trackerOptions(options_), camera_, map_),
        mapper_(localMapperOptions(options_), camera_, map_) {
    for (size_t i = 0; i < path_.size(); ++i) {
      map::Frame frame = render(path_[i].T_w_c, path_[i].timestamp, i);
      const TrackOutcome outcome = tracker_.track(frame, /*mapping_idle=*/true);
      all_tracked_ = all_tracked_ && outcome.tracked;
      if (outcome.tracked) last_tracked_T_c_w_ = frame.T_c_w;
      if (outcome.new_keyframe != nullptr) {
        mapper_.process(outcome.new_keyframe, nullptr);
        database_.add(outcome.new_keyframe);  // where LocalMapper::insertKeyframe would add it
        eraseCulledKeyframes();               // where LocalMapper culls keyframes
      }
    }
  }

  // A frame of the scene seen from T_w_c (world = the room's frame, not the map's) at time t.
  map::Frame render(const SE3& T_w_c, Timestamp t, uint64_t id) const {
    return desslam::test::renderSyntheticFrame(scene_, extractor_, pyramid_, camera_, options_.tracking, T_w_c, t, id);
  }
  map::Frame frameAt(int path_index) const {
    const auto& pose = path_.at(static_cast<size_t>(path_index));
    return render(pose.T_w_c, pose.timestamp, kPresentedIdBase + static_cast<uint64_t>(path_index));
  }
  // Standing where path frame `path_index` stood, looking at the back wall (-y).
  map::Frame frameLookingBack(int path_index) const {
    const auto& pose = path_.at(static_cast<size_t>(path_index));
    const SE3 T_w_c(sim::lookRotation(M_PI, -0.2, 0.0), pose.T_w_c.translation());
    return render(T_w_c, pose.timestamp, kPresentedIdBase + 50000 + static_cast<uint64_t>(path_index));
  }

  // Ground truth in the map's frame (the first camera's frame).
  SE3 groundTruthTcw(int path_index) const {
    return (path_.front().T_w_c.inverse() * path_.at(static_cast<size_t>(path_index)).T_w_c).inverse();
  }
  double distanceFromLastTracked(int path_index) const {
    return (path_.back().T_w_c.translation() - path_.at(static_cast<size_t>(path_index)).T_w_c.translation()).norm();
  }

  Relocaliser relocaliser() const {
    return Relocaliser(options_.relocalisation, camera_, map_, database_, bf());
  }
  double bf() const { return camera_.bf(); }
  bool allTracked() const { return all_tracked_; }
  SE3 lastTrackedPose() const { return last_tracked_T_c_w_; }
  const place::KeyframeDatabase& database() const { return database_; }
  std::shared_ptr<const place::Vocabulary> vocabulary() const { return vocabulary_; }
  map::Map& map() const { return map_; }
  const PinholeCamera& camera() const { return camera_; }
  const SystemOptions& options() const { return options_; }

 private:
  static constexpr uint64_t kPresentedIdBase = 1000000;

  static SystemOptions makeOptions() {
    SystemOptions o;
    o.camera = sim::syntheticCamera();
    o.semantic.segmenter = SegmenterKind::kNone;
    o.dynamic.mode = DynamicMode::kOff;  // a static room: nothing to check
    o.dense.enabled = false;
    return o;
  }
  void eraseCulledKeyframes() {
    std::shared_lock lock(map_.mutex());
    for (map::Keyframe* kf : map_.allKeyframes())
      if (kf->bad && database_.contains(kf->id)) database_.erase(kf->id);
  }

  SystemOptions options_;
  PinholeCamera camera_;
  sim::SyntheticScene scene_;
  Trajectory path_;
  feature::OrbExtractor extractor_;
  std::shared_ptr<const feature::ScalePyramid> pyramid_;
  std::shared_ptr<const place::Vocabulary> vocabulary_;
  place::KeyframeDatabase database_;
  mutable map::Map map_;
  Tracker tracker_;
  mapping::LocalMapper mapper_;
  bool all_tracked_ = true;
  SE3 last_tracked_T_c_w_;
};

}  // namespace desslam::tracking::test
