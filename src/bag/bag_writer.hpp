// Writes an RGB-D sequence as a ROS 1 bag in the layout of the TUM RGB-D bags, with the rosbag
// storage library: the tests' bags (the same frames as a folder, to compare the two inputs) and
// bags for checking a ROS set-up by hand.
#pragma once

#include <cstddef>
#include <filesystem>
#include <memory>
#include <string>

#include "bag/bag_options.hpp"
#include "bag/ros_messages.hpp"
#include "core/camera_options.hpp"
#include "io/rgbd_sequence.hpp"

namespace desslam::bag {

// A sensor_msgs/Image holding `pixels` (rows copied densely: step = width x pixel size), and a
// CameraInfo of `camera` (K and D as plumb_bob from it, R identity, P = K|0).
RosImage imageMessage(const cv::Mat& pixels, const std::string& encoding, RosTime stamp, std::uint32_t seq = 0,
                      const std::string& frame_id = "");
RosCameraInfo cameraInfoMessage(const CameraOptions& camera, RosTime stamp, std::uint32_t seq = 0,
                                const std::string& frame_id = "");

// Messages into a new bag at `file` (written in place; writeBag below writes atomically). Each
// message's record time is its header stamp. Throws OutputError naming the file.
class BagWriter {
 public:
  BagWriter(const std::filesystem::path& file, bool bz2_chunks);
  ~BagWriter();
  BagWriter(const BagWriter&) = delete;
  BagWriter& operator=(const BagWriter&) = delete;

  void write(const std::string& topic, const RosImage& image);
  void write(const std::string& topic, const RosCameraInfo& info);
  void close();  // writes the index; the destructor closes too (without reporting errors)

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

struct BagWriteOptions {
  BagOptions topics;                // where the images and camera_info go
  bool depth_millimetres = false;   // 16UC1 millimetres (rounded) instead of 32FC1 metres
  bool bz2_chunks = true;           // TUM's bags: bz2-compressed chunks
  bool camera_info = true;          // one sensor_msgs/CameraInfo per RGB frame, from `camera`
  std::size_t max_frames = 0;       // the first N paired frames (0: all)
};

// Frame i's RGB goes out as rgb8 stamped rgbTimestamp(i), its depth stamped depthTimestamp(i)
// (header stamp = record time, nanoseconds rounded). 32FC1 keeps the loaded float metres exactly
// (0 becomes NaN, the ROS "no reading"), so a bag reads back bit-identical to its source.
// camera_info: K and D from camera (fx, fy, cx, cy, distortion as plumb_bob), R identity, P = K|0.
// Written atomically (core/atomic_file.hpp). Throws the sequence's InputError, OutputError.
void writeBag(const io::RgbdSequence& sequence, const CameraOptions& camera, const std::filesystem::path& file,
              const BagWriteOptions& options = {});

}  // namespace desslam::bag
