// Helpers for the end-to-end tests: synthetic TUM-layout sequences with exact ground truth,
// a config file for the synthetic camera, and running the desslam binary with its output
// captured.
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <thread>
#include <utility>
#include <vector>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "core/trajectory.hpp"
#include "io/tum_dataset.hpp"
#include "sim/camera_path.hpp"
#include "sim/synthetic_scene.hpp"
#include "system/slam_system.hpp"
#include "system/system_options.hpp"

namespace desslam::test {

// Writes `frames` frames of the default static textured room along sim::sweepPath at the
// synthetic camera's rate (rgb/, depth/, rgb.txt, depth.txt, groundtruth.txt).
inline void writeSyntheticSequence(const std::filesystem::path& dir, int frames) {
  const CameraOptions camera = sim::syntheticCamera();
  const sim::SyntheticScene scene(sim::SceneOptions{}, camera);
  sim::writeSequence(dir, scene, sim::sweepPath(frames, camera.fps), camera, /*write_masks=*/false);
}

// Options for the static synthetic scenes: the synthetic camera, no segmentation network (nothing
// moves, and the tests must not depend on the model file), no dense map (not checked here).
inline SystemOptions syntheticSystemOptions() {
  SystemOptions options;
  options.camera = sim::syntheticCamera();
  options.semantic.segmenter = SegmenterKind::kNone;
  options.dynamic.mode = DynamicMode::kGeometric;
  options.dense.enabled = false;
  return options;
}

// The same settings as a YAML config for the binary; `extra` is appended verbatim (more sections).
inline std::string syntheticConfigYaml(const std::string& extra = "") {
  const CameraOptions c = sim::syntheticCamera();
  std::ostringstream yaml;
  yaml.precision(17);
  yaml << "camera:\n"
       << "  fx: " << c.fx << "\n  fy: " << c.fy << "\n  cx: " << c.cx << "\n  cy: " << c.cy << "\n"
       << "  width: " << c.width << "\n  height: " << c.height << "\n"
       << "  distortion: [0, 0, 0, 0, 0]\n"
       << "  depth_factor: " << c.depth_factor << "\n  fps: " << c.fps << "\n"
       << "semantic:\n  segmenter: none\n"
       << "dynamic:\n  mode: geometric\n"
       << "dense:\n  enabled: false\n"
       << extra;
  return yaml.str();
}

inline std::string readText(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Single-quoted for /bin/sh (paths here never contain a single quote, but be safe).
inline std::string shellQuote(const std::string& s) {
  std::string out = "'";
  for (char c : s) {
    if (c == '\'')
      out += "'\\''";
    else
      out += c;
  }
  return out + "'";
}

struct CommandResult {
  int exit_code = -1;     // the process's exit status; 128 + signal when it was killed
  bool signaled = false;  // crashed (segfault, abort) rather than exiting
  std::string out, err;
};

// Runs `command` with /bin/sh, stdout and stderr captured through files in `scratch`.
inline CommandResult runCommand(const std::string& command, const std::filesystem::path& scratch) {
  std::filesystem::create_directories(scratch);
  const auto out_file = scratch / "stdout.txt", err_file = scratch / "stderr.txt";
  const std::string full =
      command + " >" + shellQuote(out_file.string()) + " 2>" + shellQuote(err_file.string()) + " </dev/null";
  const int status = std::system(full.c_str());
  CommandResult r;
  if (status != -1 && WIFEXITED(status)) {
    r.exit_code = WEXITSTATUS(status);
    // sh reports a child killed by a signal as 128 + signal.
    r.signaled = r.exit_code > 128 && r.exit_code < 160;
  } else if (status != -1 && WIFSIGNALED(status)) {
    r.exit_code = 128 + WTERMSIG(status);
    r.signaled = true;
  }
  r.out = readText(out_file);
  r.err = readText(err_file);
  return r;
}

// A child process started with stdout and stderr in files (for signalling it while it runs).
struct ChildProcess {
  pid_t pid = -1;
  std::filesystem::path out_file, err_file;

  // Waits until stderr contains `text` (`times` times: true) or the child ended or timeout_s
  // passed (false).
  bool waitForStderr(const std::string& text, double timeout_s = 120, size_t times = 1) const {
    const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (std::chrono::steady_clock::now() < until) {
      const std::string err = readText(err_file);
      size_t found = 0;
      for (size_t at = err.find(text); at != std::string::npos; at = err.find(text, at + text.size())) ++found;
      if (found >= times) return true;
      siginfo_t info{};
      if (::waitid(P_PID, static_cast<id_t>(pid), &info, WEXITED | WNOHANG | WNOWAIT) == 0 && info.si_pid == pid)
        return false;  // ended (and left to wait() to reap)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return false;
  }
  void signal(int signal_number) const { ::kill(pid, signal_number); }
  // Waits for the child (killed after timeout_s) and returns its status and output.
  CommandResult wait(double timeout_s = 120) const {
    const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    int status = 0;
    pid_t done = 0;
    while ((done = ::waitpid(pid, &status, WNOHANG)) == 0 && std::chrono::steady_clock::now() < until)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    if (done == 0) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
    }
    CommandResult r;
    if (WIFEXITED(status)) r.exit_code = WEXITSTATUS(status);
    if (WIFSIGNALED(status)) {
      r.exit_code = 128 + WTERMSIG(status);
      r.signaled = true;
    }
    r.out = readText(out_file);
    r.err = readText(err_file);
    if (done == 0) r.err += "\n[test: killed after " + std::to_string(timeout_s) + " s]";
    return r;
  }
};

// Starts argv[0] with the arguments argv[1..] (no shell) and `env` added to the environment.
inline ChildProcess spawnProcess(const std::vector<std::string>& argv, const std::filesystem::path& scratch,
                                 const std::vector<std::pair<std::string, std::string>>& env = {}) {
  std::filesystem::create_directories(scratch);
  ChildProcess child;
  child.out_file = scratch / "stdout.txt";
  child.err_file = scratch / "stderr.txt";
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const std::string out = child.out_file.string(), err = child.err_file.string();
  child.pid = ::fork();
  if (child.pid == 0) {
    const int out_fd = ::open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int err_fd = ::open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int null_fd = ::open("/dev/null", O_RDONLY);
    if (out_fd < 0 || err_fd < 0 || null_fd < 0) ::_exit(126);
    ::dup2(null_fd, 0);
    ::dup2(out_fd, 1);
    ::dup2(err_fd, 2);
    for (const auto& [name, value] : env) ::setenv(name.c_str(), value.c_str(), 1);
    ::execv(args[0], args.data());
    ::_exit(127);
  }
  return child;
}

#ifdef DESSLAM_BINARY
inline std::string desslamBinary() { return DESSLAM_BINARY; }
#endif

// Runs the whole sequence through system::SlamSystem in deterministic mode.
struct RunResult {
  Trajectory camera;
  Trajectory keyframes;
  nlohmann::json statistics;
  size_t frames = 0;
};

// `max_frames`: only the first N (0: all).
inline RunResult runOver(const io::RgbdSequence& sequence, const SystemOptions& options, size_t max_frames = 0) {
  system::RunSettings settings;
  settings.deterministic = true;
  system::SlamSystem slam(options, settings);
  const size_t count = max_frames > 0 ? std::min(max_frames, sequence.size()) : sequence.size();
  for (size_t i = 0; i < count; ++i) {
    const io::RgbdImage image = sequence.load(i, options.camera);
    slam.processFrame(image.timestamp, image.bgr, image.depth, sequence.frameName(i));
  }
  slam.finish();
  return {slam.cameraTrajectory(), slam.keyframeTrajectory(), slam.statistics(), slam.framesProcessed()};
}

}  // namespace desslam::test
