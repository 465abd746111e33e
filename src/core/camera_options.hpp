// camera.*: the pinhole camera and depth sensor of a run (core/camera.hpp builds on it).
#pragma once

#include <array>

#include "core/option_fields.hpp"

namespace desslam {

struct CameraOptions {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  int width = 640, height = 480;
  std::array<double, 5> distortion{0, 0, 0, 0, 0};  // k1 k2 p1 p2 k3 (OpenCV order)
  double depth_factor = 5000.0;  // raw 16-bit depth value per metre (TUM/Bonn: 5000)
  double fps = 30.0;
  // Depth residuals are expressed as a virtual stereo disparity bf/z (pixels), as for RGB-D
  // keypoints in the ORB-SLAM2 paper; bf = fx * depth_baseline (Kinect-like sensors: ~8 cm).
  double depth_baseline = 0.08;  // metres

  // The virtual stereo baseline times fx (pixel * metres): the one place it is computed.
  double bf() const { return fx * depth_baseline; }

  static constexpr const char* kSection = "camera";
  template <class V> void fields(V& v) {
    v("fx", fx); v("fy", fy); v("cx", cx); v("cy", cy); v("width", width); v("height", height);
    v("distortion", distortion); v("depth_factor", depth_factor); v("fps", fps); v("depth_baseline", depth_baseline);
  }
  void validate() const;
};

}  // namespace desslam
