// `desslam run <sequence-dir> --config <yaml> --out <dir>`: runs the SLAM system over a TUM-layout
// sequence and writes CameraTrajectory.txt, KeyFrameTrajectory.txt and report.json.
// The trajectory is also saved every few hundred frames and on Ctrl-C, so a long run never loses
// what it already computed.
#include <algorithm>
#include <atomic>
#include <cctype>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/core.hpp>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "commands.hpp"
#include "core/error.hpp"
#include "eval/evaluation.hpp"
#include "io/config.hpp"
#include "io/trajectory_io.hpp"
#include "io/tum_dataset.hpp"
#include "system/slam_system.hpp"

namespace desslam::app {
namespace {

struct RunArgs {
  std::string sequence;
  std::string config;
  std::string out = "results";
  bool deterministic = false;
  std::vector<std::string> overrides;
  size_t max_frames = 0;
  bool quiet = false;
  bool realtime = false;
  std::string dynamic_mode;  // empty: from the config
  std::string debug_images;
  std::string map_color = "rgb";
  std::string skip_frames;  // "FIRST-LAST" or empty
  int mask_latency = 0;     // --emulate-mask-latency
  int mask_period = 1;      // --emulate-mask-period
};

// Frames [first, last] (0-based indices into the paired frame list) withheld from the system.
struct SkippedFrames {
  size_t first = 0;
  size_t last = 0;
  bool contains(size_t i) const { return i >= first && i <= last; }
};

// Parses --skip-frames FIRST-LAST; throws InputError naming the option and the expected form.
std::optional<SkippedFrames> parseSkipFrames(const std::string& text) {
  if (text.empty()) return std::nullopt;
  const auto fail = [&text](const std::string& why) {
    return InputError("--skip-frames '" + text + "': " + why +
                      "; expected FIRST-LAST, two 0-based frame indices with FIRST <= LAST, e.g. --skip-frames 200-259");
  };
  const size_t dash = text.find('-');
  if (dash == std::string::npos) throw fail("no '-' between the two indices");
  const auto index = [&](const std::string& part) {
    if (part.empty() || part.size() > 12 ||
        !std::all_of(part.begin(), part.end(), [](unsigned char c) { return std::isdigit(c) != 0; }))
      throw fail("'" + part + "' is not a frame index");
    return static_cast<size_t>(std::stoull(part));
  };
  SkippedFrames skipped{index(text.substr(0, dash)), index(text.substr(dash + 1))};
  if (skipped.first > skipped.last) throw fail("FIRST is after LAST");
  return skipped;
}

constexpr size_t kCheckpointEvery = 200;  // frames between partial trajectory saves

std::atomic<bool> g_interrupted{false};
extern "C" void onInterrupt(int) { g_interrupted = true; }

void writeJson(const std::filesystem::path& path, const nlohmann::json& j) {
  const std::filesystem::path tmp = path.string() + ".tmp";
  {
    std::ofstream out(tmp);
    if (!out) throw InputError("cannot write " + path.string() + ": check that the --out folder is writable");
    out << j.dump(2) << "\n";
  }
  std::filesystem::rename(tmp, path);
}

void runSequence(const RunArgs& args) {
  const std::optional<SkippedFrames> skipped = parseSkipFrames(args.skip_frames);
  SystemOptions options = io::loadConfig(args.config);
  for (const std::string& assignment : args.overrides) io::applyOverride(options, assignment);
  if (!args.dynamic_mode.empty()) options.dynamic.mode = args.dynamic_mode;
  options.validate();
  // OpenCV's thread pool is process-wide; it mostly serves the network (DeepLab).
  cv::setNumThreads(options.semantic.threads);

  const io::TumSequence sequence = io::TumSequence::open(args.sequence);
  const std::filesystem::path out_dir(args.out);
  std::filesystem::create_directories(out_dir);
  const size_t frame_count = args.max_frames > 0 ? std::min(args.max_frames, sequence.size()) : sequence.size();
  if (skipped && skipped->first >= frame_count)
    throw InputError("--skip-frames " + args.skip_frames + ": the run has only " + std::to_string(frame_count) +
                     " frames (indices 0-" + std::to_string(frame_count - 1) + "); choose a range inside it");
  std::vector<size_t> input_index;  // per frame given to the system: its index in the sequence

  system::RunSettings settings;
  settings.deterministic = args.deterministic;
  settings.realtime = args.realtime;
  settings.debug_images_dir = args.debug_images;
  settings.mask_latency_frames = args.mask_latency;
  settings.mask_period_frames = args.mask_period;
  if (args.deterministic && args.realtime)
    throw ConfigError("--deterministic and --realtime exclude each other: real-time mode never waits for a stage");
  system::SlamSystem slam(options, settings);
  std::vector<double> lag_ms;  // real-time: how late each frame started relative to its sensor time

  g_interrupted = false;
  auto previous_handler = std::signal(SIGINT, onInterrupt);
  const auto start = std::chrono::steady_clock::now();
  auto last_progress = start;
  std::string stop_reason;
  for (size_t i = 0; i < frame_count; ++i) {
    if (g_interrupted) {
      stop_reason = "interrupted after " + std::to_string(i) + " frames";
      break;
    }
    if (skipped && skipped->contains(i)) continue;
    io::RgbdImage image;
    try {
      image = sequence.load(i, options.camera);
      if (input_index.empty()) io::checkDepthScale(image.depth, sequence.record(i).depth_path, options.camera.depth_factor);
    } catch (const InputError&) {
      // Keep what was computed, then report the bad input.
      slam.finish();
      io::writeTumTrajectory(out_dir / "CameraTrajectory.txt", slam.cameraTrajectory());
      throw;
    }
    if (args.realtime) {
      // Frames arrive at the sensor's rate: wait for this frame's time, never skip one.
      const double due_s = sequence.record(i).rgb_timestamp - sequence.record(0).rgb_timestamp;
      const double now_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      if (due_s > now_s) std::this_thread::sleep_for(std::chrono::duration<double>(due_s - now_s));
      lag_ms.push_back(std::max(0.0, now_s - due_s) * 1000.0);
    }
    const io::RgbdFrameRecord& record = sequence.record(i);
    input_index.push_back(i);
    slam.processFrame(image.timestamp, image.bgr, image.depth, record.rgb_path.filename().string(),
                      record.depth_timestamp - record.rgb_timestamp);

    if ((i + 1) % kCheckpointEvery == 0) io::writeTumTrajectory(out_dir / "CameraTrajectory.txt", slam.cameraTrajectory());
    const auto now = std::chrono::steady_clock::now();
    if (!args.quiet && (now - last_progress > std::chrono::milliseconds(500) || i + 1 == frame_count)) {
      last_progress = now;
      const double seconds = std::chrono::duration<double>(now - start).count();
      std::fprintf(stderr, "\r[%zu/%zu] %.1f frames/s  %s   ", i + 1, frame_count, (i + 1) / seconds,
                   slam.lastFrameTracked() ? "tracking" : "LOST    ");
      std::fflush(stderr);
    }
  }
  std::signal(SIGINT, previous_handler);
  if (!args.quiet) std::fprintf(stderr, "\n");
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  slam.finish();
  const Trajectory trajectory = slam.cameraTrajectory();
  io::writeTumTrajectory(out_dir / "CameraTrajectory.txt", trajectory);
  const AtlasTrajectory all_maps = slam.cameraTrajectoryAll();
  io::writeAtlasTrajectory(out_dir / "CameraTrajectory_all.txt", all_maps);
  io::writeTumTrajectory(out_dir / "KeyFrameTrajectory.txt", slam.keyframeTrajectory());

  nlohmann::json report;
  report["sequence"] = std::filesystem::absolute(args.sequence).string();
  report["config"] = args.config;
  report["overrides"] = args.overrides;
  report["settings"] = io::optionsToJson(options);
  report["settings"]["skip_frames"] =
      skipped ? nlohmann::json{{"first", skipped->first}, {"last", skipped->last}} : nlohmann::json(nullptr);
  report["settings"]["emulated_mask_latency"] =
      args.mask_latency > 0 ? nlohmann::json{{"frames", args.mask_latency}, {"period", args.mask_period}}
                            : nlohmann::json(nullptr);
  report["statistics"] = slam.statistics();
  // per_frame lists the frames the system got; with --skip-frames their sequence index differs.
  if (auto& per_frame = report["statistics"]["per_frame"]; per_frame.is_array())
    for (size_t k = 0; k < per_frame.size() && k < input_index.size(); ++k) per_frame[k]["input_index"] = input_index[k];
  report["wall_seconds"] = wall_s;
  report["frames_per_second"] = slam.framesProcessed() / std::max(wall_s, 1e-9);
  report["input_warnings"] = sequence.warnings();
  if (args.realtime) report["realtime_lag_ms"] = system::summarizeMilliseconds(lag_ms);
  report["dense"] = slam.exportDenseMap(out_dir, args.map_color == "semantic");
  if (!stop_reason.empty()) report["stopped"] = stop_reason;
  if (sequence.groundTruth() && trajectory.size() >= 3) {
    try {
      const eval::AteResult ate = eval::computeAte(*sequence.groundTruth(), trajectory);
      const eval::RpeResult rpe = eval::computeRpe(*sequence.groundTruth(), trajectory);
      report["ate"] = eval::toJson(ate);
      report["rpe"] = eval::toJson(rpe);
      // Share of frames (associated with ground truth) that got a pose.
      std::vector<StampedPose> frames;
      for (size_t i : input_index) frames.push_back({sequence.record(i).rgb_timestamp, SE3()});
      const size_t associated = eval::associate(*sequence.groundTruth(), frames).size();
      // Main map (what the ATE is over) and any map of the atlas.
      report["tracked_share_of_associated_frames"] =
          associated > 0 ? static_cast<double>(ate.matched) / associated : 0.0;
      Trajectory any_map;
      for (const AtlasPose& p : all_maps) any_map.push_back({p.timestamp, p.T_w_c});
      report["tracked_share_any_map"] =
          associated > 0 ? static_cast<double>(eval::associate(*sequence.groundTruth(), any_map).size()) / associated
                         : 0.0;
      if (!args.quiet) std::cout << eval::formatTable(ate, rpe, 0.02);
    } catch (const InputError& e) {
      report["evaluation_error"] = e.what();
    }
  }
  writeJson(out_dir / "report.json", report);
  if (!args.quiet) {
    const auto& stats = report["statistics"];
    std::cout << "frames " << stats["counts"]["frames"] << ", tracked " << stats["counts"]["frames_tracked"]
              << ", with a pose " << stats["counts"]["frames_with_pose"] << " (" << stats["counts"]["predicted_poses"]
              << " predicted)"
              << " (main map " << stats["atlas"]["frames_in_main_map"] << ", maps " << stats["atlas"]["maps"].size()
              << ", merges " << stats["atlas"]["merges"] << ")"
              << ", keyframes " << stats["counts"]["keyframes"] << ", map points " << stats["counts"]["map_points"]
              << "; tracking median " << stats["timings_ms"]["tracking"]["median"] << " ms/frame\n"
              << "wrote " << (out_dir / "CameraTrajectory.txt").string() << ", KeyFrameTrajectory.txt, report.json\n";
  }
}

}  // namespace

void registerRunCommand(CLI::App& app) {
  auto args = std::make_shared<RunArgs>();
  CLI::App* cmd = app.add_subcommand("run", "Run SLAM on an RGB-D sequence in TUM layout (rgb.txt, depth.txt, ...)");
  cmd->add_option("sequence", args->sequence, "Sequence folder (rgb/, depth/, rgb.txt, depth.txt[, groundtruth.txt])")
      ->required();
  cmd->add_option("--config,-c", args->config, "Camera/system YAML, e.g. config/tum_fr1.yaml")->required();
  cmd->add_option("--out,-o", args->out, "Output folder")->capture_default_str();
  cmd->add_flag("--deterministic", args->deterministic,
                "Every stage waits for the one before it: identical results on every run");
  cmd->add_option("--set", args->overrides, "Override a config key, e.g. --set tracking.max_depth=3.5 (repeatable)");
  cmd->add_option("--max-frames", args->max_frames, "Process only the first N frames (0 = all)");
  cmd->add_option("--skip-frames", args->skip_frames,
                  "FIRST-LAST: withhold frames FIRST..LAST (0-based indices into the paired frame list, both "
                  "included) from the system, a sudden jump for testing relocalisation; recorded in report.json "
                  "settings.skip_frames, per_frame[].input_index gives each processed frame's index");
  cmd->add_flag("--quiet,-q", args->quiet, "No progress line or summary");
  cmd->add_flag("--realtime", args->realtime,
                "Feed frames at the sensor's rate; tracking never waits for segmentation");
  cmd->add_option("--emulate-mask-latency", args->mask_latency,
                  "Offline: frame k uses the mask of the newest frame s <= k - N (s a multiple of "
                  "--emulate-mask-period), carried forward as in --realtime; with --deterministic, real time's "
                  "stale masks reproducibly")
      ->check(CLI::Range(0, 100));
  cmd->add_option("--emulate-mask-period", args->mask_period, "Offline: only every Nth frame's mask is used (see "
                  "--emulate-mask-latency)")
      ->check(CLI::Range(1, 100))
      ->capture_default_str();
  cmd->add_option("--dynamic", args->dynamic_mode,
                  "Dynamic-feature removal: off | semantic | geometric | full (default: config, full)")
      ->check(CLI::IsMember({"off", "semantic", "geometric", "full"}));
  cmd->add_option("--debug-images", args->debug_images,
                  "Write each frame with its mask and features coloured static/stage-1/stage-2 here");
  cmd->add_option("--map-color", args->map_color, "Dense map colours: rgb | semantic")
      ->check(CLI::IsMember({"rgb", "semantic"}))
      ->capture_default_str();
  cmd->callback([args] { runSequence(*args); });
}

}  // namespace desslam::app
