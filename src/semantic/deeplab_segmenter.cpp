#include "semantic/deeplab_segmenter.hpp"

#include <chrono>

#include <opencv2/dnn.hpp>

#include "core/error.hpp"

namespace desslam::semantic {

struct DeepLabSegmenter::Network {
  cv::dnn::Net net;
};

DeepLabSegmenter::DeepLabSegmenter(const SemanticOptions& options)
    : network_(std::make_unique<Network>()) {
  const deeplab::ModelFile model = deeplab::locateModel(options);
  model_path_ = model.path;
  try {
    network_->net = cv::dnn::readNetFromONNX(model_path_.string());
  } catch (const cv::Exception& e) {
    throw ConfigError("semantic model " + model_path_.string() +
                      " could not be loaded by OpenCV dnn: " + e.what() + "\n" + model.where_to_get);
  }
  if (network_->net.empty()) {
    throw ConfigError("semantic model " + model_path_.string() + " loaded as an empty network. " +
                      model.where_to_get);
  }
  network_->net.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
  network_->net.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
  dynamic_lut_ = deeplab::dynamicClassLut(options.dynamic_classes);
}

DeepLabSegmenter::~DeepLabSegmenter() = default;

Segmentation DeepLabSegmenter::segment(const cv::Mat& bgr, const std::string& frame_name) {
  deeplab::checkInput(bgr, frame_name);
  const auto start = std::chrono::steady_clock::now();

  network_->net.setInput(cv::dnn::blobFromImage(deeplab::networkInput(bgr)));  // NHWC -> NCHW
  const cv::Mat logits = network_->net.forward();
  if (logits.dims != 4 || logits.size[0] != 1 || logits.size[1] != kVocClassCount ||
      logits.type() != CV_32F) {
    throw ConfigError("semantic model " + model_path_.string() +
                      " does not output [1, 21, H, W] float logits; is it the PASCAL VOC DeepLab?");
  }
  const int rows = logits.size[2], cols = logits.size[3];
  const cv::Mat labels = deeplab::argmaxOverClasses(logits.ptr<float>(), kVocClassCount, rows, cols,
                                                    std::size_t(rows) * cols, 1);
  return deeplab::finish(labels, bgr.size(), dynamic_lut_, start);
}

}  // namespace desslam::semantic
