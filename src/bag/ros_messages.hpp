// The two ROS 1 messages a TUM RGB-D bag carries for us, in their serialized (wire) form:
// sensor_msgs/Image and sensor_msgs/CameraInfo. Decoded and encoded here by hand because the
// generated ROS message headers do not compile as C++20 on Debian bookworm (and are not packaged
// with rosbag_storage); both layouts are short and fixed by the message definitions below.
//
// ROS 1 serialization: little-endian integers and floats; a string or a variable-length array is
// a uint32 length followed by its elements; a fixed-length array (float64[9]) has no length.
// std_msgs/Header: uint32 seq, time stamp (uint32 sec, uint32 nsec), string frame_id.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace desslam::bag {

struct RosTime {
  std::uint32_t sec = 0;
  std::uint32_t nsec = 0;
  double toSeconds() const { return static_cast<double>(sec) + static_cast<double>(nsec) * 1e-9; }
  bool isZero() const { return sec == 0 && nsec == 0; }
  // The nearest representable time (seconds >= 0; nsec rounded, carried into sec at 1e9).
  static RosTime fromSeconds(double seconds);
};

struct RosHeader {
  std::uint32_t seq = 0;
  RosTime stamp;
  std::string frame_id;
};

// sensor_msgs/Image. `data` holds `height` rows of `step` bytes.
struct RosImage {
  RosHeader header;
  std::uint32_t height = 0, width = 0;
  std::string encoding;  // "rgb8", "bgr8", "32FC1", "16UC1", ...
  std::uint8_t is_bigendian = 0;
  std::uint32_t step = 0;  // bytes per row
  std::vector<std::uint8_t> data;
};

// sensor_msgs/CameraInfo (the fields a pinhole camera needs, and the rest to round-trip).
struct RosCameraInfo {
  RosHeader header;
  std::uint32_t height = 0, width = 0;
  std::string distortion_model;    // "plumb_bob": D = k1 k2 t1 t2 k3 (OpenCV's order)
  std::vector<double> D;
  std::array<double, 9> K{};       // row-major 3x3: fx 0 cx; 0 fy cy; 0 0 1
  std::array<double, 9> R{};
  std::array<double, 12> P{};
  std::uint32_t binning_x = 0, binning_y = 0;
  std::uint32_t roi_x_offset = 0, roi_y_offset = 0, roi_height = 0, roi_width = 0;
  bool roi_do_rectify = false;
};

// Type names, MD5 sums and full definitions as ROS publishes them (what a bag's connection
// records carry; the MD5 sums identify the layouts above).
struct RosMessageType {
  const char* datatype;
  const char* md5sum;
  const char* definition;
};
extern const RosMessageType kImageType;
extern const RosMessageType kCameraInfoType;

// Decoders: throw InputError "<context>: ..." when the bytes do not hold a whole message of that
// layout (truncated, lengths past the end, trailing bytes), and for an Image whose data is shorter
// than height * step.
RosImage decodeImage(const std::uint8_t* bytes, std::size_t size, const std::string& context);
RosCameraInfo decodeCameraInfo(const std::uint8_t* bytes, std::size_t size, const std::string& context);

std::vector<std::uint8_t> encodeImage(const RosImage& image);
std::vector<std::uint8_t> encodeCameraInfo(const RosCameraInfo& info);

}  // namespace desslam::bag
