// libFuzzer target: a depth PNG as a run reads it: decoded by OpenCV, checked (16-bit, camera
// size) and converted to metres, then the depth statistics of the plausibility check. Only PNG
// input (other formats would fuzz OpenCV's other codecs); images are capped at 4 Mpixel.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "core/error.hpp"
#include "io/tum_dataset.hpp"
#include "plausibility/depth_scale.hpp"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  setenv("OPENCV_IO_MAX_IMAGE_PIXELS", "4194304", 1);  // read by OpenCV once, before the first decode
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const uint8_t kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (size < 8 || std::memcmp(data, kPng, 8) != 0) return 0;
  const std::vector<uint8_t> buffer(data, data + size);
  cv::Mat raw;
  try {
    raw = cv::imdecode(buffer, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception&) {
    return 0;
  }
  desslam::CameraOptions camera;
  camera.width = raw.empty() ? 640 : raw.cols;
  camera.height = raw.empty() ? 480 : raw.rows;
  camera.depth_factor = 5000;
  try {
    const cv::Mat depth = desslam::io::depthToMetres(raw, "fuzz/depth.png", camera);
    const desslam::plausibility::DepthStatistics stats = desslam::plausibility::depthStatistics({depth});
    if (stats.valid_share < 0 || stats.valid_share > 1) __builtin_trap();
  } catch (const desslam::InputError&) {
  }
  return 0;
}
