// Local mapping: turns each new keyframe into map structure. Per keyframe: covisibility update,
// culling of recent points that tracking does not confirm, new points by triangulation with
// neighbouring keyframes, fusion of duplicated points, local bundle adjustment (Ceres) and
// culling of redundant keyframes.
//
// Locking: reads happen under the Map lock held shared; every change under it held
// exclusively, in short sections; bundle adjustment copies its problem out and solves unlocked.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "core/bounded_queue.hpp"
#include "core/camera.hpp"
#include "core/queue_worker.hpp"
#include "map/map.hpp"
#include "mapping/mapping_options.hpp"
#include "mapping/mapping_pause.hpp"
#include "matching/matcher.hpp"
#include "place/keyframe_database.hpp"

namespace desslam::optim {
struct MapBaProblem;
}

namespace desslam::mapping {

struct LocalMappingStats {
  size_t keyframes_processed = 0;
  size_t points_triangulated = 0;
  size_t points_culled = 0;
  size_t keyframes_culled = 0;
  size_t ba_runs = 0;
  size_t ba_aborted = 0;
  size_t weak_keyframes_held = 0;  // keyframes made at weak poses held where local BA would move them far
  size_t keyframes_held_moved_far = 0;  // other keyframes local BA would move far (kMaxKeyframeMoveM)
  // Milliseconds per processed keyframe, per step.
  std::vector<double> insert_ms, cull_points_ms, triangulate_ms, fuse_ms, ba_ms, cull_keyframes_ms, total_ms;
};

class LocalMapper {
 public:
  // database (may be null): the keyframe BoW database kept in step with the map (keyframes added
  // after insertion, removed when culled) for relocalisation and loop detection.
  LocalMapper(const LocalMapperOptions& options, const PinholeCamera& camera, map::Map& map,
              place::KeyframeDatabase* database = nullptr);

  // abort_ba (may be null) stops bundle adjustment early when set (a newer keyframe is waiting).
  void process(map::Keyframe* kf, const std::atomic<bool>* abort_ba);
  const LocalMappingStats& stats() const { return stats_; }

 private:
  void insertKeyframe(map::Keyframe* kf);
  void cullRecentPoints(map::Keyframe* kf);
  void triangulateNewPoints(map::Keyframe* kf);
  void fuseWithNeighbours(map::Keyframe* kf);
  void localBundleAdjustment(map::Keyframe* kf, const std::atomic<bool>* abort_ba);
  // The local window of `kf` (it and its covisibles free, keyframes outside seeing their points
  // fixed); none with fewer than two keyframes. Takes the map lock shared.
  std::optional<optim::MapBaProblem> localBaProblem(map::Keyframe* kf) const;
  // Holds (Keyframe::pose_held) the free keyframes made at weak poses that the solved `problem`
  // moves more than kMaxWeakKeyframeMoveM, and the others it moves more than kMaxKeyframeMoveM
  // (optim::keyframesMovedFar); how many of each. Map lock held exclusively.
  struct HeldKeyframes {
    size_t weak = 0, other = 0;
  };
  HeldKeyframes holdKeyframesMovedFar(const optim::MapBaProblem& problem);
  void cullRedundantKeyframes(map::Keyframe* kf);

  LocalMapperOptions options_;
  PinholeCamera camera_;
  map::Map& map_;
  place::KeyframeDatabase* database_;
  double bf_;
  MatcherOptions matcher_options_;
  std::vector<map::MapPoint*> recent_points_;  // created recently, still on probation
  LocalMappingStats stats_;
};

// The local mapping thread: consumes keyframes from tracking in order (a QueueWorker).
// Queue: capacity 8, blocking (tracking waits only if mapping falls 8 keyframes behind).
// idle() is true when no keyframe is queued or being processed (a keyframe criterion).
// pause (may be null): loop closing stops mapping between keyframes through it (each keyframe is
// processed between pause->enter() and pause->leave()). on_processed (may be empty) receives each
// keyframe after that, outside the pause (e.g. the loop-closing queue).
// An exception from mapping (or on_processed) stops the thread's work: failure() holds it and the
// pipeline rethrows it to its caller (core/queue_worker.hpp).
class LocalMappingThread {
 public:
  // before_processing / on_processed run on the mapping thread before and after each keyframe
  // (before: outside the mapping pause, so it may wait without holding loop closing up).
  explicit LocalMappingThread(LocalMapper& mapper, MappingPause* pause = nullptr,
                              std::function<void(map::Keyframe*)> on_processed = {},
                              std::function<void(map::Keyframe*)> before_processing = {});
  ~LocalMappingThread();
  void push(map::Keyframe* kf);
  bool idle() const { return worker_.pending() <= 0; }
  int backlog() const { return worker_.pending(); }  // keyframes queued or being processed
  // Blocks until every pushed keyframe has been processed (or the thread failed).
  void waitUntilIdle() { worker_.waitUntilIdle(); }
  void stop();  // drains the queue and joins
  std::exception_ptr failure() const { return worker_.failure(); }

 private:
  void process(map::Keyframe* kf);
  LocalMapper& mapper_;
  MappingPause* pause_;
  std::function<void(map::Keyframe*)> on_processed_;
  std::function<void(map::Keyframe*)> before_processing_;
  std::atomic<bool> abort_ba_{false};
  QueueWorker<map::Keyframe*> worker_;  // last: its thread starts once the members above exist
};

}  // namespace desslam::mapping
