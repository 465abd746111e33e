// The XNNPACK backend of the DeepLab segmenter (semantic.backend = xnnpack) against the OpenCV
// dnn reference: same person masks on real frames of both shared clips, clear errors for a
// missing or corrupt model, and the backend option's validation.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/error.hpp"
#include "semantic/deeplab_common.hpp"
#include "semantic/segmenter.hpp"
#include "semantic/sha256.hpp"
#include "support/shared_data.hpp"
#include "support/temp_dir.hpp"

namespace desslam::semantic {
namespace {

namespace fs = std::filesystem;

fs::path sharedModel() { return test::sharedDir() / "models" / kDeepLabModelFile; }

#define REQUIRE_XNNPACK()                                                                        \
  do {                                                                                           \
    if (!haveXnnpackBackend())                                                                   \
      GTEST_SKIP() << "this build has no XNNPACK backend (install libxnnpack-dev and "          \
                      "libpthreadpool-dev, as scripts/install-and-build.sh does, and rebuild)";  \
  } while (0)

std::string configErrorOf(const SemanticOptions& options) {
  try {
    makeSegmenter(options);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

SemanticOptions xnnpackOptions(const std::string& model_path) {
  SemanticOptions options;
  options.backend = SegmentationBackend::kXnnpack;
  options.model_path = model_path;
  return options;
}

// --- option -------------------------------------------------------------------------------

TEST(SemanticBackendOption, DefaultsToXnnpack) {
  EXPECT_EQ(SemanticOptions{}.backend, SegmentationBackend::kXnnpack);
}

TEST(SemanticBackendOption, AcceptsBothBackends) {
  for (SegmentationBackend backend : {SegmentationBackend::kOpenCv, SegmentationBackend::kXnnpack}) {
    SemanticOptions options;
    options.backend = backend;
    EXPECT_NO_THROW(options.validate()) << nameOf(backend);
  }
}

// An unknown backend name is rejected where the config is read (tests/io/test_config.cpp).

TEST(SemanticBackendOption, NoBackendIsBuiltForOtherSegmenters) {
  SemanticOptions options;
  options.segmenter = SegmenterKind::kNone;
  options.backend = SegmentationBackend::kXnnpack;
  EXPECT_EQ(makeSegmenter(options), nullptr);
}

TEST(SemanticBackendOption, XnnpackInABuildWithoutItSaysHowToGetIt) {
  if (haveXnnpackBackend()) GTEST_SKIP() << "this build has the XNNPACK backend";
  SemanticOptions options;
  options.backend = SegmentationBackend::kXnnpack;
  const std::string message = configErrorOf(options);
  EXPECT_NE(message.find("libxnnpack-dev"), std::string::npos) << message;
  EXPECT_NE(message.find("semantic.backend = opencv"), std::string::npos) << message;
}

// --- model errors -------------------------------------------------------------------------

TEST(XnnpackModel, MissingModelNamesPathHashAndFix) {
  REQUIRE_XNNPACK();
  const std::string message = configErrorOf(xnnpackOptions("/nonexistent/desslam/model.onnx"));
  EXPECT_NE(message.find("/nonexistent/desslam/model.onnx"), std::string::npos) << message;
  EXPECT_NE(message.find(SemanticOptions{}.model_sha256), std::string::npos) << message;
  EXPECT_NE(message.find("semantic.model_path"), std::string::npos) << message;
}

TEST(XnnpackModel, CorruptModelFailsTheHashCheck) {
  REQUIRE_XNNPACK();
  test::TempDir dir;
  const fs::path file = dir.path() / "model.onnx";
  std::ofstream(file) << "not a network";
  const std::string message = configErrorOf(xnnpackOptions(file.string()));
  EXPECT_NE(message.find(file.string()), std::string::npos) << message;
  EXPECT_NE(message.find(sha256Hex("not a network")), std::string::npos) << message;
  EXPECT_NE(message.find("wrong or corrupt"), std::string::npos) << message;
}

TEST(XnnpackModel, UnparsableFileWithoutHashCheckNamesTheFile) {
  REQUIRE_XNNPACK();
  test::TempDir dir;
  const fs::path file = dir.path() / "model.onnx";
  std::ofstream(file) << "not a network";
  SemanticOptions options = xnnpackOptions(file.string());
  options.model_sha256.clear();
  const std::string message = configErrorOf(options);
  EXPECT_NE(message.find(file.string()), std::string::npos) << message;
  EXPECT_NE(message.find("not a readable ONNX model"), std::string::npos) << message;
  EXPECT_NE(message.find("semantic.model_path"), std::string::npos) << message;
}

TEST(XnnpackModel, TruncatedModelWithoutHashCheckIsAConfigError) {
  REQUIRE_XNNPACK();
  DESSLAM_REQUIRE_SHARED(sharedModel());
  std::ifstream in(sharedModel(), std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  test::TempDir dir;
  for (const double share : {0.1, 0.5, 0.999}) {
    const fs::path file = dir.path() / ("cut_" + std::to_string(int(share * 1000)) + ".onnx");
    std::ofstream(file, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size() * share));
    SemanticOptions options = xnnpackOptions(file.string());
    options.model_sha256.clear();
    const std::string message = configErrorOf(options);
    EXPECT_NE(message.find(file.string()), std::string::npos) << share << ": " << message;
  }
}

// --- agreement with the OpenCV dnn reference ------------------------------------------------

struct ClipAgreement {
  int frames = 0;
  double intersection = 0, unite = 0, label_agreement = 0, min_frame_iou = 1;
};

// Every `step`-th frame of the clip through both backends (1 thread each).
ClipAgreement compareOnClip(const std::string& clip, int step) {
  SemanticOptions reference_options;
  reference_options.model_path = sharedModel().string();
  SemanticOptions fast_options = xnnpackOptions(sharedModel().string());
  const int saved_threads = cv::getNumThreads();
  cv::setNumThreads(1);
  auto reference = makeSegmenter(reference_options);
  auto fast = makeSegmenter(fast_options);

  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(test::clipDir(clip) / "rgb"))
    if (entry.path().extension() == ".png") files.push_back(entry.path());
  std::sort(files.begin(), files.end());

  ClipAgreement agreement;
  for (std::size_t i = 0; i < files.size(); i += std::size_t(step)) {
    const cv::Mat bgr = cv::imread(files[i].string(), cv::IMREAD_COLOR);
    const Segmentation a = reference->segment(bgr, files[i].filename().string());
    const Segmentation b = fast->segment(bgr, files[i].filename().string());
    EXPECT_EQ(b.labels.size(), bgr.size());
    EXPECT_EQ(b.dynamic_mask.size(), bgr.size());
    const double inter = cv::countNonZero(a.dynamic_mask & b.dynamic_mask);
    const double uni = cv::countNonZero(a.dynamic_mask | b.dynamic_mask);
    agreement.intersection += inter;
    agreement.unite += uni;
    if (uni >= 500) agreement.min_frame_iou = std::min(agreement.min_frame_iou, inter / uni);
    agreement.label_agreement += 1.0 - double(cv::countNonZero(a.labels != b.labels)) / double(bgr.total());
    ++agreement.frames;
  }
  agreement.label_agreement /= std::max(1, agreement.frames);
  cv::setNumThreads(saved_threads);
  return agreement;
}

class XnnpackAgreesWithOpenCv : public ::testing::TestWithParam<const char*> {};

TEST_P(XnnpackAgreesWithOpenCv, PersonMaskIouOnClip) {
  REQUIRE_XNNPACK();
  DESSLAM_REQUIRE_SHARED(sharedModel());
  DESSLAM_REQUIRE_SHARED(test::clipDir(GetParam()) / "rgb");
  const ClipAgreement a = compareOnClip(GetParam(), 5);
  ASSERT_GT(a.frames, 0);
  ASSERT_GT(a.unite, 0) << "no person pixels at all on " << GetParam();
  const double iou = a.intersection / a.unite;
  std::printf("[ figures  ] %s: %d frames, person-mask IoU %.6f (min per frame %.6f), labels agree "
              "on %.6f of pixels, person pixels (union) %.0f\n",
              GetParam(), a.frames, iou, a.min_frame_iou, a.label_agreement, a.unite);
  EXPECT_GE(iou, 0.99);
  EXPECT_GE(a.min_frame_iou, 0.97);
  EXPECT_GE(a.label_agreement, 0.99);
}

INSTANTIATE_TEST_SUITE_P(SharedClips, XnnpackAgreesWithOpenCv,
                         ::testing::Values("bonn_crowd_0300_0399", "fr1_xyz_0000_0099"));

// --- the segmenter itself -------------------------------------------------------------------

class XnnpackOnFrames : public ::testing::Test {
 protected:
  void SetUp() override {
    REQUIRE_XNNPACK();
    DESSLAM_REQUIRE_SHARED(sharedModel());
    segmenter_ = makeSegmenter(xnnpackOptions(sharedModel().string()));
    ASSERT_NE(segmenter_, nullptr);
    EXPECT_EQ(segmenter_->name(), "deeplab");
  }
  std::unique_ptr<Segmenter> segmenter_;
};

TEST_F(XnnpackOnFrames, RejectsNonColourImage) {
  EXPECT_THROW(segmenter_->segment(cv::Mat(), "empty.png"), InputError);
  EXPECT_THROW(segmenter_->segment(cv::Mat(48, 64, CV_32F, cv::Scalar(0)), "depth.png"), InputError);
}

TEST_F(XnnpackOnFrames, KeepsOddImageSizesAndMaskIsThePersonLabel) {
  const cv::Mat bgr(123, 77, CV_8UC3, cv::Scalar(40, 90, 200));
  const Segmentation s = segmenter_->segment(bgr, "odd.png");
  EXPECT_EQ(s.labels.size(), bgr.size());
  EXPECT_EQ(s.dynamic_mask.size(), bgr.size());
  EXPECT_GT(s.seconds, 0.0);
  cv::Mat person;
  cv::compare(s.labels, kVocPerson, person, cv::CMP_EQ);
  EXPECT_EQ(cv::countNonZero(person != s.dynamic_mask), 0);
}

TEST_F(XnnpackOnFrames, TwoThreadsGiveTheSameLabels) {
  const fs::path rgb = test::clipDir("bonn_crowd_0300_0399") / "rgb" / "1548339831.27119.png";
  DESSLAM_REQUIRE_SHARED(rgb);
  const cv::Mat bgr = cv::imread(rgb.string(), cv::IMREAD_COLOR);
  SemanticOptions options = xnnpackOptions(sharedModel().string());
  options.threads = 2;
  auto two = makeSegmenter(options);
  const Segmentation a = segmenter_->segment(bgr, rgb.filename().string());
  const Segmentation b = two->segment(bgr, rgb.filename().string());
  EXPECT_LE(cv::countNonZero(a.labels != b.labels), int(bgr.total() / 1000));
  EXPECT_GT(double(cv::countNonZero(a.dynamic_mask)) / double(bgr.total()), 0.05);  // ~38 % person
}

}  // namespace
}  // namespace desslam::semantic
