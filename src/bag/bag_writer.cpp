#include "bag/bag_writer.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>
#include <rosbag/bag.h>
#include <rosbag/exceptions.h>
#include <ros/message_traits.h>
#include <ros/serialization.h>

#include "bag/ros_messages.hpp"
#include "core/atomic_file.hpp"
#include "core/error.hpp"

namespace desslam::bag {
namespace {

// A message already in its wire form, with its type: what rosbag::Bag::write is given. (The
// generated sensor_msgs classes would do the same, but do not build as C++20 here.)
struct SerializedMessage {
  const RosMessageType* type;
  std::vector<std::uint8_t> bytes;
};

}  // namespace
}  // namespace desslam::bag

// rosbag::Bag::write asks these traits for the connection record and the payload.
namespace ros::message_traits {
template <>
struct MD5Sum<desslam::bag::SerializedMessage> {
  static const char* value(const desslam::bag::SerializedMessage& m) { return m.type->md5sum; }
};
template <>
struct DataType<desslam::bag::SerializedMessage> {
  static const char* value(const desslam::bag::SerializedMessage& m) { return m.type->datatype; }
};
template <>
struct Definition<desslam::bag::SerializedMessage> {
  static const char* value(const desslam::bag::SerializedMessage& m) { return m.type->definition; }
};
}  // namespace ros::message_traits

namespace ros::serialization {
template <>
struct Serializer<desslam::bag::SerializedMessage> {
  template <typename Stream>
  static void write(Stream& stream, const desslam::bag::SerializedMessage& m) {
    if (!m.bytes.empty()) std::memcpy(stream.advance(static_cast<std::uint32_t>(m.bytes.size())), m.bytes.data(), m.bytes.size());
  }
  static std::uint32_t serializedLength(const desslam::bag::SerializedMessage& m) {
    return static_cast<std::uint32_t>(m.bytes.size());
  }
};
}  // namespace ros::serialization

namespace desslam::bag {

RosImage imageMessage(const cv::Mat& pixels, const std::string& encoding, RosTime stamp, std::uint32_t seq,
                      const std::string& frame_id) {
  RosImage image;
  image.header = {seq, stamp, frame_id};
  image.height = static_cast<std::uint32_t>(pixels.rows);
  image.width = static_cast<std::uint32_t>(pixels.cols);
  image.encoding = encoding;
  image.step = static_cast<std::uint32_t>(pixels.cols * pixels.elemSize());
  image.data.resize(static_cast<std::size_t>(image.step) * image.height);
  for (int r = 0; r < pixels.rows; ++r)
    std::memcpy(image.data.data() + static_cast<std::size_t>(r) * image.step, pixels.ptr(r), image.step);
  return image;
}

RosCameraInfo cameraInfoMessage(const CameraOptions& camera, RosTime stamp, std::uint32_t seq,
                                const std::string& frame_id) {
  RosCameraInfo info;
  info.header = {seq, stamp, frame_id};
  info.height = static_cast<std::uint32_t>(camera.height);
  info.width = static_cast<std::uint32_t>(camera.width);
  info.distortion_model = "plumb_bob";
  info.D.assign(camera.distortion.begin(), camera.distortion.end());
  info.K = {camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1};
  info.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  info.P = {camera.fx, 0, camera.cx, 0, 0, camera.fy, camera.cy, 0, 0, 0, 1, 0};
  return info;
}

namespace {

ros::Time rosTime(RosTime t) { return ros::Time(t.sec, t.nsec); }

}  // namespace

struct BagWriter::Impl {
  std::filesystem::path file;
  rosbag::Bag bag;

  void write(const std::string& topic, RosTime stamp, SerializedMessage message) {
    try {
      bag.write(topic, rosTime(stamp), message);
    } catch (const rosbag::BagException& e) {
      throw OutputError("cannot write topic " + topic + " to ROS bag " + file.string() + ": " + e.what());
    }
  }
};

BagWriter::BagWriter(const std::filesystem::path& file, bool bz2_chunks) : impl_(std::make_unique<Impl>()) {
  impl_->file = file;
  try {
    impl_->bag.open(file.string(), rosbag::bagmode::Write);
    impl_->bag.setCompression(bz2_chunks ? rosbag::compression::BZ2 : rosbag::compression::Uncompressed);
  } catch (const rosbag::BagException& e) {
    throw OutputError("cannot create ROS bag " + file.string() + ": " + e.what());
  }
}

BagWriter::~BagWriter() {
  try {
    impl_->bag.close();
  } catch (const std::exception&) {
    // close() reports; a destructor cannot.
  }
}

void BagWriter::write(const std::string& topic, const RosImage& image) {
  impl_->write(topic, image.header.stamp, SerializedMessage{&kImageType, encodeImage(image)});
}

void BagWriter::write(const std::string& topic, const RosCameraInfo& info) {
  impl_->write(topic, info.header.stamp, SerializedMessage{&kCameraInfoType, encodeCameraInfo(info)});
}

void BagWriter::close() {
  try {
    impl_->bag.close();
  } catch (const rosbag::BagException& e) {
    throw OutputError("cannot finish ROS bag " + impl_->file.string() + ": " + e.what());
  }
}

void writeBag(const io::RgbdSequence& sequence, const CameraOptions& camera, const std::filesystem::path& file,
              const BagWriteOptions& options) {
  const std::size_t count = options.max_frames > 0 ? std::min(options.max_frames, sequence.size()) : sequence.size();
  const std::string frame_id = "openni_rgb_optical_frame";  // as in the TUM bags
  writeFileAtomicallyVia(file, "ROS bag", [&](const std::filesystem::path& tmp) {
    BagWriter writer(tmp, options.bz2_chunks);
    for (std::size_t i = 0; i < count; ++i) {
      const io::RgbdImage image = sequence.load(i, camera);
      const auto seq = static_cast<std::uint32_t>(i);
      const RosTime rgb_stamp = RosTime::fromSeconds(sequence.rgbTimestamp(i));
      const RosTime depth_stamp = RosTime::fromSeconds(sequence.depthTimestamp(i));

      cv::Mat rgb;
      cv::cvtColor(image.bgr, rgb, cv::COLOR_BGR2RGB);
      writer.write(options.topics.rgb_topic, imageMessage(rgb, "rgb8", rgb_stamp, seq, frame_id));

      cv::Mat depth;
      std::string encoding;
      if (options.depth_millimetres) {
        image.depth.convertTo(depth, CV_16U, 1000.0);  // rounded, saturated at 65.535 m
        encoding = "16UC1";
      } else {
        depth = image.depth.clone();
        depth.setTo(std::numeric_limits<float>::quiet_NaN(), image.depth == 0);
        encoding = "32FC1";
      }
      writer.write(options.topics.depth_topic, imageMessage(depth, encoding, depth_stamp, seq, frame_id));
      if (options.camera_info)
        writer.write(options.topics.camera_info_topic, cameraInfoMessage(camera, rgb_stamp, seq, frame_id));
    }
    writer.close();
    return true;
  });
}

}  // namespace desslam::bag
