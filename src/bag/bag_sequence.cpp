#include "bag/bag_sequence.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <mutex>
#include <sstream>

#include <opencv2/imgproc.hpp>
#include <rosbag/bag.h>
#include <rosbag/exceptions.h>
#include <rosbag/query.h>
#include <rosbag/view.h>
#include <ros/serialization.h>
#include <spdlog/spdlog.h>

#include "bag/ros_messages.hpp"
#include "core/error.hpp"

namespace desslam::bag {
namespace fs = std::filesystem;

namespace {

std::string quoted(const fs::path& p) { return "'" + p.string() + "'"; }

std::string stampText(double seconds) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.6f", seconds);
  return text;
}

// One message of the RGB or depth stream: its stamp and where it lies in the bag.
struct StreamMessage {
  Timestamp stamp;
  rosbag::MessageInstance message;  // refers into the open Bag (kept alive by Impl)
};

std::vector<std::uint8_t> readBytes(const rosbag::MessageInstance& message) {
  std::vector<std::uint8_t> bytes(message.size());
  ros::serialization::OStream stream(bytes.data(), static_cast<std::uint32_t>(bytes.size()));
  message.write(stream);
  return bytes;
}

}  // namespace

struct BagSequence::Impl {
  fs::path file;
  BagOptions topics;
  rosbag::Bag bag;
  std::map<std::string, std::string> topic_types;  // every topic of the bag -> its type
  std::vector<StreamMessage> rgb, depth;
  std::vector<io::StreamPair> pairs;
  std::optional<Trajectory> ground_truth;
  std::string ground_truth_problem;
  std::vector<std::string> warnings;
  mutable std::mutex read_mutex;  // rosbag::Bag reads through one file position and chunk cache

  std::string topicList() const {
    std::string list;
    for (const auto& [topic, type] : topic_types) list += (list.empty() ? "" : ", ") + topic + " (" + type + ")";
    return list.empty() ? "none" : list;
  }
  std::string context(const std::string& topic, double stamp) const {
    return "ROS bag " + quoted(file) + " topic " + topic + " message at " + stampText(stamp);
  }
  // Throws unless the bag has `topic` of `type`; `key` is the option naming it.
  void requireTopic(const std::string& topic, const RosMessageType& type, const char* key) const {
    const auto found = topic_types.find(topic);
    if (found == topic_types.end())
      throw InputError("ROS bag " + quoted(file) + " has no topic " + topic + " (bag." + key +
                       "); its topics are: " + topicList() + ": set bag." + key +
                       " to the right one in the config or with --set bag." + key + "=/topic");
    if (found->second != type.datatype)
      throw InputError("topic " + topic + " of ROS bag " + quoted(file) + " is " + found->second + ", expected " +
                       type.datatype + " (bag." + key + "); its topics are: " + topicList());
  }
  std::vector<std::uint8_t> read(const rosbag::MessageInstance& message, const std::string& what) const {
    const std::lock_guard lock(read_mutex);
    try {
      return readBytes(message);
    } catch (const rosbag::BagException& e) {
      throw InputError("cannot read " + what + " from ROS bag " + quoted(file) + ": " + e.what() +
                       " (is the file truncated or damaged?)");
    }
  }
};

BagSequence::BagSequence(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
BagSequence::BagSequence(BagSequence&&) noexcept = default;
BagSequence& BagSequence::operator=(BagSequence&&) noexcept = default;
BagSequence::~BagSequence() = default;

BagSequence BagSequence::open(const fs::path& file, const BagOptions& topics, double max_dt) {
  if (!(max_dt > 0)) throw InputError("BagSequence::open: max_dt must be positive, got " + std::to_string(max_dt));
  if (!fs::is_regular_file(file))
    throw InputError("ROS bag " + quoted(file) + " does not exist or is not a file: pass a .bag file or a TUM-layout "
                     "sequence folder");
  auto impl = std::make_unique<Impl>();
  impl->file = file;
  impl->topics = topics;
  try {
    impl->bag.open(file.string(), rosbag::bagmode::Read);
  } catch (const rosbag::BagException& e) {
    throw InputError("cannot read " + quoted(file) + " as a ROS 1 bag: " + e.what() +
                     " (expected a bag recorded by rosbag, format 2.0; for a TUM-layout folder pass the folder)");
  }
  {
    rosbag::View all(impl->bag);
    for (const rosbag::ConnectionInfo* connection : all.getConnections())
      impl->topic_types[connection->topic] = connection->datatype;
  }
  impl->requireTopic(topics.rgb_topic, kImageType, "rgb_topic");
  impl->requireTopic(topics.depth_topic, kImageType, "depth_topic");
  if (topics.rgb_topic == topics.depth_topic)
    throw InputError("bag.rgb_topic and bag.depth_topic are both " + topics.rgb_topic + ": set them to the RGB and "
                     "the depth image topics of " + quoted(file) + " (its topics: " + impl->topicList() + ")");

  // One pass over both streams in the bag's order (each chunk is decompressed once): the header
  // stamps, and the message positions for load().
  size_t unstamped = 0;
  try {
    rosbag::View view(impl->bag, rosbag::TopicQuery(std::vector<std::string>{topics.rgb_topic, topics.depth_topic}));
    for (const rosbag::MessageInstance& message : view) {
      const bool is_rgb = message.getTopic() == topics.rgb_topic;
      const double record_time = message.getTime().toSec();
      if (message.getMD5Sum() != kImageType.md5sum && message.getMD5Sum() != "*")
        throw InputError("topic " + message.getTopic() + " of ROS bag " + quoted(file) + " has MD5 sum " +
                         message.getMD5Sum() + ", not sensor_msgs/Image's " + kImageType.md5sum +
                         ": recorded with another message definition");
      const std::vector<std::uint8_t> bytes = readBytes(message);
      const RosImage image = decodeImage(bytes.data(), bytes.size(), impl->context(message.getTopic(), record_time));
      double stamp = image.header.stamp.toSeconds();
      if (image.header.stamp.isZero()) {
        stamp = record_time;  // a driver that leaves the stamp out: the time it was recorded
        ++unstamped;
      }
      (is_rgb ? impl->rgb : impl->depth).push_back({stamp, message});
    }
  } catch (const rosbag::BagException& e) {
    throw InputError("cannot read the image messages of ROS bag " + quoted(file) + ": " + e.what() +
                     " (is the file truncated or damaged?)");
  }
  if (unstamped > 0) {
    std::string msg = std::to_string(unstamped) + " image messages of " + quoted(file) +
                      " have no header stamp: their record time in the bag is used instead";
    spdlog::warn("{}", msg);
    impl->warnings.push_back(std::move(msg));
  }
  for (const auto& [stream, topic] : {std::pair{&impl->rgb, topics.rgb_topic}, {&impl->depth, topics.depth_topic}})
    if (stream->empty())
      throw InputError("topic " + topic + " of ROS bag " + quoted(file) + " has no messages: nothing to run on");

  std::vector<Timestamp> rgb_stamps, depth_stamps;
  for (const StreamMessage& m : impl->rgb) rgb_stamps.push_back(m.stamp);
  for (const StreamMessage& m : impl->depth) depth_stamps.push_back(m.stamp);
  impl->pairs = io::associateByTime(rgb_stamps, depth_stamps, max_dt);
  if (impl->pairs.empty()) {
    const auto [rgb_min, rgb_max] = std::minmax_element(rgb_stamps.begin(), rgb_stamps.end());
    const auto [depth_min, depth_max] = std::minmax_element(depth_stamps.begin(), depth_stamps.end());
    throw InputError("timestamps do not match: no message on " + topics.rgb_topic + " of ROS bag " + quoted(file) +
                     " has one on " + topics.depth_topic + " within " + std::to_string(max_dt) + " s (rgb " +
                     stampText(*rgb_min) + ".." + stampText(*rgb_max) + ", depth " + stampText(*depth_min) + ".." +
                     stampText(*depth_max) + "): check bag.rgb_topic and bag.depth_topic");
  }
  if (const size_t unpaired = impl->rgb.size() - impl->pairs.size(); unpaired > 0)
    spdlog::info("{}: {} RGB frames have no depth frame within {} s and are not used", file.string(), unpaired, max_dt);

  // Ground truth beside the bag: TUM names it "<stem>-groundtruth.txt".
  for (const fs::path& gt : {fs::path(file).replace_filename(file.stem().string() + "-groundtruth.txt"),
                             fs::path(file).replace_filename("groundtruth.txt")}) {
    if (!fs::is_regular_file(gt)) continue;
    io::OptionalGroundTruth read = io::readOptionalGroundTruth(gt, impl->warnings);
    impl->ground_truth = std::move(read.trajectory);
    impl->ground_truth_problem = std::move(read.problem);
    break;
  }
  return BagSequence(std::move(impl));
}

std::size_t BagSequence::size() const { return impl_->pairs.size(); }
Timestamp BagSequence::rgbTimestamp(std::size_t i) const { return impl_->rgb[impl_->pairs.at(i).rgb].stamp; }
Timestamp BagSequence::depthTimestamp(std::size_t i) const { return impl_->depth[impl_->pairs.at(i).depth].stamp; }
std::string BagSequence::frameName(std::size_t i) const { return stampText(rgbTimestamp(i)); }
const std::optional<Trajectory>& BagSequence::groundTruth() const { return impl_->ground_truth; }
const std::string& BagSequence::groundTruthProblem() const { return impl_->ground_truth_problem; }
std::vector<std::string> BagSequence::warnings() const { return impl_->warnings; }
std::string BagSequence::description() const { return "ROS bag " + quoted(impl_->file); }
const fs::path& BagSequence::file() const { return impl_->file; }

namespace {

void requireCameraSize(const RosImage& image, const CameraOptions& camera, const std::string& context) {
  if (static_cast<int>(image.width) == camera.width && static_cast<int>(image.height) == camera.height) return;
  throw InputError(context + ": image is " + std::to_string(image.width) + "x" + std::to_string(image.height) +
                   " but camera.width x camera.height is " + std::to_string(camera.width) + "x" +
                   std::to_string(camera.height) + " (use the camera preset of this recording, or leave the "
                   "intrinsics out of the config to take them from camera_info)");
}

// A view of the image data as `type` rows; checks that a row fits in `step`.
cv::Mat wrap(const RosImage& image, int type, const std::string& context) {
  const size_t row_bytes = static_cast<size_t>(image.width) * CV_ELEM_SIZE(type);
  if (image.step < row_bytes)
    throw InputError(context + ": row step " + std::to_string(image.step) + " bytes is shorter than a row of " +
                     std::to_string(image.width) + " " + image.encoding + " pixels (" + std::to_string(row_bytes) +
                     " bytes): the message is damaged");
  return cv::Mat(static_cast<int>(image.height), static_cast<int>(image.width), type,
                 const_cast<std::uint8_t*>(image.data.data()), image.step);
}

cv::Mat decodeBgr(const RosImage& image, const std::string& context) {
  cv::Mat bgr;
  if (image.encoding == "rgb8")
    cv::cvtColor(wrap(image, CV_8UC3, context), bgr, cv::COLOR_RGB2BGR);
  else if (image.encoding == "bgr8")
    bgr = wrap(image, CV_8UC3, context).clone();
  else
    throw InputError(context + ": RGB encoding '" + image.encoding + "' is not supported: expected rgb8 or bgr8 "
                     "(check bag.rgb_topic: is it the colour image?)");
  return bgr;
}

cv::Mat decodeDepthMetres(const RosImage& image, const std::string& context) {
  if (image.is_bigendian != 0)
    throw InputError(context + ": big-endian depth images are not supported (a little-endian recording is needed)");
  cv::Mat depth;
  if (image.encoding == "32FC1") {
    depth = wrap(image, CV_32FC1, context).clone();
    // NaN (and anything not a positive finite distance) is no reading: 0, as for PNG depth.
    for (int r = 0; r < depth.rows; ++r) {
      float* row = depth.ptr<float>(r);
      for (int c = 0; c < depth.cols; ++c)
        if (!(std::isfinite(row[c]) && row[c] > 0)) row[c] = 0.0f;
    }
  } else if (image.encoding == "16UC1") {
    constexpr double kMillimetresPerMetre = 1000.0;  // REP 118: 16-bit depth images are millimetres
    wrap(image, CV_16UC1, context).convertTo(depth, CV_32F, 1.0 / kMillimetresPerMetre);
  } else {
    throw InputError(context + ": depth encoding '" + image.encoding + "' is not supported: expected 32FC1 (metres) "
                     "or 16UC1 (millimetres) (check bag.depth_topic: is it the depth image?)");
  }
  return depth;
}

}  // namespace

io::RgbdImage BagSequence::load(std::size_t i, const CameraOptions& camera) const {
  const io::StreamPair& pair = impl_->pairs.at(i);
  const StreamMessage& rgb = impl_->rgb[pair.rgb];
  const StreamMessage& depth = impl_->depth[pair.depth];
  const std::string rgb_context = impl_->context(impl_->topics.rgb_topic, rgb.stamp);
  const std::string depth_context = impl_->context(impl_->topics.depth_topic, depth.stamp);

  const std::vector<std::uint8_t> rgb_bytes = impl_->read(rgb.message, rgb_context);
  const RosImage rgb_image = decodeImage(rgb_bytes.data(), rgb_bytes.size(), rgb_context);
  requireCameraSize(rgb_image, camera, rgb_context);
  const std::vector<std::uint8_t> depth_bytes = impl_->read(depth.message, depth_context);
  const RosImage depth_image = decodeImage(depth_bytes.data(), depth_bytes.size(), depth_context);
  requireCameraSize(depth_image, camera, depth_context);

  io::RgbdImage out;
  out.timestamp = rgb.stamp;
  out.bgr = decodeBgr(rgb_image, rgb_context);
  out.depth = decodeDepthMetres(depth_image, depth_context);
  return out;
}

io::InputCalibration BagSequence::calibration() const {
  const std::string& topic = impl_->topics.camera_info_topic;
  impl_->requireTopic(topic, kCameraInfoType, "camera_info_topic");
  std::vector<std::uint8_t> bytes;
  double record_time = 0;
  try {
    const std::lock_guard lock(impl_->read_mutex);
    rosbag::View view(impl_->bag, rosbag::TopicQuery(topic));
    // The iterator owns the MessageInstance it yields: keep it while reading.
    const rosbag::View::iterator first = view.begin();
    if (first == view.end())
      throw InputError("topic " + topic + " of ROS bag " + quoted(impl_->file) + " has no messages");
    record_time = first->getTime().toSec();
    bytes = readBytes(*first);
  } catch (const rosbag::BagException& e) {
    throw InputError("cannot read " + topic + " from ROS bag " + quoted(impl_->file) + ": " + e.what());
  }
  const std::string context = impl_->context(topic, record_time);
  const RosCameraInfo info = decodeCameraInfo(bytes.data(), bytes.size(), context);

  io::InputCalibration calibration;
  calibration.fx = info.K[0];
  calibration.fy = info.K[4];
  calibration.cx = info.K[2];
  calibration.cy = info.K[5];
  calibration.width = static_cast<int>(info.width);
  calibration.height = static_cast<int>(info.height);
  calibration.source = description() + " topic " + topic;
  if (!(calibration.fx > 0 && calibration.fy > 0))
    throw InputError(context + ": K holds no calibration (fx " + std::to_string(calibration.fx) + ", fy " +
                     std::to_string(calibration.fy) + "): give camera.fx, fy, cx and cy in the config");
  // plumb_bob is OpenCV's k1 k2 p1 p2 k3; rational_polynomial starts with the same five and is
  // the same model when its further coefficients are 0.
  const bool known_model = info.distortion_model == "plumb_bob" || info.distortion_model == "rational_polynomial" ||
                           (info.distortion_model.empty() && info.D.empty());
  bool extra_terms = false;
  for (size_t k = 5; k < info.D.size(); ++k) extra_terms = extra_terms || info.D[k] != 0.0;
  if (!known_model || extra_terms || (!info.D.empty() && info.D.size() < 5 && info.distortion_model == "plumb_bob"))
    throw InputError(context + ": distortion model '" + info.distortion_model + "' with " +
                     std::to_string(info.D.size()) + " coefficients is not supported (plumb_bob k1 k2 t1 t2 k3 is): "
                     "give camera.fx, fy, cx, cy and distortion in the config");
  for (size_t k = 0; k < 5 && k < info.D.size(); ++k) calibration.distortion[k] = info.D[k];
  return calibration;
}

}  // namespace desslam::bag
