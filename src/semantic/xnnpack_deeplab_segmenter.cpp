#include "semantic/xnnpack_deeplab_segmenter.hpp"

#include <chrono>
#include <cstring>

#include "core/error.hpp"
#include "semantic/onnx_reader.hpp"
#include "semantic/xnnpack_network.hpp"

namespace desslam::semantic {

XnnpackDeepLabSegmenter::XnnpackDeepLabSegmenter(const SemanticOptions& options) {
  const deeplab::ModelFile model_file = deeplab::locateModel(options);
  model_path_ = model_file.path;
  const std::string where = "semantic model " + model_path_.string();

  onnx::Model model;
  try {
    model = onnx::readModel(model_path_);
  } catch (const onnx::FormatError& e) {
    throw ConfigError(where + " is not a readable ONNX model (" + e.what() + "). " + model_file.where_to_get);
  }
  try {
    network_ = std::make_unique<XnnpackNetwork>(model, options.threads);
  } catch (const XnnpackError& e) {
    throw ConfigError(where + " cannot run on the XNNPACK backend: " + e.what() +
                      ". Use semantic.backend = opencv, or the model of ../shared/models/README.md.");
  }
  const auto& in = network_->inputShape();
  const auto& out = network_->outputShape();
  if (in[0] != 1 || in[1] != std::size_t(kDeepLabInputSize) || in[2] != std::size_t(kDeepLabInputSize) ||
      in[3] != 3 || out[0] != 1 || out[3] != std::size_t(kVocClassCount)) {
    throw ConfigError(where + " does not map a [1, 3, 257, 257] input to [1, 21, H, W] logits; is it the "
                      "PASCAL VOC DeepLab? " + model_file.where_to_get);
  }
  dynamic_lut_ = deeplab::dynamicClassLut(options.dynamic_classes);
}

XnnpackDeepLabSegmenter::~XnnpackDeepLabSegmenter() = default;

Segmentation XnnpackDeepLabSegmenter::segment(const cv::Mat& bgr, const std::string& frame_name) {
  deeplab::checkInput(bgr, frame_name);
  const auto start = std::chrono::steady_clock::now();

  const cv::Mat input = deeplab::networkInput(bgr);  // CV_32FC3 = NHWC, continuous
  CV_Assert(input.isContinuous() && input.rows == kDeepLabInputSize && input.cols == kDeepLabInputSize);
  std::memcpy(network_->input(), input.ptr<float>(), input.total() * 3 * sizeof(float));
  const float* logits = nullptr;
  try {
    logits = network_->run();
  } catch (const XnnpackError& e) {
    throw InputError("DeepLab segmenter (XNNPACK): frame " + frame_name + ": " + e.what());
  }
  const auto& out = network_->outputShape();
  const cv::Mat labels = deeplab::argmaxOverClasses(logits, int(out[3]), int(out[1]), int(out[2]), 1, out[3]);
  return deeplab::finish(labels, bgr.size(), dynamic_lut_, start);
}

}  // namespace desslam::semantic
