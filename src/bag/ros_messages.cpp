#include "bag/ros_messages.hpp"

#include <bit>
#include <cmath>
#include <cstring>

#include "core/error.hpp"

namespace desslam::bag {

static_assert(std::endian::native == std::endian::little,
              "ROS 1 serialization is little-endian; this decoder copies values as they are");

const RosMessageType kImageType{
    "sensor_msgs/Image", "060021388200f6f0f447d0fcd9c64743",
    "std_msgs/Header header\n"
    "uint32 height\n"
    "uint32 width\n"
    "string encoding\n"
    "uint8 is_bigendian\n"
    "uint32 step\n"
    "uint8[] data\n"
    "\n"
    "================================================================================\n"
    "MSG: std_msgs/Header\n"
    "uint32 seq\n"
    "time stamp\n"
    "string frame_id\n"};

const RosMessageType kCameraInfoType{
    "sensor_msgs/CameraInfo", "c9a58c1b0b154e0e6da7578cb991d214",
    "std_msgs/Header header\n"
    "uint32 height\n"
    "uint32 width\n"
    "string distortion_model\n"
    "float64[] D\n"
    "float64[9] K\n"
    "float64[9] R\n"
    "float64[12] P\n"
    "uint32 binning_x\n"
    "uint32 binning_y\n"
    "RegionOfInterest roi\n"
    "\n"
    "================================================================================\n"
    "MSG: std_msgs/Header\n"
    "uint32 seq\n"
    "time stamp\n"
    "string frame_id\n"
    "\n"
    "================================================================================\n"
    "MSG: sensor_msgs/RegionOfInterest\n"
    "uint32 x_offset\n"
    "uint32 y_offset\n"
    "uint32 height\n"
    "uint32 width\n"
    "bool do_rectify\n"};

RosTime RosTime::fromSeconds(double seconds) {
  if (!(seconds >= 0) || !(seconds < 4294967296.0))
    throw InputError("time " + std::to_string(seconds) + " s cannot be a ROS time (0 .. 2^32 s)");
  RosTime t;
  t.sec = static_cast<std::uint32_t>(std::floor(seconds));
  const long long nsec = std::llround((seconds - t.sec) * 1e9);
  if (nsec >= 1000000000LL) {
    ++t.sec;
    t.nsec = static_cast<std::uint32_t>(nsec - 1000000000LL);
  } else {
    t.nsec = static_cast<std::uint32_t>(nsec);
  }
  return t;
}

namespace {

// Reads the wire format front to back; every read is checked against the end.
class Reader {
 public:
  Reader(const std::uint8_t* bytes, std::size_t size, const std::string& context)
      : p_(bytes), end_(bytes + size), context_(context) {}

  template <class T>
  T value(const char* field) {
    T v;
    std::memcpy(&v, take(sizeof(T), field), sizeof(T));
    return v;
  }
  std::uint32_t length(const char* field) { return value<std::uint32_t>(field); }
  std::string string(const char* field) {
    const std::uint32_t n = length(field);
    const std::uint8_t* s = take(n, field);
    return std::string(reinterpret_cast<const char*>(s), n);
  }
  template <std::size_t N>
  void doubles(std::array<double, N>& out, const char* field) {
    std::memcpy(out.data(), take(N * sizeof(double), field), N * sizeof(double));
  }
  std::vector<double> doubleVector(const char* field) {
    const std::uint32_t n = length(field);
    std::vector<double> out(n);
    if (n > 0) std::memcpy(out.data(), take(std::size_t{n} * sizeof(double), field), std::size_t{n} * sizeof(double));
    return out;
  }
  std::vector<std::uint8_t> byteVector(const char* field) {
    const std::uint32_t n = length(field);
    const std::uint8_t* s = take(n, field);
    return std::vector<std::uint8_t>(s, s + n);
  }
  RosHeader header() {
    RosHeader h;
    h.seq = value<std::uint32_t>("header.seq");
    h.stamp.sec = value<std::uint32_t>("header.stamp.sec");
    h.stamp.nsec = value<std::uint32_t>("header.stamp.nsec");
    h.frame_id = string("header.frame_id");
    return h;
  }
  void requireEnd(const char* type) const {
    if (p_ != end_)
      throw InputError(context_ + ": " + std::to_string(end_ - p_) + " bytes left after a whole " + type +
                       ": the message is not a " + type + " (check the topic's type)");
  }

 private:
  const std::uint8_t* take(std::size_t n, const char* field) {
    if (static_cast<std::size_t>(end_ - p_) < n)
      throw InputError(context_ + ": message ends inside field '" + field + "' (needs " + std::to_string(n) +
                       " bytes, " + std::to_string(end_ - p_) + " left): truncated or not of the expected type");
    const std::uint8_t* at = p_;
    p_ += n;
    return at;
  }

  const std::uint8_t* p_;
  const std::uint8_t* end_;
  const std::string& context_;
};

class Writer {
 public:
  template <class T>
  void value(T v) {
    const auto* b = reinterpret_cast<const std::uint8_t*>(&v);
    out_.insert(out_.end(), b, b + sizeof(T));
  }
  void bytes(const void* data, std::size_t n) {
    const auto* b = static_cast<const std::uint8_t*>(data);
    out_.insert(out_.end(), b, b + n);
  }
  void string(const std::string& s) {
    value(static_cast<std::uint32_t>(s.size()));
    bytes(s.data(), s.size());
  }
  void header(const RosHeader& h) {
    value(h.seq);
    value(h.stamp.sec);
    value(h.stamp.nsec);
    string(h.frame_id);
  }
  std::vector<std::uint8_t> take() { return std::move(out_); }

 private:
  std::vector<std::uint8_t> out_;
};

}  // namespace

RosImage decodeImage(const std::uint8_t* bytes, std::size_t size, const std::string& context) {
  Reader in(bytes, size, context);
  RosImage image;
  image.header = in.header();
  image.height = in.value<std::uint32_t>("height");
  image.width = in.value<std::uint32_t>("width");
  image.encoding = in.string("encoding");
  image.is_bigendian = in.value<std::uint8_t>("is_bigendian");
  image.step = in.value<std::uint32_t>("step");
  image.data = in.byteVector("data");
  in.requireEnd("sensor_msgs/Image");
  if (image.data.size() < std::uint64_t{image.height} * image.step)
    throw InputError(context + ": image data has " + std::to_string(image.data.size()) + " bytes, less than height " +
                     std::to_string(image.height) + " x step " + std::to_string(image.step));
  return image;
}

RosCameraInfo decodeCameraInfo(const std::uint8_t* bytes, std::size_t size, const std::string& context) {
  Reader in(bytes, size, context);
  RosCameraInfo info;
  info.header = in.header();
  info.height = in.value<std::uint32_t>("height");
  info.width = in.value<std::uint32_t>("width");
  info.distortion_model = in.string("distortion_model");
  info.D = in.doubleVector("D");
  in.doubles(info.K, "K");
  in.doubles(info.R, "R");
  in.doubles(info.P, "P");
  info.binning_x = in.value<std::uint32_t>("binning_x");
  info.binning_y = in.value<std::uint32_t>("binning_y");
  info.roi_x_offset = in.value<std::uint32_t>("roi.x_offset");
  info.roi_y_offset = in.value<std::uint32_t>("roi.y_offset");
  info.roi_height = in.value<std::uint32_t>("roi.height");
  info.roi_width = in.value<std::uint32_t>("roi.width");
  info.roi_do_rectify = in.value<std::uint8_t>("roi.do_rectify") != 0;
  in.requireEnd("sensor_msgs/CameraInfo");
  return info;
}

std::vector<std::uint8_t> encodeImage(const RosImage& image) {
  Writer out;
  out.header(image.header);
  out.value(image.height);
  out.value(image.width);
  out.string(image.encoding);
  out.value(image.is_bigendian);
  out.value(image.step);
  out.value(static_cast<std::uint32_t>(image.data.size()));
  out.bytes(image.data.data(), image.data.size());
  return out.take();
}

std::vector<std::uint8_t> encodeCameraInfo(const RosCameraInfo& info) {
  Writer out;
  out.header(info.header);
  out.value(info.height);
  out.value(info.width);
  out.string(info.distortion_model);
  out.value(static_cast<std::uint32_t>(info.D.size()));
  out.bytes(info.D.data(), info.D.size() * sizeof(double));
  out.bytes(info.K.data(), sizeof(info.K));
  out.bytes(info.R.data(), sizeof(info.R));
  out.bytes(info.P.data(), sizeof(info.P));
  out.value(info.binning_x);
  out.value(info.binning_y);
  out.value(info.roi_x_offset);
  out.value(info.roi_y_offset);
  out.value(info.roi_height);
  out.value(info.roi_width);
  out.value(static_cast<std::uint8_t>(info.roi_do_rectify ? 1 : 0));
  return out.take();
}

}  // namespace desslam::bag
