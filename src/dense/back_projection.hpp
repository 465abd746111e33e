// Depth image -> camera-frame points of one keyframe.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "core/camera.hpp"
#include "dense/dense_keyframe.hpp"
#include "dense/dense_options.hpp"

namespace desslam::dense {

// Holds the per-pixel ray table, so distortion is undone once per camera rather than per
// keyframe. Immutable after construction: safe to share between threads.
class BackProjector {
 public:
  BackProjector(const DenseOptions& options, const PinholeCamera& camera);

  // Every pixel_stride-th pixel (u, v multiples of the stride) with depth in [min_depth,
  // max_depth], not on a depth edge (depth_edge_ratio) and not in the exclude mask dilated by
  // exclude_dilation_px becomes x = (u'-cx) z/fx, y = (v'-cy) z/fy, z = d, where (u', v') is the
  // undistorted pixel (= (u, v) for a camera without distortion). Not downsampled.
  // Throws InputError when an image has the wrong type or size (message names the keyframe).
  KeyframeCloud operator()(const DenseKeyframe& keyframe) const;

  // The dilated exclude mask actually applied (empty when the keyframe has none).
  cv::Mat dilatedExcludeMask(const cv::Mat& exclude_mask) const;

 private:
  DenseOptions options_;
  int width_, height_;
  std::vector<Eigen::Vector2f> ray_xy_;  // (x/z, y/z) per pixel, row-major
};

// Averages points and colours within each voxel (edge voxel_size, grid anchored at the camera
// origin); the label is the voxel's majority label (Boyer-Moore vote). Output order follows the
// first point of each voxel, so the result is deterministic.
KeyframeCloud voxelDownsample(const KeyframeCloud& cloud, double voxel_size);

}  // namespace desslam::dense
