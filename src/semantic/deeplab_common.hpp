// What both DeepLab backends (OpenCV dnn and XNNPACK) share: the model file (where it is looked
// for, its hash check and the error messages), the network input (resize, RGB, scaling) and the
// output (argmax over the classes, resize to the image, dynamic mask). The model file is
// described in ../shared/models/README.md.
#pragma once

#include <chrono>
#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "semantic/segmenter.hpp"
#include "semantic/semantic_options.hpp"

namespace desslam::semantic {

inline constexpr const char* kDeepLabModelFile = "deeplabv3_mnv2_voc_257.onnx";
inline constexpr int kDeepLabInputSize = 257;
inline constexpr int kVocClassCount = 21;
inline constexpr int kVocPerson = 15;

// Where the model is looked for, in order:
//   1. options.model_path when set (only there);
//   2. $DESSLAM_SHARED_DIR/models/<file>;
//   3. ../shared/models/<file> relative to the working directory;
//   4. <executable dir>/../../shared/models/<file>;
//   5. models/<file> in the data folders (core/data_location.hpp, e.g. <prefix>/share/desslam).
// Returns the first that exists, or an empty path; `tried` (if given) receives every candidate.
std::filesystem::path resolveModelPath(const SemanticOptions& options,
                                       std::vector<std::filesystem::path>* tried = nullptr);

namespace deeplab {

struct ModelFile {
  std::filesystem::path path;
  std::string where_to_get;  // the fix, appended to every model error message
};

// Resolves the model and checks its sha256 against options.model_sha256 (skipped when that is
// empty). Throws ConfigError naming the places looked at (or the file and both hashes) and the fix.
ModelFile locateModel(const SemanticOptions& options);

// Throws InputError unless bgr is a non-empty CV_8UC3 image.
void checkInput(const cv::Mat& bgr, const std::string& frame_name);

// The network input as an image: kDeepLabInputSize^2, RGB, (x - 127.5) / 127.5, CV_32FC3
// (i.e. NHWC). cv::dnn::blobFromImage(networkInput(bgr)) is the NCHW blob of the model README.
cv::Mat networkInput(const cv::Mat& bgr);

// Argmax over the classes of float logits -> rows x cols CV_8U labels (the first of equal
// maxima wins). Element (class c, row y, col x) is at data[c * class_stride + (y * cols + x) *
// pixel_stride]: NCHW is (rows * cols, 1), NHWC is (1, classes).
cv::Mat argmaxOverClasses(const float* data, int classes, int rows, int cols,
                          std::size_t class_stride, std::size_t pixel_stride);

// 1x256 CV_8U: class id -> 255 for options.dynamic_classes, else 0. Throws ConfigError for ids
// outside 0..255.
cv::Mat dynamicClassLut(const std::vector<int>& dynamic_classes);

// Labels at network resolution -> Segmentation at image_size (nearest), mask through the LUT,
// seconds since start.
Segmentation finish(const cv::Mat& network_labels, cv::Size image_size, const cv::Mat& lut,
                    std::chrono::steady_clock::time_point start);

}  // namespace deeplab
}  // namespace desslam::semantic
