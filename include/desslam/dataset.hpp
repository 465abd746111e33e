// Reading recorded sequences and trajectory files in the TUM RGB-D formats.
//
//   const desslam::TumDataset dataset = desslam::TumDataset::open("data/fr1_xyz");
//   for (std::size_t i = 0; i < dataset.size(); ++i) {
//     const desslam::RgbdFrame f = dataset.load(i, config);
//     slam.track(f.timestamp_s, f.bgr, f.depth_m, f.depth_time_offset_s, f.image_name);
//   }
//
// That loop feeds a Slam exactly what `desslam run` does. Errors are thrown as std::runtime_error
// naming the folder or file at fault.
#pragma once

#include <cstddef>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "desslam/desslam.hpp"

namespace desslam::io {
class TumSequence;  // internal (src/io/tum_dataset.hpp)
}

namespace desslam {

// One associated RGB/depth pair as listed (nothing loaded).
struct RgbdFrameInfo {
  double timestamp_s = 0;        // the RGB image's
  double depth_timestamp_s = 0;  // the depth image's (its own clock)
  std::filesystem::path rgb_path, depth_path;
};

// A loaded pair.
struct RgbdFrame {
  double timestamp_s = 0;          // the RGB image's
  double depth_time_offset_s = 0;  // how much later the depth image was taken
  cv::Mat bgr;                     // CV_8UC3, OpenCV's channel order
  cv::Mat depth_m;                 // CV_32FC1 metres (raw / camera.depth_factor), 0 = no reading
  std::string image_name;          // the RGB file's name (what `desslam run` passes to track())
};

// A sequence folder in the TUM layout (TUM RGB-D, Bonn RGB-D Dynamic): rgb/, depth/, rgb.txt,
// depth.txt ("timestamp filename" per line), optionally groundtruth.txt. RGB and depth are
// paired by nearest timestamp within max_dt, one to one, as TUM's associate.py does; listed
// files that do not exist are skipped (warnings() says which).
class TumDataset {
 public:
  static TumDataset open(const std::filesystem::path& directory, double max_dt = 0.02);
  TumDataset(const TumDataset&);
  TumDataset& operator=(const TumDataset&);
  TumDataset(TumDataset&&) noexcept;
  TumDataset& operator=(TumDataset&&) noexcept;
  ~TumDataset();

  std::size_t size() const;
  const std::vector<RgbdFrameInfo>& frames() const { return frames_; }
  // Loads frame i; the images must have the size of the config's camera, depth is divided by its
  // camera.depth_factor. Throws naming the file when it is unreadable or of the wrong kind.
  RgbdFrame load(std::size_t i, const Config& config) const;

  // groundtruth.txt's poses when the folder has one that could be read (map ids 0).
  std::optional<std::vector<FramePose>> groundTruth() const;
  // Why groundtruth.txt could not be read (empty when it was, or when there is none).
  std::string groundTruthProblem() const;
  // What was skipped while opening.
  std::vector<std::string> warnings() const;
  const std::filesystem::path& directory() const;

 private:
  explicit TumDataset(std::unique_ptr<io::TumSequence> sequence);
  std::unique_ptr<io::TumSequence> sequence_;
  std::vector<RgbdFrameInfo> frames_;
};

// TUM trajectory files: "timestamp tx ty tz qx qy qz qw" per line, world-from-camera.
// Reading throws naming the file and line of a malformed pose; map ids are 0.
std::vector<FramePose> readTumTrajectory(const std::filesystem::path& path);
// Six decimals for timestamps, nine for pose values (as `desslam run` writes them), written
// atomically. Throws when a T_w_c is not a rigid transform or the file cannot be written.
void writeTumTrajectory(const std::filesystem::path& path, const std::vector<FramePose>& trajectory);

}  // namespace desslam
