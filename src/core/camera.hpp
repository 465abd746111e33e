// Pinhole camera with optional Brown-Conrady distortion (k1 k2 p1 p2 k3, OpenCV order).
// Depth images are registered to the RGB image, so one camera serves both.
#pragma once

#include <array>
#include <vector>

#include <opencv2/core.hpp>

#include "core/camera_options.hpp"
#include "core/types.hpp"

namespace desslam {

class PinholeCamera {
 public:
  explicit PinholeCamera(const CameraOptions& options);

  double fx() const { return options_.fx; }
  double fy() const { return options_.fy; }
  double cx() const { return options_.cx; }
  double cy() const { return options_.cy; }
  int width() const { return options_.width; }
  int height() const { return options_.height; }
  double depthFactor() const { return options_.depth_factor; }
  double depthBaseline() const { return options_.depth_baseline; }  // metres
  double bf() const { return options_.bf(); }  // virtual stereo baseline times fx (pixel * metres)
  bool hasDistortion() const { return has_distortion_; }
  const CameraOptions& options() const { return options_; }

  // Ideal (undistorted) pixel of a camera-frame point; caller ensures z > 0.
  Vec2 project(const Vec3& p_c) const {
    return {options_.fx * p_c.x() / p_c.z() + options_.cx, options_.fy * p_c.y() / p_c.z() + options_.cy};
  }
  // Camera-frame point at metric depth z along the ray of an undistorted pixel.
  Vec3 backProject(const Vec2& uv, double z) const {
    return {(uv.x() - options_.cx) * z / options_.fx, (uv.y() - options_.cy) * z / options_.fy, z};
  }
  // Whether an undistorted pixel falls inside the undistorted image bounds.
  bool inImage(const Vec2& uv) const {
    return uv.x() >= min_x_ && uv.x() < max_x_ && uv.y() >= min_y_ && uv.y() < max_y_;
  }
  double minX() const { return min_x_; }
  double maxX() const { return max_x_; }
  double minY() const { return min_y_; }
  double maxY() const { return max_y_; }

  // Raw (distorted) pixel coordinates -> ideal pinhole pixel coordinates. Identity when the
  // camera has no distortion.
  std::vector<cv::Point2f> undistort(const std::vector<cv::Point2f>& raw) const;
  // Ideal pixel -> raw pixel (applies the distortion model), e.g. to look up an image value.
  Vec2 distort(const Vec2& uv) const;

  cv::Mat K() const;                 // 3x3 CV_64F
  cv::Mat distortionCoeffs() const;  // 1x5 CV_64F

 private:
  CameraOptions options_;
  bool has_distortion_ = false;
  double min_x_ = 0, max_x_ = 0, min_y_ = 0, max_y_ = 0;
};

}  // namespace desslam
