// Data handed to dense mapping: one keyframe's images and pose, and the camera-frame cloud
// made from them. Plain data; the algorithms live in back_projection / dense_map.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "core/se3.hpp"
#include "core/types.hpp"

namespace desslam::dense {

struct DenseKeyframe {
  uint64_t keyframe_id = 0;
  Timestamp timestamp = 0;
  cv::Mat bgr;           // CV_8UC3, raw (distorted) image as read from disk
  cv::Mat depth;         // CV_32F metres registered to bgr, 0 = no reading
  cv::Mat exclude_mask;  // CV_8U, nonzero = dynamic pixel, left out (may be empty)
  cv::Mat labels;        // CV_8U semantic class ids (may be empty), for semantic colouring
  SE3 T_w_c;             // pose when the keyframe was made (later updates go through DenseMap)
};

// One keyframe's points in its CAMERA frame, so the world cloud can always be rebuilt with the
// newest pose. Floats: millimetre precision is plenty at indoor ranges and halves the memory.
struct KeyframeCloud {
  uint64_t keyframe_id = 0;
  Timestamp timestamp = 0;
  std::vector<Eigen::Vector3f> points_c;
  std::vector<std::array<uint8_t, 3>> rgb;  // per point, 0..255
  std::vector<uint8_t> labels;              // per point; all 0 when the keyframe had no labels

  size_t size() const { return points_c.size(); }
};

// The exported map: one entry per world voxel, in the world frame with the newest poses.
// first_seen is the timestamp of the keyframe that first saw the voxel (the map check compares
// it with later keyframes); observations counts the keyframes merged into it.
struct DenseCloud {
  std::vector<Vec3> points_w;
  std::vector<std::array<uint8_t, 3>> rgb;
  std::vector<uint8_t> labels;
  std::vector<Timestamp> first_seen;
  std::vector<uint32_t> observations;

  size_t size() const { return points_w.size(); }
  // Keeps the entries whose index is listed (ascending), in that order.
  void keepOnly(const std::vector<size_t>& indices);
};

// Points in the WORLD frame with the camera centre they were seen from: what OctoMap ray
// insertion needs. DenseMap::worldScans() gives one per anchor keyframe (the voxels it created).
struct WorldScan {
  uint64_t keyframe_id = 0;
  Timestamp timestamp = 0;
  Vec3 origin_w = Vec3::Zero();
  std::vector<Vec3> points_w;
};

}  // namespace desslam::dense
