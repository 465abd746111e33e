// The public API (include/desslam/desslam.hpp) over the internal pipeline (system::SlamSystem).
#include "desslam/desslam.hpp"

#include <opencv2/core.hpp>

#include <algorithm>
#include <system_error>

#include "core/data_location.hpp"
#include "core/error.hpp"
#include "io/config.hpp"
#include "io/trajectory_io.hpp"
#include "place/vocabulary_location.hpp"
#include "system/slam_system.hpp"
#include "system/system_options.hpp"

#ifndef DESSLAM_VERSION
#error "DESSLAM_VERSION must be defined by the build (src/api/CMakeLists.txt)"
#endif

namespace desslam {

std::string version() { return DESSLAM_VERSION; }

std::filesystem::path dataDirectory() {
  std::vector<std::filesystem::path> tried;
  const std::filesystem::path vocabulary = place::resolveVocabularyPath("", &tried);
  if (vocabulary.empty()) {
    throw ConfigError("DeS-SLAM's data folder (share/desslam) not found: no default vocabulary at" +
                      listPaths(tried) +
                      "\nReinstall the library (cmake --install), or set DESSLAM_DATA_DIR to its share/desslam");
  }
  return vocabulary.parent_path().parent_path();  // <data>/vocab/<file>
}

// ---- Config ----

Config::Config(std::unique_ptr<SystemOptions> options) : options_(std::move(options)) {}
Config::Config(const Config& other) : options_(std::make_unique<SystemOptions>(*other.options_)) {}
Config& Config::operator=(const Config& other) {
  if (this != &other) options_ = std::make_unique<SystemOptions>(*other.options_);
  return *this;
}
Config::Config(Config&&) noexcept = default;
Config& Config::operator=(Config&&) noexcept = default;
Config::~Config() = default;

Config Config::fromYaml(const std::filesystem::path& yaml) {
  return Config(std::make_unique<SystemOptions>(io::loadConfig(yaml)));
}

Config Config::fromPreset(const std::string& name) {
  if (name.empty() || name.find_first_of("/\\.") != std::string::npos) {
    throw ConfigError("camera preset '" + name + "': give a preset name such as tum_fr1 (use Config::fromYaml for a file)");
  }
  const std::vector<std::filesystem::path> directories = dataDirectories();
  std::vector<std::filesystem::path> tried;
  const std::filesystem::path yaml = findDataFile(std::filesystem::path("config") / (name + ".yaml"), directories, &tried);
  if (yaml.empty()) {
    std::vector<std::string> presets;
    for (const std::filesystem::path& directory : directories) {
      std::error_code ec;
      for (const auto& entry : std::filesystem::directory_iterator(directory / "config", ec)) {
        if (entry.path().extension() == ".yaml") presets.push_back(entry.path().stem().string());
      }
    }
    std::sort(presets.begin(), presets.end());
    presets.erase(std::unique(presets.begin(), presets.end()), presets.end());
    std::string known;
    for (const std::string& preset : presets) known += (known.empty() ? "" : ", ") + preset;
    throw ConfigError("camera preset '" + name + "' not found; looked at:" + listPaths(tried) +
                      "\nPresets found: " + (known.empty() ? std::string("none") : known) +
                      " (set DESSLAM_DATA_DIR to the installed share/desslam if it was moved)");
  }
  return fromYaml(yaml);
}

Config Config::fromYamlString(const std::string& yaml, const std::string& name) {
  return Config(std::make_unique<SystemOptions>(io::loadConfigFromString(yaml, name)));
}

Config& Config::set(const std::string& assignment) {
  io::applyOverride(*options_, assignment);
  return *this;
}

Config& Config::set(const std::string& key, const std::string& value) { return set(key + "=" + value); }

void Config::validate() const { options_->validate(); }

std::string Config::toJson() const {
  SystemOptions copy = *options_;  // optionsToJson's visitors need a mutable struct
  return io::optionsToJson(copy).dump(2);
}

const SystemOptions& Config::options() const { return *options_; }

Config Config::fromOptions(const SystemOptions& options) { return Config(std::make_unique<SystemOptions>(options)); }

// ---- Slam ----

namespace {

Eigen::Matrix4d toMatrix(const SE3& pose) { return pose.matrix(); }

std::vector<FramePose> toFramePoses(const AtlasTrajectory& trajectory) {
  std::vector<FramePose> out;
  out.reserve(trajectory.size());
  for (const AtlasPose& p : trajectory) out.push_back({p.timestamp, toMatrix(p.T_w_c), p.map, p.world_map});
  return out;
}

system::RunSettings toSettings(const RunMode& mode) {
  if (mode.deterministic && mode.realtime)
    throw ConfigError("RunMode: deterministic and realtime exclude each other (real-time mode never waits for a stage)");
  system::RunSettings settings;
  settings.deterministic = mode.deterministic;
  settings.realtime = mode.realtime;
  settings.debug_images_dir = mode.debug_images_dir;
  settings.mask_latency_frames = mode.mask_latency_frames;
  settings.mask_period_frames = mode.mask_period_frames;
  return settings;
}

}  // namespace

struct Slam::Impl {
  Impl(const Config& config, const RunMode& mode)
      : config(config), system((config.validate(), config.options()), toSettings(mode)) {}
  Config config;
  system::SlamSystem system;
};

Slam::Slam(const Config& config, const RunMode& mode) : impl_(std::make_unique<Impl>(config, mode)) {}

Slam::~Slam() {
  if (!impl_) return;
  try {
    impl_->system.finish();
  } catch (...) {
    // A worker's failure was already thrown from track() or finish(); a destructor must not throw.
  }
}

TrackResult Slam::track(double timestamp_s, const cv::Mat& bgr, const cv::Mat& depth, double depth_time_offset_s,
                        const std::string& image_name) {
  const CameraOptions& camera = impl_->config.options().camera;
  const auto size_text = [](const cv::Mat& m) { return std::to_string(m.cols) + "x" + std::to_string(m.rows); };
  const std::string expected = std::to_string(camera.width) + "x" + std::to_string(camera.height);
  if (bgr.type() != CV_8UC3)
    throw InputError("Slam::track: the colour image must be CV_8UC3 (BGR, 8 bits per channel)");
  if (bgr.cols != camera.width || bgr.rows != camera.height)
    throw InputError("Slam::track: the colour image is " + size_text(bgr) + " but camera.width/height say " + expected);
  if (depth.cols != camera.width || depth.rows != camera.height)
    throw InputError("Slam::track: the depth image is " + size_text(depth) + " but camera.width/height say " + expected);
  // The pipeline keeps each frame's depth image (later frames' depth checks read the last frame's
  // and the reference keyframe's), so it gets a buffer of its own: the caller may reuse or free
  // its image once track() returns (a numpy array, a driver's buffer, a cv::Mat over user memory).
  cv::Mat depth_m;
  if (depth.type() == CV_16UC1) {
    depth.convertTo(depth_m, CV_32F, 1.0 / camera.depth_factor);
  } else if (depth.type() == CV_32FC1) {
    depth_m = depth.clone();
  } else {
    throw InputError("Slam::track: the depth image must be CV_32FC1 (metres) or CV_16UC1 (raw units, divided by "
                     "camera.depth_factor)");
  }
  system::SlamSystem& system = impl_->system;
  const std::string name =
      image_name.empty() ? std::to_string(system.framesProcessed()) + ".png" : image_name;
  system.processFrame(timestamp_s, bgr, depth_m, name, depth_time_offset_s);

  const system::FrameStats& stats = system.frameStats().back();
  TrackResult result;
  result.keyframe = stats.keyframe;
  result.new_map = stats.new_map;
  result.inliers = stats.inliers;
  if (stats.tracked)
    result.state = TrackingState::kTracking;
  else if (stats.predicted)
    result.state = TrackingState::kPredicted;
  else
    result.state = system.initialised() ? TrackingState::kLost : TrackingState::kNotInitialised;
  if (result.hasPose()) {
    if (const std::optional<AtlasPose> pose = system.lastFramePose()) {
      result.T_w_c = toMatrix(pose->T_w_c);
      result.map_id = pose->world_map;
    }
    if (const std::optional<SE3> T_odom_c = system.lastOdometryPose()) result.T_odom_c = toMatrix(*T_odom_c);
  }
  return result;
}

void Slam::finish() { impl_->system.finish(); }

void Slam::finish(const FinishOptions& options) { impl_->system.finish({options.abort, options.on_stage}); }

bool Slam::finalBundleAdjustmentDone() const { return impl_->system.finalBundleAdjustmentDone(); }

std::vector<FramePose> Slam::trajectory() const {
  std::vector<FramePose> out;
  for (const FramePose& p : toFramePoses(impl_->system.cameraTrajectoryAll()))
    if (p.world_map_id == impl_->system.mainMap()) out.push_back(p);
  return out;
}

std::vector<FramePose> Slam::trajectoryAll() const { return toFramePoses(impl_->system.cameraTrajectoryAll()); }

std::vector<FramePose> Slam::keyframeTrajectory() const {
  return toFramePoses(impl_->system.keyframeTrajectoryAll());
}

std::vector<FramePose> Slam::odometryTrajectory() const {
  return toFramePoses(impl_->system.odometryTrajectory());
}

void Slam::writeTrajectory(const std::filesystem::path& file) const {
  io::writeTumTrajectory(file, impl_->system.cameraTrajectory());
}

void Slam::writeTrajectoryAll(const std::filesystem::path& file) const {
  io::writeAtlasTrajectory(file, impl_->system.cameraTrajectoryAll());
}

void Slam::writeKeyframeTrajectory(const std::filesystem::path& file) const {
  io::writeTumTrajectory(file, impl_->system.keyframeTrajectory());
}

std::string Slam::exportDenseMap(const std::filesystem::path& directory, bool semantic_colour,
                                 const std::atomic<bool>* abort,
                                 const std::function<void(const std::string& file, double share)>& on_progress) const {
  std::filesystem::create_directories(directory);
  return impl_->system.exportDenseMap(directory, semantic_colour, abort, on_progress).dump(2);
}

std::string Slam::statisticsJson() const { return impl_->system.statistics().dump(2); }

std::size_t Slam::framesProcessed() const { return impl_->system.framesProcessed(); }

const Config& Slam::config() const { return impl_->config; }

}  // namespace desslam
