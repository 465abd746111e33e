// A ROS 1 bag as an RGB-D sequence (the TUM RGB-D bags: rgbd_dataset_freiburg1_xyz.bag, ...),
// read with Debian's rosbag storage library; no ROS master, no ROS message packages.
//
// Topics (BagOptions, config section `bag`): RGB sensor_msgs/Image rgb8 or bgr8; depth
// sensor_msgs/Image 32FC1 (metres; NaN = no reading) or 16UC1 (millimetres, REP 118; 0 = no
// reading). camera.depth_factor is for PNG folders and does not apply: the encoding fixes the
// unit. camera_info (sensor_msgs/CameraInfo) gives the calibration when the config has none.
// Frames are stamped with the messages' header stamps (the bag's record time when a stamp is 0)
// and paired as for folders (io::associateByTime). Ground truth: "<stem>-groundtruth.txt" (TUM's
// name) or "groundtruth.txt" beside the bag, when there is one.
//
// open() reads every RGB and depth message once, for its header stamp, and keeps only the
// messages' positions in the bag; load(i) reads frame i again. So the sequence is never held in
// memory (a TUM bag is ~1 GB), at the price of decompressing it twice in a run.
#pragma once

#include <cstddef>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "bag/bag_options.hpp"
#include "core/camera_options.hpp"
#include "io/rgbd_sequence.hpp"

namespace desslam::bag {

class BagSequence : public io::RgbdSequence {
 public:
  // Throws InputError naming the file and the fix for: no such file, not a ROS 1 bag, a topic of
  // `topics` missing (the message lists the bag's topics and their types) or of another type,
  // a message that is not of its topic's type, no RGB/depth pair within max_dt.
  static BagSequence open(const std::filesystem::path& file, const BagOptions& topics, double max_dt = 0.02);

  BagSequence(BagSequence&&) noexcept;
  BagSequence& operator=(BagSequence&&) noexcept;
  ~BagSequence() override;

  std::size_t size() const override;
  Timestamp rgbTimestamp(std::size_t i) const override;
  Timestamp depthTimestamp(std::size_t i) const override;
  std::string frameName(std::size_t i) const override;  // the RGB stamp, "1305031102.175304"
  // Reads and decodes frame i (safe from several threads: the bag is read under a lock). Throws
  // InputError naming the bag, the topic and the stamp for: an unsupported encoding (RGB: rgb8,
  // bgr8; depth: 32FC1, 16UC1), big-endian depth, a size other than camera.width x camera.height,
  // a row step shorter than a row.
  io::RgbdImage load(std::size_t i, const CameraOptions& camera) const override;
  const std::optional<Trajectory>& groundTruth() const override;
  const std::string& groundTruthProblem() const override;
  std::vector<std::string> warnings() const override;
  // From the first message on topics.camera_info_topic: fx, fy, cx, cy from K, width, height,
  // distortion (plumb_bob k1 k2 t1 t2 k3; an empty D is none). Throws InputError naming the bag
  // and the topic when there is none (listing the topics) or it cannot be used.
  io::InputCalibration calibration() const override;
  std::string description() const override;

  const std::filesystem::path& file() const;

 private:
  struct Impl;
  explicit BagSequence(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace desslam::bag
