// What a run reads: a paired RGB-D sequence, frame by frame. Implemented by io::TumSequence (a
// TUM-layout folder) and bag::BagSequence (a ROS 1 bag, src/bag); bag::openSequence picks one by
// the path. Also the time association both use to pair the RGB and depth streams.
#pragma once

#include <array>
#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/camera_options.hpp"
#include "core/trajectory.hpp"
#include "core/types.hpp"

namespace desslam::io {

// A loaded pair.
struct RgbdImage {
  Timestamp timestamp = 0;  // the RGB timestamp
  cv::Mat bgr;              // CV_8UC3
  cv::Mat depth;            // CV_32F metres, 0 = no reading
};

// A camera calibration the input carries itself (a ROS bag's camera_info), for a config that
// leaves the intrinsics out.
struct InputCalibration {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  int width = 0, height = 0;
  std::array<double, 5> distortion{0, 0, 0, 0, 0};  // k1 k2 p1 p2 k3 (OpenCV order)
  std::string source;  // where it was read, for messages and report.json ("bag.bag topic /camera/rgb/camera_info")
};

class RgbdSequence {
 public:
  virtual ~RgbdSequence() = default;

  // Paired frames, sorted by RGB timestamp.
  virtual std::size_t size() const = 0;
  virtual Timestamp rgbTimestamp(std::size_t i) const = 0;
  virtual Timestamp depthTimestamp(std::size_t i) const = 0;  // of the depth frame paired with RGB frame i
  // A short name of frame i for logs and debug images (a folder's RGB file name).
  virtual std::string frameName(std::size_t i) const = 0;

  // Loads frame i, checked against `camera` (image size); throws InputError naming the source.
  virtual RgbdImage load(std::size_t i, const CameraOptions& camera) const = 0;

  // Ground truth (world-from-camera poses), when the input has it; see TumSequence.
  virtual const std::optional<Trajectory>& groundTruth() const = 0;
  virtual const std::string& groundTruthProblem() const = 0;
  // What was skipped or assumed while opening, for the run report.
  virtual std::vector<std::string> warnings() const = 0;

  // The input's own camera calibration (a bag's camera_info), for a config without intrinsics.
  // Throws InputError saying why when the input has none (a TUM folder never has).
  virtual InputCalibration calibration() const = 0;
  // What the input is, for messages: "TUM folder 'x'", "ROS bag 'x.bag'".
  virtual std::string description() const = 0;
};

// One RGB frame paired with one depth frame: indices into the two timestamp lists.
struct StreamPair {
  std::size_t rgb = 0;
  std::size_t depth = 0;
};

// Pairs every RGB timestamp with the nearest depth timestamp within max_dt, as TUM's
// associate.py: all candidate pairs within max_dt, taken greedily in order of increasing |dt|
// (equal |dt|: the earlier listed RGB frame first, then the earlier depth frame), so each frame of either stream is used at most
// once. Returns the pairs sorted by RGB timestamp (equal ones in list order); empty when none.
std::vector<StreamPair> associateByTime(const std::vector<Timestamp>& rgb, const std::vector<Timestamp>& depth,
                                        double max_dt);

// Ground truth a run can go without (ATE/RPE, the depth-scale check): a file that cannot be read
// or holds no poses gives `problem` (and a warning in `warnings`, also logged) instead of an error;
// its own warnings are added to `warnings` too.
struct OptionalGroundTruth {
  std::optional<Trajectory> trajectory;
  std::string problem;  // empty when read
};
OptionalGroundTruth readOptionalGroundTruth(const std::filesystem::path& file, std::vector<std::string>& warnings);

}  // namespace desslam::io
