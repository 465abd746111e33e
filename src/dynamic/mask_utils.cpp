#include "dynamic/mask_utils.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <opencv2/imgproc.hpp>

#include "core/error.hpp"

namespace desslam::dynamic {
namespace {

void requireMask(const cv::Mat& mask, const char* what) {
  if (mask.empty() || mask.type() != CV_8UC1)
    throw InputError(std::string(what) + ": expected a non-empty CV_8U single-channel mask (nonzero = dynamic)");
}

cv::Mat ellipse(int radius_px) {
  return cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * radius_px + 1, 2 * radius_px + 1));
}

}  // namespace

cv::Mat dilateMask(const cv::Mat& mask, int radius_px) {
  requireMask(mask, "dilateMask");
  if (radius_px < 0)
    throw InputError("dilateMask: radius " + std::to_string(radius_px) + " is negative (dynamic.mask_dilation_px >= 0)");
  cv::Mat binary = mask != 0;  // 0/255
  if (radius_px == 0) return binary;
  // A disc of radius r: every pixel within Euclidean distance r of the mask. The exact distance
  // transform is linear in the image size; cv::dilate with a 31x31 disc (r = 15) costs ~700
  // operations per pixel, which a real-time frame cannot afford.
  cv::Mat distance;
  cv::distanceTransform(mask == 0, distance, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  return distance <= static_cast<float>(radius_px) + 1e-3f;
}

std::vector<uint8_t> featuresInMask(const map::FeatureSet& features, const cv::Mat& mask) {
  requireMask(mask, "featuresInMask");
  std::vector<uint8_t> in(features.size(), 0);
  for (size_t i = 0; i < features.size(); ++i) {
    const cv::Point2f& p = features.keypoints[i].pt;
    const int x = static_cast<int>(std::lround(p.x)), y = static_cast<int>(std::lround(p.y));
    if (x >= 0 && y >= 0 && x < mask.cols && y < mask.rows) in[i] = mask.at<uint8_t>(y, x) != 0 ? 1 : 0;
  }
  return in;
}

cv::Mat carryMaskForward(const cv::Mat& mask_j, const cv::Mat& depth_j, const SE3& T_k_j,
                         const PinholeCamera& camera, int close_radius_px) {
  requireMask(mask_j, "carryMaskForward");
  if (depth_j.type() != CV_32FC1 || depth_j.size() != mask_j.size())
    throw InputError("carryMaskForward: depth must be CV_32F metres of the mask's size");
  if (close_radius_px < 0) throw InputError("carryMaskForward: close_radius_px must be >= 0");

  // Every second pixel in both directions, each moved as a 2x2 block: a quarter of the work, and
  // the closing below fills what the blocks leave.
  constexpr int kStep = 2;
  std::vector<cv::Point2f> raw;
  std::vector<float> depth;
  std::vector<float> valid_depths;
  for (int y = 0; y < mask_j.rows; y += kStep) {
    const uint8_t* m = mask_j.ptr<uint8_t>(y);
    const float* d = depth_j.ptr<float>(y);
    for (int x = 0; x < mask_j.cols; x += kStep) {
      if (m[x] == 0) continue;
      raw.emplace_back(static_cast<float>(x), static_cast<float>(y));
      depth.push_back(d[x]);
      if (d[x] > 0) valid_depths.push_back(d[x]);
    }
  }
  cv::Mat out = cv::Mat::zeros(mask_j.size(), CV_8UC1);
  if (raw.empty()) return out;
  // Pixels without depth: the object's typical depth is the best guess for holes inside it.
  float fill_depth = 0;
  if (!valid_depths.empty()) {
    auto mid = valid_depths.begin() + static_cast<long>(valid_depths.size() / 2);
    std::nth_element(valid_depths.begin(), mid, valid_depths.end());
    fill_depth = *mid;
  }

  const std::vector<cv::Point2f> uv = camera.undistort(raw);
  for (size_t i = 0; i < uv.size(); ++i) {
    const double z = depth[i] > 0 ? depth[i] : fill_depth;
    if (z <= 0) continue;
    const Vec3 p_k = T_k_j * camera.backProject(Vec2(uv[i].x, uv[i].y), z);
    if (p_k.z() <= 0) continue;
    const Vec2 target = camera.distort(camera.project(p_k));
    const int x0 = static_cast<int>(std::lround(target.x())), y0 = static_cast<int>(std::lround(target.y()));
    for (int y = y0; y < y0 + kStep; ++y)
      for (int x = x0; x < x0 + kStep; ++x)
        if (x >= 0 && y >= 0 && x < out.cols && y < out.rows) out.at<uint8_t>(y, x) = 255;
  }
  if (close_radius_px > 0) cv::morphologyEx(out, out, cv::MORPH_CLOSE, ellipse(close_radius_px));
  return out;
}

}  // namespace desslam::dynamic
