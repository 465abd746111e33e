#include "io/tum_dataset.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <tuple>

#include <opencv2/imgcodecs.hpp>
#include <spdlog/spdlog.h>

#include "core/error.hpp"
#include "io/data_lines.hpp"
#include "io/trajectory_io.hpp"

namespace desslam::io {
namespace fs = std::filesystem;

namespace {

struct ListEntry {
  Timestamp timestamp;
  fs::path path;
};

std::string quoted(const fs::path& p) { return "'" + p.string() + "'"; }

// Reads a "timestamp filename" list; paths are resolved against the sequence folder.
std::vector<ListEntry> readImageList(const fs::path& dir, const std::string& list_name,
                                     std::vector<std::string>& warnings) {
  const fs::path list_path = dir / list_name;
  if (!fs::is_regular_file(list_path))
    throw InputError("missing " + list_name + " in sequence folder " + quoted(dir) +
                     ": a TUM-layout sequence needs rgb.txt and depth.txt ('timestamp filename' per line)");
  std::ifstream in(list_path);
  if (!in) throw InputError("cannot read " + quoted(list_path) + ": check permissions");
  std::vector<std::string> list_warnings;
  const std::vector<TimestampListEntry> parsed = parseTimestampList(in, list_path.string(), &list_warnings);
  for (std::string& w : list_warnings) {
    spdlog::warn("{}", w);
    warnings.push_back(std::move(w));
  }
  std::vector<ListEntry> entries;
  entries.reserve(parsed.size());
  for (const TimestampListEntry& e : parsed) entries.push_back({e.timestamp, dir / e.file});
  if (entries.empty())
    throw InputError(quoted(list_path) + " lists no images: expected 'timestamp filename' lines");
  return entries;
}

// Drops entries whose file is missing; one warning per file (datasets ship with a few holes).
std::vector<ListEntry> dropMissing(std::vector<ListEntry> entries, const fs::path& list_path,
                                   std::vector<std::string>& warnings) {
  std::vector<ListEntry> present;
  present.reserve(entries.size());
  for (auto& e : entries) {
    if (fs::exists(e.path)) {
      present.push_back(std::move(e));
      continue;
    }
    std::string msg = "skipping " + e.path.string() + " listed in " + list_path.string() + ": file does not exist";
    spdlog::warn("{}", msg);
    warnings.push_back(std::move(msg));
  }
  if (present.empty())
    throw InputError("none of the " + std::to_string(entries.size()) + " files listed in " + quoted(list_path) +
                     " exist: check that the list paths are relative to the sequence folder");
  return present;
}

std::string describeType(const cv::Mat& m) {
  std::string depth;
  switch (m.depth()) {
    case CV_8U: depth = "8-bit"; break;
    case CV_8S: depth = "8-bit signed"; break;
    case CV_16U: depth = "16-bit"; break;
    case CV_16S: depth = "16-bit signed"; break;
    case CV_32S: depth = "32-bit integer"; break;
    case CV_32F: depth = "32-bit float"; break;
    case CV_64F: depth = "64-bit float"; break;
    default: depth = "unknown depth"; break;
  }
  if (m.channels() != 1) depth += " " + std::to_string(m.channels()) + "-channel";
  return depth;
}

cv::Mat readImage(const fs::path& file, const char* what) {
  if (!fs::exists(file)) throw InputError(std::string(what) + " image does not exist: " + file.string());
  cv::Mat image = cv::imread(file.string(), cv::IMREAD_UNCHANGED);
  if (image.empty())
    throw InputError("cannot read " + std::string(what) + " image (unreadable or corrupt PNG): " + file.string());
  return image;
}

void requireCameraSize(const cv::Mat& image, const fs::path& file, const CameraOptions& camera) {
  if (image.cols == camera.width && image.rows == camera.height) return;
  throw InputError("image is " + std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                   " but camera.width x camera.height is " + std::to_string(camera.width) + "x" +
                   std::to_string(camera.height) + ": " + file.string() +
                   " (use the camera preset of this dataset)");
}

}  // namespace

std::vector<TimestampListEntry> parseTimestampList(std::istream& in, const std::string& name,
                                                   std::vector<std::string>* warnings) {
  std::vector<TimestampListEntry> entries;
  forEachDataLine(in, [&](const std::string& line, int line_number) {
    std::istringstream fields(line);
    double timestamp = 0;
    std::string file;
    if (!(fields >> timestamp >> file) || !std::isfinite(timestamp))
      throw InputError(name + ":" + std::to_string(line_number) + ": expected 'timestamp filename', got '" +
                       (line.size() > 200 ? line.substr(0, 200) + "..." : line) + "'");
    entries.push_back({timestamp, file, line_number});
  });
  if (warnings != nullptr) {
    // Ties: equal timestamps, found in time order; each group is one warning naming its lines.
    std::vector<std::size_t> order(entries.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b) { return entries[a].timestamp < entries[b].timestamp; });
    constexpr std::size_t kMaxReported = 10;
    std::size_t groups = 0;
    for (std::size_t k = 0; k < order.size();) {
      std::size_t end = k + 1;
      while (end < order.size() && entries[order[end]].timestamp == entries[order[k]].timestamp) ++end;
      if (end - k > 1 && ++groups <= kMaxReported) {
        std::ostringstream msg;
        msg.precision(6);
        msg << std::fixed << name << ": lines ";
        for (std::size_t j = k; j < end; ++j) msg << (j == k ? "" : j + 1 == end ? " and " : ", ") << entries[order[j]].line;
        msg << " have the same timestamp " << entries[order[k]].timestamp
            << " (a tie: only one of them can be paired with the other stream; check the recording)";
        warnings->push_back(msg.str());
      }
      k = end;
    }
    if (groups > kMaxReported)
      warnings->push_back(name + ": " + std::to_string(groups - kMaxReported) + " more timestamp ties not listed");
  }
  return entries;
}

cv::Mat depthToMetres(const cv::Mat& raw, const fs::path& file, const CameraOptions& camera) {
  if (!(camera.depth_factor > 0) || !std::isfinite(camera.depth_factor))
    throw ConfigError("config key camera.depth_factor must be positive (5000 for TUM/Bonn, 1000 for mm)");
  if (raw.empty()) throw InputError("cannot read depth image (unreadable or corrupt PNG): " + file.string());
  if (raw.type() != CV_16UC1)
    throw InputError("depth must be 16-bit PNG (CV_16U), got " + describeType(raw) + ": " + file.string() +
                     " (raw depth units are converted to metres with camera.depth_factor)");
  requireCameraSize(raw, file, camera);
  cv::Mat depth;
  raw.convertTo(depth, CV_32F, 1.0 / camera.depth_factor);  // 0 stays 0 = no reading
  return depth;
}

TumSequence TumSequence::open(const fs::path& dir, double max_dt) {
  if (!(max_dt > 0)) throw InputError("TumSequence::open: max_dt must be positive, got " + std::to_string(max_dt));
  if (!fs::is_directory(dir))
    throw InputError("sequence folder " + quoted(dir) + " does not exist or is not a folder: " +
                     "pass a folder with rgb/, depth/, rgb.txt and depth.txt (TUM layout)");

  TumSequence seq;
  seq.directory_ = dir;
  const auto rgb = dropMissing(readImageList(dir, "rgb.txt", seq.warnings_), dir / "rgb.txt", seq.warnings_);
  const auto depth = dropMissing(readImageList(dir, "depth.txt", seq.warnings_), dir / "depth.txt", seq.warnings_);

  // Association as TUM's associate.py (io::associateByTime).
  std::vector<Timestamp> rgb_stamps, depth_stamps;
  for (const ListEntry& e : rgb) rgb_stamps.push_back(e.timestamp);
  for (const ListEntry& e : depth) depth_stamps.push_back(e.timestamp);
  for (const StreamPair& pair : associateByTime(rgb_stamps, depth_stamps, max_dt))
    seq.records_.push_back(
        {rgb[pair.rgb].timestamp, depth[pair.depth].timestamp, rgb[pair.rgb].path, depth[pair.depth].path});
  if (seq.records_.empty()) {
    const auto earlier = [](const ListEntry& a, const ListEntry& b) { return a.timestamp < b.timestamp; };
    const auto [rgb_min, rgb_max] = std::minmax_element(rgb.begin(), rgb.end(), earlier);
    const auto [depth_min, depth_max] = std::minmax_element(depth.begin(), depth.end(), earlier);
    std::ostringstream msg;
    msg.precision(6);
    msg << std::fixed << "timestamps do not match: no RGB frame in " << (dir / "rgb.txt").string()
        << " has a depth frame in " << (dir / "depth.txt").string() << " within " << max_dt << " s (rgb "
        << rgb_min->timestamp << ".." << rgb_max->timestamp << ", depth " << depth_min->timestamp << ".."
        << depth_max->timestamp << "): check that both lists come from the same recording";
    throw InputError(msg.str());
  }

  const std::size_t unpaired_rgb = rgb.size() - seq.records_.size();
  if (unpaired_rgb > 0)
    spdlog::info("{}: {} RGB frames have no depth frame within {} s and are not used", dir.string(), unpaired_rgb,
                 max_dt);

  // Ground truth is optional for a run (ATE/RPE, the depth-scale check): a problem with it is a
  // warning here; commands that need it throw groundTruthProblem().
  if (const fs::path gt = dir / "groundtruth.txt"; fs::is_regular_file(gt)) {
    OptionalGroundTruth read = readOptionalGroundTruth(gt, seq.warnings_);
    seq.ground_truth_ = std::move(read.trajectory);
    seq.ground_truth_problem_ = std::move(read.problem);
  }
  return seq;
}

InputCalibration TumSequence::calibration() const {
  throw InputError(description() + " carries no camera calibration: give camera.fx, fy, cx and cy in the config "
                   "(see the presets in config/)");
}

RgbdImage TumSequence::load(std::size_t i, const CameraOptions& camera) const {
  if (i >= records_.size())
    throw InputError("frame index " + std::to_string(i) + " is out of range: " + quoted(directory_) + " has " +
                     std::to_string(records_.size()) + " RGB-D pairs");
  if (!(camera.depth_factor > 0))
    throw ConfigError("config key camera.depth_factor must be positive (5000 for TUM/Bonn, 1000 for mm)");
  const RgbdFrameRecord& rec = records_[i];

  RgbdImage out;
  out.timestamp = rec.rgb_timestamp;

  cv::Mat bgr = readImage(rec.rgb_path, "RGB");
  if (bgr.type() != CV_8UC3)
    throw InputError("RGB image must be 8-bit 3-channel, got " + describeType(bgr) + ": " + rec.rgb_path.string());
  requireCameraSize(bgr, rec.rgb_path, camera);
  out.bgr = std::move(bgr);

  out.depth = depthToMetres(readImage(rec.depth_path, "depth"), rec.depth_path, camera);
  return out;
}

void checkDepthScale(const cv::Mat& depth_m, const fs::path& file, double depth_factor) {
  if (depth_m.empty() || depth_m.type() != CV_32FC1)
    throw InputError("checkDepthScale expects a CV_32F depth image in metres: " + file.string());
  std::vector<float> valid;
  valid.reserve(depth_m.total() / 4);
  // Every other row and column is plenty for a median.
  for (int r = 0; r < depth_m.rows; r += 2) {
    const float* row = depth_m.ptr<float>(r);
    for (int c = 0; c < depth_m.cols; c += 2)
      if (row[c] > 0 && std::isfinite(row[c])) valid.push_back(row[c]);
  }
  if (valid.empty()) return;
  auto mid = valid.begin() + static_cast<std::ptrdiff_t>(valid.size() / 2);
  std::nth_element(valid.begin(), mid, valid.end());
  const double median = *mid;
  constexpr double kMinPlausible = 0.1, kMaxPlausible = 20.0;  // metres, indoor RGB-D range
  if (median >= kMinPlausible && median <= kMaxPlausible) return;
  std::ostringstream msg;
  msg << "median depth " << median << " m in " << file.string() << " is implausible for an indoor RGB-D camera"
      << " (expected " << kMinPlausible << ".." << kMaxPlausible << " m) with camera.depth_factor = " << depth_factor
      << ": check camera.depth_factor (5000 for TUM/Bonn, 1000 for millimetre PNGs)";
  throw InputError(msg.str());
}

}  // namespace desslam::io
