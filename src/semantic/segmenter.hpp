// Segmenter interface: one RGB image in, a per-pixel dynamic mask (and class labels) out.
#pragma once

#include <memory>
#include <string>

#include <opencv2/core/mat.hpp>

#include "semantic/semantic_options.hpp"

namespace desslam::semantic {

struct Segmentation {
  cv::Mat labels;        // CV_8U class id per pixel (image size); empty for mask directories
  cv::Mat dynamic_mask;  // CV_8U (image size), 255 where a pixel belongs to a dynamic class, else 0
  double seconds = 0;    // time spent segmenting this frame
};

// Implementations are not thread-safe: one thread (the semantic thread) calls segment().
class Segmenter {
 public:
  virtual ~Segmenter() = default;
  // bgr: CV_8UC3 image. frame_name: the RGB file name (e.g. "1305031102.175304.png"); mask
  // directories look their mask up by it, the network ignores it.
  // Throws InputError when the image (or its mask file) is unusable.
  virtual Segmentation segment(const cv::Mat& bgr, const std::string& frame_name) = 0;
  virtual std::string name() const = 0;
};

// Builds the segmenter options.segmenter names: deeplab (through options.backend: opencv or
// xnnpack), mask_dir, or nullptr for none. Throws ConfigError (model missing or wrong, xnnpack
// asked of a build without it) or InputError (mask dir missing).
std::unique_ptr<Segmenter> makeSegmenter(const SemanticOptions& options);

// Whether this build has the XNNPACK backend (libxnnpack-dev was found by CMake).
bool haveXnnpackBackend();

}  // namespace desslam::semantic
