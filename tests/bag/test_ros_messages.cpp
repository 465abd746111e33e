// The ROS 1 wire format of sensor_msgs/Image and CameraInfo (bag/ros_messages.hpp): byte layout
// against the message definition written out by hand, round trips, and damaged messages.
#include "bag/ros_messages.hpp"

#include <cstring>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/error.hpp"
#include "support/expect_contains.hpp"

namespace desslam::bag {
namespace {

template <class T>
void append(std::vector<std::uint8_t>& out, T v) {
  const auto* b = reinterpret_cast<const std::uint8_t*>(&v);
  out.insert(out.end(), b, b + sizeof(T));
}
void appendString(std::vector<std::uint8_t>& out, const std::string& s) {
  append(out, static_cast<std::uint32_t>(s.size()));
  out.insert(out.end(), s.begin(), s.end());
}

std::string errorOf(const std::vector<std::uint8_t>& bytes) {
  try {
    decodeImage(bytes.data(), bytes.size(), "test.bag /camera/rgb/image_color");
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected an InputError";
  return {};
}

// A 2x1 rgb8 image laid out field by field as the message definition orders them.
std::vector<std::uint8_t> handWrittenImage() {
  std::vector<std::uint8_t> bytes;
  append<std::uint32_t>(bytes, 7);            // header.seq
  append<std::uint32_t>(bytes, 1305031102);   // header.stamp.sec
  append<std::uint32_t>(bytes, 175304000);    // header.stamp.nsec
  appendString(bytes, "openni_rgb_optical_frame");
  append<std::uint32_t>(bytes, 1);            // height
  append<std::uint32_t>(bytes, 2);            // width
  appendString(bytes, "rgb8");
  append<std::uint8_t>(bytes, 0);             // is_bigendian
  append<std::uint32_t>(bytes, 6);            // step
  append<std::uint32_t>(bytes, 6);            // data length
  for (std::uint8_t v : {10, 20, 30, 40, 50, 60}) bytes.push_back(v);
  return bytes;
}

TEST(RosMessages, ImageDecodesTheDefinitionsLayout) {
  const std::vector<std::uint8_t> bytes = handWrittenImage();
  const RosImage image = decodeImage(bytes.data(), bytes.size(), "test");
  EXPECT_EQ(image.header.seq, 7u);
  EXPECT_EQ(image.header.stamp.sec, 1305031102u);
  EXPECT_EQ(image.header.stamp.nsec, 175304000u);
  EXPECT_EQ(image.header.frame_id, "openni_rgb_optical_frame");
  EXPECT_EQ(image.height, 1u);
  EXPECT_EQ(image.width, 2u);
  EXPECT_EQ(image.encoding, "rgb8");
  EXPECT_EQ(image.step, 6u);
  EXPECT_EQ(image.data, (std::vector<std::uint8_t>{10, 20, 30, 40, 50, 60}));
  // And back, byte for byte.
  EXPECT_EQ(encodeImage(image), bytes);
}

TEST(RosMessages, CameraInfoRoundTrips) {
  RosCameraInfo info;
  info.header = {3, {1305031102, 5}, "cam"};
  info.height = 480;
  info.width = 640;
  info.distortion_model = "plumb_bob";
  info.D = {0.26, -0.95, -0.005, 0.0026, 1.16};
  info.K = {517.3, 0, 318.6, 0, 516.5, 255.3, 0, 0, 1};
  info.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  info.P = {517.3, 0, 318.6, 0, 0, 516.5, 255.3, 0, 0, 0, 1, 0};
  info.binning_x = 1;
  info.roi_width = 17;
  info.roi_do_rectify = true;
  const std::vector<std::uint8_t> bytes = encodeCameraInfo(info);
  // header 4+8+4+3, size 8, model 4+9, D 4+40, K R P (9+9+12)*8, binning 8, roi 16+1.
  EXPECT_EQ(bytes.size(), 19u + 8 + 13 + 44 + 240 + 8 + 17);
  const RosCameraInfo back = decodeCameraInfo(bytes.data(), bytes.size(), "test");
  EXPECT_EQ(back.header.frame_id, "cam");
  EXPECT_EQ(back.header.stamp.nsec, 5u);
  EXPECT_EQ(back.width, 640u);
  EXPECT_EQ(back.distortion_model, "plumb_bob");
  EXPECT_EQ(back.D, info.D);
  EXPECT_EQ(back.K, info.K);
  EXPECT_EQ(back.P, info.P);
  EXPECT_EQ(back.binning_x, 1u);
  EXPECT_EQ(back.roi_width, 17u);
  EXPECT_TRUE(back.roi_do_rectify);
}

TEST(RosMessages, DamagedImagesAreErrorsNamingTheContext) {
  const std::vector<std::uint8_t> whole = handWrittenImage();
  // Cut inside the data.
  const std::string truncated = errorOf(std::vector<std::uint8_t>(whole.begin(), whole.end() - 2));
  EXPECT_CONTAINS(truncated, "test.bag /camera/rgb/image_color");
  EXPECT_CONTAINS(truncated, "'data'");
  // Cut inside the encoding string.
  EXPECT_CONTAINS(errorOf(std::vector<std::uint8_t>(whole.begin(), whole.begin() + 50)), "encoding");
  // Trailing bytes: not an Image.
  std::vector<std::uint8_t> longer = whole;
  longer.push_back(0);
  EXPECT_CONTAINS(errorOf(longer), "bytes left");
  // Data shorter than height x step.
  RosImage image = decodeImage(whole.data(), whole.size(), "test");
  image.step = 9;
  EXPECT_CONTAINS(errorOf(encodeImage(image)), "height 1 x step 9");
  // A huge length field must not be believed.
  std::vector<std::uint8_t> huge = whole;
  const std::uint32_t big = 0xFFFFFFF0u;
  std::memcpy(huge.data() + 12, &big, sizeof(big));  // frame_id length
  EXPECT_CONTAINS(errorOf(huge), "frame_id");
}

TEST(RosMessages, TimeFromSecondsRoundsToNanoseconds) {
  const RosTime t = RosTime::fromSeconds(1305031102.175304);
  EXPECT_EQ(t.sec, 1305031102u);
  EXPECT_NEAR(static_cast<double>(t.nsec), 175304000.0, 300.0);  // a double holds ~0.2 us here
  // TUM's six-decimal stamps come back as the same double.
  for (double s : {1305031102.175304, 1305031102.211214, 1341846313.592026, 0.5, 12.999999999})
    EXPECT_EQ(RosTime::fromSeconds(s).toSeconds(), s) << std::fixed << s;
  const RosTime carry = RosTime::fromSeconds(41.9999999999);
  EXPECT_EQ(carry.sec, 42u);
  EXPECT_EQ(carry.nsec, 0u);
  EXPECT_THROW(RosTime::fromSeconds(-1), InputError);
}

}  // namespace
}  // namespace desslam::bag
