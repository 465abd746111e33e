// DeS-SLAM's public C++ API: the one header a user includes.
//
//   desslam::Config config = desslam::Config::fromYaml("config/tum_fr1.yaml");
//   config.set("dense.enabled=false");
//   desslam::Slam slam(config, {.deterministic = true});
//   for (each frame) {
//     const desslam::TrackResult r = slam.track(timestamp_s, bgr, depth_m);
//     if (r.hasPose()) use(r.T_w_c, r.map_id);
//   }
//   slam.finish();                       // drains mapping, final global bundle adjustment
//   auto poses = slam.trajectory();      // final poses of the main map
//
// Everything else under src/ is internal and may change. Errors are thrown as exceptions derived
// from std::runtime_error whose message names the file, the option or the input at fault.
//
// Threads: one Slam object is used from one thread at a time (track() runs tracking on the
// caller's thread; the object starts its own mapping, loop-closing, semantic and dense threads
// and stops them in finish() or its destructor).
#pragma once

#include <atomic>
#include <cstddef>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace desslam {

struct SystemOptions;  // internal: every stage's options (src/system/system_options.hpp)

// The library's version ("0.1.0").
std::string version();

// The folder of the data the library ships: <prefix>/share/desslam when installed (vocab/ with the
// default vocabulary, config/ with the camera presets), found relative to the library itself; the
// source tree when the library runs from its build tree; $DESSLAM_DATA_DIR first when set.
// Throws listing the places looked at when none holds the default vocabulary.
std::filesystem::path dataDirectory();

// The options of a run: every stage's settings, from a YAML file (one section per stage, as in
// config/*.yaml) and "section.key=value" assignments. Validated when a Slam is made from it.
class Config {
 public:
  // Reads and validates a YAML file; throws naming the file and "section.key" at fault.
  static Config fromYaml(const std::filesystem::path& yaml);
  // A camera preset shipped with the library, by name: "tum_fr1" reads config/tum_fr1.yaml of the
  // data folders (see dataDirectory(); tum_fr1, tum_fr2, tum_fr3, bonn). Throws listing the places
  // looked at and the presets found when there is none of that name.
  static Config fromPreset(const std::string& name);
  // The same for a YAML document in memory; `name` stands for it in messages.
  static Config fromYamlString(const std::string& yaml, const std::string& name = "<config>");

  Config(const Config& other);
  Config& operator=(const Config& other);
  Config(Config&&) noexcept;
  Config& operator=(Config&&) noexcept;
  ~Config();

  // One "section.key=value" assignment, the value read as YAML (e.g. "dynamic.mode=off",
  // "camera.distortion=[0,0,0,0,0]"). Throws naming the assignment for an unknown key or a value
  // of the wrong type. Returns *this so that assignments chain.
  Config& set(const std::string& assignment);
  Config& set(const std::string& key, const std::string& value);
  // Throws naming the first option out of range (e.g. after several set() calls).
  void validate() const;
  // Every section and key with its value, as JSON text (what report.json's "settings" holds).
  std::string toJson() const;

  // The internal options (for the project's own programs; not part of the stable API).
  const SystemOptions& options() const;
  // A Config holding `options` (for the project's own programs, which assemble the options
  // themselves, e.g. with a bag's camera intrinsics; not part of the stable API).
  static Config fromOptions(const SystemOptions& options);

 private:
  explicit Config(std::unique_ptr<SystemOptions> options);
  std::unique_ptr<SystemOptions> options_;
};

struct RunMode {
  // Every stage waits for the one before it: two runs give identical trajectories.
  bool deterministic = false;
  // Frames come at the sensor's rate and tracking never waits for the network (a late mask is
  // carried forward along optical flow). Excludes `deterministic`.
  bool realtime = false;
  // Not empty: each frame is also written there (created if needed) as track()'s image_name, with
  // its mask overlaid and its features coloured static / stage-1 / stage-2 / in the mask.
  // (Every member has an initializer: a designated initializer that leaves some out, such as
  // {.deterministic = true}, then draws no -Wmissing-field-initializers.)
  std::filesystem::path debug_images_dir{};
  // Real time's late masks, offline (0 = off; excludes `realtime`): frame k uses the mask of the
  // newest frame s <= k - mask_latency_frames with s a multiple of mask_period_frames, carried
  // forward along optical flow. With `deterministic` they are reproducible, unlike real time's,
  // which depend on the CPU's load. Throws from Slam() for a latency < 0 or a period < 1.
  int mask_latency_frames = 0;
  int mask_period_frames = 1;
};

// How finish() ends a run that is being cut short, e.g. by a signal (both optional).
struct FinishOptions {
  // Called on finish()'s thread before each of its stages, by name: "mapping" (local mapping and
  // loop closing drain their queues), "final_ba" (the final global bundle adjustment; only when
  // mapping.final_global_ba is on and no worker thread failed) and "dense" (the dense thread
  // drains its queue). Returning false at "final_ba" skips it; the other stages always run.
  std::function<bool(const std::string& stage)> on_stage{};
  // Once *abort is true (from any thread, e.g. a signal handler's flag), a running global bundle
  // adjustment (a loop closure's or the final one) stops and the final one is not started.
  const std::atomic<bool>* abort = nullptr;
};

enum class TrackingState {
  kNotInitialised,  // no map has started yet (waiting for a frame with enough static features)
  kTracking,        // tracked against the map
  kPredicted,       // lost, but within tracking.predict_through_loss_s: the motion prediction is its pose
  kLost,            // no pose
};

// What track() found for one frame.
struct TrackResult {
  TrackingState state = TrackingState::kNotInitialised;
  // World-from-camera, in the world of map `map_id` (identity when the frame has no pose).
  Eigen::Matrix4d T_w_c = Eigen::Matrix4d::Identity();
  int map_id = -1;          // the atlas map whose world T_w_c is in (-1: no pose)
  // The same frame in the odometry frame (ROS REP 105's "odom"): continuous where T_w_c jumps (a new
  // map starts at the camera, a merge or a loop correction moves the world, a frame found again
  // after a loss leaves the prediction). Each frame follows the one before by the motion tracking
  // measured (or predicted) between them; across maps no merge has joined and from a predicted
  // frame to one found again, by the last velocity (for at most tracking.predict_through_loss_s).
  // It drifts and is never corrected: T_w_c * T_odom_c^-1 is T_w_odom, the odometry frame in map
  // map_id's world, as a robot's map -> odom transform. Identity when the frame has no pose.
  Eigen::Matrix4d T_odom_c = Eigen::Matrix4d::Identity();
  bool keyframe = false;    // the frame became a keyframe
  bool new_map = false;     // the frame started a map of the atlas
  int inliers = 0;          // map points that agreed with the pose
  bool hasPose() const { return state == TrackingState::kTracking || state == TrackingState::kPredicted; }
};

// A frame's pose: world-from-camera in the world of map `world_map_id`, the map that the map it was
// tracked in (`map_id`) has been merged into (or that map itself).
struct FramePose {
  double timestamp_s = 0;
  Eigen::Matrix4d T_w_c = Eigen::Matrix4d::Identity();
  int map_id = 0;
  int world_map_id = 0;
};

class Slam {
 public:
  // Starts every stage (loads the vocabulary and the segmentation model the config names).
  // Throws naming the option or file at fault.
  explicit Slam(const Config& config, const RunMode& mode = {});
  ~Slam();  // finishes the run if finish() was not called
  Slam(const Slam&) = delete;
  Slam& operator=(const Slam&) = delete;

  // Tracks one RGB-D frame. Frames must come in time order.
  //   bgr: CV_8UC3 (OpenCV's channel order); depth: CV_32FC1 metres, or CV_16UC1 raw sensor units
  //   (divided by the config's camera.depth_factor); 0 = no reading. Both of the config's size.
  //   Neither is modified; they may be reused once track() returns.
  //   depth_time_offset_s: how much later the depth image was taken than the colour image.
  //   image_name: the frame's name for debug images and the mask_dir segmenter (default: its index).
  // Throws for an image of the wrong type or size, and when a worker thread has failed.
  TrackResult track(double timestamp_s, const cv::Mat& bgr, const cv::Mat& depth, double depth_time_offset_s = 0,
                    const std::string& image_name = "");

  // Waits for mapping, runs the final global bundle adjustment (mapping.final_global_ba) and
  // stops the threads. Idempotent. The trajectories below follow the final keyframe poses.
  void finish();
  void finish(const FinishOptions& options);
  // Whether finish() ran the final global bundle adjustment to its end (false: off, skipped,
  // aborted, or finish() not called yet).
  bool finalBundleAdjustmentDone() const;

  // The frames of the main map (the map that, after all merges, holds the most frames).
  std::vector<FramePose> trajectory() const;
  // Every frame with a pose in any map.
  std::vector<FramePose> trajectoryAll() const;
  // Every keyframe of the atlas (map_id: its map).
  std::vector<FramePose> keyframeTrajectory() const;
  // Every frame that had a pose when track() returned, as TrackResult::T_odom_c gave it (map_id: the
  // map it was tracked in; world_map_id: -1, the odometry frame; writeTumTrajectory() writes it).
  // Not for an ATE: across a loss that started a map the motion is extrapolated, and the error of
  // that guess stays in every later pose (fr1_desk composites, 8 runs with 1-13 such steps: 0.10-1.07
  // m, where their main maps are within 0.025 m; the README's figures).
  std::vector<FramePose> odometryTrajectory() const;
  // The first three as TUM files, as `desslam run` writes them (CameraTrajectory.txt,
  // CameraTrajectory_all.txt with map_id and world_map_id after each pose, KeyFrameTrajectory.txt),
  // written atomically. They hold the run's own rotations: writeTumTrajectory(slam.trajectory())
  // recomputes each quaternion from the 4x4 matrix (the same rotation, possibly of the other sign).
  // Throw naming the file when it cannot be written.
  void writeTrajectory(const std::filesystem::path& file) const;
  void writeTrajectoryAll(const std::filesystem::path& file) const;
  void writeKeyframeTrajectory(const std::filesystem::path& file) const;

  // After finish(): writes the dense map (dense_map.ply, .pcd, dense_map_sources.bin, octomap.bt,
  // dense_map.png) into `directory` (created if needed). Returns what was written as JSON text; a
  // map without keyframes writes nothing ("exported": false and a "note" say so). Once *abort is
  // true (checked between files, e.g. a signal handler's flag), the files still to come are
  // skipped: all of them when it is true from the start ("exported": false, "note"), otherwise
  // the OctoMap and the PNG that follow the point cloud ("skipped" lists them); the OctoMap's ray
  // insertion, the one export that can take long, also looks at it while it runs (stops within a
  // fraction of a second). on_progress(file, share done 0..1), when given, is called from this
  // thread during that insertion, a few times a second or more. An OctoMap whose rays would cross
  // more than dense.octomap_max_ray_cells cells is written at a coarser resolution ("warnings"
  // says so, "octomap" gives the resolution used).
  std::string exportDenseMap(const std::filesystem::path& directory, bool semantic_colour = false,
                             const std::atomic<bool>* abort = nullptr,
                             const std::function<void(const std::string& file, double share)>& on_progress = {}) const;
  // Counts, timings and per-frame statistics as JSON text (report.json's "statistics").
  std::string statisticsJson() const;

  std::size_t framesProcessed() const;
  const Config& config() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace desslam
