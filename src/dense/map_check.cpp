#include "dense/map_check.hpp"

#include <cmath>
#include <string>

#include "core/error.hpp"

namespace desslam::dense {

MapCheckResult freeSpaceViolations(const std::vector<Vec3>& points_w, const std::vector<Timestamp>& source_times,
                                   const std::vector<DenseKeyframe>& keyframes, const PinholeCamera& camera,
                                   double tolerance) {
  if (points_w.size() != source_times.size())
    throw InputError("freeSpaceViolations: " + std::to_string(points_w.size()) + " points but " +
                     std::to_string(source_times.size()) + " source times; pass one time per point");
  struct View {
    Timestamp timestamp;
    Mat3 R_c_w;
    Vec3 t_c_w;
    const cv::Mat* depth;
  };
  std::vector<View> views;
  views.reserve(keyframes.size());
  for (const DenseKeyframe& kf : keyframes) {
    if (kf.depth.type() != CV_32FC1 || kf.depth.cols != camera.width() || kf.depth.rows != camera.height())
      throw InputError("freeSpaceViolations: keyframe " + std::to_string(kf.keyframe_id) +
                       " depth must be CV_32F metres of the camera's size");
    const SE3 T_c_w = kf.T_w_c.inverse();
    views.push_back({kf.timestamp, T_c_w.rotation(), T_c_w.translation(), &kf.depth});
  }

  MapCheckResult result;
  for (size_t i = 0; i < points_w.size(); ++i) {
    bool checked = false, violated = false;
    for (const View& view : views) {
      if (view.timestamp <= source_times[i]) continue;
      const Vec3 p_c = view.R_c_w * points_w[i] + view.t_c_w;
      if (p_c.z() <= 0) continue;
      const Vec2 uv_raw = camera.distort(camera.project(p_c));
      const long u = std::lround(uv_raw.x()), v = std::lround(uv_raw.y());
      if (u < 0 || v < 0 || u >= camera.width() || v >= camera.height()) continue;
      const float observed = view.depth->at<float>(static_cast<int>(v), static_cast<int>(u));
      if (!(observed > 0)) continue;
      checked = true;
      if (observed > p_c.z() + tolerance) {
        violated = true;
        break;
      }
    }
    result.checked += checked ? 1 : 0;
    result.violations += violated ? 1 : 0;
  }
  return result;
}

MapCheckResult freeSpaceViolations(const std::vector<WorldScan>& scans, const std::vector<DenseKeyframe>& keyframes,
                                   const PinholeCamera& camera, double tolerance) {
  std::vector<Vec3> points;
  std::vector<Timestamp> times;
  for (const WorldScan& scan : scans) {
    points.insert(points.end(), scan.points_w.begin(), scan.points_w.end());
    times.insert(times.end(), scan.points_w.size(), scan.timestamp);
  }
  return freeSpaceViolations(points, times, keyframes, camera, tolerance);
}

}  // namespace desslam::dense
