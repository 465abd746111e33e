#include "system/slam_system.hpp"

#include <algorithm>
#include <chrono>
#include <mutex>
#include <shared_mutex>

#include <opencv2/imgproc.hpp>

namespace desslam::system {

namespace {
double millisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}
}  // namespace

nlohmann::json summarizeMilliseconds(std::vector<double> values) {
  if (values.empty()) return {{"median", 0.0}, {"p95", 0.0}, {"mean", 0.0}, {"count", 0}};
  std::sort(values.begin(), values.end());
  auto quantile = [&](double q) { return values[static_cast<size_t>(q * (values.size() - 1) + 0.5)]; };
  double sum = 0;
  for (double v : values) sum += v;
  return {{"median", quantile(0.5)}, {"p95", quantile(0.95)}, {"mean", sum / values.size()}, {"count", values.size()}};
}

SlamSystem::SlamSystem(const SystemOptions& options, const RunSettings& settings)
    : options_(options),
      settings_(settings),
      camera_(options.camera),
      extractor_(options.orb),
      pyramid_(std::make_shared<feature::ScalePyramid>(extractor_.pyramid())),
      tracker_(options, camera_, map_),
      mapper_(options, camera_, map_) {
  options_.validate();
  if (!settings_.deterministic) mapping_thread_ = std::make_unique<mapping::LocalMappingThread>(mapper_);
}

SlamSystem::~SlamSystem() { finish(); }

void SlamSystem::processFrame(Timestamp timestamp, const cv::Mat& bgr, const cv::Mat& depth,
                              const std::string& image_name) {
  const auto start = std::chrono::steady_clock::now();
  FrameTiming timing;
  cv::Mat gray;
  cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY);
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  extractor_.extract(gray, keypoints, descriptors);
  auto features = map::buildFeatureSet(std::move(keypoints), std::move(descriptors), camera_, depth, pyramid_,
                                       options_.tracking.min_depth, options_.tracking.max_depth);
  map::Frame frame(next_frame_id_++, timestamp, image_name, std::move(features));
  timing.extraction_ms = millisecondsSince(start);

  const auto track_start = std::chrono::steady_clock::now();
  const bool mapping_idle = mapping_thread_ == nullptr || mapping_thread_->idle();
  const tracking::TrackOutcome outcome = tracker_.track(frame, mapping_idle);
  timing.tracking_ms = millisecondsSince(track_start);
  last_tracked_ = outcome.tracked;

  if (outcome.new_keyframe != nullptr) {
    if (mapping_thread_)
      mapping_thread_->push(outcome.new_keyframe);
    else
      mapper_.process(outcome.new_keyframe, nullptr);
  }
  timing.total_ms = millisecondsSince(start);
  timings_.push_back(timing);
}

void SlamSystem::finish() {
  if (finished_) return;
  finished_ = true;
  if (mapping_thread_) mapping_thread_->stop();
}

Trajectory SlamSystem::cameraTrajectory() const {
  Trajectory trajectory;
  std::shared_lock lock(map_.mutex());
  for (const tracking::FrameRecord& r : tracker_.records()) {
    if (r.reference == nullptr) continue;
    const SE3 T_c_w = r.T_c_r * map::keyframeTcw(r.reference);
    trajectory.push_back({r.timestamp, T_c_w.inverse()});
  }
  return trajectory;
}

Trajectory SlamSystem::keyframeTrajectory() const {
  Trajectory trajectory;
  std::shared_lock lock(map_.mutex());
  for (const map::Keyframe* kf : map_.keyframes()) trajectory.push_back({kf->timestamp, kf->T_w_c()});
  return trajectory;
}

nlohmann::json SlamSystem::statistics() const {
  std::vector<double> extraction, tracking, total;
  for (const FrameTiming& t : timings_) {
    extraction.push_back(t.extraction_ms);
    tracking.push_back(t.tracking_ms);
    total.push_back(t.total_ms);
  }
  size_t tracked = 0;
  for (const auto& r : tracker_.records())
    if (r.reference != nullptr) ++tracked;
  nlohmann::json j;
  {
    std::shared_lock lock(map_.mutex());
    j["counts"] = {{"frames", timings_.size()},
                   {"frames_tracked", tracked},
                   {"tracking_losses", tracker_.lostFrames()},
                   {"keyframes", map_.keyframeCount()},
                   {"keyframes_created", map_.allKeyframes().size()},
                   {"map_points", map_.pointCount()}};
  }
  const auto& ms = mapper_.stats();
  j["local_mapping"] = {{"keyframes_processed", ms.keyframes_processed},
                        {"points_triangulated", ms.points_triangulated},
                        {"recent_points_culled", ms.points_culled},
                        {"keyframes_culled", ms.keyframes_culled},
                        {"ba_runs", ms.ba_runs},
                        {"ba_aborted", ms.ba_aborted},
                        {"timings_ms",
                         {{"insert", summarizeMilliseconds(ms.insert_ms)},
                          {"cull_points", summarizeMilliseconds(ms.cull_points_ms)},
                          {"triangulate", summarizeMilliseconds(ms.triangulate_ms)},
                          {"fuse", summarizeMilliseconds(ms.fuse_ms)},
                          {"local_ba", summarizeMilliseconds(ms.ba_ms)},
                          {"cull_keyframes", summarizeMilliseconds(ms.cull_keyframes_ms)},
                          {"per_keyframe", summarizeMilliseconds(ms.total_ms)}}}};
  // "tracking" = extraction + pose estimation: the per-frame cost on the tracking thread.
  std::vector<double> tracking_total(timings_.size());
  for (size_t i = 0; i < timings_.size(); ++i) tracking_total[i] = timings_[i].extraction_ms + timings_[i].tracking_ms;
  j["timings_ms"] = {{"orb_extraction", summarizeMilliseconds(extraction)},
                     {"pose_tracking", summarizeMilliseconds(tracking)},
                     {"tracking", summarizeMilliseconds(tracking_total)},
                     {"frame_total", summarizeMilliseconds(total)}};
  j["mode"] = settings_.deterministic ? "deterministic" : "concurrent";
  return j;
}

}  // namespace desslam::system
