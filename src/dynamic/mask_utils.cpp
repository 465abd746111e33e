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

GrownMask dilateMaskLeavingFeatures(const cv::Mat& mask, const std::vector<cv::KeyPoint>& keypoints, int base_px,
                                    int growth_px, int step_px, double min_outside_share) {
  requireMask(mask, "dilateMaskLeavingFeatures");
  if (base_px < 0 || growth_px < 0)
    throw InputError("dilateMaskLeavingFeatures: negative radius " + std::to_string(base_px) + " + " +
                     std::to_string(growth_px));
  cv::Mat distance;  // to the nearest mask pixel (0 on it)
  cv::distanceTransform(mask == 0, distance, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  std::vector<float> at_keypoints;
  at_keypoints.reserve(keypoints.size());
  for (const cv::KeyPoint& kp : keypoints) {
    const int x = std::clamp(cvRound(kp.pt.x), 0, mask.cols - 1), y = std::clamp(cvRound(kp.pt.y), 0, mask.rows - 1);
    at_keypoints.push_back(distance.at<float>(y, x));
  }
  const double wanted = min_outside_share * static_cast<double>(keypoints.size());
  int growth = growth_px;
  while (growth > 0) {
    const float radius = static_cast<float>(base_px + growth) + 1e-3f;
    const auto outside = std::count_if(at_keypoints.begin(), at_keypoints.end(), [&](float d) { return d > radius; });
    if (static_cast<double>(outside) >= wanted) break;
    growth = step_px > 0 ? std::max(0, growth - step_px) : 0;
  }
  GrownMask grown;
  grown.radius_px = base_px + growth;
  grown.mask = distance <= static_cast<float>(grown.radius_px) + 1e-3f;
  // From the same distance map: a second dilation would cost another distance transform a frame.
  grown.base_mask = growth > 0 ? cv::Mat(distance <= static_cast<float>(base_px) + 1e-3f) : grown.mask;
  return grown;
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

}  // namespace desslam::dynamic
