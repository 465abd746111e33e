// RGB-D sequences in the TUM layout (TUM RGB-D, Bonn RGB-D Dynamic): rgb/, depth/, rgb.txt and
// depth.txt ("timestamp filename" per line, '#' comments), optional groundtruth.txt.
// RGB and depth are separate streams with their own clocks; frames are paired by timestamp
// (io::associateByTime).
#pragma once

#include <cstddef>
#include <filesystem>
#include <istream>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/camera_options.hpp"
#include "core/trajectory.hpp"
#include "core/types.hpp"
#include "io/rgbd_sequence.hpp"

namespace desslam::io {

// One associated RGB/depth pair, as listed (nothing loaded yet).
struct RgbdFrameRecord {
  Timestamp rgb_timestamp = 0;
  Timestamp depth_timestamp = 0;
  std::filesystem::path rgb_path;    // absolute or relative to the working directory
  std::filesystem::path depth_path;
};

class TumSequence : public RgbdSequence {
 public:
  // Reads rgb.txt/depth.txt (and groundtruth.txt if present); pairs each RGB with the nearest depth
  // within max_dt (as TUM's associate.py: greedy by smallest |dt|, one-to-one), sorted by time.
  // Listed files that do not exist are skipped with one spdlog warning each.
  // Throws InputError naming the folder/file for: missing folder, missing rgb.txt/depth.txt,
  // malformed line, empty list, no pairs within max_dt ("timestamps do not match: ...").
  static TumSequence open(const std::filesystem::path& dir, double max_dt = 0.02);

  std::size_t size() const override { return records_.size(); }
  const RgbdFrameRecord& record(std::size_t i) const { return records_.at(i); }
  Timestamp rgbTimestamp(std::size_t i) const override { return record(i).rgb_timestamp; }
  Timestamp depthTimestamp(std::size_t i) const override { return record(i).depth_timestamp; }
  std::string frameName(std::size_t i) const override { return record(i).rgb_path.filename().string(); }
  std::string description() const override { return "TUM folder '" + directory_.string() + "'"; }
  // A TUM folder carries no calibration: throws InputError (the config must give the intrinsics).
  InputCalibration calibration() const override;
  const std::vector<RgbdFrameRecord>& records() const { return records_; }
  const std::filesystem::path& directory() const { return directory_; }

  // Loads frame i. Throws InputError naming the file: unreadable/corrupt PNG, depth not 16-bit
  // single channel, size differs from camera width/height, RGB not 8-bit 3-channel.
  // Depth is converted to metres with camera.depth_factor.
  RgbdImage load(std::size_t i, const CameraOptions& camera) const override;

  // Ground truth (world-from-marker/camera poses) when groundtruth.txt exists and could be read.
  // A malformed groundtruth.txt does not stop open(): a run does not need it (it is left out,
  // with a warning, and groundTruthProblem() says why); commands that need it throw that.
  const std::optional<Trajectory>& groundTruth() const override { return ground_truth_; }
  const std::string& groundTruthProblem() const override { return ground_truth_problem_; }
  // What was skipped while opening, for the run report.
  std::vector<std::string> warnings() const override { return warnings_; }

 private:
  std::filesystem::path directory_;
  std::vector<RgbdFrameRecord> records_;
  std::optional<Trajectory> ground_truth_;
  std::string ground_truth_problem_;
  std::vector<std::string> warnings_;
};

// One line of a "timestamp filename" list (rgb.txt, depth.txt).
struct TimestampListEntry {
  Timestamp timestamp = 0;
  std::string file;  // as listed (relative to the list's folder)
  int line = 0;      // 1-based line in the list
};

// Parses a "timestamp filename" list ('#' comments, blank lines); `name` names it in messages.
// Throws InputError "name:line: ..." for a malformed line or a non-finite timestamp. Ties (the
// same timestamp on several lines) are kept; each is reported in `warnings` (when given) naming
// the file and the lines.
std::vector<TimestampListEntry> parseTimestampList(std::istream& in, const std::string& name,
                                                   std::vector<std::string>* warnings = nullptr);

// A raw depth image (as read from a PNG) in metres (raw / camera.depth_factor, 0 = no reading).
// Throws InputError naming `file` unless it is 16-bit single channel of the camera's size.
cv::Mat depthToMetres(const cv::Mat& raw, const std::filesystem::path& file, const CameraOptions& camera);

// Wrong depth scale guard, for the first frames: throws InputError naming `file` when the median
// valid depth is implausible for an indoor RGB-D camera (< 0.1 m or > 20 m), suggesting to check
// camera.depth_factor. An image without any valid reading is not judged.
void checkDepthScale(const cv::Mat& depth_m, const std::filesystem::path& file, double depth_factor);

}  // namespace desslam::io
