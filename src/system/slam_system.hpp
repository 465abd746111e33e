// The whole pipeline behind one object: feed RGB-D frames in order, read trajectories and
// statistics out. Owns the map and every stage.
//
// Threads: tracking runs on the caller's thread (processFrame); local mapping in its own thread
// unless `deterministic`, where each keyframe is mapped inline before the next frame so two runs
// give identical results.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/camera.hpp"
#include "core/options.hpp"
#include "core/trajectory.hpp"
#include "feature/orb_extractor.hpp"
#include "map/map.hpp"
#include "mapping/local_mapper.hpp"
#include "tracking/tracker.hpp"

namespace desslam::system {

struct RunSettings {
  bool deterministic = false;
};

// Per-frame timings, milliseconds.
struct FrameTiming {
  double extraction_ms = 0;
  double tracking_ms = 0;  // pose estimation and keyframe decision (after extraction)
  double total_ms = 0;     // the whole processFrame call
};

class SlamSystem {
 public:
  SlamSystem(const SystemOptions& options, const RunSettings& settings);
  ~SlamSystem();

  // bgr: CV_8UC3, depth: CV_32F metres. Frames must come in time order.
  void processFrame(Timestamp timestamp, const cv::Mat& bgr, const cv::Mat& depth, const std::string& image_name);
  // Waits for mapping to finish its queue and stops the threads. Idempotent.
  void finish();

  // Poses of every tracked frame (world-from-camera), following the final keyframe poses.
  Trajectory cameraTrajectory() const;
  Trajectory keyframeTrajectory() const;
  // Counts, timings (median/p95) and stage statistics for report.json.
  nlohmann::json statistics() const;

  size_t framesProcessed() const { return timings_.size(); }
  bool lastFrameTracked() const { return last_tracked_; }
  const std::vector<FrameTiming>& timings() const { return timings_; }

 private:
  SystemOptions options_;
  RunSettings settings_;
  PinholeCamera camera_;
  feature::OrbExtractor extractor_;
  std::shared_ptr<const feature::ScalePyramid> pyramid_;
  map::Map map_;
  tracking::Tracker tracker_;
  mapping::LocalMapper mapper_;
  std::unique_ptr<mapping::LocalMappingThread> mapping_thread_;  // null when deterministic
  std::vector<FrameTiming> timings_;
  uint64_t next_frame_id_ = 0;
  bool last_tracked_ = false;
  bool finished_ = false;
};

// Median and 95th percentile of a series (0 when empty).
nlohmann::json summarizeMilliseconds(std::vector<double> values);

}  // namespace desslam::system
