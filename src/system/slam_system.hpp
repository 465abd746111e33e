// The whole pipeline behind one object: feed RGB-D frames in order, read trajectories, maps and
// statistics out. Owns the map and every stage.
//
// Threads (DESIGN.md): tracking runs on the caller's thread (processFrame); segmentation in the
// semantic thread; local mapping, loop closing (with its global BA) and dense mapping in their
// own threads. With `deterministic`, local mapping and loop closing run inline after each
// keyframe and tracking waits for every mask, so two runs give identical trajectories. In
// real-time mode tracking waits for the network only briefly (a frame being
// segmented, semantic.realtime_mask_wait_ms): a frame without a fresh mask uses the newest one
// carried forward along optical flow.
#pragma once

#include <atomic>
#include <deque>
#include <functional>
#include <map>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/camera.hpp"
#include "core/trajectory.hpp"
#include "dynamic/mask_propagation.hpp"
#include "feature/orb_extractor.hpp"
#include "loop/loop_closer.hpp"
#include "map/map.hpp"
#include "mapping/local_mapper.hpp"
#include "optim/map_bundle_adjustment.hpp"
#include "place/keyframe_database.hpp"
#include "system/odometry_chain.hpp"
#include "system/system_options.hpp"
#include "tracking/tracker.hpp"

namespace desslam::semantic {
class SemanticThread;
struct Segmentation;
}
namespace desslam::dense {
class DenseMappingThread;
struct DenseKeyframe;
}

namespace desslam::system {

struct RunSettings {
  bool deterministic = false;
  bool realtime = false;            // never wait for segmentation (masks carried forward)
  std::filesystem::path debug_images_dir;  // empty: none written
  // Offline only (0 = off): frame k gets the mask of the newest frame s <= k - mask_latency_frames
  // with s a multiple of mask_period_frames, carried forward as in real time. Real time's stale
  // masks, reproducible with `deterministic` (real time itself depends on the CPU's load).
  int mask_latency_frames = 0;
  int mask_period_frames = 1;
  // Called after local mapping has processed each keyframe, on the thread that mapped it (the
  // local-mapping thread, or the caller when deterministic), with the keyframe's id. For tests and
  // tools (e.g. a fault injected there must reach processFrame's or finish()'s caller).
  std::function<void(uint64_t keyframe_id)> after_local_mapping;
};

// How finish() ends a run that is being interrupted (all optional).
struct FinishControl {
  // Once true (any thread; e.g. a signal handler's flag), a running global BA (the loop closer's
  // or the final one) is aborted and the final BA is not started.
  const std::atomic<bool>* abort = nullptr;
  // Called on the caller's thread before each stage of finish(): "mapping" (local mapping and loop
  // closing drain their queues; always runs), "final_ba" (mapping.final_global_ba) and "dense"
  // (the dense thread drains its queue; always runs). Returning false skips "final_ba".
  std::function<bool(const std::string& stage)> on_stage;
};

// Per-frame record for the report, milliseconds and counts.
struct FrameStats {
  double extraction_ms = 0;
  double mask_wait_ms = 0;   // time tracking waited for the semantic mask
  double tracking_ms = 0;    // pose estimation, dynamic checks and keyframe decision
  double total_ms = 0;       // the whole processFrame call
  double segmentation_ms = -1;  // network time of the mask used (-1: none)
  int mask_age = -1;         // frames between the mask's frame and this one (0 = fresh, -1 = no mask)
  int mask_radius_px = -1;   // dilation (+ growth of a carried mask) applied to it
  bool own_mask_waited = false;  // lost: waited for its own mask instead of a carried one
  int features_added_outside_mask = 0;  // extra features on the background (a mask covered most)
  int features_with_depth = 0;  // keypoints with a valid depth reading (tracking.min/max_depth)
  // Of those, the ones still static after tracking (not in the mask, not removed by stage 1/2):
  // what starting a map counts (atlas.min_initial_features).
  int static_with_depth = 0;
  int features = 0, in_mask = 0, semantic_removed = 0, stage1_checked = 0, stage1_removed = 0, stage2_removed = 0;
  int free_space_removed = 0;  // of stage1_removed: the free-space test outside the mask
  int map_verified = 0;        // of stage1_removed: taken back, a map point at their depth (dynamic.stage1_map_check)
  bool tracked = false;
  bool keyframe = false;
  int inliers = 0;            // map-point inliers after local-map tracking
  bool motion_model = false;  // the first estimate came from the constant-velocity prediction
  bool new_map = false;       // the frame started a map of the atlas
  bool weak = false;          // tracked with few inliers that agreed with the motion prediction
  bool odometry = false;      // tracked by frame-to-frame odometry alone (tracking.odometry_min_inliers)
  bool depth_odometry = false;  // of those, by depth alignment (tracking.depth_odometry_max_s)
  bool predicted = false;     // not tracked: the motion prediction is its pose (tracking.predict_through_loss_s)
  bool backfilled = false;    // not tracked then: a later frame's tracking gave it a pose (tracking.backfill_max_s)
  bool interpolated = false;  // not tracked then: its pose lies between the frames tracked before and after
  bool predicted_backwards = false;  // not tracked then: the motion after it, extrapolated (tracking.predict_back_s)
  // Given the nearer frame's pose at the end of the run, beyond both predictions
  // (tracking.hold_pose_s); predicted or predicted_backwards says which side's.
  bool held = false;
  // Relocalisation attempt on this frame (lost): candidates tried, best descriptor matches, PnP
  // inliers, pose inliers (-1: not attempted).
  int reloc_candidates = -1, reloc_matches = -1, reloc_pnp_inliers = -1, reloc_inliers = -1;
  int map = -1;               // the map it was tracked in (-1: none)
  double timestamp = 0;
};

class SlamSystem {
 public:
  SlamSystem(const SystemOptions& options, const RunSettings& settings);
  ~SlamSystem();

  // bgr: CV_8UC3, depth: CV_32F metres; neither is modified nor copied, so the caller must not
  // write into them afterwards. Frames must come in time order.
  // depth_time_offset: seconds the depth image was taken after the RGB image (TUM: the two
  // timestamps' difference); tracking compensates it during fast motion.
  void processFrame(Timestamp timestamp, const cv::Mat& bgr, const cv::Mat& depth, const std::string& image_name,
                    double depth_time_offset = 0);
  // Both throw WorkerError (once) when a worker thread (local mapping, loop closing, global BA,
  // dense mapping) has failed; the system then maps nothing more, but finish() still stops every
  // thread and the trajectories, statistics and export read what was built until then.
  //
  // Waits for mapping to finish its queue, runs the final global BA and stops the threads.
  // Idempotent (a second call does nothing).
  void finish(const FinishControl& control = {});
  // Whether finish() ran the final global BA to its end (false: off, skipped or aborted).
  bool finalBundleAdjustmentDone() const { return final_ba_.completed; }

  // Poses (world-from-camera, following the final keyframe poses) of the frames of the main map:
  // the map of the atlas that, after all merges, holds the most frames (the earliest on a tie).
  Trajectory cameraTrajectory() const;
  // Every frame with a pose in any map, with its map and the map whose world the pose is in.
  AtlasTrajectory cameraTrajectoryAll() const;
  Trajectory keyframeTrajectory() const;
  // Every keyframe with its map (map and world_map: the map it belongs to now, after merges).
  AtlasTrajectory keyframeTrajectoryAll() const;
  // The main map's id (see cameraTrajectory; -1 before any frame was tracked).
  int mainMap() const;
  // The pose of the frame processed last, in the world of the map it belongs to now (nullopt:
  // that frame has no pose).
  std::optional<AtlasPose> lastFramePose() const;
  // The pose of the frame processed last in the odometry frame (odometry_chain.hpp: continuous
  // over new maps, merges and loop corrections; nullopt: that frame has no pose).
  std::optional<SE3> lastOdometryPose() const { return last_T_odom_c_; }
  // Every frame that had a pose when it was processed, in the odometry frame as it was then (map:
  // the map it was tracked in; world_map: -1, no map's world). Tracking thread only.
  AtlasTrajectory odometryTrajectory() const;
  // Whether a map has been started (tracking is past initialisation).
  bool initialised() const { return tracker_.state() != tracking::TrackingState::kNotInitialized; }
  // After finish(): fuses the dense map with the final keyframe poses and writes dense_map.ply,
  // dense_map.pcd, dense_map_sources.bin, octomap.bt and dense_map.png into out_dir. Returns counts
  // and timings. An empty dense map (no keyframe) writes nothing and says so ("exported": false,
  // "note"). Once *abort is true (checked between files and during the OctoMap's ray insertion),
  // the files still to come are skipped ("skipped" lists them). on_progress(file, share done) is
  // called during the OctoMap export, the one that can take long, a few times a second or more.
  // An OctoMap too fine for dense.octomap_max_ray_cells is written coarser ("warnings" says so).
  // Files are written atomically; a failure throws OutputError.
  nlohmann::json exportDenseMap(const std::filesystem::path& out_dir, bool semantic_colour,
                                const std::atomic<bool>* abort = nullptr,
                                const std::function<void(const std::string& file, double share)>& on_progress = {}) const;
  // After finish(): counts, timings (median/p95) and stage statistics for report.json.
  nlohmann::json statistics() const;

  size_t framesProcessed() const { return frames_.size(); }
  bool lastFrameTracked() const { return !frames_.empty() && frames_.back().tracked; }
  const std::vector<FrameStats>& frameStats() const { return frames_; }

 private:
  // The dilated mask of dynamic classes for this frame, and its provenance; `ungrown` gets the
  // same mask dilated by dynamic.mask_dilation_px alone, without a late mask's growth.
  // bgr: the frame's image as handed to the semantic thread (for an own-mask request).
  cv::Mat maskFor(uint64_t frame_id, const std::shared_ptr<const cv::Mat>& bgr, const std::string& image_name,
                  const std::vector<cv::KeyPoint>& keypoints, FrameStats& stats, cv::Mat& ungrown);
  // Local mapping's thread (or the caller when deterministic), before local mapping processes kf:
  // when the keyframe's own mask was requested, waits for it, and the features in it (dilated as
  // at the keyframe's creation) become dynamic; their points lose this observation.
  void applyKeyframeMask(map::Keyframe* kf);
  // Flags the frames the outcome predicted backwards (tracking.predict_back_s) in frames_.
  void markPredictedBackwards(const tracking::TrackOutcome& outcome);
  // Adds the frame just tracked to the odometry chain when it has a pose (takes the map lock shared).
  void updateOdometry(uint64_t frame_id);
  // Frames with a pose per map they ended in (after every merge). Map lock held shared.
  std::map<int, size_t> framesPerMapLocked() const;
  // The live map holding the most tracked frames (-1: none). Map lock held shared.
  int mainMapLocked() const;
  // The same from framesPerMapLocked()'s counts (the older map wins a tie).
  static int mainMapOf(const std::map<int, size_t>& frames_per_map);
  // Throws WorkerError for the first failed worker thread, once (later calls return).
  void rethrowWorkerFailure();
  // The atlas for report.json: maps, merges. Map lock taken here.
  nlohmann::json atlasJson() const;
  // Hands the keyframe to the dense thread, or holds it while its map is not the dense map's
  // world (tracking thread only).
  void pushDenseKeyframe(const map::Keyframe* kf, const map::Frame& frame, const cv::Mat& bgr,
                         const cv::Mat& labels);
  // Moves the held dense keyframes whose map is now `world` (merged into the dense map's world)
  // into `ready`, with their keyframes' poses. Map lock held (shared); tracking thread only.
  void releaseHeldDenseKeyframes(int world, std::vector<std::shared_ptr<dense::DenseKeyframe>>& ready);

  SystemOptions options_;
  RunSettings settings_;
  PinholeCamera camera_;
  feature::OrbExtractor extractor_;
  std::shared_ptr<const feature::ScalePyramid> pyramid_;
  map::Map map_;
  // Keyframe BoW database (null when relocalisation and loop closing are both off): written by
  // local mapping, read by tracking's relocaliser and the loop closer (its own lock).
  std::unique_ptr<place::KeyframeDatabase> keyframe_db_;
  tracking::Tracker tracker_;
  mapping::LocalMapper mapper_;
  mapping::MappingPause mapping_pause_;                         // loop closing pauses local mapping
  std::unique_ptr<loop::LoopCloser> loop_closer_;            // null when loop.enabled is false
  std::unique_ptr<loop::LoopClosingThread> loop_thread_;     // null when deterministic
  std::unique_ptr<mapping::LocalMappingThread> mapping_thread_;  // null when deterministic
  std::unique_ptr<semantic::SemanticThread> semantic_;           // null when no masks are used
  std::unique_ptr<dense::DenseMappingThread> dense_;             // null when dense.enabled is false

  // Carries a late mask forward along optical flow (tracking thread only; real time and emulated
  // latency).
  dynamic::MaskPropagator mask_propagator_;
  cv::Mat last_labels_;  // labels of the mask used for the current frame (dense semantic colour)
  // Emulated latency: the result handed to the frames after its own (offline waitFor erases it).
  std::shared_ptr<const semantic::Segmentation> emulated_result_;
  uint64_t emulated_result_id_ = 0;
  bool carriesMasks() const { return settings_.realtime || settings_.mask_latency_frames > 0; }
  // The optical flow is kept when masks are carried or held (dynamic.mask_hold_previous).
  bool tracksFlow() const { return carriesMasks() || options_.dynamic.mask_hold_previous; }
  // dynamic.mask_hold_previous: the segmentation before the current one (tracking thread only).
  std::shared_ptr<const semantic::Segmentation> held_result_, current_result_;
  uint64_t held_result_id_ = 0, current_result_id_ = 0;

  // Dense keyframes of maps not (yet) merged into the dense map's world (tracking thread only),
  // with their keyframe (its map_id, read under the Map lock, follows merges); at most
  // kMaxHeldDenseKeyframes (the oldest are dropped).
  static constexpr size_t kMaxHeldDenseKeyframes = 300;
  int dense_world_map_ = -1;
  std::vector<std::pair<const map::Keyframe*, std::shared_ptr<dense::DenseKeyframe>>> dense_held_;
  size_t dense_held_dropped_ = 0;

  // Written by processFrame (requested) and applyKeyframeMask (local mapping's thread), read by
  // statistics(); all under keyframe_mask_mutex_.
  struct KeyframeMaskStats {
    size_t requested = 0;         // keyframes made with a carried mask (tracking thread)
    size_t applied = 0;           // keyframes that got their own mask
    size_t features_removed = 0;  // their features found in it
    size_t points_removed = 0;    // map points that left with them (held by no other keyframe)
    std::vector<double> wait_ms;  // how long local mapping waited for the mask
  };
  mutable std::mutex keyframe_mask_mutex_;
  KeyframeMaskStats keyframe_masks_;

  std::vector<FrameStats> frames_;
  // The odometry frame (tracking thread only): the chain, the map each of its frames was tracked
  // in, the record of the last frame added, and the last frame's pose in it.
  OdometryChain odometry_;
  std::vector<int> odometry_maps_;
  std::optional<tracking::FrameRecord> odometry_last_;
  std::optional<SE3> last_T_odom_c_;
  // Real time: the previous frame's processing time without its mask wait, and the time a frame
  // keeps free of the mask wait (1.5 frame periods minus both bounds the wait).
  double previous_processing_ms_ = 0;
  static constexpr double kRealtimeMargin_ms = 3.0;
  struct {
    std::chrono::steady_clock::time_point wall{};
    Timestamp timestamp = 0;
  } realtime_origin_;
  double realtime_behind_ms_ = 0;
  uint64_t next_frame_id_ = 0;
  bool finished_ = false;
  bool failure_reported_ = false;  // a worker's failure has been thrown to the caller
  optim::GlobalBaResult final_ba_;  // the bundle adjustment finish() runs (empty when off)
};

}  // namespace desslam::system
