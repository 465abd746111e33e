// Constructed depth images for the dense-mapping tests.
#pragma once

#include <opencv2/core.hpp>

#include "core/camera.hpp"
#include "core/camera_options.hpp"
#include "core/se3.hpp"
#include "dense/dense_keyframe.hpp"
#include "dense/dense_options.hpp"

namespace desslam::dense::test {

inline CameraOptions smallCamera(int width = 640, int height = 480) {
  CameraOptions c;
  c.width = width;
  c.height = height;
  c.fx = c.fy = 0.78 * width;
  c.cx = (width - 1) / 2.0;
  c.cy = (height - 1) / 2.0;
  return c;
}

// Depth of the world plane n_w . p = d_w seen from T_w_c (0 where the plane is behind the
// camera or parallel to the ray).
inline cv::Mat planeDepth(const PinholeCamera& camera, const SE3& T_w_c, const Vec3& n_w, double d_w) {
  const Vec3 n_c = T_w_c.rotation().transpose() * n_w;
  const double d_c = d_w - n_w.dot(T_w_c.translation());
  cv::Mat depth(camera.height(), camera.width(), CV_32F, cv::Scalar(0));
  for (int v = 0; v < camera.height(); ++v) {
    for (int u = 0; u < camera.width(); ++u) {
      const Vec3 ray((u - camera.cx()) / camera.fx(), (v - camera.cy()) / camera.fy(), 1.0);
      const double denom = n_c.dot(ray);
      if (std::abs(denom) < 1e-9) continue;
      const double z = d_c / denom;
      if (z > 0) depth.at<float>(v, u) = static_cast<float>(z);
    }
  }
  return depth;
}

// Dense options without the statistical outlier filter, so tests see every fused point.
inline DenseOptions noFilterOptions() {
  DenseOptions o;
  o.outlier_neighbors = 0;
  return o;
}

inline DenseKeyframe planeKeyframe(const PinholeCamera& camera, uint64_t id, Timestamp t, const SE3& T_w_c,
                                   const Vec3& n_w, double d_w, cv::Scalar bgr = {40, 160, 220}) {
  DenseKeyframe kf;
  kf.keyframe_id = id;
  kf.timestamp = t;
  kf.T_w_c = T_w_c;
  kf.depth = planeDepth(camera, T_w_c, n_w, d_w);
  kf.bgr = cv::Mat(camera.height(), camera.width(), CV_8UC3, bgr);
  return kf;
}

}  // namespace desslam::dense::test
