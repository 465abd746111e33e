#include "semantic/mask_directory_segmenter.hpp"

#include <chrono>
#include <system_error>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/error.hpp"

namespace desslam::semantic {

MaskDirectorySegmenter::MaskDirectorySegmenter(std::filesystem::path directory)
    : directory_(std::move(directory)) {
  std::error_code ec;
  if (!std::filesystem::is_directory(directory_, ec)) {
    throw InputError("mask directory " + directory_.string() +
                     " does not exist; set semantic.mask_dir to a folder with one PNG per RGB frame");
  }
}

Segmentation MaskDirectorySegmenter::segment(const cv::Mat& bgr, const std::string& frame_name) {
  const auto start = std::chrono::steady_clock::now();
  const std::filesystem::path file = directory_ / frame_name;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec)) {
    throw InputError("mask file " + file.string() + " is missing; the mask directory needs one PNG "
                     "per RGB frame, with the RGB file's name (nonzero = dynamic)");
  }
  const cv::Mat mask = cv::imread(file.string(), cv::IMREAD_UNCHANGED);
  if (mask.empty()) throw InputError("mask file " + file.string() + " could not be read as an image");
  if (!bgr.empty() && mask.size() != bgr.size()) {
    throw InputError("mask file " + file.string() + " is " + std::to_string(mask.cols) + "x" +
                     std::to_string(mask.rows) + " but its RGB frame is " + std::to_string(bgr.cols) +
                     "x" + std::to_string(bgr.rows));
  }

  // A pixel is dynamic when any colour channel is nonzero (8- or 16-bit, gray or colour masks);
  // an alpha channel (gray+alpha, BGRA) is ignored, since it is usually opaque everywhere.
  const int colour_channels = mask.channels() == 2 || mask.channels() == 4 ? mask.channels() - 1
                                                                           : mask.channels();
  Segmentation result;
  result.dynamic_mask = cv::Mat(mask.size(), CV_8U, cv::Scalar(0));
  cv::Mat channel, nonzero;
  for (int c = 0; c < colour_channels; ++c) {
    cv::extractChannel(mask, channel, c);
    cv::compare(channel, 0, nonzero, cv::CMP_NE);
    result.dynamic_mask |= nonzero;
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace desslam::semantic
