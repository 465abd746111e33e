// The ORB features of one RGB-D image: immutable once built, so frames and keyframes share them
// between threads without locking.
#pragma once

#include <array>
#include <memory>
#include <vector>

#include <opencv2/core.hpp>

#include "core/camera.hpp"
#include "core/se3.hpp"
#include "core/types.hpp"
#include "feature/orb_extractor.hpp"

namespace desslam::map {

// Buckets feature indices by undistorted position for fast radius queries.
class FeatureGrid {
 public:
  static constexpr int kCols = 64;
  static constexpr int kRows = 48;

  FeatureGrid() = default;
  FeatureGrid(const PinholeCamera& camera, const std::vector<Vec2>& uv);
  // Indices of features within an axis-aligned square of half-size radius around (u, v).
  void query(double u, double v, double radius, std::vector<int>& out) const;

 private:
  bool cellOf(const Vec2& uv, int& col, int& row) const;
  double min_x_ = 0, min_y_ = 0, inv_cell_w_ = 1, inv_cell_h_ = 1;
  std::vector<std::vector<int>> cells_;
};

// Why a feature was excluded from tracking and mapping.
enum class FeatureStatus : uint8_t {
  kStatic = 0,
  kDynamicStage1 = 1,  // inside the semantic mask and depth-inconsistent with the previous frame
  kDynamicStage2 = 2,  // depth-inconsistent with co-visible keyframes' optimised points
  kDynamicMask = 3,    // inside the semantic mask (semantic-only ablation)
  kPendingStage1 = 4,  // inside the semantic mask, not yet checked: kept out of the first pose estimate
};

struct FeatureSet {
  std::vector<cv::KeyPoint> keypoints;  // raw (distorted) pixels, octave = pyramid level
  std::vector<Vec2> uv;                 // undistorted pixels (all geometry uses these)
  std::vector<float> depth;             // metres at the keypoint; <= 0 when unknown or out of range
  cv::Mat descriptors;                  // N x 32 CV_8U
  std::shared_ptr<const feature::ScalePyramid> pyramid;
  FeatureGrid grid;

  size_t size() const { return keypoints.size(); }
  int level(size_t i) const { return keypoints[i].octave; }
  const uint8_t* descriptor(size_t i) const { return descriptors.ptr<uint8_t>(static_cast<int>(i)); }
  bool hasDepth(size_t i) const { return depth[i] > 0; }
  // Indices within `radius` (square window) of (u, v) whose level is in [min_level, max_level]
  // (a negative bound means unbounded).
  std::vector<int> inArea(double u, double v, double radius, int min_level = -1, int max_level = -1) const;
};

// Undistorts the keypoints, samples depth (CV_32F metres) at each raw keypoint and keeps it when
// within [min_depth, max_depth], and builds the grid.
std::shared_ptr<const FeatureSet> buildFeatureSet(std::vector<cv::KeyPoint> keypoints, cv::Mat descriptors,
                                                  const PinholeCamera& camera, const cv::Mat& depth_m,
                                                  std::shared_ptr<const feature::ScalePyramid> pyramid,
                                                  double min_depth, double max_depth);

// RGB and depth streams of many sensors are not triggered together (TUM fr1: up to +-20 ms), so
// during fast motion the depth read at a keypoint belongs to a slightly different surface point
// (1 m/s x 15 ms = 1.5 cm). Given T_rgb_depth, the camera at the RGB time from the camera at the
// depth time (from the motion model), each keypoint's depth is re-read where the depth camera saw
// the keypoint's surface point: a fixed-point search u_d <- u_d + (u - project(T_rgb_depth *
// backProject(u_d, D(u_d)))). A keypoint whose search does not settle within `tolerance_px` (a
// depth edge), or that settles next to one (depths in its 3x3 window differing by over 5 %), loses
// its depth rather than keep a wrong one. Returns a copy with the new depths.
std::shared_ptr<const FeatureSet> compensateDepthDelay(const FeatureSet& features, const PinholeCamera& camera,
                                                       const cv::Mat& depth_m, const SE3& T_rgb_depth,
                                                       double min_depth, double max_depth, double tolerance_px = 0.5);

}  // namespace desslam::map
