#include "semantic/deeplab_segmenter.hpp"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdlib>
#include <system_error>

#include <opencv2/dnn.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.hpp"
#include "semantic/sha256.hpp"

namespace desslam::semantic {
namespace fs = std::filesystem;

namespace {

std::string lowerCase(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

fs::path executableDir() {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);  // Linux; empty elsewhere
  return ec ? fs::path() : exe.parent_path();
}

std::string joinPaths(const std::vector<fs::path>& paths) {
  std::string out;
  for (const auto& p : paths) out += "\n  " + p.string();
  return out;
}

// Argmax over the class axis of a [1, C, H, W] float blob -> H x W CV_8U labels.
cv::Mat argmaxOverClasses(const cv::Mat& logits) {
  const int classes = logits.size[1], rows = logits.size[2], cols = logits.size[3];
  const std::size_t plane = std::size_t(rows) * cols;
  const auto* data = logits.ptr<float>();
  cv::Mat labels(rows, cols, CV_8U, cv::Scalar(0));
  cv::Mat best(rows, cols, CV_32F);
  std::copy(data, data + plane, best.ptr<float>());
  auto* best_ptr = best.ptr<float>();
  auto* label_ptr = labels.ptr<std::uint8_t>();
  // Channel-major sweep: reads each logit plane contiguously.
  for (int c = 1; c < classes; ++c) {
    const float* channel = data + c * plane;
    for (std::size_t i = 0; i < plane; ++i) {
      if (channel[i] > best_ptr[i]) {
        best_ptr[i] = channel[i];
        label_ptr[i] = std::uint8_t(c);
      }
    }
  }
  return labels;
}

}  // namespace

struct DeepLabSegmenter::Network {
  cv::dnn::Net net;
};

fs::path resolveModelPath(const SemanticOptions& options, std::vector<fs::path>* tried) {
  std::vector<fs::path> candidates;
  if (!options.model_path.empty()) {
    candidates.emplace_back(options.model_path);  // an explicit path is the only place looked at
  } else {
    if (const char* env = std::getenv("DESSLAM_SHARED_DIR"); env != nullptr && *env != '\0')
      candidates.push_back(fs::path(env) / "models" / kDeepLabModelFile);
    candidates.push_back(fs::path("..") / "shared" / "models" / kDeepLabModelFile);
    if (const fs::path exe_dir = executableDir(); !exe_dir.empty())
      candidates.push_back(exe_dir / ".." / ".." / "shared" / "models" / kDeepLabModelFile);
  }
  if (tried != nullptr) *tried = candidates;
  for (const auto& candidate : candidates) {
    std::error_code ec;
    if (fs::is_regular_file(candidate, ec)) return candidate.lexically_normal();
  }
  return {};
}

DeepLabSegmenter::DeepLabSegmenter(const SemanticOptions& options)
    : network_(std::make_unique<Network>()) {
  const std::string expected = lowerCase(options.model_sha256);
  const std::string where_to_get =
      std::string("Put ") + kDeepLabModelFile + " (sha256 " +
      (expected.empty() ? std::string("not checked") : expected) +
      ") there, or set semantic.model_path to it (see ../shared/models/README.md), "
      "or use semantic.segmenter = mask_dir | none.";

  std::vector<fs::path> tried;
  model_path_ = resolveModelPath(options, &tried);
  if (model_path_.empty()) {
    throw ConfigError("semantic model not found; looked at:" + joinPaths(tried) + "\n" +
                      where_to_get);
  }
  if (!expected.empty()) {
    const std::string actual = sha256FileHex(model_path_);
    if (actual != expected) {
      throw ConfigError("semantic model " + model_path_.string() + " has sha256 " + actual +
                        " but semantic.model_sha256 expects " + expected +
                        " (wrong or corrupt file). " + where_to_get);
    }
  }
  try {
    network_->net = cv::dnn::readNetFromONNX(model_path_.string());
  } catch (const cv::Exception& e) {
    throw ConfigError("semantic model " + model_path_.string() +
                      " could not be loaded by OpenCV dnn: " + e.what() + "\n" + where_to_get);
  }
  if (network_->net.empty()) {
    throw ConfigError("semantic model " + model_path_.string() + " loaded as an empty network. " +
                      where_to_get);
  }
  network_->net.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
  network_->net.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);

  dynamic_lut_ = cv::Mat(1, 256, CV_8U, cv::Scalar(0));
  for (int id : options.dynamic_classes) {
    if (id < 0 || id > 255)
      throw ConfigError("config key semantic.dynamic_classes: class id " + std::to_string(id) +
                        " is outside 0..255");
    dynamic_lut_.at<std::uint8_t>(id) = 255;
  }
}

DeepLabSegmenter::~DeepLabSegmenter() = default;

Segmentation DeepLabSegmenter::segment(const cv::Mat& bgr, const std::string& frame_name) {
  if (bgr.empty() || bgr.type() != CV_8UC3) {
    throw InputError("DeepLab segmenter: frame " + frame_name +
                     " is not a non-empty 8-bit BGR image (CV_8UC3)");
  }
  const auto start = std::chrono::steady_clock::now();

  // Model README: RGB, 257x257, (x - 127.5) / 127.5, NCHW.
  const cv::Mat blob = cv::dnn::blobFromImage(
      bgr, 1.0 / 127.5, cv::Size(kDeepLabInputSize, kDeepLabInputSize),
      cv::Scalar(127.5, 127.5, 127.5), /*swapRB=*/true, /*crop=*/false);
  network_->net.setInput(blob);
  const cv::Mat logits = network_->net.forward();
  if (logits.dims != 4 || logits.size[0] != 1 || logits.size[1] != kVocClassCount ||
      logits.type() != CV_32F) {
    throw ConfigError("semantic model " + model_path_.string() +
                      " does not output [1, 21, H, W] float logits; is it the PASCAL VOC DeepLab?");
  }

  Segmentation result;
  cv::resize(argmaxOverClasses(logits), result.labels, bgr.size(), 0, 0, cv::INTER_NEAREST);
  cv::LUT(result.labels, dynamic_lut_, result.dynamic_mask);
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace desslam::semantic
