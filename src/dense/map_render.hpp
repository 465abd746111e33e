// A small offscreen renderer for map previews: points projected with a z-buffer from a
// viewpoint above and behind the camera path, square splats, depth shading. No display needed.
#pragma once

#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "core/se3.hpp"

namespace open3d::geometry {
class PointCloud;
}

namespace desslam::dense {

struct RenderSettings {
  int width = 1024;
  int height = 768;
  double point_size = 0.01;      // metres a point covers (the map's voxel size): sets splat size
  int max_splat_radius = 4;      // pixels
  double elevation_deg = 35.0;   // how far above the mean viewing direction the eye looks down
  bool draw_camera_path = true;  // red polyline through the camera centres, green dot at the start
  // Explicit viewpoint (x right, y down, z forward, like a camera); the focal length still fits
  // the cloud into the image. Empty: chosen from the camera path as described above.
  std::optional<SE3> T_w_view;
  cv::Vec3b background{40, 40, 40};  // BGR
};

// BGR CV_8UC3 image of the cloud. camera_path gives T_w_c of the cameras (may be empty: then
// the view looks along world +x with +z up). An empty cloud gives a background-only image.
cv::Mat renderMap(const open3d::geometry::PointCloud& cloud, const std::vector<SE3>& camera_path,
                  const RenderSettings& settings = {});

}  // namespace desslam::dense
