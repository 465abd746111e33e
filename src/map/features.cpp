#include "map/features.hpp"

#include <algorithm>
#include <cmath>

namespace desslam::map {

FeatureGrid::FeatureGrid(const PinholeCamera& camera, const std::vector<Vec2>& uv)
    : min_x_(camera.minX()),
      min_y_(camera.minY()),
      inv_cell_w_(kCols / (camera.maxX() - camera.minX())),
      inv_cell_h_(kRows / (camera.maxY() - camera.minY())),
      cells_(kCols * kRows) {
  for (size_t i = 0; i < uv.size(); ++i) {
    int col, row;
    if (cellOf(uv[i], col, row)) cells_[row * kCols + col].push_back(static_cast<int>(i));
  }
}

bool FeatureGrid::cellOf(const Vec2& uv, int& col, int& row) const {
  col = static_cast<int>(std::floor((uv.x() - min_x_) * inv_cell_w_));
  row = static_cast<int>(std::floor((uv.y() - min_y_) * inv_cell_h_));
  return col >= 0 && col < kCols && row >= 0 && row < kRows;
}

void FeatureGrid::query(double u, double v, double radius, std::vector<int>& out) const {
  out.clear();
  if (cells_.empty()) return;
  const int c0 = std::max(0, static_cast<int>(std::floor((u - radius - min_x_) * inv_cell_w_)));
  const int c1 = std::min(kCols - 1, static_cast<int>(std::floor((u + radius - min_x_) * inv_cell_w_)));
  const int r0 = std::max(0, static_cast<int>(std::floor((v - radius - min_y_) * inv_cell_h_)));
  const int r1 = std::min(kRows - 1, static_cast<int>(std::floor((v + radius - min_y_) * inv_cell_h_)));
  for (int r = r0; r <= r1; ++r)
    for (int c = c0; c <= c1; ++c) {
      const auto& cell = cells_[r * kCols + c];
      out.insert(out.end(), cell.begin(), cell.end());
    }
}

std::vector<int> FeatureSet::inArea(double u, double v, double radius, int min_level, int max_level) const {
  std::vector<int> candidates;
  grid.query(u, v, radius, candidates);
  std::vector<int> result;
  result.reserve(candidates.size());
  for (int i : candidates) {
    const Vec2& p = uv[i];
    if (std::abs(p.x() - u) > radius || std::abs(p.y() - v) > radius) continue;
    const int lvl = keypoints[i].octave;
    if (min_level >= 0 && lvl < min_level) continue;
    if (max_level >= 0 && lvl > max_level) continue;
    result.push_back(i);
  }
  return result;
}

std::shared_ptr<const FeatureSet> buildFeatureSet(std::vector<cv::KeyPoint> keypoints, cv::Mat descriptors,
                                                  const PinholeCamera& camera, const cv::Mat& depth_m,
                                                  std::shared_ptr<const feature::ScalePyramid> pyramid,
                                                  double min_depth, double max_depth) {
  auto set = std::make_shared<FeatureSet>();
  std::vector<cv::Point2f> raw(keypoints.size());
  for (size_t i = 0; i < keypoints.size(); ++i) raw[i] = keypoints[i].pt;
  const std::vector<cv::Point2f> undistorted = camera.undistort(raw);
  set->uv.resize(keypoints.size());
  set->depth.assign(keypoints.size(), -1.0f);
  for (size_t i = 0; i < keypoints.size(); ++i) {
    set->uv[i] = Vec2(undistorted[i].x, undistorted[i].y);
    if (depth_m.empty()) continue;
    // Depth is registered to the raw RGB image, so it is read at the raw keypoint.
    const int x = static_cast<int>(std::lround(raw[i].x));
    const int y = static_cast<int>(std::lround(raw[i].y));
    if (x < 0 || y < 0 || x >= depth_m.cols || y >= depth_m.rows) continue;
    const float d = depth_m.at<float>(y, x);
    if (d >= min_depth && d <= max_depth) set->depth[i] = d;
  }
  set->keypoints = std::move(keypoints);
  set->descriptors = std::move(descriptors);
  set->pyramid = std::move(pyramid);
  set->grid = FeatureGrid(camera, set->uv);
  return set;
}

namespace {
// Depth at an ideal pixel: the depth image is registered to the raw image.
float depthAtIdealPixel(const PinholeCamera& camera, const cv::Mat& depth_m, const Vec2& uv) {
  const Vec2 raw = camera.distort(uv);
  const int x = static_cast<int>(std::lround(raw.x()));
  const int y = static_cast<int>(std::lround(raw.y()));
  if (x < 0 || y < 0 || x >= depth_m.cols || y >= depth_m.rows) return -1.0f;
  return depth_m.at<float>(y, x);
}
// Whether the valid depths in the 3x3 window around an ideal pixel differ from the centre's by
// more than `ratio` of it.
bool nearDepthEdge(const PinholeCamera& camera, const cv::Mat& depth_m, const Vec2& uv, float ratio) {
  const Vec2 raw = camera.distort(uv);
  const int x = static_cast<int>(std::lround(raw.x())), y = static_cast<int>(std::lround(raw.y()));
  if (x < 1 || y < 1 || x >= depth_m.cols - 1 || y >= depth_m.rows - 1) return true;
  const float centre = depth_m.at<float>(y, x);
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      const float d = depth_m.at<float>(y + dy, x + dx);
      if (d > 0 && std::abs(d - centre) > ratio * centre) return true;
    }
  return false;
}
}  // namespace

std::shared_ptr<const FeatureSet> compensateDepthDelay(const FeatureSet& features, const PinholeCamera& camera,
                                                       const cv::Mat& depth_m, const SE3& T_rgb_depth,
                                                       double min_depth, double max_depth, double tolerance_px) {
  auto set = std::make_shared<FeatureSet>(features);
  if (depth_m.empty()) return set;
  constexpr int kIterations = 4;
  constexpr float kEdgeRatio = 0.05f;
  for (size_t i = 0; i < features.size(); ++i) {
    set->depth[i] = -1.0f;
    const Vec2& uv = features.uv[i];
    Vec2 uv_depth = uv;
    double z_rgb = -1.0;
    bool settled = false;
    for (int it = 0; it < kIterations; ++it) {
      const float d = depthAtIdealPixel(camera, depth_m, uv_depth);
      if (!(d >= min_depth && d <= max_depth)) break;
      const Vec3 p_rgb = T_rgb_depth * camera.backProject(uv_depth, d);
      if (p_rgb.z() <= 0) break;
      const Vec2 residual = uv - camera.project(p_rgb);
      z_rgb = p_rgb.z();
      if (residual.norm() < tolerance_px) {
        settled = true;
        break;
      }
      uv_depth += residual;
    }
    // Next to a depth edge the search can settle on the other surface (the background the depth
    // camera sees beside an object, or the reverse): no depth there rather than a wrong one.
    // Only when the search moved the lookup: otherwise the reading is the one the image gave.
    if (settled && (uv_depth - uv).norm() >= tolerance_px && nearDepthEdge(camera, depth_m, uv_depth, kEdgeRatio))
      settled = false;
    if (settled && z_rgb >= min_depth && z_rgb <= max_depth) set->depth[i] = static_cast<float>(z_rgb);
  }
  return set;
}

}  // namespace desslam::map
