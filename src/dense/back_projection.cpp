#include "dense/back_projection.hpp"

#include <cmath>
#include <string>
#include <unordered_map>

#include <opencv2/imgproc.hpp>

#include "core/error.hpp"

namespace desslam::dense {
namespace {

void requireImage(const cv::Mat& image, int type, int width, int height, uint64_t id, const char* what,
                  const char* expected) {
  if (image.type() == type && image.cols == width && image.rows == height) return;
  throw InputError("dense keyframe " + std::to_string(id) + ": " + what + " is " +
                   std::to_string(image.cols) + "x" + std::to_string(image.rows) + " type " +
                   std::to_string(image.type()) + ", expected " + std::to_string(width) + "x" +
                   std::to_string(height) + " " + expected + " (same size as the camera config)");
}

// A pixel whose depth jumps relative to a valid 4-neighbour lies on a depth discontinuity,
// where the sensor mixes foreground and background ("flying pixels").
bool onDepthEdge(const cv::Mat& depth, int u, int v, float d, double ratio) {
  const float limit = static_cast<float>(ratio) * d;
  const int du[4] = {1, -1, 0, 0}, dv[4] = {0, 0, 1, -1};
  for (int k = 0; k < 4; ++k) {
    const int un = u + du[k], vn = v + dv[k];
    if (un < 0 || vn < 0 || un >= depth.cols || vn >= depth.rows) continue;
    const float dn = depth.at<float>(vn, un);
    if (dn > 0 && std::abs(dn - d) > limit) return true;
  }
  return false;
}

}  // namespace

BackProjector::BackProjector(const DenseOptions& options, const PinholeCamera& camera)
    : options_(options), width_(camera.width()), height_(camera.height()) {
  options_.validate();
  std::vector<cv::Point2f> raw;
  raw.reserve(static_cast<size_t>(width_) * height_);
  for (int v = 0; v < height_; ++v)
    for (int u = 0; u < width_; ++u) raw.emplace_back(static_cast<float>(u), static_cast<float>(v));
  const std::vector<cv::Point2f> ideal = camera.undistort(raw);
  ray_xy_.resize(ideal.size());
  for (size_t i = 0; i < ideal.size(); ++i) {
    ray_xy_[i] = {static_cast<float>((ideal[i].x - camera.cx()) / camera.fx()),
                  static_cast<float>((ideal[i].y - camera.cy()) / camera.fy())};
  }
}

cv::Mat BackProjector::dilatedExcludeMask(const cv::Mat& exclude_mask) const {
  if (exclude_mask.empty() || options_.exclude_dilation_px <= 0) return exclude_mask;
  const int r = options_.exclude_dilation_px;
  cv::Mat dilated;
  cv::dilate(exclude_mask, dilated, cv::getStructuringElement(cv::MORPH_ELLIPSE, {2 * r + 1, 2 * r + 1}));
  return dilated;
}

KeyframeCloud BackProjector::operator()(const DenseKeyframe& keyframe) const {
  const uint64_t id = keyframe.keyframe_id;
  requireImage(keyframe.depth, CV_32FC1, width_, height_, id, "depth", "CV_32F metres");
  requireImage(keyframe.bgr, CV_8UC3, width_, height_, id, "bgr image", "CV_8UC3");
  if (!keyframe.exclude_mask.empty())
    requireImage(keyframe.exclude_mask, CV_8UC1, width_, height_, id, "exclude mask", "CV_8U");
  if (!keyframe.labels.empty())
    requireImage(keyframe.labels, CV_8UC1, width_, height_, id, "labels", "CV_8U");

  const cv::Mat exclude = dilatedExcludeMask(keyframe.exclude_mask);
  const bool has_labels = !keyframe.labels.empty();
  const int stride = options_.pixel_stride;
  const float min_depth = static_cast<float>(options_.min_depth);
  const float max_depth = static_cast<float>(options_.max_depth);

  KeyframeCloud cloud;
  cloud.keyframe_id = id;
  cloud.timestamp = keyframe.timestamp;
  const size_t capacity = static_cast<size_t>((width_ + stride - 1) / stride) * ((height_ + stride - 1) / stride);
  cloud.points_c.reserve(capacity);
  cloud.rgb.reserve(capacity);
  cloud.labels.reserve(capacity);
  for (int v = 0; v < height_; v += stride) {
    const float* depth_row = keyframe.depth.ptr<float>(v);
    const cv::Vec3b* bgr_row = keyframe.bgr.ptr<cv::Vec3b>(v);
    const uint8_t* exclude_row = exclude.empty() ? nullptr : exclude.ptr<uint8_t>(v);
    const uint8_t* label_row = has_labels ? keyframe.labels.ptr<uint8_t>(v) : nullptr;
    for (int u = 0; u < width_; u += stride) {
      const float z = depth_row[u];
      if (!(z >= min_depth && z <= max_depth) || z <= 0.0f) continue;  // also rejects NaN
      if (exclude_row != nullptr && exclude_row[u] != 0) continue;
      if (options_.depth_edge_ratio > 0 && onDepthEdge(keyframe.depth, u, v, z, options_.depth_edge_ratio))
        continue;
      const Eigen::Vector2f& ray = ray_xy_[static_cast<size_t>(v) * width_ + u];
      cloud.points_c.emplace_back(ray.x() * z, ray.y() * z, z);
      const cv::Vec3b& c = bgr_row[u];
      cloud.rgb.push_back({c[2], c[1], c[0]});
      cloud.labels.push_back(label_row != nullptr ? label_row[u] : 0);
    }
  }
  return cloud;
}

KeyframeCloud voxelDownsample(const KeyframeCloud& cloud, double voxel_size) {
  struct Cell {
    Eigen::Vector3d sum_point = Eigen::Vector3d::Zero();
    Eigen::Vector3d sum_rgb = Eigen::Vector3d::Zero();
    int count = 0;
    uint8_t label = 0;  // Boyer-Moore majority candidate
    int label_votes = 0;
  };
  if (!(voxel_size > 0)) return cloud;
  const double inv = 1.0 / voxel_size;
  // 21 bits per axis covers +-10 km at 1 cm: far beyond any depth sensor.
  auto key = [inv](const Eigen::Vector3f& p) {
    const auto q = [inv](float x) { return static_cast<uint64_t>(static_cast<int64_t>(std::floor(x * inv)) & 0x1FFFFF); };
    return (q(p.x()) << 42) | (q(p.y()) << 21) | q(p.z());
  };
  std::unordered_map<uint64_t, size_t> index;
  index.reserve(cloud.size());
  std::vector<Cell> cells;
  for (size_t i = 0; i < cloud.size(); ++i) {
    const auto [it, inserted] = index.try_emplace(key(cloud.points_c[i]), cells.size());
    if (inserted) cells.emplace_back();
    Cell& cell = cells[it->second];
    cell.sum_point += cloud.points_c[i].cast<double>();
    cell.sum_rgb += Eigen::Vector3d(cloud.rgb[i][0], cloud.rgb[i][1], cloud.rgb[i][2]);
    ++cell.count;
    const uint8_t label = cloud.labels.empty() ? 0 : cloud.labels[i];
    if (cell.label_votes == 0) {
      cell.label = label;
      cell.label_votes = 1;
    } else {
      cell.label_votes += (cell.label == label) ? 1 : -1;
    }
  }
  KeyframeCloud out;
  out.keyframe_id = cloud.keyframe_id;
  out.timestamp = cloud.timestamp;
  out.points_c.reserve(cells.size());
  out.rgb.reserve(cells.size());
  out.labels.reserve(cells.size());
  for (const Cell& cell : cells) {
    out.points_c.push_back((cell.sum_point / cell.count).cast<float>());
    const Eigen::Vector3d rgb = cell.sum_rgb / cell.count;
    out.rgb.push_back({static_cast<uint8_t>(std::lround(rgb.x())), static_cast<uint8_t>(std::lround(rgb.y())),
                       static_cast<uint8_t>(std::lround(rgb.z()))});
    out.labels.push_back(cell.label);
  }
  return out;
}

}  // namespace desslam::dense
