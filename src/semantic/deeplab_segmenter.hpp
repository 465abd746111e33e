// DeepLabV3-MobileNetV2 (PASCAL VOC, 21 classes) through OpenCV dnn, CPU backend
// (semantic.backend = opencv, the reference). The model file is described in
// ../shared/models/README.md; model lookup, input and output steps are in deeplab_common.hpp.
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "semantic/deeplab_common.hpp"
#include "semantic/segmenter.hpp"

namespace desslam::semantic {

class DeepLabSegmenter final : public Segmenter {
 public:
  // Resolves the model, checks its sha256 against options.model_sha256 (skipped when that is
  // empty) and loads it. Throws ConfigError saying where to put the model and its expected sha256
  // when the file is missing, has the wrong hash, or cannot be loaded.
  // Threads: OpenCV dnn uses the process-wide cv::setNumThreads(); the application sets it
  // (from SemanticOptions::threads), the library never does.
  explicit DeepLabSegmenter(const SemanticOptions& options);
  ~DeepLabSegmenter() override;

  Segmentation segment(const cv::Mat& bgr, const std::string& frame_name) override;
  std::string name() const override { return "deeplab"; }
  const std::filesystem::path& modelPath() const { return model_path_; }

 private:
  struct Network;  // keeps <opencv2/dnn.hpp> out of this header
  std::unique_ptr<Network> network_;
  std::filesystem::path model_path_;
  cv::Mat dynamic_lut_;  // 1x256 CV_8U: class id -> 0 or 255
};

}  // namespace desslam::semantic
