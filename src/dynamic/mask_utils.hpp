// Semantic-mask helpers for the dynamic-feature checks. Masks are CV_8U, raw (distorted) pixels,
// nonzero = dynamic class; outputs use 255.
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/core/types.hpp>

#include "map/features.hpp"

namespace desslam::dynamic {

// Grows the mask by radius_px with an elliptical (disc) kernel: segmentation misses the
// silhouette's last pixels, where features often sit. radius 0 returns a 0/255 copy.
// Throws InputError unless mask is a non-empty CV_8U single-channel image and radius_px >= 0.
cv::Mat dilateMask(const cv::Mat& mask, int radius_px);

// A mask carried from an older frame is dilated by base_px + growth_px, where the growth shrinks
// in steps of step_px (down to 0) until at least min_outside_share of the keypoints lie outside
// the result (with none at all: growth 0). radius_px is the radius used; base_mask is the mask
// dilated by base_px alone (what dilateMask(mask, base_px) gives; the same cv::Mat as mask when
// nothing was added).
struct GrownMask {
  cv::Mat mask;       // 0/255
  cv::Mat base_mask;  // 0/255
  int radius_px = 0;
};
GrownMask dilateMaskLeavingFeatures(const cv::Mat& mask, const std::vector<cv::KeyPoint>& keypoints, int base_px,
                                    int growth_px, int step_px, double min_outside_share);

// 1 for each feature whose raw keypoint (rounded) lies on a nonzero mask pixel.
std::vector<uint8_t> featuresInMask(const map::FeatureSet& features, const cv::Mat& mask);

}  // namespace desslam::dynamic
