#include "dense/dense_thread.hpp"

#include <chrono>
#include <ctime>

#include <open3d/geometry/PointCloud.h>

#include "core/thread_priority.hpp"

namespace desslam::dense {
namespace {
// CPU time of the calling thread: on a busy 2-core machine wall time mostly measures waiting
// for a core, not the work.
double threadCpuMilliseconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec / 1e6;
}
}  // namespace

DenseMappingThread::DenseMappingThread(const DenseOptions& options, const PinholeCamera& camera,
                                       QueueFullPolicy full_policy)
    : full_policy_(full_policy), queue_(static_cast<size_t>(options.queue_capacity), full_policy), map_(options, camera) {
  worker_ = std::thread([this] { run(); });
}

DenseMappingThread::~DenseMappingThread() { stop(); }

bool DenseMappingThread::push(std::shared_ptr<const DenseKeyframe> keyframe) {
  if (stopped_ || failed_) return false;
  ++pushed_;  // counted first so waitUntilIdle() never misses a keyframe in flight
  if (queue_.push(std::move(keyframe))) return true;
  std::lock_guard lock(map_mutex_);
  --pushed_;
  idle_.notify_all();
  return false;
}

void DenseMappingThread::run() {
  // Real time (keyframes may be dropped): the map is the least urgent work; yield to tracking.
  if (full_policy_ == QueueFullPolicy::kDropOldest) lowerCurrentThreadPriority(10);
  size_t seen_dropped = 0;
  while (auto message = queue_.pop()) {
    const size_t dropped = queue_.dropped();
    if (!failed_) {
      try {
        integrate(**message);
      } catch (...) {
        // Kept for the pipeline to rethrow (failure()); later keyframes are taken off the queue
        // unmapped, so producers and waitUntilIdle() are never left waiting.
        std::lock_guard lock(map_mutex_);
        failure_ = std::current_exception();
        failed_ = true;
      }
    }
    std::lock_guard lock(map_mutex_);
    processed_ += 1 + (dropped - seen_dropped);  // dropped keyframes will never arrive
    seen_dropped = dropped;
    idle_.notify_all();
  }
  std::lock_guard lock(map_mutex_);
  processed_ += queue_.dropped() - seen_dropped;
  idle_.notify_all();
}

void DenseMappingThread::integrate(const DenseKeyframe& keyframe) {
  // Back-projection outside the lock: the BackProjector is immutable and shared.
  const auto start = std::chrono::steady_clock::now();
  const double cpu_start = threadCpuMilliseconds();
  const KeyframeCloud cloud = map_.backProjector()(keyframe);
  const double project_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  std::lock_guard lock(map_mutex_);
  const auto merge_start = std::chrono::steady_clock::now();
  applyPendingPoses();
  const auto it = pose_overrides_.find(keyframe.keyframe_id);
  map_.integrate(cloud, it != pose_overrides_.end() ? it->second : keyframe.T_w_c, keyframe.depth);
  if (culled_ids_.erase(keyframe.keyframe_id) != 0) map_.removeKeyframe(keyframe.keyframe_id);
  keyframe_ms_.push_back(project_ms +
                         std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - merge_start).count());
  keyframe_cpu_ms_.push_back(threadCpuMilliseconds() - cpu_start);
}

std::exception_ptr DenseMappingThread::failure() const {
  std::lock_guard lock(map_mutex_);
  return failure_;
}

void DenseMappingThread::updatePoses(const PoseMap& T_w_c_by_id) {
  std::lock_guard lock(inbox_mutex_);
  for (const auto& [id, pose] : T_w_c_by_id) inbox_poses_.insert_or_assign(id, pose);
}

void DenseMappingThread::applyPendingPoses() const {
  PoseMap received;
  {
    std::lock_guard lock(inbox_mutex_);
    received.swap(inbox_poses_);
  }
  for (const auto& [id, pose] : received) {
    pose_overrides_.insert_or_assign(id, pose);
    pending_poses_.insert_or_assign(id, pose);
  }
  if (pending_poses_.empty()) return;
  map_.updatePoses(pending_poses_);
  pending_poses_.clear();
}

void DenseMappingThread::removeKeyframe(uint64_t keyframe_id) {
  std::lock_guard lock(map_mutex_);
  if (map_.contains(keyframe_id)) {
    map_.removeKeyframe(keyframe_id);
  } else {
    culled_ids_.insert(keyframe_id);  // still queued (or never pushed: then harmless)
  }
}

DenseCloud DenseMappingThread::exportCloud(const PoseMap& T_w_c_by_id) const {
  DenseCloud cloud;
  {
    std::lock_guard lock(map_mutex_);
    applyPendingPoses();
    cloud = map_.extract(T_w_c_by_id);
  }
  removeStatisticalOutliers(cloud, map_.options());  // options_ are immutable: no lock needed
  return cloud;
}

std::vector<WorldScan> DenseMappingThread::worldScans(const PoseMap& T_w_c_by_id) const {
  std::lock_guard lock(map_mutex_);
  applyPendingPoses();
  return map_.worldScans(T_w_c_by_id);
}

DenseMapStats DenseMappingThread::mapStats() const {
  std::lock_guard lock(map_mutex_);
  applyPendingPoses();
  return map_.stats();
}

std::vector<double> DenseMappingThread::keyframeMilliseconds() const {
  std::lock_guard lock(map_mutex_);
  return keyframe_ms_;
}

std::vector<double> DenseMappingThread::keyframeCpuMilliseconds() const {
  std::lock_guard lock(map_mutex_);
  return keyframe_cpu_ms_;
}

DenseMap DenseMappingThread::snapshot() const {
  std::lock_guard lock(map_mutex_);
  applyPendingPoses();
  return map_;
}

std::shared_ptr<open3d::geometry::PointCloud> DenseMappingThread::fuse(bool semantic_colour) const {
  return toOpen3d(exportCloud(), semantic_colour);
}

std::shared_ptr<open3d::geometry::PointCloud> DenseMappingThread::fuse(const PoseMap& T_w_c_by_id,
                                                                       bool semantic_colour) const {
  return toOpen3d(exportCloud(T_w_c_by_id), semantic_colour);
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
