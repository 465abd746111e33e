// Loop closing and map merging: detection (loop/loop_detector.hpp), correction, global bundle
// adjustment.
//
// Correction of a detected loop (current keyframe K, loop keyframe L, K's pose in L's world),
// named steps that a merge of two atlas maps shares (LoopCloser::applyLoopCorrection):
//  0. merges only (L in another map): mergeMaps moves the younger map, every keyframe and point,
//     into the older one's world by the rigid transform recognition found, and relabels it
//     (tracking waits on Map::worldGate() meanwhile); then the maps are one and the steps below
//     run as for a loop;
//  1. local mapping is paused (MappingPause) and a running global BA is aborted;
//  2. write section: correctNeighbourhood (K and its covisible neighbours move by the loop's
//     world correction, with their points), replaceDuplicatedPoints (K's matched points become
//     L's, L's group's points are fused into K's neighbourhood by projection),
//     updateLoopConnections (new covisibility links become loop edges), buildEssentialGraph;
//  3. unlocked: pose-graph optimisation (optim/pose_graph.hpp) over the essential graph of L's
//     map (spanning tree, covisibility >= loop.strong_covisibility_weight, loop edges), L fixed;
//  4. write section (applyPoseGraph): optimised poses; every map point moves with its reference
//     keyframe's correction; keyframes tracking created meanwhile move with K's correction;
//  5. local mapping resumes; a global BA starts in its own thread (abortable by a newer loop), its
//     result applied in a final write section with local mapping paused again. Every map's
//     origin keyframe holds that map's gauge.
// Tracking is blocked only by the write sections (the Map lock held exclusively) and, for a
// merge, by the rigid move; the pose graph and the global BA are solved on copies.
//
// Lock order: correction mutex (LoopCloser internal) -> MappingPause -> Map::worldGate() ->
// Map::mutex() -> KeyframeDatabase's mutex. The local-mapping thread takes MappingPause then the
// Map lock; tracking takes the world gate (shared, for a whole frame) then the Map lock.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <thread>
#include <vector>

#include "core/bounded_queue.hpp"
#include "core/camera.hpp"
#include "core/queue_worker.hpp"
#include "loop/loop_detector.hpp"
#include "loop/loop_options.hpp"
#include "map/map.hpp"
#include "mapping/mapping_pause.hpp"
#include "optim/pose_graph.hpp"
#include "place/keyframe_database.hpp"

namespace desslam::loop {

// One corrected loop, for the report (check it against ground truth by the timestamps).
struct ClosedLoop {
  uint64_t current_keyframe = 0, loop_keyframe = 0;
  double current_timestamp = 0, loop_timestamp = 0;
  int inliers = 0;
  double correction_m = 0, correction_deg = 0;  // the drift the loop implied at the current keyframe
  bool merge = false;                           // closed across two maps of the atlas (after merging them)
};

// Two maps of the atlas made one: every keyframe and point of from_map moved by T_into_from.
struct MergedMaps {
  int from_map = 0, into_map = 0;
  SE3 T_into_from;
  uint64_t current_keyframe = 0, loop_keyframe = 0;
  double timestamp = 0;  // the current keyframe's
  int inliers = 0;
  bool found_by_tracking = false;  // suggested by tracking (suggestMerge), not found by place recognition
};

struct LoopClosingStats {
  size_t loops_detected = 0;   // verified by geometry
  size_t loops_closed = 0;     // corrections applied
  size_t loops_skipped = 0;    // detected, but a keyframe was culled before the correction
  size_t points_fused = 0;
  size_t global_ba_runs = 0;
  size_t global_ba_applied = 0;
  size_t global_ba_aborted = 0;
  size_t weak_keyframes_held = 0;  // by global BA (optim::solveGlobalBa)
  size_t loose_groups_held = 0;    // likewise, keyframe groups tied by few points (optim::looseGroupsMovedFar)
  std::vector<double> correction_ms, pose_graph_ms, global_ba_ms;
  std::vector<ClosedLoop> closed;
  std::vector<MergedMaps> merges;
  size_t merges_at_end = 0;    // of those, by mergeRemainingMaps()
  LoopDetectionStats detection;
};

// What changed, for listeners (dense map, tracker): called after each final write section from
// the loop-closing or the global-BA thread, with the Map lock released (a listener may take it)
// but local mapping still paused, so keep it short (e.g. queue the poses for the dense thread).
struct LoopEvent {
  enum class Kind { kLoopCorrected, kMapsMerged, kGlobalBaApplied } kind = Kind::kLoopCorrected;
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
  // inline on the caller's thread).
  LoopCloser(const LoopCloserOptions& options, const PinholeCamera& camera, map::Map& map, place::KeyframeDatabase& database,
             mapping::MappingPause* pause, GlobalBaMode global_ba = GlobalBaMode::kThread);
  ~LoopCloser();  // aborts and joins a running global BA

  // Detects and, if found, closes a loop ending at kf. Returns whether a loop was closed.
  // One caller thread at a time (the loop-closing thread).
  bool process(map::Keyframe* kf);
  // Applies a detected loop (exposed for tests that build the match themselves).
  bool correctLoop(const LoopMatch& match);
  // The end of a run (atlas.final_merge_search), keyframes no longer arriving: the maps still
  // apart are searched for each other (LoopDetector::searchMergeAcrossMaps) and merged one after
  // another, each with the steps of a merge found online and its global BA. Returns the merges.
  // Only with the loop-closing thread stopped (or never started).
  int mergeRemainingMaps(const std::atomic<bool>* abort = nullptr);
  // A merge that tracking found (the camera, tracked in match.current's map, was tracked in
  // match.loop's map too: tracking::FoundInOtherMap): process(match.current) applies it when place
  // recognition finds nothing there itself. Any thread; before match.current reaches process().
  void suggestMerge(const LoopMatch& match);

  // Blocks until no global BA is running, or until *abort becomes true (then returns false and the
  // BA may still run: abortGlobalBa() stops it).
  bool waitForGlobalBa(const std::atomic<bool>* abort = nullptr);
  // Stops a running global BA (its result is not applied) and joins its thread; the
  // process() caller's thread only (or once that thread has stopped).
  void abortGlobalBa();
  // The exception the global-BA thread threw (null while none did); any thread. A failed global
  // BA applies nothing and ends as an aborted one would.
  std::exception_ptr failure() const;
  void setListener(std::function<void(const LoopEvent&)> listener);
  LoopClosingStats stats() const;  // a copy, safe from any thread

 private:
  // Loop correction and map merging, under the correction mutex and a mapping pause:
  // (0, merges only) mergeMaps, then correctNeighbourhood, replaceDuplicatedPoints,
  // updateLoopConnections, buildEssentialGraph (Map lock exclusive), the pose graph (no lock),
  // applyPoseGraph (exclusive); the caller then starts the global BA. newest_in_graph: the newest
  // keyframe the pose graph covered. False when K or L was culled meanwhile.
  bool applyLoopCorrection(const LoopMatch& match, uint64_t& newest_in_graph);

  struct EssentialGraph {
    std::vector<optim::PoseGraphNode> nodes;
    std::vector<optim::PoseGraphEdge> edges;
    std::vector<map::Keyframe*> keyframes;   // per node
    std::map<uint64_t, SE3> snapshot_T_c_w;  // poses the pose graph starts from
    uint64_t newest = 0;
  };
  // Moves the younger of the two maps into the older one's world (World gate and Map lock
  // exclusive, taken here); sets match.T_w_c_corrected to K's pose in the merged world.
  bool mergeMaps(LoopMatch& match);
  // The steps below need the Map lock held exclusively.
  // Moves K's covisible neighbourhood (poses, points) by the loop's correction; returns it (T_wnew_wold).
  SE3 correctNeighbourhood(const LoopMatch& match, const std::vector<map::Keyframe*>& connected,
                           const std::map<uint64_t, SE3>& old_T_w_c);
  // K's matched points replaced by the loop's; the loop group's points fused into K's neighbourhood.
  size_t replaceDuplicatedPoints(const LoopMatch& match, const std::vector<map::Keyframe*>& connected);
  // Covisibility of the neighbourhood recomputed; its new links become loop edges.
  void updateLoopConnections(const LoopMatch& match, const std::vector<map::Keyframe*>& connected,
                             const std::map<uint64_t, std::set<uint64_t>>& links_before);
  // Spanning tree, strong covisibility and loop edges of the loop's map (L fixed).
  EssentialGraph buildEssentialGraph(const map::Keyframe* loop, const std::map<uint64_t, SE3>& old_T_w_c) const;
  // Optimised poses written back, keyframes made meanwhile moved with K, points with their keyframe.
  // Returns K's pose-graph correction.
  SE3 applyPoseGraph(const EssentialGraph& graph, bool usable, const map::Keyframe* current, int map_id, const SE3& C);
  void startGlobalBa(uint64_t newest_keyframe);
  void runGlobalBa(uint64_t newest_keyframe);
  void globalBa(uint64_t newest_keyframe);  // runGlobalBa's work (may throw)
  void notify(const LoopEvent& event);

  LoopCloserOptions options_;
  PinholeCamera camera_;
  map::Map& map_;
  mapping::MappingPause* pause_;
  GlobalBaMode global_ba_mode_;
  double bf_;
  LoopDetector detector_;

  std::mutex correction_mutex_;  // serialises loop corrections and global-BA write-back
  std::mutex suggested_mutex_;   // guards suggested_ (tracking adds, process() takes)
  std::map<uint64_t, LoopMatch> suggested_;  // by current keyframe id
  // Loop edges of the essential graph (keyframe pairs), guarded by the Map lock.
  std::vector<std::pair<map::Keyframe*, map::Keyframe*>> loop_edges_;

  std::thread global_ba_thread_;      // touched only by the process() caller and the destructor
  std::atomic<bool> global_ba_abort_{false};
  std::atomic<bool> global_ba_running_{false};
  mutable std::mutex ba_wait_mutex_;  // the wait for global_ba_running_; guards global_ba_failure_
  std::condition_variable ba_done_cv_;
  std::exception_ptr global_ba_failure_;

  mutable std::mutex stats_mutex_;    // guards stats_ and listener_
  LoopClosingStats stats_;
  std::function<void(const LoopEvent&)> listener_;
};

// The loop-closing thread: consumes keyframes that local mapping has finished, in order (a
// QueueWorker). Queue: loop.queue_capacity, dropping the oldest when full (a skipped keyframe is
// only a missed detection chance; local mapping must never wait for loop closing, which may be
// waiting for it). An exception from loop closing stops the thread's work: failure() holds it
// (and the global-BA thread's, LoopCloser::failure()) for the pipeline to rethrow.
class LoopClosingThread {
 public:
  explicit LoopClosingThread(LoopCloser& closer, size_t capacity = 64);
  ~LoopClosingThread();
  void push(map::Keyframe* kf);
  // Blocks until every pushed keyframe is processed and no global BA runs.
  void waitUntilIdle();
  // Drains the queue, joins, waits for the global BA (aborted instead once *abort is true).
  // Idempotent.
  void stop(const std::atomic<bool>* abort = nullptr);
  size_t dropped() const { return worker_.dropped(); }
  std::exception_ptr failure() const { return worker_.failure(); }

 private:
  LoopCloser& closer_;
  QueueWorker<map::Keyframe*> worker_;  // last: its thread starts once closer_ is set
};

}  // namespace desslam::loop
