#include "core/camera.hpp"

#include <algorithm>

#include <opencv2/calib3d.hpp>

namespace desslam {

PinholeCamera::PinholeCamera(const CameraOptions& options) : options_(options) {
  options_.validate();
  has_distortion_ = std::any_of(options_.distortion.begin(), options_.distortion.end(),
                                [](double d) { return d != 0.0; });
  if (!has_distortion_) {
    min_x_ = 0;
    max_x_ = options_.width;
    min_y_ = 0;
    max_y_ = options_.height;
    return;
  }
  // Undistorted bounds: where the raw image corners land after undistortion.
  const float w = static_cast<float>(options_.width), h = static_cast<float>(options_.height);
  const auto corners = undistort({{0, 0}, {w, 0}, {0, h}, {w, h}});
  min_x_ = std::min(corners[0].x, corners[2].x);
  max_x_ = std::max(corners[1].x, corners[3].x);
  min_y_ = std::min(corners[0].y, corners[1].y);
  max_y_ = std::max(corners[2].y, corners[3].y);
}

std::vector<cv::Point2f> PinholeCamera::undistort(const std::vector<cv::Point2f>& raw) const {
  if (!has_distortion_ || raw.empty()) return raw;
  std::vector<cv::Point2f> out;
  const cv::Mat K_mat = K();
  // P = K re-projects normalised coordinates back into pixels. OpenCV's default 5 iterations
  // leave ~0.1 px error at the corners under fr1's strong distortion; 20 reach 1e-4 px.
  cv::undistortPoints(raw, out, K_mat, distortionCoeffs(), cv::noArray(), K_mat,
                      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 1e-6));
  return out;
}

Vec2 PinholeCamera::distort(const Vec2& uv) const {
  if (!has_distortion_) return uv;
  const double x = (uv.x() - options_.cx) / options_.fx;
  const double y = (uv.y() - options_.cy) / options_.fy;
  const auto& d = options_.distortion;  // k1 k2 p1 p2 k3
  const double r2 = x * x + y * y;
  const double radial = 1 + d[0] * r2 + d[1] * r2 * r2 + d[4] * r2 * r2 * r2;
  const double xd = x * radial + 2 * d[2] * x * y + d[3] * (r2 + 2 * x * x);
  const double yd = y * radial + d[2] * (r2 + 2 * y * y) + 2 * d[3] * x * y;
  return {xd * options_.fx + options_.cx, yd * options_.fy + options_.cy};
}

cv::Mat PinholeCamera::K() const {
  return (cv::Mat_<double>(3, 3) << options_.fx, 0, options_.cx, 0, options_.fy, options_.cy, 0, 0, 1);
}

cv::Mat PinholeCamera::distortionCoeffs() const {
  const auto& d = options_.distortion;
  return (cv::Mat_<double>(1, 5) << d[0], d[1], d[2], d[3], d[4]);
}

}  // namespace desslam
