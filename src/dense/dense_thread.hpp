// Dense mapping thread: keyframes come in through a bounded queue, the worker back-projects
// them and adds them to a DenseMap; pose updates, culling and fuse() go through this object.
//
// Lock discipline (two locks, never held together):
//  - the queue's own mutex (BoundedQueue) guards only the queue;
//  - map_mutex_ guards map_, pose_overrides_, removed_ids_ and processed_. Held only for short
//    bookkeeping: the worker back-projects and downsamples BEFORE taking it, and fuse() copies
//    the map under it (clouds are shared and immutable, so the copy is cheap) and fuses after
//    releasing it. So neither the producer nor a caller of fuse() waits for the other's work.
// Queue: capacity DenseOptions::queue_capacity; full policy kBlock (offline: every keyframe is
// mapped; the producer waits) or kDropOldest (real time: the oldest waiting keyframe is dropped,
// counted in droppedCount()).
#pragma once

#include <condition_variable>
#include <cstdint>
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

  // Any thread. Returns false after stop() (the keyframe is not mapped).
  bool push(std::shared_ptr<const DenseKeyframe> keyframe);

  // Any thread. New poses for keyframes (after local BA / loop closure). Also remembered for
  // keyframes still in the queue, so an update is never lost to the race with the worker.
  void updatePoses(const PoseMap& T_w_c_by_id);
  // Any thread. A culled keyframe: removed now, or dropped when the worker reaches it.
  void removeKeyframe(uint64_t keyframe_id);

  // Any thread. Fused world cloud with the newest poses known here (DenseMap::fuse), or with
  // the given ones (ids missing there use the newest known).
  std::shared_ptr<open3d::geometry::PointCloud> fuse(bool semantic_colour = false) const;
  std::shared_ptr<open3d::geometry::PointCloud> fuse(const PoseMap& T_w_c_by_id, bool semantic_colour = false) const;
  // Any thread. A consistent copy of the map (cheap: clouds are shared), e.g. for worldScans().
  DenseMap snapshot() const;

  // Blocks until every keyframe pushed so far has been mapped or dropped (offline mode uses
  // this before exporting). Returns at once after stop().
  void waitUntilIdle() const;
  // Closes the queue, maps what is left in it, joins the worker. Idempotent.
  void stop();

  size_t keyframeCount() const;
  size_t processedCount() const;  // keyframes taken from the queue (mapped or removed)
  size_t droppedCount() const { return queue_.dropped(); }

 private:
  void run();

  BoundedQueue<std::shared_ptr<const DenseKeyframe>> queue_;
  mutable std::mutex map_mutex_;
  mutable std::condition_variable idle_;
  DenseMap map_;
  PoseMap pose_overrides_;       // newest poses, also for keyframes not yet mapped
  std::set<uint64_t> removed_ids_;
  size_t pushed_ = 0;            // guarded by map_mutex_
  size_t processed_ = 0;         // guarded by map_mutex_
  bool stopped_ = false;         // guarded by map_mutex_
  std::mutex stop_mutex_;        // serialises stop() callers only
  std::thread worker_;
};

}  // namespace desslam::dense
