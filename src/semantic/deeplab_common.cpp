#include "semantic/deeplab_common.hpp"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <system_error>

#include <opencv2/imgproc.hpp>

#include "core/data_location.hpp"
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

}  // namespace

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
    // models/ in the data folders: where an installed library's user can put the model.
    for (const fs::path& data_dir : dataDirectories()) candidates.push_back(data_dir / "models" / kDeepLabModelFile);
  }
  if (tried != nullptr) *tried = candidates;
  for (const auto& candidate : candidates) {
    std::error_code ec;
    if (fs::is_regular_file(candidate, ec)) return candidate.lexically_normal();
  }
  return {};
}

namespace deeplab {

ModelFile locateModel(const SemanticOptions& options) {
  const std::string expected = lowerCase(options.model_sha256);
  ModelFile model;
  model.where_to_get =
      std::string("Put ") + kDeepLabModelFile + " (sha256 " +
      (expected.empty() ? std::string("not checked") : expected) +
      ") there, or set semantic.model_path to it (see ../shared/models/README.md), "
      "or use semantic.segmenter = mask_dir | none.";

  std::vector<fs::path> tried;
  model.path = resolveModelPath(options, &tried);
  if (model.path.empty()) {
    throw ConfigError("semantic model not found; looked at:" + joinPaths(tried) + "\n" +
                      model.where_to_get);
  }
  if (!expected.empty()) {
    const std::string actual = sha256FileHex(model.path);
    if (actual != expected) {
      throw ConfigError("semantic model " + model.path.string() + " has sha256 " + actual +
                        " but semantic.model_sha256 expects " + expected +
                        " (wrong or corrupt file). " + model.where_to_get);
    }
  }
  return model;
}

void checkInput(const cv::Mat& bgr, const std::string& frame_name) {
  if (bgr.empty() || bgr.type() != CV_8UC3) {
    throw InputError("DeepLab segmenter: frame " + frame_name +
                     " is not a non-empty 8-bit BGR image (CV_8UC3)");
  }
}

cv::Mat networkInput(const cv::Mat& bgr) {
  // The same steps, in the same order, as cv::dnn::blobFromImage(bgr, 1 / 127.5, {257, 257},
  // {127.5, 127.5, 127.5}, swapRB = true): bilinear resize of the 8-bit image, float, - mean, * scale.
  cv::Mat resized;
  const cv::Size size(kDeepLabInputSize, kDeepLabInputSize);
  if (bgr.size() != size) cv::resize(bgr, resized, size, 0, 0, cv::INTER_LINEAR);
  else resized = bgr;
  cv::Mat rgb;
  cv::cvtColor(resized, rgb, cv::COLOR_BGR2RGB);
  cv::Mat input;
  rgb.convertTo(input, CV_32F);
  input -= cv::Scalar::all(127.5);
  input *= 1.0 / 127.5;
  return input;
}

cv::Mat argmaxOverClasses(const float* data, int classes, int rows, int cols,
                          std::size_t class_stride, std::size_t pixel_stride) {
  cv::Mat labels(rows, cols, CV_8U);
  auto* label_ptr = labels.ptr<std::uint8_t>();
  const std::size_t pixels = std::size_t(rows) * cols;
  for (std::size_t i = 0; i < pixels; ++i) {
    const float* pixel = data + i * pixel_stride;
    float best = pixel[0];
    int best_class = 0;
    for (int c = 1; c < classes; ++c) {
      const float v = pixel[std::size_t(c) * class_stride];
      if (v > best) {
        best = v;
        best_class = c;
      }
    }
    label_ptr[i] = std::uint8_t(best_class);
  }
  return labels;
}

cv::Mat dynamicClassLut(const std::vector<int>& dynamic_classes) {
  cv::Mat lut(1, 256, CV_8U, cv::Scalar(0));
  for (int id : dynamic_classes) {
    if (id < 0 || id > 255)
      throw ConfigError("config key semantic.dynamic_classes: class id " + std::to_string(id) +
                        " is outside 0..255");
    lut.at<std::uint8_t>(id) = 255;
  }
  return lut;
}

Segmentation finish(const cv::Mat& network_labels, cv::Size image_size, const cv::Mat& lut,
                    std::chrono::steady_clock::time_point start) {
  Segmentation result;
  cv::resize(network_labels, result.labels, image_size, 0, 0, cv::INTER_NEAREST);
  cv::LUT(result.labels, lut, result.dynamic_mask);
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace deeplab
}  // namespace desslam::semantic
