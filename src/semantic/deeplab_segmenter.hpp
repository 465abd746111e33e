// DeepLabV3-MobileNetV2 (PASCAL VOC, 21 classes) through OpenCV dnn, CPU backend.
// The model file is described in ../shared/models/README.md.
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "semantic/segmenter.hpp"

namespace desslam::semantic {

inline constexpr const char* kDeepLabModelFile = "deeplabv3_mnv2_voc_257.onnx";
inline constexpr int kDeepLabInputSize = 257;
inline constexpr int kVocClassCount = 21;
inline constexpr int kVocPerson = 15;

// Where the model is looked for, in order:
//   1. options.model_path when set (only there);
//   2. $DESSLAM_SHARED_DIR/models/<file>;
//   3. ../shared/models/<file> relative to the working directory;
//   4. <executable dir>/../../shared/models/<file>.
// Returns the first that exists, or an empty path; `tried` (if given) receives every candidate.
std::filesystem::path resolveModelPath(const SemanticOptions& options,
                                       std::vector<std::filesystem::path>* tried = nullptr);

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
