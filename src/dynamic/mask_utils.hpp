// Semantic-mask helpers for the dynamic-feature checks. Masks are CV_8U, raw (distorted) pixels,
// nonzero = dynamic class; outputs use 255.
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "core/camera.hpp"
#include "core/se3.hpp"
#include "map/features.hpp"

namespace desslam::dynamic {

// Grows the mask by radius_px with an elliptical (disc) kernel: segmentation misses the
// silhouette's last pixels, where features often sit. radius 0 returns a 0/255 copy.
// Throws InputError unless mask is a non-empty CV_8U single-channel image and radius_px >= 0.
cv::Mat dilateMask(const cv::Mat& mask, int radius_px);

// 1 for each feature whose raw keypoint (rounded) lies on a nonzero mask pixel.
std::vector<uint8_t> featuresInMask(const map::FeatureSet& features, const cv::Mat& mask);

// Real-time mode: segmentation of frame k is not ready, the latest mask is of frame j. Each mask
// pixel of j with depth is back-projected with depth_j, moved by T_k_j and splatted at its
// pixel in frame k (forward warp); mask pixels without depth use the median depth of the mask's
// valid pixels (holes inside a person). A morphological closing of close_radius_px then fills the
// gaps a forward warp leaves when the object comes closer, without growing the mask's outline.
// Only the camera's motion is compensated, not the object's own: callers dilate as usual.
// Throws InputError on empty/mistyped inputs or size mismatch.
cv::Mat carryMaskForward(const cv::Mat& mask_j, const cv::Mat& depth_j, const SE3& T_k_j,
                         const PinholeCamera& camera, int close_radius_px = 2);

}  // namespace desslam::dynamic
