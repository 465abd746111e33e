// Dense mapping thread: keyframes come in through a bounded queue, the worker back-projects
// them and integrates them into a DenseMap; pose updates, culling and export go through here.
//
// Lock discipline:
//  - the queue's own mutex (BoundedQueue) guards only the queue;
//  - map_mutex_ guards map_, pose_overrides_, pending_poses_, culled_ids_, the timings and
//    processed_ and failure_. The worker back-projects BEFORE taking it and holds it while applying pending
//    poses and merging the keyframe into the voxel map (the deferred re-key, linear in the voxels
//    of moved anchors, then free-space carving and the merge: tens of ms on Bonn crowd);
//    exportCloud() holds it while extracting the voxels (poses only, never a re-key) and runs
//    the outlier filter after releasing it;
//  - inbox_mutex_ guards only inbox_poses_: updatePoses() takes nothing else, and push() takes
//    no lock but the queue's (pushed_ and stopped_ are atomics), so the tracking thread never
//    waits for the worker's merge. Order: map_mutex_ -> inbox_mutex_ (the worker moves the inbox
//    into pending_poses_ while holding map_mutex_), never the reverse.
// Queue: capacity DenseOptions::queue_capacity; full policy kBlock (offline: every keyframe is
// mapped; the producer waits) or kDropOldest (real time: the oldest waiting keyframe is dropped,
// counted in droppedCount()).
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <exception>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <thread>
#include <vector>

#include "core/bounded_queue.hpp"
#include "dense/dense_map.hpp"

namespace desslam::dense {

class DenseMappingThread {
 public:
  // Starts the worker.
  DenseMappingThread(const DenseOptions& options, const PinholeCamera& camera,
                     QueueFullPolicy full_policy = QueueFullPolicy::kBlock);
  ~DenseMappingThread();  // stop()
  DenseMappingThread(const DenseMappingThread&) = delete;
  DenseMappingThread& operator=(const DenseMappingThread&) = delete;

  // Any thread. Returns false after stop() or a failure (the keyframe is not mapped).
  bool push(std::shared_ptr<const DenseKeyframe> keyframe);

  // Any thread. New poses for keyframes (after local BA / loop closure). Also remembered for
  // keyframes still in the queue, so an update is never lost to the race with the worker.
  // Cheap for the caller: the map takes them in the worker before its next keyframe (and
  // re-keys then if needed), or in the next export/snapshot call (which never re-keys).
  void updatePoses(const PoseMap& T_w_c_by_id);
  // Any thread. A culled keyframe: its voxels stay (DenseMap::removeKeyframe), also when it is
  // still queued (then it is marked once mapped).
  void removeKeyframe(uint64_t keyframe_id);

  // Any thread. Exported cloud with the newest poses known here (DenseMap::exportCloud), or
  // with the given ones (ids missing there use the newest known).
  DenseCloud exportCloud(const PoseMap& T_w_c_by_id = {}) const;
  std::shared_ptr<open3d::geometry::PointCloud> fuse(bool semantic_colour = false) const;
  std::shared_ptr<open3d::geometry::PointCloud> fuse(const PoseMap& T_w_c_by_id, bool semantic_colour = false) const;
  // Any thread. DenseMap::worldScans under the lock (no copy of the map).
  std::vector<WorldScan> worldScans(const PoseMap& T_w_c_by_id = {}) const;
  // Any thread. A full copy of the map (linear in its voxel count: tests and tools only).
  DenseMap snapshot() const;
  DenseMapStats mapStats() const;
  // Milliseconds the worker spent on each keyframe (back-projection + integration, excluding
  // waits), in processing order.
  std::vector<double> keyframeMilliseconds() const;
  // The same work as this thread's CPU time (excludes time the thread waited for a core).
  std::vector<double> keyframeCpuMilliseconds() const;

  // Blocks until every keyframe pushed so far has been mapped or dropped (offline mode uses
  // this before exporting). Returns at once after stop().
  void waitUntilIdle() const;
  // Closes the queue, maps what is left in it, joins the worker. Idempotent.
  void stop();

  size_t keyframeCount() const;   // keyframes mapped (culled included)
  size_t processedCount() const;  // keyframes taken from the queue (mapped or dropped)
  size_t droppedCount() const { return queue_.dropped(); }
  // The exception mapping a keyframe threw (null while none did). The worker maps nothing after
  // it (queued keyframes are taken off unmapped); the pipeline rethrows it to its caller.
  std::exception_ptr failure() const;

 private:
  void run();
  void integrate(const DenseKeyframe& keyframe);  // back-projection and merge (may throw)

  const QueueFullPolicy full_policy_;  // kDropOldest = real time: the worker runs at lower priority
  BoundedQueue<std::shared_ptr<const DenseKeyframe>> queue_;
  mutable std::mutex map_mutex_;
  mutable std::condition_variable idle_;
  void applyPendingPoses() const;  // requires map_mutex_; drains the inbox first

  mutable DenseMap map_;         // mutable: const readers first apply pending poses
  mutable PoseMap pose_overrides_;  // newest poses, also for keyframes not yet mapped
  mutable PoseMap pending_poses_;  // sent but not yet applied to map_
  mutable std::mutex inbox_mutex_;
  mutable PoseMap inbox_poses_;    // guarded by inbox_mutex_: received, not yet in pending_poses_
  std::set<uint64_t> culled_ids_;  // culled before the worker mapped them
  std::vector<double> keyframe_ms_;
  std::vector<double> keyframe_cpu_ms_;
  std::atomic<size_t> pushed_{0};
  size_t processed_ = 0;         // guarded by map_mutex_
  std::atomic<bool> stopped_{false};
  std::atomic<bool> failed_{false};
  std::exception_ptr failure_;   // guarded by map_mutex_
  std::mutex stop_mutex_;        // serialises stop() callers only
  std::thread worker_;
};

}  // namespace desslam::dense
