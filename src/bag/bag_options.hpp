// bag.*: ROS 1 bag input.
#pragma once

#include <string>

#include "core/option_fields.hpp"

namespace desslam {

// ROS 1 bag input (`desslam run <file.bag>`, src/bag): the topics read. A section of the config
// rather than run flags because the topics belong to the recording set-up, like the camera preset
// beside them, and so land in report.json's settings with everything else. Defaults: TUM RGB-D's.
struct BagOptions {
  std::string rgb_topic = "/camera/rgb/image_color";          // sensor_msgs/Image rgb8 or bgr8
  std::string depth_topic = "/camera/depth/image";            // sensor_msgs/Image 32FC1 m or 16UC1 mm
  std::string camera_info_topic = "/camera/rgb/camera_info";  // sensor_msgs/CameraInfo (intrinsics)

  static constexpr const char* kSection = "bag";
  template <class V> void fields(V& v) {
    v("rgb_topic", rgb_topic); v("depth_topic", depth_topic); v("camera_info_topic", camera_info_topic);
  }
  void validate() const;
};

}  // namespace desslam
