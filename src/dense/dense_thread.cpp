#include "dense/dense_thread.hpp"

#include <open3d/geometry/PointCloud.h>

namespace desslam::dense {

DenseMappingThread::DenseMappingThread(const DenseOptions& options, const PinholeCamera& camera,
                                       QueueFullPolicy full_policy)
    : queue_(static_cast<size_t>(options.queue_capacity), full_policy), map_(options, camera) {
  worker_ = std::thread([this] { run(); });
}

DenseMappingThread::~DenseMappingThread() { stop(); }

bool DenseMappingThread::push(std::shared_ptr<const DenseKeyframe> keyframe) {
  {
    std::lock_guard lock(map_mutex_);
    if (stopped_) return false;
    ++pushed_;  // counted first so waitUntilIdle() never misses a keyframe in flight
  }
  if (queue_.push(std::move(keyframe))) return true;
  std::lock_guard lock(map_mutex_);
  --pushed_;
  idle_.notify_all();
  return false;
}

void DenseMappingThread::run() {
  size_t seen_dropped = 0;
  while (auto message = queue_.pop()) {
    const DenseKeyframe& keyframe = **message;
    // The expensive part, outside the lock: the BackProjector is immutable and shared.
    auto cloud = std::make_shared<const KeyframeCloud>(
        voxelDownsample(map_.backProjector()(keyframe), map_.options().voxel_size));
    const size_t dropped = queue_.dropped();
    std::lock_guard lock(map_mutex_);
    if (removed_ids_.erase(keyframe.keyframe_id) == 0) {
      const auto it = pose_overrides_.find(keyframe.keyframe_id);
      map_.addCloud(std::move(cloud), it != pose_overrides_.end() ? it->second : keyframe.T_w_c);
    }
    processed_ += 1 + (dropped - seen_dropped);  // dropped keyframes will never arrive
    seen_dropped = dropped;
    idle_.notify_all();
  }
  std::lock_guard lock(map_mutex_);
  processed_ += queue_.dropped() - seen_dropped;
  idle_.notify_all();
}

void DenseMappingThread::updatePoses(const PoseMap& T_w_c_by_id) {
  std::lock_guard lock(map_mutex_);
  for (const auto& [id, pose] : T_w_c_by_id) pose_overrides_.insert_or_assign(id, pose);
  map_.updatePoses(T_w_c_by_id);
}

void DenseMappingThread::removeKeyframe(uint64_t keyframe_id) {
  std::lock_guard lock(map_mutex_);
  pose_overrides_.erase(keyframe_id);
  if (map_.contains(keyframe_id)) {
    map_.removeKeyframe(keyframe_id);
  } else {
    removed_ids_.insert(keyframe_id);  // still queued (or never pushed: then harmless)
  }
}

DenseMap DenseMappingThread::snapshot() const {
  std::lock_guard lock(map_mutex_);
  return map_;
}

std::shared_ptr<open3d::geometry::PointCloud> DenseMappingThread::fuse(bool semantic_colour) const {
  return snapshot().fuse(semantic_colour);
}

std::shared_ptr<open3d::geometry::PointCloud> DenseMappingThread::fuse(const PoseMap& T_w_c_by_id,
                                                                       bool semantic_colour) const {
  return snapshot().fuse(T_w_c_by_id, semantic_colour);
}

void DenseMappingThread::waitUntilIdle() const {
  std::unique_lock lock(map_mutex_);
  idle_.wait(lock, [&] { return processed_ >= pushed_; });
}

void DenseMappingThread::stop() {
  std::lock_guard stop_lock(stop_mutex_);
  {
    std::lock_guard lock(map_mutex_);
    stopped_ = true;
  }
  queue_.close();
  if (worker_.joinable()) worker_.join();
}

size_t DenseMappingThread::keyframeCount() const {
  std::lock_guard lock(map_mutex_);
  return map_.keyframeCount();
}

size_t DenseMappingThread::processedCount() const {
  std::lock_guard lock(map_mutex_);
  return processed_;
}

}  // namespace desslam::dense
