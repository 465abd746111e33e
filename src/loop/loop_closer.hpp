// Loop closing: detection (loop/loop_detector.hpp), correction, global bundle adjustment.
//
// Correction of a detected loop (current keyframe K, loop keyframe L, K's pose in L's world):
//  1. local mapping is paused (MappingPause) and a running global BA is aborted;
//  2. write section: K and its covisible neighbours move by the loop's world correction, with
//     their map points; K's matched points are fused with L's (replacePoint), L's group's points
//     are fused into K's neighbourhood by projection; new covisibility links become loop edges;
//  3. unlocked: pose-graph optimisation (optim/pose_graph.hpp) over the essential graph
//     (spanning tree, covisibility >= loop.strong_covisibility_weight, loop edges), L fixed;
//  4. write section: optimised poses; every map point moves with its reference keyframe's
//     correction; keyframes tracking created meanwhile move with K's correction;
//  5. local mapping resumes; a global BA starts in its own thread (abortable by a newer loop), its
//     result applied in a final write section with local mapping paused again.
// Tracking is blocked only by the write sections (the Map lock held exclusively); the pose graph
// and the global BA are solved on copies.
//
// Lock order: correction mutex (LoopCloser internal) -> MappingPause -> Map::mutex() ->
// KeyframeDatabase's mutex. The local-mapping thread takes MappingPause then the Map lock, so
// the order is the same everywhere.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "core/bounded_queue.hpp"
#include "core/camera.hpp"
#include "core/options.hpp"
#include "loop/keyframe_database.hpp"
#include "loop/loop_detector.hpp"
#include "map/map.hpp"

namespace desslam::loop {

// Lets the loop closer stop local mapping between keyframes. The local-mapping thread brackets
// each keyframe with enter()/leave(); pause() returns once no keyframe is being processed and
// keeps enter() waiting until resume(). Pauses nest (a counter). Thread-safe (own mutex).
class MappingPause {
 public:
  // -- local-mapping side --
  void enter();  // blocks while paused
  void leave();
  // Set to true by pause() (e.g. LocalMappingThread's abort_ba_, so a running local BA yields).
  void setAbortFlag(std::atomic<bool>* flag);

  // -- loop-closing side --
  void pause();   // blocks until local mapping is between keyframes
  void resume();
  bool paused() const;

 private:
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  int pausers_ = 0;
  bool working_ = false;
  std::atomic<bool>* abort_flag_ = nullptr;
};

// One corrected loop, for the report (check it against ground truth by the timestamps).
struct ClosedLoop {
  uint64_t current_keyframe = 0, loop_keyframe = 0;
  double current_timestamp = 0, loop_timestamp = 0;
  int inliers = 0;
  double correction_m = 0, correction_deg = 0;  // the drift the loop implied at the current keyframe
};

struct LoopClosingStats {
  size_t loops_detected = 0;   // verified by geometry
  size_t loops_closed = 0;     // corrections applied
  size_t loops_skipped = 0;    // detected, but a keyframe was culled before the correction
  size_t points_fused = 0;
  size_t global_ba_runs = 0;
  size_t global_ba_applied = 0;
  size_t global_ba_aborted = 0;
  std::vector<double> correction_ms, pose_graph_ms, global_ba_ms;
  std::vector<ClosedLoop> closed;
  LoopDetectionStats detection;
};

// What changed, for listeners (dense map, tracker): called after each final write section from
// the loop-closing or the global-BA thread, with the Map lock released (a listener may take it)
// but local mapping still paused, so keep it short (e.g. queue the poses for the dense thread).
struct LoopEvent {
  enum class Kind { kLoopCorrected, kGlobalBaApplied } kind = Kind::kLoopCorrected;
  uint64_t current_keyframe = 0;  // K (for a global BA: the newest keyframe it covered)
  uint64_t loop_keyframe = 0;     // L (loops only)
  // World correction at K: T_w_new_w_old. A pose tracked in the old world (the tracker's last
  // frame) becomes T_c_w_new = T_c_w_old * T_wnew_wold.inverse().
  SE3 T_wnew_wold;
};

enum class GlobalBaMode { kThread, kInline, kOff };

class LoopCloser {
 public:
  // pause may be null (no local-mapping thread, e.g. deterministic mode where mapping runs
  // inline on the caller's thread). options.loop and options.tracking.depth_baseline are used.
  LoopCloser(const SystemOptions& options, const PinholeCamera& camera, map::Map& map, KeyframeDatabase& database,
             MappingPause* pause, GlobalBaMode global_ba = GlobalBaMode::kThread);
  ~LoopCloser();  // aborts and joins a running global BA

  // Detects and, if found, closes a loop ending at kf. Returns whether a loop was closed.
  // One caller thread at a time (the loop-closing thread).
  bool process(map::Keyframe* kf);
  // Applies a detected loop (exposed for tests that build the match themselves).
  bool correctLoop(const LoopMatch& match);

  // Blocks until no global BA is running.
  void waitForGlobalBa();
  void setListener(std::function<void(const LoopEvent&)> listener);
  LoopClosingStats stats() const;  // a copy, safe from any thread

 private:
  // Steps 1-4 under the correction mutex and a mapping pause; newest_in_graph: the newest
  // keyframe the pose graph covered. False when K or L was culled meanwhile.
  bool applyLoopCorrection(const LoopMatch& match, uint64_t& newest_in_graph);
  void startGlobalBa(uint64_t newest_keyframe);
  void runGlobalBa(uint64_t newest_keyframe);
  void abortGlobalBa();
  void notify(const LoopEvent& event);

  SystemOptions options_;
  PinholeCamera camera_;
  map::Map& map_;
  MappingPause* pause_;
  GlobalBaMode global_ba_mode_;
  double bf_;
  LoopDetector detector_;

  std::mutex correction_mutex_;  // serialises loop corrections and global-BA write-back
  // Loop edges of the essential graph (keyframe pairs), guarded by the Map lock.
  std::vector<std::pair<map::Keyframe*, map::Keyframe*>> loop_edges_;

  std::thread global_ba_thread_;      // touched only by the process() caller and the destructor
  std::atomic<bool> global_ba_abort_{false};
  std::atomic<bool> global_ba_running_{false};
  std::mutex ba_wait_mutex_;
  std::condition_variable ba_done_cv_;

  mutable std::mutex stats_mutex_;    // guards stats_ and listener_
  LoopClosingStats stats_;
  std::function<void(const LoopEvent&)> listener_;
};

// The loop-closing thread: consumes keyframes that local mapping has finished, in order.
// Queue: loop.queue_capacity, dropping the oldest when full (a skipped keyframe is only a missed
// detection chance; local mapping must never wait for loop closing, which may be waiting for it).
class LoopClosingThread {
 public:
  explicit LoopClosingThread(LoopCloser& closer, size_t capacity = 64);
  ~LoopClosingThread();
  void push(map::Keyframe* kf);
  // Blocks until every pushed keyframe is processed and no global BA runs.
  void waitUntilIdle();
  void stop();  // drains the queue, waits for the global BA, joins. Idempotent.
  size_t dropped() const { return queue_.dropped(); }

 private:
  void run();
  LoopCloser& closer_;
  BoundedQueue<map::Keyframe*> queue_;
  std::atomic<int> pending_{0};
  std::mutex idle_mutex_;  // guards nothing but the idle_cv_ wait
  std::condition_variable idle_cv_;
  std::thread worker_;
};

}  // namespace desslam::loop
