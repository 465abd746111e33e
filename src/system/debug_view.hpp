// --debug-images: a frame with its semantic mask overlaid and each feature coloured by what the
// dynamic checks decided (green static, red stage 1, magenta stage 2, orange dropped by the mask).
#pragma once

#include <opencv2/core.hpp>

#include "map/frame.hpp"

namespace desslam::system {

cv::Mat drawDynamicDebugView(const cv::Mat& bgr, const cv::Mat& mask, const map::Frame& frame);

}  // namespace desslam::system
