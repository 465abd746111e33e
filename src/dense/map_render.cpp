#include "dense/map_render.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <open3d/geometry/PointCloud.h>
#include <opencv2/imgproc.hpp>

namespace desslam::dense {
namespace {

double percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0;
  const size_t k = std::min(values.size() - 1, static_cast<size_t>(q * (values.size() - 1)));
  std::nth_element(values.begin(), values.begin() + static_cast<long>(k), values.end());
  return values[k];
}

// Any unit vector perpendicular to n.
Vec3 perpendicular(const Vec3& n) {
  const Vec3 a = std::abs(n.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  return n.cross(a).normalized();
}

Vec3 robustCentre(const std::vector<Eigen::Vector3d>& points) {
  std::vector<double> xs, ys, zs;
  const size_t step = std::max<size_t>(1, points.size() / 20000);  // a sample is enough
  for (size_t i = 0; i < points.size(); i += step) {
    xs.push_back(points[i].x());
    ys.push_back(points[i].y());
    zs.push_back(points[i].z());
  }
  return {percentile(xs, 0.5), percentile(ys, 0.5), percentile(zs, 0.5)};
}

// Eye above and behind the camera path, looking down at the middle of the map. "Up" is the
// cameras' mean -y axis: handheld and robot cameras are held roughly upright, while the world
// frame of a dataset (motion capture, first camera) has no agreed up direction.
SE3 chooseView(const std::vector<Eigen::Vector3d>& points, const std::vector<SE3>& camera_path, double elevation_deg) {
  Vec3 up = Vec3::UnitZ(), forward = Vec3::UnitX(), path_centre = Vec3::Zero();
  if (!camera_path.empty()) {
    Vec3 sum_up = Vec3::Zero(), sum_forward = Vec3::Zero();
    for (const SE3& T_w_c : camera_path) {
      const Mat3 R = T_w_c.rotation();
      sum_up -= R.col(1);
      sum_forward += R.col(2);
      path_centre += T_w_c.translation();
    }
    path_centre /= static_cast<double>(camera_path.size());
    if (sum_up.norm() > 1e-9) up = sum_up.normalized();
    forward = sum_forward - sum_forward.dot(up) * up;
    forward = forward.norm() > 1e-9 ? forward.normalized() : perpendicular(up);
  }
  const Vec3 target = robustCentre(points);
  if (camera_path.empty()) path_centre = target - forward;
  std::vector<double> distances;
  const size_t step = std::max<size_t>(1, points.size() / 20000);
  for (size_t i = 0; i < points.size(); i += step) distances.push_back((points[i] - target).norm());
  const double radius = std::max(0.5, percentile(distances, 0.9));
  const double elevation = elevation_deg * M_PI / 180.0;
  // Back off from the path along the horizontal viewing direction, then rise.
  const Vec3 eye = path_centre - forward * (radius * std::cos(elevation)) + up * (radius * std::sin(elevation));
  Vec3 z_axis = target - eye;
  z_axis = z_axis.norm() > 1e-9 ? z_axis.normalized() : forward;
  Vec3 x_axis = z_axis.cross(up);
  x_axis = x_axis.norm() > 1e-9 ? x_axis.normalized() : perpendicular(z_axis);
  const Vec3 y_axis = z_axis.cross(x_axis);
  Mat3 R;
  R << x_axis, y_axis, z_axis;
  return SE3(R, eye);
}

}  // namespace

cv::Mat renderMap(const open3d::geometry::PointCloud& cloud, const std::vector<SE3>& camera_path,
                  const RenderSettings& settings) {
  cv::Mat image(settings.height, settings.width, CV_8UC3, cv::Scalar(settings.background));
  if (cloud.points_.empty()) return image;

  const SE3 T_w_view = settings.T_w_view ? *settings.T_w_view : chooseView(cloud.points_, camera_path, settings.elevation_deg);
  const SE3 T_view_w = T_w_view.inverse();
  const Mat3 R = T_view_w.rotation();
  const Vec3 t = T_view_w.translation();
  constexpr double kNear = 0.05;

  // Fit the focal length and principal point to the middle 98 % of the projected points.
  std::vector<Vec3> p_view(cloud.points_.size());
  std::vector<double> xs, ys, zs;
  for (size_t i = 0; i < cloud.points_.size(); ++i) {
    p_view[i] = R * cloud.points_[i] + t;
    if (p_view[i].z() <= kNear) continue;
    xs.push_back(p_view[i].x() / p_view[i].z());
    ys.push_back(p_view[i].y() / p_view[i].z());
    zs.push_back(p_view[i].z());
  }
  if (zs.empty()) return image;
  double x_lo = percentile(xs, 0.01), x_hi = percentile(xs, 0.99);
  double y_lo = percentile(ys, 0.01), y_hi = percentile(ys, 0.99);
  if (settings.draw_camera_path) {  // keep the whole path in the picture too
    for (const SE3& T_w_c : camera_path) {
      const Vec3 p = R * T_w_c.translation() + t;
      if (p.z() <= kNear) continue;
      x_lo = std::min(x_lo, p.x() / p.z());
      x_hi = std::max(x_hi, p.x() / p.z());
      y_lo = std::min(y_lo, p.y() / p.z());
      y_hi = std::max(y_hi, p.y() / p.z());
    }
  }
  const double f = 0.9 * std::min(settings.width / std::max(x_hi - x_lo, 1e-6), settings.height / std::max(y_hi - y_lo, 1e-6));
  const double cx = settings.width / 2.0 - f * (x_lo + x_hi) / 2.0;
  const double cy = settings.height / 2.0 - f * (y_lo + y_hi) / 2.0;
  const double z_near = percentile(zs, 0.02), z_far = std::max(percentile(zs, 0.98), z_near + 1e-6);

  cv::Mat z_buffer(settings.height, settings.width, CV_32F, cv::Scalar(std::numeric_limits<float>::infinity()));
  const bool has_colours = cloud.colors_.size() == cloud.points_.size();
  for (size_t i = 0; i < p_view.size(); ++i) {
    const Vec3& p = p_view[i];
    if (p.z() <= kNear) continue;
    const double u = f * p.x() / p.z() + cx, v = f * p.y() / p.z() + cy;
    const int r = std::clamp(static_cast<int>(std::ceil(0.5 * f * settings.point_size / p.z())) - 1, 0,
                             settings.max_splat_radius);
    const int u0 = static_cast<int>(std::lround(u)), v0 = static_cast<int>(std::lround(v));
    if (u0 + r < 0 || v0 + r < 0 || u0 - r >= settings.width || v0 - r >= settings.height) continue;
    // Nearer points brighter: a cheap depth cue that separates overlapping surfaces.
    const double shade = 1.0 - 0.55 * std::clamp((p.z() - z_near) / (z_far - z_near), 0.0, 1.0);
    const Eigen::Vector3d rgb = has_colours ? cloud.colors_[i] : Eigen::Vector3d(0.8, 0.8, 0.8);
    const cv::Vec3b bgr(cv::saturate_cast<uint8_t>(255 * shade * rgb.z()), cv::saturate_cast<uint8_t>(255 * shade * rgb.y()),
                        cv::saturate_cast<uint8_t>(255 * shade * rgb.x()));
    const float z = static_cast<float>(p.z());
    for (int vv = std::max(0, v0 - r); vv <= std::min(settings.height - 1, v0 + r); ++vv) {
      float* zrow = z_buffer.ptr<float>(vv);
      cv::Vec3b* row = image.ptr<cv::Vec3b>(vv);
      for (int uu = std::max(0, u0 - r); uu <= std::min(settings.width - 1, u0 + r); ++uu) {
        if (z < zrow[uu]) {
          zrow[uu] = z;
          row[uu] = bgr;
        }
      }
    }
  }

  if (settings.draw_camera_path && !camera_path.empty()) {
    std::vector<cv::Point> path;
    for (const SE3& T_w_c : camera_path) {
      const Vec3 p = R * T_w_c.translation() + t;
      if (p.z() <= kNear) continue;
      path.emplace_back(static_cast<int>(std::lround(f * p.x() / p.z() + cx)),
                        static_cast<int>(std::lround(f * p.y() / p.z() + cy)));
    }
    if (path.size() >= 2) cv::polylines(image, path, false, cv::Scalar(0, 0, 255), 2, cv::LINE_AA);
    if (!path.empty()) cv::circle(image, path.front(), 5, cv::Scalar(0, 255, 0), cv::FILLED, cv::LINE_AA);
  }
  return image;
}

}  // namespace desslam::dense
