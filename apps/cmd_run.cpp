// `desslam run <sequence-dir | file.bag> --config <yaml> --out <dir>`: runs the SLAM system, through
// the public API (desslam::Slam, include/desslam/desslam.hpp) as a library user would, over a
// TUM-layout sequence or a ROS 1 bag (bag/open_sequence.hpp) and writes CameraTrajectory.txt,
// CameraTrajectory_all.txt, KeyFrameTrajectory.txt, report.json and the dense map. Every file is
// written atomically (core/atomic_file.hpp); the trajectory is also saved every few hundred frames.
//
// SIGINT, SIGTERM and SIGHUP, from the start of the run to its last output: the first stops the
// frame loop at the next frame and the run ends as a normal one does (mapping drains, the final
// global BA is skipped, trajectories, dense map, report.json with "interrupted"), exit status
// 128 + signal; a second one also aborts a running global BA and skips the dense-map export. The
// handler only sets atomics; this thread looks at them between frames and stages.
//
// Any other failure during the run (bad frame, worker thread, unwritable output) also ends it with
// the outputs computed so far and report.json naming the error, when they can still be written.
#include <algorithm>
#include <atomic>
#include <cctype>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/core.hpp>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "api/pose_conversion.hpp"
#include "bag/open_sequence.hpp"
#include "commands.hpp"
#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/exit_codes.hpp"
#include "desslam/desslam.hpp"
#include "eval/evaluation.hpp"
#include "io/config.hpp"
#include "io/frame_prefetcher.hpp"
#include "io/timing_summary.hpp"
#include "plausibility/sequence_check.hpp"
#include "report/maps_apart.hpp"
#include "report/run_plots.hpp"
#include "report/trajectory_check.hpp"

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
  bool overwrite = false;   // --overwrite: replace an earlier run's outputs in --out
  bool force = false;       // --force: implausible input (depth scale) is a warning, not an error
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
constexpr size_t kFramesLoadedAhead = 3;  // decoded frames waiting for the tracker (about 2 MB each at 640x480)

// ---- signals ----------------------------------------------------------------------------------

constexpr int kStopSignals[] = {SIGINT, SIGTERM, SIGHUP};

// Written by the handler (any thread), read by the run's thread. Lock-free atomics are
// async-signal-safe; the handler does nothing else.
std::atomic<int> g_first_signal{0};   // the first stop signal's number (0: none yet)
std::atomic<int> g_signal_count{0};   // stop signals received
std::atomic<bool> g_skip_optional{false};  // a second signal: skip global BA and dense export
static_assert(std::atomic<int>::is_always_lock_free && std::atomic<bool>::is_always_lock_free,
              "the signal handler needs lock-free atomics");

extern "C" void onStopSignal(int signal_number) {
  int none = 0;
  g_first_signal.compare_exchange_strong(none, signal_number);  // set before the count is seen
  if (g_signal_count.fetch_add(1) >= 1) g_skip_optional.store(true);
}

const char* signalName(int signal_number) {
  switch (signal_number) {
    case SIGINT: return "SIGINT";
    case SIGTERM: return "SIGTERM";
    case SIGHUP: return "SIGHUP";
    default: return "signal";
  }
}

// Installs the stop handler for its lifetime (the whole run) and restores the previous ones.
class StopSignals {
 public:
  StopSignals() {
    g_first_signal = 0;
    g_signal_count = 0;
    g_skip_optional = false;
    struct sigaction action {};
    action.sa_handler = onStopSignal;
    sigemptyset(&action.sa_mask);
    action.sa_flags = SA_RESTART;  // writes and waits resume after the handler
    for (size_t k = 0; k < std::size(kStopSignals); ++k) sigaction(kStopSignals[k], &action, &previous_[k]);
  }
  ~StopSignals() {
    for (size_t k = 0; k < std::size(kStopSignals); ++k) sigaction(kStopSignals[k], &previous_[k], nullptr);
  }
  StopSignals(const StopSignals&) = delete;
  StopSignals& operator=(const StopSignals&) = delete;

 private:
  struct sigaction previous_[std::size(kStopSignals)] {};
};

// What the run's thread has seen of the signals, told on stderr once each.
struct Interruption {
  int signal = 0;    // first signal (0: not interrupted)
  int count = 0;     // signals seen so far
  std::string stage;        // what the run was doing when the first one was seen
  size_t next_frame = 0;    // index (in the sequence) of the first frame not read
  size_t frames_processed = 0;

  bool interrupted() const { return signal != 0; }
  // Looks at the handler's atomics; prints what changes. `stage`: what the run does now.
  void notice(const std::string& now_stage, size_t next_frame_index, size_t processed, size_t frame_count) {
    const int seen = g_signal_count.load();
    if (seen == count) return;
    if (count == 0) {
      signal = g_first_signal.load();
      stage = now_stage;
      next_frame = next_frame_index;
      frames_processed = processed;
      std::fprintf(stderr,
                   "\ninterrupted by %s (%d) during %s after %zu of %zu frames: finishing the run without the "
                   "final bundle adjustment (mapping drains, then trajectories, dense map, report.json); send "
                   "the signal again to skip the dense map too\n",
                   signalName(signal), signal, stage.c_str(), processed, frame_count);
    }
    if (seen >= 2 && count < 2)
      std::fprintf(stderr, "\nsecond signal during %s: skipping the remaining optional stages (global bundle "
                           "adjustment, dense-map export); writing trajectories and report.json\n",
                   now_stage.c_str());
    std::fflush(stderr);
    count = seen;
  }
};

// DESSLAM_HOLD_AT=stage[,stage...] (tests): at each named stage ("frame:N" after frame N, "mapping",
// "final_ba", "dense", "export", "report"; "octomap": at every progress report of the OctoMap's
// ray insertion) the run says so on stderr and waits for a signal (at most 60 s), so a test can
// signal it exactly there.
void holdIfAsked(const std::string& stage) {
  static const std::vector<std::string> stages = [] {
    std::vector<std::string> list;
    const char* env = std::getenv("DESSLAM_HOLD_AT");
    std::string text = env != nullptr ? env : "";
    for (size_t begin = 0; begin <= text.size();) {
      const size_t end = std::min(text.find(',', begin), text.size());
      if (end > begin) list.push_back(text.substr(begin, end - begin));
      begin = end + 1;
    }
    return list;
  }();
  if (std::find(stages.begin(), stages.end(), stage) == stages.end()) return;
  const int seen = g_signal_count.load();
  std::fprintf(stderr, "\nholding at %s until a signal (DESSLAM_HOLD_AT)\n", stage.c_str());
  std::fflush(stderr);
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (g_signal_count.load() == seen && std::chrono::steady_clock::now() < until)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
}

// ---- the output folder ------------------------------------------------------------------------

// Every file `run` writes into --out (only these are ever removed by --overwrite).
constexpr const char* kRunOutputs[] = {"CameraTrajectory.txt", "CameraTrajectory_all.txt", "KeyFrameTrajectory.txt",
                                       "report.json",          "dense_map.ply",            "dense_map.pcd",
                                       "dense_map_sources.bin", "octomap.bt",              "dense_map.png"};
// Those that show an earlier run used the folder.
constexpr const char* kRunMarkers[] = {"report.json", "CameraTrajectory.txt", "CameraTrajectory_all.txt",
                                       "KeyFrameTrajectory.txt"};

// Refuses a folder holding an earlier run's outputs unless --overwrite (then removes exactly the
// files a run writes, and temporary files a killed run left), then checks it can be written.
void prepareOutputFolder(const std::filesystem::path& out_dir, bool overwrite) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::is_directory(out_dir, ec)) {
    std::vector<std::string> earlier;
    for (const char* name : kRunMarkers)
      if (fs::exists(out_dir / name, ec)) earlier.push_back(name);
    if (!earlier.empty() && !overwrite)
      throw InputError("--out " + out_dir.string() + " holds the outputs of an earlier run (" + earlier.front() +
                       "): pass --overwrite to replace them, or choose another --out folder");
    if (overwrite) {
      std::vector<fs::path> remove;
      std::vector<std::string> names(std::begin(kRunOutputs), std::end(kRunOutputs));
      for (const std::string& id : report::runPlotIds()) names.push_back(id + ".svg");  // and `desslam report`'s page
      names.push_back("report.html");
      for (const std::string& name : names)
        if (fs::is_regular_file(fs::symlink_status(out_dir / name, ec)) || fs::is_symlink(out_dir / name, ec))
          remove.push_back(out_dir / name);
      for (const fs::directory_entry& entry : fs::directory_iterator(out_dir, ec))
        if (isAtomicTempName(entry.path().filename().string()) && entry.is_regular_file(ec)) remove.push_back(entry.path());
      for (const fs::path& file : remove) {
        fs::remove(file, ec);
        if (ec) throw OutputError("--overwrite: cannot remove " + file.string() + ": " + ec.message());
      }
    }
  }
  requireWritableFolder(out_dir, "--out folder");
}

// ---- errors during the run ---------------------------------------------------------------------

// The first error of the run (later ones are consequences) and its exit status.
struct RunError {
  std::string message;
  int code = exit_code::kOk;
  explicit operator bool() const { return code != exit_code::kOk; }
  void record(const std::exception& e) {
    if (*this) return;
    message = e.what();
    code = exitCodeFor(e);
  }
};

// Runs `step`; an exception becomes the run's error instead of ending it.
template <class Step>
void attempt(RunError& error, Step&& step) {
  try {
    step();
  } catch (const std::exception& e) {
    error.record(e);
  }
}

void writeJson(const std::filesystem::path& path, const nlohmann::json& j) {
  writeFileAtomically(path, j.dump(2) + "\n", "report");
}

// Why a run tracked no frame, from the per-frame keypoint counts (statistics' "per_frame"):
// too few keypoints with depth (camera covered, wrong depth scale), too few of them left once the
// dynamic features were removed (masks covering the view), or too little spread to start a map.
std::string nothingTrackedMessage(const nlohmann::json& per_frame, const SystemOptions& options, size_t frame_count) {
  if (per_frame.empty()) return "nothing was tracked: no frame was processed (of " + std::to_string(frame_count) + ")";
  const int needed = options.atlas.min_initial_features;
  size_t enough = 0, enough_static = 0;
  int best = 0;
  const nlohmann::json* best_static = &per_frame.front();  // the frame that kept the most
  for (const nlohmann::json& f : per_frame) {
    const int with_depth = f["features_with_depth"].get<int>();
    const int kept = f["static_with_depth"].get<int>();
    enough += with_depth >= needed ? 1 : 0;
    enough_static += kept >= needed ? 1 : 0;
    best = std::max(best, with_depth);
    if (kept > (*best_static)["static_with_depth"].get<int>()) best_static = &f;
  }
  std::ostringstream msg;
  msg << "nothing was tracked: " << enough << " of " << per_frame.size() << " frames had " << needed
      << " or more keypoints with valid depth (atlas.min_initial_features, needed to start a map; the best frame had "
      << best << ")";
  if (enough == 0) {
    msg << ": is the camera covered, is camera.depth_factor right (" << options.camera.depth_factor
        << " depth-image units per metre), does tracking.min_depth/max_depth (" << options.tracking.min_depth << "-"
        << options.tracking.max_depth << " m) cover the scene?";
  } else if (enough_static == 0) {
    // Before a map has started, stage 1 and 2 have nothing to compare with: the masks took them.
    const nlohmann::json& f = *best_static;
    const int checks = f["stage1_removed"].get<int>() + f["stage2_removed"].get<int>();
    msg << ", but none kept " << needed << " once the dynamic features were removed (dynamic.mode "
        << nameOf(options.dynamic.mode) << "): in the frame that kept the most, all but "
        << f["static_with_depth"].get<int>() << " of its " << f["features_with_depth"].get<int>()
        << " lay in the dynamic-object masks";
    if (checks > 0) msg << " or failed the depth checks (stage 1 and 2 removed " << checks << ")";
    if (options.semantic.segmenter == SegmenterKind::kMaskDir) {
      msg << ": are the masks in semantic.mask_dir (" << options.semantic.mask_dir
          << ") right (nonzero = dynamic), or is the view covered by people?";
    } else {
      std::string classes;
      for (const int c : options.semantic.dynamic_classes) classes += (classes.empty() ? "" : ", ") + std::to_string(c);
      msg << ": is semantic.dynamic_classes right ([" << classes << "]; 15 = person), or is the view covered by people?";
    }
  } else {
    if (enough_static < enough) msg << ", " << enough_static << " of them with enough outside the dynamic masks";
    msg << ", but none started a map: are the keypoints spread over at least atlas.min_initial_cells ("
        << options.atlas.min_initial_cells << ") cells of a 4 x 4 grid?";
  }
  return msg.str();
}

int runSequence(const RunArgs& args) {
  const StopSignals stop_signals;  // from here to the last output
  const std::optional<SkippedFrames> skipped = parseSkipFrames(args.skip_frames);
  io::ConfigForInput config = io::loadConfigForInput(args.config);
  SystemOptions& options = config.options;
  for (const std::string& assignment : args.overrides) io::applyOverride(options, assignment);
  if (!args.dynamic_mode.empty()) io::applyOverride(options, "dynamic.mode=" + args.dynamic_mode);
  // Intrinsics from the input (a bag's camera_info) only when neither the config nor --set gives them.
  const CameraOptions& given = options.camera;
  const bool intrinsics_from_input =
      !config.intrinsics_given && given.fx == 0 && given.fy == 0 && given.cx == 0 && given.cy == 0;
  if (!intrinsics_from_input) options.validate();

  const std::unique_ptr<io::RgbdSequence> opened = bag::openSequence(args.sequence, options.bag);
  const io::RgbdSequence& sequence = *opened;
  std::string intrinsics_source = "config";
  if (intrinsics_from_input) {
    io::InputCalibration calibration;
    try {
      calibration = sequence.calibration();
    } catch (const InputError& e) {
      throw ConfigError("config " + args.config + " has no camera intrinsics (camera.fx, fy, cx, cy), and the input "
                        "cannot give them: " + e.what());
    }
    io::useInputCalibration(options.camera, calibration);
    intrinsics_source = calibration.source;
    std::fprintf(stderr, "camera intrinsics from %s (the config has none)\n", intrinsics_source.c_str());
    options.validate();
  }
  // OpenCV's thread pool is process-wide; it mostly serves the network (DeepLab).
  cv::setNumThreads(options.semantic.threads);
  const std::filesystem::path out_dir(args.out);
  const size_t frame_count = args.max_frames > 0 ? std::min(args.max_frames, sequence.size()) : sequence.size();
  if (skipped && skipped->first >= frame_count)
    throw InputError("--skip-frames " + args.skip_frames + ": the run has only " + std::to_string(frame_count) +
                     " frames (indices 0-" + std::to_string(frame_count - 1) + "); choose a range inside it");
  if (args.deterministic && args.realtime)
    throw ConfigError("--deterministic and --realtime exclude each other: real-time mode never waits for a stage");
  prepareOutputFolder(out_dir, args.overwrite);
  nlohmann::json plausibility_report = {{"enabled", options.plausibility.enabled}};
  if (options.plausibility.enabled && frame_count > 0) {
    const plausibility::CheckResult check =
        plausibility::checkSequence(sequence, options.camera, options.plausibility, frame_count);
    plausibility_report.update(check.toJson());
    plausibility_report["forced"] = args.force && check.hasError();
    if (check.hasError() && !args.force) throw ConfigError(check.firstError());
    for (const plausibility::Finding& finding : check.findings) {
      if (finding.error)
        std::fprintf(stderr,
                     "\n*** WARNING (--force): continuing although the input looks wrong ***\n%s\n"
                     "*** the trajectory and map will be in the wrong scale if this is right ***\n\n",
                     finding.message.c_str());
      else
        std::fprintf(stderr, "warning: %s\n", finding.message.c_str());
    }
    std::fflush(stderr);
  }
  std::vector<size_t> input_index;  // per frame given to the system: its index in the sequence

  RunMode mode;
  mode.deterministic = args.deterministic;
  mode.realtime = args.realtime;
  mode.debug_images_dir = args.debug_images;
  mode.mask_latency_frames = args.mask_latency;
  mode.mask_period_frames = args.mask_period;
  Slam slam(Config::fromOptions(options), mode);
  std::vector<double> lag_ms;  // real-time: how late each frame started relative to its sensor time

  Interruption interruption;
  RunError error;
  const auto notice = [&](const std::string& stage, size_t next_frame) {
    interruption.notice(stage, next_frame, slam.framesProcessed(), frame_count);
  };
  const auto start = std::chrono::steady_clock::now();
  auto last_progress = start;
  size_t next_frame = 0;  // index of the first frame not read
  attempt(error, [&] {
    // Frames are decoded ahead on a thread of their own, as a camera driver delivers them: in
    // real time decoding does not eat into the frame period, and offline it overlaps processing.
    std::vector<size_t> to_load;
    for (size_t i = 0; i < frame_count; ++i)
      if (!(skipped && skipped->contains(i))) to_load.push_back(i);
    io::FramePrefetcher prefetcher(sequence, options.camera, std::move(to_load), kFramesLoadedAhead);
    for (size_t i = 0; i < frame_count; ++i) {
      next_frame = i;
      notice("the frame loop", i);
      if (interruption.interrupted()) return;
      if (skipped && skipped->contains(i)) continue;
      io::RgbdImage image = prefetcher.take(i);
      if (args.realtime) {
        // Frames arrive at the sensor's rate: wait for this frame's time, never skip one.
        const double due_s = sequence.rgbTimestamp(i) - sequence.rgbTimestamp(0);
        const double now_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        if (due_s > now_s) std::this_thread::sleep_for(std::chrono::duration<double>(due_s - now_s));
        lag_ms.push_back(std::max(0.0, now_s - due_s) * 1000.0);
      }
      input_index.push_back(i);
      const TrackResult tracked = slam.track(image.timestamp, image.bgr, image.depth,
                                             sequence.depthTimestamp(i) - sequence.rgbTimestamp(i), sequence.frameName(i));
      next_frame = i + 1;

      if ((i + 1) % kCheckpointEvery == 0)
        slam.writeTrajectory(out_dir / "CameraTrajectory.txt");
      const auto now = std::chrono::steady_clock::now();
      if (!args.quiet && (now - last_progress > std::chrono::milliseconds(500) || i + 1 == frame_count)) {
        last_progress = now;
        const double seconds = std::chrono::duration<double>(now - start).count();
        std::fprintf(stderr, "\r[%zu/%zu] %.1f frames/s  %s   ", i + 1, frame_count, (i + 1) / seconds,
                     tracked.state == TrackingState::kTracking ? "tracking" : "LOST    ");
        std::fflush(stderr);
      }
      holdIfAsked("frame:" + std::to_string(i));
    }
    next_frame = frame_count;
  });
  if (!args.quiet) std::fprintf(stderr, "\n");
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  // Finish: mapping drains; the final BA only when not interrupted; a second signal aborts a
  // running global BA.
  FinishOptions finish;
  finish.abort = &g_skip_optional;
  finish.on_stage = [&](const std::string& stage) {
    notice(stage, next_frame);
    holdIfAsked(stage);
    notice(stage, next_frame);
    return !(stage == "final_ba" && interruption.interrupted());
  };
  attempt(error, [&] { slam.finish(finish); });

  // Outputs: each attempted even when an earlier one failed (a trajectory may still fit).
  attempt(error, [&] { slam.writeTrajectory(out_dir / "CameraTrajectory.txt"); });
  attempt(error, [&] { slam.writeTrajectoryAll(out_dir / "CameraTrajectory_all.txt"); });
  attempt(error, [&] { slam.writeKeyframeTrajectory(out_dir / "KeyFrameTrajectory.txt"); });
  Trajectory trajectory;  // the main map's, for the evaluation and the plots
  attempt(error, [&] { trajectory = api::toTrajectory(slam.trajectory(), "trajectory"); });

  nlohmann::json report;
  report["sequence"] = std::filesystem::absolute(args.sequence).string();
  report["config"] = args.config;
  report["overrides"] = args.overrides;
  report["settings"] = io::optionsToJson(options);
  report["settings"]["camera_intrinsics_from"] = intrinsics_source;
  report["settings"]["skip_frames"] =
      skipped ? nlohmann::json{{"first", skipped->first}, {"last", skipped->last}} : nlohmann::json(nullptr);
  report["settings"]["emulated_mask_latency"] =
      args.mask_latency > 0 ? nlohmann::json{{"frames", args.mask_latency}, {"period", args.mask_period}}
                            : nlohmann::json(nullptr);
  report["statistics"] = nlohmann::json::parse(slam.statisticsJson());
  // per_frame lists the frames the system got; with --skip-frames their sequence index differs.
  if (auto& per_frame = report["statistics"]["per_frame"]; per_frame.is_array())
    for (size_t k = 0; k < per_frame.size() && k < input_index.size(); ++k) per_frame[k]["input_index"] = input_index[k];
  report["wall_seconds"] = wall_s;
  report["frames_per_second"] = slam.framesProcessed() / std::max(wall_s, 1e-9);
  report["input_warnings"] = sequence.warnings();
  report["plausibility"] = plausibility_report;
  if (args.realtime) report["realtime_lag_ms"] = io::summarizeMilliseconds(lag_ms);
  notice("export", next_frame);
  holdIfAsked("export");
  notice("export", next_frame);
  if (error.code == exit_code::kOutputError) {
    report["dense"] = {{"exported", false}, {"note", "skipped: an earlier output could not be written"}};
  } else {
    // The OctoMap can take long (a fine dense.octomap_resolution on a large map): a signal is
    // acknowledged at once, a second one stops it (g_skip_optional), and after a second a
    // progress line shows how far it is.
    const auto export_start = std::chrono::steady_clock::now();
    auto last_line = export_start;
    bool progress_shown = false;
    const auto on_progress = [&](const std::string& file, double share) {
      notice("export", next_frame);
      holdIfAsked("octomap");
      notice("export", next_frame);
      const auto now = std::chrono::steady_clock::now();
      if (args.quiet || now - export_start < std::chrono::seconds(1) ||
          (progress_shown && now - last_line < std::chrono::milliseconds(500)))
        return;
      last_line = now;
      progress_shown = true;
      std::fprintf(stderr, "\rexporting the dense map: %s %.0f %% (%.0f s)   ", file.c_str(), 100.0 * share,
                   std::chrono::duration<double>(now - export_start).count());
      std::fflush(stderr);
    };
    attempt(error, [&] {
      report["dense"] = nlohmann::json::parse(
          slam.exportDenseMap(out_dir, args.map_color == "semantic", &g_skip_optional, on_progress));
    });
    if (progress_shown) std::fprintf(stderr, "\n");
  }
  if (report["dense"].contains("note")) std::fprintf(stderr, "note: dense map: %s\n", report["dense"]["note"].get<std::string>().c_str());
  if (report["dense"].contains("warnings"))
    for (const nlohmann::json& warning : report["dense"]["warnings"])
      std::fprintf(stderr, "warning: dense map: %s\n", warning.get<std::string>().c_str());
  if (sequence.groundTruth() && trajectory.size() < 3) {
    report["evaluation_error"] = "the main map's trajectory has " + std::to_string(trajectory.size()) +
                                 (trajectory.size() == 1 ? " pose" : " poses") + ", too few: ATE needs at least 3";
  } else if (sequence.groundTruth()) {
    try {
      const eval::AteResult ate = eval::computeAte(*sequence.groundTruth(), trajectory);
      const eval::RpeResult rpe = eval::computeRpe(*sequence.groundTruth(), trajectory);
      report["ate"] = eval::toJson(ate);
      report["rpe"] = eval::toJson(rpe);
      // Share of frames (associated with ground truth) that got a pose.
      std::vector<StampedPose> frames;
      for (size_t i : input_index) frames.push_back({sequence.rgbTimestamp(i), SE3()});
      const size_t associated = eval::associate(*sequence.groundTruth(), frames).size();
      // Main map (what the ATE is over) and any map of the atlas.
      report["tracked_share_of_associated_frames"] =
          associated > 0 ? static_cast<double>(ate.matched) / associated : 0.0;
      const Trajectory any_map = api::toTrajectory(slam.trajectoryAll(), "trajectory of every map");
      report["tracked_share_any_map"] =
          associated > 0 ? static_cast<double>(eval::associate(*sequence.groundTruth(), any_map).size()) / associated
                         : 0.0;
      if (!args.quiet) std::cout << eval::formatTable(ate, rpe, 0.02);
    } catch (const InputError& e) {
      report["evaluation_error"] = e.what();
    }
  }
  // Where the ATE table would be, why there is none (a run without a pose says why itself).
  if (!args.quiet && report.contains("evaluation_error") && !trajectory.empty())
    std::cout << "ATE/RPE          n/a: " << report["evaluation_error"].get<std::string>() << "\n";
  notice("report", next_frame);
  holdIfAsked("report");
  notice("report", next_frame);
  const nlohmann::json& counts = report["statistics"]["counts"];
  // (An error or an interruption says itself why little was tracked.)
  const bool nothing_tracked = !error && !interruption.interrupted() && counts["frames_with_pose"].get<size_t>() == 0;
  report["interrupted"] = interruption.interrupted();
  if (interruption.interrupted())
    report["interruption"] = {{"signal", signalName(interruption.signal)},
                              {"signal_number", interruption.signal},
                              {"signals", interruption.count},
                              {"stage", interruption.stage},
                              {"next_frame_index", interruption.next_frame},
                              {"frames_processed", interruption.frames_processed},
                              {"frames_in_run", frame_count},
                              {"final_global_ba", slam.finalBundleAdjustmentDone() ? "done" : "skipped"},
                              {"optional_stages_skipped", g_skip_optional.load()}};
  if (error) report["error"] = error.message;
  if (nothing_tracked)
    report["nothing_tracked"] = nothingTrackedMessage(report["statistics"]["per_frame"], options, frame_count);
  // Frames tracked in maps that no merge joined to the main map are in no evaluated trajectory:
  // "with a pose" below counts them, so the user is told where they are.
  const std::optional<std::string> maps_apart = report::mapsApartWarning(report["statistics"]);
  if (maps_apart) report["warnings"].push_back(*maps_apart);
  // Jumps in what the run hands over, which tracking's own gate cannot see (report/trajectory_check.hpp).
  std::vector<report::WorldPose> world_poses;
  for (const FramePose& p : slam.trajectoryAll())
    world_poses.push_back({p.timestamp_s, p.T_w_c.topRightCorner<3, 1>(), p.world_map_id});
  const report::FastSteps fast_steps = report::findFastSteps(std::move(world_poses), options.tracking.max_speed_m_s);
  report["trajectory_check"] = report::toJson(fast_steps);
  const std::optional<std::string> fast_steps_warning = report::fastStepsWarning(fast_steps);
  if (fast_steps_warning) report["warnings"].push_back(*fast_steps_warning);
  const int code = error                          ? error.code
                   : interruption.interrupted()   ? exit_code::interrupted(interruption.signal)
                   : nothing_tracked              ? exit_code::kNothingTracked
                                                  : exit_code::kOk;
  report["exit_code"] = code;
  // The plots beside report.json (`desslam report` remakes them with the HTML page). They only
  // picture what the run computed, so failing to draw them is a warning, not the run's status.
  if (error.code != exit_code::kOutputError) {
    try {
      const Trajectory* gt = sequence.groundTruth() ? &*sequence.groundTruth() : nullptr;
      const std::string no_gt = sequence.groundTruthProblem().empty() ? "the sequence has no groundtruth.txt"
                                                                       : sequence.groundTruthProblem();
      const report::RunPlots plots = report::makeRunPlots(report, trajectory, gt, no_gt);
      report::writeRunPlots(out_dir, plots);
      report["plots"] = report::toJson(plots);
    } catch (const std::exception& e) {
      report["plots"] = {{"error", e.what()}};
      std::fprintf(stderr, "warning: plots not written: %s (run `desslam report %s` to retry)\n", e.what(),
                   out_dir.string().c_str());
    }
  }
  RunError report_error;
  attempt(report_error, [&] { writeJson(out_dir / "report.json", report); });
  if (!args.quiet && !error && !report_error) {
    const auto& stats = report["statistics"];
    std::cout << "frames " << stats["counts"]["frames"] << ", tracked " << stats["counts"]["frames_tracked"]
              << ", with a pose " << stats["counts"]["frames_with_pose"] << " (" << stats["counts"]["predicted_poses"]
              << " predicted)"
              << " (main map " << stats["atlas"]["frames_in_main_map"] << ", maps " << stats["atlas"]["maps"].size()
              << ", merges " << stats["atlas"]["merges"] << ")"
              << ", keyframes " << stats["counts"]["keyframes"] << ", map points " << stats["counts"]["map_points"]
              << "; tracking median " << std::fixed << std::setprecision(1)
              << stats["timings_ms"]["tracking"]["median"].get<double>() << std::defaultfloat << " ms/frame\n"
              << "wrote " << (out_dir / "CameraTrajectory.txt").string()
              << ", CameraTrajectory_all.txt, KeyFrameTrajectory.txt, report.json\n";
  }
  if (maps_apart && !report_error) {
    std::cout.flush();  // after the summary, also when both streams go to one file
    std::fprintf(stderr, "warning: %s\n", maps_apart->c_str());
  }
  if (fast_steps_warning && !report_error) {
    std::cout.flush();
    std::fprintf(stderr, "warning: %s\n", fast_steps_warning->c_str());
  }
  if (error) std::fprintf(stderr, "error: %s\n", error.message.c_str());
  if (report_error) std::fprintf(stderr, "error: %s\n", report_error.message.c_str());
  if (nothing_tracked) std::fprintf(stderr, "%s\n", report["nothing_tracked"].get<std::string>().c_str());
  if (interruption.interrupted())
    std::fprintf(stderr, "interrupted by %s after %zu of %zu frames: outputs written to %s (exit status %d)\n",
                 signalName(interruption.signal), interruption.frames_processed, frame_count, out_dir.string().c_str(),
                 code);
  return report_error && !error ? report_error.code : code;
}

}  // namespace

void registerRunCommand(CLI::App& app) {
  auto args = std::make_shared<RunArgs>();
  CLI::App* cmd = app.add_subcommand("run", "Run SLAM on an RGB-D sequence in TUM layout (rgb.txt, depth.txt, ...) or "
                                            "a ROS 1 bag");
  cmd->add_option("sequence", args->sequence,
                  "Sequence folder (rgb/, depth/, rgb.txt, depth.txt[, groundtruth.txt]) or ROS 1 bag (.bag; topics: "
                  "config section bag)")
      ->required();
  cmd->add_option("--config,-c", args->config, "Camera/system YAML, e.g. config/tum_fr1.yaml")->required();
  cmd->add_option("--out,-o", args->out, "Output folder")->capture_default_str();
  cmd->add_flag("--deterministic", args->deterministic,
                "Every stage waits for the one before it: identical results on every run");
  cmd->add_option("--set", args->overrides, "Override a config key, e.g. --set tracking.max_depth=3.5 (repeatable)");
  cmd->add_option("--max-frames", args->max_frames, "Process only the first N frames (0 = all)")
      ->check(CLI::Range(static_cast<size_t>(0), static_cast<size_t>(1) << 40));
  cmd->add_option("--skip-frames", args->skip_frames,
                  "FIRST-LAST: withhold frames FIRST..LAST (0-based indices into the paired frame list, both "
                  "included) from the system, a sudden jump for testing relocalisation; recorded in report.json "
                  "settings.skip_frames, per_frame[].input_index gives each processed frame's index");
  cmd->add_flag("--quiet,-q", args->quiet, "No progress line or summary");
  cmd->add_flag("--realtime", args->realtime,
                "Feed frames at the sensor's rate; tracking waits for segmentation only briefly (a frame ends at "
                "most half a frame period late)");
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
      ->check(CLI::IsMember(enumNameList<DynamicMode>()));
  cmd->add_option("--debug-images", args->debug_images,
                  "Write each frame with its mask and features coloured static/stage-1/stage-2 here");
  cmd->add_option("--map-color", args->map_color, "Dense map colours: rgb | semantic")
      ->check(CLI::IsMember({"rgb", "semantic"}))
      ->capture_default_str();
  cmd->add_flag("--overwrite", args->overwrite,
                "Reuse an --out folder that holds an earlier run's outputs: removes the files a run writes "
                "(trajectories, report.json, dense map) first, never other files");
  cmd->add_flag("--force", args->force,
                "Continue when the input looks wrong (camera.depth_factor against the ground truth or the depth "
                "range): the error becomes a loud warning and report.json says plausibility.forced");
  cmd->callback([args] {
    const int code = runSequence(*args);
    if (code != exit_code::kOk) throw ExitStatus{code};
  });
}

}  // namespace desslam::app
