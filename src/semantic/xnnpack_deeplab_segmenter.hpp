// DeepLabV3-MobileNetV2 (PASCAL VOC) through XNNPACK (semantic.backend = xnnpack): the ONNX
// file is read directly (onnx_reader.hpp, no converted file) and its graph rebuilt as an XNNPACK
// subgraph, fp32, NHWC (xnnpack_network.hpp). Same model file, same input and output steps
// (deeplab_common.hpp) as the OpenCV dnn backend; the person masks agree with it
// (tests/semantic/test_xnnpack_segmenter.cpp).
#pragma once

#include <filesystem>
#include <memory>
#include <string>

#include "semantic/deeplab_common.hpp"
#include "semantic/segmenter.hpp"
#include "semantic/xnnpack_network.hpp"

namespace desslam::semantic {

class XnnpackDeepLabSegmenter final : public Segmenter {
 public:
  // Resolves and hash-checks the model like DeepLabSegmenter, parses it and builds the XNNPACK
  // runtime. Threads: options.threads (1 = on the calling thread, no pool). Throws ConfigError
  // naming the file and the fix when the model is missing, wrong, unreadable or uses an op or
  // shape this backend does not support.
  explicit XnnpackDeepLabSegmenter(const SemanticOptions& options);
  ~XnnpackDeepLabSegmenter() override;

  Segmentation segment(const cv::Mat& bgr, const std::string& frame_name) override;
  std::string name() const override { return "deeplab"; }
  const std::filesystem::path& modelPath() const { return model_path_; }

 private:
  std::unique_ptr<XnnpackNetwork> network_;
  std::filesystem::path model_path_;
  cv::Mat dynamic_lut_;
};

}  // namespace desslam::semantic
