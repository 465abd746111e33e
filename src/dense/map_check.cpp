#include "dense/map_check.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/error.hpp"

namespace desslam::dense {

MapCheckResult freeSpaceViolations(const std::vector<Vec3>& points_w, const std::vector<Timestamp>& source_times,
                                   const std::vector<DenseKeyframe>& keyframes, const PinholeCamera& camera,
                                   const MapCheckOptions& options) {
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
      // Nearest reading in the window, among valid ones: the surface closest to the camera
      // decides whether the ray could have passed the point.
      float nearest = 0;
      const int r = options.window_radius_px;
      for (int vv = std::max<long>(0, v - r); vv <= std::min<long>(camera.height() - 1, v + r); ++vv) {
        const float* row = view.depth->ptr<float>(vv);
        for (int uu = std::max<long>(0, u - r); uu <= std::min<long>(camera.width() - 1, u + r); ++uu) {
          if (row[uu] > 0 && (nearest == 0 || row[uu] < nearest)) nearest = row[uu];
        }
      }
      if (!(nearest > 0)) continue;
      checked = true;
      if (nearest > p_c.z() + options.tolerance) {
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
                                   const PinholeCamera& camera, const MapCheckOptions& options) {
  std::vector<Vec3> points;
  std::vector<Timestamp> times;
  for (const WorldScan& scan : scans) {
    points.insert(points.end(), scan.points_w.begin(), scan.points_w.end());
    times.insert(times.end(), scan.points_w.size(), scan.timestamp);
  }
  return freeSpaceViolations(points, times, keyframes, camera, options);
}

}  // namespace desslam::dense
