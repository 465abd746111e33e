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

}  // namespace desslam::dynamic
